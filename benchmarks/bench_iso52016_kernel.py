"""The ISO 52016-1 zone balance's compiled step loop against numpy's, on the 18 ASHRAE 140 cases.

    python benchmarks/bench_iso52016_kernel.py [--cases 600 950 ...] [--repeat 3] [--data-dir DIR]

Builds each case's inputs once (the weather route, TMY3, the default options: 5-min sub-steps, EnergyPlus's inside
convection), then times :func:`widesky.thermal.zone_iso52016.simulate_iso52016` on them with ``engine="python"``
(numpy.linalg.solve on the whole node matrix each sub-step, the loop before 2026-12-05) and ``engine="auto"`` (the
compiled loop, thermal/_iso52016.c), both in this run, best of ``--repeat``; prints a Markdown table per case (the
two times, their ratio, the largest differences of the air temperature and the loads) and the totals. Needs the
reference data folder (ASHRAE 140 case files and the TMY3 year). Timings are wall-clock on whatever else the
machine runs; the ratio is the figure to read.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from widesky.thermal import bestest
from widesky.thermal.bestest import CASES, run_case


def case_inputs(case, data_dir):
    """The (args, kwargs) run_case hands to simulate_iso52016 for ``case``."""
    seen = []
    real = bestest.simulate_iso52016

    def record(*a, **k):
        seen.append((a, k))
        return real(*a, **k)
    bestest.simulate_iso52016 = record
    try:
        run_case(case, data_dir=data_dir)
    finally:
        bestest.simulate_iso52016 = real
    return seen[-1]


def best_time(fn, repeat):
    out, best = None, np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python benchmarks/bench_iso52016_kernel.py")
    ap.add_argument("--cases", nargs="+", default=list(CASES))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--data-dir", default=None)
    a = ap.parse_args(argv)
    bad = [c for c in a.cases if c not in CASES]
    if bad or a.repeat < 1:
        ap.error(f"unknown cases {bad}" if bad else "--repeat must be >= 1")
    rows, tot = [], np.zeros(2)
    for case in a.cases:
        args, kw = case_inputs(case, a.data_dir)
        times, outs = [], []
        for engine in ("python", "auto"):
            t, out = best_time(lambda: bestest.simulate_iso52016(*args, **{**kw, "engine": engine}), a.repeat)
            times.append(t)
            outs.append(out)
        d_t = float(np.abs(outs[0]["temp_air"] - outs[1]["temp_air"]).max())
        d_q = max(float(np.abs(outs[0][k] - outs[1][k]).max()) for k in ("heating", "cooling"))
        tot += times
        rows.append(f"| {case} | {times[0]:.2f} | {times[1]:.3f} | {times[0] / times[1]:.1f} | {d_t:.1e} | {d_q:.1e} |")
        print(rows[-1], file=sys.stderr)
    print("| case | numpy loop [s] | compiled [s] | ratio | max diff air [K] | max diff load [W] |")
    print("|---|---|---|---|---|---|")
    print("\n".join(rows))
    print(f"| all {len(a.cases)} | {tot[0]:.1f} | {tot[1]:.2f} | {tot[0] / tot[1]:.1f} | | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
