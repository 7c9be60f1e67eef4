"""Dataset size against fit error: choose knots and rank by measurement (docs/default-dataset.md, figure
docs/figures/dataset_size_vs_error.png).

For solved grid states in the build cache (``widesky dataset build`` or skymodel.generator.dataset_build.solve_all must have
run for the configuration), the fit samples of each state are split at random (seeded) into 75 % fitted and 25 %
held out; each (knots, rank) setting is fitted on the first part and its solid-angle-weighted normalised mean
absolute error measured on the held-out part, per channel. The dataset size is that of the configuration's grid
with those knots and rank.

Run:  python benchmarks/bench_dataset_knots.py skymodel/data/default-dataset-plane-parallel.json --states 6 --max-elevation 4.5 --plot
(the published figure: the 6 low-sun states, sun 2-4.5 deg, the hardest to fit)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

SETTINGS = [  # (n_sun, n_zen, n_emph, rank)
    (24, 18, 12, 3), (24, 18, 12, 4), (32, 24, 16, 4), (32, 24, 16, 5), (40, 30, 24, 5), (40, 30, 24, 6),
    (48, 36, 24, 6), (48, 36, 24, 8), (60, 45, 30, 8),
]


def block_bytes(ns, nz, ne, rank):
    """Bytes of one configuration's block in the file [bytes]."""
    return rank * (2 * ns + 8 + 2 * nz) + 2 * ne


def run(config_path, n_states=10, albedo=0.3, seed=0, settings=SETTINGS, max_elevation=90.0):
    from dataclasses import replace

    from widesky.skymodel.generator.dataset_build import (load_state, config_knots, direction_samples, fit_weights, ground_file,
                                        load_config, radiance_with_albedo, state_file)
    from widesky.skymodel.generator.fit import fit_radiance

    cfg = load_config(config_path)
    rng = np.random.default_rng(seed)
    states = [(v, e) for v in cfg.visibilities_km for e in cfg.elevations_deg
              if state_file(cfg, v, e).exists() and ground_file(cfg, v).exists() and 2.0 <= e <= max_elevation]
    if not states:
        raise SystemExit("no solved states in the cache: run the build's solve stage first")
    pick = [states[i] for i in sorted(rng.choice(len(states), min(n_states, len(states)), replace=False))]
    n_cfg = len(cfg.visibilities_km) * len(cfg.albedos) * len(cfg.elevations_deg) * 55
    rows = []
    for ns, nz, ne, rank in settings:
        c2 = replace(cfg, knots=(ns, nz, ne), rank=rank)
        sb, zb, eb = config_knots(c2)
        errs, t0, nfit = [], time.perf_counter(), 0
        for v, e in pick:
            s = load_state(state_file(cfg, v, e))
            g = load_state(ground_file(cfg, v))
            smp = direction_samples(s["zenith"], s["azimuth"], float(s["solved_elevation"]))
            y = radiance_with_albedo(s, g, albedo).reshape(-1, 55)
            m = len(y)
            test = np.zeros(m, bool)
            test[np.random.default_rng(seed + int(10 * v + e)).choice(m, m // 4, replace=False)] = True
            w = fit_weights(smp["weights"])
            ch_err = np.zeros(55)
            for c in range(55):
                if not np.any(y[:, c] > 0):
                    continue
                tr = ~test
                f = fit_radiance(smp["gamma"][tr], smp["zero"][tr], smp["zero"][tr], y[tr, c], sb, zb, eb, rank,
                                 weights=w[tr], smoothing=cfg.smoothing, iterations=cfg.iterations,
                                 refine=cfg.refine)
                nfit += 1
                p = f.evaluate(smp["gamma"][test], smp["zero"][test], smp["zero"][test], sb, zb, eb)
                sw = smp["weights"][test]
                ch_err[c] = np.sum(sw * np.abs(p - y[test, c])) / max(np.sum(sw * y[test, c]), 1e-300)
            errs.append(ch_err)
        errs = np.array(errs)
        size = n_cfg * block_bytes(ns, nz, ne, rank)
        wl = 300 + 40 * np.arange(55)
        tgt = (wl >= 400) & (wl <= 1300)
        row = {"knots": [ns, nz, ne], "rank": rank, "size_mb": size / 1e6, "nmae_mean": float(errs.mean()),
               "nmae_median_400_1300_max": float(np.median(errs, 0)[tgt].max()),
               "nmae_p90": float(np.percentile(errs, 90)), "ms_per_fit": 1e3 * (time.perf_counter() - t0) / nfit}
        rows.append(row)
        print(json.dumps(row), flush=True)
    return {"states": pick, "albedo": albedo, "rows": rows}


def plot(result, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result["rows"]
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    x = [r["size_mb"] for r in rows]
    ax.plot(x, [100 * r["nmae_mean"] for r in rows], "o-", label="mean over channels and states")
    ax.plot(x, [100 * r["nmae_median_400_1300_max"] for r in rows], "s--",
            label="worst per-channel median, 400-1300 nm")
    for r in rows:
        ax.annotate(f"{r['knots'][0]}/{r['knots'][1]}/{r['knots'][2]} r{r['rank']}", (r["size_mb"], 100 * r["nmae_mean"]),
                    fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.axvline(30, color="grey", lw=0.8, ls=":")
    ax.text(30.3, ax.get_ylim()[1] * 0.9, "30 MB limit", fontsize=7, color="grey")
    ax.set_xlabel("dataset size [MB] (default grid)")
    ax.set_ylabel("held-out NMAE [%]")
    el = [e for _, e in result["states"]]
    ax.set_title(f"Held-out fit error vs size ({len(result['states'])} states, sun {min(el):g}-{max(el):g} deg, "
                 f"albedo {result['albedo']})", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("config")
    ap.add_argument("--states", type=int, default=10)
    ap.add_argument("--plot", action="store_true")
    ap.add_argument("--max-elevation", type=float, default=90.0, help="only states with the sun up to this [deg]")
    ap.add_argument("--json", default=None, help="write the result here")
    a = ap.parse_args()
    res = run(a.config, a.states, max_elevation=a.max_elevation)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)
    if a.plot:
        plot(res, "docs/figures/dataset_size_vs_error.png")
    sys.exit(0)
