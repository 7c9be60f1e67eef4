"""What the smoothness check's guard band excuses, and whether it is the sky's own (issue 11).

The check (skymodel.generator.smoothness) allows a profile the solver's own turning points, counted with half the
check's hysteresis (``REFERENCE_REL_TOL`` 0.25 %, floor ``REFERENCE_FLOOR_FRACTION``). This bench takes every grid
state that the build solved at its own elevation, from the build's cache, and lists the (state, channel, profile)
cases that fail when the solver is counted at the check's own hysteresis (0.5 %) but pass with the guard band, with:

- the file's and the solver's turning points at 0.5 % and 0.25 %;
- the reversal size: the largest hysteresis at which the profile still has more turning points than the limit
  (file and solver), i.e. how large the feature is in each;
- where the turning points lie (angle along the profile [deg]) in the file and in the solver, and the largest
  distance from a file turning point to the nearest solver one: a feature of the sky that the file reproduces sits
  at the same place.

With ``--figure`` it draws
six of the excused profiles (two of each kind), file and solver zoomed onto their turning points (thin lines: where
each turns).

Run:  python benchmarks/bench_dataset_guard_band.py skymodel/data/default-dataset.json skymodel/data/default.dat \
          [--json out.json] [--figure docs/figures/dataset_guard_band.png]
(needs the build's solve cache: ``widesky dataset build CONFIG -o FILE`` first.)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings

import numpy as np


def reversal_size(y, limit: int, floor_fraction: float) -> float:
    """Largest hysteresis [1] at which profile ``y`` still has more than ``limit`` turning points (0 if it never
    has): bisection on :func:`widesky.skymodel.generator.smoothness.turning_points`."""
    from widesky.skymodel.generator.smoothness import turning_points

    if turning_points(y, 0.0, floor_fraction) <= limit:
        return 0.0
    lo, hi = 0.0, 0.5
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        if turning_points(y, mid, floor_fraction) > limit:
            lo = mid
        else:
            hi = mid
    return lo


def profile_axis(kind: str) -> np.ndarray:
    """The coordinate along a profile [deg]: relative azimuth (almucantar), view zenith (vertical), angle from the
    sun (aureole ray)."""
    from widesky.skymodel.generator import smoothness as S

    if kind == "almucantar":
        return np.arange(0.0, 180.0 + 1e-9, S.ALMUCANTAR_STEP_DEG)
    if kind == "vertical":
        return np.arange(0.0, 89.5 + 1e-9, S.VERTICAL_STEP_DEG)
    return np.arange(0.25, S.AUREOLE_MAX_DEG + 1e-9, 0.25)


def file_profiles(model, state) -> dict:
    """The dataset's radiance along every profile at ``state`` (visibility, elevation, albedo): as
    :func:`widesky.skymodel.generator.smoothness.solver_profiles`, the profile's shape + (C,)."""
    from widesky.skymodel.evaluate import sky_radiance
    from widesky.skymodel.generator.smoothness import profile_directions

    d = profile_directions(state[1])
    out = {}
    for k in ("almucantar", "vertical", "aureole"):
        flat = d[k].reshape(-1, 3)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            L = sky_radiance(model, flat, np.array([state[1]]), np.array([180.0]), np.array([state[0]]),
                             np.array([state[2]]))
        out[k] = np.asarray(L).reshape(d[k].shape[:-1] + (-1,))
    return out


