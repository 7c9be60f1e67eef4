"""Where the rings, fringes and spots of the first default dataset came from (issue 11), stage by stage.

For the states the issue names (sun 8 deg at 29.2 km, the grid visibility nearest to its 30 km; sun 45 deg at 40 km,
between grid points) and a few channels, the solver is run on a fine product grid of directions (1 deg zenith x
2 deg azimuth, the reference image) and on the build's fit directions, then fitted, changing one thing at a time:

A  solver, intensity correction from the 256-moment Legendre series (Nakajima-Tanaka; the first file) vs from the
   tabulated phase function (Buras-Emde; now);
B  the fit's direction sampling: the first file's grid (3 deg zenith, 10 deg azimuth beyond 50 deg) vs now
   (2 deg x 5 deg), with the first file's fit settings;
C  the fit settings: emphasis fitted (4 alternations) and penalty 1e-6 (the first file) vs emphasis held at 1 and
   penalty 1e-5 (now);
D  half-float storage of the factors (the writer's encoding) on top of C;
E  the first file itself (rank 6, 40/30/24 knots, interpolated between grid states where the state is between).

Each variant is scored with the smoothness check's metrics (skymodel.generator.smoothness) and its mean absolute
error against the fine-grid solver (the reference image), and drawn: solver vs fit images and the 80 deg almucantar.

Run:  python benchmarks/bench_dataset_artefacts.py --old /path/to/first/default.dat \
          --plot docs/figures/dataset_artefacts
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
import warnings
from pathlib import Path

import numpy as np

STATES = ((29.2, 8.0, (540.0, 1260.0, 380.0)), (40.0, 45.0, (1260.0, 540.0)))
OLD_AZIMUTHS_DEG = np.array([0.0, 0.25, 0.5, 1.0, 1.5, 2.5, 4.0, 6.0, 9.0, 12.5, 17.0, 22.0, 28.0, 35.0, 42.5, 50.0,
                             60.0, 70.0, 80.0, 90.0, 100.0, 110.0, 120.0, 130.0, 140.0, 150.0, 160.0, 170.0, 180.0])


def _solve(vis, ele, channels, th, ph, tabulated, cfg):
    """Radiance (T, P, nC) [W m-2 sr-1 nm-1] of the given channels [index] over a black ground."""
    from widesky.skymodel.generator.dataset_build import _problems
    from widesky.skymodel.generator.solver import SolverConfig, run_disort

    probs, et, _ = _problems(vis, cfg)
    sc = SolverConfig(cfg.n_streams, cfg.n_moments, True, tabulated_phase=tabulated)
    mu0 = np.sin(np.radians(ele))
    out = np.zeros((len(th), len(ph), len(channels)))
    for k, c in enumerate(channels):
        for p in probs[c]:
            out[:, :, k] += p.weight * run_disort(p, mu0, 0.0, th, ph, sc)[0]
        out[:, :, k] *= et[c]
    return out


def _grid(ele, step, azimuths):
    from widesky.skymodel.generator.dataset_grid import SUN_OFFSETS_DEG
    from widesky.skymodel.generator.solver import MAX_VIEW_ZENITH_DEG

    zs = 90.0 - ele
    th = np.concatenate([np.arange(0.0, 89.0, step), [85.5, 87.0, 88.0, 89.0, MAX_VIEW_ZENITH_DEG],
                         zs + SUN_OFFSETS_DEG, zs - SUN_OFFSETS_DEG, [zs]])
    return np.unique(np.round(np.clip(th, 0.0, MAX_VIEW_ZENITH_DEG), 6)), np.asarray(azimuths, float)


def _fit(rad, th, ph, ele, cfg, half=False):
    """Fitted factors of every channel of ``rad`` and an evaluator f(directions) -> (N, nC)."""
    from widesky.skymodel.evaluate import reference_angles
    from widesky.skymodel.generator.dataset_build import config_knots, fit_state
    from widesky.skymodel.generator.fit import hat_weights
    from widesky.skymodel.writer import encode_radiance_blocks

    br = config_knots(cfg)
    sun, zen, emph, _ = fit_state(cfg, th, ph, rad, ele, br)
    if half:
        b = encode_radiance_blocks(sun, zen, emph)
        sun, emph = b["r"]["sun"].astype(float), b["emph"].astype(float)
        zen = b["r"]["zen"].astype(float) / b["r"]["scale"][..., None]

    def f(dirs):
        a = reference_angles(dirs, ele, 180.0)
        ig, gl, gh = hat_weights(a["gamma"], br[0])
        ia, al, ah = hat_weights(a["zero"], br[1])
        iz, zl, zh = hat_weights(a["zero"], br[2])
        s = sun[..., ig] * gl + sun[..., ig + 1] * gh
        z = zen[..., ia] * al + zen[..., ia + 1] * ah
        e = emph[..., iz] * zl + emph[..., iz + 1] * zh
        return np.maximum(e * np.sum(s * z, axis=1), 0.0).T

    return f


def _solver_lookup(ref, th, ph):
    """Bilinear lookup of the fine-grid solver radiance at directions (east-north-up, sun at azimuth 180)."""
    from scipy.interpolate import RegularGridInterpolator

    interp = RegularGridInterpolator((th, ph), ref, bounds_error=False, fill_value=None)

    def f(dirs):
        v = dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)
        z = np.degrees(np.arccos(np.clip(v[:, 2], -1, 1)))
        az = np.degrees(np.arctan2(v[:, 0], v[:, 1])) % 360.0
        rel = np.abs(((az - 180.0) + 180.0) % 360.0 - 180.0)
        return interp(np.stack([np.minimum(z, th[-1]), rel], -1))
    return f


def _score(f, ele, ref_f):
    from widesky.skymodel.generator import smoothness as S

    d = S.profile_directions(ele)
    rad = {k: f(d[k].reshape(-1, 3)).reshape(d[k].shape[:-1] + (-1,))
           for k in ("almucantar", "vertical", "aureole", "zenith")}
    m = S.profile_metrics(rad, d["aureole_valid"][..., None], ele)
    # error against the reference image over the hemisphere (5 deg cells, solid-angle weighted)
    th = np.arange(2.5, 89.0, 2.5)
    ph = np.arange(1.25, 360.0, 2.5)
    T, P = np.meshgrid(th, ph, indexing="ij")
    dirs = S._enu(T.ravel(), P.ravel())
    w = np.sin(np.radians(T)).ravel()[:, None]
    mod, ref = f(dirs), ref_f(dirs)
    nmae = np.sum(w * np.abs(mod - ref), 0) / np.sum(w * ref, 0)
    return {k: np.asarray(v).tolist() for k, v in m.items()} | {"nmae": nmae.tolist()}


def run(old_path=None, plot=None):
    from widesky.skymodel import load_dataset
    from widesky.skymodel.evaluate import sky_radiance
    from widesky.skymodel.generator.dataset_build import AZIMUTHS_DEG, load_config

    cfg = load_config("skymodel/data/default-dataset-plane-parallel.json")
    old_cfg = dataclasses.replace(cfg, iterations=4, smoothing=1e-6)
    old = load_dataset(old_path) if old_path else None
    results = []
    for vis, ele, wls in STATES:
        chans = [int(round((w - 300.0) / 40.0)) for w in wls]
        t0 = time.perf_counter()
        th_f = np.unique(np.concatenate([np.arange(0.0, 89.0, 1.0), [89.5, 89.95], 90.0 - ele + np.array([0.0])]))
        ph_f = np.unique(np.concatenate([np.arange(0.0, 180.1, 2.0), [0.25, 0.5, 1.0, 1.5]]))
        ref = _solve(vis, ele, chans, th_f, ph_f, True, cfg)
        ref_nt = _solve(vis, ele, chans, th_f, ph_f, False, cfg)
        th_o, ph_o = _grid(ele, 3.0, OLD_AZIMUTHS_DEG)
        th_n, ph_n = _grid(ele, cfg.zenith_step_deg, AZIMUTHS_DEG)
        nt_old = _solve(vis, ele, chans, th_o, ph_o, False, cfg)
        tab_old = _solve(vis, ele, chans, th_o, ph_o, True, cfg)
        tab_new = _solve(vis, ele, chans, th_n, ph_n, True, cfg)
        variants = {
            "A: solver, Legendre-series correction": _solver_lookup(ref_nt, th_f, ph_f),
            "A: solver, tabulated phase function": _solver_lookup(ref, th_f, ph_f),
            "fit: first file's pipeline (NT solver, old grid, old settings)": _fit(nt_old, th_o, ph_o, ele, old_cfg),
            "B: tabulated solver, old grid, old settings": _fit(tab_old, th_o, ph_o, ele, old_cfg),
            "B: tabulated solver, new grid, old settings": _fit(tab_new, th_n, ph_n, ele, old_cfg),
            "C: new grid, new settings (emphasis 1, penalty 1e-5)": _fit(tab_new, th_n, ph_n, ele, cfg),
            "D: as C, half-float factors": _fit(tab_new, th_n, ph_n, ele, cfg, half=True),
        }
        if old is not None:
            def old_f(dirs, vis=vis, ele=ele, chans=chans):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    return sky_radiance(old, dirs, ele, 180.0, vis, 0.0, channels=chans)
            variants["E: the first default.dat"] = old_f
        ref_f = _solver_lookup(ref, th_f, ph_f)
        scores = {k: _score(f, ele, ref_f) for k, f in variants.items()}
        # the profile of the figure straight from the solver at 0.5 deg steps (finer than the reference image's grid,
        # which is too coarse for the Legendre series' ringing, period about 1.4 deg in scattering angle)
        x, th_p, ph_p = _profile(ele)
        direct = {"A: solver, Legendre-series correction": _solve(vis, ele, chans[:1], th_p, ph_p, False, cfg),
                  "A: solver, tabulated phase function": _solve(vis, ele, chans[:1], th_p, ph_p, True, cfg)}
        for k, v in direct.items():
            scores[k]["profile_turning_points"] = int(_tp(v, ele))
        results.append({"visibility": vis, "elevation": ele, "wavelengths_nm": list(wls), "scores": scores,
                        "seconds": round(time.perf_counter() - t0, 1)})
        if plot:
            _plot(variants, direct, vis, ele, wls, f"{plot}_{ele:g}deg.png")
    return results


def _profile(ele):
    """The figure's profile: the 80 deg almucantar (sun below 20 deg) or the solar meridian through the zenith:
    (x [deg], view zeniths, relative azimuths) as solver product grids."""
    if ele < 20:
        return np.arange(0.0, 180.01, 0.5), np.array([80.0]), np.arange(0.0, 180.01, 0.5)
    zz = np.arange(0.0, 10.01, 0.25)
    return np.concatenate([-zz[::-1], zz[1:]]), zz, np.array([0.0, 180.0])


def _as_profile(solved, ele):
    """Solver output of :func:`_profile`'s grid as a 1-D profile (first channel)."""
    if ele < 20:
        return solved[0, :, 0]
    return np.concatenate([solved[::-1, 0, 0], solved[1:, 1, 0]])


