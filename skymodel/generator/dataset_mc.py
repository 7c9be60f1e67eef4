"""Monte Carlo sky states of a dataset build: polarisation, low sun and twilight (``widesky dataset build``).

A build configuration turns the Monte Carlo solver (:mod:`widesky.skymodel.generator.montecarlo`) on with
``polarisation: true`` (every fitted grid state gets a polarised Monte Carlo solution, whose degree of polarisation
fills the format's polarisation section) and/or ``mc_below_elevation_deg`` (grid elevations below it take their sky
radiance from the Monte Carlo solution in spherical shells instead of plane-parallel DISORT; elevations below 0 deg,
down to -4.2 deg as the official datasets, need it). Without those keys a build is the scalar DISORT build, byte
for byte and with the same cache keys.

One Monte Carlo state = one (visibility, solar elevation) on its own product grid of view zeniths x relative
azimuths (:func:`mc_directions`), all 55 channels in batches of neighbouring channels that share paths, traced over
a white ground with the contributions split by the number of ground reflections (``ground_orders``), so that every
albedo of the grid comes from one run (:func:`widesky.skymodel.generator.montecarlo.stokes_at_albedo`), with the random
stream mode of ``mc_streams`` (default "correlated": common random numbers across the state's directions, so that
its error is a smooth field over the sky rather than a speckle; docs/atmosphere-and-solver.md). It is cached as
``mc_<key>_v<vis>_e<ele>.npz`` beside the DISORT states, ``<key>`` hashing everything that changes its numbers.

**Polarisation quantity** (what the format's polarisation factors hold; docs/atmosphere-and-solver.md). The
reference's ``polarisation()`` returns the negated stored value; we store P = Q_s / I, with Q_s the Stokes Q referred
to the scattering plane (the plane through the sun, the observer and the view direction; Q_s > 0 polarised in that
plane), so that readers get -Q_s / I = (I_perp - I_par) / I: the signed degree of linear polarisation, positive where
skylight is polarised perpendicular to the scattering plane (Rayleigh scattering), negative near the neutral points.
Its magnitude equals the degree of linear polarisation sqrt(Q^2 + U^2) / I wherever the polarisation is
perpendicular or parallel to the scattering plane (exactly in the sun's vertical, by symmetry); elsewhere it is
smaller by cos(2 chi) for a rotation chi of the plane of polarisation (measured by :func:`polarisation_summary`).
"""

from __future__ import annotations

import hashlib
import json
import time

import numpy as np

from widesky.core.atomic import atomic_write

from .cache import cache_root, load_state, state_file
from .dataset_grid import AZIMUTHS_DEG, direction_samples, fit_directions, fit_weights, knots
from .fit import fit_radiance
from .montecarlo import MonteCarloConfig, _unit_views, solve_sky_mc, stokes_at_albedo
from .solver import MAX_VIEW_ZENITH_DEG, SkyState

MC_AZIMUTHS_DEG = (0.0, 1.0, 2.5, 5.0, 10.0, 17.0, 25.0, 35.0, 47.5, 60.0, 75.0, 90.0, 105.0, 120.0, 135.0, 150.0,
                   165.0, 180.0)
"""Default relative azimuths of the Monte Carlo direction grid [deg] (0 = toward the sun), refined near the sun."""
MC_FIRST_ORDER = {"radiance": "quadrature", "polarisation": "sampled"}
"""First-order method (:class:`widesky.skymodel.generator.montecarlo.MonteCarloConfig`) of the build's Monte Carlo states
whose radiance is used (low sun and twilight: the quadrature, 3-185x more efficient at -2 deg) and of those that only
give the polarisation (sun higher up: the original sampled estimator, whose degree of polarisation is as good or
better at 36 deg; docs/atmosphere-and-solver.md, "Variance reduction")."""
MC_SUN_OFFSETS_DEG = (1.0, 3.0)
"""Offsets of extra view zeniths around the solar zenith [deg] (sun above the horizon)."""


def uses_mc(config) -> bool:
    """Whether the build configuration needs Monte Carlo states at all."""
    return bool(config.polarisation) or config.mc_below_elevation_deg is not None


