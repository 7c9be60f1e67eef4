"""Choosing the default dataset's visibility and elevation grids by measured interpolation error.

The evaluator interpolates linearly between grid configurations with weights that do not depend on the
view direction, so the sky-diffuse horizontal irradiance (DHI) of an interpolated sky is the linear
interpolation of the grid skies' DHIs (up to the per-configuration clamp at zero). The grid's share of
the irradiance error between grid points is therefore the linear-interpolation error of the solver's DHI
as a function of visibility and of solar elevation, which the solver's own fluxes measure without fitting
anything:

* visibility: DHI at 31 visibilities log-uniform in 20-131.8 km x 8 solar elevations (albedo 0); candidate
  grids of n visibilities are subsets of those 31 (log-uniform), tested on the 31 - n others;
* elevation: DHI at the current grid's elevations and their midpoints x 4 visibilities; candidate grids
  are subsets, tested on every other elevation from 2 to 80 deg.

Printed: per candidate, the worst (over channels 400-1300 nm) median and the maximum relative DHI error.
Cost: 380 solver states with one view direction (about 2 s each), 6.5 minutes on 2 processes; ``--data``
reuses a saved run.

Run:  python benchmarks/bench_dataset_grid.py skymodel/data/default-dataset-plane-parallel.json [--data grid.json] [--plot F]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import time

import numpy as np

ELEVATIONS_FOR_VIS = (5.0, 10.5, 17.0, 25.5, 36.0, 48.5, 63.0, 80.0)
ELEVATION_CANDIDATES = {
    "21 (7 x 21 grid)": [0, 1, 2, 3, 4.5, 6, 8, 10.5, 13.5, 17, 21, 25.5, 30.5, 36, 42, 48.5, 55.5, 63, 71, 80],
    "17": [0, 1, 2, 3, 4.5, 6, 8, 10.5, 13.5, 17, 21, 25.5, 36, 48.5, 63, 80],
    "17 (b)": [0, 1, 2, 3, 4.5, 6, 8, 10.5, 13.5, 17, 21, 25.5, 30.5, 42, 55.5, 80],
    "16": [0, 1, 2, 3, 4.5, 6, 8, 10.5, 13.5, 17, 25.5, 36, 48.5, 63, 80],
    "15": [0, 1, 2, 3, 4.5, 6, 8, 10.5, 13.5, 17, 25.5, 36, 55.5, 80],
}
"""Candidate elevation grids [deg] (each also holds 90 deg, which repeats the 80 deg fit); names count 90."""


def _solve(job):
    from widesky.skymodel.generator.dataset_build import load_config, solve_state

    path, v, e = job
    s = solve_state(v, e, load_config(path), zenith_deg=[0.0], azimuth_deg=[0.0])
    return [v, e], s["dhi"].tolist()


def solve(config_path, processes=2):
    """Solver DHI [W m-2 nm-1] (55,) on the study's (visibility, elevation) points (see module docstring)."""
    from widesky.skymodel.generator.dataset_build import load_config

    cfg = load_config(config_path)
    vf = np.exp(np.linspace(np.log(20.0), np.log(131.8), 31))
    e_cur = np.array(ELEVATION_CANDIDATES["21 (7 x 21 grid)"] + [90.0], float)
    e_fine = np.unique(np.concatenate([e_cur, 0.5 * (e_cur[1:] + e_cur[:-1])]))
    e_fine = e_fine[e_fine >= cfg.min_solve_elevation_deg]
    pts = {(float(v), float(e)) for v in vf for e in ELEVATIONS_FOR_VIS}
    pts |= {(float(v), float(e)) for v in vf[[0, 10, 20, 30]] for e in e_fine}
    jobs = [(str(config_path), v, e) for v, e in sorted(pts)]
    t0 = time.perf_counter()
    with mp.get_context("spawn").Pool(processes) as pool:
        res = pool.map(_solve, jobs, chunksize=4)
    return {"VF": vf.tolist(), "E_fine": e_fine.tolist(), "res": res, "seconds": time.perf_counter() - t0}


