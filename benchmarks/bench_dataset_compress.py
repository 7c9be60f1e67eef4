"""Channel omission for the default dataset (the paper's Fig. 7): dataset-size reduction against the threshold.

Samples the dataset's sky radiance at seeded random directions for every grid configuration (sun >= 2 deg), runs
greedy omission (first 12 channels kept) for a range of thresholds and three error statistics over the samples
(maximum, 99th percentile, median) and draws docs/figures/dataset_compression.png.

Run:  python benchmarks/bench_dataset_compress.py skymodel/data/default.dat
"""

from __future__ import annotations

import argparse
import json


THRESHOLDS = (0.01, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.5)
QUANTILES = (1.0, 0.99, 0.5)


def run(path, n_directions=300, seed=0):
    from widesky.skymodel.compress import greedy_omission, radiance_samples
    from widesky.skymodel.dataset import load_dataset

    m = load_dataset(path)
    y = radiance_samples(m, n_directions, seed)
    rows = []
    for q in QUANTILES:
        for t in THRESHOLDS:
            kept = greedy_omission(y, m.wavelengths, t, quantile=q)
            rows.append({"quantile": q, "threshold": t, "kept": int(kept.size),
                         "reduction": 1.0 - kept.size / m.n_channels, "kept_nm": m.wavelengths[kept].tolist()})
            print(json.dumps({k: v for k, v in rows[-1].items() if k != "kept_nm"}))
    return rows, y.shape[0]


def plot(rows, n, path="docs/figures/dataset_compression.png"):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    names = {1.0: "maximum error (the paper's rule)", 0.99: "99th percentile of the error", 0.5: "median error"}
    for q in QUANTILES:
        rr = [r for r in rows if r["quantile"] == q]
        ax.plot([100 * r["threshold"] for r in rr], [100 * r["reduction"] for r in rr], "o-", label=names[q])
        for r in rr:
            ax.annotate(f"{r['kept']}", (100 * r["threshold"], 100 * r["reduction"]), fontsize=6, xytext=(2, -9),
                        textcoords="offset points")
    ax.legend(fontsize=7)
    ax.set_xscale("log")
    ax.set_xlabel("maximum relative interpolation error [%]")
    ax.set_ylabel("radiance data size reduction [%]")
    ax.set_title(f"Greedy channel omission (labels: channels kept of 55; {n} spectra)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("--directions", type=int, default=300)
    ap.add_argument("--no-plot", action="store_true")
    a = ap.parse_args()
    rows, n = run(a.dataset, a.directions)
    if not a.no_plot:
        plot(rows, n)
