"""Evaluation of a loaded Prague Sky Model: sky radiance, sun radiance, polarisation, transmittance.

Conventions (ARCHITECTURE section 3): view ``directions`` are vectors (..., 3) in a local
east-north-up frame (x east, y north, z up; normalised internally); solar elevation and azimuth in
degrees, azimuth clockwise from north (180 = south); visibility km; albedo 1; observer altitude m above
the ground; wavelengths nm. The reference measures azimuth from +x towards +y; the conversion is done
once here.

Shapes: the sky-state arguments broadcast together to a shape S; results have shape
``S + directions.shape[:-1] + (C,)`` where C is the number of requested channels (all selected
channels of the model by default).

Exactness: the numbers equal the published reference algorithm's (same parameters, safety altitude,
knot lookup and clamping, nested interpolation, transmittance mapping) to float rounding. Sky-state
values outside the dataset's grids are clamped exactly as the reference does, and a
:class:`SkyStateClampedWarning` says so (or ``return_clamped=True`` returns a per-state flag).
"""

from __future__ import annotations

import bisect
import math
import sys
import threading
import warnings

import numpy as np

from widesky.core.spectral import band_average

from . import _core
from .dataset import SkyModel
from .solar import SUN_RADIUS, SUN_SOLID_ANGLE, extraterrestrial_spectrum

__all__ = ["SkyStateClampedWarning", "RadianceTables", "reference_angles", "sky_radiance", "sun_radiance", "polarisation", "transmittance",
           "solar_direct_normal", "sun_direction", "direction_from_zenith", "directions_from_angles",
           "channel_indices"]

KERNEL_INFO = {}
"""What the last radiance/polarisation call's kernel did (for benchmarks): ``path`` 1 direct, 2 table,
3 twilight table; ``mixed_terms`` kept as their own clamped terms; ``cells_built`` by the twilight table."""

PLANET_RADIUS = 6378000.0
SAFETY_ALTITUDE = 50.0


class SkyStateClampedWarning(UserWarning):
    """A sky-state value lay outside the dataset's range and was clamped (as the reference does)."""


# ---------------------------------------------------------------------------------------------- helpers

def sun_direction(elevation, azimuth):
    """Unit vectors towards the sun in the east-north-up frame.

    Parameters
    ----------
    elevation : array_like  [deg]
    azimuth : array_like  [deg] clockwise from north

    Returns
    -------
    ndarray, shape broadcast(elevation, azimuth).shape + (3,)
    """
    e = np.radians(np.asarray(elevation, float))
    a = np.radians(np.asarray(azimuth, float))
    e, a = np.broadcast_arrays(e, a)
    return np.stack([np.cos(e) * np.sin(a), np.cos(e) * np.cos(a), np.sin(e)], axis=-1)


def direction_from_zenith(zenith, azimuth):
    """Unit view directions (east-north-up) from the zenith angle [deg] (0 = straight up, 90 = horizon)
    and the azimuth [deg, clockwise from north]; shape broadcast(zenith, azimuth).shape + (3,)."""
    return sun_direction(90.0 - np.asarray(zenith, float), azimuth)


directions_from_angles = direction_from_zenith
"""Former name of :func:`direction_from_zenith` (which says which angle it takes), kept for callers."""


_GRID_LISTS: dict = {}  # id(grid) -> (grid, its bytes, its values as Python floats): a model's grids


def _grid_list(grid):
    """A grid's values as a list of Python floats, kept while the array and its bytes stay the same."""
    if not isinstance(grid, np.ndarray):
        return [float(x) for x in grid]
    raw = grid.tobytes()
    hit = _GRID_LISTS.get(id(grid))
    if hit is not None and hit[0] is grid and hit[1] == raw:
        return hit[2]
    if len(_GRID_LISTS) >= 64:
        _GRID_LISTS.clear()
    values = [float(x) for x in grid.ravel()]
    _GRID_LISTS[id(grid)] = (grid, raw, values)
    return values


def _reference_lookup(q, grid):
    """Reference knot lookup (clamped): (index, factor)."""
    g = _grid_list(grid)  # Python floats: the same IEEE arithmetic, faster than numpy scalars
    n = len(g)
    q = min(max(float(q), g[0]), g[-1])
    k = bisect.bisect_right(g, q)  # as searchsorted(side="right"), without its per-call overhead
    if k >= n:
        return n - 1, 0.0
    lo = g[k - 1]
    return k - 1, (q - lo) / (g[k] - lo)


def _config_weights(model: SkyModel, visibility, albedo, altitude_param, elevation_deg):
    """Corner configurations and weights of the nested interpolation (visibility, albedo, altitude,
    elevation); a level whose factor is < 1e-6 keeps its lower branch only, as the reference does."""
    cfg, wts = [0], [1.0]
    for grid, q in ((model.visibilities, visibility), (model.albedos, albedo), (model.altitudes, altitude_param),
                    (model.elevations, elevation_deg)):
        i, f = _reference_lookup(q, grid)
        n = len(grid)
        if f < 1e-6:  # one branch of weight 1: the weights unchanged (w * 1.0 is w)
            cfg = [c * n + i for c in cfg]
        else:
            hi, g = min(i + 1, n - 1), 1.0 - f
            cfg = [c * n + j for c in cfg for j in (i, hi)]
            wts = [x for w in wts for x in (w * g, w * f)]
    return np.array(cfg, dtype=np.int64), np.array(wts, dtype=np.float64)


