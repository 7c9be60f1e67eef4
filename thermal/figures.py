"""Figures of docs/thermal.md (matplotlib, written atomically as PNG).

``python -m widesky.thermal.figures OUTDIR [--bestest-integrator JSON] [--bestest-solar] [--bestest-days]
[--study DIR ...]``: the glazing and ASHRAE 140 figures always; the integrator-route BESTEST markers from a JSON of
:func:`widesky.thermal.bestest.run_case` results; ASHRAE 140's clear and cloudy days' light and its free-floating
days against the programs on both sky routes; the glazing-study figure from the folders ``widesky thermal study``
wrote.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np
import pandas as pd
import trimesh

from widesky.core.atomic import atomic_write

from .bestest import LOAD_CASES as CASES, reference_results, run_case
from .glazing import ANGLES, GlazingUnit, read_solar_spectrum
from .study import standard_units


def _save(fig, path):
    with atomic_write(path) as tmp:
        fig.savefig(tmp, dpi=110, bbox_inches="tight")


def fig_glazing(outdir, data_dir=None):
    """g by angle (AM1.5) and T, g by wavelength at normal incidence of the four units."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    units = standard_units(data_dir, solar_control=True)
    sw, se = read_solar_spectrum(data_dir)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for (name, u), col in zip(units.items(), ("C0", "C1", "C2", "C3")):
        g = [u.rated(sw, se, a)["shgc"] for a in ANGLES]
        ax[0].plot(ANGLES, g, color=col, label=f"{name} (g_n {g[0]:.3f}, U {u.u_value():.2f})")
        o = u.optics([0.0], sw)
        keep = sw <= 2500
        ax[1].plot(sw[keep], o["transmittance"][0][keep], color=col, lw=1, label=f"{name} T")
        ax[1].plot(sw[keep], o["shgc"][0][keep], color=col, lw=1, ls="--", label=f"{name} g")
    # the low-e unit with its coated layer traced by the equivalent-slab route instead
    le = units["low-e"]
    alt = GlazingUnit("alt", [le.layers[0], dataclasses.replace(le.layers[1],
                                                                angular_model="equivalent")], le.gaps)
    g_alt = [alt.rated(sw, se, a)["shgc"] for a in ANGLES]
    ax[0].plot(ANGLES, g_alt, color="C1", ls=":", label="low-e, coated layer by equivalent slab")
    ax[0].set(xlabel="angle of incidence [deg]", ylabel="g (AM1.5 global weighted) [1]",
              title="Solar heat gain coefficient by angle")
    ax[0].legend(fontsize=8)
    ax[0].grid(alpha=0.3)
    ax2 = ax[1].twinx()
    ax2.fill_between(sw[sw <= 2500], se[sw <= 2500], color="0.85", zorder=0)
    ax2.set_ylabel("AM1.5 global [W m-2 nm-1]")
    ax[1].set_zorder(ax2.get_zorder() + 1)
    ax[1].patch.set_visible(False)
    ax[1].set(xlabel="wavelength [nm]", ylabel="[1]", title="Normal incidence: T and g", xlim=(280, 2500))
    ax[1].legend(fontsize=7, ncol=2)
    _save(fig, Path(outdir) / "thermal_glazing.png")
    plt.close(fig)
    return {"g_alt": g_alt}


