"""The solver's own sky at states between grid points, for the smoothness check (issue 11).

Between grid states the check (:mod:`widesky.skymodel.generator.smoothness`) first allows a profile the most turning points
that the solver's own sky has at the bracketing grid states. That rule cannot see what the sky does *between* them:
two neighbours whose rays from the sun have one turning point each, one a minimum close to the sun (the aureole
falling onto the brightening above a low sun), the other a maximum further out, blend into a ray with both, and so
does the sky itself in between (docs/default-dataset.md, "The check"). Every between-grid (state, channel) pair that
fails by that rule is therefore looked at again against the solver's sky solved at that state itself:

- at elevations that the build solves with DISORT, a DISORT solve at the state (its visibility, elevation and
  albedo) on the build's fit directions (:func:`widesky.skymodel.generator.dataset_grid.fit_directions`);
- at elevations that take the split Monte Carlo radiance, what the build itself would solve there: the exact single
  scattering at the state (:func:`widesky.skymodel.generator.dataset_mc.single_scatter`, noise-free) plus the smoothed rest
  (multiple scattering and ground light, a cosine series of order 2 in azimuth, :func:`split_rest`) of the grid's
  Monte Carlo states at the two bracketing elevations, each smoothed across visibility by the build's cubic in log
  visibility and evaluated at the state's visibility, then blended linearly in elevation with the evaluator's weights.

The solver's turning points there (:func:`widesky.skymodel.generator.smoothness.solver_turning_points`) replace the
bracketing rule for that (state, channel): the pair fails only with more turning points than the limit and that
solve. Results are cached in the build cache.
"""

from __future__ import annotations

import hashlib

import numpy as np

from widesky.core.atomic import atomic_write

from .cache import cache_root, load_state
from .dask_scheduler import pool_map
from .dataset_grid import fit_directions
from .dataset_mc import (SPLIT_SMOOTHING, mc_file, mc_key, radiance_by_mc, single_scatter, smooth_across_visibility,
                         split_rest, split_state)
from .dataset_solve import solve_state
from .smoothness import (AUREOLE_REFERENCE_READ_ON_DEG, LIMITS, REFERENCE_FLOOR_FRACTION, REFERENCE_REL_TOL,
                         VERTICAL_REFERENCE_HORIZON_DEG, between_grid_states, check_states, solver_turning_points)

__all__ = ["solvable", "between_state_radiance", "between_reference"]


def _elevation_bracket(grid_deg, elevation_deg: float):
    """Grid elevations around ``elevation_deg`` and the evaluator's linear weights: [(elevation, weight), ...]."""
    g = np.asarray(grid_deg, float)
    k = int(np.clip(np.searchsorted(g, elevation_deg, side="right"), 1, len(g) - 1))
    f = float(np.clip((elevation_deg - g[k - 1]) / (g[k] - g[k - 1]), 0.0, 1.0))
    return [(float(g[k - 1]), 1.0 - f), (float(g[k]), f)]


def _split_rest_at(config, elevation_deg: float, albedo: float, zenith_deg, azimuth_deg, visibility_km: float):
    """The grid's split rest at grid elevation ``elevation_deg`` [deg] and ``albedo`` [1] on the product grid
    ``zenith_deg`` x ``azimuth_deg`` [deg], smoothed across the grid visibilities and evaluated at ``visibility_km``
    [km]: (T, P, 55) [W m-2 sr-1 nm-1]."""
    vis = [float(v) for v in config.visibilities_km]
    rests = np.stack([split_rest(load_state(mc_file(config, v, elevation_deg)), albedo, zenith_deg, azimuth_deg)
                      for v in vis])
    return smooth_across_visibility(rests, vis, at_km=[visibility_km])[0]


def solvable(config, elevation_deg: float) -> str | None:
    """How the solver's own sky at an off-grid elevation [deg] is had: "split" (exact single scattering plus the
    bracketing split states' rest), "disort", or None where the build has no noise-free reference there (a sky taken
    from an unsplit Monte Carlo solution, e.g. a polarised or twilight build, or below ``min_solve_elevation_deg`` in
    a plane-parallel one); such pairs keep the bracketing rule."""
    if split_state(config, elevation_deg):
        ok = all(split_state(config, e) for e, _ in _elevation_bracket(config.elevations_deg, elevation_deg))
        return "split" if ok else None
    if radiance_by_mc(config, elevation_deg) or elevation_deg < float(config.min_solve_elevation_deg):
        return None
    return "disort"


