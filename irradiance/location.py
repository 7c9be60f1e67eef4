"""Sites and the time axis of a simulation.

A :class:`Site` (alias :class:`Location`, as in pvlib) holds latitude, longitude, altitude, time zone
and name. Times are tz-aware :class:`pandas.DatetimeIndex` objects. Interval data (hourly weather
files, 15-min averages) states how each timestamp labels its interval:

- ``"left"``: the timestamp is the start of the interval (sun at ``t + step / 2``);
- ``"right"``: the timestamp is the end of the interval (EPW and TMY3 files; sun at ``t - step / 2``);
- ``"center"``: the timestamp is the middle of the interval, or an instantaneous sample (sun at ``t``).

Sun positions for interval data are always taken at the interval mid-points (:func:`sun_times`).
Naive timestamps are rejected unless a time zone is given explicitly.
"""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .solarposition import solar_position

__all__ = ["Site", "Location", "LABELS", "ensure_tz_aware", "infer_step", "sun_times",
           "time_range", "daytime_steps", "fixed_offset_tz"]

LABELS = ("left", "right", "center")
"""Valid interval labels."""


def fixed_offset_tz(hours: float) -> _dt.timezone:
    """A fixed-offset time zone ``hours`` [h] east of UTC (e.g. -7 for US Mountain Standard Time),
    as in the headers of EPW and TMY3 files (local standard time, no daylight saving)."""
    h = float(hours)
    if not -14.0 <= h <= 14.0:
        raise ValueError(f"time zone offset={h:g} h outside the valid range [-14, 14]")
    return _dt.timezone(_dt.timedelta(hours=h))


def _normalise_tz(tz):
    if tz is None:
        return None
    if isinstance(tz, bool):
        raise TypeError(f"tz must be an IANA name, a tzinfo or an offset in hours, got {tz!r}")
    if isinstance(tz, (int, float, np.integer, np.floating)):
        return fixed_offset_tz(tz)
    if isinstance(tz, str):
        try:
            pd.Timestamp("2000-01-01").tz_localize(tz)
        except Exception as exc:  # pandas raises several types for unknown zones
            raise ValueError(f"tz={tz!r} is not a known time zone name (e.g. 'Europe/Amsterdam', "
                             f"'Etc/GMT+7', 'UTC')") from exc
        return tz
    if isinstance(tz, _dt.tzinfo):
        return tz
    raise TypeError(f"tz must be an IANA name, a tzinfo or an offset in hours, got {tz!r}")


def _check_label(label):
    if label not in LABELS:
        raise ValueError(f"label={label!r} is not one of {LABELS}")
    return label


def ensure_tz_aware(times, tz=None, name="times") -> pd.DatetimeIndex:
    """Return ``times`` as a tz-aware DatetimeIndex.

    Parameters
    ----------
    times : array_like of datetimes or pandas.DatetimeIndex
        Timestamps; if naive they are localized to ``tz``.
    tz : str, tzinfo, float or None
        Time zone for naive timestamps (IANA name, tzinfo or offset [h] east of UTC). ``None``
        with naive times raises ValueError: widesky never guesses a time zone. Tz-aware
        ``times`` are returned unchanged (not converted).
    name : str
        Parameter name used in error messages.
    """
    if not isinstance(times, pd.DatetimeIndex):
        try:
            times = pd.DatetimeIndex(times)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name} could not be read as timestamps: {exc}") from exc
    if times.tz is None:
        if tz is None:
            raise ValueError(
                f"{name} are tz-naive; give tz-aware times or the time zone they are in "
                f"(tz='Europe/Amsterdam', tz=-7 for UTC-7, ...)")
        tz = _normalise_tz(tz)
        try:
            times = times.tz_localize(tz)
        except Exception as exc:  # nonexistent / ambiguous local times around DST changes
            raise ValueError(f"{name} cannot be localized to tz={tz!r}: {exc}") from exc
    if times.hasnans:
        raise ValueError(f"{name} contain NaT at position {int(np.flatnonzero(times.isna())[0])}")
    return times