def fig_bestest(outdir, integrator=None, data_dir=None):
    """Annual loads and peaks of the cases with heating and cooling against the limits and the programs' range.

    ``integrator``: the JSON of ``benchmarks/bench_bestest_cases.py --json`` (ISO 52016-1: ``{"integrator": {case:
    figures}, "weather": {...}, "options": {...}}``, both routes plotted from it) or its older 5R1C form (``{case:
    figures}``, the integrator route only; the weather route then run here). Figures in W and Wh as
    :func:`~widesky.thermal.bestest.run_case` returns them, plotted in kW and MWh."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    refs = reference_results(data_dir)
    label_w, label_i = "ISO 52016-1, weather file (Perez)", "ISO 52016-1, widesky integrator"
    if integrator is not None and "integrator" in integrator:           # both routes of the default model
        ours, integrator = integrator["weather"], integrator["integrator"]
    else:                                                               # run_case's default: ISO 52016-1, Perez
        ours = {c: run_case(c, data_dir) for c in CASES}
        label_i = "5R1C, widesky integrator"                            # the older JSON: 5R1C's integrator route
    qs = (("annual_heating", "annual heating [MWh]"), ("annual_cooling", "annual cooling [MWh]"),
          ("peak_heating", "peak heating [kW]"), ("peak_cooling", "peak cooling [kW]"))
    fig, axs = plt.subplots(4, 1, figsize=(12, 12), layout="constrained")
    table = {}
    for ax, (q, title) in zip(axs, qs):
        for i, c in enumerate(CASES):
            r = refs[c][q]
            prog = np.array(list(r["programs"].values())) / 1000
            if "limits" in r:
                lo, hi = np.array(r["limits"]) / 1000
                ax.plot([i, i], [lo, hi], color="0.75", lw=10, solid_capstyle="butt",
                        label="140 acceptance limits" if i == 0 else None)
            ax.plot([i, i], [prog.min(), prog.max()], color="0.35", lw=3,
                    label="reference programs" if i == 0 else None)
            v = ours[c][q] / 1000
            ax.plot(i - 0.12, v, "o", color="C3", label=label_w if i == 0 else None)
            table[(c, q)] = v
            if integrator is not None:
                ax.plot(i + 0.12, integrator[c][q] / 1000, "s", color="C0",
                        label=label_i if i == 0 else None)
        ax.set_xticks(range(len(CASES)), CASES)
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3, axis="y")
    axs[0].legend(fontsize=7, loc="upper left")
    _save(fig, Path(outdir) / "thermal_bestest.png")
    plt.close(fig)
    return table


def fig_bestest_solar(outdir, data_dir=None, n_jobs=1):
    """ASHRAE 140's clear (14 July) and cloudy (4 May) days, Case 600's south, west and horizontal surfaces: the six
    programs' hourly range against widesky's weather (Perez) and integrator routes
    (:func:`widesky.thermal.bestest_solar.solar_outputs`), written as ``thermal_bestest_solar.png``. Returns the
    two routes' outputs."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from .bestest_solar import DAY_HOURLY_RANGE, HOURS, solar_outputs
    routes = {"weather file (Perez 1990)": solar_outputs("weather", data_dir=data_dir),
              "widesky integrator (all-sky)": solar_outputs("integrator", data_dir=data_dir, n_jobs=n_jobs)}
    fig, axs = plt.subplots(2, 3, figsize=(13, 7), layout="constrained", sharex=True)
    for row, day in zip(axs, ("july_14", "may_4")):
        for ax, surf in zip(row, ("south", "west", "horizontal")):
            lo, hi = DAY_HOURLY_RANGE[(day, surf)]
            x = np.array(HOURS) - 0.5                                        # the hour's middle
            ax.fill_between(x, lo, hi, color="0.8", step=None, label="six reference programs (range)")
            for (name, out), style in zip(routes.items(), ("-o", "-s")):
                y = np.asarray(out["hourly"][(day, surf)])[np.array(HOURS) - 1]
                ax.plot(x, y, style, ms=3, lw=1, label=name)
            title = {"july_14": "14 July (clear)", "may_4": "4 May (cloudy)"}[day]
            ax.set_title(f"Case 600 {surf}, {title}", fontsize=10)
            ax.grid(alpha=0.3)
        row[0].set_ylabel("incident solar [Wh m-2]")
    for ax in axs[1]:
        ax.set_xlabel("hour, local standard time")
    handles, labels = axs[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8)
    _save(fig, Path(outdir) / "thermal_bestest_solar.png")
    plt.close(fig)
    return routes