def radiance_by_mc(config, elevation_deg: float) -> bool:
    """Whether the sky radiance of grid elevation ``elevation_deg`` [deg] comes from the Monte Carlo solution."""
    b = config.mc_below_elevation_deg
    return b is not None and float(elevation_deg) < float(b)


SPLIT_SMOOTHING = "cos2-pole-lam1e-3-xv3"
"""Name of the split states' smoothing (:func:`split_rest`: azimuth orders, regularity at the zenith, zenith penalty;
:func:`smooth_across_visibility`: the polynomial degree in log visibility); part of the cache names of what is
computed from it (fits, validation states, :func:`rest_across_visibility` files), so that a change of it never reuses
stale results."""

SPLIT_VALIDATION_SAMPLES_FACTOR = 4
"""Paths per direction of a split validation state's own Monte Carlo run (one between grid points), as a multiple of
``mc_samples``: the reference's noise then halves, so the held-out error measures the dataset more than the
reference (docs/default-dataset.md, "Low sun in spherical shells")."""

SPLIT_VISIBILITY_DEGREE = 3
"""Degree of the polynomial in log visibility that smooths the split states' rest across the visibilities of one
elevation (:func:`smooth_across_visibility`). The solver's own sky-diffuse irradiance departs from a cubic in log V by
at most 0.08 % over the 11 visibilities 20-131.8 km (DISORT, sun 10.5 and 13.5 deg, 460-900 nm), the Monte Carlo
rest's by 0.7-1.2 % rms at 460 nm (docs/default-dataset.md, "Low sun in spherical shells")."""

SPLIT_ZENITH_PENALTY = 1e-3
"""Penalty of :func:`split_rest`'s zenith smoothing spline [rad^3, for weights normalised to mean 1]: its
equivalent kernel is about 6 deg wide on the Monte Carlo grid's ~35 mirrored zenith samples (measured choice,
docs/default-dataset.md, "Low sun in spherical shells")."""


def split_state(config, elevation_deg: float) -> bool:
    """Whether the grid elevation ``elevation_deg`` [deg] takes its radiance from a split Monte Carlo state: scalar,
    the singly scattered light exact on the fit grid (``mc_single_scatter_exact``; :func:`split_radiance`)."""
    return bool(config.mc_single_scatter_exact) and radiance_by_mc(config, elevation_deg)


def needs_mc_state(config, elevation_deg: float) -> bool:
    """Whether the grid elevation ``elevation_deg`` [deg] has a Monte Carlo state (polarisation or radiance)."""
    return bool(config.polarisation) or radiance_by_mc(config, elevation_deg)


def mc_config(config, visibility_km: float, elevation_deg: float):
    """The :class:`widesky.skymodel.generator.montecarlo.MonteCarloConfig` of one grid state (its own seed)."""
    h = hashlib.sha1(json.dumps([int(config.mc_seed), round(float(visibility_km), 4),
                                 round(float(elevation_deg), 4)]).encode()).hexdigest()
    return MonteCarloConfig(samples=int(config.mc_samples), seed=int(h[:15], 16),
                            channels_per_batch=int(config.mc_channels_per_batch),
                            ground_orders=int(config.mc_ground_orders), threads=1, streams=config.mc_streams,
                            polarised=not split_state(config, elevation_deg),
                            first_order=MC_FIRST_ORDER["radiance" if radiance_by_mc(config, elevation_deg)
                                                       else "polarisation"])


def mc_key(config) -> str:
    """Hash of everything that changes a Monte Carlo state's numbers (12 hex digits)."""
    d = {"atmosphere": config.atmosphere, "samples": int(config.mc_samples), "seed": int(config.mc_seed),
         "channels_per_batch": int(config.mc_channels_per_batch), "ground_orders": int(config.mc_ground_orders),
         "zenith_step": float(config.mc_zenith_step_deg), "azimuths": [float(x) for x in mc_azimuths(config)],
         "first_order": MC_FIRST_ORDER, "below": config.mc_below_elevation_deg, "v": 3}
    if config.mc_streams != "independent":  # the keys of the builds before the stream modes stay valid
        d["streams"] = config.mc_streams
    if config.mc_single_scatter_exact:  # likewise for the builds before the split
        d["single_scatter_exact"] = True
    return hashlib.sha1(json.dumps(d, sort_keys=True).encode()).hexdigest()[:12]