def _trans_weights(model: SkyModel, visibility, altitude_param):
    """(visibility index, altitude index, weight) pairs over the transmittance grids."""
    iv, fv = _reference_lookup(visibility, model.trans_visibilities)
    ia, fa = _reference_lookup(altitude_param, model.trans_altitudes)
    pv = [(iv, 1.0)] if fv <= 0 else [(iv, 1.0 - fv), (iv + 1, fv)]
    pa = [(ia, 1.0)] if fa <= 0 else [(ia, 1.0 - fa), (ia + 1, fa)]
    pairs = [(v, a, wv * wa) for v, wv in pv for a, wa in pa]
    return (np.array([p[0] for p in pairs], np.int64), np.array([p[1] for p in pairs], np.int64),
            np.array([p[2] for p in pairs], np.float64))


def channel_indices(model: SkyModel, channels=None, wavelengths=None):
    """Indices into the model's selected channels for ``channels`` (indices, default all) or point
    ``wavelengths`` [nm] (each mapped to the channel containing it, as the reference does).

    Raises
    ------
    ValueError
        For a wavelength outside the dataset's channels, or in a channel that was not loaded.
    """
    if channels is not None and wavelengths is not None:
        raise ValueError("give either channels or wavelengths, not both")
    if wavelengths is not None:
        wl = np.atleast_1d(np.asarray(wavelengths, float)).ravel()
        lo, hi = model.wavelength_range
        bad = ~((wl >= lo) & (wl < hi))
        if bad.any():
            raise ValueError(f"wavelength {wl[bad][0]:g} nm outside the dataset's range [{lo:g}, {hi:g}) nm")
        file_ch = np.floor((wl - model.channel_start) / model.channel_width).astype(np.int64)
        pos = np.searchsorted(model.channel_index, file_ch)
        pos = np.minimum(pos, model.n_channels - 1)
        missing = model.channel_index[pos] != file_ch
        if missing.any():
            raise ValueError(f"wavelength {wl[missing][0]:g} nm lies in channel {file_ch[missing][0]}, which was "
                             "not loaded (see load_dataset(channels=..., wavelength_range=...))")
        return pos.astype(np.int64)
    if channels is None:
        return np.arange(model.n_channels, dtype=np.int64)
    ch = np.atleast_1d(np.asarray(channels)).astype(np.int64).ravel()
    if ch.size == 0 or ch.min() < 0 or ch.max() >= model.n_channels:
        raise ValueError(f"channels={channels!r} outside [0, {model.n_channels - 1}] (the loaded channels)")
    return ch


def _prepare(model, directions, sun_elevation, sun_azimuth, visibility, albedo, altitude, what, unit=False,
             plain=False):
    """``unit`` (private, the renderer's own directions): unit vectors by construction, not checked.
    ``plain``: a state of plain numbers comes back as a tuple of floats (one state, S = ()), not 0-d arrays."""
    dirs = np.asarray(directions, dtype=np.float64)
    if dirs.ndim < 1 or dirs.shape[-1] != 3:
        raise ValueError(f"directions must have shape (..., 3), got {dirs.shape}")
    flat = np.ascontiguousarray(dirs.reshape(-1, 3))
    if not unit:
        bad = _core.check_dirs(flat)  # one pass in C: NaN, inf, overflowing and zero vectors
    if not unit and bad >= 0:
        v = flat[bad]
        what = "a zero vector" if np.all(v == 0) else f"a non-finite (or overflowing) vector {v}"
        raise ValueError(f"directions contain {what}")
    sc = (sun_elevation, sun_azimuth, visibility, albedo, altitude)
    if all(type(x) is float or type(x) is int for x in sc):  # one plain-number state: checks without arrays
        v = [float(x) for x in sc]
        if all(map(math.isfinite, v)) and v[2] > 0 and v[4] >= 0:
            return flat, dirs.shape[:-1], (tuple(v) if plain else tuple(np.array(x) for x in v))
    state = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in sc))
    names = ("sun_elevation [deg]", "sun_azimuth [deg]", "visibility [km]", "albedo", "altitude [m]")
    for name, arr in zip(names, state):
        if not np.isfinite(arr).all():
            raise ValueError(f"{name} contains non-finite values")
    if np.any(state[2] <= 0):
        raise ValueError(f"visibility must be > 0 km, got {state[2][state[2] <= 0].ravel()[0]}")
    if np.any(state[4] < 0):
        raise ValueError(f"altitude must be >= 0 m (above the ground), got {state[4][state[4] < 0].ravel()[0]}")
    return flat, dirs.shape[:-1], state


def _check_clamp(model: SkyModel, el, vis, alb, alt, quantity):
    """Names of sky-state parameters outside the dataset's ranges (for the warning / flag)."""
    out = []
    checks = (("visibility", vis, model.visibilities, "km"), ("albedo", alb, model.albedos, ""),
              ("sun_elevation", el, model.elevations, "deg"))
    for name, v, grid, unit in checks:
        g = _grid_list(grid)  # the grid's ends as floats, as model.visibility_range etc. give them
        lo, hi = g[0], g[-1]
        if v < lo - 1e-9 or v > hi + 1e-9:
            out.append(f"{name}={v:g} {unit} outside the dataset's range [{lo:g}, {hi:g}]")
    hi = _grid_list(model.altitudes)[-1]
    if alt > hi + 1e-9:
        out.append(f"altitude={alt:g} m above the dataset's highest altitude {hi:g} m")
    return out