def analyse(data):
    """Rows of (dimension, candidate, n, worst median [1], mean median [1], max [1]) over 400-1300 nm."""
    vf, ef = np.array(data["VF"]), np.array(data["E_fine"])
    tab = {(round(r[0][0], 6), round(r[0][1], 6)): np.array(r[1]) for r in data["res"]}
    wl = 300.0 + 40.0 * np.arange(55)
    tgt = (wl >= 400) & (wl <= 1300)

    def get(v, e):
        return tab[(round(float(v), 6), round(float(e), 6))]

    def stats(errs):
        a = np.abs(np.array(errs))[:, tgt]
        med = np.median(a, axis=0)
        return float(med.max()), float(med.mean()), float(a.max())

    rows = []
    for n in (5, 7, 9, 11, 13, 16):
        nodes = np.unique(np.round(np.linspace(0, 30, n)).astype(int))
        errs = []
        for e in ELEVATIONS_FOR_VIS:
            y = np.array([get(v, e) for v in vf])
            for i in sorted(set(range(31)) - set(nodes.tolist())):
                k = np.searchsorted(nodes, i) - 1
                a, b = nodes[k], nodes[k + 1]
                f = (vf[i] - vf[a]) / (vf[b] - vf[a])
                errs.append(((1 - f) * y[a] + f * y[b]) / y[i] - 1)
        rows.append(("visibility", f"{n} log-uniform", n, *stats(errs)))
    for name, g in ELEVATION_CANDIDATES.items():
        g = np.array(g, float)
        errs = []
        for v in vf[[0, 10, 20, 30]]:
            for e in ef:
                if e < 2.0 or e > g[-1] or np.any(np.isclose(g, e)):
                    continue
                k = np.searchsorted(g, e) - 1
                a, b = g[k], g[k + 1]
                ya = get(v, a if a > 0 else min(ef))      # the 0 deg configuration holds the lowest solve
                f = (e - a) / (b - a)
                errs.append(((1 - f) * ya + f * get(v, b)) / get(v, e) - 1)
        rows.append(("elevation", name, len(g) + 1, *stats(errs)))
    return rows


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    from matplotlib.ticker import FuncFormatter, LogLocator

    for ax, dim, plural in zip(axes, ("visibility", "elevation"), ("visibilities", "solar elevations")):
        r = [x for x in rows if x[0] == dim]
        n = [x[2] for x in r]
        ax.plot(n, [100 * x[3] for x in r], "o-", label="worst channel median")
        ax.plot(n, [100 * x[5] for x in r], "s--", label="maximum")
        ax.axhline(1.0, color="grey", lw=0.8)
        ax.set_xlabel(f"number of {plural} in the grid")
        ax.set_ylabel("DHI interpolation error, 400-1300 nm [%]")
        ax.set_yscale("log")
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: f"{y:g}"))
        ax.yaxis.set_minor_formatter(FuncFormatter(lambda y, _: ""))
        ax.legend(fontsize=8)
    fig.suptitle("Linear interpolation error of the solver's sky-diffuse irradiance between grid points", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("config")
    ap.add_argument("--data", default=None, help="JSON of a previous run (written there when absent)")
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--plot", default=None, help="write the chart (PNG)")
    a = ap.parse_args()
    try:
        data = json.load(open(a.data)) if a.data else None
    except FileNotFoundError:
        data = None
    if data is None:
        data = solve(a.config, a.processes)
        print(f"solved {len(data['res'])} states in {data['seconds']:.0f} s")
        if a.data:
            json.dump(data, open(a.data, "w"))
    rows = analyse(data)
    print("| dimension | grid | values | worst channel median | mean of channel medians | maximum |")
    print("|---|---|---|---|---|---|")
    for dim, name, n, worst, mean, mx in rows:
        print(f"| {dim} | {name} | {n} | {100 * worst:.2f} % | {100 * mean:.2f} % | {100 * mx:.2f} % |")
    if a.plot:
        plot(rows, a.plot)