def mc_azimuths(config) -> np.ndarray:
    """Relative azimuths of the Monte Carlo grid [deg], ascending in [0, 180]."""
    az = MC_AZIMUTHS_DEG if config.mc_azimuths_deg is None else config.mc_azimuths_deg
    return np.unique(np.asarray(az, float))


def mc_file(config, visibility_km: float, elevation_deg: float):
    """Cache file of one Monte Carlo state [.npz]."""
    return cache_root(config) / f"mc_{mc_key(config)}_v{visibility_km:.4f}_e{elevation_deg:.4f}.npz"


def mc_directions(solar_elevation_deg: float, config):
    """Product grid of one Monte Carlo state: view zenith (T,) [deg] ascending in [0, 89.95] (every
    ``mc_zenith_step_deg`` plus a horizon band and, with the sun up, zeniths around the sun) and relative azimuth
    (P,) [deg] (:func:`mc_azimuths`)."""
    step = float(config.mc_zenith_step_deg)
    th = [np.arange(0.0, 89.0, step), [84.0, 87.0, 88.5, MAX_VIEW_ZENITH_DEG]]
    zs = 90.0 - float(solar_elevation_deg)
    if zs < 90.0:
        off = np.asarray(MC_SUN_OFFSETS_DEG)
        th += [[zs], zs + off, zs - off]
    th = np.unique(np.round(np.clip(np.concatenate(th), 0.0, MAX_VIEW_ZENITH_DEG), 6))
    return th, mc_azimuths(config)


def solve_mc_state(visibility_km: float, elevation_deg: float, config, data_dir=None, fine_directions=None) -> dict:
    """Monte Carlo solution of one grid state in spherical shells (polarised; scalar for a split state,
    :func:`split_state`).

    Parameters
    ----------
    fine_directions : (zenith (T2,), azimuth (P2,)) [deg], split states only: the grid of the exact singly scattered
        light (default the DISORT fit grid, :func:`widesky.skymodel.generator.dataset_grid.fit_directions`).

    Returns
    -------
    dict with zenith (T,), azimuth (P,) [deg]; stokes, stderr (T, P, 55, B, 4) (I, Q, U, V) [W m-2 sr-1 nm-1] by
    order of ground reflection (B = ``mc_ground_orders``) in the observer's meridian frame; solved_elevation [deg];
    samples (paths per direction and channel batch); seconds [s]. A split state also holds single (T, P, 55), the
    singly scattered radiance on the Monte Carlo grid, and fine_zenith (T2,), fine_azimuth (P2,), single_fine
    (T2, P2, 55) [W m-2 sr-1 nm-1] on the fine grid.
    """
    t0 = time.perf_counter()
    th, ph = mc_directions(elevation_deg, config)
    T, P = np.meshgrid(th, ph, indexing="ij")
    state = SkyState(45.0, visibility_km=float(visibility_km), ground_albedo=0.0)
    r = solve_sky_mc(state, config.spec(), T.ravel(), P.ravel(), None, mc_config(config, visibility_km, elevation_deg),
                     solar_elevation_deg=float(elevation_deg), data_dir=data_dir)
    shape = (len(th), len(ph)) + r.stokes.shape[1:]
    out = {"zenith": th, "azimuth": ph, "stokes": r.stokes.reshape(shape), "stderr": r.stderr.reshape(shape),
           "solved_elevation": float(elevation_deg), "samples": r.samples}
    if split_state(config, elevation_deg):
        if fine_directions is None:
            fine_directions = fit_directions(elevation_deg, config.zenith_step_deg)
        t2, p2 = (np.asarray(x, float) for x in fine_directions)
        out.update(single=single_scatter(visibility_km, elevation_deg, th, ph, config, data_dir),
                   fine_zenith=t2, fine_azimuth=p2,
                   single_fine=single_scatter(visibility_km, elevation_deg, t2, p2, config, data_dir))
    out["seconds"] = time.perf_counter() - t0
    return out