def fig_bestest_days(outdir, data_dir=None, n_jobs=1):
    """The free-floating rooms hour by hour on the Standard's days (600FF and 900FF on 1 February, 650FF and 950FF on
    14 July): the six programs' hourly range against widesky's weather (Perez) and integrator routes
    (:func:`widesky.thermal.bestest_days.free_float_days`), written as ``thermal_bestest_days.png``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from .bestest_days import FREE_FLOAT_DAY_RANGE, free_float_days
    routes = {"weather file (Perez 1990)": free_float_days("weather", data_dir=data_dir),
              "widesky integrator (all-sky)": free_float_days("integrator", data_dir=data_dir, n_jobs=n_jobs)}
    fig, axs = plt.subplots(1, 4, figsize=(15, 3.8), layout="constrained")
    x = np.arange(1, 25) - 0.5
    for ax, (case, day) in zip(axs, FREE_FLOAT_DAY_RANGE):
        lo, hi = FREE_FLOAT_DAY_RANGE[(case, day)]
        ax.fill_between(x, lo, hi, color="0.8", label="six reference programs (range)")
        for (name, out), style in zip(routes.items(), ("-o", "-s")):
            ax.plot(x, out[(case, day)], style, ms=3, lw=1, label=name)
        ax.set_title(f"{case}, {'1 February' if day == 'feb_1' else '14 July'}", fontsize=10)
        ax.set_xlabel("hour, local standard time")
        ax.grid(alpha=0.3)
    axs[0].set_ylabel("zone air temperature [degC]")
    handles, labels = axs[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8)
    _save(fig, Path(outdir) / "thermal_bestest_days.png")
    plt.close(fig)
    return routes


def _climate(folder):
    """'San Francisco' from 'study_USA_CA_San.Francisco.Intl.AP.724940_TMY3' and the like."""
    stem = Path(folder).name.replace("study_", "")
    parts = stem.split("_", 2)
    core = parts[2] if len(parts) == 3 else stem
    return core.split(".Intl")[0].split("-OHare")[0].replace(".", " ")


def fig_study(outdir, study_dirs, names=None):
    """Effective g per month, south and north facades, spectral vs rated route, per climate (``names``: the
    climates' titles, default from the folder names)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axs = plt.subplots(2, len(study_dirs), figsize=(4.2 * len(study_dirs), 6.5), sharey="row",
                            squeeze=False)
    for j, d in enumerate(study_dirs):
        eff = pd.read_csv(Path(d) / "effective_g.csv", index_col=[0, 1, 2]).sort_index()
        name = _climate(d) if names is None else names[j]
        for i, o in enumerate(("south", "north")):
            ax = axs[i, j]
            for unit, col in zip(eff.index.get_level_values(0).unique(), ("C0", "C1", "C2")):
                e = eff.loc[(unit, o)]
                ax.plot(e.index, e["spectral"], color=col, label=f"{unit} spectral")
                ax.plot(e.index, e["rated_route"], color=col, ls="--", label=f"{unit} rated g(angle)")
                ax.axhline(e["rated_normal"].iloc[0], color=col, ls=":", lw=1)
            ax.set_title(f"{name}: {o} facade", fontsize=9)
            ax.set_xticks(range(1, 13, 2))
            ax.grid(alpha=0.3)
            if j == 0:
                ax.set_ylabel("effective g [1]")
            if i == 1:
                ax.set_xlabel("month")
    axs[0, 0].legend(fontsize=6, ncol=1)
    _save(fig, Path(outdir) / "thermal_effective_g.png")
    plt.close(fig)


