"""Report: fitting error per channel of a polarised dataset build (radiance NMAE and the polarisation's mean absolute
error, the paper's Fig. 10 per channel), with the Monte Carlo noise of the targets, from the build's sidecar and
its cached Monte Carlo states.

    WIDESKY_CACHE_DIR=... python benchmarks/bench_dataset_polarised.py CONFIG DATASET [--plot PNG] [--json OUT]

Noise: the median over directions of the Monte Carlo standard-error bound of I relative to I (the states whose radiance
is Monte Carlo) and of the degree of polarisation (all states), per channel: bounds (sums over the orders of ground
reflection, which share paths), upper estimates. ``--repeat VIS,ELE`` (repeatable) measures the noise directly:
the state solved again with another seed, rms difference / sqrt(2) per channel, of I (relative) and of the signed
degree of polarisation (absolute).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def noise(config) -> dict:
    """Median relative se of I (Monte Carlo radiance states) and median se of P (all states) per channel, albedo 0.5
    (or the grid's middle albedo)."""
    from skymodel.generator.cache import load_state
    from skymodel.generator.dataset_build import _fitted_elevations
    from skymodel.generator.dataset_mc import mc_file, mc_stokes, radiance_by_mc, stored_polarisation

    alb = float(np.median(config.albedos))
    rel_i, se_p = [], []
    for v in config.visibilities_km:
        for e in _fitted_elevations(config):
            m = load_state(mc_file(config, float(v), float(e)))
            p, sp = stored_polarisation(m, alb)
            se_p.append(np.median(sp.reshape(-1, 55), axis=0))
            if radiance_by_mc(config, e):
                s, se = mc_stokes(m, alb)
                i = s[..., 0].reshape(-1, 55)
                rel_i.append(np.median(np.where(i > 0, se[..., 0].reshape(-1, 55) / np.where(i > 0, i, 1), np.nan),
                                       axis=0))
    return {"albedo": alb, "rel_se_i_median": np.nanmedian(rel_i, axis=0).tolist() if rel_i else None,
            "se_p_median": np.median(se_p, axis=0).tolist()}


def repeat_noise(config, visibility_km, elevation_deg) -> dict:
    """Noise of one Monte Carlo state measured against an independent re-solve (seed + 1), albedo as :func:`noise`."""
    from dataclasses import replace

    from skymodel.generator.cache import load_state
    from skymodel.generator.dataset_mc import mc_file, mc_stokes, solve_mc_state, stored_polarisation

    alb = float(np.median(config.albedos))
    a = load_state(mc_file(config, visibility_km, elevation_deg))
    b = solve_mc_state(visibility_km, elevation_deg, replace(config, mc_seed=int(config.mc_seed) + 1))
    ia, ib = (mc_stokes(x, alb)[0][..., 0].reshape(-1, 55) for x in (a, b))
    pa, pb = (stored_polarisation(x, alb)[0].reshape(-1, 55) for x in (a, b))
    ok = (ia > 0) & (ib > 0)
    rel = np.where(ok, (ia - ib) / np.where(ok, 0.5 * (ia + ib), 1.0), np.nan)
    rms = lambda x: np.sqrt(np.nanmean(x ** 2, axis=0)) / np.sqrt(2)  # noqa: E731
    return {"visibility_km": visibility_km, "elevation_deg": elevation_deg, "albedo": alb,
            "rel_noise_i": rms(rel).tolist(), "noise_p": rms(np.where(ok, pa - pb, np.nan)).tolist()}


def main(argv=None):
    from skymodel.generator.channels import CHANNEL_CENTERS_NM
    from skymodel.generator.dataset_build import load_config

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("config")
    ap.add_argument("dataset")
    ap.add_argument("--plot", default=None)
    ap.add_argument("--json", default=None)
    ap.add_argument("--repeat", action="append", default=[], help="VIS,ELE of a state to re-solve with another seed")
    a = ap.parse_args(argv)
    cfg = load_config(a.config)
    meta = json.loads(Path(a.dataset + ".json").read_text())
    pol = meta["monte_carlo"]["polarisation"]
    nm = np.asarray(meta["fit_on_samples"]["nmae_median_per_channel"])
    pm = np.asarray(pol["fit_mae_median_per_channel"])
    nz = noise(cfg)
    out = {"channels_nm": CHANNEL_CENTERS_NM.tolist(), "radiance_nmae_median": nm.tolist(),
           "polarisation_mae_median": pm.tolist(), **nz, "dolp_mean": pol["dolp_mean_per_channel"],
           "abs_qs_mean": pol["abs_qs_over_i_mean_per_channel"], "docp_mean": pol["docp_mean_per_channel"]}
    print(f"{'nm':>6} {'rad NMAE %':>10} {'pol MAE':>8} {'se(I)/I %':>9} {'se(P)':>7} {'DoLP':>6} {'|Qs|/I':>6} "
          f"{'|V|/I':>7}")
    for c, w in enumerate(CHANNEL_CENTERS_NM):
        ri = nz["rel_se_i_median"][c] if nz["rel_se_i_median"] else float("nan")
        print(f"{w:6.0f} {100 * nm[c]:10.2f} {pm[c]:8.4f} {100 * ri:9.2f} {nz['se_p_median'][c]:7.4f} "
              f"{out['dolp_mean'][c]:6.3f} {out['abs_qs_mean'][c]:6.3f} {out['docp_mean'][c]:7.5f}")
    out["repeats"] = []
    for r in a.repeat:
        v, e = (float(x) for x in r.split(","))
        rp = repeat_noise(cfg, v, e)
        out["repeats"].append(rp)
        sel = [3, 5, 10, 20, 27, 40, 50]
        print(f"re-solved vis={v} ele={e}: noise of I [%] / of P at " + ", ".join(
            f"{CHANNEL_CENTERS_NM[c]:.0f} nm {100 * rp['rel_noise_i'][c]:.1f} / {rp['noise_p'][c]:.3f}" for c in sel))
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))
    if a.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
        ax[0].plot(CHANNEL_CENTERS_NM, 100 * nm, "o-", label="radiance fit NMAE (median over states)")
        if nz["rel_se_i_median"]:
            ax[0].plot(CHANNEL_CENTERS_NM, 100 * np.asarray(nz["rel_se_i_median"]), "s:",
                       label="Monte Carlo se(I)/I bound (median, MC radiance states)")
        ax[0].set_ylabel("%")
        ax[0].set_yscale("log")
        ax[0].legend(fontsize=8)
        ax[1].plot(CHANNEL_CENTERS_NM, pm, "o-", label="polarisation fit MAE (median over states)")
        ax[1].plot(CHANNEL_CENTERS_NM, nz["se_p_median"], "s:", label="Monte Carlo se bound of the target (median)")
        ax[1].plot(CHANNEL_CENTERS_NM, out["dolp_mean"], "^-", alpha=0.6, label="mean degree of linear polarisation")
        ax[1].set_ylabel("degree of polarisation [1]")
        ax[1].set_xlabel("channel centre [nm]")
        ax[1].legend(fontsize=8)
        fig.suptitle(f"{Path(a.dataset).name}: fitting error per channel and Monte Carlo noise")
        fig.tight_layout()
        fig.savefig(a.plot, dpi=110)


if __name__ == "__main__":
    main()
