"""The last degrees above the horizon: dataset files against the solver's own radiance along a vertical (a figure).

The smoothness check's antisolar vertical (relative azimuth 180 deg) of a low-sun grid state over a bright ground:
the solver's radiance is the build's own solved samples there (``dataset_build.state_radiance``: for the split
Monte Carlo states the exact single scattering plus the smoothed rest, on the fit grid's view zeniths), so nothing is
interpolated; each file is evaluated along the same vertical every 0.05 deg with the evaluator. Printed per file:
the turning points on the check's part of the vertical (view zenith 0-89.5 deg, 0.5 deg steps, the check's
hysteresis) and the largest departure from the solved samples at view zenith 80 deg and beyond; drawn: the
radiance from 80 deg to the horizon (relative to the solver's minimum there) and the files' ratio to the solver at
its samples.

Needs the build cache of the configuration (the state's elevation, every visibility) and the input data directory.

Run:  python benchmarks/bench_dataset_horizon.py skymodel/data/default-dataset.json OLD.dat NEW.dat \
          --visibility 20 --elevation 1 --albedo 1 --channel 740 --figure docs/figures/dataset_horizon.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from widesky.core.atomic import atomic_write

AZIMUTH_DEG = 180.0
"""Relative azimuth of the vertical [deg] (the antisolar one)."""


def file_vertical(path, visibility_km, elevation_deg, albedo, channel, zenith_deg):
    """A dataset file's radiance [W m-2 sr-1 nm-1] of one channel along the vertical at view zeniths [deg]."""
    from bench_dataset_aureole_ray import file_radiance

    z = np.asarray(zenith_deg, float)
    return file_radiance(path, visibility_km, elevation_deg, albedo, channel, z, np.full(len(z), 180.0 + AZIMUTH_DEG))


def main(argv=None):
    from widesky.skymodel.generator.dataset_build import load_config, state_radiance
    from widesky.skymodel.generator.smoothness import VERTICAL_STEP_DEG, turning_points

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("config", help="the build configuration whose cache holds the state")
    ap.add_argument("files", nargs="+", help="dataset files to compare (labelled by their names)")
    ap.add_argument("--visibility", type=float, default=20.0, help="[km], a grid visibility")
    ap.add_argument("--elevation", type=float, default=1.0, help="solar elevation [deg], a grid elevation")
    ap.add_argument("--albedo", type=float, default=1.0, help="ground albedo [1], a grid albedo")
    ap.add_argument("--channel", type=float, default=740.0, help="channel centre [nm]")
    ap.add_argument("--figure", default=None, help="PNG to write")
    a = ap.parse_args(argv)
    try:
        cfg = load_config(a.config)
    except (OSError, ValueError) as exc:
        sys.exit(f"{a.config}: {exc}")
    for f in a.files:
        if not Path(f).is_file():
            sys.exit(f"{f}: no such file")
    for name, value, grid in (("--visibility", a.visibility, cfg.visibilities_km),
                              ("--elevation", a.elevation, cfg.elevations_deg), ("--albedo", a.albedo, cfg.albedos)):
        if value not in [float(x) for x in grid]:
            sys.exit(f"{name} {value:g}: not one of the configuration's {[float(x) for x in grid]}")
    centres = 300.0 + 40.0 * np.arange(55)
    c = int(np.argmin(np.abs(centres - a.channel)))
    if abs(centres[c] - a.channel) > 20.0:
        sys.exit(f"--channel {a.channel:g}: outside the 55 channels (300-2460 nm centres)")
    try:
        th, ph, rad, _ = state_radiance(cfg, a.visibility, a.elevation, a.albedo)
    except FileNotFoundError as exc:
        sys.exit(f"state {a.visibility:g} km / {a.elevation:g} deg is not in the build cache ({exc}); "
                 "run widesky dataset build first")
    j = int(np.argmin(np.abs(ph - AZIMUTH_DEG)))
    solved = rad[:, j, c]
    near = th >= 80.0
    check_z = np.arange(0.0, 89.5 + 1e-9, VERTICAL_STEP_DEG)
    fine_z = np.arange(80.0, float(th[-1]) + 1e-9, 0.05)
    print(f"{a.visibility:g} km, sun {a.elevation:g} deg, albedo {a.albedo:g}, {centres[c]:.0f} nm, relative azimuth "
          f"{AZIMUTH_DEG:g} deg; solver samples at view zenith >= 80 deg: {th[near].round(2).tolist()}")
    solved_tp = turning_points(np.interp(check_z, th, solved)[None])[0]
    print(f"  solver (linear between its samples): {solved_tp} turning points on the check's vertical; rise from its "
          f"minimum beyond 80 deg to the last sample: {(solved[-1] / solved[near].min() - 1) * 100:+.2f} %")
    curves = {}
    for f in a.files:
        on_check = file_vertical(f, a.visibility, a.elevation, a.albedo, c, check_z)
        at_samples = file_vertical(f, a.visibility, a.elevation, a.albedo, c, th[near])
        dev = at_samples / solved[near] - 1.0
        curves[f] = (file_vertical(f, a.visibility, a.elevation, a.albedo, c, fine_z), dev)
        print(f"  {Path(f).name}: {turning_points(on_check[None])[0]} turning points; departure from the solver at "
              f"view zenith >= 80 deg {dev.min() * 100:+.2f} .. {dev.max() * 100:+.2f} %")
    if a.figure:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
        ref = solved[near].min()
        ax.plot(th[near], solved[near] / ref, "ko", ms=4, label="solver (solved samples)")
        for f, (fine, dev) in curves.items():
            ax.plot(fine_z, fine / ref, lw=1.4, label=Path(f).name)
            bx.plot(th[near], dev * 100, "o-", ms=3, lw=1.2, label=Path(f).name)
        for x in (ax, bx):
            x.axvspan(89.5, 90.0, color="0.9", lw=0)
            x.set_xlabel("view zenith [deg]")
            x.set_xlim(80.0, 90.0)
            x.legend(fontsize=8)
        ax.set_ylabel("radiance / solver's minimum beyond 80 deg")
        bx.set_ylabel("file / solver - 1 [%]")
        bx.axhline(0.0, color="k", lw=0.6)
        fig.suptitle(f"antisolar vertical, {a.visibility:g} km, sun {a.elevation:g} deg, albedo {a.albedo:g}, "
                     f"{centres[c]:.0f} nm (grey: beyond the check's 89.5 deg)", fontsize=10)
        fig.tight_layout()
        out = Path(a.figure)
        with atomic_write(out) as tmp:
            fig.savefig(tmp, dpi=110)
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