def infer_step(times: pd.DatetimeIndex) -> pd.Timedelta:
    """The regular step [time] of ``times``: the most common difference between consecutive
    timestamps. Raises ValueError for fewer than two timestamps or a non-positive step."""
    if len(times) < 2:
        raise ValueError("cannot infer the step of fewer than 2 timestamps; give step=")
    diffs = np.diff(times.as_unit("ns").asi8)
    values, counts = np.unique(diffs, return_counts=True)
    step = int(values[np.argmax(counts)])
    if step <= 0:
        raise ValueError("times are not increasing; cannot infer the step, give step=")
    return pd.Timedelta(step, unit="ns")


def sun_times(times, label="center", step=None, tz=None) -> pd.DatetimeIndex:
    """Instants at which to evaluate the sun for each (interval) timestamp.

    Parameters
    ----------
    times : pandas.DatetimeIndex
        Interval labels (tz-aware, or naive with ``tz``).
    label : {"left", "right", "center"}
        What each timestamp labels: start, end or middle of its interval.
    step : str, pandas.Timedelta or None
        Interval length (e.g. ``"1h"``, ``"15min"``); inferred from ``times`` when ``None`` and
        the label is not "center".
    tz : str, tzinfo, float or None
        Time zone for naive ``times``.

    Returns
    -------
    pandas.DatetimeIndex
        Mid-interval instants, same length and time zone as ``times``.
    """
    times = ensure_tz_aware(times, tz)
    _check_label(label)
    if label == "center":
        return times
    step = infer_step(times) if step is None else pd.Timedelta(step)
    if step <= pd.Timedelta(0):
        raise ValueError(f"step={step} must be positive")
    half = step / 2
    return times + half if label == "left" else times - half


def time_range(start, end, step="1h", tz=None, label="left") -> pd.DatetimeIndex:
    """Regular interval labels covering [start, end).

    Parameters
    ----------
    start, end : str or datetime-like
        Period bounds; naive values are taken in ``tz``. ``end`` is exclusive.
    step : str or pandas.Timedelta
        Interval length, e.g. ``"1h"``, ``"15min"``.
    tz : str, tzinfo, float or None
        Time zone (required if ``start``/``end`` are naive).
    label : {"left", "right", "center"}
        Which point of each interval the returned timestamps label.

    Returns
    -------
    pandas.DatetimeIndex
        One timestamp per interval, tz-aware, with ``freq`` set to ``step``.
    """
    _check_label(label)
    step = pd.Timedelta(step)
    if step <= pd.Timedelta(0):
        raise ValueError(f"step={step} must be positive")
    bounds = ensure_tz_aware(pd.DatetimeIndex([pd.Timestamp(start), pd.Timestamp(end)]), tz,
                             name="start/end")
    if bounds[1] <= bounds[0]:
        raise ValueError(f"end={bounds[1]} must be after start={bounds[0]}")
    starts = pd.date_range(bounds[0], bounds[1], freq=step, inclusive="left")
    offset = {"left": pd.Timedelta(0), "center": step / 2, "right": step}[label]
    out = starts + offset
    return pd.DatetimeIndex(out, freq=step)


