"""Run the validation cases, return their figures as plain numbers and draw docs/figures/build_*.png."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..channels import CHANNEL_CENTERS_NM
from . import validation as v
from .gases import SHIPPED_FILE
from .lowtran_check import lowtran_comparison, plot_lowtran
from .solar import channel_extraterrestrial
from .validation import spctrl2_reference


def run(which=("rayleigh", "lowsun", "g173", "spctrl2", "6s", "lowtran"), figures=None, data_dir=None, processes=None):
    """Run the named validations; return a JSON-able dict of their results (and draw figures if asked)."""
    out = {}
    fig = Path(figures) if figures else None
    if fig:
        fig.mkdir(parents=True, exist_ok=True)
    if "rayleigh" in which:
        rb = v.rayleigh_benchmark()
        out["rayleigh_sweigart"] = [{"tau": r[0], "ssa": r[1], "down_rel_err": r[2] / r[3] - 1,
                                     "up_rel_err": r[4] / r[5] - 1} for r in rb]
    if "lowsun" in which:
        ls = v.low_sun_comparison(data_dir=data_dir)
        out["low_sun_dni_pp_over_spherical"] = dict(zip(map(float, ls["elevation_deg"]),
                                                        map(float, ls["dni_ratio"])))
        if fig:
            _plot_lowsun(ls, fig / "build_lowsun.png")
    if "g173" in which:
        g = v.g173_comparison(processes=processes, progress=True, data_dir=data_dir)
        r = g["result"]
        ok = (g["energy_share"] > 0.01) & ~g["strong_band"]
        out["g173"] = {"dni": g["dni"], "gti": g["gti"], "ref_dni": g["ref_dni_integral"],
                       "ref_gti": g["ref_gti_integral"], "dni_ratio": g["dni_ratio"], "gti_ratio": g["gti_ratio"],
                       "n_checked_channels": int(ok.sum()),
                       "dni_channels_within_5pct": int(np.sum(np.abs(g["ratio_dni"][ok] - 1) <= 0.05)),
                       "gti_channels_within_5pct": int(np.sum(np.abs(g["ratio_gti"][ok] - 1) <= 0.05)),
                       "ratio_dni": np.round(g["ratio_dni"], 4).tolist(),
                       "ratio_gti": np.round(g["ratio_gti"], 4).tolist(),
                       "flux_closure_max_abs": float(np.max(np.abs(r.dhi_integrated / r.dhi - 1))),
                       "seconds": r.seconds, "solver_runs": int(r.n_runs.sum()), "processes": r.meta["processes"]}
        if fig:
            _plot_g173(g, fig / "build_g173.png")
    if "spctrl2" in which:
        s = v.spctrl2_comparison(processes=processes, data_dir=data_dir)
        out["spctrl2"] = {k: s[k] for k in ("model_dni", "ref_dni", "dni_ratio", "model_dhi", "ref_dhi", "dhi_ratio",
                                            "model_ghi", "ref_ghi", "ghi_ratio")}
        if fig:
            _plot_spctrl2(s, fig / "build_spctrl2.png", data_dir)
    if "6s" in which:
        s6 = v.sixs_comparison(processes=processes or 2, data_dir=data_dir)
        out["sixs"] = {k: s6[k] for k in ("direct_ratio", "diffuse_ratio", "global_ratio")}
        if fig:
            _plot_6s(s6, fig / "build_6s.png")
    if "lowtran" in which:
        lt = lowtran_comparison(data_dir=data_dir)
        et = channel_extraterrestrial("tsis1", data_dir)
        weak = lt["ours_gas"] >= 0.95
        out["lowtran"] = {"zenith_deg": lt["zenith_deg"].tolist(),
                          "integrated_ratio": [float((et * a).sum() / (et * b).sum()) for a, b in
                                               zip(lt["lowtran"], lt["ours"])],
                          "weak_absorption_max_dev": [float(np.abs(a[w] / b[w] - 1).max()) for a, b, w in
                                                      zip(lt["lowtran"], lt["ours"], weak)],
                          "ratio_total": np.round(lt["lowtran"] / lt["ours"], 4).tolist()}
        if fig:
            plot_lowtran(lt, fig / "build_lowtran.png")
    if "gasfit" in which and fig:
        _plot_gasfit(fig / "build_gasfit.png")
    return out


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _plot_g173(g, path):
    plt = _plt()
    f, ax = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    x = CHANNEL_CENTERS_NM
    for a, key, name in ((ax[0], "ratio_dni", "direct normal"), (ax[1], "ratio_gti", "global 37 deg tilt")):
        r = np.clip(g[key], 0.5, 1.5)
        a.axhspan(0.95, 1.05, color="0.9")
        a.axhline(1, color="k", lw=0.8)
        a.plot(x, r, "o-", ms=3, label="model / G173")
        a.plot(x[g["strong_band"]], r[g["strong_band"]], "x", color="r", label="strong absorption band")
        a.set_ylim(0.8, 1.3)
        a.set_ylabel(f"{name}\nratio [1]")
        a2 = a.twinx()
        a2.bar(x, g["energy_share"], width=30, alpha=0.25, color="tab:orange")
        a2.set_ylabel("energy share [1]")
        a.legend(loc="upper left", fontsize=8)
    ax[0].set_title("ASTM G173-03 check: DNI %.1f vs %.1f W m-2 (%.3f), GTI %.1f vs %.1f W m-2 (%.3f)" % (
        g["dni"], g["ref_dni_integral"], g["dni_ratio"], g["gti"], g["ref_gti_integral"], g["gti_ratio"]), fontsize=9)
    ax[1].set_xlabel("channel centre [nm]")
    f.tight_layout()
    f.savefig(path, dpi=110)
    plt.close(f)


def _plot_lowsun(ls, path):
    plt = _plt()
    f, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].plot(ls["elevation_deg"], ls["dni_ratio"], "o-")
    ax[0].set_xlabel("solar elevation [deg]")
    ax[0].set_ylabel("DNI plane-parallel / spherical [1]")
    ax[0].axhline(1, color="k", lw=0.8)
    ax[0].grid(alpha=0.3)
    for i, e in enumerate(ls["elevation_deg"]):
        if e in (1, 3, 5, 10):
            ax[1].plot(CHANNEL_CENTERS_NM, ls["t_plane_parallel"][i] / np.maximum(ls["t_spherical"][i], 1e-30),
                       label=f"{e:g} deg")
    ax[1].set_ylim(0, 1.05)
    ax[1].set_xlabel("channel centre [nm]")
    ax[1].set_ylabel("T_pp / T_spherical [1]")
    ax[1].legend(fontsize=8)
    f.suptitle("Direct beam at low sun: plane-parallel vs spherical shells (US std, V = 40 km)", fontsize=10)
    f.tight_layout()
    f.savefig(path, dpi=110)
    plt.close(f)


def _plot_spctrl2(s, path, data_dir):
    plt = _plt()
    ref = spctrl2_reference(data_dir)
    r = s["result"]
    f, ax = plt.subplots(figsize=(9, 4))
    for k, c in (("dni", "C0"), ("dhi", "C1"), ("ghi", "C2")):
        ax.plot(ref["wavelength_nm"], ref[k], color=c, lw=0.8, label=f"SPCTRL2 {k}")
        ax.step(r.wavelength_nm, getattr(r, k), where="mid", color=c, ls="--", label=f"model {k}")
    ax.set_xlim(280, 2480)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("[W m-2 nm-1]")
    ax.set_title("SPCTRL2 example: DNI %.3f, DHI %.3f, GHI %.3f (model / SPCTRL2, 300-2480 nm)" % (
        s["dni_ratio"], s["dhi_ratio"], s["ghi_ratio"]), fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    f.tight_layout()
    f.savefig(path, dpi=110)
    plt.close(f)


def _plot_6s(s6, path):
    plt = _plt()
    x = CHANNEL_CENTERS_NM[s6["channels"]]
    f, ax = plt.subplots(figsize=(9, 4))
    ax.plot(x, s6["model_direct"], "C0-", label="DISORT direct / ET")
    ax.plot(x, s6["sixs_direct"], "C0--", label="6S direct / ET")
    ax.plot(x, s6["model_diffuse"], "C1-", label="DISORT diffuse / ET")
    ax.plot(x, s6["sixs_diffuse"], "C1--", label="6S diffuse (+env.) / ET")
    ax.set_xlabel("channel centre [nm]")
    ax.set_ylabel("horizontal irradiance / ET [1]")
    ax.set_title("6S vs this solver (G173 gases, AOD550 %.3f): direct %.3f, diffuse %.3f, global %.3f" % (
        s6["result"].meta["aod550"], s6["direct_ratio"], s6["diffuse_ratio"], s6["global_ratio"]), fontsize=9)
    ax.legend(fontsize=8)
    f.tight_layout()
    f.savefig(path, dpi=110)
    plt.close(f)


def _plot_gasfit(path):
    plt = _plt()
    d = json.loads(Path(SHIPPED_FILE).read_text())
    ew = [c["water"]["max_error"] for c in d["channels"]]
    em = [c["mixed"]["max_error"] for c in d["channels"]]
    nw = [len(c["water"]["k"]) for c in d["channels"]]
    nm = [len(c["mixed"]["k"]) for c in d["channels"]]
    f, ax = plt.subplots(figsize=(9, 3.8))
    ax.semilogy(CHANNEL_CENTERS_NM, np.maximum(ew, 1e-7), "o-", ms=3, label="H2O")
    ax.semilogy(CHANNEL_CENTERS_NM, np.maximum(em, 1e-7), "s-", ms=3, label="O2+CO2+CH4+N2O+CO")
    for x, a, b in zip(CHANNEL_CENTERS_NM, nw, nm):
        ax.annotate(f"{a}/{b}", (x, 1.5e-7), fontsize=5, ha="center", rotation=90)
    ax.axhline(1e-3, color="k", lw=0.8, ls=":")
    ax.set_xlabel("channel centre [nm]")
    ax.set_ylabel("max |T_fit - T_6S| [1]")
    ax.set_title("Exponential-sum fits of 6S band transmittance (terms H2O/mixed annotated)", fontsize=9)
    ax.legend(fontsize=8)
    f.tight_layout()
    f.savefig(path, dpi=110)
    plt.close(f)
