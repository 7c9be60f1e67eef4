"""Monte Carlo reference solver: validation reports, spherical correction, convergence and speed.

Subcommands (each prints its numbers; the figure ones write docs/figures/mc_*.png atomically):

- ``cds``: polarised Rayleigh slab (tau 0.5, mu0 0.2, albedo 0 and 0.8) against the corrected Coulson-Dave-Sekera
  tables of Natraj et al. (2009) at many samples (I, Q, U differences and their standard errors);
- ``disort``: scalar Monte Carlo (planet radius 1e6 km) against DISORT at high sun: radiances and the
  hemisphere-averaged radiance (diffuse horizontal irradiance / pi) per channel;
- ``spherical``: the spherical correction of the diffuse horizontal irradiance per channel, DHI in spherical shells
  over DHI in plane-parallel slabs (same seeds), at low sun, DISORT over plane-parallel Monte Carlo as the control,
  and the twilight sky (sun at -2 deg) -> docs/figures/mc_spherical_correction.png;
- ``hero``: 4 neighbouring channels sharing paths (hero wavelengths) against one channel per path: time, noise
  and efficiency;
- ``convergence``: relative error against samples per direction per channel (a saturated water band included)
  against a long reference run, with the estimated standard error and paths per second ->
  docs/figures/mc_convergence.png.

- ``estimators``: the two first-order methods (``first_order="sampled"``, the original estimator, and
  ``"quadrature"``, first order by quadrature with the sunlit-importance mixtures) against samples per direction at
  twilight (-2 deg) and at 36 deg, 4-channel batches as the dataset build, the variant's state (visibility 51.3 km,
  albedo 0.5), 24 directions down to the horizon: rms relative error of I and absolute error of the degree of
  polarisation against a long run of the new estimator (its own variance subtracted), CPU time per path, and the
  efficiency 1 / (error^2 x time) -> docs/figures/mc_estimators.png (``--json`` writes the numbers).

- ``streams``: independent against correlated random streams (common random numbers across directions) at the same
  paths (1280 per direction and 4-channel batch, the variant's budget), the variant's state (51.3 km, albedo 0.5),
  channels 420-540 nm, sun at -2 and 36 deg: along the almucantars at view zenith 60 and 85 deg (every 2 deg of
  relative azimuth) the per-direction error (two seeds: rms difference / sqrt 2, and the rms standard error), the
  correlation of the error between directions 2, 6, 10 and 20 deg apart, the rms second difference of the error
  field (sqrt(6) x the error for independent errors), and the error of the hemisphere-integrated radiance (the
  cosine-weighted mean over 256 Latin-hypercube directions, DHI / pi), which independent errors average down and
  correlated ones do not.

Usage: ``python benchmarks/bench_montecarlo.py {cds,disort,spherical,convergence,hero,estimators,streams}
[--quick]``.
Single-threaded kernel (threads=1) unless ``--threads N``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from widesky.core.atomic import atomic_write
from widesky.skymodel.generator.montecarlo import (MonteCarloConfig, hemisphere_directions, rayleigh_slab, solve_sky_mc,
                                           trace)
from widesky.skymodel.generator.solver import SkyState, solve_sky

FIG = Path(__file__).resolve().parents[1] / "docs" / "figures"
STATE = dict(aod550=0.2, ground_albedo=0.2)


def _save(fig, name):
    FIG.mkdir(parents=True, exist_ok=True)
    out = FIG / name
    with atomic_write(out) as tmp:
        fig.savefig(tmp, dpi=110)
    print(f"wrote {out}")


def _cds_reference():
    import importlib.util

    p = Path(__file__).resolve().parents[1] / "tests" / "generator" / "test_montecarlo_validation.py"
    spec = importlib.util.spec_from_file_location("mc_validation", p)
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    return m


def cds(a):
    m = _cds_reference()
    n = 20000 if a.quick else 400000
    for alb, ref in m.CDS_REFLECTED.items():
        r = m.run_cds(alb, n, threads=a.threads)
        st, se = r.stokes[:, 0, :3] * np.pi, r.stderr[:, 0, :3] * np.pi
        print(f"albedo {alb}: {r.samples} paths per direction, {r.seconds:.1f} s")
        print("   mu   phi |      I ref   dI/I [%] +- se |      Q ref  dQ/I [%] +- se |      U ref  dU/I [%] +- se")
        for i, (mu, ph) in enumerate(zip(m.CDS_MU, m.CDS_PHI)):
            ir, qr, ur = ref[i]
            mc = st[i] * np.array([1, m.Q_SIGN, 1])
            print(f" {mu:4.2f} {ph:5.0f} | {ir:10.6f} {100 * (mc[0] / ir - 1):+7.3f} {100 * se[i, 0] / ir:5.3f} | "
                  f"{qr:10.6f} {100 * (mc[1] - qr) / ir:+7.3f} {100 * se[i, 1] / ir:5.3f} | "
                  f"{ur:10.6f} {100 * (mc[2] - ur) / ir:+7.3f} {100 * se[i, 2] / ir:5.3f}")


def disort(a):
    n = 4000 if a.quick else 40000
    nh = 4000 if a.quick else 60000
    vz, va = [0, 30, 60, 80, 45], [0, 90, 180, 180, 0]
    hz, ha = hemisphere_directions(nh, 3)
    for ch in ([5] if a.quick else [2, 5, 14, 27, 40]):
        st = SkyState(60.0, **STATE)
        d = solve_sky(st, channels=[ch], processes=1, view_zenith_deg=vz, relative_azimuth_deg=va)
        cfg = MonteCarloConfig(samples=n, polarised=False, planet_radius_km=1e6, threads=a.threads)
        m = solve_sky_mc(st, view_zenith_deg=vz, relative_azimuth_deg=va, channels=[ch], config=cfg)
        h = solve_sky_mc(st, view_zenith_deg=hz, relative_azimuth_deg=ha, channels=[ch],
                         config=MonteCarloConfig(samples=1, polarised=False, planet_radius_km=1e6, threads=a.threads))
        dhi = np.pi * h.radiance.mean()
        sdhi = np.pi * h.radiance.std() / np.sqrt(len(hz))
        print(f"channel {ch} ({m.wavelength_nm[0]:.0f} nm): radiance MC/DISORT - 1 [%] "
              + " ".join(f"{100 * x:+.2f}" for x in (m.radiance[:, 0] / d.radiance[:, 0] - 1))
              + " (se " + " ".join(f"{100 * x:.2f}" for x in m.stderr[:, 0, 0] / m.radiance[:, 0]) + ")"
              + f"; DHI {100 * (dhi / d.dhi[0] - 1):+.2f} % (se {100 * sdhi / dhi:.2f} %); "
              f"MC {m.seconds + h.seconds:.1f} s, DISORT {d.seconds:.1f} s")


def spherical(a):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    chans = [0, 2, 5, 9, 14, 19, 24, 27, 32, 39, 44, 50] if not a.quick else [2, 14]
    elevs = [10.0, 3.0] if not a.quick else [4.0]
    nh = 1500 if a.quick else 8000
    hz, ha = hemisphere_directions(nh, 5)
    rows = {}
    t0 = time.perf_counter()
    for el in elevs:
        st = SkyState(el, **STATE)
        d = solve_sky(st, channels=chans, processes=1)
        sph = solve_sky_mc(st, view_zenith_deg=hz, relative_azimuth_deg=ha, channels=chans,
                           config=MonteCarloConfig(samples=1, seed=11, threads=a.threads))
        pp = solve_sky_mc(st, view_zenith_deg=hz, relative_azimuth_deg=ha, channels=chans,
                          config=MonteCarloConfig(samples=1, seed=11, planet_radius_km=None, threads=a.threads))
        e_s, e_p = np.pi * sph.radiance.mean(0), np.pi * pp.radiance.mean(0)
        se = np.sqrt(np.var(sph.radiance / sph.radiance.mean(0) - pp.radiance / pp.radiance.mean(0), axis=0)
                     / len(hz))
        se_pp = np.pi * pp.radiance.std(0) / np.sqrt(len(hz)) / e_p
        rows[el] = (e_s / e_p, se, d.dhi / e_p, e_s, d.dhi, se_pp * d.dhi / e_p)
        print(f"elevation {el:5.1f} deg: DHI spherical / plane-parallel (MC, same seeds) per channel:")
        for j, c in enumerate(chans):
            print(f"   {sph.wavelength_nm[j]:6.0f} nm  sph/pp {e_s[j] / e_p[j]:.4f} +- {se[j]:.4f}   DISORT/pp-MC "
                  f"{d.dhi[j] / e_p[j]:.4f} +- {se_pp[j] * d.dhi[j] / e_p[j]:.4f}   DHI sph {e_s[j]:.4g} W m-2 nm-1")
    st = SkyState(1.0, **STATE)
    tw = solve_sky_mc(st, view_zenith_deg=hz, relative_azimuth_deg=ha, channels=chans, solar_elevation_deg=-2.0,
                      config=MonteCarloConfig(samples=4, seed=13, threads=a.threads))
    tdhi = np.pi * tw.radiance.mean(0)
    tse = np.pi * tw.radiance.std(0) / np.sqrt(len(hz))
    print("twilight, sun at -2 deg: DHI [W m-2 nm-1] " + " ".join(f"{x:.3g}+-{s:.1g}" for x, s in zip(tdhi, tse)))
    print(f"total {time.perf_counter() - t0:.0f} s")
    wl = tw.wavelength_nm
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for el, (ratio, se, ctrl, _, _, se_c) in rows.items():
        l = ax[0].errorbar(wl, ratio, yerr=2 * se, marker="o", ms=4, capsize=2, label=f"MC spherical / MC plane-par., "
                           f"elev. {el:g} deg")
        ax[0].errorbar(wl + 8, ctrl, yerr=2 * se_c, ls=":", marker="x", capsize=2, color=l[0].get_color(),
                       label=f"DISORT / MC plane-par., {el:g} deg")
    ax[0].axhline(1.0, color="k", lw=0.8)
    ax[0].set_xlabel("channel centre [nm]")
    ax[0].set_ylabel("diffuse horizontal irradiance ratio [1]")
    ax[0].set_title("Spherical correction of the diffuse sky (error bars 2 se)")
    ax[0].legend(fontsize=7)
    ax[1].errorbar(wl, tdhi, yerr=2 * tse, marker="o", ms=4, capsize=2, color="k", label="sun at -2 deg (MC spherical)")
    for i, (el, (_, _, _, e_s, _, _)) in enumerate(rows.items()):
        ax[1].plot(wl, e_s, lw=1, color=f"C{i}", label=f"elev. {el:g} deg (MC spherical)")
    ax[1].set_yscale("log")
    ax[1].set_xlabel("channel centre [nm]")
    ax[1].set_ylabel("DHI [W m-2 nm-1]")
    ax[1].set_title("Diffuse horizontal irradiance, low sun and twilight")
    ax[1].legend(fontsize=7)
    fig.suptitle(f"US standard atmosphere, continental average AOD550 0.2, albedo 0.2; {nh} stratified directions",
                 fontsize=9)
    fig.tight_layout()
    _save(fig, "mc_spherical_correction.png")


def convergence(a):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    chans = {5: "500 nm", 14: "860 nm", 27: "1380 nm (saturated H2O)", 40: "1900 nm (saturated H2O)"}
    if a.quick:
        chans = {5: "500 nm", 27: "1380 nm (saturated H2O)"}
    st = SkyState(30.0, **STATE)
    vz = np.array([0.0, 30.0, 60.0, 80.0, 60.0, 85.0])
    va = np.array([0.0, 90.0, 180.0, 180.0, 10.0, 0.0])
    n_ref = 16384 if a.quick else 131072
    ns = [64, 256, 1024, 4096] if a.quick else [64, 256, 1024, 4096, 16384]
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for ch, name in chans.items():
        cfg = dict(polarised=True, threads=a.threads, channels_per_batch=1)
        ref = solve_sky_mc(st, view_zenith_deg=vz, relative_azimuth_deg=va, channels=[ch],
                           config=MonteCarloConfig(samples=n_ref, seed=999, **cfg))
        I0 = ref.radiance[:, 0]
        err, est = [], []
        reps = 2 if a.quick else 4
        for i, n in enumerate(ns):
            e2, s2 = [], []
            for rep in range(reps):  # independent repetitions: rms over directions x repetitions
                r = solve_sky_mc(st, view_zenith_deg=vz, relative_azimuth_deg=va, channels=[ch],
                                 config=MonteCarloConfig(samples=n, seed=100 + 10 * i + rep, **cfg))
                e2.append((r.radiance[:, 0] / I0 - 1) ** 2)
                s2.append((r.stderr[:, 0, 0] / I0) ** 2)
            err.append(np.sqrt(np.mean(e2)))
            est.append(np.sqrt(np.mean(s2)))
        pps = ref.samples * len(vz) / ref.seconds
        l = ax.loglog(ns, err, marker="o", label=f"{name}: rms error ({pps:.0f} paths/s)")
        ax.loglog(ns, est, ls=":", color=l[0].get_color())
        print(f"channel {ch} {name}: {ref.samples} reference paths per direction, reference se "
              f"{100 * np.max(ref.stderr[:, 0, 0] / I0):.2f} % max, {pps:.0f} paths/s; rms rel. error vs samples: "
              + ", ".join(f"{n}: {100 * e:.2f} %" for n, e in zip(ns, err)))
    ax.loglog(ns, [0.5 / np.sqrt(n) for n in ns], color="k", lw=0.8, ls="--", label="slope -1/2")
    ax.axhline(0.005, color="grey", lw=0.8)
    ax.set_xlabel("paths per view direction")
    ax.set_ylabel("relative error of the radiance I [1]")
    ax.set_title("Monte Carlo convergence (6 directions x 4 repetitions, sun at 30 deg; dotted: estimated se)",
                 fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    _save(fig, "mc_convergence.png")


def hero(a):
    """Hero wavelengths: 4 neighbouring channels on shared paths vs one channel per path, same samples per
    direction: wall time, mean relative standard error and the efficiency 1 / (se^2 t), ratio batched / single."""
    st = SkyState(30.0, **STATE)
    vz = np.array([0.0, 30.0, 60.0, 80.0, 60.0, 85.0])
    va = np.array([0.0, 90.0, 180.0, 180.0, 10.0, 0.0])
    n = 1024 if a.quick else 8192
    for chans in ([5, 6, 7, 8], [24, 25, 26, 27]):
        res = {}
        for nb in (1, 4):
            r = solve_sky_mc(st, view_zenith_deg=vz, relative_azimuth_deg=va, channels=chans,
                             config=MonteCarloConfig(samples=n, seed=31, channels_per_batch=nb, threads=a.threads))
            rel = np.mean(r.stderr[..., 0] / r.radiance, axis=0)
            res[nb] = (r.seconds, rel)
            print(f"channels {chans} batch {nb}: {r.seconds:.1f} s, se/I per channel "
                  + " ".join(f"{100 * x:.2f} %" for x in rel))
        eff = (res[1][0] * res[1][1] ** 2) / (res[4][0] * res[4][1] ** 2)
        print("   efficiency batched / single per channel: " + " ".join(f"{x:.2f}" for x in eff))


EST_CHANNELS = {5: ([4, 5, 6, 7], "500 nm"), 14: ([12, 13, 14, 15], "860 nm"),
                27: ([24, 25, 26, 27], "1380 nm (saturated H2O)"), 40: ([38, 39, 40, 41], "1900 nm (saturated H2O)")}


def _dolp(r):
    return np.hypot(r.stokes[..., 1], r.stokes[..., 2]) / r.radiance


def estimators(a):
    """Old (sampled first order) against new (first order by quadrature) estimator: error against paths."""
    import json

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    vz = np.repeat([0.0, 30.0, 60.0, 80.0, 87.0, 89.95], 4)
    va = np.tile([0.0, 55.0, 105.0, 180.0], 6)
    st = SkyState(45.0, visibility_km=51.3, ground_albedo=0.5)
    n_ref = 8192 if a.quick else 65536
    ns = [128, 512, 2048] if a.quick else [128, 512, 2048, 8192]
    reps = 2
    chans = dict(list(EST_CHANNELS.items())[::2]) if a.quick else EST_CHANNELS
    out = {"paths": ns, "reference_paths": n_ref, "directions": len(vz), "results": []}
    fig, axes = plt.subplots(2, 2, figsize=(11, 8))
    for col, el in enumerate((-2.0, 36.0)):
        for ch, (batch, name) in chans.items():
            j = batch.index(ch)
            ref = solve_sky_mc(st, None, vz, va, batch, MonteCarloConfig(samples=n_ref, seed=7, threads=a.threads),
                               solar_elevation_deg=el)
            I0, P0 = ref.radiance[:, j], _dolp(ref)[:, j]
            ref_var_i = np.mean((ref.stderr[:, j, 0] / I0) ** 2)
            for fo, ls in (("sampled", ":"), ("quadrature", "-")):
                ei, ep, cpu = [], [], 0.0
                for i, n in enumerate(ns):
                    e2, p2 = [], []
                    for rep in range(reps):
                        t0 = time.process_time()
                        r = solve_sky_mc(st, None, vz, va, batch,
                                         MonteCarloConfig(samples=n, seed=1000 + 10 * i + rep, first_order=fo,
                                                          threads=a.threads), solar_elevation_deg=el)
                        cpu += time.process_time() - t0
                        e2.append((r.radiance[:, j] / I0 - 1) ** 2)
                        p2.append((_dolp(r)[:, j] - P0) ** 2)
                    ei.append(float(np.sqrt(max(np.mean(e2) - ref_var_i, 0.0))))
                    ep.append(float(np.sqrt(np.mean(p2))))
                us = 1e6 * cpu / (reps * sum(ns) * len(vz))
                out["results"].append({"elevation_deg": el, "channel": ch, "name": name, "first_order": fo,
                                       "rms_rel_error_i": ei, "rms_abs_error_dolp": ep,
                                       "cpu_us_per_path_and_batch": us})
                print(f"{el:+.0f} deg {name:24s} {fo:10s}: rms rel. error of I " +
                      ", ".join(f"{n}: {100 * e:.2f} %" for n, e in zip(ns, ei)) + "; DoLP " +
                      ", ".join(f"{e:.4f}" for e in ep) + f"; {us:.1f} us per path and batch", flush=True)
                c = {5: "C0", 14: "C1", 27: "C2", 40: "C3"}[ch]
                axes[0, col].loglog(ns, ei, ls=ls, marker="o", color=c, label=f"{name}, {fo}")
                axes[1, col].loglog(ns, ep, ls=ls, marker="o", color=c, label=f"{name}, {fo}")
        for row, q in enumerate(("relative error of I [1]", "absolute error of the DoLP [1]")):
            ax = axes[row, col]
            ax.loglog(ns, [(0.5 if row == 0 else 0.2) * (ns[0] / n) ** 0.5 for n in ns], color="k", lw=0.6, ls="--")
            ax.axhline(0.005, color="grey", lw=0.8)
            ax.set_xlabel("paths per view direction and 4-channel batch")
            ax.set_ylabel("rms " + q)
            ax.set_title(f"sun at {el:+.0f} deg (dotted: sampled first order, solid: quadrature)", fontsize=9)
            ax.grid(True, which="both", lw=0.3)
        axes[0, col].legend(fontsize=6)
    fig.suptitle(f"Monte Carlo estimators: {len(vz)} directions (zenith 0-89.95 deg) x {reps} repetitions, "
                 f"visibility 51.3 km, albedo 0.5; reference {n_ref} paths (its variance subtracted)", fontsize=9)
    fig.tight_layout()
    _save(fig, "mc_estimators.png")
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))


def streams(a):
    """Independent against correlated streams: per-direction and direction-to-direction error, hemisphere error."""
    import json

    st = SkyState(45.0, visibility_km=51.3, ground_albedo=0.5)
    batch, n = [3, 4, 5, 6], (320 if a.quick else 1280)
    az = np.arange(0.0, 181.0, 2.0)
    hz, ha = hemisphere_directions(64 if a.quick else 256, seed=3)
    out = []
    print(f"{n} paths per direction and 4-channel batch, channels 420-540 nm (numbers: the mean over the 4)")
    for el in (-2.0, 36.0):
        fo = "quadrature" if el < 5 else "sampled"  # the build's choice (dataset_mc.MC_FIRST_ORDER)
        for mode in ("independent", "correlated"):
            cfg = lambda seed: MonteCarloConfig(samples=n, seed=seed, first_order=fo, streams=mode,  # noqa: E731
                                                threads=a.threads)
            row = {"elevation_deg": el, "streams": mode, "almucantars": []}
            for vz in (60.0, 85.0):
                r1, r2 = (solve_sky_mc(st, None, np.full(az.shape, vz), az, batch, cfg(s), solar_elevation_deg=el)
                          for s in (1, 2))
                m = 0.5 * (r1.radiance + r2.radiance)
                e = (r1.radiance - r2.radiance) / m / np.sqrt(2)
                rms = float(np.sqrt(np.mean(e ** 2)))
                se = float(np.sqrt(np.mean((r1.stderr[..., 0] / r1.radiance) ** 2)))
                lags = {2 * k: float(np.mean([np.corrcoef(e[:-k, c], e[k:, c])[0, 1] for c in range(4)]))
                        for k in (1, 3, 5, 10)}
                d2 = float(np.sqrt(np.mean(np.diff(e, 2, axis=0) ** 2)))
                row["almucantars"].append({"view_zenith_deg": vz, "rms_error": rms, "rms_stderr": se,
                                           "error_correlation_at_lag_deg": lags, "rms_second_difference": d2})
                print(f"{el:+.0f} deg, {mode:11s}, zenith {vz:.0f}: error {100 * rms:.2f} % (se {100 * se:.2f} %); "
                      "correlation at " + ", ".join(f"{k} deg {v:.2f}" for k, v in lags.items()) +
                      f"; rms 2nd difference {100 * d2:.2f} % ({d2 / rms:.2f} x the error)", flush=True)
            h = [solve_sky_mc(st, None, hz, ha, batch, cfg(s), solar_elevation_deg=el).radiance.mean(axis=0)
                 for s in range(11, 19)]
            hd = [(h[i] - h[i + 1]) / (0.5 * (h[i] + h[i + 1])) / np.sqrt(2) for i in range(0, 8, 2)]
            row["hemisphere_rel_error"] = float(np.sqrt(np.mean(np.square(hd))))
            print(f"{el:+.0f} deg, {mode:11s}: hemisphere-integrated radiance ({len(hz)} directions) error "
                  f"{100 * row['hemisphere_rel_error']:.2f} % (four pairs of seeds)", flush=True)
            out.append(row)
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=["cds", "disort", "spherical", "convergence", "hero", "estimators", "streams"])
    ap.add_argument("--quick", action="store_true", help="few samples (a smoke run)")
    ap.add_argument("--threads", type=int, default=1, help="kernel OpenMP threads")
    ap.add_argument("--json", help="estimators, streams: write the numbers to this JSON file")
    a = ap.parse_args()
    {"cds": cds, "disort": disort, "spherical": spherical, "convergence": convergence, "hero": hero,
     "estimators": estimators, "streams": streams}[a.what](a)


if __name__ == "__main__":
    main()
