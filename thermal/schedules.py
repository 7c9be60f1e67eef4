"""Office use profiles: hourly fractions of the peak internal gains, and the hours the office is occupied.

The profiles are the office schedules of the ASHRAE Standard 90.1-1989 User's Manual, as carried by the U.S.
DOE commercial reference buildings (Deru et al. 2011, *U.S. Department of Energy Commercial Reference Building
Models of the National Building Stock*, NREL/TP-5500-46861; the EnergyPlus objects ``BLDG_OCC_SCH``,
``BLDG_LIGHT_SCH`` and ``BLDG_EQUIP_SCH`` of the small and medium office): one 24-hour profile for weekdays, one
for Saturdays and one for Sundays (and holidays, which are not modelled: every Monday-Friday is a working day).
Hour ``h`` covers ``h:00``-``h+1:00`` local time; a step takes the value of the hour its middle falls in (``label``
says what the step's time stamp marks: its start, as a clear-sky period's steps, or its end, as an EPW/TMY3 file's).

The peak densities (:data:`OFFICE_DENSITIES`) are each stated with their source. With them a 1000 m2 office floor
gives, on a weekday at 10:00, 0.95 x 1000 / 18.58 x 75 W of people, 0.9 x 6.89 W m-2 of lighting and 0.9 x 8.07
W m-2 of equipment: 17.2 W m-2 in all.

Units: fractions [1], densities [W m-2] and [m2 per person], heat per person [W], hours [h].
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["OFFICE_PROFILES", "OFFICE_DENSITIES", "OCCUPIED_THRESHOLD", "OFFICE_HVAC", "OFFICE_THERMOSTAT",
           "profile_fractions", "office_gains", "occupied_hours", "office_setpoints"]


def _steps(*spans):
    """24 hourly values from (until_hour, value) pairs, EnergyPlus ``Until: hh:00, value`` style."""
    out, h0 = [], 0
    for until, value in spans:
        out += [float(value)] * (until - h0)
        h0 = until
    if h0 != 24:
        raise ValueError("profile does not end at 24:00")
    return tuple(out)


OFFICE_PROFILES = {
    # ASHRAE 90.1-1989 User's Manual office schedules (DOE reference small/medium office, Deru et al. 2011)
    "occupancy": {
        "weekday": _steps((6, 0.0), (7, 0.1), (8, 0.2), (12, 0.95), (13, 0.5), (17, 0.95), (18, 0.7), (20, 0.4),
                          (22, 0.1), (24, 0.05)),
        "saturday": _steps((6, 0.0), (8, 0.1), (14, 0.5), (17, 0.1), (24, 0.0)),
        "sunday": _steps((24, 0.0)),
    },
    "lighting": {
        "weekday": _steps((5, 0.05), (7, 0.1), (8, 0.3), (17, 0.9), (18, 0.7), (20, 0.5), (22, 0.3), (23, 0.1),
                          (24, 0.05)),
        "saturday": _steps((6, 0.05), (8, 0.1), (14, 0.5), (17, 0.15), (24, 0.05)),
        "sunday": _steps((24, 0.05)),
    },
    "equipment": {
        "weekday": _steps((8, 0.4), (12, 0.9), (13, 0.8), (17, 0.9), (18, 0.8), (20, 0.6), (22, 0.5), (24, 0.4)),
        "saturday": _steps((6, 0.3), (8, 0.4), (14, 0.5), (17, 0.35), (24, 0.3)),
        "sunday": _steps((24, 0.3)),
    },
}
"""Hourly fractions [1] of the peak per profile and day type (24 values, hour 0 = 00:00-01:00)."""

OFFICE_DENSITIES = {
    "people_m2": 18.58,       # m2 of floor per person: 200 ft2, ASHRAE 90.1-1989 User's Manual office (DOE reference)
    "people_w": 75.0,         # W sensible per person, "moderately active office work": ASHRAE Handbook
                              # Fundamentals 2017 ch. 18 Table 1
    "lighting_w_m2": 6.89,    # 0.64 W ft-2: ASHRAE 90.1-2019 Table 9.5.1, office, building area method
    "equipment_w_m2": 8.07,   # 0.75 W ft-2: office plug loads of the DOE reference medium office (Deru et al. 2011)
}
"""Peak densities of an office's internal gains, each with its source."""

OFFICE_HVAC = {"weekday": _steps((6, 0.0), (22, 1.0), (24, 0.0)), "saturday": _steps((6, 0.0), (18, 1.0), (24, 0.0)),
               "sunday": _steps((24, 0.0))}
"""Hours the office's thermostat holds its occupied set-points (1) rather than its set-back and set-up (0): weekdays
06:00-22:00, Saturdays 06:00-18:00, never on Sundays; the periods of the DOE commercial reference office's
``HTGSETP_SCH`` and ``CLGSETP_SCH`` (Deru et al. 2011, after the ASHRAE 90.1-1989 User's Manual office)."""

OFFICE_THERMOSTAT = {"heating": 21.0, "heating_setback": 15.6, "cooling": 24.0, "cooling_setup": 26.7}
"""The DOE commercial reference office's air set-points [degC] (``HTGSETP_SCH``: 21.0 in the hours of
:data:`OFFICE_HVAC`, 15.6 (60 F) otherwise; ``CLGSETP_SCH``: 24.0, 26.7 (80 F) otherwise; Deru et al. 2011)."""

