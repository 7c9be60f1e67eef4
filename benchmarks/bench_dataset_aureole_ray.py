"""The ray rising from a low sun: two dataset files against the solver's own radiance along it (a figure).

The smoothness check's aureole ray at position angle 0 (straight up from the sun, view zenith from the sun's up to
``--span`` degrees above it) of a split low-sun state (``mc_single_scatter_exact``): the solver's radiance along it
is the exact single scattering solved at the ray's own directions plus the build's smoothed rest evaluated there
(``dataset_mc.rest_across_visibility`` on those directions, as the build smooths it), so no interpolation between
grid samples hides or adds structure. Each file is evaluated along the same ray with the evaluator; printed: the
turning points of each (the check's hysteresis) and the largest departure from the solver; drawn: the radiance and
the files' ratio to it.

Needs the build cache of the configuration (the Monte Carlo states of that elevation, every visibility) and the
input data directory.

Run:  python benchmarks/bench_dataset_aureole_ray.py skymodel/data/default-dataset.json OLD.dat NEW.dat \
          --visibility 20 --elevation 3 --channel 540 --figure docs/figures/dataset_aureole_ray.png
"""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np


def solver_ray(config, visibility_km: float, elevation_deg: float, albedo: float, channel: int, gamma_deg):
    """Solver radiance [W m-2 sr-1 nm-1] of one channel along the upward ray at angles ``gamma_deg`` from the sun."""
    from widesky.skymodel.generator.dataset_mc import rest_across_visibility, single_scatter

    zen = 90.0 - float(elevation_deg) - np.asarray(gamma_deg, float)
    order = np.argsort(zen)
    z = zen[order]
    ss = single_scatter(visibility_km, elevation_deg, z, [0.0], config, channels=[channel])[:, 0, 0]
    i = [float(v) for v in config.visibilities_km].index(float(visibility_km))
    rest = rest_across_visibility(config, elevation_deg, albedo, z, [0.0])[i, :, 0, channel]
    out = np.empty_like(ss)
    out[order] = ss + np.maximum(rest, 0.0)
    return out


def file_ray(path, visibility_km, elevation_deg, albedo, channel, gamma_deg):
    """A dataset file's radiance [W m-2 sr-1 nm-1] of one channel along the same ray."""
    zen = 90.0 - float(elevation_deg) - np.asarray(gamma_deg, float)
    return file_radiance(path, visibility_km, elevation_deg, albedo, channel, zen, np.full(len(zen), 180.0))


def file_radiance(path, visibility_km, elevation_deg, albedo, channel, zenith_deg, azimuth_deg):
    """A dataset file's radiance [W m-2 sr-1 nm-1] of one channel at view zeniths and azimuths [deg] (sun at azimuth
    180 deg, the evaluator's clamping warnings silenced)."""
    from widesky.skymodel import load_dataset
    from widesky.skymodel.evaluate import directions_from_angles, sky_radiance

    model = load_dataset(path)
    d = directions_from_angles(np.asarray(zenith_deg, float), np.asarray(azimuth_deg, float))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        L = sky_radiance(model, d, np.array([elevation_deg]), np.array([180.0]), np.array([visibility_km]),
                         np.array([albedo]))
    return np.asarray(L)[0, :, channel]


def main(argv=None):
    from widesky.skymodel.generator.dataset_build import load_config
    from widesky.skymodel.generator.dataset_mc import split_state
    from widesky.skymodel.generator.smoothness import AUREOLE_MAX_ZENITH_DEG, turning_points

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("config")
    ap.add_argument("files", nargs="+", help="dataset files to compare (e.g. before and after)")
    ap.add_argument("--visibility", type=float, default=20.0, help="a grid visibility [km]")
    ap.add_argument("--elevation", type=float, default=3.0, help="a split grid elevation [deg]")
    ap.add_argument("--albedo", type=float, default=0.5, help="ground albedo [1]")
    ap.add_argument("--channel", type=float, default=540.0, help="channel centre [nm]")
    ap.add_argument("--span", type=float, default=12.0, help="ray length [deg]")
    ap.add_argument("--figure", default=None, help="PNG to draw")
    a = ap.parse_args(argv)
    try:
        cfg = load_config(a.config)
    except (OSError, ValueError) as exc:
        sys.exit(f"{a.config}: {exc}")
    if float(a.visibility) not in [float(v) for v in cfg.visibilities_km]:
        sys.exit(f"--visibility {a.visibility}: not one of the configuration's {list(cfg.visibilities_km)}")
    if float(a.elevation) not in [float(e) for e in cfg.elevations_deg] or not split_state(cfg, a.elevation):
        sys.exit(f"--elevation {a.elevation}: not a split Monte Carlo grid elevation of {a.config}")
    if not 0.0 < a.span <= 30.0:
        sys.exit("--span must lie in (0, 30] deg")
    channel = int(round((a.channel - 300.0) / 40.0))
    if not 0 <= channel < 55 or abs(300.0 + 40.0 * channel - a.channel) > 1e-6:
        sys.exit(f"--channel {a.channel}: expected a channel centre 300, 340, ... 2460 nm")
    g = np.arange(0.25, a.span + 1e-9, 0.125)
    checked = (90.0 - a.elevation - g) < AUREOLE_MAX_ZENITH_DEG
    try:
        ref = solver_ray(cfg, a.visibility, a.elevation, a.albedo, channel, g)
    except FileNotFoundError as exc:
        sys.exit(f"the Monte Carlo states of {a.elevation} deg are not in the build cache ({exc}); "
                 "run widesky dataset build first")
    rows = []
    for f in a.files:
        try:
            L = file_ray(f, a.visibility, a.elevation, a.albedo, channel, g)
        except (OSError, ValueError) as exc:
            sys.exit(str(exc) if f in str(exc) else f"{f}: {exc}")
        rows.append((f, L))
        dev = L / ref - 1.0
        print(f"{f}: turning points on the checked part {int(turning_points(L[checked]))} (solver "
              f"{int(turning_points(ref[checked]))}); file / solver - 1 from {dev.min() * 100:+.2f} to "
              f"{dev.max() * 100:+.2f} %")
    if a.figure:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
        ax[0].plot(g, ref, "k-", lw=2, label="solver (exact single scattering + smoothed rest)")
        for f, L in rows:
            ax[0].plot(g, L, lw=1, label=f.rsplit("/", 1)[-1])
            ax[1].plot(g, (L / ref - 1.0) * 100, lw=1, label=f.rsplit("/", 1)[-1])
        for x in ax:
            x.axvspan(g[0], g[checked][0] if checked.any() else g[-1], color="0.9", lw=0)
            x.set_xlabel("angle from the sun along the upward ray [deg]")
        ax[0].set_ylabel("radiance [W m-2 sr-1 nm-1]")
        ax[1].set_ylabel("file / solver - 1 [%]")
        ax[0].set_title(f"{a.channel:g} nm, {a.visibility:g} km, sun {a.elevation:g} deg, albedo {a.albedo:g}",
                        fontsize=9)
        ax[0].legend(fontsize=7)
        ax[1].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(a.figure, dpi=100)
        print(f"wrote {a.figure} (grey: below view zenith {AUREOLE_MAX_ZENITH_DEG:g} deg, not checked)")


if __name__ == "__main__":
    main()
