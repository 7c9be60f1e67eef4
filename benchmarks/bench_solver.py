"""Benchmark of the reference solver: one sky state, all 55 channels, 1 process vs all cores.

Prints solver runs, wall time and runs per second, and the speed-up against the single-process baseline measured
in the same run. Usage: ``python benchmarks/bench_solver.py [--channels N]``.
"""

import argparse
import os
import time

from widesky.skymodel.generator.solver import AtmosphereSpec, SkyState, solve_sky


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--channels", type=int, default=55, help="number of channels (first N)")
    ap.add_argument("--skip-baseline", action="store_true", help="only the multi-process run")
    a = ap.parse_args()
    state = SkyState(solar_elevation_deg=41.764, visibility_km=40.0, ground_albedo=0.2)
    spec = AtmosphereSpec()
    ch = list(range(a.channels))
    solve_sky(state, spec, channels=[6], processes=1)  # warm caches (Mie, profiles)
    res = {}
    for nproc in ([] if a.skip_baseline else [1]) + [os.cpu_count() or 1]:
        t = time.perf_counter()
        r = solve_sky(state, spec, channels=ch, processes=nproc, progress=True)
        dt = time.perf_counter() - t
        res[nproc] = dt
        print(f"processes={nproc}: {r.n_runs.sum()} DISORT runs, {len(ch)} channels, "
              f"{r.grid_radiance.shape[0] * r.grid_radiance.shape[1]} directions: {dt:.1f} s "
              f"({r.n_runs.sum() / dt:.1f} runs/s)")
    if 1 in res and len(res) > 1:
        print(f"speed-up vs 1 process: {res[1] / res[max(res)]:.2f}x")


if __name__ == "__main__":
    main()