def fig_facade(outdir, ply_path, title=""):
    """Render a facade map PLY (:func:`widesky.thermal.facade.write_facade_ply`) seen from the south-west."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    m = trimesh.load(ply_path, process=False)
    tri = m.vertices[m.faces]
    col = np.asarray(m.visual.face_colors)[:, :3] / 255.0
    fig = plt.figure(figsize=(9, 5))
    for k, (elev, azim) in enumerate(((20, -120), (20, 60))):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        ax.add_collection3d(Poly3DCollection(tri, facecolors=col, edgecolors="0.3", linewidths=0.2))
        lo, hi = m.vertices.min(0), m.vertices.max(0)
        ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), zlim=(lo[2], hi[2]),
               xlabel="x east [m]", ylabel="y north [m]")
        ax.set_box_aspect(hi - lo)
        ax.view_init(elev, azim)
        ax.set_title(("from south-west" if k == 0 else "from north-east"), fontsize=9)
    vals = None
    try:
        vals = pd.read_csv(Path(ply_path).with_suffix(".csv"))["incident_kWh_m2"]
    except (OSError, KeyError):
        pass
    if vals is not None:
        sm = plt.cm.ScalarMappable(cmap=matplotlib.colors.LinearSegmentedColormap.from_list(
            "w", np.array([[49, 54, 149], [116, 173, 209], [255, 255, 191], [244, 109, 67],
                           [165, 0, 38]]) / 255.0), norm=plt.Normalize(vals.min(), vals.max()))
        fig.colorbar(sm, ax=fig.axes, shrink=0.6, label="annual incident shortwave [kWh m-2]")
    fig.suptitle(title, fontsize=10)
    _save(fig, Path(outdir) / "thermal_facade.png")
    plt.close(fig)


def study_table(study_dirs):
    """Markdown rows: per climate and unit, annual window gain, heating and cooling by route and
    their relative difference (spectral / rated - 1)."""
    lines = ["| climate | unit | window gain spectral / rated [MWh] | diff | cooling spectral / "
             "rated [MWh] | diff | heating spectral / rated [MWh] | diff |",
             "|---|---|---|---|---|---|---|---|"]
    for d in study_dirs:
        a = pd.read_csv(Path(d) / "annual.csv", index_col=[0, 1])
        name = _climate(d)
        for unit in a.index.get_level_values(0).unique():
            s, r = a.loc[(unit, "spectral")], a.loc[(unit, "rated")]
            cells = []
            for q in ("window_gain_kWh", "cooling_kWh", "heating_kWh"):
                cells += [f"{s[q] / 1000:.2f} / {r[q] / 1000:.2f}", f"{(s[q] / r[q] - 1) * 100:+.2f} %"]
            lines.append(f"| {name} | {unit} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m widesky.thermal.figures")
    ap.add_argument("outdir")
    ap.add_argument("--bestest-integrator", default=None)
    ap.add_argument("--study", nargs="*", default=[])
    ap.add_argument("--facade", default=None, help="facade map PLY to render")
    ap.add_argument("--bestest-solar", action="store_true",
                    help="also draw ASHRAE 140's clear and cloudy days against the programs (both sky routes)")
    ap.add_argument("--bestest-days", action="store_true",
                    help="also draw the free-floating rooms hour by hour on the Standard's days (both sky routes)")
    args = ap.parse_args(argv)
    out = Path(args.outdir)
    out.mkdir(parents=True, exist_ok=True)
    g = fig_glazing(out)
    print("low-e g by equivalent slab:", np.round(g["g_alt"], 3).tolist())
    integ = json.loads(Path(args.bestest_integrator).read_text()) if args.bestest_integrator else None
    t = fig_bestest(out, integ)
    for k, v in t.items():
        print(k, round(v, 3))
    if args.bestest_solar:
        fig_bestest_solar(out)
    if args.bestest_days:
        fig_bestest_days(out)
    if args.facade:
        fig_facade(out, args.facade, "widesky thermal loads: Denver TMY3, 2 storeys, WWR 0.4, "
                                     "1 m overhangs, 0.5 m fins, low-e, spectral route")
    if args.study:
        fig_study(out, args.study)
        print(study_table(args.study))


if __name__ == "__main__":
    import sys
    try:
        main()
    except (OSError, ValueError) as exc:         # e.g. the ASHRAE 140 files of the reference data folder missing
        print(f"python -m widesky.thermal.figures: error: {exc}", file=sys.stderr)
        sys.exit(2)