def single_scatter(visibility_km: float, elevation_deg: float, zenith_deg, azimuth_deg, config, data_dir=None,
                   channels=None):
    """Singly scattered sky radiance of one state in spherical shells, scalar (P11 only), on the product grid of view
    zeniths (T,) and relative azimuths (P,) [deg]: (T, P, C) [W m-2 sr-1 nm-1], C = 55 or ``len(channels)`` (channel
    indices 0..54). Deterministic: the Monte Carlo solver's first-order quadrature along each view ray
    (``max_order=1``; no sampled path contributes), independent of the ground."""
    th, ph = np.asarray(zenith_deg, float), np.asarray(azimuth_deg, float)
    T, P = np.meshgrid(th, ph, indexing="ij")
    state = SkyState(45.0, visibility_km=float(visibility_km), ground_albedo=0.0)
    cfg = MonteCarloConfig(samples=1, polarised=False, max_order=1, ground_orders=0, first_order="quadrature",
                           channels_per_batch=int(config.mc_channels_per_batch), threads=1)
    r = solve_sky_mc(state, config.spec(), T.ravel(), P.ravel(), channels, cfg,
                     solar_elevation_deg=float(elevation_deg), data_dir=data_dir)
    return r.stokes[..., 0].reshape(len(th), len(ph), -1)


def _even_smoothing_spline(x, y, sd, lam: float, x_to) -> np.ndarray:
    """Cubic smoothing spline of samples ``y`` with standard errors ``sd`` at ``x`` >= 0 [rad], constrained even in
    ``x`` (fitted to the samples mirrored onto -x; a sample at x = 0 is not doubled), penalty ``lam`` [rad^3] for
    inverse-variance weights normalised to mean 1; evaluated at ``x_to`` [rad]. Even in x means zero slope at 0."""
    from scipy.interpolate import make_smoothing_spline

    pos = x > 0
    xm = np.concatenate([-x[pos][::-1], x])
    ym = np.concatenate([y[pos][::-1], y])
    wm = 1.0 / np.concatenate([sd[pos][::-1], sd]) ** 2
    return make_smoothing_spline(xm, ym, w=wm / wm.mean(), lam=float(lam))(x_to)