def _check_trans_clamp(model: SkyModel, vis, alt):
    """Names of the transmittance's parameters outside the dataset's transmittance grids (for the warning
    / flag): visibility [km], and the observer altitude [m] above the highest transmittance altitude (as
    :func:`_check_clamp` tests the radiance's altitude)."""
    out = []
    lo, hi = float(model.trans_visibilities[0]), float(model.trans_visibilities[-1])
    if vis < lo - 1e-6 or vis > hi + 1e-6:
        out.append(f"visibility={vis:g} km outside the transmittance range [{lo:g}, {hi:g}]")
    top = float(model.trans_altitudes[-1])
    if alt > top + 1e-9:
        out.append(f"altitude={alt:g} m above the dataset's highest transmittance altitude {top:g} m")
    return out


def _state_params(el_deg, az_deg, alt):
    """Reference sky-state parameters: radians in the reference's azimuth convention, the altitude
    parameter (with the 50 m safety altitude) and the solar elevation at the view point [deg]."""
    # math.radians / math.degrees: x * (pi / 180) and x * (180 / pi), numpy's radians and degrees to the bit
    el = math.radians(el_deg)
    az_math = math.radians(90.0 - az_deg)  # compass (clockwise from north) -> from +x (east) towards +y (north)
    d = (alt + PLANET_RADIUS) + SAFETY_ALTITUDE
    altitude_param = max(d - PLANET_RADIUS, 0.0)
    sz = np.sin(el)
    elevation_view = 0.5 * np.pi - np.arccos(min(max(sz, -1.0), 1.0))  # sz is finite: np.clip's value, faster
    return el, az_math, altitude_param, math.degrees(elevation_view)


def reference_angles(directions, sun_elevation, sun_azimuth, altitude=0.0):
    """The model's angles for view directions, computed as the reference's computeParameters does (and
    as the C core does): observer at (0, 0, altitude) raised by the 50 m safety altitude, altitude-
    corrected view direction for ``zero`` and ``shadow``.

    Parameters
    ----------
    directions : array_like (..., 3)  east-north-up
    sun_elevation, sun_azimuth : float  [deg] (azimuth clockwise from north)
    altitude : float  [m]

    Returns
    -------
    dict of ndarray (...) [rad]: ``theta`` (view zenith), ``gamma`` (to the sun), ``shadow``, ``zero``
    (altitude-corrected view zenith), plus ``elevation`` [rad] and ``altitude`` [m] (the parameters used
    for the configuration lookup) as floats.
    """
    v = np.asarray(directions, float)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    el, az, alt_param, el_view = _state_params(float(sun_elevation), float(sun_azimuth), float(altitude))
    d = (float(altitude) + PLANET_RADIUS) + SAFETY_ALTITUDE
    sz = -PLANET_RADIUS + d
    c = np.sqrt(d * d - PLANET_RADIUS * PLANET_RADIUS) / d
    oz = -PLANET_RADIUS + (d - c)
    cv = v.copy()
    cv[..., 2] = (v[..., 2] + sz) - oz
    cv /= np.linalg.norm(cv, axis=-1, keepdims=True)
    s = np.array([np.cos(az) * np.cos(el), np.sin(az) * np.cos(el), np.sin(el)])
    sig = el + 0.5 * np.pi
    h = np.array([np.cos(sig) * np.cos(az), np.cos(sig) * np.sin(az), np.sin(sig)])
    # east-north-up equals the reference frame (x east, y north) with its azimuth measured from +x
    ang = lambda x: np.arccos(np.clip(x, -1.0, 1.0))  # noqa: E731
    return dict(theta=ang(v[..., 2]), gamma=ang(v @ s), shadow=ang(cv @ h), zero=ang(cv[..., 2]),
                elevation=float(np.radians(el_view)), altitude=alt_param)


def _output(shape, dtype, out):
    dtype = np.dtype(dtype)
    if dtype not in (np.float32, np.float64):
        raise ValueError(f"dtype must be float32 or float64, got {dtype}")
    if out is None:
        return np.empty(shape, dtype)
    if out.shape != tuple(shape) or out.dtype != dtype or not out.flags.c_contiguous:
        raise ValueError(f"out must be a C-contiguous {dtype} array of shape {tuple(shape)}, got {out.dtype} "
                         f"{out.shape}")
    return out


def _report_clamped(flags, msgs, return_clamped, quantity):
    if msgs and not return_clamped:
        more = f" (and {len(msgs) - 1} more)" if len(msgs) > 1 else ""
        warnings.warn(f"{quantity}: {msgs[0]}{more}; clamped to the dataset's range as the reference does",
                      SkyStateClampedWarning, stacklevel=3)


# ---------------------------------------------------------------------------------------------- public API