OCCUPIED_THRESHOLD = 0.5
"""An hour counts as occupied when the occupancy fraction is at least this [1] (weekdays 08:00-18:00, Saturdays
08:00-14:00 with :data:`OFFICE_PROFILES`)."""


_LABEL_SHIFT = {"left": 0.5, "center": 0.0, "right": -0.5}


def _hour_and_day(times, step_hours, label="left"):
    """Local hour (0-23) of each step's middle and its day type index (0 weekday, 1 Saturday, 2 Sunday)."""
    if label not in _LABEL_SHIFT:
        raise ValueError(f"label={label!r} not one of {tuple(_LABEL_SHIFT)}")
    t = pd.DatetimeIndex(times) + pd.Timedelta(hours=_LABEL_SHIFT[label] * float(step_hours))
    dow = np.asarray(t.day_of_week)
    return np.asarray(t.hour), np.where(dow < 5, 0, np.where(dow == 5, 1, 2))


def profile_fractions(times, step_hours=1.0, profiles=None, label="left"):
    """Fractions of the peak per profile at each step.

    Parameters
    ----------
    times : pandas.DatetimeIndex
        (T,) step labels in local time.
    step_hours : float
        [h].
    profiles : dict, optional
        Like :data:`OFFICE_PROFILES` (default).
    label : {"left", "right", "center"}
        What a time stamp marks: the step's start, end or middle.

    Returns
    -------
    dict of str to numpy.ndarray
        (T,) fraction [1] per profile (``occupancy``, ``lighting``, ``equipment``).
    """
    profiles = OFFICE_PROFILES if profiles is None else profiles
    hour, day = _hour_and_day(times, step_hours, label)
    out = {}
    for name, p in profiles.items():
        table = np.array([p["weekday"], p["saturday"], p["sunday"]], float)
        out[name] = table[day, hour]
    return out


def office_gains(times, step_hours=1.0, densities=None, label="left"):
    """Internal sensible gains per m2 of floor [W m-2] at each step, by source and in total.

    Parameters
    ----------
    times : pandas.DatetimeIndex
        (T,) local step labels.
    step_hours : float
        [h].
    densities : dict, optional
        Keys of :data:`OFFICE_DENSITIES` (default those values): ``people_m2`` [m2 per person], ``people_w``
        [W per person], ``lighting_w_m2``, ``equipment_w_m2`` [W m-2].
    label : {"left", "right", "center"}
        See :func:`profile_fractions`.

    Returns
    -------
    dict of str to numpy.ndarray
        (T,) ``people``, ``lighting``, ``equipment``, ``total`` [W m-2].
    """
    d = {**OFFICE_DENSITIES, **(densities or {})}
    for k, v in d.items():
        if not (np.isfinite(v) and v >= 0) or (k == "people_m2" and v <= 0):
            raise ValueError(f"{k}={v!r} must be finite and >= 0 (people_m2 > 0)")
    f = profile_fractions(times, step_hours, label=label)
    out = {"people": f["occupancy"] * d["people_w"] / d["people_m2"],
           "lighting": f["lighting"] * d["lighting_w_m2"], "equipment": f["equipment"] * d["equipment_w_m2"]}
    out["total"] = out["people"] + out["lighting"] + out["equipment"]
    return out


def occupied_hours(times, step_hours=1.0, threshold=OCCUPIED_THRESHOLD, label="left"):
    """(T,) bool: the steps whose occupancy fraction is at least ``threshold`` [1] (``label``: see
    :func:`profile_fractions`)."""
    return profile_fractions(times, step_hours, label=label)["occupancy"] >= threshold


def office_setpoints(times, step_hours=1.0, label="left", heating=None, cooling=None, heating_setback=None,
                     cooling_setup=None):
    """The office thermostat's air set-points at each step: the occupied ``heating`` / ``cooling`` in the hours of
    :data:`OFFICE_HVAC`, the ``heating_setback`` / ``cooling_setup`` otherwise.

    Parameters
    ----------
    times : pandas.DatetimeIndex
        (T,) local step labels.
    step_hours : float
        [h].
    label : {"left", "right", "center"}
        See :func:`profile_fractions`.
    heating, cooling, heating_setback, cooling_setup : float, optional
        [degC]; default the DOE reference office's (:data:`OFFICE_THERMOSTAT`). They must satisfy
        ``heating_setback <= heating <= cooling <= cooling_setup``.

    Returns
    -------
    heating, cooling : numpy.ndarray
        (T,) [degC].
    """
    given = {"heating": heating, "cooling": cooling, "heating_setback": heating_setback,
             "cooling_setup": cooling_setup}
    v = {k: float(OFFICE_THERMOSTAT[k] if x is None else x) for k, x in given.items()}
    bad = [k for k, x in v.items() if not np.isfinite(x)]
    if bad:
        raise ValueError(f"{bad[0]}={v[bad[0]]!r} degC must be finite")
    if not v["heating_setback"] <= v["heating"] <= v["cooling"] <= v["cooling_setup"]:
        raise ValueError(f"set-points must satisfy heating_setback <= heating <= cooling <= cooling_setup, got "
                         f"{v['heating_setback']:g} / {v['heating']:g} / {v['cooling']:g} / "
                         f"{v['cooling_setup']:g} degC")
    on = profile_fractions(times, step_hours, {"hvac": OFFICE_HVAC}, label)["hvac"] > 0.5
    return (np.where(on, v["heating"], v["heating_setback"]), np.where(on, v["cooling"], v["cooling_setup"]))
