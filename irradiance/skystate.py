"""The sky state of every time step, and grouping of equal states.

The Prague Sky Model is parameterised by solar elevation [deg], visibility [km], ground albedo [1]
and observer altitude [m]; a scene also needs the solar azimuth [deg] to place the sky. This module
turns a site, its time steps and (optionally) weather into that state per step:

- sun: the mid-interval *apparent* (refracted) topocentric position, i.e. where the light comes from;
- visibility: the weather's ``visibility`` [km] where valid, else from its aerosol optical depth
  ``aod`` through the same Koschmieder relation the dataset generator uses
  (:func:`widesky.skymodel.visibility.visibility_from_aod550`, after an Angstrom-law conversion to 550 nm),
  else a configured default;
- albedo: the weather's ``albedo`` where valid, else a configured default;
- altitude: the observer's height above the model's (sea-level) ground, 0 by default.

Values outside the model's ranges are clamped to the range and flagged per step (columns
``*_clamped``). Steps whose sun is below the model's minimum elevation are flagged ``below_min``
(the model cannot be evaluated: no sky, no beam); steps with the sun below the horizon have no beam
(``has_beam`` False).

:func:`group_sky_states` then rounds states to a configurable resolution so that each distinct sky
is evaluated once and the result is gathered back per step.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, fields

import numpy as np
import pandas as pd

from widesky.skymodel.visibility import aod_at_wavelength, visibility_from_aod550

from .location import Site, _check_label, infer_step, time_range
from .skies import SkyStates
from .weather import WeatherData, read_weather

__all__ = ["SkyRanges", "PSM_RANGES", "sky_ranges", "sky_states", "sky_states_for", "GroupingSteps",
           "DEFAULT_GROUPING", "SkyGroups", "group_sky_states", "SKY_STATE_COLUMNS", "interval_starts",
           "interval_months", "interval_text", "utc_offset_text"]


@dataclass(frozen=True)
class SkyRanges:
    """Valid ranges of a sky model's parameters (the same attributes as a loaded dataset).

    Attributes
    ----------
    visibility_range : (float, float)
        [km]
    albedo_range : (float, float)
        [1]
    elevation_range : (float, float)
        Solar elevation [deg].
    altitude_range : (float, float)
        Observer altitude [m].
    """

    visibility_range: tuple = (20.0, 131.8)
    albedo_range: tuple = (0.0, 1.0)
    elevation_range: tuple = (-4.2, 90.0)
    altitude_range: tuple = (0.0, 15000.0)

    def __post_init__(self):
        for f in fields(self):
            lo, hi = (float(x) for x in getattr(self, f.name))
            if not lo <= hi:
                raise ValueError(f"{f.name}=({lo:g}, {hi:g}) must have min <= max")
            object.__setattr__(self, f.name, (lo, hi))


PSM_RANGES = SkyRanges()
"""Ranges of the full published Prague Sky Model dataset (Wilkie et al. 2021): visibility
20-131.8 km, albedo 0-1, solar elevation -4.2-90 deg, altitude 0-15000 m."""


def sky_ranges(model=None) -> SkyRanges:
    """The ranges of ``model``: any object with attributes ``visibility_range``, ``albedo_range``,
    ``elevation_range`` and ``altitude_range`` (a loaded dataset, a :class:`SkyRanges`, a
    SimpleNamespace ...); ``None`` gives :data:`PSM_RANGES`."""
    if model is None:
        return PSM_RANGES
    if isinstance(model, SkyRanges):
        return model
    names = [f.name for f in fields(SkyRanges)]
    missing = [n for n in names if not hasattr(model, n)]
    if missing:
        raise TypeError(f"model {type(model).__name__} lacks the range attributes {missing}")
    return SkyRanges(*(tuple(getattr(model, n)) for n in names))


SKY_STATE_COLUMNS = ("elevation", "azimuth", "visibility", "albedo", "altitude", "solar_elevation",
                     "visibility_source", "visibility_clamped", "albedo_clamped", "altitude_clamped",
                     "elevation_clamped", "below_min", "has_beam")


def _valid(col, lo_open=0.0, hi=None):
    v = np.asarray(col, dtype=float)
    ok = np.isfinite(v) & (v > lo_open)
    if hi is not None:
        ok &= v <= hi
    return v, ok


def sky_states(solar_position: pd.DataFrame, weather=None, model=None, altitude=0.0,
               default_visibility=50.0, default_albedo=0.2, aod_wavelength=500.0, angstrom=1.3,
               prefer="visibility", use_refraction=True) -> pd.DataFrame:
    """Sky state per time step.

    Parameters
    ----------
    solar_position : pandas.DataFrame
        Per-step solar position with ``apparent_elevation`` (or ``elevation``) [deg] and
        ``azimuth`` [deg], e.g. from :meth:`Site.solar_position` (mid-interval).
    weather : pandas.DataFrame, WeatherData or None
        Optional per-step weather on the same index, with ``visibility`` [km], ``aod`` [1]
        and/or ``albedo`` [1] columns (NaN = missing).
    model : object or None
        Anything with the range attributes (see :func:`sky_ranges`); ``None`` = full PSM ranges.
    altitude : float
        Observer altitude [m] as the sky model defines it: height above the model's ground, which
        the PSM puts at sea level. 0 (default) is an observer on the ground. Passing a site's
        elevation above sea level (e.g. ``site.altitude``) approximates an elevated site by
        removing the air below it: right for the beam's air mass, approximate for the sky (the
        model's ground then lies that far below, seen through the removed air).
    default_visibility : float
        Visibility where the weather gives none [km], > 0.
    default_albedo : float
        Albedo where the weather gives none [1], in [0, 1].
    aod_wavelength : float
        Wavelength at which the weather's ``aod`` is given [nm] (TMY3/EPW broadband AOD is
        conventionally taken at 500 nm).
    angstrom : float
        Angstrom exponent [1] converting ``aod`` to 550 nm.
    prefer : {"visibility", "aod"}
        Which weather column wins when both are valid.
    use_refraction : bool
        Use the apparent (refracted) elevation; False uses the geometric one.

    Returns
    -------
    pandas.DataFrame
        Indexed like ``solar_position``: ``elevation`` [deg] (the model input: clamped to the
        model's range), ``azimuth`` [deg], ``visibility`` [km], ``albedo`` [1], ``altitude`` [m]
        (clamped), ``solar_elevation`` [deg] (unclamped), ``visibility_source``
        ("weather", "aod" or "default"), flags ``visibility_clamped``, ``albedo_clamped``,
        ``altitude_clamped``, ``elevation_clamped``, ``below_min`` (sun below the model's minimum
        elevation: evaluate nothing), ``has_beam`` (sun above the horizon and not ``below_min``).
    """
    if not isinstance(solar_position, pd.DataFrame):
        raise TypeError("solar_position must be a DataFrame (e.g. from Site.solar_position)")
    if prefer not in ("visibility", "aod"):
        raise ValueError(f"prefer={prefer!r} is not one of ('visibility', 'aod')")
    if not default_visibility > 0:
        raise ValueError(f"default_visibility={default_visibility!r} km must be > 0")
    if not 0.0 <= default_albedo <= 1.0:
        raise ValueError(f"default_albedo={default_albedo!r} outside the valid range [0, 1]")
    if not 100.0 <= aod_wavelength <= 5000.0:
        raise ValueError(f"aod_wavelength={aod_wavelength!r} nm outside the valid range [100, 5000]")
    if not -1.0 <= angstrom <= 4.0:
        raise ValueError(f"angstrom={angstrom!r} outside the valid range [-1, 4]")
    ranges = sky_ranges(model)
    key = "apparent_elevation" if use_refraction and "apparent_elevation" in solar_position else "elevation"
    for col in (key, "azimuth"):
        if col not in solar_position:
            raise ValueError(f"solar_position lacks the column {col!r}")
    n = len(solar_position)
    sun_el = solar_position[key].to_numpy(dtype=float)
    azimuth = solar_position["azimuth"].to_numpy(dtype=float) % 360.0

    if weather is not None and hasattr(weather, "data") and hasattr(weather, "site"):
        weather = weather.data
    if weather is not None:
        if len(weather) != n or not weather.index.equals(solar_position.index):
            raise ValueError("weather and solar_position must share the same index "
                             f"({len(weather)} vs {n} steps)")

    vis = np.full(n, float(default_visibility))
    source = np.full(n, "default", dtype=object)
    from_weather = np.zeros(n, bool)
    from_aod = np.zeros(n, bool)
    if weather is not None and "visibility" in weather:
        v_w, from_weather = _valid(weather["visibility"])
    if weather is not None and "aod" in weather:
        tau, from_aod = _valid(weather["aod"])
        tau550 = np.where(from_aod, aod_at_wavelength(np.where(from_aod, tau, 1.0), aod_wavelength,
                                                       550.0, angstrom), 1.0)
        v_a = np.asarray(visibility_from_aod550(tau550), dtype=float)
    order = (("aod", from_aod), ("weather", from_weather))
    if prefer == "aod":
        order = order[::-1]
    for name, ok in order:  # the later one wins
        if ok.any():
            vis = np.where(ok, v_w if name == "weather" else v_a, vis)
            source[ok] = name
    alb = np.full(n, float(default_albedo))
    if weather is not None and "albedo" in weather:
        a_w = np.asarray(weather["albedo"], dtype=float)
        ok = np.isfinite(a_w) & (a_w >= 0.0)
        alb = np.where(ok, a_w, alb)

    def clamp(v, rng):
        c = np.clip(v, rng[0], rng[1])
        return c, c != v

    vis_c, vis_flag = clamp(vis, ranges.visibility_range)
    alb_c, alb_flag = clamp(alb, ranges.albedo_range)
    alt_c, alt_flag = clamp(np.full(n, float(altitude)), ranges.altitude_range)
    el_c, el_flag = clamp(sun_el, ranges.elevation_range)
    below = sun_el < ranges.elevation_range[0]
    return pd.DataFrame({
        "elevation": el_c, "azimuth": azimuth, "visibility": vis_c, "albedo": alb_c,
        "altitude": alt_c, "solar_elevation": sun_el, "visibility_source": source,
        "visibility_clamped": vis_flag, "albedo_clamped": alb_flag, "altitude_clamped": alt_flag,
        "elevation_clamped": el_flag & ~below, "below_min": below, "has_beam": (sun_el > 0.0) & ~below,
    }, index=solar_position.index)


@dataclass(frozen=True)
class GroupingSteps:
    """Rounding resolution for grouping sky states.

    Attributes
    ----------
    elevation : float
        Solar elevation step [deg] (default 0.25). The PSM's own elevation knots are 1-10 deg apart
        near the horizon and coarser above; 0.25 deg keeps the per-step sky error far below the
        model's fitting error (see docs/time-and-weather.md for measured figures).
    azimuth : float or None
        Solar azimuth step [deg] (default 1.0); ``None`` leaves azimuth out of the key (for
        consumers that rotate one sky per elevation themselves).
    visibility : float
        Relative visibility step [1] (default 0.02: bins of 2 % in log space).
    albedo : float
        Albedo step [1] (default 0.01).
    altitude : float
        Altitude step [m] (default 10).
    """

    elevation: float = 0.25
    azimuth: float | None = 1.0
    visibility: float = 0.02
    albedo: float = 0.01
    altitude: float = 10.0

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None and f.name == "azimuth":
                continue
            if v is None or not (float(v) > 0 and np.isfinite(float(v))):
                raise ValueError(f"grouping step {f.name}={v!r} must be a positive number")


DEFAULT_GROUPING = GroupingSteps()


@dataclass(frozen=True)
class SkyGroups:
    """Distinct (rounded) sky states and the map from steps to them.

    Attributes
    ----------
    states : pandas.DataFrame
        One row per distinct sky: ``elevation`` [deg], ``azimuth`` [deg] (NaN when azimuth is not
        grouped), ``visibility`` [km], ``albedo`` [1], ``altitude`` [m] (the members' means, inside
        the model's ranges) and ``count`` (steps using it).
    inverse : numpy.ndarray of int
        Shape (n_steps,): the group of each step, -1 for steps not evaluated (``below_min``).
    index : pandas.Index
        The steps' index.
    steps : GroupingSteps
        The resolution used.
    """

    states: pd.DataFrame
    inverse: np.ndarray
    index: pd.Index
    steps: GroupingSteps

    @property
    def n_steps(self) -> int:
        """Number of time steps."""
        return len(self.inverse)

    @property
    def n_evaluated(self) -> int:
        """Number of steps with a sky (not ``below_min``)."""
        return int(np.count_nonzero(self.inverse >= 0))

    @property
    def n_groups(self) -> int:
        """Number of distinct skies to evaluate."""
        return len(self.states)

    @property
    def reduction(self) -> float:
        """Evaluated steps per distinct sky (the ideal speed-up of evaluating once per group)."""
        return self.n_evaluated / max(self.n_groups, 1)

    def expand(self, values, fill=np.nan):
        """Gather per-group results back to per-step ones.

        Parameters
        ----------
        values : array_like
            Shape (n_groups, ...), one result per distinct sky.
        fill : float
            Value for steps not evaluated.

        Returns
        -------
        numpy.ndarray
            Shape (n_steps, ...).
        """
        v = np.asarray(values)
        if v.shape[:1] != (self.n_groups,):
            raise ValueError(f"values has leading dimension {v.shape[:1]}, expected ({self.n_groups},)")
        out = np.empty((self.n_steps,) + v.shape[1:], dtype=np.result_type(v, np.asarray(fill)))
        ok = self.inverse >= 0
        out[ok] = v[self.inverse[ok]]
        out[~ok] = fill
        return out


def group_sky_states(states: pd.DataFrame, steps: GroupingSteps = DEFAULT_GROUPING,
                     model=None) -> SkyGroups:
    """Group steps whose sky states are equal after rounding.

    Steps share a group when their elevation, azimuth, albedo and altitude round to the same
    multiples of their steps and their visibility to the same power of ``1 + steps.visibility``
    (uniform relative resolution); azimuth wraps at 360 deg. Each group's state is the mean of its
    members (circular mean for azimuth, geometric mean for visibility), so a step's state differs
    from its group's by less than one step, and a constant input (e.g. a default visibility) is
    kept exactly instead of being moved to a bin centre.

    Parameters
    ----------
    states : pandas.DataFrame
        From :func:`sky_states`.
    steps : GroupingSteps
        Resolution.
    model : object or None
        Ranges to clip bin values to (see :func:`sky_ranges`).

    Returns
    -------
    SkyGroups
    """
    for col in ("elevation", "azimuth", "visibility", "albedo", "altitude", "below_min"):
        if col not in states:
            raise ValueError(f"states lacks the column {col!r} (use sky_states())")
    ranges = sky_ranges(model)
    ok = ~states["below_min"].to_numpy(dtype=bool)
    el = states["elevation"].to_numpy(dtype=float)[ok]
    az = states["azimuth"].to_numpy(dtype=float)[ok]
    vis = states["visibility"].to_numpy(dtype=float)[ok]
    alb = states["albedo"].to_numpy(dtype=float)[ok]
    alt = states["altitude"].to_numpy(dtype=float)[ok]
    log_step = np.log1p(steps.visibility)
    k_el = np.round(el / steps.elevation).astype(np.int64)
    if steps.azimuth is None:
        k_az = np.zeros_like(k_el)
    else:
        n_az = int(round(360.0 / steps.azimuth))
        k_az = np.round(az / steps.azimuth).astype(np.int64) % max(n_az, 1)
    k_vis = np.round(np.log(vis) / log_step).astype(np.int64)
    k_alb = np.round(alb / steps.albedo).astype(np.int64)
    k_alt = np.round(alt / steps.altitude).astype(np.int64)
    keys = np.stack([k_el, k_az, k_vis, k_alb, k_alt], axis=1)
    if len(keys):
        uniq, inv, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
        inv = inv.ravel()
    else:
        uniq, inv, counts = np.zeros((0, 5), np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    inverse = np.full(len(states), -1, dtype=np.int64)
    inverse[ok] = inv
    n_g = len(uniq)

    def mean(v):
        return np.bincount(inv, weights=v, minlength=n_g) / np.maximum(counts, 1)

    if steps.azimuth is None:
        az_rep = np.full(n_g, np.nan)
    else:  # circular mean of the members
        rad = np.radians(az)
        az_rep = np.degrees(np.arctan2(mean(np.sin(rad)), mean(np.cos(rad)))) % 360.0
    table = pd.DataFrame({
        "elevation": np.clip(mean(el), *ranges.elevation_range),
        "azimuth": az_rep,
        "visibility": np.clip(np.exp(mean(np.log(vis))), *ranges.visibility_range),
        "albedo": np.clip(mean(alb), *ranges.albedo_range),
        "altitude": np.clip(mean(alt), *ranges.altitude_range),
        "count": counts,
    })
    return SkyGroups(table, inverse, states.index, steps)


def interval_starts(times, label, step=None) -> pd.DatetimeIndex:
    """The start of each step's interval: the rule that puts a step in a period, a month or an hour.

    A weather file's hour is labelled by its end (EPW, TMY3: "right"), so the hour labelled
    Jan 1 00:00 is Dec 31 23:00-24:00 and belongs to December; a site's period by its start ("left").

    Parameters
    ----------
    times : pandas.DatetimeIndex
        Interval labels (tz-aware).
    label : {"left", "right", "center"}
        What each label marks: the start, end or middle of its interval.
    step : str or pandas.Timedelta, optional
        Interval length (e.g. "1h"); inferred from ``times`` when None (then at least 2 steps).

    Returns
    -------
    pandas.DatetimeIndex
        The interval starts, same length and time zone as ``times``.
    """
    times = pd.DatetimeIndex(times)
    if _check_label(label) == "left":
        return times
    step = infer_step(times) if step is None else pd.Timedelta(step)
    return times - (step if label == "right" else step / 2)


def interval_months(times, label, step=None) -> np.ndarray:
    """(T,) calendar month 1..12 of each step's interval, by its start (:func:`interval_starts`): an
    end-labelled hour ending at 1 Feb 00:00 is January's last, one ending at 1 Jan 00:00 is December's."""
    return np.asarray(interval_starts(times, label, step).month)


def interval_text(time, label, step, fmt="%d %b %H:%M") -> str:
    """One step's interval as text, start-end by its start (:func:`interval_starts`), e.g. "31 Dec 23:00-24:00"
    for the EPW hour labelled 1 Jan 00:00 (``label="right"``, ``step="1h"``); ``fmt`` formats the start (strftime),
    the end is its time of day, "24:00" where it is the next midnight."""
    b = interval_starts(pd.DatetimeIndex([pd.Timestamp(time)]), label, step)[0]
    e = b + pd.Timedelta(step)
    end = "24:00" if e.normalize() > b.normalize() and e == e.normalize() else f"{e:%H:%M}"
    return f"{b:{fmt}}-{end}"


def utc_offset_text(time) -> str:
    """A time's offset from UTC as text, "UTC-07:00"; "local time" for a naive time."""
    off = pd.Timestamp(time).utcoffset()
    if off is None:
        return "local time"
    m = int(off.total_seconds() // 60)
    return f"UTC{'+' if m >= 0 else '-'}{abs(m) // 60:02d}:{abs(m) % 60:02d}"


def sky_states_for(source, start=None, end=None, step="1h", *, model=None, visibility=50.0,
                   albedo=0.2, altitude=0.0, label="left", warn=True, prefer="visibility"):
    """Sky states for a site and period (clear sky) or for a weather file: the one path.

    Parameters
    ----------
    source : Site, WeatherData or path
        A :class:`widesky.irradiance.Site` (then ``start`` and ``end`` are required: a regular period), a
        :class:`widesky.irradiance.WeatherData`, or a weather file path (EPW, TMY3, CSV with pvlib names;
        :func:`widesky.irradiance.read_weather`): its steps, per-step visibility (or aerosol optical depth)
        and albedo.
    start, end : str or datetime-like, optional
        Period [start, end) (naive times in the site's zone); with a weather file, a part of it: the steps
        whose interval starts in [start, end), whatever the file's label (an EPW or TMY3 hour, labelled
        with its end t, covers [t - 1 h, t): a full year [Jan 1, Jan 1 of the next year) keeps all 8760
        hours, the last one labelled Jan 1 00:00 of the next year, i.e. Dec 31 24:00).
    step : str or pandas.Timedelta
        Interval length for a site's period, e.g. "1h", "15min" (weather files carry their own).
    model : object, optional
        A loaded dataset (or anything with its range attributes, :func:`sky_ranges`); default the
        full PSM ranges.
    visibility : float
        Visibility [km] where the weather gives none (and for a site's period), > 0.
    albedo : float
        Ground albedo [1] where the weather gives none (and for a site's period), in [0, 1].
    altitude : float
        Observer altitude above the model's ground [m] (see :func:`sky_states`).
    label : {"left", "right", "center"}
        What a site period's timestamps label (weather files carry their own).
    prefer : {"visibility", "aod"}
        Aerosol input from a weather file that has both (:func:`sky_states`); "aod" takes the
        column's aerosol optical depth where valid (docs/all-sky.md: station visibility mixes in fog,
        rain and humid near-surface haze).
    warn : bool
        Warn (UserWarning) with the number of steps clamped to the model's ranges.

    Returns
    -------
    irradiance.skies.SkyStates
        With ``times`` (tz-aware interval labels), the mid-interval apparent sun position [deg],
        ``earth_sun_distance`` [AU] (NREL SPA), and ``clamped`` flags for ``visibility``,
        ``albedo`` and ``altitude`` (values outside the model's ranges are clamped to them).
    """


    if isinstance(source, Site):
        if start is None or end is None:
            raise ValueError("a site's sky states need start= and end= (the period)")
        times = time_range(start, end, step, tz=source.tz, label=label)
        sp = source.solar_position(times, label=label, step=step)
        weather = None
    else:
        wd = source if isinstance(source, WeatherData) else read_weather(source)
        data = wd.data
        if start is not None or end is not None:
            # a step belongs to the period by its interval, not by its label: the interval starts in [start, end)
            # (as time_range's steps of a site's period); an end-labelled hour (EPW, TMY3) ending at `end`
            # is the period's last, and one ending at `start` is the hour before it
            begins = interval_starts(data.index, wd.label, wd.step)
            keep = np.ones(len(data), bool)
            if start is not None:
                keep &= begins >= wd.site.localize([start])[0]
            if end is not None:
                keep &= begins < wd.site.localize([end])[0]
            data = data[keep]
            if data.empty:
                years = sorted(set(wd.data.index.year))
                mixed = (f"; its records carry the years {years[0]}..{years[-1]} (a typical year mixes years: move "
                         f"them to one year with coerce_year, --coerce-year on the command line)"
                         if len(years) > 1 else f"; its records are of {years[0]}: choose a period in {years[0]}, "
                         f"or move them to the period's year with coerce_year (--coerce-year on the command line)")
                raise ValueError(f"no steps of the weather file in the period {start} .. {end}{mixed}")
        times = data.index
        sp = wd.site.solar_position(times, wd.label, wd.step)
        weather = data
    st = sky_states(sp, weather, model=model, altitude=altitude, default_visibility=visibility, prefer=prefer,
                    default_albedo=albedo)
    clamped = {"visibility": st["visibility_clamped"].to_numpy(),
               "albedo": st["albedo_clamped"].to_numpy(),
               "altitude": st["altitude_clamped"].to_numpy()}
    states = SkyStates.create(st["solar_elevation"].to_numpy(), st["azimuth"].to_numpy(),
                              st["visibility"].to_numpy(), st["albedo"].to_numpy(),
                              st["altitude"].to_numpy(),
                              earth_sun_distance=sp["earth_sun_distance"].to_numpy(),
                              clamped=clamped, times=times)
    n = states.n_clamped
    if warn and n:
        r = sky_ranges(model)
        rng = {"visibility": (r.visibility_range, "km"), "albedo": (r.albedo_range, ""),
               "altitude": (r.altitude_range, "m")}
        parts = ", ".join(f"{k} {v} (range [{rng[k][0][0]:g}, {rng[k][0][1]:g}]{' ' if rng[k][1] else ''}"
                          f"{rng[k][1]})" for k, v in n.items())
        warnings.warn(f"{len(states)} steps: clamped to the sky model's ranges: {parts}; flagged in "
                      "SkyStates.clamped", UserWarning, stacklevel=2)
    return states
