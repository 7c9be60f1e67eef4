"""Accuracy against speed of the POA integrator (issue 6): annual error against the brute-force
reference for sky patch counts and rays per patch, run time on the benchmark scene.

Error: the two validation scenes of :func:`widesky.irradiance.reference.validation_scenes` (an unobstructed
tilted plane, an obstructed facade), hourly clear-sky year at Prague (as ``bench_poa.py``), the
embedded default PSM dataset, broadband.
Reference: :func:`widesky.irradiance.reference.reference_poa` with its default (converged) settings and exact
sky states (``elevation_quantum=0``); the integrator runs as users run it (``PragueSky()``, elevation
quantum 0.2 deg). Error of a point: annual poa_global / reference - 1; reported: the largest
absolute error over the scene's points and the area-weighted total.

Time: CPU time of ``poa_irradiance`` end to end in one process (``n_jobs=1``, so the ray casting, the
sky and the products all run in it; CPU time is far less sensitive than wall time to the other jobs
on a shared machine) on the ``bench_poa.py`` scene with ``--timing-faces`` faces (hourly year, three
responses), one run per setting.

Run: python benchmarks/bench_poa_accuracy.py [--cache DIR] [--timing-faces 2000]
     [--figure docs/figures/poa_accuracy_speed.png] [--days N] [--hourly]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

GRID = [
    dict(mf=1, rays_per_patch=1), dict(mf=1, rays_per_patch=2), dict(mf=1, rays_per_patch=3),
    dict(mf=1, rays_per_patch=4), dict(mf=2, rays_per_patch=1), dict(mf=2, rays_per_patch=2),
    dict(mf=2, rays_per_patch=3), dict(mf=2, rays_per_patch=4), dict(mf=4, rays_per_patch=1),
    dict(mf=4, rays_per_patch=2),
    # one factor at a time around the default
    dict(mf=1, rays_per_patch=2, radiance_samples=1), dict(mf=1, rays_per_patch=2, radiance_samples=4),
    dict(mf=1, rays_per_patch=2, sun_bin=0.0), dict(mf=1, rays_per_patch=2, sun_bin=2.0),
]


def label(kw):
    return ", ".join(f"{k}={v}" for k, v in kw.items())


def study_states(days=None):
    from bench_poa import year_states
    times, states = year_states()
    if days:
        keep = np.isin(times.dayofyear, np.linspace(1, 365, days).round().astype(int))
        times, states = times[keep], states.take(np.nonzero(keep)[0])
    return times, states


def dataset_digest(model):
    """sha1 of the dataset file (identifies the sky the numbers belong to)."""
    h = hashlib.sha1()
    with open(model.path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()[:12]


def reference(name, scene, states, cache, jobs, sky):
    from widesky.irradiance.reference import reference_poa
    from widesky.irradiance.skies import PragueSky
    key = hashlib.sha1(np.concatenate([states.sun_elevation, states.sun_azimuth, scene.points.ravel(),
                                       states.albedo]).tobytes()
                       + dataset_digest(sky.model).encode()).hexdigest()[:12]
    path = os.path.join(cache, f"poa_reference_{name}_{key}.npz")
    if os.path.exists(path):
        with np.load(path) as f:
            return {k: f[k] for k in f.files}, path
    t = time.perf_counter()
    r = reference_poa(scene, PragueSky(sky.model, elevation_quantum=0), states, n_jobs=jobs)
    out = {q: getattr(r, q) for q in ("poa_global", "poa_direct", "poa_sky_diffuse",
                                      "poa_ground_diffuse", "disc_correction")}
    out["seconds"] = np.array(time.perf_counter() - t)
    out["n_rays"] = np.array(r.n_rays)
    os.makedirs(cache, exist_ok=True)
    np.savez_compressed(path, **out)
    return out, path


def hourly(scenes, states, args):
    """Per-step errors of the default settings against the reference, steps where the reference's
    poa_global exceeds 50 W m-2: relative error of poa_global, and errors of the sky-diffuse and
    reflected components as fractions of that step's poa_global (percentiles over steps and points)."""
    from widesky.irradiance.poa import RunOptions, poa_irradiance
    from widesky.irradiance.skies import PragueSky

    sky = PragueSky()
    for name, scene in scenes.items():
        ref, _ = reference(name, scene, states, args.cache, args.jobs, sky)
        res = poa_irradiance(scene, sky, states, run=RunOptions(n_jobs=args.jobs))
        g = ref["poa_global"]
        ok = g > 50.0
        rel = (res.poa_global - g)[ok] / g[ok]
        print(f"{name}: {ok.sum()} point-steps above 50 W m-2")
        for q, r in (("poa_global (relative)", rel),
                     ("poa_sky_diffuse (of global)", (res.poa_sky_diffuse - ref["poa_sky_diffuse"])[ok] / g[ok]),
                     ("poa_ground_diffuse (of global)",
                      (res.poa_ground_diffuse - ref["poa_ground_diffuse"])[ok] / g[ok])):
            a = np.abs(r)
            print(f"  {q:32s} median {100 * np.median(a):.2f} %  p95 {100 * np.percentile(a, 95):.2f} %  "
                  f"p99 {100 * np.percentile(a, 99):.2f} %  max {100 * a.max():.2f} %  mean {100 * r.mean():+.2f} %")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", default=os.path.join(os.path.expanduser("~"), ".cache", "widesky"))
    ap.add_argument("--timing-faces", type=int, default=2000)
    ap.add_argument("--jobs", type=int, default=2, help="processes for the reference")
    ap.add_argument("--days", type=int, default=None, help="evenly spread days instead of the year")
    ap.add_argument("--figure", default=None, help="write the chart (PNG)")
    ap.add_argument("--no-timing", action="store_true")
    ap.add_argument("--replot", default=None, help="draw the chart from a saved rows file only")
    ap.add_argument("--hourly", action="store_true",
                    help="per-step (hourly) errors of the default settings against the reference, then stop")
    args = ap.parse_args(argv)
    if args.replot:
        import json
        with open(args.replot) as f:
            saved = json.load(f)
        args.synthetic, args.timing_faces = saved["synthetic"], saved["timing_faces"]
        plot([(kw, {k: tuple(v) for k, v in errs.items()}, secs, load)
              for kw, errs, secs, load in saved["rows"]], args)
        return 0
    from widesky.irradiance.integrator import IntegratorSettings
    from widesky.irradiance.poa import RunOptions, poa_irradiance
    from widesky.irradiance.reference import validation_scenes
    from widesky.irradiance.skies import PragueSky

    times, states = study_states(args.days)
    scenes = validation_scenes()
    if args.hourly:
        hourly(scenes, states, args)
        return 0
    sky = PragueSky()
    print(f"load average at start: {os.getloadavg()[0]:.1f}; {len(states)} steps; dataset "
          f"{sky.model.path} sha1 {dataset_digest(sky.model)}, synthetic: {sky.model.is_synthetic}")
    refs = {}
    for name, scene in scenes.items():
        refs[name], path = reference(name, scene, states, args.cache, args.jobs, sky)
        r = refs[name]
        tot = r["poa_global"].sum()
        print(f"reference {name}: {float(r['seconds']):.0f} s, {int(r['n_rays']) / 1e6:.0f} M rays "
              f"({path}); annual mean poa_global {r['poa_global'].sum(0).mean() / 1e3:.0f} kWh m-2 "
              f"; shares direct {r['poa_direct'].sum() / tot:.3f}, sky "
              f"{r['poa_sky_diffuse'].sum() / tot:.3f}, reflected {r['poa_ground_diffuse'].sum() / tot:.3f};"
              f" disc edge correction {r['disc_correction'].sum() / tot:+.1e}")
    if not args.no_timing:
        from bench_poa import benchmark_scene, responses, year_states
        from widesky.irradiance.scene import make_scene
        an, groups, ctx = benchmark_scene(args.timing_faces)
        tscene = make_scene(an, ctx, groups=groups, ground_z=0.0)
        ttimes, tstates = year_states()
        resp = responses(sky.wavelengths)
    rows = []
    for kw in GRID:
        st = IntegratorSettings(**kw)
        errs = {}
        for name, scene in scenes.items():
            a = poa_irradiance(scene, sky, states, settings=st, run=RunOptions(n_jobs=1))
            ref = refs[name]
            e = a.poa_global.sum(0, dtype=np.float64) / ref["poa_global"].sum(0) - 1
            area = scene.face_area
            tot = (a.poa_global.sum(0, dtype=np.float64) @ area) / (ref["poa_global"].sum(0) @ area) - 1
            errs[name] = (np.abs(e).max(), tot)
        secs = np.nan
        if not args.no_timing:
            t = time.process_time()
            poa_irradiance(tscene, sky, tstates, responses=resp, settings=st, run=RunOptions(n_jobs=1))
            secs = time.process_time() - t
        rows.append((kw, errs, secs, os.getloadavg()[0]))
        print(f"{label(kw):45s} " + "  ".join(
            f"{n}: max {100 * m:.2f} % total {100 * t:+.2f} %" for n, (m, t) in errs.items())
            + f"  CPU {secs:.1f} s (load {rows[-1][3]:.1f})", flush=True)

    print("\n| settings | tilted plane max / total | facade max / total | CPU time [s] |")
    print("|---|---|---|---|")
    for kw, errs, secs, _ in rows:
        tp, fa = errs["tilted_plane"], errs["obstructed_facade"]
        print(f"| {label(kw)} | {100 * tp[0]:.2f} % / {100 * tp[1]:+.2f} % | "
              f"{100 * fa[0]:.2f} % / {100 * fa[1]:+.2f} % | {secs:.1f} |")
    import json
    os.makedirs(args.cache, exist_ok=True)
    saved = os.path.join(args.cache, "poa_accuracy_rows.json")
    with open(saved, "w") as f:
        json.dump({"rows": [[kw, {k: list(v) for k, v in errs.items()}, secs, load]
                            for kw, errs, secs, load in rows],
                   "synthetic": bool(sky.model.is_synthetic),
                   "timing_faces": args.timing_faces}, f)
    print(f"rows: {saved} (python benchmarks/bench_poa_accuracy.py --replot {saved} --figure ...)")
    if args.figure:
        args.synthetic = bool(sky.model.is_synthetic)
        plot(rows, args)
    return 0


