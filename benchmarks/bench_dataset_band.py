"""The elevation-interpolation band: a ray from a sun between two grid elevations, with and without the band's samples.

Between grid elevations the evaluator blends the bracketing states' fits at the query's own angles (gamma to the sun,
view zenith), so each state is asked for pairs that no direction of its own sky has (``band_samples`` in
``widesky.skymodel.generator.dataset_build``). This solves DISORT (the build's solver and settings, one channel at a time) at
the two grid elevations and at the elevation between them, fits the grid states with the configuration's settings
with and without the band, blends them with the evaluator's weights, and compares along the smoothness check's ray
from the sun toward the horizon (position angle 180 deg) and the ray toward the zenith (0 deg), both on the solar
vertical and solved there directly: turning points (0.5 % hysteresis) and the departure from the solve. Also prints
each fit's in-sample NMAE.

Run:  python benchmarks/bench_dataset_band.py skymodel/data/default-dataset.json \
          --figure docs/figures/dataset_elevation_band.png [--visibility 20 --low 17 --high 21 --channels 33 6]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from widesky.core.atomic import atomic_write


def main(argv=None):
    from dataclasses import replace

    from widesky.skymodel.evaluate import reference_angles
    from widesky.skymodel.generator import smoothness as S
    from widesky.skymodel.generator.dataset_build import config_knots, fit_state, load_config, solve_state
    from widesky.skymodel.generator.fit import RadianceFit

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config")
    ap.add_argument("--visibility", type=float, default=20.0, help="[km]")
    ap.add_argument("--low", type=float, default=17.0, help="lower grid elevation [deg]")
    ap.add_argument("--high", type=float, default=21.0, help="upper grid elevation [deg]")
    ap.add_argument("--channels", type=int, nargs="+", default=[33, 6], help="channel indices (33: 1620 nm)")
    ap.add_argument("--band-max-gamma", type=float, default=None,
                    help="band_max_gamma_deg of the trial [deg] (default: the configuration's, else 15)")
    ap.add_argument("--band-weight", type=float, default=None,
                    help="band_weight of the trial (default: the configuration's, else 0.03)")
    ap.add_argument("--figure", default=None)
    a = ap.parse_args(argv)
    if not a.low < a.high:
        ap.error(f"--low {a.low} must be below --high {a.high}")
    if any(not 0 <= c < 55 for c in a.channels):
        ap.error("--channels: indices 0..54")
    try:
        cfg = load_config(a.config)
    except (OSError, ValueError) as e:
        ap.error(f"{a.config}: {e}")
    gmax = a.band_max_gamma if a.band_max_gamma is not None else (cfg.band_max_gamma_deg or 15.0)
    weight = a.band_weight if a.band_weight is not None else (
        cfg.band_weight if cfg.band_max_gamma_deg is not None else 0.03)
    try:
        band = replace(cfg, band_max_gamma_deg=gmax, band_weight=weight)
    except ValueError as e:
        ap.error(str(e))
    print(f"band: out to {gmax:g} deg from the sun, weight {weight:g}")
    mid = 0.5 * (a.low + a.high)
    t0 = time.perf_counter()
    solved = {e: solve_state(a.visibility, e, cfg, channels=a.channels) for e in (a.low, mid, a.high)}
    print(f"DISORT at {a.low:g}, {mid:g}, {a.high:g} deg: {time.perf_counter() - t0:.0f} s")
    d = S.profile_directions(mid)
    br = config_knots(cfg)
    wl = 300.0 + 40.0 * np.asarray(a.channels)
    rays = {"toward the horizon (180 deg)": 4, "toward the zenith (0 deg)": 0}
    g = np.arange(0.25, S.AUREOLE_MAX_DEG + 1e-9, 0.25)
    curves = {}
    for name, c in (("without the band", replace(cfg, band_max_gamma_deg=None)), ("with the band", band)):
        fits = []
        for e in (a.low, a.high):
            s = solved[e]
            sun, zen, emph, nmae = fit_state(c, s["zenith"], s["azimuth"], s["radiance"][..., a.channels], e)
            fits.append((sun, zen, emph))
            print(f"{name}: fit at {e:g} deg, in-sample NMAE " +
                  ", ".join(f"{w:.0f} nm {100 * x:.3f} %" for w, x in zip(wl, nmae)))
        for label, j in rays.items():
            ang = reference_angles(d["aureole"][j], mid, 180.0)
            blend = sum(0.5 * np.stack([RadianceFit(f[0][q], f[1][q], f[2][q], 0).evaluate(
                ang["gamma"], ang["zero"], ang["zero"], *br) for q in range(len(a.channels))], -1) for f in fits)
            curves[(name, label)] = blend
    # the reference: DISORT solved at the rays' own directions (both lie on the solar vertical, relative azimuth 0),
    # so no interpolation between solved directions adds or hides structure
    ref = {}
    for label, j in rays.items():
        z = np.degrees(np.arccos(np.clip(d["aureole"][j][:, 2], -1, 1)))
        order = np.argsort(z)
        r = solve_state(a.visibility, mid, cfg, z[order], np.array([0.0]), channels=a.channels)["radiance"]
        ref[label] = np.empty((len(z), len(a.channels)))
        ref[label][order] = r[:, 0, a.channels]
    for label, j in rays.items():
        valid = d["aureole_valid"][j]
        for q, w in enumerate(wl):
            tp_ref = int(S.turning_points(ref[label][valid, q]))
            line = [f"ray {label}, {w:.0f} nm: DISORT at {mid:g} deg {tp_ref} turning points"]
            for name in ("without the band", "with the band"):
                c = curves[(name, label)][valid, q]
                dev = 100 * (c / ref[label][valid, q] - 1)
                line.append(f"{name} {int(S.turning_points(c))} ({dev.min():+.1f} to {dev.max():+.1f} %)")
            print("; ".join(line))
    if a.figure:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(len(wl), len(rays), figsize=(10, 3.2 * len(wl)), squeeze=False)
        for q, w in enumerate(wl):
            for k, (label, j) in enumerate(rays.items()):
                ax = axes[q, k]
                valid = d["aureole_valid"][j]
                ax.axhline(0.0, color="k", lw=1.5, label=f"DISORT solved at {mid:g} deg")
                for name, style in (("without the band", "r--"), ("with the band", "b-")):
                    c = curves[(name, label)][valid, q]
                    ax.plot(g[valid], 100 * (c / ref[label][valid, q] - 1), style,
                            label=f"blend of the {a.low:g} and {a.high:g} deg fits, {name} "
                                  f"({int(S.turning_points(c))} turning points)")
                ax.set_title(f"{w:.0f} nm, ray {label}, {a.visibility:g} km, albedo 0 (solve: "
                             f"{int(S.turning_points(ref[label][valid, q]))} turning points)", fontsize=8)
                ax.set_xlabel("angle from the sun [deg]")
                ax.set_ylabel("departure from the solve [%]")
                ax.legend(fontsize=6)
                ax.tick_params(labelsize=7)
        fig.suptitle(f"sun at {mid:g} deg, between the grid elevations {a.low:g} and {a.high:g} deg", fontsize=9)
        fig.tight_layout()
        with atomic_write(a.figure) as tmp:
            fig.savefig(tmp, dpi=110)
        plt.close(fig)
        print(f"wrote {a.figure}")


if __name__ == "__main__":
    main()
