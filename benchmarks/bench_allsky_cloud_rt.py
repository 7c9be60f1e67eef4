"""The all-sky model's cloudy spectra against radiative transfer with a cloud layer (docs/validation/all-sky.md, section 4e).

For each solar elevation and cloud optical depth, ``widesky.skymodel.generator.cloud_reference.cloudy_fluxes`` solves the
dataset's clear atmosphere with a homogeneous stratiform water cloud (Mie droplets, saturated in-cloud vapour,
DISORT fluxes). Its broadband direct and diffuse horizontal irradiance are then given to the all-sky model as the
"measured" weather, with the same atmosphere's clear-sky spectra (the cloud-free solve) as the clear sky, and the
model's global horizontal spectrum is set beside the radiative transfer's: average photon energy 340-1060 nm,
band ratios, and the mismatch of generic a-Si, CdTe, c-Si and CIGS responses relative to the clear spectrum.

    python benchmarks/bench_allsky_cloud_rt.py [--elevations 20,40,60] [--taus 0,3,10,20,40,80] [--figure PNG]

Needs the data directory (../shared/data or WIDESKY_DATA_DIR) and disortpp; about 5 s of DISORT per
(elevation, optical depth) on one core, plus ~30 s of Mie once.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from widesky.core.atomic import atomic_write
from widesky.irradiance.allsky import CLEAR_SHAPE, AllSkyOptions
from widesky.irradiance.allsky_compare import ape, generic_eqe, spectral_response
from widesky.skymodel.channels import CHANNEL_EDGES_NM
from widesky.skymodel.generator.cloud_reference import allsky_global_horizontal, cloudy_fluxes

TECHS = ("a-Si", "CdTe", "c-Si", "CIGS")
BANDS = ((380, 500), (500, 700), (700, 900), (900, 1100), (1100, 1300))


def run(elevations, taus, aod550=0.1):
    edges = CHANNEL_EDGES_NM
    wl, w = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)
    sr = spectral_response(generic_eqe(wl), wl)
    rows = []
    for el in elevations:
        t0 = time.perf_counter()
        clear = cloudy_fluxes(0.0, el, aod550)
        for tau in taus:
            cl = clear if tau == 0 else cloudy_fluxes(tau, el, aod550)
            g_rt = cl.ghi
            kc = float((g_rt @ w) / (clear.ghi @ w))
            out = {"elevation": el, "tau": tau, "kc": kc, "rt": g_rt, "clear": clear.ghi,
                   "cloud_top_km": cl.cloud_top_km, "vapour_cm": cl.in_cloud_vapour_cm}
            for label, opt in (("model", AllSkyOptions()), ("plain", CLEAR_SHAPE),
                               ("previous", AllSkyOptions(droplet_optics="adt", vapour_path="diffusion"))):
                out[label] = g_rt if tau == 0 else allsky_global_horizontal(clear, cl, el, opt)
            rows.append(out)
        print(f"  sun {el:g} deg: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return rows, wl, w, sr


def mismatch(g, ref, s, w):
    """Response-weighted mean of spectrum g relative to that of ref [1]."""
    return float(((g * s * w).sum() / (g * w).sum()) / ((ref * s * w).sum() / (ref * w).sum()))


def report(rows, wl, w, sr):
    print("APE of global horizontal 340-1060 nm [eV] and spectral mismatch against the clear spectrum [%]: "
          "radiative transfer (RT) / the all-sky model / the model before the Mie droplets and the two-stream path "
          "(previous); plain = the clear shape scaled")
    print("sun  tau   kc     APE clear / RT / model / previous / plain    "
          + "  ".join(f"{t} RT/model/previous" for t in TECHS))
    for r in rows:
        a = [ape(r[k], wl, w) for k in ("clear", "rt", "model", "previous", "plain")]
        m = "  ".join("/".join(f"{100 * (mismatch(r[k], r['clear'], sr[t], w) - 1):+.2f}" for k in ("rt", "model", "previous"))
                      for t in TECHS)
        print(f"{r['elevation']:4g} {r['tau']:4g} {r['kc']:5.3f}  " + " / ".join(f"{x:.3f}" for x in a) + f"    {m}")
    print("\nband ratios (cloudy / clear, each normalised to 1 over 380-1300 nm): RT | model | previous")
    band = (wl > 380) & (wl < 1300)
    for r in rows:
        if r["tau"] == 0:
            continue
        parts = []
        for k in ("rt", "model", "previous"):
            q = r[k] / r["clear"]
            q = q / (np.sum((r[k] * w)[band]) / np.sum((r["clear"] * w)[band]))
            parts.append(" ".join(f"{np.sum((q * r['clear'] * w)[(wl > lo) & (wl < hi)]) / np.sum((r['clear'] * w)[(wl > lo) & (wl < hi)]):.3f}"
                                  for lo, hi in BANDS))
        print(f"  sun {r['elevation']:g} tau {r['tau']:g}: " + " | ".join(parts)
              + f"   ({', '.join(f'{lo}-{hi}' for lo, hi in BANDS)} nm)")


def figure(rows, wl, w, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    els = sorted({r["elevation"] for r in rows})
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    ax = axes[0]
    for i, el in enumerate(els):
        rr = [r for r in rows if r["elevation"] == el]
        kc = [r["kc"] for r in rr]
        ax.plot(kc, [ape(r["rt"], wl, w) for r in rr], "o-", color=f"C{i}", label=f"radiative transfer, sun {el:g} deg")
        ax.plot(kc, [ape(r["model"], wl, w) for r in rr], "s--", color=f"C{i}", label=f"all-sky model, sun {el:g} deg")
        ax.plot(kc, [ape(r["previous"], wl, w) for r in rr], ":", color=f"C{i}", alpha=0.7)
    ax.set_xlabel("clear-sky index GHI / GHI_clear")
    ax.set_ylabel("APE of global horizontal 340-1060 nm [eV]")
    ax.set_title("Cloudy global horizontal: APE (dotted: the model before)")
    ax.legend(fontsize=7)
    ax = axes[1]
    mid = els[len(els) // 2]
    for i, r in enumerate(r for r in rows if r["elevation"] == mid and r["tau"] > 0):
        for k, ls in (("rt", "-"), ("model", "--")):
            q = (r[k] / (r[k] @ w)) / (r["clear"] / (r["clear"] @ w))
            ax.plot(wl, q, ls, color=f"C{i}", label=f"tau {r['tau']:g} ({'RT' if k == 'rt' else 'model'})")
    ax.set_xlim(300, 1400)
    ax.set_ylim(0.4, 1.6)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("cloudy / clear global horizontal, per unit broadband")
    ax.set_title(f"Spectral change under cloud, sun {mid:g} deg")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    with atomic_write(path) as tmp:
        fig.savefig(tmp, dpi=110)
    print(f"figure written: {path}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--elevations", default="20,40,60", help="solar elevations [deg], comma list")
    ap.add_argument("--taus", default="0,3,10,20,40,80", help="cloud optical depths at 550 nm, comma list (0 first)")
    ap.add_argument("--aod550", type=float, default=0.1, help="aerosol optical depth at 550 nm")
    ap.add_argument("--figure", default=None, help="write the figure (PNG)")
    args = ap.parse_args(argv)
    try:
        els = [float(x) for x in args.elevations.split(",")]
        taus = [float(x) for x in args.taus.split(",")]
    except ValueError as exc:
        ap.error(f"--elevations/--taus: {exc}")
    if any(not 10.0 < e <= 90.0 for e in els):
        ap.error(f"--elevations: {args.elevations!r} must lie in (10, 90] deg (plane-parallel beam)")
    if any(not 0.0 <= t <= 200.0 for t in taus):
        ap.error(f"--taus: {args.taus!r} must lie in [0, 200]")
    if taus[0] != 0:
        taus = [0.0] + taus
    rows, wl, w, sr = run(els, taus, args.aod550)
    report(rows, wl, w, sr)
    if args.figure:
        figure(rows, wl, w, args.figure)


if __name__ == "__main__":
    main()