def between_state_radiance(config, visibility_km: float, elevation_deg: float, albedo: float, channels=None,
                           data_dir=None):
    """The solver's own sky at a state off the grid (see the module docstring), on the build's fit directions.

    Parameters
    ----------
    config : :class:`widesky.skymodel.generator.dataset_build.BuildConfig` (its cache holds the grid's Monte Carlo states).
    visibility_km [km], elevation_deg [deg], albedo [1]: the state.
    channels : channel indices (0..54) to return (default all 55).

    Returns
    -------
    zenith (T,) [deg], relative azimuth (P,) [deg], radiance (T, P, C) [W m-2 sr-1 nm-1].
    """
    ch = np.arange(55) if channels is None else np.asarray(channels, int)
    th, ph = fit_directions(elevation_deg, config.zenith_step_deg)
    bracket = _elevation_bracket(config.elevations_deg, elevation_deg)
    how = solvable(config, elevation_deg)
    if how is None:
        raise ValueError(f"no noise-free solver reference at elevation {elevation_deg} deg for this configuration")
    if how == "split":
        single = single_scatter(visibility_km, elevation_deg, th, ph, config, data_dir, channels=ch)
        rest = sum(w * _split_rest_at(config, e, albedo, th, ph, visibility_km)[..., ch] for e, w in bracket if w)
        return th, ph, single + np.maximum(rest, 0.0)
    s = solve_state(visibility_km, elevation_deg, config, th, ph, albedo=albedo, data_dir=data_dir, channels=ch)
    return th, ph, s["radiance"][..., ch]


def _reference_file(config, visibility_km, elevation_deg, albedo, channels):
    """Cache file of one state's turning points [.npz], named by what the solve depends on beyond the solver's key:
    the channels, the reference's hysteresis and how far its verticals and aureole rays are read on past the checked
    part, and for the split Monte Carlo states their key, smoothing and the grid they are blended from."""
    parts = [[int(c) for c in channels], REFERENCE_REL_TOL, REFERENCE_FLOOR_FRACTION,
             ["read on", list(VERTICAL_REFERENCE_HORIZON_DEG), AUREOLE_REFERENCE_READ_ON_DEG]]
    if split_state(config, elevation_deg):
        parts += [mc_key(config), SPLIT_SMOOTHING, [float(v) for v in config.visibilities_km],
                  [float(e) for e in config.elevations_deg]]
    key = hashlib.sha1(repr(parts).encode()).hexdigest()[:8]
    return cache_root(config) / (f"smoothbetween_v{visibility_km:.4f}_e{elevation_deg:.4f}_a{albedo:.4f}_{key}"
                                 ".npz")


def _reference_job(job):
    """Turning points of the solver's own sky at one state for some channels: (state, channels, {kind: (C, n)})."""
    config, state, channels = job

    path = _reference_file(config, *state, channels)
    if path.exists():
        with np.load(path) as z:
            return state, channels, {k: z[k] for k in ("almucantar", "vertical", "aureole")}
    th, ph, rad = between_state_radiance(config, *state, channels=channels)
    tp = solver_turning_points(th, ph, rad, state[1])
    with atomic_write(path) as tmp:
        np.savez(tmp, **tp)
    return state, channels, tp


def between_reference(config, model, grid_reference, processes: int = 2, progress: bool = True) -> dict:
    """Re-examine every between-grid (state, channel) pair of ``model`` that fails the smoothness check by the
    bracketing rule (``grid_reference``: :func:`widesky.skymodel.generator.smoothness.reference_from_entries` of the grid
    rows) against the solver's own sky at that state.

    Returns
    -------
    dict, JSON-ready: ``examined`` [[visibility km, elevation deg, albedo, channel index], ...] (the pairs at
    elevations where :func:`solvable` gives a reference; the others keep the bracketing rule) and ``rows`` (the
    profiles of those pairs where the solve has more turning points than the limit, as
    :func:`widesky.skymodel.generator.smoothness.reference_entries` rows), for
    :func:`widesky.skymodel.generator.smoothness.reference_from_entries`'s ``between``.
    """
    states = between_grid_states(model)
    rows = check_states(model, states, reference=grid_reference)
    jobs = [(config, s, [int(c) for c in np.flatnonzero(r["fails"])]) for s, r in zip(states, rows)
            if r["fails"].any() and solvable(config, s[1]) is not None]
    examined, out = [], []
    for state, channels, tp in pool_map(_reference_job, jobs, processes, progress, "between-grid solves"):
        for q, c in enumerate(channels):
            examined.append([float(state[0]), float(state[1]), float(state[2]), int(c)])
            for k, lim in LIMITS.items():
                for j in np.flatnonzero(np.asarray(tp[k])[q] > lim):
                    out.append([float(state[0]), float(state[1]), float(state[2]), int(c), k, int(j),
                                int(tp[k][q][j])])
    return {"examined": sorted(examined), "rows": sorted(out)}
