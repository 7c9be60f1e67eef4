"""Fitting error of the default dataset against the reference solver (the paper's Fig. 10 for our dataset).

Evaluates the dataset on the held-out validation states of its build configuration (solved by the build and cached;
see skymodel.generator.dataset_errors) and draws

- docs/figures/dataset_fit_error.png: per-channel box plot of the normalised mean absolute error of sky radiance
  over the held-out states (held-out directions on grid states, and states between grid points);
- docs/figures/dataset_irradiance_error.png: per-channel relative error of sky-diffuse irradiance, horizontal and
  37 deg tilted toward the sun (median and maximum over states), and of direct normal irradiance.

and prints the table used in docs/default-dataset.md.

Run:  python benchmarks/bench_dataset_errors.py skymodel/data/default-dataset.json skymodel/data/default.dat
"""

from __future__ import annotations

import argparse
import json

import numpy as np


def table(summary) -> str:
    wl = np.array(summary["wavelength_nm"])
    lines = ["| channel [nm] | NMAE median, grid states | NMAE median, between grid | NMAE mean, all | "
             "sky-diffuse horizontal median / max | sky-diffuse tilted median / max | DNI median / max | "
             "global tilted median / max |",
             "|---|---|---|---|---|---|---|---|"]
    a, on, off = summary["all"], summary.get("on", {}), summary.get("off", {})
    pct = lambda x: f"{100 * x:.2f}"  # noqa: E731
    for i, w in enumerate(wl):
        lines.append(f"| {w:.0f} | {pct(on['nmae_median'][i]) if on else '-'} | "
                     f"{pct(off['nmae_median'][i]) if off else '-'} | {pct(a['nmae_mean'][i])} | "
                     f"{pct(a['e_horizontal_median'][i])} / {pct(a['e_horizontal_max'][i])} | "
                     f"{pct(a['e_tilted_median'][i])} / {pct(a['e_tilted_max'][i])} | "
                     f"{pct(a['dni_error_median'][i])} / {pct(a['dni_error_max'][i])} | "
                     f"{pct(a['e_global_tilted_median'][i])} / {pct(a['e_global_tilted_max'][i])} |")
    return "\n".join(lines)


def plots(errors, summary, prefix="docs/figures/dataset_"):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    wl = np.array(summary["wavelength_nm"])
    fig, ax = plt.subplots(figsize=(11, 4.2))
    for kind, colour, shift in (("on", "tab:blue", -9), ("off", "tab:orange", 9)):
        sel = [e for e in errors if e["kind"] == kind]
        if not sel:
            continue
        nm = 100 * np.array([e["nmae"] for e in sel])
        bp = ax.boxplot([nm[:, c] for c in range(55)], positions=wl + shift, widths=14, patch_artist=True,
                        showfliers=True, flierprops={"markersize": 2})
        for b in bp["boxes"]:
            b.set_facecolor(colour)
            b.set_alpha(0.6)
        ax.plot([], [], color=colour, lw=6, alpha=0.6,
                label=f"{'grid states, held-out directions' if kind == 'on' else 'states between grid points'} "
                      f"({len(sel)})")
    ax.axhline(3, color="grey", ls=":", lw=0.8)
    ax.axhline(6, color="grey", ls="--", lw=0.8)
    ax.set_xticks(wl[::3])
    ax.set_xticklabels([f"{w:.0f}" for w in wl[::3]], rotation=45)
    ax.set_xlim(270, 2490)
    ax.set_xlabel("channel centre [nm]")
    ax.set_ylabel("NMAE of sky radiance [%]")
    ax.set_title(f"Default dataset vs reference solver: mean over channels and states "
                 f"{100 * summary['all']['nmae_channel_mean']:.2f} %")
    ax.legend(fontsize=8)
    ax.set_yscale("log")
    fig.tight_layout()
    fig.savefig(prefix + "fit_error.png", dpi=110)

    fig, ax = plt.subplots(figsize=(11, 4.2))
    a = summary["all"]
    for key, label, colour in (("e_horizontal", "sky diffuse, horizontal", "tab:blue"),
                               ("e_tilted", "sky diffuse, 37 deg tilted to the sun", "tab:green"),
                               ("dni_error", "direct normal", "tab:red"),
                               ("e_global_tilted", "global, 37 deg tilted", "black")):
        ax.plot(wl, 100 * np.array(a[key + "_median"]), "-o", ms=3, color=colour, label=label + " (median)")
        ax.plot(wl, 100 * np.array(a[key + "_max"]), ":", color=colour, label=label + " (max)")
    ax.axhline(1, color="grey", ls="--", lw=0.8)
    ax.axvspan(400, 1300, color="grey", alpha=0.08)
    ax.set_yscale("log")
    ax.set_ylim(5e-3, 100)  # DNI in opaque channels (280-320, 1840-1880 nm at low sun) is ~0: relative error off-scale
    ax.set_xlabel("channel centre [nm]")
    ax.set_ylabel("|relative error| [%]")
    ax.set_title(f"Irradiance errors over {summary['n_states']['all']} held-out states")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(prefix + "irradiance_error.png", dpi=110)


if __name__ == "__main__":
    from widesky.skymodel.generator.dataset_build import load_config
    from widesky.skymodel.generator.dataset_errors import evaluate_errors, summarise

    ap = argparse.ArgumentParser()
    ap.add_argument("config")
    ap.add_argument("dataset")
    ap.add_argument("--no-plot", action="store_true")
    ap.add_argument("--json", default=None)
    ap.add_argument("--below", type=float, default=None, metavar="DEG",
                    help="also print, per validation state with the sun below DEG, the worst and the median channel's "
                         "sky-diffuse horizontal error 400-1300 nm")
    a = ap.parse_args()
    errs = evaluate_errors(load_config(a.config), a.dataset)
    summ = summarise(errs)
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"summary": summ, "states": [{k: (v.tolist() if isinstance(v, np.ndarray) else v)
                                                    for k, v in e.items()} for e in errs]}, f)
    if not a.no_plot:
        plots(errs, summ)
    print(table(summ))
    for g in ("all", "on", "off"):
        if g in summ:
            print(g, summ["n_states"][g], "states; channel-mean NMAE", summ[g]["nmae_channel_mean"], summ[g]["targets"])
    if a.below is not None:
        wl = np.asarray(summ["wavelength_nm"], float)
        band = (wl >= 400.0) & (wl <= 1300.0)
        for e in sorted(errs, key=lambda e: (e["elevation"], e["visibility"])):
            if e["elevation"] < a.below:
                x = np.abs(np.asarray(e["e_horizontal"], float)[band]) * 100
                print(f"{e['kind']:3s} {e['visibility']:6.1f} km, sun {e['elevation']:5.2f} deg, "
                      f"albedo {e['albedo']:.2f}: sky-diffuse horizontal worst {np.nanmax(x):.2f} % ({wl[band][np.nanargmax(x)]:.0f} nm), "
                      f"median channel {np.nanmedian(x):.2f} %")