def split_rest(state: dict, albedo: float, zenith_deg=None, azimuth_deg=None, azimuth_orders: int = 2,
               zenith_penalty: float = SPLIT_ZENITH_PENALTY) -> np.ndarray:
    """The smoothed rest of a split Monte Carlo state over a ground of albedo ``albedo`` [1] (orders >= 2 and all
    ground-reflected light: the Monte Carlo total minus its single scattering on the Monte Carlo grid), evaluated on
    the product grid ``zenith_deg`` (T2,) x ``azimuth_deg`` (P2,) [deg] (default the state's fine grid):
    (T2, P2, 55) [W m-2 sr-1 nm-1], not clipped.

    Along each zenith row of the Monte Carlo grid the rest is fitted by the cosine series sum_m a_m(theta) cos(m phi),
    m = 0..``azimuth_orders`` (the azimuthal Fourier form of the radiance field), weighted by the inverse standard
    error. Each coefficient is then smoothed in the view zenith theta as a field on the sphere must be at its pole:
    a_m = sin^m(theta) b_m(theta) with every b_m even in theta (so the m >= 1 terms vanish at the zenith and a_0 has
    zero slope there; without it the noise leaves a spot at the zenith, up to 4 % of the sky at sun 0 deg), b_m a
    cubic smoothing spline weighted by the coefficients' inverse variances with penalty ``zenith_penalty`` [rad^3]
    (:func:`_even_smoothing_spline`).

    Measured at 51.3 km, sun 0 deg, against a 16x longer run (docs/default-dataset.md, "Low sun in spherical
    shells"; median over rows of the largest difference, relative to the row's maximum, the longer run itself noisy
    by about 2 %): 2.7 % (the earlier unconstrained GCV spline 2.5 %, with zenith spots to 4 %); the zenith then
    differs from a ring 2 deg around it by at most 0.6 % at the states measured (sun 0-6 deg). Two azimuth orders
    are what multiple scattering needs at the build's noise level: orders 2 / 3 / 4 of the azimuth fit alone are
    within 2.4 / 2.0 / 2.7 %, and only order 2 adds no almucantar turning points beyond the single scattering's.
    Arguments other than the defaults are for study: the build's cache names assume :data:`SPLIT_SMOOTHING`."""
    value, err = mc_stokes(state, albedo)
    rest = value[..., 0] - np.asarray(state["single"], float)                   # (T, P, C)
    w = 1.0 / np.maximum(err[..., 0], 1e-9 * np.maximum(np.abs(rest).max(axis=1, keepdims=True), 1e-300))
    m = np.arange(int(azimuth_orders) + 1)
    A = np.cos(np.radians(np.asarray(state["azimuth"], float))[:, None] * m)    # (P, M)
    az_to = state["fine_azimuth"] if azimuth_deg is None else azimuth_deg
    A2 = np.cos(np.radians(np.asarray(az_to, float))[:, None] * m)
    Aw = A[None, :, None, :] * w[..., None]                                     # (T, P, C, M)
    normal = np.einsum("tpcm,tpcn->tcmn", Aw, Aw) + 1e-12 * np.eye(len(m))
    coef = np.linalg.solve(normal, np.einsum("tpcm,tpc->tcm", Aw, rest * w)[..., None])[..., 0]  # (T, C, M)
    sd = np.sqrt(np.maximum(np.diagonal(np.linalg.inv(normal), axis1=-2, axis2=-1), 1e-300))    # (T, C, M)
    th = np.radians(np.asarray(state["zenith"], float))
    t2 = np.radians(np.asarray(state["fine_zenith"] if zenith_deg is None else zenith_deg, float))
    fine = np.zeros((len(t2),) + coef.shape[1:])
    for k in m:
        keep = th > 0 if k > 0 else np.ones(len(th), bool)   # at the zenith sin^m = 0 for m >= 1: no information
        tap, tap2 = np.sin(th[keep]) ** k, np.sin(t2) ** k
        for c in range(coef.shape[1]):
            y = coef[keep, c, k]
            if np.any(y != 0.0):
                fine[:, c, k] = tap2 * _even_smoothing_spline(th[keep], y / tap, sd[keep, c, k] / tap,
                                                              zenith_penalty, t2)
    return np.einsum("qm,tcm->tqc", A2, fine)


def split_radiance(state: dict, albedo: float, rest=None, **kw) -> np.ndarray:
    """Radiance of a split Monte Carlo state over a ground of albedo ``albedo`` [1] on its fine grid, (T2, P2, 55)
    [W m-2 sr-1 nm-1]: the exact singly scattered light there plus the smoothed rest (:func:`split_rest` of this
    state with keywords ``kw``, or ``rest`` (T2, P2, 55) given, e.g. from :func:`rest_across_visibility`), the rest
    kept non-negative. The sharp structure of a low-sun sky (aureole, horizon band, the Earth's shadow) is single
    scattering and so noise-free; the rest carries the Monte Carlo noise and is smooth over the sky."""
    if rest is None:
        rest = split_rest(state, albedo, **kw)
    return np.asarray(state["single_fine"], float) + np.maximum(rest, 0.0)


def smooth_across_visibility(values, visibilities_km, degree: int = SPLIT_VISIBILITY_DEGREE,
                             at_km=None) -> np.ndarray:
    """Least-squares polynomial of degree ``degree`` in log visibility through ``values`` (V, ...) [any unit] given at
    ``visibilities_km`` (V,) [km], evaluated at the same visibilities (or at ``at_km`` (A,) [km]: then (A, ...)),
    element by element (the degree is lowered to V - 1 where there are fewer visibilities). Pure array function."""
    x = np.log(np.asarray(visibilities_km, float))
    y = np.asarray(values, float)
    if y.shape[0] != len(x):
        raise ValueError(f"smooth_across_visibility: {y.shape[0]} value rows for {len(x)} visibilities")
    deg = min(int(degree), len(x) - 1)
    X = np.vander(x - x.mean(), deg + 1)                                        # (V, deg + 1)
    coef, *_ = np.linalg.lstsq(X, y.reshape(len(x), -1), rcond=None)
    if at_km is None:
        return (X @ coef).reshape(y.shape)
    xa = np.log(np.atleast_1d(np.asarray(at_km, float)))
    return (np.vander(xa - x.mean(), deg + 1) @ coef).reshape((len(xa),) + y.shape[1:])


