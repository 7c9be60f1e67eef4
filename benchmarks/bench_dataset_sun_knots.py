"""Sun-angle knots near a low sun: refit cached low-sun states with extra knots close to the sun and count the
smoothness check's failures of each fit (docs/default-dataset.md, "What the check still flags in the fourth rebuild").

For the states (visibility x elevation, albedo 0.5) the cached solver radiance of the build (``state_radiance``:
DISORT, or the split Monte Carlo states) is refitted with the configuration's settings, except that the sun knots
strictly between ``--between LO HI`` degrees from the sun are replaced by that many plus ``--extra`` evenly spaced
ones, or (``--midpoints LO HI``, the build option ``sun_knot_midpoints_deg``) every sun-knot interval inside LO-HI
degrees is halved and the fit takes the samples filling the new cells (``dataset_build.fill_grid``). ``--extra 0``
fits with the configuration's own knots, ``--no-midpoints`` with them less its midpoints. The fit is evaluated on
the check's profiles at the solved geometry; a (state, channel) pair fails on a profile kind where the fit has more
turning points than both the limit and the reference at that profile
(``smoothness.solver_turning_points``), or a zenith spot above 1 %; channels with less than 1 % of the brightest
channel's sky-diffuse irradiance are not checked. Prints the failures per state and in all, and the in-sample NMAE.

Run:  python benchmarks/bench_dataset_sun_knots.py skymodel/data/default-dataset.json --extra 6 [--between 2 12]
      python benchmarks/bench_dataset_sun_knots.py skymodel/data/default-dataset.json --extra 0 [--no-midpoints]
      (about 10 min for the 18 default states on one core)
      python benchmarks/bench_dataset_sun_knots.py CONFIG --extra 0 --states "20,1,1;24.2,3,0" [--zenith-midpoints 80 89.7]
      (named states, each at its own albedo; ``--refine LO HI``: the build option ``sun_knot_refine_deg``, the
      sun-knot intervals inside LO-HI halved once more, with fill samples; ``--zenith-midpoints LO HI``: the build option
      ``zenith_knot_midpoints_deg``, every zenith-knot interval inside LO-HI degrees of view zenith halved;
      ``--no-zenith-midpoints``: the configuration without it)
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def sun_knots(config, extra: int, lo_deg: float, hi_deg: float) -> np.ndarray:
    """The configuration's sun knots [rad] with those strictly between ``lo_deg`` and ``hi_deg`` [deg] replaced by
    that many plus ``extra`` evenly spaced ones."""
    from widesky.skymodel.generator.dataset_build import config_knots

    br = np.degrees(config_knots(config)[0])
    if not extra:
        return np.radians(br)
    inside = (br > lo_deg) & (br < hi_deg)
    new = np.linspace(lo_deg, hi_deg, int(inside.sum()) + extra + 2)[1:-1]
    return np.radians(np.sort(np.concatenate([br[~inside], new])))


def fit_failures(config, visibility_km: float, elevation_deg: float, sun_breaks, albedo: float = 0.5):
    """({kind: (C,) bool}, in-sample NMAE of the checked channels (n,) [1]) of one refitted state."""
    import widesky.skymodel.generator.dataset_build as B
    from widesky.skymodel.evaluate import reference_angles
    from widesky.skymodel.generator import smoothness as S
    from widesky.skymodel.generator.fit import RadianceFit

    th, ph, rad, es = B.state_radiance(config, visibility_km, elevation_deg, albedo)
    smp = B.direction_samples(th, ph, es)
    ref = S.solver_turning_points(th, ph, rad, es)
    _, zb, eb = B.config_knots(config)
    br = (sun_breaks, zb, eb)
    sun, zen, emph, nmae = B.fit_state(config, th, ph, rad, es, br)
    d = S.profile_directions(elevation_deg)
    C = rad.shape[-1]
    out = {}
    for k in ("almucantar", "vertical", "aureole", "zenith"):
        a = reference_angles(d[k].reshape(-1, 3), es, 180.0)
        out[k] = np.stack([RadianceFit(sun[c], zen[c], emph[c], 0).evaluate(a["gamma"], a["zero"], a["zero"], *br)
                           for c in range(C)], -1).reshape(d[k].shape[:-1] + (C,))
    tp = S.profile_turning_points(out, d["aureole_valid"][..., None])
    m = S.profile_metrics(out, d["aureole_valid"][..., None], elevation_deg)
    w = smp["weights"] * np.maximum(np.cos(np.radians(np.repeat(np.asarray(th, float), len(ph)))), 0.0)
    e = (w[:, None] * rad.reshape(-1, C)).sum(0)
    checked = e >= S.MIN_ENERGY_FRACTION * e.max()
    f = {k: (tp[k] > np.maximum(S.LIMITS[k], ref[k])).any(-1) & checked for k in S.LIMITS}
    f["zenith"] = (m["zenith_spot"] > S.ZENITH_SPOT_TOL) & checked
    return f, nmae[checked]


def main(argv=None):
    from widesky.skymodel.generator.dataset_build import load_config

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("config")
    ap.add_argument("--extra", type=int, default=None,
                    help="knots added between --between LO HI [deg] (default 6; 0: as configured); the "
                         "configuration's midpoints are left out")
    ap.add_argument("--between", type=float, nargs=2, default=(2.0, 12.0), metavar=("LO", "HI"))
    ap.add_argument("--midpoints", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                    help="instead of --extra: halve every sun-knot interval inside LO-HI [deg]")
    ap.add_argument("--no-midpoints", action="store_true",
                    help="the configuration's knots without its sun_knot_midpoints_deg (the fourth rebuild's)")
    ap.add_argument("--albedo", type=float, default=0.5,
                    help="ground albedo of the refitted states [1] (a grid albedo)")
    ap.add_argument("--visibilities", type=float, nargs="+", default=[20.0, 51.3, 131.8])
    ap.add_argument("--elevations", type=float, nargs="+", default=[1.0, 2.0, 3.0, 4.5, 6.0, 8.0])
    ap.add_argument("--states", default=None,
                    help="instead of --visibilities x --elevations at --albedo: 'v,e,a;v,e,a' [km, deg, 1]")
    ap.add_argument("--refine", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                    help="the build option sun_knot_refine_deg: the sun-knot intervals inside LO-HI deg halved once more")
    ap.add_argument("--zenith-midpoints", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                    help="halve every zenith-knot interval inside LO-HI [deg of view zenith]")
    ap.add_argument("--no-refine", action="store_true",
                    help="the configuration's knots without its sun_knot_refine_deg (the sixth rebuild's sun knots)")
    ap.add_argument("--no-zenith-midpoints", action="store_true",
                    help="the configuration's knots without its zenith_knot_midpoints_deg")
    a = ap.parse_args(argv)
    if a.midpoints is not None and a.extra:
        sys.exit("--midpoints replaces --extra: give one of them")
    if a.extra is None:
        a.extra = 0 if a.midpoints is not None or a.no_midpoints else 6
    if a.extra < 0 or not 0.0 <= a.between[0] < a.between[1] <= 180.0:
        sys.exit("--extra must be >= 0 and --between LO HI within 0-180 deg with LO < HI")
    if a.midpoints is not None and not 0.0 <= a.midpoints[0] < a.midpoints[1] <= 180.0:
        sys.exit("--midpoints LO HI must lie within 0-180 deg with LO < HI")
    try:
        cfg = load_config(a.config)
    except (OSError, ValueError) as exc:
        sys.exit(f"{a.config}: {exc}")
    if a.states is None:
        states = [(v, e, a.albedo) for v in a.visibilities for e in a.elevations]
    else:
        try:
            states = [tuple(float(x) for x in st.split(",")) for st in a.states.split(";") if st.strip()]
        except ValueError:
            states = [()]
        if not states or any(len(st) != 3 for st in states):
            sys.exit(f"--states {a.states!r}: expected 'visibility,elevation,albedo' triples separated by ';'")
    bad = sorted({st[2] for st in states} - {float(x) for x in cfg.albedos})
    if bad:
        sys.exit(f"albedo {bad[0]}: not one of the configuration's albedos {list(cfg.albedos)}")
    if a.refine is not None and a.no_refine:
        sys.exit("--refine and --no-refine exclude each other: give one of them")
    if a.zenith_midpoints is not None and a.no_zenith_midpoints:
        sys.exit("--zenith-midpoints and --no-zenith-midpoints exclude each other: give one of them")
    if a.zenith_midpoints is not None and not 0.0 <= a.zenith_midpoints[0] < a.zenith_midpoints[1] <= 90.0:
        sys.exit("--zenith-midpoints LO HI must lie within 0-90 deg with LO < HI")
    from dataclasses import replace

    from widesky.skymodel.generator.dataset_build import config_knots
    if a.no_midpoints or a.extra or a.midpoints is not None:
        # (the second halving lies inside the first: it goes with it, and --refine gives it again)
        cfg = replace(cfg, sun_knot_midpoints_deg=None if a.midpoints is None else tuple(a.midpoints),
                      sun_knot_refine_deg=None)
    if a.zenith_midpoints is not None or a.no_zenith_midpoints:
        cfg = replace(cfg, zenith_knot_midpoints_deg=None if a.zenith_midpoints is None else tuple(a.zenith_midpoints))
    if a.no_refine:
        cfg = replace(cfg, sun_knot_refine_deg=None)
    if a.refine is not None:
        try:
            cfg = replace(cfg, sun_knot_refine_deg=tuple(a.refine))
        except ValueError as exc:
            sys.exit(f"--refine: {exc}")
    br = sun_knots(cfg, a.extra, *a.between) if a.extra else config_knots(cfg)[0]
    print(f"{len(br)} sun knots; below 16 deg: {np.degrees(br[np.degrees(br) < 16]).round(2).tolist()}; "
          f"{len(config_knots(cfg)[1])} zenith knots", flush=True)
    total = {"almucantar": 0, "vertical": 0, "aureole": 0, "zenith": 0}
    nm, t0 = [], time.perf_counter()
    for v, e, alb in states:
        try:
            f, n = fit_failures(cfg, v, e, br, alb)
        except FileNotFoundError as exc:
            sys.exit(f"state {v} km / {e} deg is not in the build cache ({exc}); run widesky dataset build first")
        for k in total:
            total[k] += int(f[k].sum())
        nm.append(n)
        print(f"  {v:6.1f} km {e:4.1f} deg albedo {alb:g}: " + " ".join(f"{k} {int(f[k].sum())}" for k in total)
              + f"; NMAE {n.mean() * 100:.3f} %", flush=True)
    nm = np.concatenate(nm)
    print(f"in all: {total} = {sum(total.values())} failing pairs; in-sample NMAE mean {nm.mean() * 100:.3f} %, "
          f"max {nm.max() * 100:.2f} % ({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