def _evaluate_component(model, kind, directions, sun_elevation, sun_azimuth, visibility, albedo, altitude,
                        channels, wavelengths, dtype, out, method, threads, return_clamped, rows=None):
    """Evaluate radiance or polarisation. ``rows`` (private, for the renderer): int64 output row of each
    direction in ``out`` (shape (n_rows, C), one sky state), so an image is filled without a scatter copy;
    the renderer's directions are unit vectors by construction and are not checked again."""
    dirs, dshape, state = _prepare(model, directions, sun_elevation, sun_azimuth, visibility, albedo, altitude,
                                   kind, unit=rows is not None, plain=True)
    chi_sel = channel_indices(model, channels, wavelengths)
    if kind == "radiance":
        sun, zen, emph = model.radiance_coefficients()
        breaks = (model.sun_breaks, model.zenith_breaks, model.emph_breaks)
        rank = model.rank
    else:
        sun, zen = model.polarisation_coefficients()
        emph = None
        breaks = (model.pol_sun_breaks, model.pol_zenith_breaks, None)
        rank = model.pol_rank
    plain = type(state[0]) is float  # one state of plain numbers (floats, not arrays)
    S = () if plain else state[0].shape
    C = chi_sel.size
    if rows is None:
        res = _output(S + dshape + (C,), dtype, out)
        flat = res.reshape((-1, dirs.shape[0] * C)) if res.size else res.reshape(-1, 0)
    else:
        if S != () or out is None or out.ndim != 2 or out.shape[1] != C or rows.shape != (dirs.shape[0],):
            raise ValueError("rows: one sky state, out of shape (n_rows, C) and one row per direction")
        res = _output(out.shape, dtype, out)
        flat = res.reshape(1, -1)
        rows = np.ascontiguousarray(rows, dtype=np.int64)
    method_code = {"auto": 0, "direct": 1, "table": 2}[method]
    flags = np.zeros(S, dtype=bool)
    msgs = []
    nch = model.n_channels
    for si, idx in enumerate(np.ndindex(S) if S else ((),)):
        el_deg, az_deg, vis, alb, alt = state if plain else (float(a[idx]) for a in state)
        m = _check_clamp(model, el_deg, vis, alb, alt, kind)
        if m:
            flags[idx] = True
            msgs += m
        el, az, alt_param, el_view = _state_params(el_deg, az_deg, alt)
        cfg, w = _config_weights(model, vis, alb, alt_param, el_view)
        info = _core.radiance(sun, zen, emph, breaks[0], breaks[1], breaks[2], rank, nch, cfg, w, chi_sel, dirs,
                              (alt, el, az), flat[si], method_code, int(threads), rows)
    KERNEL_INFO.update(zip(("path", "mixed_terms", "cells_built"), info))
    _report_clamped(flags, msgs, return_clamped, kind)
    return (res, flags) if return_clamped else res


def sky_radiance(model: SkyModel, directions, sun_elevation, sun_azimuth, visibility, albedo, altitude=0.0, *,
                 channels=None, wavelengths=None, dtype=np.float64, out=None, method="auto", threads=0,
                 return_clamped=False):
    """Sky radiance (without the sun) per view direction and channel.

    Parameters
    ----------
    model : SkyModel
        A dataset from :func:`widesky.skymodel.load_dataset`.
    directions : array_like, shape (..., 3)
        View directions, east-north-up (need not be normalised).
    sun_elevation : array_like  [deg]
    sun_azimuth : array_like  [deg] clockwise from north
    visibility : array_like  [km]
    albedo : array_like  [1] ground albedo
    altitude : array_like  [m] observer altitude above the ground
    channels : sequence of int, optional
        Indices into ``model.wavelengths``; default all selected channels.
    wavelengths : array_like, optional
        Point wavelengths [nm], each evaluated in the channel that contains it (no interpolation, as in
        the reference); outside the dataset's range raises ValueError.
    dtype : float32 or float64
    out : ndarray, optional
        Preallocated result (C-contiguous, right shape and dtype).
    method : {"auto", "direct", "table"}
        "table" precomputes per sky state a piecewise-polynomial table over the cells in the range of
        the call's angles (fast for many directions); "direct" does the angle lookups once per direction
        and reuses them over channels; "auto" picks table from 20,000 direction-channel values, and for
        smaller calls with the sun above the horizon wherever building the cells in range costs less
        than the direct path (directions close together). Both give the reference's values.
    threads : int
        OpenMP threads (0: all cores).
    return_clamped : bool
        Return ``(values, clamped)`` with a boolean per sky state instead of warning.

    Returns
    -------
    ndarray, shape S + directions.shape[:-1] + (C,)  [W m-2 sr-1 nm-1]
    """
    return _evaluate_component(model, "radiance", directions, sun_elevation, sun_azimuth, visibility, albedo,
                               altitude, channels, wavelengths, dtype, out, method, threads, return_clamped)


def polarisation(model: SkyModel, directions, sun_elevation, sun_azimuth, visibility, albedo, altitude=0.0, *,
                 channels=None, wavelengths=None, dtype=np.float64, out=None, method="auto", threads=0,
                 return_clamped=False):
    """Degree of polarisation [1] per view direction and channel (the reference's sign convention:
    the negated model value; may be negative). Arguments and shape as :func:`sky_radiance`.

    Raises
    ------
    ValueError
        If the dataset has no polarisation section.
    """
    return _evaluate_component(model, "polarisation", directions, sun_elevation, sun_azimuth, visibility,
                               albedo, altitude, channels, wavelengths, dtype, out, method, threads,
                               return_clamped)


