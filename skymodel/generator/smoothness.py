"""Smoothness check of a sky-radiance dataset: spurious rings, fringes and spots that the fit-error figures miss.

A clear sky is smooth where its physics is: along an almucantar (fixed view zenith) the radiance falls from the sun's
side to one minimum and may rise again toward the antisolar side; along the verticals at 90 and 180 deg from the sun
it has at most one minimum between the zenith and the horizon; outward from the sun (the aureole) it only falls; and
the zenith is no brighter or darker than a small ring around it beyond what the curvature of the sky allows. The
check evaluates a dataset with the evaluator (what a render or the integrator sees) along these profiles, for every
channel whose sky carries measurable energy, at every grid state and at states between grid points, and counts

- **turning points** along each almucantar and vertical, with a hysteresis ``rel_tol``: a reversal counts only once the
  profile has moved back by more than ``rel_tol`` of its current extreme (ripples smaller than that are invisible
  and below the fit error; see docs/default-dataset.md, "Smoothness", for the choice of 0.5 %);
- **aureole turning points**: along rays from the sun out to ``AUREOLE_MAX_DEG`` (above view zenith
  ``AUREOLE_MAX_ZENITH_DEG``) the radiance falls, and may rise once where the sky's own gradient takes over (toward
  the zenith in the UV at low sun, where the ozone path shortens): at most one turning point; rings around the sun
  make more;
- **zenith spot**: ``|L(zenith) / mean(L on a ring of ZENITH_RING_DEG) - 1|``.

Where the solver's own sky has more turning points along a profile than the limit (a minimum between the aureole and
the bright band a few degrees above the horizon on a ray rising from a low sun, structure of the water bands along the
antisolar vertical), the check can compare with it: :func:`solver_turning_points` counts the solver's (with half the
hysteresis, :data:`REFERENCE_REL_TOL`: a guard band, so that a real feature just under the threshold in the solver
and just over it in the fit is not called spurious), the build keeps
the profiles above the limit (:func:`reference_entries`, the sidecar's ``smoothness_reference``), and a profile then
fails only with more turning points than both the limit and the solver's there (between grid states: the most of the
bracketing grid states'). A between-grid pair that fails by that rule is solved at its own state by the build
(:mod:`widesky.skymodel.generator.smoothness_between`) and then judged against that solve instead (``between`` of
:func:`reference_from_entries`). The verdicts by the limits alone and by the bracketing rule are kept beside it.

Pure functions over arrays; :func:`check_dataset` runs everything and :func:`summarise` reduces it for the sidecar.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..evaluate import sky_radiance

__all__ = ["ALMUCANTAR_ZENITHS_DEG", "VERTICAL_AZIMUTHS_DEG", "REL_TOL", "ZENITH_SPOT_TOL", "MAX_ALMUCANTAR_TP",
           "MAX_VERTICAL_TP", "MAX_AUREOLE_TP", "REFERENCE_REL_TOL", "REFERENCE_FLOOR_FRACTION", "VERTICAL_REFERENCE_HORIZON_DEG",
           "AUREOLE_REFERENCE_READ_ON_DEG", "AUREOLE_GAMMAS_DEG", "aureole_rays", "turning_points",
           "monotone_violations", "profile_directions", "profile_turning_points", "profile_metrics", "LIMITS",
           "check_states", "held_valid", "solver_profiles", "turning_point_indices", "solver_turning_points",
           "reference_entries", "reference_from_entries", "allowed_turning_points", "grid_states",
           "between_grid_states", "check_dataset", "summarise"]

ALMUCANTAR_ZENITHS_DEG = (20.0, 40.0, 60.0, 70.0, 75.0, 80.0, 84.0, 87.0, 89.0)
"""View zeniths of the checked almucantars [deg]."""
ALMUCANTAR_STEP_DEG = 1.0
"""Relative-azimuth step along an almucantar [deg] (0 = toward the sun ... 180)."""
VERTICAL_AZIMUTHS_DEG = (90.0, 180.0)
"""Relative azimuths of the checked verticals [deg] (zenith to the horizon in 0.5 deg steps)."""
VERTICAL_STEP_DEG = 0.5
AUREOLE_MAX_DEG = 12.0
"""Largest angle from the sun of the aureole rays [deg] (0.25 deg steps, 8 position angles)."""
AUREOLE_MAX_ZENITH_DEG = 85.0
"""Aureole ray points below this view zenith only [deg] (toward the horizon the path length makes the sky brighten)."""
ZENITH_RING_DEG = 1.5
"""Radius of the ring the zenith radiance is compared with [deg]."""
REL_TOL = 0.005
"""Hysteresis of the turning-point and monotonicity counts [1] (docs/default-dataset.md, "Smoothness")."""
ZENITH_SPOT_TOL = 0.01
"""Largest accepted ``|L(zenith) / ring mean - 1|`` [1]."""
MAX_ALMUCANTAR_TP = 1
"""Turning points allowed along an almucantar (one minimum)."""
MAX_VERTICAL_TP = 2
"""Turning points allowed along the verticals at 90 and 180 deg from the sun: a minimum, then the maximum a few degrees
above the horizon that the solver's own radiance shows (the horizon band darkens again below it; measured at 29.2 km,
sun 8 deg: maximum at view zenith 81-89 deg in every channel)."""
MAX_AUREOLE_TP = 1
"""Turning points allowed along a ray from the sun."""
MIN_ENERGY_FRACTION = 0.01
"""Channels whose sky-diffuse horizontal irradiance is below this fraction of the state's brightest channel are not
checked [1] (saturated absorption bands: their dim skies are set by the half-float floor, not by the fit)."""
FLOOR_FRACTION = 1e-3
"""Absolute floor of the hysteresis as a fraction of each profile's maximum [1] (near-zero values)."""
REFERENCE_REL_TOL = 0.0025
"""Hysteresis of the solver's own turning-point count [1], half the check's :data:`REL_TOL`: a guard band. A reversal of
the dataset's profile by more than ``REL_TOL`` is the sky's own where the solver's sky reverses on that profile by more
than this; where it reverses by less, the dataset's is spurious. Counting both at the same hysteresis turns a real
feature at the threshold into a coin toss decided by the fit's error (a 0.4 % reversal of the solver that the file
shows at 0.6 %: docs/default-dataset.md, "The check", the guard band)."""
REFERENCE_FLOOR_FRACTION = 5e-4
"""Absolute floor of the solver's own count [1], half the check's :data:`FLOOR_FRACTION` (the same guard band)."""


