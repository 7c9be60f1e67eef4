"""Solar position by the NREL Solar Position Algorithm (SPA).

Implemented from the algorithm description in

    I. Reda and A. Andreas, "Solar position algorithm for solar radiation applications",
    Solar Energy 76(5), 577-589 (2004); NREL/TP-560-34302 (revised 2008).

The periodic-term tables (Earth heliocentric longitude, latitude and radius vector from the
VSOP87 theory as truncated in the paper, and the 63 IAU 1980 nutation terms) are the paper's
Tables A4.2 and A4.3. The algorithm's stated uncertainty is +-0.0003 deg for years -2000 to 6000.

Everything is vectorised over time steps with numpy: :func:`spa` is the array kernel (takes
UNIX seconds in UTC), :func:`solar_position` the pandas edge (takes a tz-aware DatetimeIndex
and returns a DataFrame with pvlib's column names).

Conventions: angles in degrees; azimuth clockwise from north (east = 90, south = 180);
pressure in Pa (the paper uses mbar: converted here once); temperature in degC; altitude in m
above sea level; equation of time in minutes.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd

__all__ = [
    "SpaResult",
    "spa",
    "solar_position",
    "julian_day",
    "delta_t_estimate",
    "dni_extra",
    "SOLAR_CONSTANT",
]

SOLAR_CONSTANT = 1361.0
"""Total solar irradiance at 1 AU [W m-2] (Kopp & Lean 2011, Geophys. Res. Lett. 38, L01706)."""

_J2000 = 2451545.0
_UNIX_EPOCH_JD = 2440587.5
_EARTH_RADIUS_M = 6378140.0
_SUN_RADIUS_DEG = 0.26667

# --------------------------------------------------------------------------------------------
# Reda & Andreas (2004), Table A4.2: Earth periodic terms. Rows are (A, B, C); the term is
# A cos(B + C * JME), A in 1e-8 rad (1e-8 AU for R), B in rad, C in rad per Julian millennium.
# --------------------------------------------------------------------------------------------
_L0 = [
    (175347046, 0, 0), (3341656, 4.6692568, 6283.07585), (34894, 4.6261, 12566.1517),
    (3497, 2.7441, 5753.3849), (3418, 2.8289, 3.5231), (3136, 3.6277, 77713.7715),
    (2676, 4.4181, 7860.4194), (2343, 6.1352, 3930.2097), (1324, 0.7425, 11506.7698),
    (1273, 2.0371, 529.691), (1199, 1.1096, 1577.3435), (990, 5.233, 5884.927),
    (902, 2.045, 26.298), (857, 3.508, 398.149), (780, 1.179, 5223.694),
    (753, 2.533, 5507.553), (505, 4.583, 18849.228), (492, 4.205, 775.523),
    (357, 2.92, 0.067), (317, 5.849, 11790.629), (284, 1.899, 796.298),
    (271, 0.315, 10977.079), (243, 0.345, 5486.778), (206, 4.806, 2544.314),
    (205, 1.869, 5573.143), (202, 2.458, 6069.777), (156, 0.833, 213.299),
    (132, 3.411, 2942.463), (126, 1.083, 20.775), (115, 0.645, 0.98),
    (103, 0.636, 4694.003), (102, 0.976, 15720.839), (102, 4.267, 7.114),
    (99, 6.21, 2146.17), (98, 0.68, 155.42), (86, 5.98, 161000.69),
    (85, 1.3, 6275.96), (85, 3.67, 71430.7), (80, 1.81, 17260.15),
    (79, 3.04, 12036.46), (75, 1.76, 5088.63), (74, 3.5, 3154.69),
    (74, 4.68, 801.82), (70, 0.83, 9437.76), (62, 3.98, 8827.39),
    (61, 1.82, 7084.9), (57, 2.78, 6286.6), (56, 4.39, 14143.5),
    (56, 3.47, 6279.55), (52, 0.19, 12139.55), (52, 1.33, 1748.02),
    (51, 0.28, 5856.48), (49, 0.49, 1194.45), (41, 5.37, 8429.24),
    (41, 2.4, 19651.05), (39, 6.17, 10447.39), (37, 6.04, 10213.29),
    (37, 2.57, 1059.38), (36, 1.71, 2352.87), (36, 1.78, 6812.77),
    (33, 0.59, 17789.85), (30, 0.44, 83996.85), (30, 2.74, 1349.87),
    (25, 3.16, 4690.48),
]
_L1 = [
    (628331966747, 0, 0), (206059, 2.678235, 6283.07585), (4303, 2.6351, 12566.1517),
    (425, 1.59, 3.523), (119, 5.796, 26.298), (109, 2.966, 1577.344),
    (93, 2.59, 18849.23), (72, 1.14, 529.69), (68, 1.87, 398.15),
    (67, 4.41, 5507.55), (59, 2.89, 5223.69), (56, 2.17, 155.42),
    (45, 0.4, 796.3), (36, 0.47, 775.52), (29, 2.65, 7.11),
    (21, 5.34, 0.98), (19, 1.85, 5486.78), (19, 4.97, 213.3),
    (17, 2.99, 6275.96), (16, 0.03, 2544.31), (16, 1.43, 2146.17),
    (15, 1.21, 10977.08), (12, 2.83, 1748.02), (12, 3.26, 5088.63),
    (12, 5.27, 1194.45), (12, 2.08, 4694), (11, 0.77, 553.57),
    (10, 1.3, 6286.6), (10, 4.24, 1349.87), (9, 2.7, 242.73),
    (9, 5.64, 951.72), (8, 5.3, 2352.87), (6, 2.65, 9437.76),
    (6, 4.67, 4690.48),
]
_L2 = [
    (52919, 0, 0), (8720, 1.0721, 6283.0758), (309, 0.867, 12566.152),
    (27, 0.05, 3.52), (16, 5.19, 26.3), (16, 3.68, 155.42),
    (10, 0.76, 18849.23), (9, 2.06, 77713.77), (7, 0.83, 775.52),
    (5, 4.66, 1577.34), (4, 1.03, 7.11), (4, 3.44, 5573.14),
    (3, 5.14, 796.3), (3, 6.05, 5507.55), (3, 1.19, 242.73),
    (3, 6.12, 529.69), (3, 0.31, 398.15), (3, 2.28, 553.57),
    (2, 4.38, 5223.69), (2, 3.75, 0.98),
]
_L3 = [
    (289, 5.844, 6283.076), (35, 0, 0), (17, 5.49, 12566.15),
    (3, 5.2, 155.42), (1, 4.72, 3.52), (1, 5.3, 18849.23), (1, 5.97, 242.73),
]
_L4 = [(114, 3.142, 0), (8, 4.13, 6283.08), (1, 3.84, 12566.15)]
_L5 = [(1, 3.14, 0)]

_B0 = [
    (280, 3.199, 84334.662), (102, 5.422, 5507.553), (80, 3.88, 5223.69),
    (44, 3.7, 2352.87), (32, 4, 1577.34),
]
_B1 = [(9, 3.9, 5507.55), (6, 1.73, 5223.69)]

_R0 = [
    (100013989, 0, 0), (1670700, 3.0984635, 6283.07585), (13956, 3.05525, 12566.1517),
    (3084, 5.1985, 77713.7715), (1628, 1.1739, 5753.3849), (1576, 2.8469, 7860.4194),
    (925, 5.453, 11506.77), (542, 4.564, 3930.21), (472, 3.661, 5884.927),
    (346, 0.964, 5507.553), (329, 5.9, 5223.694), (307, 0.299, 5573.143),
    (243, 4.273, 11790.629), (212, 5.847, 1577.344), (186, 5.022, 10977.079),
    (175, 3.012, 18849.228), (110, 5.055, 5486.778), (98, 0.89, 6069.78),
    (86, 5.69, 15720.84), (86, 1.27, 161000.69), (65, 0.27, 17260.15),
    (63, 0.92, 529.69), (57, 2.01, 83996.85), (56, 5.24, 71430.7),
    (49, 3.25, 2544.31), (47, 2.58, 775.52), (45, 5.54, 9437.76),
    (43, 6.01, 6275.96), (39, 5.36, 4694), (38, 2.39, 8827.39),
    (37, 0.83, 19651.05), (37, 4.9, 12139.55), (36, 1.67, 12036.46),
    (35, 1.84, 2942.46), (33, 0.24, 7084.9), (32, 0.18, 5088.63),
    (32, 1.78, 398.15), (28, 1.21, 6286.6), (28, 1.9, 6279.55),
    (26, 4.59, 10447.39),
]
_R1 = [
    (103019, 1.10749, 6283.07585), (1721, 1.0644, 12566.1517), (702, 3.142, 0),
    (32, 1.02, 18849.23), (31, 2.84, 5507.55), (25, 1.32, 5223.69),
    (18, 1.42, 1577.34), (10, 5.91, 10977.08), (9, 1.42, 6275.96),
    (9, 0.27, 5486.78),
]
_R2 = [
    (4359, 5.7846, 6283.0758), (124, 5.579, 12566.152), (12, 3.14, 0),
    (9, 3.63, 77713.77), (6, 1.87, 5573.14), (3, 5.47, 18849.23),
]
_R3 = [(145, 4.273, 6283.076), (7, 3.92, 12566.15)]
_R4 = [(4, 2.56, 6283.08)]

_L_TERMS = tuple(np.array(t, dtype=float) for t in (_L0, _L1, _L2, _L3, _L4, _L5))
_B_TERMS = tuple(np.array(t, dtype=float) for t in (_B0, _B1))
_R_TERMS = tuple(np.array(t, dtype=float) for t in (_R0, _R1, _R2, _R3, _R4))

# --------------------------------------------------------------------------------------------
# Reda & Andreas (2004), Table A4.3: periodic terms for the nutation in longitude and obliquity
# (IAU 1980). Multipliers of (X0 .. X4) = (D, M, M', F, Omega) and coefficients (a, b, c, d):
# dpsi = sum (a + b JCE) sin(arg), deps = sum (c + d JCE) cos(arg), in 0.0001 arcsec.
# --------------------------------------------------------------------------------------------
_NUTATION = np.array([
    (0, 0, 0, 0, 1, -171996, -174.2, 92025, 8.9),
    (-2, 0, 0, 2, 2, -13187, -1.6, 5736, -3.1),
    (0, 0, 0, 2, 2, -2274, -0.2, 977, -0.5),
    (0, 0, 0, 0, 2, 2062, 0.2, -895, 0.5),
    (0, 1, 0, 0, 0, 1426, -3.4, 54, -0.1),
    (0, 0, 1, 0, 0, 712, 0.1, -7, 0),
    (-2, 1, 0, 2, 2, -517, 1.2, 224, -0.6),
    (0, 0, 0, 2, 1, -386, -0.4, 200, 0),
    (0, 0, 1, 2, 2, -301, 0, 129, -0.1),
    (-2, -1, 0, 2, 2, 217, -0.5, -95, 0.3),
    (-2, 0, 1, 0, 0, -158, 0, 0, 0),
    (-2, 0, 0, 2, 1, 129, 0.1, -70, 0),
    (0, 0, -1, 2, 2, 123, 0, -53, 0),
    (2, 0, 0, 0, 0, 63, 0, 0, 0),
    (0, 0, 1, 0, 1, 63, 0.1, -33, 0),
    (2, 0, -1, 2, 2, -59, 0, 26, 0),
    (0, 0, -1, 0, 1, -58, -0.1, 32, 0),
    (0, 0, 1, 2, 1, -51, 0, 27, 0),
    (-2, 0, 2, 0, 0, 48, 0, 0, 0),
    (0, 0, -2, 2, 1, 46, 0, -24, 0),
    (2, 0, 0, 2, 2, -38, 0, 16, 0),
    (0, 0, 2, 2, 2, -31, 0, 13, 0),
    (0, 0, 2, 0, 0, 29, 0, 0, 0),
    (-2, 0, 1, 2, 2, 29, 0, -12, 0),
    (0, 0, 0, 2, 0, 26, 0, 0, 0),
    (-2, 0, 0, 2, 0, -22, 0, 0, 0),
    (0, 0, -1, 2, 1, 21, 0, -10, 0),
    (0, 2, 0, 0, 0, 17, -0.1, 0, 0),
    (2, 0, -1, 0, 1, 16, 0, -8, 0),
    (-2, 2, 0, 2, 2, -16, 0.1, 7, 0),
    (0, 1, 0, 0, 1, -15, 0, 9, 0),
    (-2, 0, 1, 0, 1, -13, 0, 7, 0),
    (0, -1, 0, 0, 1, -12, 0, 6, 0),
    (0, 0, 2, -2, 0, 11, 0, 0, 0),
    (2, 0, -1, 2, 1, -10, 0, 5, 0),
    (2, 0, 1, 2, 2, -8, 0, 3, 0),
    (0, 1, 0, 2, 2, 7, 0, -3, 0),
    (-2, 1, 1, 0, 0, -7, 0, 0, 0),
    (0, -1, 0, 2, 2, -7, 0, 3, 0),
    (2, 0, 0, 2, 1, -7, 0, 3, 0),
    (2, 0, 1, 0, 0, 6, 0, 0, 0),
    (-2, 0, 2, 2, 2, 6, 0, -3, 0),
    (-2, 0, 1, 2, 1, 6, 0, -3, 0),
    (2, 0, -2, 0, 1, -6, 0, 3, 0),
    (2, 0, 0, 0, 1, -6, 0, 3, 0),
    (0, -1, 1, 0, 0, 5, 0, 0, 0),
    (-2, -1, 0, 2, 1, -5, 0, 3, 0),
    (-2, 0, 0, 0, 1, -5, 0, 3, 0),
    (0, 0, 2, 2, 1, -5, 0, 3, 0),
    (-2, 0, 2, 0, 1, 4, 0, 0, 0),
    (-2, 1, 0, 2, 1, 4, 0, 0, 0),
    (0, 0, 1, -2, 0, 4, 0, 0, 0),
    (-1, 0, 1, 0, 0, -4, 0, 0, 0),
    (-2, 1, 0, 0, 0, -4, 0, 0, 0),
    (1, 0, 0, 0, 0, -4, 0, 0, 0),
    (0, 0, 1, 2, 0, 3, 0, 0, 0),
    (0, 0, -2, 2, 2, -3, 0, 0, 0),
    (-1, -1, 1, 0, 0, -3, 0, 0, 0),
    (0, 1, 1, 0, 0, -3, 0, 0, 0),
    (0, -1, 1, 2, 2, -3, 0, 0, 0),
    (2, -1, -1, 2, 2, -3, 0, 0, 0),
    (0, 0, 3, 2, 2, -3, 0, 0, 0),
    (2, -1, 0, 2, 2, -3, 0, 0, 0),
], dtype=float)
_NUT_Y = _NUTATION[:, :5]
_NUT_ABCD = _NUTATION[:, 5:]
_NUT_Y_IDX = _NUT_Y.astype(np.int64) + 3  # column in the table of powers k = -3..3


class SpaResult(NamedTuple):
    """All outputs of :func:`spa`, each a numpy array of the broadcast input shape.

    Angles in degrees, ``earth_sun_distance`` in AU, ``equation_of_time`` in minutes,
    ``julian_day``/``julian_ephemeris_day`` in days.
    """

    julian_day: np.ndarray
    julian_ephemeris_day: np.ndarray
    heliocentric_longitude: np.ndarray  # L [deg], 0..360
    heliocentric_latitude: np.ndarray  # B [deg]
    earth_sun_distance: np.ndarray  # R [AU]
    nutation_longitude: np.ndarray  # delta psi [deg]
    nutation_obliquity: np.ndarray  # delta epsilon [deg]
    true_obliquity: np.ndarray  # epsilon [deg]
    apparent_sun_longitude: np.ndarray  # lambda [deg]
    apparent_sidereal_time: np.ndarray  # nu [deg]
    right_ascension: np.ndarray  # alpha, geocentric [deg], 0..360
    declination: np.ndarray  # delta, geocentric [deg]
    hour_angle: np.ndarray  # H, observer local, geocentric [deg], 0..360
    topocentric_right_ascension: np.ndarray  # alpha' [deg]
    topocentric_declination: np.ndarray  # delta' [deg]
    topocentric_hour_angle: np.ndarray  # H' [deg]
    elevation: np.ndarray  # e0, topocentric, no refraction [deg]
    apparent_elevation: np.ndarray  # e, with refraction [deg]
    zenith: np.ndarray  # 90 - e0 [deg]
    apparent_zenith: np.ndarray  # 90 - e [deg]
    azimuth: np.ndarray  # clockwise from north [deg], 0..360
    equation_of_time: np.ndarray  # [min]


def _check_range(name, value, lo, hi, unit, lo_open=False):
    v = np.asarray(value, dtype=float)
    bad = ~((v > lo) if lo_open else (v >= lo)) | ~(v <= hi)
    if np.any(bad):
        first = v[bad].ravel()[0] if v.ndim else float(v)
        lb = "(" if lo_open else "["
        raise ValueError(f"{name}={first:g} {unit} outside the valid range {lb}{lo:g}, {hi:g}]")
    return v


def julian_day(unixtime):
    """Julian day (UT) [d] of UNIX timestamps ``unixtime`` [s since 1970-01-01T00:00 UTC].

    Accepts an array, or a tz-aware :class:`pandas.DatetimeIndex` (converted to UTC).
    Reda & Andreas (2004) eq. 4 for the Gregorian calendar is equivalent to
    ``JD = unixtime / 86400 + 2440587.5``.
    """
    if isinstance(unixtime, pd.DatetimeIndex):
        unixtime = _unixtime(unixtime)
    return np.asarray(unixtime, dtype=float) / 86400.0 + _UNIX_EPOCH_JD


def _unixtime(times: pd.DatetimeIndex) -> np.ndarray:
    if times.tz is None:
        raise ValueError(
            "times are tz-naive; give tz-aware times (e.g. times.tz_localize('Etc/GMT+7')) "
            "or use a Site, which localizes naive times in its own time zone")
    ns = times.tz_convert("UTC").as_unit("ns").asi8
    return ns.astype(np.float64) / 1e9


def delta_t_estimate(year):
    """Estimated Delta T = TT - UT [s] for decimal ``year`` [yr].

    Polynomial expressions of Espenak & Meeus (2006), "Five Millennium Canon of Solar Eclipses",
    NASA/TP-2006-214141, for 1900-2150; their long-term parabola
    ``-20 + 32 ((year - 1820) / 100)^2`` outside. Observed values: 63.8 s (2000), 69.4 s (2020);
    the estimate is within about 2 s of them over 1900-2023. SPA's sun position depends on Delta T
    only through the ephemeris time: 1 s of Delta T moves the sun by about 1e-5 deg.
    """
    y = np.asarray(year, dtype=float)
    out = -20.0 + 32.0 * ((y - 1820.0) / 100.0) ** 2
    t = y - 1900.0
    out = np.where((y >= 1900) & (y < 1920),
                   -2.79 + 1.494119 * t - 0.0598939 * t**2 + 0.0061966 * t**3 - 0.000197 * t**4, out)
    t = y - 1920.0
    out = np.where((y >= 1920) & (y < 1941),
                   21.20 + 0.84493 * t - 0.076100 * t**2 + 0.0020936 * t**3, out)
    t = y - 1950.0
    out = np.where((y >= 1941) & (y < 1961), 29.07 + 0.407 * t - t**2 / 233.0 + t**3 / 2547.0, out)
    t = y - 1975.0
    out = np.where((y >= 1961) & (y < 1986), 45.45 + 1.067 * t - t**2 / 260.0 - t**3 / 718.0, out)
    t = y - 2000.0
    out = np.where((y >= 1986) & (y < 2005),
                   63.86 + 0.3345 * t - 0.060374 * t**2 + 0.0017275 * t**3 + 0.000651814 * t**4
                   + 0.00002373599 * t**5, out)
    out = np.where((y >= 2005) & (y < 2050), 62.92 + 0.32217 * t + 0.005589 * t**2, out)
    out = np.where((y >= 2050) & (y < 2150),
                   -20.0 + 32.0 * ((y - 1820.0) / 100.0) ** 2 - 0.5628 * (2150.0 - y), out)
    return out


def _series(terms, jme):
    """sum over terms of A cos(B + C JME); ``jme`` shape (n,), result (n,)."""
    a, b, c = terms[:, 0], terms[:, 1], terms[:, 2]
    return np.cos(b + np.multiply.outer(jme, c)) @ a


def _poly(series_list, jme):
    total = np.zeros_like(jme)
    for power, terms in enumerate(series_list):
        total = total + _series(terms, jme) * jme**power
    return total / 1e8


def dni_extra(earth_sun_distance, solar_constant=SOLAR_CONSTANT):
    """Extraterrestrial normal irradiance [W m-2] at ``earth_sun_distance`` [AU]:
    ``solar_constant / R^2`` with ``solar_constant`` [W m-2] (default 1361, Kopp & Lean 2011)."""
    r = _check_range("earth_sun_distance", earth_sun_distance, 0.0, 10.0, "AU", lo_open=True)
    return float(solar_constant) / r**2


def spa(unixtime, latitude, longitude, altitude=0.0, pressure=101325.0, temperature=12.0,
        delta_t=None, atmos_refract=0.5667):
    """NREL SPA (Reda & Andreas 2004) over arrays; returns every intermediate as :class:`SpaResult`.

    Parameters
    ----------
    unixtime : array_like
        Times as seconds since 1970-01-01T00:00 UTC [s], shape (n,) or scalar.
    latitude : float or array_like
        Observer geodetic latitude [deg], north positive, in [-90, 90].
    longitude : float or array_like
        Observer longitude [deg], east positive, in [-180, 180].
    altitude : float or array_like
        Observer altitude above sea level [m], >= -6500000.
    pressure : float or array_like
        Annual mean local pressure [Pa] for refraction, in (0, 500000].
    temperature : float or array_like
        Annual mean local air temperature [degC] for refraction, in (-273.15, 6000].
    delta_t : float, array_like or None
        TT - UT [s], in [-8000, 8000]; ``None`` uses :func:`delta_t_estimate` for each time.
    atmos_refract : float
        Atmospheric refraction at sunrise and sunset [deg], in [-5, 5]; refraction is applied
        only when the unrefracted sun is above ``-(0.26667 + atmos_refract)`` deg, as in the
        paper's reference code.

    Returns
    -------
    SpaResult
        Arrays of the broadcast shape of the inputs.
    """
    ut = np.asarray(unixtime, dtype=float)
    if np.any(~np.isfinite(ut)):
        raise ValueError("unixtime contains non-finite values (NaT in times?)")
    lat = _check_range("latitude", latitude, -90.0, 90.0, "deg")
    lon = _check_range("longitude", longitude, -180.0, 180.0, "deg")
    alt = _check_range("altitude", altitude, -6500000.0, 1e8, "m")
    p_mbar = _check_range("pressure", pressure, 0.0, 500000.0, "Pa", lo_open=True) / 100.0
    temp = _check_range("temperature", temperature, -273.15, 6000.0, "degC", lo_open=True)
    refr = _check_range("atmos_refract", atmos_refract, -5.0, 5.0, "deg")

    shape = np.broadcast_shapes(ut.shape, lat.shape, lon.shape, alt.shape, p_mbar.shape, temp.shape,
                                refr.shape)
    ut = np.broadcast_to(ut, shape).ravel()
    if delta_t is None:
        dt = delta_t_estimate(1970.0 + ut / (365.2425 * 86400.0))
    else:
        dt = np.broadcast_to(_check_range("delta_t", delta_t, -8000.0, 8000.0, "s"), shape).ravel()
    flat = [np.broadcast_to(v, shape).ravel() for v in (lat, lon, alt, p_mbar, temp, refr)]
    n = ut.size
    parts = [_spa_kernel(ut[i:i + _CHUNK], dt[i:i + _CHUNK], *(v[i:i + _CHUNK] for v in flat))
             for i in (range(0, n, _CHUNK) or [0])]
    cols = [np.concatenate(c) for c in zip(*parts)]
    return SpaResult(*(np.reshape(c, shape) for c in cols))


_CHUNK = 1024  # time steps per kernel call: keeps the (chunk, terms) work arrays in cache


def _spa_kernel(ut, dt, lat_b, lon_b, alt_b, p_b, t_b, refr_b):
    """SPA on flat arrays of equal length; returns the SpaResult fields in order."""
    jd = ut / 86400.0 + _UNIX_EPOCH_JD
    # Julian century / millennium (eqs. 5-8); offsets from J2000 in days keep full precision.
    d_ut = (ut - 946728000.0) / 86400.0  # JD - 2451545 (946728000 s = 2000-01-01T12:00 UTC)
    jc = d_ut / 36525.0
    jce = (d_ut + dt / 86400.0) / 36525.0
    jme = jce / 10.0

    # 3.2 Earth heliocentric longitude, latitude, radius vector
    l_deg = np.degrees(_poly(_L_TERMS, jme)) % 360.0
    b_deg = np.degrees(_poly(_B_TERMS, jme))
    r_au = _poly(_R_TERMS, jme)
    # 3.3 geocentric
    theta = (l_deg + 180.0) % 360.0
    beta = -b_deg
    # 3.4 nutation
    x = np.stack([
        297.85036 + 445267.111480 * jce - 0.0019142 * jce**2 + jce**3 / 189474.0,
        357.52772 + 35999.050340 * jce - 0.0001603 * jce**2 - jce**3 / 300000.0,
        134.96298 + 477198.867398 * jce + 0.0086972 * jce**2 + jce**3 / 56250.0,
        93.27191 + 483202.017538 * jce - 0.0036825 * jce**2 + jce**3 / 327270.0,
        125.04452 - 1934.136261 * jce + 0.0020708 * jce**2 + jce**3 / 450000.0,
    ], axis=-1)
    # exp(i * sum_j Y_ij X_j) as products of exp(i k X_j), k = -3..3: 10 trig calls per time
    # instead of 126 (same values to rounding: the multipliers Y_ij are small integers).
    ex = np.exp(1j * np.radians(x))  # (n, 5)
    powers = ex[:, :, None] ** np.arange(-3, 4)  # (n, 5, 7)
    rot = powers[:, 0, _NUT_Y_IDX[:, 0]]
    for j in range(1, 5):
        rot = rot * powers[:, j, _NUT_Y_IDX[:, j]]  # (n, 63)
    a, b, c, d = _NUT_ABCD.T
    dpsi = ((rot.imag * a).sum(-1) + jce * (rot.imag @ b)) / 36000000.0
    deps = ((rot.real * c).sum(-1) + jce * (rot.real @ d)) / 36000000.0
    # 3.5 obliquity of the ecliptic
    u = jme / 10.0
    eps0 = (84381.448 + u * (-4680.93 + u * (-1.55 + u * (1999.25 + u * (-51.38 + u * (
        -249.67 + u * (-39.05 + u * (7.12 + u * (27.87 + u * (5.79 + u * 2.45))))))))))
    eps = eps0 / 3600.0 + deps
    # 3.6-3.7 aberration, apparent sun longitude
    dtau = -20.4898 / (3600.0 * r_au)
    lam = theta + dpsi + dtau
    # 3.8 apparent sidereal time at Greenwich
    nu0 = (280.46061837 + 360.98564736629 * d_ut + 0.000387933 * jc**2 - jc**3 / 38710000.0) % 360.0
    eps_r = np.radians(eps)
    nu = nu0 + dpsi * np.cos(eps_r)
    # 3.9-3.10 geocentric right ascension and declination
    lam_r, beta_r = np.radians(lam), np.radians(beta)
    alpha = np.degrees(np.arctan2(np.sin(lam_r) * np.cos(eps_r) - np.tan(beta_r) * np.sin(eps_r),
                                  np.cos(lam_r))) % 360.0
    delta = np.degrees(np.arcsin(np.sin(beta_r) * np.cos(eps_r)
                                 + np.cos(beta_r) * np.sin(eps_r) * np.sin(lam_r)))
    # 3.11 observer local hour angle
    h = (nu + lon_b - alpha) % 360.0
    # 3.12 topocentric right ascension
    xi = np.radians(8.794 / (3600.0 * r_au))
    phi = np.radians(lat_b)
    uu = np.arctan(0.99664719 * np.tan(phi))
    xx = np.cos(uu) + alt_b / _EARTH_RADIUS_M * np.cos(phi)
    yy = 0.99664719 * np.sin(uu) + alt_b / _EARTH_RADIUS_M * np.sin(phi)
    h_r, delta_r = np.radians(h), np.radians(delta)
    denom = np.cos(delta_r) - xx * np.sin(xi) * np.cos(h_r)
    dalpha = np.arctan2(-xx * np.sin(xi) * np.sin(h_r), denom)
    alpha_p = np.degrees(np.radians(alpha) + dalpha)
    delta_p_r = np.arctan2((np.sin(delta_r) - yy * np.sin(xi)) * np.cos(dalpha), denom)
    # 3.13 topocentric local hour angle
    hp_r = h_r - dalpha
    # 3.14 topocentric zenith angle
    e0 = np.degrees(np.arcsin(np.sin(phi) * np.sin(delta_p_r)
                              + np.cos(phi) * np.cos(delta_p_r) * np.cos(hp_r)))
    refracted = e0 >= -(_SUN_RADIUS_DEG + refr_b)
    e_ok = np.where(refracted, e0, 45.0)  # keeps the formula finite where it is not applied
    de = (p_b / 1010.0) * (283.0 / (273.0 + t_b)) * 1.02 / (
        60.0 * np.tan(np.radians(e_ok + 10.3 / (e_ok + 5.11))))
    de = np.where(refracted, de, 0.0)
    e = e0 + de
    # 3.15 topocentric azimuth (astronomers' from south, then navigators' from north)
    gamma = np.degrees(np.arctan2(np.sin(hp_r),
                                  np.cos(hp_r) * np.sin(phi) - np.tan(delta_p_r) * np.cos(phi)))
    azimuth = (gamma + 180.0) % 360.0
    # A.1 equation of time
    m = (280.4664567 + jme * (360007.6982779 + jme * (0.03032028 + jme * (
        1.0 / 49931.0 + jme * (-1.0 / 15300.0 - jme / 2000000.0))))) % 360.0
    eot = 4.0 * (m - 0.0057183 - alpha + dpsi * np.cos(eps_r))
    eot = np.where(eot < -20.0, eot + 1440.0, eot)
    eot = np.where(eot > 20.0, eot - 1440.0, eot)

    return (jd, jd + dt / 86400.0, l_deg, b_deg, r_au, dpsi, deps, eps, lam, nu % 360.0, alpha, delta, h,
            alpha_p % 360.0, np.degrees(delta_p_r), np.degrees(hp_r) % 360.0, e0, e, 90.0 - e0, 90.0 - e,
            azimuth, eot)


SOLAR_POSITION_COLUMNS = ("apparent_zenith", "zenith", "apparent_elevation", "elevation", "azimuth",
                          "equation_of_time", "declination", "earth_sun_distance")


def solar_position(times, latitude, longitude, altitude=0.0, pressure=101325.0, temperature=12.0,
                   delta_t=None, atmos_refract=0.5667):
    """Solar position for a tz-aware DatetimeIndex by NREL SPA (pvlib's ``spa_python`` columns).

    Parameters
    ----------
    times : pandas.DatetimeIndex
        Instants at which to compute the position, tz-aware (naive times raise ValueError).
        For interval data pass the interval mid-points (see :func:`widesky.irradiance.location.sun_times`).
    latitude, longitude : float
        Observer latitude [deg] (north positive) and longitude [deg] (east positive).
    altitude : float
        Observer altitude above sea level [m].
    pressure : float
        Mean air pressure for refraction [Pa].
    temperature : float
        Mean air temperature for refraction [degC].
    delta_t : float or None
        TT - UT [s]; ``None`` estimates it per time (:func:`delta_t_estimate`).
    atmos_refract : float
        Refraction at sunrise/sunset [deg].

    Returns
    -------
    pandas.DataFrame
        Indexed by ``times``; columns ``apparent_zenith``, ``zenith``, ``apparent_elevation``,
        ``elevation`` [deg] (topocentric; "apparent" includes refraction), ``azimuth`` [deg]
        clockwise from north, ``equation_of_time`` [min], ``declination`` [deg] (geocentric),
        ``earth_sun_distance`` [AU].
    """
    if not isinstance(times, pd.DatetimeIndex):
        raise TypeError(f"times must be a pandas.DatetimeIndex, got {type(times).__name__}")
    if np.ndim(latitude) or np.ndim(longitude):
        raise ValueError("latitude and longitude must be scalars here; use spa() for arrays")
    res = spa(_unixtime(times), latitude, longitude, altitude, pressure, temperature, delta_t,
              atmos_refract)
    return pd.DataFrame({name: getattr(res, name) for name in SOLAR_POSITION_COLUMNS}, index=times)