def transmittance(model: SkyModel, directions, sun_elevation, sun_azimuth, visibility, albedo, altitude=0.0, *,
                  distance=np.inf, channels=None, wavelengths=None, dtype=np.float64, out=None, threads=0,
                  return_clamped=False):
    """Transmittance [1] from the observer along each view direction over ``distance`` [m] (default:
    to the top of the atmosphere or the ground). Only visibility and altitude affect it; the other
    sky-state arguments are accepted so calls broadcast like :func:`sky_radiance`.

    Returns
    -------
    ndarray, shape S + directions.shape[:-1] + (C,)  [1]
    """
    dirs, dshape, state = _prepare(model, directions, sun_elevation, sun_azimuth, visibility, albedo, altitude,
                                   "transmittance")
    dist = float(distance)
    if not dist > 0:
        raise ValueError(f"distance must be > 0 m, got {distance}")
    dist = min(dist, np.finfo(float).max)
    chi = channel_indices(model, channels, wavelengths)
    U, V = model.transmittance_coefficients()
    S = state[0].shape
    res = _output(S + dshape + (chi.size,), dtype, out)
    flat = res.reshape((-1, dirs.shape[0] * chi.size)) if res.size else res.reshape(-1, 0)
    flags = np.zeros(S, dtype=bool)
    msgs = []
    for si, idx in enumerate(np.ndindex(S)):
        _, _, vis, _, alt = (float(a[idx]) for a in state)
        m = _check_trans_clamp(model, vis, alt)
        if m:
            flags[idx] = True
            msgs += m
        alt_param = max((alt + PLANET_RADIUS) + SAFETY_ALTITUDE - PLANET_RADIUS, 0.0)
        pv, pa, pw = _trans_weights(model, vis, alt_param)
        _core.transmittance(U, V, model.trans_d_dim, model.trans_a_dim, U.shape[0], model.trans_rank,
                            model.n_channels, pv, pa, pw, chi, dirs, alt_param, dist, flat[si], int(threads))
    _report_clamped(flags, msgs, return_clamped, "transmittance")
    return (res, flags) if return_clamped else res


def _extraterrestrial(model: SkyModel, chi, wavelengths):
    """Extraterrestrial irradiance per requested channel (band mean) or point wavelength [W m-2 nm-1]."""
    et = model.metadata.get("extraterrestrial")
    if et is not None:
        wl, e = np.asarray(et["wavelength"], float), np.asarray(et["irradiance"], float)
    else:
        wl, e = extraterrestrial_spectrum()
    if wavelengths is not None:
        w = np.atleast_1d(np.asarray(wavelengths, float)).ravel()
        if w.min() < wl[0] or w.max() > wl[-1]:
            raise ValueError(f"wavelength outside the extraterrestrial spectrum's range [{wl[0]}, {wl[-1]}] nm")
        return np.interp(w, wl, e)
    lower = model.channel_lower[chi]
    return band_average(wl, e, lower, lower + model.channel_width, outside="raise")


def sun_radiance(model: SkyModel, directions, sun_elevation, sun_azimuth, visibility, albedo, altitude=0.0, *,
                 channels=None, wavelengths=None, dtype=np.float64, threads=0, return_clamped=False):
    """Radiance of the solar disc [W m-2 sr-1 nm-1]: the extraterrestrial radiance times the
    transmittance to the top of the atmosphere for directions within the sun's radius (0.2667 deg) of
    the sun, 0 elsewhere. Per channel the extraterrestrial value is the band mean; for point
    wavelengths it is interpolated. Arguments and shape as :func:`sky_radiance`."""
    dirs, dshape, state = _prepare(model, directions, sun_elevation, sun_azimuth, visibility, albedo, altitude,
                                   "sun radiance")
    chi = channel_indices(model, channels, wavelengths)
    et = _extraterrestrial(model, chi, wavelengths) / SUN_SOLID_ANGLE
    S = state[0].shape
    res = np.zeros(S + (dirs.shape[0], chi.size), dtype)
    unit = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    flags = np.zeros(S, dtype=bool)
    msgs = []
    for idx in np.ndindex(S):
        el, az, vis, alb, alt = (float(a[idx]) for a in state)
        s = sun_direction(el, az)
        gamma = np.arccos(np.clip(unit @ s, -1.0, 1.0))
        hit = np.nonzero(gamma <= SUN_RADIUS)[0]
        if hit.size:
            t, fl = transmittance(model, dirs[hit], el, az, vis, alb, alt, channels=chi, threads=threads,
                                  return_clamped=True)
            flags[idx] = bool(fl)
            msgs += _check_trans_clamp(model, vis, alt)
            res[idx][hit] = et * t
    res = res.reshape(S + dshape + (chi.size,))
    _report_clamped(flags, msgs, return_clamped, "sun radiance")
    return (res, flags) if return_clamped else res