def rest_across_visibility(config, elevation_deg: float, albedo: float, zenith_deg=None, azimuth_deg=None,
                           states=None) -> np.ndarray:
    """The split states' smoothed rest at one grid elevation ``elevation_deg`` [deg] and albedo ``albedo`` [1] for
    every visibility of ``config``, each :func:`split_rest` on the grid ``zenith_deg`` x ``azimuth_deg`` [deg]
    (default the states' common fine grid), then smoothed across visibility (:func:`smooth_across_visibility`): the
    multiple scattering is smooth in the aerosol amount, each state's Monte Carlo noise is not. Returns (V, T2, P2, 55)
    [W m-2 sr-1 nm-1] in the order of ``config.visibilities_km``. ``states``: the loaded Monte Carlo states (default:
    read from the build cache)."""
    vis = [float(v) for v in config.visibilities_km]
    if states is None:
        states = [load_state(mc_file(config, v, elevation_deg)) for v in vis]
    rests = np.stack([split_rest(m, albedo, zenith_deg, azimuth_deg) for m in states])
    return smooth_across_visibility(rests, vis)


def rest_across_visibility_file(config, elevation_deg: float, albedo: float):
    """Cache file of :func:`rest_across_visibility` on the fit grid [.npz], named by the Monte Carlo key and
    :data:`SPLIT_SMOOTHING`."""
    return cache_root(config) / (f"mcxv_{mc_key(config)}_{SPLIT_SMOOTHING}_e{elevation_deg:.4f}"
                                 f"_a{albedo:.4f}.npz")


def cached_rest_across_visibility(config, elevation_deg: float, albedo: float) -> np.ndarray:
    """:func:`rest_across_visibility` on the fit grid, computed once per (elevation, albedo) and kept in the build
    cache (written atomically, so parallel fit workers can share it)."""
    path = rest_across_visibility_file(config, elevation_deg, albedo)
    if path.exists():
        with np.load(path) as z:
            return z["rest"]
    rest = rest_across_visibility(config, elevation_deg, albedo)
    with atomic_write(path) as tmp:
        np.savez(tmp, rest=rest)
    return rest


def mc_stokes(state: dict, albedo: float):
    """Stokes vectors of a cached Monte Carlo state over a ground of albedo ``albedo`` [1]: (value, stderr bound),
    each (T, P, 55, 4) [W m-2 sr-1 nm-1]."""
    return stokes_at_albedo(state["stokes"], float(albedo), state["stderr"])


def resample_radiance(zenith_deg, azimuth_deg, radiance, zenith_to, azimuth_to):
    """Shape-preserving interpolation of a Monte Carlo state's radiance from its product grid onto a denser one:
    monotone piecewise-cubic (PCHIP, Fritsch & Carlson 1980) along the azimuths of every zenith row, then along the
    zeniths of every azimuth column. Between two samples it stays between their values and adds no extremum, so it
    puts no ring between the samples that the fit could follow (with correlated streams the samples themselves vary
    smoothly from one direction to the next).

    Parameters
    ----------
    zenith_deg (T,), azimuth_deg (P,) [deg] ascending; radiance (T, P, ...) [any unit];
    zenith_to (T2,), azimuth_to (P2,) [deg] inside the source grid's range.

    Returns
    -------
    ndarray (T2, P2, ...)
    """
    from scipy.interpolate import PchipInterpolator

    th, ph = np.asarray(zenith_deg, float), np.asarray(azimuth_deg, float)
    t2, p2 = np.asarray(zenith_to, float), np.asarray(azimuth_to, float)
    if t2.min() < th[0] or t2.max() > th[-1] or p2.min() < ph[0] or p2.max() > ph[-1]:
        raise ValueError(f"resample_radiance: target grid zenith {t2.min()}..{t2.max()}, azimuth {p2.min()}.."
                         f"{p2.max()} deg outside the source grid {th[0]}..{th[-1]}, {ph[0]}..{ph[-1]} deg")
    x = PchipInterpolator(ph, np.asarray(radiance, float), axis=1)(p2)
    return PchipInterpolator(th, x, axis=0)(t2)


