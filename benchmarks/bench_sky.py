"""Benchmark: the sky evaluator against the project's C port of the reference loop, per core.

Dataset: realistic-sized synthetic file (6 visibilities x 3 albedos x 30 solar elevations x 55 channels,
rank 8, 60/60/40 knots: 61 MB), written once to a cache directory.

Baseline: ``_core.reference_loop``, the project's C port of the public reference C++ evaluation loop
(Wilkie et al. 2021): for every direction the parameters, then one channel per call with every lookup and
the nested 16-configuration interpolation done anew; one thread, on every ``--baseline-stride``-th
direction of the image (its cost per value does not depend on how many directions it is given).

Candidates, each timed in the same run, interleaved with the baseline (baseline, candidate, baseline, ...),
in CPU time (``time.process_time``) and wall time, median of ``--repeat`` pairs:

  daylight   a 1000 x 1000 up-facing fisheye (785,456 directions) x 55 channels, sun at 33.3 deg,
             visibility 47 km, albedo 0.37 (between grid points: every interpolation level exercised),
             float32 into a preallocated array; ``sky_radiance`` end to end (argument checks, the
             per-sky-state table and its evaluation), 1 thread (per core) and 2 threads (the image time);
  twilight   the same with the sun 2.5 deg below the horizon (the twilight table);
  small      calls below ``auto``'s old 20,000-value threshold: 300 directions x 55 channels, scattered
             over the upper hemisphere and clustered within about 8 deg, by the direct path
             (``method="direct"``) and by ``auto`` (which builds a table of only the cells in the range of
             the call's angles where that is cheaper);
  one        a single direction x 55 channels by the direct path, 200 calls per timing (the Python
             wrapper's per-call cost, about 15 us, included: what a caller of one direction pays).

The direct path's kernel (AVX-512 where the processor has it, else AVX2; ``_core.direct_impl``) is named in
the output and the JSON; ``--direct-kernel avx2`` times the AVX2 kernel on an AVX-512 machine.

Per-core ratio = baseline time per value / candidate time per value, both on one thread; the CPU-time
ratio is the fair one on a shared machine (a long baseline run gets less of a core than a short one).
OpenMP's idle workers are told to sleep (OMP_WAIT_POLICY=PASSIVE unless set) so that the 2-thread runs
leave no spinning thread charged to the 1-thread measurements.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_sky.py [--repeat 7] [--resolution 1000] [--json out.json]
                                                          [--small-only]  (only the small and one-direction calls)
                                                          [--auto-sweep]  (auto's choice against both paths)
                                                          [--fit-auto [--fit-calls 480] [--fit-seed 7]]
                                                          [--direct-kernel auto|avx2|avx512] [--passes 3]

``--auto-sweep`` times both paths on 48 calls below 20,000 values (4, 16 and 55 channels, 8 to 5,000
directions in clusters 0.5 to 30 deg wide, sun at 5 and 33.3 deg, one thread; the least of ``--passes``
passes' medians) and reports how much slower auto's pick is than the faster path: the check of the cost
model ``table_pays`` in _core.c (with the direct kernel in use, or the one ``--direct-kernel`` names).

``--fit-auto`` fits that model: it times the table path and the direct path with each kernel on
``--fit-calls`` random calls (seed ``--fit-seed``; 1 to 55 channels, 8 to 5,000 directions and 256 to
20,000 values, clusters 0.5 to 30 deg wide anywhere above the horizon, sun 5 to 70 deg, random visibility
and albedo; the embedded dataset, this benchmark's dataset and the tests' small one), fits each path's cost
terms (non-negative least squares of the relative error) and prints the constants for ``table_pays``, with
the picks' cost on these calls by the fitted model and by the built one (another seed: an independent check).
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before libgomp starts (the import below)

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from widesky import skymodel  # noqa: E402
from widesky.skymodel import _core  # noqa: E402
from widesky.skymodel.evaluate import (KERNEL_INFO, PLANET_RADIUS, SAFETY_ALTITUDE, _config_weights,  # noqa: E402
                                       _state_params, reference_angles)
from widesky.skymodel.render import fisheye_directions  # noqa: E402
from widesky.skymodel.synthetic import write_synthetic_dataset  # noqa: E402

STATE = dict(sun_elevation=33.3, sun_azimuth=150.0, visibility=47.0, albedo=0.37)  # between grid points
TWILIGHT = dict(STATE, sun_elevation=-2.5)  # sun below the horizon: the shadow angle, the twilight table
BASELINE_NAME = "reference loop, C port (_core.reference_loop), 1 thread"


def dataset(cache: Path) -> Path:
    path = cache / "bench_6x3x30x55_r8.dat"
    if not path.exists():
        elev = np.concatenate([[-4.2, -2.0, 0.0], np.geomspace(1.0, 90.0, 27)])
        write_synthetic_dataset(path, visibilities=np.linspace(20, 131.8, 6), albedos=(0.0, 0.5, 1.0),
                                elevations=elev, n_channels=55, rank=8, n_sun=60, n_zen=60, n_emph=40, seed=3)
    return path


def small_dataset(cache: Path) -> Path:
    """The tests' small dataset (tests/test_sky_table_ranges.py): 4 channels, rank 3, 9/11/7 knots."""
    path = cache / "bench_small_3x2x3_r3.dat"
    if not path.exists():
        write_synthetic_dataset(path, visibilities=(20, 45.5, 131.8), albedos=(0, 1), altitudes=(0, 1000, 6000),
                                n_channels=4, channel_start=300, rank=3, n_sun=9, n_zen=11, n_emph=7,
                                polarisation=True, pol_rank=2, n_pol_sun=6, n_pol_zen=5, roughness=0.4, seed=11)
    return path