def main(argv=None):
    from widesky.skymodel import load_dataset
    from widesky.skymodel.generator import smoothness as S
    from widesky.skymodel.generator.dataset_build import _fitted_elevations, load_config, state_radiance
    from widesky.skymodel.generator.dataset_mc import radiance_by_mc, split_state

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config")
    ap.add_argument("dataset")
    ap.add_argument("--json", default=None, help="write the cases here")
    ap.add_argument("--figure", default=None, help="PNG of up to six excused profiles")
    a = ap.parse_args(argv)
    try:
        cfg = load_config(a.config)
        model = load_dataset(a.dataset)
    except (OSError, ValueError) as e:
        sys.exit(f"bench_dataset_guard_band: {e}")
    t0 = time.perf_counter()
    fitted = _fitted_elevations(cfg)
    states = []
    for v in cfg.visibilities_km:
        for e in cfg.elevations_deg:
            own = split_state(cfg, e) if radiance_by_mc(cfg, e) else e >= cfg.min_solve_elevation_deg
            if own and float(e) in [float(x) for x in fitted]:
                states += [(float(v), float(e), float(al)) for al in cfg.albedos]
    res = S.check_states(model, states)                     # the file's counts at the check's hysteresis
    cases = []
    for st, r in zip(states, res):
        if not r["fails_plain"].any():
            continue
        try:
            zen, az, rad, solved = state_radiance(cfg, *st)
        except FileNotFoundError as e:
            sys.exit(f"bench_dataset_guard_band: {e} (run the build first: its cache holds the solves)")
        sol = S.solver_profiles(zen, az, rad, solved)
        d = S.profile_directions(st[1])
        valid = d["aureole_valid"]
        tp_strict = S.profile_turning_points(sol, valid[..., None], S.REL_TOL, S.FLOOR_FRACTION)
        tp_guard = S.profile_turning_points(sol, valid[..., None], S.REFERENCE_REL_TOL, S.REFERENCE_FLOOR_FRACTION)
        fp = None
        for k, lim in S.LIMITS.items():
            f_tp = r["profile_tp"][k]                                  # (C, n)
            strict = np.maximum(tp_strict[k], lim)
            guard = np.maximum(tp_guard[k], lim)
            bad_strict = (f_tp > strict) & r["checked"][:, None]
            bad_guard = (f_tp > guard) & r["checked"][:, None]
            for c, j in zip(*np.nonzero(bad_strict & ~bad_guard)):
                if fp is None:
                    fp = file_profiles(model, st)
                yf = np.moveaxis(fp[k], -1, 0)[c][j]
                ys = np.moveaxis(sol[k], -1, 0)[c][j]
                x = profile_axis(k)
                if k == "aureole":
                    yf, ys = S.held_valid(yf, valid[j]), S.held_valid(ys, valid[j])
                i_f = S.turning_point_indices(yf, S.REL_TOL, S.FLOOR_FRACTION)
                i_s = S.turning_point_indices(ys, S.REFERENCE_REL_TOL, S.REFERENCE_FLOOR_FRACTION)
                dist = max((min(abs(x[i] - x[q]) for q in i_s) for i in i_f), default=0.0) if i_s else float("inf")
                cases.append({"state": list(st), "channel_nm": float(model.wavelengths[c]), "kind": k,
                              "profile": int(j),
                              "file_tp": int(f_tp[c, j]), "solver_tp_strict": int(tp_strict[k][c, j]),
                              "solver_tp_guard": int(tp_guard[k][c, j]), "limit": lim,
                              "file_reversal": round(reversal_size(yf, int(max(lim, tp_strict[k][c, j])),
                                                                   S.FLOOR_FRACTION), 5),
                              "solver_reversal": round(reversal_size(ys, int(max(lim, tp_strict[k][c, j])),
                                                                     S.REFERENCE_FLOOR_FRACTION), 5),
                              "file_tp_at_deg": [float(x[i]) for i in i_f],
                              "solver_tp_at_deg": [float(x[i]) for i in i_s],
                              "largest_distance_deg": float(dist), "_x": x, "_yf": yf, "_ys": ys})
    secs = time.perf_counter() - t0
    pairs = {(tuple(c["state"]), c["channel_nm"]) for c in cases}
    print(f"{len(states)} grid states solved at their own elevation; {len(cases)} profiles in {len(pairs)} (state, "
          f"channel) pairs fail against the solver counted at {100 * S.REL_TOL:g} % and pass with the guard band "
          f"({100 * S.REFERENCE_REL_TOL:g} %) [{secs:.0f} s]")
    for c in cases:
        print(f"  {c['state']} {c['channel_nm']:.0f} nm {c['kind']}[{c['profile']}]: file {c['file_tp']} tp, solver "
              f"{c['solver_tp_strict']} at 0.5 % / {c['solver_tp_guard']} at 0.25 %; reversal file "
              f"{100 * c['file_reversal']:.2f} %, solver {100 * c['solver_reversal']:.2f} %; file tp at "
              f"{c['file_tp_at_deg']} deg, solver at {c['solver_tp_at_deg']} deg (largest distance "
              f"{c['largest_distance_deg']:.2f} deg)")
    if cases:
        dist = np.array([c["largest_distance_deg"] for c in cases])
        fr = np.array([c["file_reversal"] for c in cases])
        sr = np.array([c["solver_reversal"] for c in cases])
        print(f"largest distance file -> solver turning point: median {np.median(dist):.2f}, max {dist.max():.2f} deg; "
              f"reversal sizes: file median {100 * np.median(fr):.2f} % (max {100 * fr.max():.2f}), solver median "
              f"{100 * np.median(sr):.2f} % (max {100 * sr.max():.2f})")
    if a.json:
        with open(a.json, "w") as f:
            json.dump([{k: v for k, v in c.items() if not k.startswith("_")} for c in cases], f, indent=1)
    if a.figure and cases:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        # two cases of each profile kind (the largest reversals in the file, distinct channels), zoomed onto the
        # turning points: a 0.5 % feature is invisible on the whole profile
        pick = []
        for kind in ("aureole", "vertical", "almucantar"):
            seen = set()
            for c in sorted((c for c in cases if c["kind"] == kind), key=lambda c: -c["file_reversal"]):
                if c["channel_nm"] not in seen and len(seen) < 2:
                    seen.add(c["channel_nm"])
                    pick.append(c)
        fig, axes = plt.subplots(2, 3, figsize=(11, 6), squeeze=False)
        for ax, c in zip(axes.T.ravel(), pick):
            x = c["_x"]
            at = c["file_tp_at_deg"] + c["solver_tp_at_deg"]
            lo, hi = (min(at) - 6.0, max(at) + 6.0) if at else (x[0], x[-1])
            win = (x >= lo) & (x <= hi)
            m = float(np.median(c["_ys"][win]))
            ax.plot(x[win], c["_ys"][win] / m, "k-", lw=1.2, label="solver")
            ax.plot(x[win], c["_yf"][win] / m, "C3--", lw=1.2, label="file")
            for q in c["solver_tp_at_deg"]:
                ax.axvline(q, color="k", lw=0.5, alpha=0.4)
            for q in c["file_tp_at_deg"]:
                ax.axvline(q, color="C3", lw=0.5, alpha=0.4, ls=":")
            v, e, al = c["state"]
            ax.set_title(f"{c['kind']} {c['profile']}, {c['channel_nm']:.0f} nm\n"
                         f"{v:g} km, sun {e:g} deg, albedo {al:g}", fontsize=8)
            ax.set_xlabel({"almucantar": "relative azimuth [deg]", "vertical": "view zenith [deg]",
                           "aureole": "angle from the sun [deg]"}[c["kind"]], fontsize=8)
            ax.tick_params(labelsize=7)
        axes[0, 0].legend(fontsize=7)
        axes[0, 0].set_ylabel("radiance / solver's median in the window", fontsize=8)
        for ax in axes.ravel()[len(pick):]:
            ax.axis("off")
        fig.tight_layout()
        fig.savefig(a.figure, dpi=110)
        print("wrote", a.figure)


if __name__ == "__main__":
    main()