def fit_grid(state: dict, config):
    """Directions the radiance fit of a Monte Carlo state uses: a split state's fine grid (:func:`split_radiance`),
    its own product grid, or with ``mc_fit_resample`` the DISORT states' fit grid (zeniths every
    ``zenith_step_deg``, the fit azimuths) merged with it; (zenith (T,), azimuth (P,)) [deg]."""
    if "single_fine" in state:
        return np.asarray(state["fine_zenith"], float), np.asarray(state["fine_azimuth"], float)
    th, ph = np.asarray(state["zenith"], float), np.asarray(state["azimuth"], float)
    if not config.mc_fit_resample:
        return th, ph

    t2 = np.arange(0.0, th[-1], float(config.zenith_step_deg))
    p2 = np.asarray(AZIMUTHS_DEG, float)
    return (np.unique(np.concatenate([t2, th])),
            np.unique(np.concatenate([p2[(p2 >= ph[0]) & (p2 <= ph[-1])], ph])))


def scattering_plane_rotation(zenith_deg, azimuth_deg, solar_elevation_deg: float):
    """cos 2 chi, sin 2 chi of the angle chi from the Monte Carlo observer frame's first axis (in the vertical plane
    through the view) to the scattering plane (through the view and the sun), for view zenith (T,) and relative
    azimuth (P,) [deg] and the solar elevation [deg]; arrays (T, P). Where the view points at the sun or away from it
    the plane is undefined and chi = 0."""
    T, P = np.meshgrid(np.asarray(zenith_deg, float), np.asarray(azimuth_deg, float), indexing="ij")
    v, a = _unit_views(T.ravel(), P.ravel(), False)
    w = -v                        # propagation toward the observer
    b = np.cross(w, a)            # second axis of the kernel's frame (a, w x a)
    z = np.radians(90.0 - float(solar_elevation_deg))
    s = np.array([np.sin(z), 0.0, np.cos(z)])
    p = s[None, :] - (v @ s)[:, None] * v
    c, sn = np.einsum("ij,ij->i", a, p), np.einsum("ij,ij->i", b, p)
    n = c * c + sn * sn
    ok = n > 1e-20
    c2 = np.where(ok, (c * c - sn * sn) / np.where(ok, n, 1.0), 1.0)
    s2 = np.where(ok, 2.0 * c * sn / np.where(ok, n, 1.0), 0.0)
    return c2.reshape(T.shape), s2.reshape(T.shape)


def scattering_plane_stokes(state: dict, albedo: float):
    """(I, Q_s, U_s, V) [W m-2 sr-1 nm-1] of a Monte Carlo state over albedo ``albedo`` [1] with Q, U referred to the
    scattering plane (Q_s > 0: polarised in the plane through the sun and the view), shape (T, P, 55, 4), and the
    standard-error bound of the same shape."""
    s, e = mc_stokes(state, albedo)
    c2, s2 = scattering_plane_rotation(state["zenith"], state["azimuth"], float(state["solved_elevation"]))
    c2, s2 = c2[..., None], s2[..., None]
    out = s.copy()
    out[..., 1] = s[..., 1] * c2 + s[..., 2] * s2
    out[..., 2] = -s[..., 1] * s2 + s[..., 2] * c2
    err = e.copy()
    err[..., 1] = np.abs(e[..., 1] * c2) + np.abs(e[..., 2] * s2)
    err[..., 2] = np.abs(e[..., 1] * s2) + np.abs(e[..., 2] * c2)
    return out, err


def stored_polarisation(state: dict, albedo: float):
    """The value the format's polarisation factors hold, P = Q_s / I [1] (readers return -P, the signed degree of
    polarisation; module docstring), shape (T, P, 55), and its standard error estimate (delta method, without the
    I-Q covariance, which only lowers it for a ratio of positively correlated estimates) [1]. Zero where I = 0."""
    s, e = scattering_plane_stokes(state, albedo)
    i, q = s[..., 0], s[..., 1]
    ok = i > 0
    safe = np.where(ok, i, 1.0)
    p = np.where(ok, q / safe, 0.0)
    se = np.where(ok, np.sqrt(e[..., 1] ** 2 + (p * e[..., 0]) ** 2) / safe, 0.0)
    return p, se