def timed(fn):
    """(CPU seconds, wall seconds) of one call."""
    c0, w0 = time.process_time(), time.perf_counter()
    fn()
    return time.process_time() - c0, time.perf_counter() - w0


def interleaved(base, base_values, cand, cand_values, repeat):
    """Baseline and candidate alternately, ``repeat`` pairs (after one warm-up call of each); medians of
    the CPU and wall seconds per value, and the per-core ratios (baseline / candidate)."""
    base(), cand()
    b, c = [], []
    for _ in range(repeat):
        b.append(timed(base))
        c.append(timed(cand))
    b, c = np.array(b), np.array(c)
    bc, bw = np.median(b[:, 0]) / base_values, np.median(b[:, 1]) / base_values
    cc, cw = np.median(c[:, 0]) / cand_values, np.median(c[:, 1]) / cand_values
    return dict(baseline_cpu_ns=1e9 * bc, baseline_wall_ns=1e9 * bw, cpu_ns=1e9 * cc, wall_ns=1e9 * cw,
                ratio_cpu=bc / cc, ratio_wall=bw / cw, call_cpu_s=float(np.median(c[:, 0])),
                call_wall_s=float(np.median(c[:, 1])), call_wall_s_all=c[:, 1].tolist())


def auto_sweep(m, repeat, passes=3):
    """auto against the faster of the direct and table paths, CPU time: the least over ``passes`` passes
    over the 48 calls of the median of ``repeat`` calls of each path (a busy period of the shared machine
    slows one pass's call, not all of them)."""
    rng = np.random.default_rng(2)

    def cpu(fn):
        fn()
        t = []
        for _ in range(repeat):
            t.append(timed(fn)[0])
        return float(np.median(t))
    load0, calls = load_average(), []
    for el in (33.3, 5.0):
        state = dict(STATE, sun_elevation=el)
        for nc in (55, 16, 4):
            for n in sorted({max(1000 // nc, 8), 19999 // nc}):
                for spread in (0.5, 2.0, 8.0, 30.0):
                    z, a = np.radians(40.0), np.radians(200.0)
                    v = np.array([np.sin(z) * np.sin(a), np.sin(z) * np.cos(a), np.cos(z)])
                    v = v + np.radians(spread) * rng.normal(size=(n, 3))
                    D = np.ascontiguousarray(v / np.linalg.norm(v, axis=1)[:, None])
                    calls.append((el, state, nc, n, spread, D, {}))
    for _ in range(passes):
        for el, state, nc, n, spread, D, t in calls:
            for meth in ("direct", "table"):
                t[meth] = min(t.get(meth, np.inf), cpu(lambda meth=meth, D=D, state=state, nc=nc: skymodel.sky_radiance(
                    m, D, **state, channels=np.arange(nc), method=meth, threads=1)))
    rows = []
    for el, state, nc, n, spread, D, t in calls:
        skymodel.sky_radiance(m, D, **state, channels=np.arange(nc), threads=1)
        pick = "table" if KERNEL_INFO.get("path") == 2 else "direct"
        slow = t[pick] / min(t["direct"], t["table"])
        rows.append(slow)
        print(f"sun {el:4.1f} deg  {nc:2d} channels  {n:5d} directions  {spread:4.1f} deg: direct "
              f"{t['direct'] * 1e6:6.0f} us, table {t['table'] * 1e6:6.0f} us, auto picks {pick:6s} "
              f"({slow:.2f}x the faster)", flush=True)
    rows = np.array(rows)
    print(f"auto's pick / the faster path: mean {rows.mean():.3f}, worst {rows.max():.2f}, "
          f"{int((rows > 1.05).sum())} of {rows.size} more than 5 % slower (least of {passes} passes' medians of "
          f"{repeat}); load average {load0:.1f} -> {load_average():.1f}")
    return {"auto_slowdown": rows.tolist()}


def _interval_of(q, b):
    """_core.c's interval_of: the knot interval [0, n-2] containing q (clamped to the knots)."""
    q = min(max(q, b[0]), b[-1])
    return int(min(max(np.searchsorted(b, q, side="right") - 1, 0), len(b) - 2))


def _buckets(*knots):
    """accel_init's bucket count (table_eval's cell lookup) on the merged, distinct knots."""
    b = np.unique(np.concatenate(knots))
    span = b[-1] - b[0]
    d = np.diff(b)
    dmin = min(span, d[d > 0].min()) if (d > 0).any() else span
    want = 8.0 * span / dmin if dmin > 0 else 0.0
    return 65536 if want > 65536 else (int(want) if want > 8 * b.size else 8 * b.size)


def cost_features(m, D, state, nc):
    """The quantities ``table_pays`` computes for a radiance call (one thread, the sun up): sun rows and
    padded merged zenith/emphasis columns in the range of the call's angles, configurations, rank."""
    a = reference_angles(D, state["sun_elevation"], state["sun_azimuth"])
    d = PLANET_RADIUS + SAFETY_ALTITUDE
    wz = 1e-6 + np.arcsin(np.sqrt(d * d - PLANET_RADIUS ** 2) / d)  # angle_range's widening of the zenith range
    g0, g1 = a["gamma"].min() - 1e-6, a["gamma"].max() + 1e-6
    z0, z1 = a["theta"].min() - wz, a["theta"].max() + wz
    sb, zb, eb = m.sun_breaks, m.zenith_breaks, m.emph_breaks
    emph = eb is not None and len(eb) > 0
    rows = _interval_of(g1, sb) - _interval_of(g0, sb) + 3
    zcols = _interval_of(z1, zb) - _interval_of(z0, zb)
    cols = zcols + 3 + ((_interval_of(z1, eb) - _interval_of(z0, eb)) if emph else 0)
    nup = (len(zb) + (len(eb) if emph else 0) + 7) & ~3
    el, _, alt_param, el_view = _state_params(state["sun_elevation"], state["sun_azimuth"], 0.0)
    ncfg = len(_config_weights(m, state["visibility"], state["albedo"], alt_param, el_view)[0])
    return dict(n=D.shape[0], nc=nc, ncfg=ncfg, R=m.rank, rows=rows, zcols=zcols, pad=min(cols + 7, nup),
                buckets=_buckets(sb) + (_buckets(zb, eb) if emph else _buckets(zb)))


def table_terms(f):
    """Terms of the table path's cost [ns]: per (channel, configuration) its zenith and emphasis factors at
    the padded columns (R + 1 polynomial evaluations each) and per sun row their rank sums and corner
    products (rows (R + 8) per column); per value; per direction; per call and per bucket of the cell
    lookups' index (accel_init: up to 65,536 per knot set)."""
    w = f["nc"] * f["ncfg"] * f["pad"]
    return np.array([w * (f["R"] + 1), w * f["rows"] * (f["R"] + 8), f["n"] * f["nc"], f["n"], 1.0, f["buckets"]])


def direct_terms(f, kernel):
    """Terms of the direct path's cost [ns] with its kept copy (a repeated state): per (direction,
    configuration, 3 R + 4) and channel vector (AVX-512: vectors of eight and a last one of four; AVX2:
    vectors of four); per (direction, configuration); per direction; per call."""
    nc4 = 4 * ((f["nc"] + 3) // 4)
    n8, n4 = ((nc4 - (nc4 & 4)) // 8, (nc4 & 4) // 4) if kernel == "avx512" else (0, nc4 // 4)
    w = f["n"] * f["ncfg"] * (3 * f["R"] + 4)
    return np.array([w * n8, w * n4, f["n"] * f["ncfg"], f["n"], 1.0])


def _relative_fit(X, t):
    """Non-negative least squares of the relative error: min sum((X c - t) / t)^2, c >= 0."""
    from scipy.optimize import nnls
    A = X / t[:, None]
    scale = np.abs(A).max(axis=0)
    scale[scale == 0] = 1.0
    c, _ = nnls(A / scale, np.ones_like(t))
    return c / scale


def fit_auto(m, small, embedded, repeat, calls, seed=7, passes=3):
    """``--fit-auto``: time the direct path (each available kernel) and the table path on ``calls`` random
    calls below 20,000 values (sun up, one thread; the benchmark dataset and the tests' small one), fit
    ``table_pays``' constants (relative least squares, non-negative) and print them with the picks' cost
    on these calls (the fitted model's, and the built one's). A third of the calls on the embedded default
    dataset, a sixth on the tests' small one, the rest on the benchmark dataset."""
    rng = np.random.default_rng(seed)
    kernels = ["avx2"]
    try:
        _core.direct_impl(2)
        kernels.append("avx512")
    except ValueError:
        pass
    _core.direct_impl(0)

    def cpu(fn):
        fn()
        t0 = timed(fn)[0]
        reps = max(1, int(3e-4 / max(t0, 1e-6)))  # batches of at least about 0.3 ms
        t = []
        for _ in range(repeat):
            c0 = time.process_time()
            for _ in range(reps):
                fn()
            t.append((time.process_time() - c0) / reps)
        return float(np.median(t))
    load0, recs, design = load_average(), [], []
    for i in range(calls):
        mod = embedded if i % 3 == 1 else (small if i % 6 == 5 else m)
        C = mod.n_channels
        while True:
            nc = int(rng.choice([c for c in (1, 2, 3, 4, 6, 8, 12, 16, 20, 24, 32, 40, 48, 55) if c <= C]))
            n = int(np.exp(rng.uniform(np.log(8), np.log(5000))))
            if 256 <= n * nc < 20000:
                break
        spread = float(np.exp(rng.uniform(np.log(0.5), np.log(30.0))))
        z, a = np.radians(rng.uniform(0.0, 85.0)), np.radians(rng.uniform(0.0, 360.0))
        v = np.array([np.sin(z) * np.sin(a), np.sin(z) * np.cos(a), np.cos(z)])
        v = v + np.radians(spread) * rng.normal(size=(n, 3))
        D = np.ascontiguousarray(v / np.linalg.norm(v, axis=1)[:, None])
        vis = mod.visibilities
        state = dict(sun_elevation=float(rng.uniform(5.0, 70.0)), sun_azimuth=float(rng.uniform(0.0, 360.0)),
                     visibility=float(rng.uniform(vis[0], vis[-1])), albedo=float(rng.uniform(0.05, 0.95)))
        design.append((mod, D, state, nc))
        recs.append(dict(cost_features(mod, D, state, nc), spread=spread, small=mod is small,
                         embedded=mod is embedded, state=state, centre=[float(np.degrees(z)), float(np.degrees(a))]))
    # every call timed in each of `passes` passes over the design, the least of the passes' medians kept: a
    # busy period of the shared machine (a sibling thread's load) slows a whole pass's call, not all of them
    for _ in range(passes):
        for (mod, D, state, nc), r in zip(design, recs):
            def call(meth, D=D, state=state, ch=np.arange(nc), mod=mod):
                skymodel.sky_radiance(mod, D, **state, channels=ch, method=meth, threads=1)
            r["table"] = min(r.get("table", np.inf), cpu(lambda: call("table")))
            for k in kernels:
                _core.direct_impl({"avx2": 1, "avx512": 2}[k])
                r["direct_" + k] = min(r.get("direct_" + k, np.inf), cpu(lambda: call("direct")))
                call("auto")
                r["built_" + k] = "table" if KERNEL_INFO.get("path") == 2 else "direct"
            _core.direct_impl(0)
    load1 = load_average()
    T = np.array([table_terms(r) for r in recs])
    tt = np.array([r["table"] for r in recs]) * 1e9
    ct = _relative_fit(T, tt)
    print(f"{len(recs)} calls ({sum(r['embedded'] for r in recs)} on the embedded dataset, "
          f"{sum(r['small'] for r in recs)} on the small one), CPU time, least of {passes} passes' medians of "
          f"{repeat}; load average {load0:.1f} -> {load1:.1f}")
    print(f"table [ns]: {ct[0]:.4f} per (channel, configuration, padded column, R + 1) + {ct[1]:.4f} per "
          f"(channel, configuration, padded column, rows (R + 8)) + {ct[2]:.3f} per value + {ct[3]:.2f} per "
          f"direction + {ct[4]:.0f} per call + {ct[5]:.3f} per bucket; relative rms "
          f"{np.sqrt(np.mean((T @ ct / tt - 1) ** 2)):.3f}")
    out = {"calls": recs, "table": ct.tolist()}
    for k in kernels:
        X = np.array([direct_terms(r, k) for r in recs])
        td = np.array([r["direct_" + k] for r in recs]) * 1e9
        if k == "avx2":
            X = X[:, 1:]
        cd = _relative_fit(X, td)
        if k == "avx2":
            cd = np.concatenate([[0.0], cd])
            X = np.array([direct_terms(r, k) for r in recs])
        print(f"direct, {k} [ns]: {cd[0]:.4f} per (direction, configuration, 3 R + 4) and 8-channel vector + "
              f"{cd[1]:.4f} per 4-channel vector + {cd[2]:.3f} per (direction, configuration) + {cd[3]:.2f} per "
              f"direction + {cd[4]:.0f} per call; relative rms {np.sqrt(np.mean((X @ cd / td - 1) ** 2)):.3f}")
        best = np.minimum(tt, td)
        fitted = np.where(T @ ct < X @ cd, tt, td) / best
        built = np.where(np.array([r["built_" + k] == "table" for r in recs]), tt, td) / best
        same = int(((T @ ct < X @ cd) == np.array([r["built_" + k] == "table" for r in recs])).sum())
        print(f"  the built model picks as the fitted one on {same} of {len(recs)} calls")
        for name, s in (("fitted", fitted), ("built", built)):
            print(f"  {name:6s} model's pick / the faster path on these calls: mean {s.mean():.4f}, worst "
                  f"{s.max():.2f}, {int((s > 1.05).sum())} of {s.size} more than 5 % slower")
        out["direct_" + k] = cd.tolist()
    return out


def load_average():
    try:
        return os.getloadavg()[0]
    except OSError:
        return float("nan")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--resolution", type=int, default=1000)
    ap.add_argument("--baseline-stride", type=int, default=40, help="baseline on every Nth image direction")
    ap.add_argument("--json", default=None)
    ap.add_argument("--small-only", action="store_true", help="skip the images (the direct-path rows only)")
    ap.add_argument("--auto-sweep", action="store_true", help="only the check of auto's choice (table_pays)")
    ap.add_argument("--fit-auto", action="store_true",
                    help="only the fit of table_pays' constants (times both paths on random small calls)")
    ap.add_argument("--fit-calls", type=int, default=480, help="calls timed by --fit-auto")
    ap.add_argument("--passes", type=int, default=3,
                    help="--auto-sweep and --fit-auto: passes over their calls (the least median kept)")
    ap.add_argument("--fit-seed", type=int, default=7, help="seed of --fit-auto's calls (7: the fitted set)")
    ap.add_argument("--direct-kernel", choices=("auto", "avx2", "avx512"), default="auto",
                    help="the direct path's vector kernel (default: AVX-512 where available)")
    ap.add_argument("--cache", default=os.environ.get("WIDESKY_BENCH_CACHE", tempfile.gettempdir()))
    args = ap.parse_args(argv)

    try:
        _core.direct_impl({"auto": 0, "avx2": 1, "avx512": 2}[args.direct_kernel])
    except ValueError:
        ap.error(f"--direct-kernel {args.direct_kernel}: not available on this processor")
    path = dataset(Path(args.cache))
    m = skymodel.load_dataset(path)
    m.load()
    if args.auto_sweep:
        return auto_sweep(m, max(args.repeat, 9), args.passes)
    if args.fit_auto:
        small, embedded = skymodel.load_dataset(small_dataset(Path(args.cache))), skymodel.load_dataset()
        small.load()
        embedded.load()
        res = fit_auto(m, small, embedded, max(args.repeat, 5), args.fit_calls, args.fit_seed, args.passes)
        if args.json:
            Path(args.json).write_text(json.dumps(res, indent=1))
        return res
    d, mask = fisheye_directions(args.resolution)
    dirs = np.ascontiguousarray(d[mask])
    n, C = dirs.shape[0], m.n_channels
    out = np.empty((n, C), np.float32)
    res = {"baseline": BASELINE_NAME, "dataset_MB": path.stat().st_size / 1e6, "resolution": args.resolution,
           "directions": n, "channels": C, "machine": platform.processor() or platform.machine(),
           "cpu_count": os.cpu_count(), "load_average_start": load_average()}
    sun, zen, emph = m.radiance_coefficients()

    def baseline_for(state, sub):
        el, az = np.radians(state["sun_elevation"]), np.radians(90.0 - state["sun_azimuth"])
        bo = np.empty((sub.shape[0], C))

        def run():
            _core.reference_loop(sun, zen, emph, m.sun_breaks, m.zenith_breaks, m.emph_breaks, m.rank, C,
                                 m.visibilities, m.albedos, m.altitudes, m.elevations, sub,
                                 (0.0, el, az, state["visibility"], state["albedo"]), np.arange(C), bo)
        return run, bo

    sub = np.ascontiguousarray(dirs[:: args.baseline_stride])
    for name, state in (() if args.small_only else (("daylight", STATE), ("twilight", TWILIGHT))):
        base, bo = baseline_for(state, sub)
        base()
        ours = skymodel.sky_radiance(m, sub, **state)
        res[name + "_max_rel_diff"] = float(np.max(np.abs(ours - bo)) / np.abs(bo).max())
        for threads in (1, 2):
            def cand(state=state, threads=threads):
                skymodel.sky_radiance(m, dirs, **state, method="table", threads=threads, dtype=np.float32, out=out)
            r = interleaved(base, sub.shape[0] * C, cand, n * C, args.repeat)
            r["path"] = KERNEL_INFO.get("path")
            if threads == 2:  # per core: 2 threads' wall-clock throughput over 2 cores (CPU time counts both)
                r["ratio_wall"] = r["ratio_wall"] / 2
            res[f"{name}_{threads}t"] = r

    # small calls: 300 directions, scattered and clustered
    rng = np.random.default_rng(1)
    v = rng.normal(size=(300, 3))
    v[:, 2] = np.abs(v[:, 2])
    scattered = np.ascontiguousarray(v / np.linalg.norm(v, axis=1)[:, None])
    c = np.array([np.cos(np.radians(40)) * np.sin(np.radians(200)), np.cos(np.radians(40)) * np.cos(np.radians(200)),
                  np.sin(np.radians(40))])
    w = c + 0.08 * rng.normal(size=(300, 3))
    clustered = np.ascontiguousarray(w / np.linalg.norm(w, axis=1)[:, None])
    for name, D in (("scattered", scattered), ("clustered", clustered)):
        base, bo = baseline_for(STATE, D)
        for method in ("direct", "auto"):
            def cand(D=D, method=method):
                skymodel.sky_radiance(m, D, **STATE, method=method, threads=1)
            r = interleaved(base, D.shape[0] * C, cand, D.shape[0] * C, max(args.repeat, 9))
            r["path"] = KERNEL_INFO.get("path")
            base()
            r["max_rel_diff"] = float(np.max(np.abs(skymodel.sky_radiance(m, D, **STATE, method=method) - bo))
                                      / np.abs(bo).max())
            res[f"small_{name}_{method}"] = r
    # one direction, direct path: 200 calls per timing (the baseline on the same direction, 200 calls)
    one, reps = np.ascontiguousarray(scattered[:1]), 200
    base1, bo1 = baseline_for(STATE, one)

    def base_one():
        for _ in range(reps):
            base1()

    def cand_one():
        for _ in range(reps):
            skymodel.sky_radiance(m, one, **STATE, method="direct", threads=1)
    r = interleaved(base_one, reps * C, cand_one, reps * C, max(args.repeat, 9))
    r["path"] = KERNEL_INFO.get("path")
    r["max_rel_diff"] = float(np.max(np.abs(skymodel.sky_radiance(m, one, **STATE, method="direct") - bo1))
                              / np.abs(bo1).max())
    res["one_direct"] = r
    res["load_average_end"] = load_average()
    res["direct_kernel"] = {0: "scalar", 1: "AVX2", 2: "AVX-512"}[_core.direct_impl(0)]  # (and back to auto)

    print(f"baseline: {BASELINE_NAME}; dataset {res['dataset_MB']:.1f} MB; image {args.resolution}^2 "
          f"({n} directions in the disc) x {C} channels; direct-path kernel {res['direct_kernel']}; load average "
          f"{res['load_average_start']:.1f} -> {res['load_average_end']:.1f}")
    print(f"{'case':34s} {'base ns/val':>11s} {'ns/val':>8s} {'CPU ratio':>9s} {'wall ratio':>10s} {'call wall':>10s}")
    for key, label in (("daylight_1t", "daylight, table, 1 thread"), ("daylight_2t", "daylight, table, 2 threads"),
                       ("twilight_1t", "twilight -2.5 deg, 1 thread"), ("twilight_2t", "twilight -2.5 deg, 2 threads"),
                       ("small_scattered_direct", "300 scattered, direct"), ("small_scattered_auto", "300 scattered, auto"),
                       ("small_clustered_direct", "300 clustered, direct"), ("small_clustered_auto", "300 clustered, auto"),
                       ("one_direct", "1 direction, direct (per call)")):
        if key not in res:
            continue
        r = res[key]
        print(f"{label:34s} {r['baseline_cpu_ns']:11.1f} {r['cpu_ns']:8.2f} {r['ratio_cpu']:8.1f}x {r['ratio_wall']:9.1f}x "
              f"{r['call_wall_s'] * 1e3:8.2f} ms  (path {r['path']})")
    if not args.small_only:
        print(f"agreement with the baseline (max abs difference / max value): daylight "
              f"{res['daylight_max_rel_diff']:.1e}, twilight {res['twilight_max_rel_diff']:.1e}")
    print("agreement, direct path: " + ", ".join(f"{k} {res[k]['max_rel_diff']:.1e}" for k in
                                                 ("small_scattered_direct", "small_clustered_direct", "one_direct")))
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))
    return res


if __name__ == "__main__":
    main()