def _tp(solved, ele):
    from widesky.skymodel.generator.smoothness import turning_points
    return turning_points(_as_profile(solved, ele))


def _plot(variants, direct, vis, ele, wls, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from widesky.skymodel.colour import srgb_encode
    from widesky.skymodel.generator import smoothness as S
    from widesky.skymodel.render import fisheye_directions

    view, vaz = ("side", 200.0) if ele < 20 else ("up", 180.0)
    dirs, mask = fisheye_directions(220, view, vaz)
    mask = mask & (dirs[..., 2] >= 0)
    keys = [k for k in variants if not k.startswith("B: tabulated solver, old grid")]
    fig = plt.figure(figsize=(2.3 * len(keys), 5.0 if view == "side" else 5.8))
    gs = fig.add_gridspec(2, len(keys), height_ratios=[0.6 if view == "side" else 1.0, 0.9])
    for j, k in enumerate(keys):
        img = np.zeros(mask.shape)
        img[mask] = variants[k](dirs[mask])[:, 0]
        ref = np.percentile(img[mask], 99.0)
        ax = fig.add_subplot(gs[0, j])
        shown = srgb_encode(img / ref)
        if view == "side":
            shown = shown[: shown.shape[0] // 2 + 2]  # the sky half (the ground is dark)
        ax.imshow(shown, cmap="gray", vmin=0, vmax=1)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(k.replace(", ", ",\n", 1), fontsize=6.5)
    ax = fig.add_subplot(gs[1, :])
    x, th_p, ph_p = _profile(ele)
    if ele < 20:
        d = S._enu(np.full(len(x), 80.0), 180.0 + x)
        xl = "relative azimuth along the 80 deg almucantar [deg]"
    else:
        d = S._enu(np.abs(x), np.where(x < 0, 180.0, 0.0))  # the sun is at azimuth 180
        xl = "view zenith along the solar meridian [deg] (negative toward the sun)"
    for k in keys:
        y = _as_profile(direct[k], ele) if k in direct else variants[k](d)[:, 0]
        ax.plot(x, y, lw=1.6 if k.startswith("A") else 1.0, ls=":" if k.startswith("A: solver, L") else "-", label=k)
    ax.set_yscale("log")
    ax.set_xlabel(xl)
    ax.set_ylabel(f"radiance {wls[0]:.0f} nm [W m-2 sr-1 nm-1]")
    ax.legend(fontsize=6, ncol=2)
    fig.suptitle(f"{vis:g} km, sun {ele:g} deg, {wls[0]:.0f} nm, albedo 0 ({view} view)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", default=None, help="the first default.dat (variant E)")
    ap.add_argument("--plot", default=None, help="figure path prefix (adds _<elevation>deg.png)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    res = run(a.old, a.plot)
    for r in res:
        print(f"\n{r['visibility']} km, sun {r['elevation']} deg ({r['seconds']} s); channels {r['wavelengths_nm']}")
        print("| variant | almucantar turning points (max) | vertical | aureole ray | zenith spot [%] | "
              "NMAE vs solver [%] |")
        print("|---|---|---|---|---|---|")
        for k, s in r["scores"].items():
            if "profile_turning_points" in s:
                print(f"| {k}: the figure's profile at 0.5 deg steps | {s['profile_turning_points']} turning points "
                      "| | | | |")
            f = lambda v, p=False: " / ".join(f"{100 * x:.1f}" if p else f"{x:g}" for x in v)  # noqa: E731
            print(f"| {k} | {f(s['almucantar_tp'])} | {f(s['vertical_tp'])} | {f(s['aureole_tp'])} | "
                  f"{f(s['zenith_spot'], True)} | {f(s['nmae'], True)} |")
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