@dataclass(frozen=True)
class Site:
    """A place on Earth (pvlib's ``Location`` in spirit).

    Attributes
    ----------
    latitude : float
        Latitude [deg], north positive, in [-90, 90].
    longitude : float
        Longitude [deg], east positive, in [-180, 180].
    altitude : float
        Altitude above sea level [m], in [-500, 9000].
    tz : str, tzinfo or float
        Time zone for naive timestamps: IANA name, tzinfo, or an offset [h] east of UTC.
    name : str
        Label for reports.
    """

    latitude: float
    longitude: float
    altitude: float = 0.0
    tz: object = "UTC"
    name: str = ""

    def __post_init__(self):
        for attr, lo, hi, unit in (("latitude", -90.0, 90.0, "deg"), ("longitude", -180.0, 180.0, "deg"),
                                   ("altitude", -500.0, 9000.0, "m")):
            value = getattr(self, attr)
            try:
                v = float(value)
            except (TypeError, ValueError) as exc:
                raise TypeError(f"{attr} must be a number, got {value!r}") from exc
            if not lo <= v <= hi:
                raise ValueError(f"{attr}={v:g} {unit} outside the valid range [{lo:g}, {hi:g}]")
            object.__setattr__(self, attr, v)
        object.__setattr__(self, "tz", _normalise_tz(self.tz))
        object.__setattr__(self, "name", str(self.name))

    def localize(self, times) -> pd.DatetimeIndex:
        """``times`` as a tz-aware DatetimeIndex: naive ones are taken in the site's time zone."""
        return ensure_tz_aware(times, self.tz)

    @property
    def pressure(self) -> float:
        """Standard-atmosphere air pressure at the site's altitude [Pa] (ISO 2533 barometric formula)."""
        return 101325.0 * (1.0 - 2.25577e-5 * self.altitude) ** 5.25588

    def solar_position(self, times, label="center", step=None, pressure=None, temperature=12.0,
                       delta_t=None) -> pd.DataFrame:
        """Solar position at this site (NREL SPA), evaluated mid-interval.

        Parameters
        ----------
        times : DatetimeIndex
            Interval labels; naive times are taken in the site's time zone.
        label : {"left", "right", "center"}
            What each timestamp labels (see :func:`sun_times`).
        step : str, Timedelta or None
            Interval length; inferred when ``None``.
        pressure : float or None
            Air pressure for refraction [Pa]; ``None`` uses :attr:`pressure`.
        temperature : float
            Air temperature for refraction [degC].
        delta_t : float or None
            TT - UT [s]; ``None`` estimates it.

        Returns
        -------
        pandas.DataFrame
            Indexed by the given (localized) ``times``; the columns of
            :func:`widesky.irradiance.solarposition.solar_position`.
        """
        labels = self.localize(times)
        instants = sun_times(labels, label, step)
        sp = solar_position(instants, self.latitude, self.longitude, self.altitude,
                            self.pressure if pressure is None else pressure, temperature, delta_t)
        sp.index = labels
        return sp

    @classmethod
    def from_metadata(cls, metadata: dict) -> "Site":
        """A Site from a weather file's metadata dict (keys ``latitude``, ``longitude``,
        ``altitude``, ``tz`` and optionally ``name``)."""
        missing = [k for k in ("latitude", "longitude") if k not in metadata]
        if missing:
            raise ValueError(f"metadata lacks {missing}")
        return cls(metadata["latitude"], metadata["longitude"], metadata.get("altitude", 0.0),
                   metadata.get("tz", "UTC"), metadata.get("name", ""))


Location = Site
"""Alias of :class:`Site` for pvlib users."""


def daytime_steps(site: Site, start, end, step="1h", label="center", min_elevation=0.0,
                  **solar_kwargs) -> pd.DataFrame:
    """Daytime steps of a clear-sky period: no weather file needed.

    Parameters
    ----------
    site : Site
        Where.
    start, end : str or datetime-like
        Period [start, end); naive values are taken in the site's time zone.
    step : str or Timedelta
        Interval length, e.g. ``"1h"`` or ``"15min"``.
    label : {"left", "right", "center"}
        What the returned timestamps label; the sun is always taken mid-interval.
    min_elevation : float
        Keep intervals whose mid-interval apparent solar elevation exceeds this [deg].
    **solar_kwargs
        Passed to :meth:`Site.solar_position` (pressure, temperature, delta_t).

    Returns
    -------
    pandas.DataFrame
        The solar position of the kept steps, indexed by their labels.
    """
    if not -90.0 <= float(min_elevation) <= 90.0:
        raise ValueError(f"min_elevation={min_elevation:g} deg outside the valid range [-90, 90]")
    labels = time_range(start, end, step, site.tz, label)
    sp = site.solar_position(labels, label=label, step=step, **solar_kwargs)
    keep = sp["apparent_elevation"].to_numpy() > float(min_elevation)
    return sp.loc[keep]
