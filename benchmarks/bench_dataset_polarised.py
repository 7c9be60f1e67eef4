"""Report: fitting error per channel of a polarised dataset build (radiance NMAE and the polarisation's mean absolute
error, the paper's Fig. 10 per channel), with the Monte Carlo noise of the targets, from the build's sidecar and
its cached Monte Carlo states.

    WIDESKY_CACHE_DIR=... python benchmarks/bench_dataset_polarised.py CONFIG DATASET [--plot PNG] [--json OUT]

Noise: the median over directions of the Monte Carlo standard-error bound of I relative to I (the states whose radiance
is Monte Carlo) and of the degree of polarisation (all states), per channel: bounds (sums over the orders of ground
reflection, which share paths), upper estimates. ``--repeat VIS,ELE`` (repeatable) measures the noise directly:
the state solved again with another seed, rms difference / sqrt(2) per channel, of I (relative) and of the signed
degree of polarisation (absolute), and how that error varies from one direction of the state's grid to the next
(the correlation of the error between neighbouring azimuths and zeniths, the rms second difference of the error along
the azimuths over its rms, sqrt(6) = 2.45 for independent errors) and the error of the hemisphere-integrated radiance
(cosine-weighted mean over the grid, diffuse horizontal irradiance / pi); ``--streams MODE`` re-solves with that stream
mode (the cached state of that mode must exist). ``--smoothness-tol`` (repeatable) reruns the smoothness check of the
dataset at its Monte Carlo elevations with a larger turning-point tolerance (the amplitude of the ripples that fail).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def noise(config) -> dict:
    """Median relative se of I (Monte Carlo radiance states) and median se of P (all states) per channel, albedo 0.5
    (or the grid's middle albedo)."""
    from widesky.skymodel.generator.cache import load_state
    from widesky.skymodel.generator.dataset_build import _fitted_elevations
    from widesky.skymodel.generator.dataset_mc import mc_file, mc_stokes, radiance_by_mc, stored_polarisation

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


def _grid_weights(zenith_deg, azimuth_deg):
    """Trapezoid weights (T, P) of the cosine-weighted integral over the upper hemisphere of a product grid of view
    zenith (T,) and relative azimuth (P,) in [0, 180] [deg] (mirror-symmetric sky), normalised to 1."""
    th, ph = np.radians(zenith_deg), np.radians(azimuth_deg)
    wt = np.gradient(np.sin(th) ** 2 / 2) if len(th) > 1 else np.ones(1)  # d(sin^2/2) = sin cos dtheta
    wp = np.gradient(ph) if len(ph) > 1 else np.ones(1)
    w = np.abs(wt)[:, None] * np.abs(wp)[None, :]
    return w / w.sum()


def repeat_noise(config, visibility_km, elevation_deg, keep=None) -> dict:
    """Noise of one Monte Carlo state measured against an independent re-solve (seed + 1), albedo as :func:`noise`:
    per channel (55,) the rms over directions of I (relative) and P (absolute), the error's correlation between
    neighbouring azimuths and zeniths, its rms second difference along the azimuths over its rms, and the relative
    error of the hemisphere-integrated radiance; and the share of the almucantars of the state's grid (its zeniths
    but the zenith itself, all channels, both runs) with more than one turning point of I at the smoothness check's
    0.5 % tolerance (a clear sky has one minimum along an almucantar). ``keep``: folder where the re-solve is cached
    (reused when there)."""
    from dataclasses import replace

    from widesky.skymodel.generator.cache import load_state
    from widesky.skymodel.generator.dataset_mc import mc_file, mc_stokes, solve_mc_state, stored_polarisation

    alb = float(np.median(config.albedos))
    a = load_state(mc_file(config, visibility_km, elevation_deg))
    from widesky.skymodel.generator.cache import save_state
    from widesky.skymodel.generator.smoothness import turning_points

    kf = None if keep is None else Path(keep) / f"repeat_{config.mc_streams}_v{visibility_km:g}_e{elevation_deg:g}.npz"
    if kf is not None and kf.exists():
        b = load_state(kf)
    else:
        b = solve_mc_state(visibility_km, elevation_deg, replace(config, mc_seed=int(config.mc_seed) + 1))
        if kf is not None:
            kf.parent.mkdir(parents=True, exist_ok=True)
            save_state(kf, b)
    sa, sb = (mc_stokes(x, alb)[0][..., 0] for x in (a, b))  # (T, P, 55)
    ia, ib = sa.reshape(-1, 55), sb.reshape(-1, 55)
    pa, pb = (stored_polarisation(x, alb)[0].reshape(-1, 55) for x in (a, b))
    ok = (ia > 0) & (ib > 0)
    rel = np.where(ok, (ia - ib) / np.where(ok, 0.5 * (ia + ib), 1.0), np.nan)
    rms = lambda x: np.sqrt(np.nanmean(x ** 2, axis=0)) / np.sqrt(2)  # noqa: E731
    th, ph = a["zenith"], a["azimuth"]
    e = np.nan_to_num(rel.reshape(len(th), len(ph), 55))[1:]  # the zenith row is one direction at every azimuth

    def corr(x, y):
        x, y = x.reshape(-1, 55), y.reshape(-1, 55)
        return np.sum(x * y, axis=0) / np.sqrt(np.sum(x * x, axis=0) * np.sum(y * y, axis=0) + 1e-300)

    d2 = np.sqrt(np.mean(np.diff(e, 2, axis=1).reshape(-1, 55) ** 2, axis=0))
    w = _grid_weights(th, ph)[..., None]
    ha, hb = (np.sum(w * x, axis=(0, 1)) for x in (sa, sb))
    tp = np.stack([turning_points(np.moveaxis(x[1:], 1, -1)) for x in (sa, sb)])  # (2, T-1, 55)
    return {"visibility_km": visibility_km, "elevation_deg": elevation_deg, "albedo": alb,
            "streams": config.mc_streams, "almucantar_tp_gt1_share": np.mean(tp > 1, axis=(0, 1)).tolist(), "rel_noise_i": rms(rel).tolist(),
            "noise_p": rms(np.where(ok, pa - pb, np.nan)).tolist(),
            "corr_azimuth_neighbours": corr(e[:, 1:], e[:, :-1]).tolist(),
            "corr_zenith_neighbours": corr(e[1:], e[:-1]).tolist(),
            "d2_azimuth_over_rms": (d2 / np.sqrt(np.mean(e.reshape(-1, 55) ** 2, axis=0) + 1e-300)).tolist(),
            "rel_noise_hemisphere": (np.abs(ha - hb) / (0.5 * (ha + hb)) / np.sqrt(2)).tolist()}


def smoothness_at_tolerances(config, dataset, tolerances) -> list:
    """The smoothness check of ``dataset`` on its grid states at the Monte Carlo radiance elevations, per turning-point
    tolerance [1]: failing (state, channel) pairs of the checked ones, and how many by almucantar / vertical /
    aureole turning points and zenith spots."""
    from widesky.skymodel.dataset import load_dataset
    from widesky.skymodel.generator.dataset_mc import radiance_by_mc
    from widesky.skymodel.generator.smoothness import ZENITH_SPOT_TOL, check_states, grid_states

    model = load_dataset(dataset)
    states = [s for s in grid_states(model) if radiance_by_mc(config, s[1])]
    out = []
    for tol in tolerances:
        rows = check_states(model, states, float(tol))
        chk = np.array([r["checked"] for r in rows])
        get = lambda k: np.array([r[k] for r in rows])  # noqa: E731
        ele = get("elevation")
        f = get("fails") & chk
        out.append({"rel_tol": float(tol), "checked_pairs": int(chk.sum()), "failing_pairs": int(f.sum()),
                    "almucantar": int(((get("almucantar_tp") > 1) & chk).sum()),
                    "vertical": int(((get("vertical_tp") > 2) & chk).sum()),
                    "aureole": int(((get("aureole_tp") > 1) & chk).sum()),
                    "zenith_spot": int(((get("zenith_spot") > ZENITH_SPOT_TOL) & chk).sum()),
                    "by_elevation": {f"{e:g}": int(f[ele == e].sum()) for e in np.unique(ele)}})
    return out


def main(argv=None):
    from widesky.skymodel.channels import CHANNEL_CENTERS_NM
    from widesky.skymodel.generator.dataset_build import load_config

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("config")
    ap.add_argument("dataset")
    ap.add_argument("--plot", default=None)
    ap.add_argument("--json", default=None)
    ap.add_argument("--repeat", action="append", default=[], help="VIS,ELE of a state to re-solve with another seed")
    ap.add_argument("--keep", default=None, help="folder to cache the re-solved states in (reused)")
    ap.add_argument("--streams", default=None, help="stream mode of the re-solve (default: the configuration's)")
    ap.add_argument("--smoothness-tol", action="append", default=[], type=float,
                    help="turning-point tolerance [1] of a smoothness check at the Monte Carlo elevations")
    a = ap.parse_args(argv)
    cfg = load_config(a.config)
    if a.streams:
        from dataclasses import replace
        cfg = replace(cfg, mc_streams=a.streams)
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
        rp = repeat_noise(cfg, v, e, a.keep)
        out["repeats"].append(rp)
        sel = [3, 5, 10, 20, 27, 40, 50]
        print(f"re-solved vis={v} ele={e} ({cfg.mc_streams} streams): noise of I [%] / of P at " + ", ".join(
            f"{CHANNEL_CENTERS_NM[c]:.0f} nm {100 * rp['rel_noise_i'][c]:.1f} / {rp['noise_p'][c]:.3f}" for c in sel))
        for k, f in (("corr_azimuth_neighbours", "{:.2f}"), ("corr_zenith_neighbours", "{:.2f}"),
                     ("d2_azimuth_over_rms", "{:.2f}"), ("rel_noise_hemisphere", "{:.2%}"),
                     ("almucantar_tp_gt1_share", "{:.2f}")):
            x = np.asarray(rp[k])
            print(f"   {k:26s} " + " ".join(f.format(x[c]) for c in sel) + "   mean over channels " + f.format(x.mean()))
    out["smoothness"] = smoothness_at_tolerances(cfg, a.dataset, a.smoothness_tol) if a.smoothness_tol else []
    for row in out["smoothness"]:
        print(f"smoothness at rel_tol {row['rel_tol']:g}: {row['failing_pairs']} of {row['checked_pairs']} pairs fail "
              f"(almucantar {row['almucantar']}, vertical {row['vertical']}, aureole {row['aureole']}, zenith spot "
              f"{row['zenith_spot']}); by elevation {row['by_elevation']}")
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