def turning_points(y, rel_tol: float = REL_TOL, floor_fraction: float = FLOOR_FRACTION) -> np.ndarray:
    """Number of direction reversals of each profile, counting a reversal once the profile has moved back by more than
    ``rel_tol`` of its current extreme (a zigzag filter), with an absolute floor of ``floor_fraction`` of the profile's
    largest absolute value.

    Parameters
    ----------
    y : ndarray (..., n)  profiles along their last axis (any unit).

    Returns
    -------
    ndarray (...) int
    """
    y = np.asarray(y, float)
    floor = floor_fraction * np.max(np.abs(y), axis=-1)
    shape = y.shape[:-1]
    hi = y[..., 0].copy()
    lo = y[..., 0].copy()
    ext = y[..., 0].copy()
    trend = np.zeros(shape, np.int8)
    count = np.zeros(shape, np.int64)
    for k in range(1, y.shape[-1]):
        v = y[..., k]
        tol = np.maximum(rel_tol * np.abs(ext), floor)
        # no trend yet: start one once the profile has left its range by more than the tolerance
        und = trend == 0
        hi = np.where(und, np.maximum(hi, v), hi)
        lo = np.where(und, np.minimum(lo, v), lo)
        up0 = und & (v - lo > np.maximum(rel_tol * np.abs(lo), floor))
        dn0 = und & ~up0 & (hi - v > np.maximum(rel_tol * np.abs(hi), floor))
        # rising: a new maximum, or a reversal once it has fallen by more than the tolerance
        rising = trend == 1
        rev_dn = rising & (ext - v > tol)
        # falling
        falling = trend == -1
        rev_up = falling & (v - ext > tol)
        count += rev_dn | rev_up
        new_ext = np.where(rising & (v > ext), v, ext)
        new_ext = np.where(falling & (v < ext), v, new_ext)
        new_ext = np.where(rev_dn | rev_up | up0 | dn0, v, new_ext)
        trend = np.where(up0 | rev_up, 1, np.where(dn0 | rev_dn, -1, trend)).astype(np.int8)
        ext = new_ext
    return count