def polarisation_summary(state: dict, albedo: float) -> dict:
    """Figures of one state's polarisation for the sidecar: per channel (55,) the solid-angle mean of the degree of
    linear polarisation sqrt(Q^2 + U^2) / I, of abs(Q_s) / I, of the circular part abs(V) / I, and of the standard error of
    P [1]."""
    s, _ = scattering_plane_stokes(state, albedo)
    p, se = stored_polarisation(state, albedo)
    w = direction_samples(state["zenith"], state["azimuth"], float(state["solved_elevation"]))["weights"]
    w = w.reshape(len(state["zenith"]), len(state["azimuth"]))[..., None]
    i = np.where(s[..., 0] > 0, s[..., 0], np.inf)
    mean = lambda x: (np.sum(w * x, axis=(0, 1)) / np.sum(w)).tolist()  # noqa: E731
    return {"dolp": mean(np.hypot(s[..., 1], s[..., 2]) / i), "abs_qs": mean(np.abs(s[..., 1]) / i),
            "docp": mean(np.abs(s[..., 3]) / i), "se_p": mean(se)}


def fit_polarisation(values, samples, breaks, rank, smoothing=1e-5, refine=2):
    """Fit every channel of one configuration's polarisation into the format's form P = sum_r psun_r(gamma) pzen_r(zero)
    (no emphasis, no clamp).

    Parameters
    ----------
    values : (T, P, C) [1] on the grid of ``samples`` (:func:`widesky.skymodel.generator.dataset_grid.direction_samples`).
    breaks : (sun, zenith) knots [rad]; rank : int.

    Returns
    -------
    psun (C, rank, nPSun), pzen (C, rank, nPZen), mae (C,) [1] solid-angle weighted mean absolute error on the samples.
    """
    y = np.asarray(values, float).reshape(-1, values.shape[-1])
    C = y.shape[1]
    sb, zb = breaks
    eb = np.array([0.0, 0.5 * np.pi])
    w = fit_weights(samples["weights"])
    sw = samples["weights"]
    psun = np.zeros((C, rank, len(sb)))
    pzen = np.zeros((C, rank, len(zb)))
    mae = np.zeros(C)
    for c in range(C):
        if not np.any(y[:, c] != 0):
            continue
        f = fit_radiance(samples["gamma"], samples["zero"], samples["zero"], y[:, c], sb, zb, eb, rank, weights=w,
                         smoothing=smoothing, iterations=1, refine=refine, clamp=False)
        psun[c], pzen[c] = f.sun, f.zen * f.emph[0]
        pred = f.evaluate(samples["gamma"], samples["zero"], samples["zero"], sb, zb, eb, clamp=False)
        mae[c] = np.sum(sw * np.abs(pred - y[:, c])) / np.sum(sw)
    return psun, pzen, mae


def pol_knots(config):
    """(sun, zenith) knots [rad] of the polarisation section: gamma in [0, pi] dense near the sun, the
    altitude-corrected view zenith ``zero`` in [0, pi/2] dense near the horizon."""
    ns, nz = (int(x) for x in config.pol_knots)
    return knots(ns, 0.0, np.pi, 1.3, "lo"), knots(nz, 0.0, 0.5 * np.pi, 1.3, "hi")


def validation_file(config, kind: str, visibility_km: float, elevation_deg: float, albedo: float):
    """Cache file of a validation state (``kind`` 'on' or 'off') [.npz]: the DISORT solve's, or where its elevation
    takes the split Monte Carlo radiance, one named by the Monte Carlo key."""
    if split_state(config, elevation_deg):  # the file holds the recombined radiance: named by the smoothing too
        return cache_root(config) / (f"mcval_{mc_key(config)}_{SPLIT_SMOOTHING}_x{SPLIT_VALIDATION_SAMPLES_FACTOR}"
                                     f"_{kind}_v{visibility_km:.4f}"
                                     f"_e{elevation_deg:.4f}_a{albedo:.4f}.npz")
    return state_file(config, visibility_km, elevation_deg, "val_" + kind, albedo)
