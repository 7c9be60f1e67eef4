"""Benchmark: every library technology in one run vs the POA run with three responses (issue 12).

Scene, sky and year as benchmarks/bench_poa.py (rows of PV modules, an analysed building, context;
the Prague Sky Model; an hourly clear-sky year at Prague). Both runs in this process, one after the
other, with the same settings:

1. baseline: ``poa_irradiance`` with three responses (broadband, a c-Si-like SR and a glazing-like
   transmittance: bench_poa.responses, channel weights without optics);
2. pvsim: ``widesky.pvsim.simulate`` with all library technologies -- one integrator run with every distinct
   sub-cell EQE as a response with the Fresnel cover optic applied per incoming direction, plus the
   cover's unit weight -- with the yield model (cell temperature, DC, AC, waterfall) of every
   technology on every module group fused into the integrator's stream (``widesky.pvsim.stream``): the
   sub-cell currents exist chunk by chunk, the POA file holds the broadband parts and the cover's global
   (``--keep-currents`` writes the currents too; ``--unfused`` runs the earlier path: the POA file
   with the currents, then ``pv_yield`` reads it back).

Both results stream to HDF5 files in a temporary folder (``output=``).
Printed: wall seconds of each, the ratio (target <= 1.25, issue 12), the phases, and throughput.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_pvsim.py [--faces 20000] [--jobs 2]
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import bench_poa  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faces", type=int, default=20000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--dataset", default=None, help="PSM dataset file (default: the embedded one)")
    ap.add_argument("--order", choices=("baseline-first", "pvsim-first"), default="baseline-first",
                    help="which run goes first (the second profits from warm caches)")
    ap.add_argument("--all-parts", action="store_true",
                    help="with --unfused: keep the three parts of every technology response")
    ap.add_argument("--unfused", action="store_true",
                    help="the unfused path: the POA file with every sub-cell current, then pv_yield reads it")
    ap.add_argument("--keep-currents", action="store_true",
                    help="fused: also write every sub-cell current (global) to the POA file")
    args = ap.parse_args(argv)
    from widesky import pvsim
    from widesky.irradiance import IntegratorSettings, OutputOptions, RunOptions, make_scene, poa_irradiance

    analysis, groups, context = bench_poa.benchmark_scene(args.faces)
    scene = make_scene(analysis, context, groups=groups, ground_z=0.0)
    times, states = bench_poa.year_states()
    sky, which = bench_poa.sky_source(args.dataset)
    settings = IntegratorSettings()
    techs = list(pvsim.TECHNOLOGIES)
    resp, sources = pvsim.technology_responses(techs)
    print(f"scene: {scene.n_faces} analysis faces; {len(states)} hourly steps; sky: PSM {which}; "
          f"{len(techs)} technologies -> {len(resp)} responses + broadband")
    print(f"load average before: {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores")
    tmp = tempfile.mkdtemp(prefix="bench_pvsim.")

    def cpu():
        """CPU seconds of this process and its finished children (the ray-casting workers)."""
        a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime

    cpu_s = {}

    def baseline():
        c0 = cpu()
        t0 = time.perf_counter()
        r = poa_irradiance(scene, sky, states, responses=bench_poa.responses(sky.wavelengths),
                           settings=settings, times=times, run=RunOptions(n_jobs=args.jobs),
                           output=OutputOptions(path=os.path.join(tmp, "base.h5")))
        cpu_s["baseline"] = cpu() - c0
        return time.perf_counter() - t0, r

    def technologies():
        c0 = cpu()
        t0 = time.perf_counter()
        out = os.path.join(tmp, "pv.h5")
        if args.unfused:                           # the POA file with the currents, then pv_yield reads it
            r = poa_irradiance(scene, sky, states, responses=resp, settings=settings, times=times,
                               run=RunOptions(n_jobs=args.jobs),
                               output=OutputOptions(path=out, parts=None if args.all_parts
                                                    else pvsim.technology_parts(resp)))
            t_poa = time.perf_counter() - t0
            y = pvsim.pv_yield(r, techs, 20.0, 1.0, sources=sources)
        else:                                      # the yield model fused into the stream
            r, y = pvsim.simulate(scene, sky, states, techs, 20.0, 1.0, settings=settings, times=times,
                                  output=out, keep_currents=args.keep_currents,
                                  run=RunOptions(n_jobs=args.jobs))
            t_poa = time.perf_counter() - t0
        cpu_s["pvsim"] = cpu() - c0
        return time.perf_counter() - t0, t_poa, r, y

    if args.order == "baseline-first":
        t_base, rb = baseline()
        t_pv, t_pv_poa, rp, y = technologies()
    else:
        t_pv, t_pv_poa, rp, y = technologies()
        t_base, rb = baseline()
    label = "unfused: POA + pv_yield" if args.unfused else (
        "fused (yield model in the stream" + (", currents written)" if args.keep_currents else ")"))
    for name, t, r in (("baseline (3 responses)", t_base, rb), (f"all technologies, {label}", t_pv_poa, rp)):
        tm = r.timings
        print(f"{name}: {t:.1f} s; " + ", ".join(f"{k} {v:.1f} s" for k, v in tm.items()
                                               if isinstance(v, float) and k != "total"))
    if args.unfused:
        print(f"pvsim yield model (reads the file back): {t_pv - t_pv_poa:.1f} s for {len(techs)} technologies x "
              f"{len(y.groups)} groups ({scene.n_faces * len(states) * len(techs) / max(t_pv - t_pv_poa, 1e-9) / 1e6:.1f}"
              " M face-steps/s)")
    else:
        c = rp.timings.get("consumer", 0.0)
        print(f"pvsim yield model in the stream (consumer): {c:.1f} s for {len(techs)} technologies x "
              f"{len(y.groups)} groups ({scene.n_faces * rp.timings['lit_steps'] * len(techs) / max(c, 1e-9) / 1e6:.0f}"
              " M face-steps/s over the daylight steps)")
    print(f"ratio all technologies (POA + yield) / POA with three responses = {t_pv / t_base:.2f} (target <= 1.25)")
    print(f"CPU seconds (this process + ray-casting workers; steadier than wall time on a shared machine): "
          f"baseline {cpu_s['baseline']:.1f}, all technologies {cpu_s['pvsim']:.1f}, "
          f"ratio {cpu_s['pvsim'] / cpu_s['baseline']:.2f}")
    g = y.groups[0]
    print("specific yield of group " + g + " [kWh/kWp]: " +
          ", ".join(f"{n} {ty.specific_yield(g):.0f}" for n, ty in y.technologies.items()))
    print(f"load average after: {os.getloadavg()[0]:.1f}")
    for f in ("base.h5", "pv.h5"):
        try:
            os.remove(os.path.join(tmp, f))
        except OSError:
            pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