def monotone_violations(y, rel_tol: float = REL_TOL, floor_fraction: float = FLOOR_FRACTION, valid=None):
    """Largest rise of each profile above its running minimum, relative to that minimum [1] (0 for a non-increasing
    profile); ``valid`` (same shape, bool) masks points that do not count (and do not lower the running minimum)."""
    y = np.asarray(y, float)
    if valid is None:
        valid = np.ones(y.shape, bool)
    yv = np.where(valid, y, np.inf)
    run_min = np.minimum.accumulate(yv, axis=-1)
    floor = floor_fraction * np.max(np.where(valid, np.abs(y), 0.0), axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        rise = np.where(valid & np.isfinite(run_min), (y - run_min) / np.maximum(run_min, floor + 1e-300), 0.0)
    return np.max(rise, axis=-1)


def _enu(zenith_deg, azimuth_deg):
    z = np.radians(zenith_deg)
    a = np.radians(azimuth_deg)
    return np.stack([np.sin(z) * np.sin(a), np.sin(z) * np.cos(a), np.cos(z)], axis=-1)


def profile_directions(sun_elevation_deg: float):
    """View directions (east-north-up, sun at azimuth 180) of every checked profile for one solar elevation [deg].

    Returns
    -------
    dict of ndarray: ``almucantar`` (nZ, nAz, 3), ``vertical`` (nV, nTh, 3), ``aureole`` (8, nG, 3) with
    ``aureole_valid`` (8, nG) bool (above :data:`AUREOLE_MAX_ZENITH_DEG`), ``zenith`` (1 + 16, 3): the zenith, then
    a ring of :data:`ZENITH_RING_DEG`.
    """
    az = np.arange(0.0, 180.0 + 1e-9, ALMUCANTAR_STEP_DEG)
    alm = np.stack([_enu(np.full_like(az, z), 180.0 + az) for z in ALMUCANTAR_ZENITHS_DEG])
    th = np.arange(0.0, 89.5 + 1e-9, VERTICAL_STEP_DEG)
    ver = np.stack([_enu(th, np.full_like(th, 180.0 + a)) for a in VERTICAL_AZIMUTHS_DEG])
    dirs, valid = aureole_rays(sun_elevation_deg, AUREOLE_GAMMAS_DEG)
    ring = _enu(np.full(16, ZENITH_RING_DEG), np.arange(16) * 22.5)
    zen = np.concatenate([[[0.0, 0.0, 1.0]], ring])
    return {"almucantar": alm, "vertical": ver, "aureole": dirs, "aureole_valid": valid, "zenith": zen}


AUREOLE_GAMMAS_DEG = np.arange(0.25, AUREOLE_MAX_DEG + 1e-9, 0.25)
"""Angles from the sun [deg] of the samples along the checked aureole rays."""


def aureole_rays(sun_elevation_deg: float, gammas_deg):
    """Directions (east-north-up, sun at azimuth 180) along the 8 aureole rays (position angles 0, 45, ... 315 deg, 0
    toward the zenith) at angles ``gammas_deg`` (n,) [deg] from a sun at ``sun_elevation_deg`` [deg]: (8, n, 3), with
    (8, n) bool, True above view zenith :data:`AUREOLE_MAX_ZENITH_DEG`."""
    s = _enu(np.array(90.0 - sun_elevation_deg), np.array(180.0))
    up = np.array([0.0, 0.0, 1.0]) - s * s[2]
    up = up / np.linalg.norm(up) if np.linalg.norm(up) > 1e-9 else np.array([0.0, -1.0, 0.0])
    side = np.cross(s, up)
    g = np.radians(np.asarray(gammas_deg, float))
    psi = np.radians(np.arange(0.0, 360.0, 45.0))
    dirs = (np.cos(g)[None, :, None] * s + np.sin(g)[None, :, None] *
            (np.cos(psi)[:, None, None] * up + np.sin(psi)[:, None, None] * side))
    valid = np.degrees(np.arccos(np.clip(dirs[..., 2], -1, 1))) < AUREOLE_MAX_ZENITH_DEG
    return dirs, valid


def _last(a, n):
    """Move the profile's ``n`` leading axes to the end."""
    return np.moveaxis(a, list(range(n)), list(range(a.ndim - n, a.ndim)))


def held_valid(rays, valid):
    """Aureole rays ``rays`` (..., nG) with the points outside ``valid`` (same shape, bool) held at the nearest valid
    value: the valid part of a ray is contiguous (a prefix where the ray runs toward the horizon, a suffix where it
    rises from a sun below :data:`AUREOLE_MAX_ZENITH_DEG`), so holding the last valid value after it and the first one
    before it adds no turning point."""
    n = rays.shape[-1]
    idx = np.maximum.accumulate(np.where(valid, np.arange(n), -1), axis=-1)
    first = np.argmax(valid, axis=-1)[..., None]
    idx = np.where(idx < 0, first, idx)
    return np.take_along_axis(np.where(valid, rays, 0.0), idx, axis=-1)


def profile_turning_points(radiance: dict, aureole_valid, rel_tol: float = REL_TOL,
                           floor_fraction: float = FLOOR_FRACTION) -> dict:
    """Turning points of every single profile (radiance as for :func:`profile_metrics`; hysteresis ``rel_tol`` [1] with
    the absolute floor ``floor_fraction`` [1], as :func:`turning_points`): dict of int arrays ``almucantar``
    (..., C, nZ), ``vertical`` (..., C, nV), ``aureole`` (..., C, 8) (the ray's checked part only)."""
    aur = _last(radiance["aureole"], 2)                                          # (..., C, 8, nG)
    held = held_valid(aur, np.broadcast_to(_last(np.asarray(aureole_valid), 2), aur.shape))
    return {"almucantar": turning_points(_last(radiance["almucantar"], 2), rel_tol, floor_fraction),
            "vertical": turning_points(_last(radiance["vertical"], 2), rel_tol, floor_fraction),
            "aureole": turning_points(held, rel_tol, floor_fraction)}


def profile_metrics(radiance: dict, aureole_valid, sun_elevation_deg: float, rel_tol: float = REL_TOL) -> dict:
    """Smoothness metrics from the radiance along the profiles of :func:`profile_directions` for one solar elevation.

    Parameters
    ----------
    radiance : dict with the keys of :func:`profile_directions`, each of the profile's shape + (..., C): trailing
        axes are sky states and channels [W m-2 sr-1 nm-1].
    aureole_valid : bool, the aureole's shape + ones for the trailing axes.

    Returns
    -------
    dict of (..., C) arrays: almucantar_tp (max over almucantars), almucantar_excess (spurious turning points summed
    over almucantars: above 1 each), vertical_tp (max), aureole_tp (max over rays), aureole_rise [1] (largest rise
    above the running minimum, max over rays; reported, not a criterion), zenith_spot [1].
    """
    tp = profile_turning_points(radiance, aureole_valid, rel_tol)
    tp_alm, tp_ver, tp_aur = tp["almucantar"], tp["vertical"], tp["aureole"]
    aur = _last(radiance["aureole"], 2)
    valid = np.broadcast_to(_last(np.asarray(aureole_valid), 2), aur.shape)
    rise = monotone_violations(aur, rel_tol, valid=valid)
    z = radiance["zenith"]
    ring = z[1:].mean(axis=0)
    # relative to the ring, floored at FLOOR_FRACTION of the larger of the two (a zero ring around a lit zenith counts
    # as 1000, not as infinity)
    spot = np.abs(z[0] - ring) / np.maximum(ring, FLOOR_FRACTION * np.maximum(z[0], ring) + 1e-300)
    if 90.0 - sun_elevation_deg < 15.0:
        spot = np.zeros_like(spot)  # the zenith lies in the aureole: the aureole check covers it
    return {"almucantar_tp": tp_alm.max(axis=-1), "almucantar_excess": np.maximum(tp_alm - 1, 0).sum(axis=-1),
            "vertical_tp": tp_ver.max(axis=-1), "aureole_tp": tp_aur.max(axis=-1), "aureole_rise": rise.max(axis=-1),
            "zenith_spot": spot}


def _fails(m, rel_tol):
    """Boolean (C,) per metric set: any profile beyond its limit."""
    return (m["almucantar_tp"] > MAX_ALMUCANTAR_TP) | (m["vertical_tp"] > MAX_VERTICAL_TP) | \
        (m["aureole_tp"] > MAX_AUREOLE_TP) | (m["zenith_spot"] > ZENITH_SPOT_TOL)


LIMITS = {"almucantar": MAX_ALMUCANTAR_TP, "vertical": MAX_VERTICAL_TP, "aureole": MAX_AUREOLE_TP}
"""Turning points allowed per profile kind (the check's limits)."""


def check_states(model, states, rel_tol: float = REL_TOL, reference=None) -> list:
    """Run the check on ``model`` for sky states ``states`` = [(visibility [km], elevation [deg], albedo [1]), ...].

    ``reference`` (optional, :func:`reference_from_entries`): the solver's own turning points at the grid states. A
    profile then fails only where it has more turning points than both the limit and the reference at that profile
    (:func:`allowed_turning_points`: at a grid state its own solve, between grid states the most of the bracketing
    grid states'); ``fails_plain`` keeps the verdict by the limits alone.

    Returns
    -------
    list of dict per state (in the order given): visibility, elevation, albedo, checked (C,) bool (channels with
    measurable energy), the metrics of :func:`profile_metrics`, profile_tp (turning points of every profile), fails
    and fails_plain (C,) bool.
    """
    keys = ("almucantar", "vertical", "aureole", "zenith")
    th = np.arange(2.5, 90.0, 5.0)  # the hemisphere for the energy criterion: 5 deg cells
    ph = np.arange(2.5, 360.0, 5.0)
    T, P = np.meshgrid(th, ph, indexing="ij")
    hemi = _enu(T.ravel(), P.ravel())
    w = (np.sin(np.radians(T)) * np.cos(np.radians(T))).ravel()[None, :, None]
    out = [None] * len(states)
    by_ele = {}
    for i, (vis, ele, alb) in enumerate(states):
        by_ele.setdefault(float(ele), []).append(i)
    for ele, idx in by_ele.items():
        d = profile_directions(ele)
        flat = np.concatenate([d[k].reshape(-1, 3) for k in keys] + [hemi])
        vis = np.array([states[i][0] for i in idx], float)
        alb = np.array([states[i][2] for i in idx], float)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # clamping at the grid's edges is the user's view too
            L = sky_radiance(model, flat, np.full(len(idx), ele), np.full(len(idx), 180.0), vis, alb)
        L = L.reshape(len(idx), len(flat), -1)                   # (S, N, C)
        n_prof = len(flat) - len(hemi)
        e = np.sum(w * L[:, n_prof:], axis=1)                      # (S, C)
        checked = e >= MIN_ENERGY_FRACTION * e.max(axis=1, keepdims=True)
        rad, j = {}, 0
        for k in keys:
            n = int(np.prod(d[k].shape[:-1]))
            rad[k] = np.moveaxis(L[:, j:j + n].reshape((len(idx),) + d[k].shape[:-1] + (L.shape[-1],)), 0, -2)
            j += n
        m = profile_metrics(rad, d["aureole_valid"][..., None], ele, rel_tol)  # arrays (S, C)
        tp = profile_turning_points(rad, d["aureole_valid"][..., None], rel_tol)  # arrays (S, C, n)
        f = _fails(m, rel_tol) & checked
        for q, i in enumerate(idx):
            fq = f[q]
            extra = {}
            if reference is not None:
                spot = (m["zenith_spot"][q] > ZENITH_SPOT_TOL) & checked[q]

                def beyond(allow):
                    return spot | np.any([(tp[k][q] > allow[k]).any(axis=-1) & checked[q] for k in LIMITS], axis=0)

                fq = beyond(allowed_turning_points(reference, states[i], L.shape[-1]))
                if tuple(float(x) for x in states[i]) in reference.get("own", {}):
                    extra["fails_bracket"] = beyond(allowed_turning_points(reference, states[i], L.shape[-1], False))
            out[i] = {"visibility": float(states[i][0]), "elevation": ele, "albedo": float(states[i][2]),
                      "checked": checked[q], **{k: v[q] for k, v in m.items()}, "fails": fq, "fails_plain": f[q],
                      **extra, "profile_tp": {k: v[q] for k, v in tp.items()}}
    return out


def _log_interpolator(zenith_deg, azimuth_deg, radiance):
    """A function of view directions (..., 3) (east-north-up, sun at azimuth 180) giving the solver's radiance
    ``radiance`` (T, P, C) [W m-2 sr-1 nm-1], on a product grid of view zeniths ``zenith_deg`` (T,) and relative
    azimuths ``azimuth_deg`` (P,, 0 = toward the sun ... 180) [deg], interpolated bilinearly in log radiance (clamped
    to the grid): (..., C)."""
    from scipy.interpolate import RegularGridInterpolator

    zen = np.asarray(zenith_deg, float)
    az = np.asarray(azimuth_deg, float)
    logr = np.log(np.maximum(np.asarray(radiance, float), 1e-300))
    f = RegularGridInterpolator((zen, az), logr, bounds_error=False, fill_value=None)

    def at(v):
        z = np.clip(np.degrees(np.arccos(np.clip(v[..., 2], -1, 1))), zen[0], zen[-1])
        a = np.degrees(np.arctan2(v[..., 0], v[..., 1]))
        rel = np.clip(np.abs(a % 360.0 - 180.0), az[0], az[-1])
        return np.exp(f(np.stack([z.ravel(), rel.ravel()], -1))).reshape(v.shape[:-1] + (logr.shape[-1],))

    return at


def solver_profiles(zenith_deg, azimuth_deg, radiance, sun_elevation_deg: float) -> dict:
    """The solver's radiance ``radiance`` (T, P, C) [W m-2 sr-1 nm-1] on a product grid of view zeniths ``zenith_deg``
    (T,) and relative azimuths ``azimuth_deg`` (P,, 0 = toward the sun ... 180) [deg], with the sun at
    ``sun_elevation_deg`` [deg], interpolated bilinearly in log radiance onto the profiles of
    :func:`profile_directions`: dict ``almucantar``, ``vertical``, ``aureole``, each the profile's shape + (C,)."""
    d = profile_directions(sun_elevation_deg)
    at = _log_interpolator(zenith_deg, azimuth_deg, radiance)
    return {k: at(d[k]) for k in ("almucantar", "vertical", "aureole")}


def turning_point_indices(y, rel_tol: float = REL_TOL, floor_fraction: float = FLOOR_FRACTION) -> list:
    """Sample indices of the extrema that :func:`turning_points` counts along one profile ``y`` (n,) (any unit): the
    extreme before each counted reversal, in order; ``len`` equals :func:`turning_points` (for diagnostics: where a
    file's turning points lie against the solver's)."""
    y = np.asarray(y, float)
    floor = floor_fraction * np.max(np.abs(y))
    hi = lo = ext = y[0]
    i_ext = 0
    trend, out = 0, []
    for k in range(1, len(y)):
        v = y[k]
        if trend == 0:  # as turning_points: a trend starts once the profile leaves its range; that start is no extremum
            hi, lo = max(hi, v), min(lo, v)
            if v - lo > max(rel_tol * abs(lo), floor):
                trend, ext, i_ext = 1, v, k
            elif hi - v > max(rel_tol * abs(hi), floor):
                trend, ext, i_ext = -1, v, k
            continue
        tol = max(rel_tol * abs(ext), floor)
        if trend == 1 and ext - v > tol:
            out.append(i_ext)
            trend, ext, i_ext = -1, v, k
        elif trend == -1 and v - ext > tol:
            out.append(i_ext)
            trend, ext, i_ext = 1, v, k
        elif (trend == 1 and v > ext) or (trend == -1 and v < ext):
            ext, i_ext = v, k
    return out


VERTICAL_REFERENCE_HORIZON_DEG = (89.75, 90.0)
"""View zeniths [deg] past the checked verticals' end (89.5 deg) at which the solver's verticals are also read
(:func:`solver_turning_points`): an extremum of the solver's sky inside the checked part whose reversal only completes
past 89.5 deg (the minimum at 89 deg over a white ground at sun 0 deg, whose rise to the horizon is 1.3 %) is the
solver's own, and the file's turning point there is allowed."""


def _vertical_horizon_counts(zenith_deg, azimuth_deg, radiance, rel_tol, floor_fraction):
    """(C, nV) turning points of the solver's verticals read on to :data:`VERTICAL_REFERENCE_HORIZON_DEG`, counting
    only the extrema that lie in the checked part (view zenith up to 89.5 deg)."""
    from scipy.interpolate import RegularGridInterpolator

    zen = np.asarray(zenith_deg, float)
    az = np.asarray(azimuth_deg, float)
    th = np.arange(0.0, 89.5 + 1e-9, VERTICAL_STEP_DEG)
    n_in = th.size
    th = np.concatenate([th, VERTICAL_REFERENCE_HORIZON_DEG])
    logr = np.log(np.maximum(np.asarray(radiance, float), 1e-300))
    f = RegularGridInterpolator((zen, az), logr, bounds_error=False, fill_value=None)
    C = logr.shape[-1]
    out = np.zeros((C, len(VERTICAL_AZIMUTHS_DEG)), np.int64)
    for j, a in enumerate(VERTICAL_AZIMUTHS_DEG):
        pts = np.stack([np.clip(th, zen[0], zen[-1]), np.full_like(th, np.clip(a, az[0], az[-1]))], -1)
        y = np.exp(f(pts))                                                       # (n, C)
        for c in range(C):
            out[c, j] = sum(1 for i in turning_point_indices(y[:, c], rel_tol, floor_fraction) if i < n_in)
    return out


AUREOLE_REFERENCE_READ_ON_DEG = 15.0
"""Angle from the sun [deg] to which the solver's aureole rays are read on past the checked rays' end
(:data:`AUREOLE_MAX_DEG`, 12 deg) in :func:`solver_turning_points`: an extremum of the solver's sky inside the checked
part whose reversal only completes past 12 deg (the maximum 9.75 deg from a sun at 5.25 deg on the rays at position
angle +-45 deg, 380 nm, whose fall is 0.18 % by 12 deg and 4.7 % by 20 deg) is the solver's own, and the file's turning
point there is allowed."""


def _aureole_read_on_counts(zenith_deg, azimuth_deg, radiance, sun_elevation_deg, rel_tol, floor_fraction):
    """(C, 8) turning points of the solver's aureole rays read on to :data:`AUREOLE_REFERENCE_READ_ON_DEG`, counting
    only the extrema that lie in the checked part (up to :data:`AUREOLE_MAX_DEG` from the sun, above view zenith
    :data:`AUREOLE_MAX_ZENITH_DEG`; points below that zenith are held as on the checked rays)."""
    n_in = AUREOLE_GAMMAS_DEG.size
    step = AUREOLE_GAMMAS_DEG[1] - AUREOLE_GAMMAS_DEG[0]
    g = np.concatenate([AUREOLE_GAMMAS_DEG, np.arange(AUREOLE_MAX_DEG + step, AUREOLE_REFERENCE_READ_ON_DEG + 1e-9,
                                                      step)])
    dirs, valid = aureole_rays(sun_elevation_deg, g)
    y = np.moveaxis(_log_interpolator(zenith_deg, azimuth_deg, radiance)(dirs), -1, 0)        # (C, 8, n)
    y = held_valid(y, np.broadcast_to(valid, y.shape))
    out = np.zeros(y.shape[:2], np.int64)
    for c in range(y.shape[0]):
        for j in range(y.shape[1]):
            out[c, j] = sum(1 for i in turning_point_indices(y[c, j], rel_tol, floor_fraction) if i < n_in)
    return out


def solver_turning_points(zenith_deg, azimuth_deg, radiance, sun_elevation_deg: float,
                          rel_tol: float = REFERENCE_REL_TOL, floor_fraction: float = REFERENCE_FLOOR_FRACTION):
    """Turning points of the solver's own radiance along every profile: ``radiance`` (T, P, C) [W m-2 sr-1 nm-1] on a
    product grid of view zeniths ``zenith_deg`` (T,) and relative azimuths ``azimuth_deg`` (P,, 0 = toward the sun
    ... 180) [deg] with the sun at ``sun_elevation_deg`` [deg], interpolated bilinearly in log radiance onto the
    profiles of :func:`profile_directions`, counted with the guard band's hysteresis (:data:`REFERENCE_REL_TOL`,
    :data:`REFERENCE_FLOOR_FRACTION`; pass :data:`REL_TOL`, :data:`FLOOR_FRACTION` for the check's own); a vertical
    also counts the extrema in its checked part whose reversal completes past it, toward the horizon
    (:data:`VERTICAL_REFERENCE_HORIZON_DEG`), and an aureole ray the extrema in its checked part whose reversal
    completes past its end (:data:`AUREOLE_REFERENCE_READ_ON_DEG`). Returns :func:`profile_turning_points`' dict of (C, n) int arrays."""
    rad = solver_profiles(zenith_deg, azimuth_deg, radiance, sun_elevation_deg)
    valid = profile_directions(sun_elevation_deg)["aureole_valid"]
    tp = profile_turning_points(rad, valid[..., None], rel_tol, floor_fraction)
    tp["vertical"] = np.maximum(tp["vertical"], _vertical_horizon_counts(zenith_deg, azimuth_deg, radiance, rel_tol,
                                                                         floor_fraction))
    tp["aureole"] = np.maximum(tp["aureole"], _aureole_read_on_counts(zenith_deg, azimuth_deg, radiance,
                                                                      sun_elevation_deg, rel_tol, floor_fraction))
    return tp


def reference_entries(reference: dict) -> list:
    """The profiles where the solver's own sky has more turning points than the limit, as JSON-ready rows
    ``[visibility, elevation, albedo, channel index, kind, profile index, turning points]`` (``reference``:
    {(visibility [km], elevation [deg], albedo [1]): :func:`solver_turning_points` dict})."""
    rows = []
    for (v, e, a), tp in sorted(reference.items()):
        for k, lim in LIMITS.items():
            for c, j in zip(*np.nonzero(np.asarray(tp[k]) > lim)):
                rows.append([float(v), float(e), float(a), int(c), k, int(j), int(tp[k][c, j])])
    return rows


def _rows_by_state(rows) -> dict:
    tp = {}
    for v, e, a, c, k, j, n in rows:
        tp.setdefault((float(v), float(e), float(a)), {}).setdefault(k, {})[(int(c), int(j))] = int(n)
    return tp


def reference_from_entries(rows, grid, between=None) -> dict:
    """Inverse of :func:`reference_entries`: {"grid": (visibilities, elevations, albedos) of the dataset,
    "tp": {(v, e, a): {kind: {(channel, profile): turning points}}}} for :func:`check_states`; with ``between``
    (:func:`widesky.skymodel.generator.smoothness_between.between_reference`: the (state, channel) pairs off the grid
    re-examined against the solver's sky solved there, and its rows) also "own": {(v, e, a): {channel, ...}} and
    "own_tp" (as "tp"), which replace the bracketing rule for those pairs (:func:`allowed_turning_points`)."""
    out = {"grid": tuple(np.asarray(x, float) for x in grid), "tp": _rows_by_state(rows)}
    if between is not None:
        own = {}
        for v, e, a, c in between["examined"]:
            own.setdefault((float(v), float(e), float(a)), set()).add(int(c))
        out["own"], out["own_tp"] = own, _rows_by_state(between["rows"])
    return out


def _bracket(x, grid):
    """The grid values around ``x``: [x] on a grid value, else the two neighbours (the edge value outside)."""
    g = np.asarray(grid, float)
    hit = np.isclose(g, x, rtol=1e-9, atol=1e-9)
    if hit.any():
        return [float(g[hit][0])]
    i = int(np.clip(np.searchsorted(g, x), 1, len(g) - 1))
    return [float(g[i - 1]), float(g[i])] if g[0] < x < g[-1] else [float(g[0] if x < g[0] else g[-1])]


def allowed_turning_points(reference: dict, state, n_channels: int, own: bool = True) -> dict:
    """Turning points allowed per profile at ``state`` (visibility, elevation, albedo): the limit, or the solver's own
    count where that is larger, at a grid state that state's, between grid states the largest of the bracketing grid
    states' (in each of the three dimensions), except for the channels solved at the state itself (the reference's
    "own", with ``own``): there the solve's. Returns {kind: (C, n) int}."""
    n_prof = {"almucantar": len(ALMUCANTAR_ZENITHS_DEG), "vertical": len(VERTICAL_AZIMUTHS_DEG), "aureole": 8}
    out = {k: np.full((n_channels, n_prof[k]), lim) for k, lim in LIMITS.items()}
    gv, ge, ga = reference["grid"]
    for v in _bracket(state[0], gv):
        for e in _bracket(state[1], ge):
            for a in _bracket(state[2], ga):
                for k, d in reference["tp"].get((v, e, a), {}).items():
                    for (c, j), n in d.items():
                        out[k][c, j] = max(out[k][c, j], n)
    key = tuple(float(x) for x in state)
    solved = reference.get("own", {}).get(key, ()) if own else ()
    for c in solved:
        for k, lim in LIMITS.items():
            out[k][c] = lim
    for k, d in (reference.get("own_tp", {}).get(key, {}) if solved else {}).items():
        for (c, j), n in d.items():
            if c in solved:
                out[k][c, j] = max(LIMITS[k], n)
    return out


def grid_states(model) -> list:
    """Every (visibility, elevation, albedo) configuration of the dataset's grid (ground level)."""
    return [(float(v), float(e), float(a)) for v in model.visibilities for e in model.elevations
            for a in model.albedos]


def between_grid_states(model) -> list:
    """States between grid points: geometric midpoints of adjacent visibilities x midpoints of adjacent elevations
    x albedo midpoints (and the grid albedos when there is one)."""
    v = np.asarray(model.visibilities, float)
    e = np.asarray(model.elevations, float)
    a = np.asarray(model.albedos, float)
    vm = np.sqrt(v[1:] * v[:-1]) if len(v) > 1 else v
    em = 0.5 * (e[1:] + e[:-1]) if len(e) > 1 else e
    am = 0.5 * (a[1:] + a[:-1]) if len(a) > 1 else a
    return [(float(x), float(y), float(z)) for x in vm for y in em for z in am]


def check_dataset(model, rel_tol: float = REL_TOL, between: bool = True, reference=None) -> dict:
    """The smoothness check over the grid (and between grid points): {'grid': [...], 'between': [...]}, each a list of
    :func:`check_states` results (``reference``: see there)."""
    res = {"grid": check_states(model, grid_states(model), rel_tol, reference)}
    if between:
        res["between"] = check_states(model, between_grid_states(model), rel_tol, reference)
    return res


def summarise(result: dict, wavelengths_nm=None) -> dict:
    """JSON-ready summary of :func:`check_dataset`: per group, the number of states and of checked (state, channel)
    pairs, the failing pairs per metric, the channels and states that fail, and the worst values."""
    out = {"rel_tol": REL_TOL, "zenith_spot_tol": ZENITH_SPOT_TOL, "reference_rel_tol": REFERENCE_REL_TOL,
           "reference_floor_fraction": REFERENCE_FLOOR_FRACTION, "max_turning_points": {
               "almucantar": MAX_ALMUCANTAR_TP, "vertical": MAX_VERTICAL_TP, "aureole_ray": MAX_AUREOLE_TP},
           "almucantar_zeniths_deg": list(ALMUCANTAR_ZENITHS_DEG), "vertical_azimuths_deg": list(VERTICAL_AZIMUTHS_DEG)}
    for group, rows in result.items():
        if not rows:
            continue
        chk = np.array([r["checked"] for r in rows])
        get = lambda k: np.array([r[k] for r in rows])  # noqa: E731
        fails = get("fails")
        plain = get("fails_plain") if "fails_plain" in rows[0] else fails
        bracket = np.array([r.get("fails_bracket", r["fails"]) for r in rows])
        g = {"states": len(rows), "checked_pairs": int(chk.sum()), "failing_pairs": int(fails.sum()),
             "failing_pairs_by_limits": int(plain.sum()),
             "failing_states": int(fails.any(axis=1).sum()),
             "almucantar_tp_gt1": int(((get("almucantar_tp") > 1) & chk).sum()),
             "vertical_tp_gt2": int(((get("vertical_tp") > 2) & chk).sum()),
             "aureole_tp_gt1": int(((get("aureole_tp") > MAX_AUREOLE_TP) & chk).sum()),
             "zenith_spot_pairs": int(((get("zenith_spot") > ZENITH_SPOT_TOL) & chk).sum()),
             "max_almucantar_tp": int(np.max(np.where(chk, get("almucantar_tp"), 0))),
             "max_aureole_rise": round(float(np.max(np.where(chk, get("aureole_rise"), 0))), 5),
             "max_zenith_spot": round(float(np.max(np.where(chk, get("zenith_spot"), 0))), 5),
             "failing_channels_per_state_max": int(fails.sum(axis=1).max())}
        if any("fails_bracket" in r for r in rows):
            g["failing_pairs_by_bracketing_states"] = int(bracket.sum())
        ele = np.array([r["elevation"] for r in rows])
        g["failing_pairs_by_elevation"] = {f"{e:g}": int(fails[ele == e].sum()) for e in np.unique(ele)}
        g["checked_pairs_by_elevation"] = {f"{e:g}": int(chk[ele == e].sum()) for e in np.unique(ele)}
        if wavelengths_nm is not None:
            wl = np.asarray(wavelengths_nm, float)
            g["failing_channels_nm"] = wl[fails.any(axis=0)].round(1).tolist()
        worst = sorted(range(len(rows)), key=lambda i: -int(fails[i].sum()))[:5]
        g["worst_states"] = [{"visibility": rows[i]["visibility"], "elevation": rows[i]["elevation"],
                              "albedo": rows[i]["albedo"], "failing_channels": int(fails[i].sum())}
                             for i in worst if fails[i].any()]
        out[group] = g
    return out