def solar_direct_normal(model: SkyModel, sun_elevation, sun_azimuth, visibility, albedo, altitude=0.0, *,
                        channels=None, wavelengths=None, threads=0, return_clamped=False):
    """Spectral direct normal irradiance [W m-2 nm-1]: extraterrestrial irradiance (band mean per
    channel) times the model's transmittance from the observer towards the sun's centre.

    Returns
    -------
    ndarray, shape S + (C,)
    """
    st = np.broadcast_arrays(*(np.asarray(x, float) for x in (sun_elevation, sun_azimuth, visibility, albedo,
                                                                 altitude)))
    chi = channel_indices(model, channels, wavelengths)
    et = _extraterrestrial(model, chi, wavelengths)
    S = st[0].shape
    res = np.zeros(S + (chi.size,))
    flags = np.zeros(S, dtype=bool)
    msgs = []
    for idx in np.ndindex(S):
        el, az, vis, alb, alt = (float(a[idx]) for a in st)
        t, fl = transmittance(model, sun_direction(el, az)[None], el, az, vis, alb, alt, channels=chi,
                              threads=threads, return_clamped=True)
        flags[idx] = bool(fl)
        msgs += _check_trans_clamp(model, vis, alt)
        res[idx] = et * t[0]
    _report_clamped(flags, msgs, return_clamped, "solar_direct_normal")
    return (res, flags) if return_clamped else res