def plot(rows, args):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), sharey=True)
    colours = {1: "tab:blue", 2: "tab:orange", 4: "tab:green"}
    for ax, name, title, target in ((axes[0], "tilted_plane", "unobstructed tilted plane", 0.01),
                                    (axes[1], "obstructed_facade", "obstructed facade", 0.02)):
        for mf in (1, 2, 4):
            pts = [(secs, 100 * errs[name][0], kw["rays_per_patch"]) for kw, errs, secs, _ in rows
                   if kw["mf"] == mf and len(kw) == 2]
            if not pts:
                continue
            pts.sort(key=lambda p: p[2])              # along k
            x, y, k = zip(*pts)
            ax.plot(x, y, "o-", color=colours[mf], label=f"mf={mf} ({144 * mf * mf + 1} patches)")
            for xi, yi, ki in pts:
                ax.annotate(f"{ki}x{ki}", (xi, yi), textcoords="offset points", xytext=(4, 4),
                            fontsize=8)
        short = {"radiance_samples": "rs", "sun_bin": "sun bin"}
        n_extra = 0
        for kw, errs, secs, _ in rows:
            if len(kw) > 2:
                extra = ", ".join(f"{short.get(k, k)} {v:g}" for k, v in kw.items()
                                  if k not in ("mf", "rays_per_patch"))
                ax.plot(secs, 100 * errs[name][0], "x", color="grey")
                ax.annotate(extra, (secs, 100 * errs[name][0]), textcoords="offset points",
                            xytext=(5, -11 - 9 * (n_extra % 2)), fontsize=7, color="grey")
                n_extra += 1
            elif kw == {"mf": 1, "rays_per_patch": 2}:
                ax.plot(secs, 100 * errs[name][0], "*", ms=14, mfc="none", color="black",
                        label="default" if name == "tilted_plane" else None)
        ax.axhline(100 * target, color="red", lw=0.8, ls="--")
        ax.text(0.02, 100 * target, f" target {100 * target:.0f} %", color="red", fontsize=8,
                va="bottom", transform=ax.get_yaxis_transform())
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):      # plain numbers, not 2 x 10^1
            axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            axis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
        ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 3.0, 5.0)))
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.set_title(title)
        ax.set_xlabel(f"CPU time, {args.timing_faces}-face benchmark scene, hourly year, one process [s]")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("largest annual error of a point vs brute force [%]")
    axes[0].legend(fontsize=8, title="labels: rays per patch k x k; grey: mf=1, 2x2 with one change",
                   title_fontsize=7)
    fig.suptitle("POA integrator: accuracy against speed (hourly clear-sky year, Prague, "
                 f"{'synthetic' if args.synthetic else 'default'} PSM dataset)", fontsize=10)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(args.figure)), exist_ok=True)
    fig.savefig(args.figure, dpi=110)
    print(f"chart: {args.figure}")


if __name__ == "__main__":
    sys.exit(main())
