"""Benchmark: a 1000 x 1000 up-facing fisheye of all 55 channels of sky radiance.

Dataset: realistic-sized synthetic file (6 visibilities x 3 albedos x 30 solar elevations x 55 channels,
rank 8, 60/60/40 knots: 61 MB), written once to a cache directory.

Measured in the same run:
  baseline  a straight port of the reference loop in C (skymodel._core.reference_loop): for every
            direction the parameters, then one channel per call with every lookup and the nested
            16-configuration interpolation done anew; one thread, on a subset of the directions;
  direct    widesky's direct path (angle lookups once per direction, all channels together);
  table     widesky's per-sky-state piecewise-polynomial table (the default for images);
for 1 and 2 threads, float32 output into a preallocated array (file writing excluded). Median of
``--repeat`` runs. Ratios are per core (throughput with one thread against the baseline's). The same for
the sun 2.5 deg below the horizon (``twilight``: the baseline and the table path, which then builds
only the 3-D cells the directions visit). CPU times (``time.process_time``) are reported beside the
wall-clock times: on a shared machine they are the steadier ratio.

    python benchmarks/bench_sky.py [--repeat 7] [--resolution 1000] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from widesky import skymodel
from widesky.skymodel import _core
from widesky.skymodel.render import fisheye_directions
from widesky.skymodel.synthetic import write_synthetic_dataset

STATE = dict(sun_elevation=33.3, sun_azimuth=150.0, visibility=47.0, albedo=0.37)  # between grid points
TWILIGHT = dict(STATE, sun_elevation=-2.5)  # sun below the horizon: the shadow angle, the twilight table


def dataset(cache: Path) -> Path:
    path = cache / "bench_6x3x30x55_r8.dat"
    if not path.exists():
        elev = np.concatenate([[-4.2, -2.0, 0.0], np.geomspace(1.0, 90.0, 27)])
        write_synthetic_dataset(path, visibilities=np.linspace(20, 131.8, 6), albedos=(0.0, 0.5, 1.0),
                                elevations=elev, n_channels=55, rank=8, n_sun=60, n_zen=60, n_emph=40, seed=3)
    return path


def median_time(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), times


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--resolution", type=int, default=1000)
    ap.add_argument("--baseline-stride", type=int, default=40, help="evaluate every Nth direction in the baseline")
    ap.add_argument("--json", default=None)
    ap.add_argument("--cache", default=os.environ.get("WIDESKY_BENCH_CACHE", tempfile.gettempdir()))
    args = ap.parse_args(argv)

    path = dataset(Path(args.cache))
    m = skymodel.load_dataset(path)
    t0 = time.perf_counter()
    m.load()
    decode = time.perf_counter() - t0
    d, mask = fisheye_directions(args.resolution)
    dirs = np.ascontiguousarray(d[mask])
    n, C = dirs.shape[0], m.n_channels
    out = np.empty((n, C), np.float32)
    res = {"dataset_MB": path.stat().st_size / 1e6, "decode_s": decode, "resolution": args.resolution,
           "directions": n, "channels": C, "machine": platform.processor() or platform.machine(),
           "cpu_count": os.cpu_count()}

    # baseline: straight port of the reference loop, one direction and one channel per call
    sub = np.ascontiguousarray(dirs[:: args.baseline_stride])
    sun, zen, emph = m.radiance_coefficients()
    base_out = np.empty((sub.shape[0], C))
    el, az = np.radians(STATE["sun_elevation"]), np.radians(90.0 - STATE["sun_azimuth"])

    def baseline():
        _core.reference_loop(sun, zen, emph, m.sun_breaks, m.zenith_breaks, m.emph_breaks, m.rank, C,
                             m.visibilities, m.albedos, m.altitudes, m.elevations, sub,
                             (0.0, el, az, STATE["visibility"], STATE["albedo"]), np.arange(C), base_out)

    tb, _ = median_time(baseline, max(3, args.repeat // 2))
    base_rate = sub.shape[0] * C / tb
    res["baseline_ns_per_value"] = 1e9 / base_rate
    res["baseline_full_image_s_estimate"] = n * C / base_rate

    check = skymodel.sky_radiance(m, sub, **STATE)
    res["baseline_max_rel_diff"] = float(np.max(np.abs(check - base_out) / np.maximum(np.abs(check), 1e-30)))

    for method in ("direct", "table"):
        for threads in (1, 2):
            if method == "direct":  # a subset: the direct path costs about as much per value as the baseline/8
                target, o = sub, np.empty((sub.shape[0], C), np.float32)
            else:
                target, o = dirs, out
            def fn(target=target, method=method, threads=threads, o=o):
                skymodel.sky_radiance(m, target, **STATE, method=method, threads=threads, dtype=np.float32, out=o)
            fn()  # warm-up (first-touch of the output, workspace)
            t, times = median_time(fn, args.repeat)
            rate = target.shape[0] * C / t
            key = f"{method}_{threads}t"
            res[key + "_ns_per_value"] = 1e9 / rate
            res[key + "_speedup_vs_baseline"] = rate / base_rate / threads
            if method == "table":
                res[key + "_image_s"] = t
                res[key + "_image_s_all_runs"] = times
    # twilight: the baseline and the twilight table path, wall and CPU time
    from widesky.skymodel.evaluate import KERNEL_INFO

    elt, azt = np.radians(TWILIGHT["sun_elevation"]), np.radians(90.0 - TWILIGHT["sun_azimuth"])

    def baseline_tw():
        _core.reference_loop(sun, zen, emph, m.sun_breaks, m.zenith_breaks, m.emph_breaks, m.rank, C,
                             m.visibilities, m.albedos, m.altitudes, m.elevations, sub,
                             (0.0, elt, azt, TWILIGHT["visibility"], TWILIGHT["albedo"]), np.arange(C), base_out)

    c0 = time.process_time()
    tbt, _ = median_time(baseline_tw, max(3, args.repeat // 2))
    cpu_b = (time.process_time() - c0) / max(3, args.repeat // 2)
    res["twilight_baseline_ns_per_value"] = 1e9 * tbt / (sub.shape[0] * C)
    res["twilight_baseline_max_rel_diff"] = float(np.max(np.abs(skymodel.sky_radiance(m, sub, **TWILIGHT) - base_out))
                                                  / np.abs(base_out).max())
    for threads in (1, 2):
        fn = lambda threads=threads: skymodel.sky_radiance(m, dirs, **TWILIGHT, method="table", threads=threads,  # noqa: E731
                                                           dtype=np.float32, out=out)
        fn()
        c0 = time.process_time()
        t, times = median_time(fn, args.repeat)
        cpu = (time.process_time() - c0) / args.repeat
        key = f"twilight_table_{threads}t"
        res[key + "_image_s"] = t
        res[key + "_speedup_vs_baseline"] = (n * C / t) / (sub.shape[0] * C / tbt) / threads
        res[key + "_cpu_speedup_vs_baseline"] = (cpu_b / sub.shape[0]) / (cpu / n)
    res["twilight_cells_built"] = KERNEL_INFO.get("cells_built")
    res["twilight_mixed_terms"] = KERNEL_INFO.get("mixed_terms")
    # the table precompute alone (per sky state)
    tp, _ = median_time(lambda: skymodel.sky_radiance(m, dirs[:8], **STATE, method="table", threads=2), args.repeat)
    res["table_precompute_2t_s"] = tp
    # fresh float64 output (allocation and page faults included), as a plain call returns
    tf, _ = median_time(lambda: skymodel.sky_radiance(m, dirs, **STATE, threads=2), max(3, args.repeat // 2))
    res["table_2t_image_float64_fresh_s"] = tf

    print(f"dataset {res['dataset_MB']:.1f} MB, decoded in {decode:.2f} s; image {args.resolution}^2 "
          f"({n} directions in the disc) x {C} channels")
    print(f"baseline (reference loop, 1 thread):   {res['baseline_ns_per_value']:8.1f} ns/value  "
          f"(full image would take {res['baseline_full_image_s_estimate']:.1f} s)")
    for method in ("direct", "table"):
        for threads in (1, 2):
            k = f"{method}_{threads}t"
            extra = f"  image {res[k + '_image_s']:.3f} s" if method == "table" else ""
            print(f"{method:6s} {threads} thread(s): {res[k + '_ns_per_value']:8.2f} ns/value  "
                  f"{res[k + '_speedup_vs_baseline']:7.1f}x baseline per core{extra}")
    print(f"table precompute per sky state (2 threads): {tp * 1e3:.1f} ms; float64 with fresh output: {tf:.3f} s")
    print(f"agreement with the baseline: max relative difference {res['baseline_max_rel_diff']:.1e}")
    print(f"twilight (sun {TWILIGHT['sun_elevation']} deg): baseline {res['twilight_baseline_ns_per_value']:.1f} ns/value; "
          f"table 1 thread {res['twilight_table_1t_image_s']:.3f} s = {res['twilight_table_1t_speedup_vs_baseline']:.1f}x "
          f"baseline per core (CPU time {res['twilight_table_1t_cpu_speedup_vs_baseline']:.1f}x), 2 threads "
          f"{res['twilight_table_2t_image_s']:.3f} s = {res['twilight_table_2t_speedup_vs_baseline']:.1f}x per core "
          f"(CPU {res['twilight_table_2t_cpu_speedup_vs_baseline']:.1f}x); {res['twilight_cells_built']} cells built; "
          f"max relative difference to the baseline {res['twilight_baseline_max_rel_diff']:.1e}")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))
    return res


if __name__ == "__main__":
    main()