class RadianceTables:
    """Sky radiance of many sky states, each configuration's table built once and kept.

    A sky state's radiance is the weighted sum, over its corner configurations (one visibility, albedo,
    altitude and elevation knot each; at most 16), of each configuration's clamped value. The daytime
    table of one configuration does not depend on the sun position or on the state's weights, so a
    time series whose thousands of states share a few hundred configurations builds each table once
    (about 1-2 ms and 2.2 MB of float32 for the embedded dataset's 55 channels, rows padded to 56) and
    evaluates each step as the weighted sum of its corners' tables at its own sun position: the values of
    :func:`sky_radiance` (the same terms summed in another order, the tables kept in float32: relative
    differences below 1e-6, 4e-7 measured), at a fraction of the per-state table precompute
    (``benchmarks/bench_poa.py --sky-steps``).
    Steps with the sun below the horizon, states outside the dataset's ranges (clamped, with a
    warning) and datasets whose knots make an ill-conditioned cell go through :func:`sky_radiance`.

    Parameters
    ----------
    model : SkyModel
    channels : array_like of int, optional
        Indices into the model's channels (default all).
    max_bytes : int
        Tables kept (least recently used dropped first); a call needing more evaluates in parts.
    threads : int
        OpenMP threads per call (0: all cores).
    """

    def __init__(self, model: SkyModel, channels=None, max_bytes=128 << 20, threads=1):
        self.model = model
        self.chi = channel_indices(model, channels)
        self._coef = None                     # the decoded factors, on the first table (direct_normal needs none)
        self.u = np.unique(np.concatenate([model.zenith_breaks, model.emph_breaks])).astype(np.float64)
        self.sb = np.ascontiguousarray(model.sun_breaks, dtype=np.float64)
        self.tab_len = (self.sb.size - 1) * (self.u.size - 1) * 6 * ((self.chi.size + 7) // 8 * 8)   # padded rows
        self.max_tables = max(16, int(max_bytes) // (4 * self.tab_len))
        self.threads = int(threads)
        self._tables = {}                     # flat configuration index -> (tab, start, ch, coef), LRU order
        self.usable = True                    # False once a table is ill-conditioned (then sky_radiance)
        self._lock = threading.Lock()
        self._spare = []                      # at most one evicted table's buffer, reused by the next build
        self.built = 0

    def _table(self, cfg):
        with self._lock:                      # callers may share one sky between threads
            return self._table_locked(cfg)

    def _table_locked(self, cfg):
        t = self._tables.pop(cfg, None)
        if t is None:
            # an evicted table's buffer when there is one: fresh pages cost as much as the build itself
            tab = self._spare.pop() if self._spare else np.empty(self.tab_len, np.float32)
            if self._coef is None:
                m = self.model
                self._coef = (*m.radiance_coefficients(), m.sun_breaks, m.zenith_breaks, m.emph_breaks)
            sun, zen, emph, sb, zb, eb = self._coef
            r = _core.radiance_config_table(sun, zen, emph, sb, zb, eb, self.model.rank, self.model.n_channels,
                                            np.array([cfg], np.int64), self.chi, tab)
            if r is None:
                self.usable = False
                return None
            start, ch, coef = (np.frombuffer(x, dt) for x, dt in zip(r, (np.int32, np.int32, np.float64)))
            t = (tab, start, ch, coef)
            self.built += 1
        self._tables[cfg] = t                 # most recently used last
        while len(self._tables) > self.max_tables:
            old = self._tables.pop(next(iter(self._tables)))
            # reuse only a table no caller holds (the tuple: this name and the call's argument; its array: the tuple
            # and the argument)
            if not self._spare and sys.getrefcount(old) <= 2 and sys.getrefcount(old[0]) <= 2:
                self._spare.append(old[0])
        return t

    def state_corners(self, sun_elevation, visibility, albedo, altitude):
        """Per state (T,): corner configurations (T, 16) int64 (flat indices) and weights (T, 16) [1]
        (unused corners: weight 0), and the states evaluated here (T,) bool (daytime, in range).

        The reference's nested lookup (:func:`_config_weights`), vectorised: a level whose factor is
        below 1e-6 keeps its lower knot with weight 1."""
        m = self.model
        el = np.asarray(sun_elevation, float)
        vis, alb, alt = (np.broadcast_to(np.asarray(x, float), el.shape) for x in (visibility, albedo, altitude))
        T = el.size
        (vlo, vhi), (alo, ahi), (elo, ehi) = m.visibility_range, m.albedo_range, m.elevation_range
        ok = ((el >= 0.0) & (el >= elo - 1e-9) & (el <= ehi + 1e-9) & (vis >= vlo - 1e-9) & (vis <= vhi + 1e-9)
              & (alb >= alo - 1e-9) & (alb <= ahi + 1e-9) & (alt <= m.altitude_range[1] + 1e-9))
        alt_param = np.maximum((alt + PLANET_RADIUS) + SAFETY_ALTITUDE - PLANET_RADIUS, 0.0)
        el_view = np.degrees(0.5 * np.pi - np.arccos(np.clip(np.sin(np.radians(el)), -1.0, 1.0)))
        cfg = np.zeros((T, 1), np.int64)
        w = np.ones((T, 1))
        for grid, q in ((m.visibilities, vis), (m.albedos, alb), (m.altitudes, alt_param),
                        (m.elevations, el_view)):
            g = np.asarray(grid, float)
            n = g.size
            qc = np.clip(q, g[0], g[-1])
            k = np.searchsorted(g, qc, side="right")
            last = k >= n
            i = np.where(last, n - 1, k - 1)
            with np.errstate(invalid="ignore", divide="ignore"):     # a one-knot grid: 0 / 0, not used
                f = np.where(last, 0.0, (qc - g[i]) / (g[np.minimum(k, n - 1)] - g[i]))
            f = np.where(f < 1e-6, 0.0, f)
            hi = np.minimum(i + 1, n - 1)
            cfg = np.concatenate([cfg * n + i[:, None], cfg * n + hi[:, None]], axis=1)
            w = np.concatenate([w * np.where(f > 0, 1.0 - f, 1.0)[:, None], w * f[:, None]], axis=1)
        order = [int(b, 2) for b in (format(j, "04b")[::-1] for j in range(16))]   # nested order
        cfg, w = cfg[:, order], w[:, order]
        cfg[w == 0] = cfg[:, :1].repeat(16, 1)[w == 0]
        return cfg, w, ok

    def _corners(self, el, vis, alb, alt):
        """:meth:`state_corners`, the last states' answer kept (the integrator evaluates the same chunk of steps at
        its patch samples and at its circumsolar nodes)."""
        last = getattr(self, "_last_corners", None)
        if last is not None and all(np.array_equal(a, b) for a, b in zip(last[0], (el, vis, alb, alt))):
            return last[1]
        res = self.state_corners(el, vis, alb, alt)
        self._last_corners = (tuple(np.array(x) for x in (el, vis, alb, alt)), res)
        return res

    def order_key(self, sun_elevation, visibility, albedo, altitude):
        """A (T,) sort key that puts states sharing corner configurations next to each other (visibility
        cell, albedo cell, altitude, elevation)."""
        def cell(q, grid):
            g = np.asarray(grid, float)
            if g.size < 2:
                return np.zeros(np.shape(q), np.int64)
            return np.clip(np.searchsorted(g, np.clip(q, g[0], g[-1]), side="right") - 1, 0, g.size - 2)
        m = self.model
        return np.lexsort((np.asarray(sun_elevation, float), np.asarray(altitude, float),
                           cell(albedo, m.albedos), cell(visibility, m.visibilities)))

    def radiance(self, directions, sun_elevation, sun_azimuth, visibility, albedo, altitude, rows=None,
                 weights=None):
        """Sky radiance [W m-2 sr-1 nm-1] of (T,) states: elevation, azimuth [deg], visibility [km], albedo [1],
        altitude [m], at per-state directions (T, N, 3) (east-north-up, unit vectors).

        Returns (T, N, C); with ``rows`` (N,) int and ``weights`` (N,) [1] the weighted sums per row instead,
        (T, rows.max() + 1, C) (e.g. patch means of stratified samples), and the directions may be (N, 3),
        the same for every state.
        """
        d = np.ascontiguousarray(directions, dtype=np.float64)
        T = np.shape(sun_elevation)[0]
        grouped = rows is not None
        if grouped:
            rows = np.ascontiguousarray(rows, dtype=np.int64)
            weights = np.ascontiguousarray(weights, dtype=np.float64)
            N, n_out = rows.size, int(rows.max()) + 1
            if weights.shape != rows.shape or d.shape[-2:] != (N, 3) or rows.min() < 0:
                raise ValueError("rows and weights: one per direction, rows >= 0")
        else:
            N = n_out = d.shape[1]
        el, az, vis, alb, alt = (np.broadcast_to(np.asarray(x, float), (T,)) for x in
                                 (sun_elevation, sun_azimuth, visibility, albedo, altitude))
        C = self.chi.size
        res = np.empty((T, n_out, C))
        cfg, w, ok = self._corners(el, vis, alb, alt)
        fast = np.nonzero(ok)[0] if self.usable else np.zeros(0, np.int64)
        used = np.where(w[fast] > 0, cfg[fast], -1)
        start = 0
        while start < fast.size and self.usable:
            if np.unique(used[start:]).size - 1 <= self.max_tables:
                need, stop = set(np.unique(used[start:]).tolist()) - {-1}, fast.size
            else:                                   # as many steps as the kept tables allow
                need, stop = set(), start
                while stop < fast.size:
                    new = need | (set(used[stop].tolist()) - {-1})
                    if len(new) > self.max_tables and stop > start:
                        break
                    need, stop = new, stop + 1
            idx = fast[start:stop]
            keys = sorted(need)
            tabs = [self._table(k) for k in keys]
            if not self.usable:
                break
            ci = np.minimum(np.searchsorted(np.array(keys, np.int64), cfg[idx]), len(keys) - 1)
            geo = np.stack([alt[idx], np.radians(el[idx]), np.radians(90.0 - az[idx])], axis=1)
            whole = idx.size == T
            blk = res if whole else np.empty((idx.size, n_out, C))
            dd = d if (d.ndim == 2 or whole) else np.ascontiguousarray(d[idx])
            extra = (rows, weights) if grouped else ()
            _core.radiance_config_eval(tabs, self.sb, self.u, np.ascontiguousarray(ci),
                                       np.ascontiguousarray(w[idx]), geo, dd, blk, self.threads, *extra)
            if not whole:
                res[idx] = blk
            start = stop
        for t in (np.setdiff1d(np.arange(T), fast[:start]) if start < T else ()):
            v = sky_radiance(self.model, d if d.ndim == 2 else d[t], el[t], az[t], vis[t], alb[t], alt[t],
                             channels=self.chi, threads=self.threads)
            if grouped:
                res[t] = 0.0
                np.add.at(res[t], rows, weights[:, None] * v)
            else:
                res[t] = v
        return res

    def direct_normal(self, sun_elevation, sun_azimuth, visibility, altitude):
        """(T, C) spectral direct normal irradiance [W m-2 nm-1] of :func:`solar_direct_normal` for (T,) states
        (elevation, azimuth [deg], visibility [km], altitude [m]), without its per-call overhead; states
        outside the transmittance grids (clamped, with a warning) go through :func:`solar_direct_normal`."""
        m = self.model
        el, az, vis, alt = (np.atleast_1d(np.asarray(x, float)) for x in
                            (sun_elevation, sun_azimuth, visibility, altitude))
        el, az, vis, alt = np.broadcast_arrays(el, az, vis, alt)
        if getattr(self, "_et", None) is None:
            self._et = _extraterrestrial(m, self.chi, None)
            self._trans = m.transmittance_coefficients()
        U, V = self._trans
        T = el.size
        res = np.empty((T, self.chi.size))
        alt_param = np.maximum((alt + PLANET_RADIUS) + SAFETY_ALTITUDE - PLANET_RADIUS, 0.0)
        tv, ta = m.trans_visibilities, m.trans_altitudes
        ok = (vis >= tv[0] - 1e-6) & (vis <= tv[-1] + 1e-6) & (alt <= ta[-1] + 1e-9)
        sun = sun_direction(el, az)
        # the reference lookups of _trans_weights, vectorised (one branch where the factor is <= 0)
        lk = [self._lookup(q, g) for q, g in ((vis, tv), (alt_param, ta))]
        for t in np.nonzero(~ok)[0]:
            res[t] = solar_direct_normal(m, el[t], az[t], vis[t], 0.5, alt[t], channels=self.chi, threads=self.threads)
        # steps with the same knots, factors and altitude share one kernel call over their sun directions (the kernel
        # evaluates each direction on its own: the same values as one call per step)
        good = np.nonzero(ok)[0]
        key = np.stack([lk[0][0][good], lk[0][1][good], lk[1][0][good], lk[1][1][good], alt_param[good]], axis=1)
        _, inverse = np.unique(key, axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        groups = (np.split(good[np.argsort(inverse, kind="stable")], np.cumsum(np.bincount(inverse))[:-1])
                  if good.size else [])
        for grp in groups:
            t = grp[0]
            (iv, fv), (ia, fa) = ((int(i[t]), float(f[t])) for i, f in lk)
            bv = [(iv, 1.0)] if fv <= 0 else [(iv, 1.0 - fv), (iv + 1, fv)]
            ba = [(ia, 1.0)] if fa <= 0 else [(ia, 1.0 - fa), (ia + 1, fa)]
            pv = np.array([v for v, _ in bv for _ in ba], np.int64)
            pa = np.array([a for _ in bv for a, _ in ba], np.int64)
            pw = np.array([wv * wa for _, wv in bv for _, wa in ba], np.float64)
            one = np.empty((grp.size, self.chi.size))
            _core.transmittance(U, V, m.trans_d_dim, m.trans_a_dim, U.shape[0], m.trans_rank, m.n_channels, pv,
                                pa, pw, self.chi, np.ascontiguousarray(sun[grp]), float(alt_param[t]),
                                np.finfo(float).max, one.reshape(-1), self.threads)
            res[grp] = self._et * one
        return res

    @staticmethod
    def _lookup(q, grid):
        """The reference knot lookup (:func:`_reference_lookup`) of each value of ``q``: (index, factor) arrays."""
        g = np.asarray(grid, float)
        n = g.size
        qc = np.clip(np.asarray(q, float), g[0], g[-1])
        k = np.searchsorted(g, qc, side="right")
        last = k >= n
        i = np.where(last, n - 1, k - 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            f = np.where(last, 0.0, (qc - g[i]) / (g[np.minimum(k, n - 1)] - g[i]))
        return i, f
