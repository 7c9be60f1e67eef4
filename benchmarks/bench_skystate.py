"""Benchmark: grouping equal sky states over a year — speed-up and the error it causes.

Run: ``python benchmarks/bench_skystate.py [--quick] [--no-real]``.

For each time series (a weather year, a clear-sky hourly year, a clear-sky 15-min year) and each
grouping resolution it prints: evaluated steps, distinct skies, the time to evaluate the sky for
every step (baseline, measured in the same run) and for every distinct sky plus grouping and
gathering, the ratio, and the error grouping causes on diffuse irradiance:

- per step, the relative error of the sky-diffuse irradiance on a horizontal and on a south-facing
  vertical plane (95th percentile and maximum over steps with more than 5 W m-2 horizontal),
- over the year, the relative error of the annual sums on both planes.

Two sky functions are used:

1. a smooth *stand-in* sky: the CIE general sky (CIE S 011/E:2003) gradation and indicatrix
   functions, their parameters blended from standard type 12 (clear, low turbidity) at 131.8 km to
   type 13 (clear, polluted) at 20 km visibility, with a zenith radiance growing smoothly with solar
   elevation and a (1 + 0.3 albedo) ground-reflection factor. It is not the Prague Sky Model, only a
   function of the same state with realistic angular gradients;
2. ``widesky.skymodel.sky_radiance`` — the real evaluator — on a *synthetic* PSM-format dataset
   (``widesky.skymodel.synthetic``: right structure, not physical values), 55 channels; its errors show the
   effect of grouping through the real interpolation, its times the real per-state cost.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from widesky import irradiance
from widesky.irradiance.location import Site, daytime_steps
from widesky.irradiance.skystate import GroupingSteps, group_sky_states, sky_states
from widesky.irradiance.weather import read_epw

SHARED = Path(os.environ.get("WIDESKY_SHARED_DATA",
                             Path(__file__).resolve().parents[1].parent / "shared" / "data"))
EPW = SHARED / "weather" / "NLD_Amsterdam062400_IWEC.epw"
SAMPLE = Path(irradiance.__file__).parent / "data" / "sample_golden_june.epw"

SETTINGS = {
    "fine (0.1 deg, 0.5 deg, 1 %, 0.01)": GroupingSteps(0.1, 0.5, 0.01, 0.01),
    "default (0.25 deg, 1 deg, 2 %, 0.01)": GroupingSteps(),
    "coarse (0.5 deg, 2 deg, 5 %, 0.05)": GroupingSteps(0.5, 2.0, 0.05, 0.05),
    "default, azimuth not grouped (rotated)": GroupingSteps(azimuth=None),
}


def patches(n_theta=12, n_phi=24):
    """Lat-long patches of the upper hemisphere with exact solid angles [sr]."""
    t = np.linspace(0, np.pi / 2, n_theta + 1)
    om = np.repeat(2 * np.pi * (np.cos(t[:-1]) - np.cos(t[1:])) / n_phi, n_phi)
    theta = np.repeat(0.5 * (t[:-1] + t[1:]), n_phi)
    phi = np.tile((np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi, n_theta)
    d = np.stack([np.sin(theta) * np.sin(phi), np.sin(theta) * np.cos(phi), np.cos(theta)], -1)
    return d, om


def standin_sky(el, az, vis, alb, dirs):
    """Stand-in sky radiance [W m-2 sr-1], shape (n_states, n_dirs) (see module docstring)."""
    el, az, vis, alb = (np.asarray(x, float)[:, None] for x in (el, az, vis, alb))
    h = np.clip((131.8 - vis) / (131.8 - 20.0), 0.0, 1.0)
    a, b = -1.0, -0.32
    c, d, e = 10.0 + 6.0 * h, -3.0, 0.45 - 0.15 * h
    zs = np.radians(90.0 - el)
    sun = np.stack([np.sin(zs) * np.sin(np.radians(az)), np.sin(zs) * np.cos(np.radians(az)),
                    np.cos(zs)], -1)  # (n, 1, 3)
    cosg = np.clip(np.sum(dirs[None] * sun, -1), -1.0, 1.0)
    gamma = np.arccos(cosg)
    cz = np.clip(dirs[None, :, 2], 0.02, 1.0)

    def f(chi):
        return 1.0 + c * (np.exp(d * chi) - np.exp(d * np.pi / 2)) + e * np.cos(chi) ** 2

    phi = 1.0 + a * np.exp(b / cz)
    phi0 = 1.0 + a * np.exp(b)
    lz = 30.0 * (np.sin(np.radians(np.clip(el, -4.2, 90) + 4.5))) ** 0.8 * (1 + 1.2 * h) * (1 + 0.3 * alb)
    return lz * f(gamma) * phi / (f(zs) * phi0)


def plane_irradiance(L, dirs, om):
    """Diffuse irradiance [W m-2] on a horizontal and a south-facing vertical plane: (n, 2)."""
    normals = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    w = np.clip(dirs @ normals.T, 0.0, None) * om[:, None]  # (n_dirs, 2)
    return np.tensordot(L, w, axes=([1], [0])) if L.ndim == 2 else np.einsum("sdc,dp->spc", L, w)


def error_stats(exact, approx, elevation):
    """Per-step relative error of the two planes over bright steps (horizontal > 5 W m-2): p95,
    max, and max with the sun above 5 deg; relative error of the annual sums."""
    bright = exact[:, 0] > 5.0
    rel = np.abs(approx[bright] - exact[bright]) / np.maximum(exact[bright], 1e-9)
    high = elevation[bright] > 5.0
    annual = np.abs(approx.sum(0) - exact.sum(0)) / exact.sum(0)
    return np.percentile(rel, 95, axis=0), rel.max(axis=0), rel[high].max(axis=0), annual


def run_case(name, states, dirs, om, real=None, real_steps=1000):
    ok = ~states["below_min"].to_numpy()
    st = states.loc[ok]
    el, az, vis, alb = (st[c].to_numpy() for c in ("elevation", "azimuth", "visibility", "albedo"))
    print(f"\n== {name}: {len(states)} steps, {ok.sum()} with a sky ==")

    def per_state_loop(els, azs, viss, albs):
        return np.concatenate([standin_sky(els[i:i + 1], azs[i:i + 1], viss[i:i + 1], albs[i:i + 1], dirs)
                               for i in range(len(els))])

    t0 = time.perf_counter()
    L_all = per_state_loop(el, az, vis, alb)
    t_all = time.perf_counter() - t0
    E_exact = plane_irradiance(L_all, dirs, om)
    print(f"stand-in sky, one evaluation per state, {len(dirs)} directions:")
    print(f"  {'grouping':42s} {'groups':>7s} {'reduct.':>8s} {'t_all':>8s} {'t_group':>8s} "
          f"{'speed-up':>8s} | {'p95 rel err h/v':>15s} | {'max rel err h/v':>15s} | "
          f"{'max, sun > 5 deg':>15s} | {'annual err h/v':>15s}")
    for label, steps in SETTINGS.items():
        t0 = time.perf_counter()
        g = group_sky_states(st, steps)
        gs = g.states
        gaz = gs["azimuth"].to_numpy() if steps.azimuth is not None else np.full(len(gs), 180.0)
        L_g = per_state_loop(gs["elevation"].to_numpy(), gaz, gs["visibility"].to_numpy(),
                             gs["albedo"].to_numpy())
        E_g = g.expand(plane_irradiance(L_g, dirs, om))
        t_g = time.perf_counter() - t0
        if steps.azimuth is None:  # the consumer rotates each group's sky to the step's azimuth:
            rep = gs.iloc[g.inverse]  # emulate exactly with the analytic stand-in
            E_g = plane_irradiance(standin_sky(rep["elevation"].to_numpy(), az, rep["visibility"].to_numpy(),
                                               rep["albedo"].to_numpy(), dirs), dirs, om)
        p95, mx, mx5, annual = error_stats(E_exact, E_g, el)
        print(f"  {label:42s} {g.n_groups:7d} {g.reduction:7.2f}x {t_all * 1e3:7.0f}ms {t_g * 1e3:7.0f}ms "
              f"{t_all / t_g:7.2f}x | {p95[0]:7.1e} {p95[1]:7.1e} | {mx[0]:7.1e} {mx[1]:7.1e} | "
              f"{mx5[0]:7.1e} {mx5[1]:7.1e} | {annual[0]:7.1e} {annual[1]:7.1e}")
    if real is not None:
        run_real(st.iloc[:real_steps], real, dirs, om)


def run_real(st, real, dirs, om):
    from widesky import skymodel

    model = real
    el, az, vis, alb = (st[c].to_numpy() for c in ("elevation", "azimuth", "visibility", "albedo"))

    def evaluate(els, azs, viss, albs):
        out = []
        for i in range(0, len(els), 256):
            s = slice(i, i + 256)
            out.append(skymodel.sky_radiance(model, dirs, els[s], azs[s], viss[s], albs[s], 0.0, threads=2,
                                             dtype=np.float32))
        return np.concatenate(out)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        L_all = evaluate(el, az, vis, alb)
        t_all = time.perf_counter() - t0
        E_exact = plane_irradiance(L_all.astype(float), dirs, om).sum(-1)  # all channels
        print(f"widesky.skymodel.sky_radiance on a synthetic dataset ({model.n_channels} channels, "
              f"{len(dirs)} directions, 2 threads), first {len(st)} steps with a sky:")
        for label, steps in SETTINGS.items():
            if steps.azimuth is None:
                continue
            t0 = time.perf_counter()
            g = group_sky_states(st, steps, model=model)
            gs = g.states
            L_g = evaluate(*(gs[c].to_numpy() for c in ("elevation", "azimuth", "visibility", "albedo")))
            E_g = g.expand(plane_irradiance(L_g.astype(float), dirs, om).sum(-1))
            t_g = time.perf_counter() - t0
            p95, mx, mx5, annual = error_stats(E_exact, E_g, el)
            print(f"  {label:42s} {g.n_groups:7d} {g.reduction:7.2f}x {t_all:7.2f}s {t_g:7.2f}s "
                  f"{t_all / t_g:7.2f}x | {p95[0]:7.1e} {p95[1]:7.1e} | {mx[0]:7.1e} {mx[1]:7.1e} | "
                  f"{mx5[0]:7.1e} {mx5[1]:7.1e} | {annual[0]:7.1e} {annual[1]:7.1e}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two months instead of a year")
    ap.add_argument("--no-real", action="store_true", help="skip the real evaluator")
    ap.add_argument("--real-steps", type=int, default=1000,
                    help="steps evaluated with the real evaluator per case (it costs ~10 ms a state)")
    args = ap.parse_args(argv)
    dirs, om = patches()
    end = "2021-03-01" if args.quick else "2022-01-01"

    real = None
    if not args.no_real:
        try:
            from widesky import skymodel
            from widesky.skymodel.synthetic import write_synthetic_dataset
            tmp = tempfile.mkdtemp()
            real = skymodel.load_dataset(write_synthetic_dataset(Path(tmp) / "synthetic.dat"))
        except Exception as exc:  # the evaluator is optional here
            print(f"(real evaluator unavailable: {exc})")

    if EPW.is_file():
        w = read_epw(EPW, coerce_year=2021)
        label = "Amsterdam IWEC weather year (hourly; visibility from the file)"
    else:
        w = read_epw(SAMPLE)
        label = "shipped sample weather (2 weeks; shared data not found)"
    if args.quick:
        w_data = w.data.loc[w.data.index < pd.Timestamp(end, tz=w.data.index.tz)]
        sp = w.site.solar_position(w_data.index, label="right", step="1h")
    else:
        w_data, sp = w.data, w.solar_position()
    run_case(label, sky_states(sp, w_data, altitude=0.0), dirs, om, real, args.real_steps)

    site = Site(w.site.latitude, w.site.longitude, 0.0, tz=w.site.tz)
    for step in ("1h", "15min"):
        sp = daytime_steps(site, "2021-01-01", end, step, label="left", min_elevation=-4.2)
        run_case(f"clear-sky {step} steps at the same site (default visibility 50 km, albedo 0.2)",
                 sky_states(sp), dirs, om, real, args.real_steps)


if __name__ == "__main__":
    main()
