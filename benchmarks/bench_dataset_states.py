"""Benchmark: sky states per hour of ``widesky dataset build`` on 2 cores, the DISORT path against the Monte Carlo
path, measured in the same run, and the projected cost of the official SWIR grid (issue 15).

    python benchmarks/bench_dataset_states.py [--states 4] [--processes 2] [--json out.json]

DISORT path: one grid state of the default configuration (skymodel/data/default-dataset-plane-parallel.json: 16 streams, 256
moments, its fit directions, all 55 channels, albedo 0; the albedos of the grid then cost nothing). Monte Carlo
path: one state of the polarised variant (skymodel/data/polarised-dataset.json: its direction grid, paths per
direction and batch, all 55 channels, every albedo from one run). Each state is a task of a spawn pool of
``--processes`` workers (one thread each), as in the build; states/hour = states / wall time, and, since the states
are independent tasks, 2 x 3600 / (core seconds per state) on two free cores (the CPU time of each task, which a
shared machine's load does not inflate the way it inflates the wall time). The Monte Carlo cost
scales with (directions x paths per direction), so the per-(direction x path) cost measured here projects the
cost of any budget: the 0.5 % budget of docs/atmosphere-and-solver.md (16384 paths per direction and 4-channel
batch, 1000 directions) and the official SWIR grid (10 visibilities x 45 solar elevations, the layout of the
official file per docs/benchmarks.md, one altitude; every albedo from one run), against the 800,000 core-hours
the wide-spectral-range model's path tracing took (Vevoda et al. 2022, as cited by issue 15).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAPER_CORE_HOURS = 800_000
SWIR_STATES = 10 * 45
BUDGET_PATHS, BUDGET_DIRECTIONS = 16384, 1000


def _disort_job(args):
    from widesky.skymodel.generator.dataset_build import load_config, solve_state

    vis, ele = args
    cfg = load_config(ROOT / "skymodel" / "data" / "default-dataset-plane-parallel.json")
    t0 = time.process_time()
    d = solve_state(vis, ele, cfg)
    return time.process_time() - t0, d["radiance"].shape[0] * d["radiance"].shape[1]


def _mc_job(args):
    from widesky.skymodel.generator.dataset_build import load_config
    from widesky.skymodel.generator.dataset_mc import solve_mc_state

    vis, ele = args
    cfg = load_config(ROOT / "skymodel" / "data" / "polarised-dataset.json")
    t0 = time.process_time()
    d = solve_mc_state(vis, ele, cfg)
    return time.process_time() - t0, len(d["zenith"]) * len(d["azimuth"]), int(d["samples"])


def _warm(_):
    """Mie tables and gas fits into the caches, so that neither path's timing includes them."""
    from widesky.skymodel.generator.montecarlo_mie import mixture_matrix
    from widesky.skymodel.generator.solver import AtmosphereSpec, SkyState, channel_problems
    from widesky.skymodel.channels import CHANNEL_CENTERS_NM

    channel_problems(SkyState(30.0, visibility_km=40.0), AtmosphereSpec())
    for w in CHANNEL_CENTERS_NM:
        mixture_matrix("continental_average", 50, float(min(max(w, 300.0), 2400.0)))
    return 0


def _timed(pool, fn, jobs):
    t0 = time.perf_counter()
    res = pool.map(fn, jobs)
    return time.perf_counter() - t0, res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--states", type=int, default=4, help="states per path (default 4)")
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--json", default=None, help="write the figures here")
    a = ap.parse_args(argv)
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    vis = [20.0, 131.8, 51.3, 29.2, 90.4, 42.5]
    states = [(vis[i % len(vis)], 36.0) for i in range(a.states)]
    _warm(0)
    with mp.get_context("spawn").Pool(a.processes) as pool:
        pool.map(_warm, range(a.processes))
        wall_d, res_d = _timed(pool, _disort_job, states)
        wall_m, res_m = _timed(pool, _mc_job, states)
    cpu_d = sum(r[0] for r in res_d) / len(res_d)
    cpu_m = sum(r[0] for r in res_m) / len(res_m)
    dirs_m, paths_m = res_m[0][1], res_m[0][2]
    per_path_dir = cpu_m / (dirs_m * paths_m)  # core-seconds per (direction x path per batch), all 55 channels
    budget_core_h = per_path_dir * BUDGET_PATHS * BUDGET_DIRECTIONS / 3600
    out = {
        "processes": a.processes, "states": a.states, "load_average_1min_at_end": os.getloadavg()[0],
        "disort": {"wall_s": round(wall_d, 1), "states_per_hour_wall": round(a.states / wall_d * 3600, 1),
                   "core_s_per_state": round(cpu_d, 1),
                   "states_per_hour_on_2_free_cores": round(2 * 3600 / cpu_d, 1), "directions": res_d[0][1]},
        "monte_carlo": {"wall_s": round(wall_m, 1), "states_per_hour_wall": round(a.states / wall_m * 3600, 2),
                        "core_s_per_state": round(cpu_m, 1),
                        "states_per_hour_on_2_free_cores": round(2 * 3600 / cpu_m, 1), "directions": dirs_m,
                        "paths_per_direction": paths_m, "core_us_per_direction_path": round(1e6 * per_path_dir, 2)},
        "ratio_disort_over_mc_states_per_hour_wall": round(wall_m / wall_d, 2),
        "ratio_disort_over_mc_core_s": round(cpu_m / cpu_d, 2),
        "budget_0p5pct": {"paths_per_direction": BUDGET_PATHS, "directions": BUDGET_DIRECTIONS,
                          "core_hours_per_state": round(budget_core_h, 2),
                          "swir_grid_states": SWIR_STATES,
                          "swir_grid_core_hours": round(budget_core_h * SWIR_STATES),
                          "swir_grid_days_on_2_cores": round(budget_core_h * SWIR_STATES / 2 / 24, 1),
                          "paper_core_hours": PAPER_CORE_HOURS,
                          "fraction_of_paper": round(budget_core_h * SWIR_STATES / PAPER_CORE_HOURS, 4)},
        "swir_grid_at_disort": {"core_hours": round(cpu_d * SWIR_STATES / 3600, 1)},
    }
    print(json.dumps(out, indent=1))
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
