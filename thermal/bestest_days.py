"""ASHRAE 140's specific days, hour by hour: the free-floating rooms' air temperature against the programs.

Beside the year's extremes and mean, Standard 140 asks for the free-floating cases' hourly zone temperature on one
day: Cases 600FF and 900FF on 1 February (clear and cold), 650FF and 950FF (night ventilation) on 14 July (clear and
hot). They test the zone model's dynamics hour by hour, where an extreme can match for the wrong reason. The six
reference programs' hourly values of the 2020 edition (Denver TMY3; the Standard's results workbook RESULTS5-2A, as
converted in github.com/JasonGlazer/ashrae-140-automation, ``processed/<program>/<version>/results5-2a.json``; BSIMAC,
CSE, DeST, EnergyPlus, ESP-r, TRNSYS) stand below as their lowest and highest per hour, scalar facts.
"""

from __future__ import annotations

import numpy as np

from .bestest import Verdict, run_case_on_route

__all__ = ["FREE_FLOAT_DAY_RANGE", "free_float_days", "day_verdicts"]

FREE_FLOAT_DAY_RANGE = {
    ("600FF", "feb_1"): (
        (4.47, 2.86, 1.41, -0.02, -1.22, -2.29, -3.19, -3.33, -0.2, 6.1, 12.5, 20.2, 28.5, 36.1, 41.9, 45.4, 43.47,
         36.54, 29.67, 24.21, 19.26, 15.03, 11.22, 8.12),
        (13, 10.3, 7.9, 5.7, 3.8, 2.1, 0.7, 0.1, 4.11, 11.97, 20.7, 29.83, 38.21, 44.87, 48.81, 49.81, 47.28, 44,
         39.5, 34.4, 29.3, 24.6, 20.2, 16.3),
    ),
    ("900FF", "feb_1"): (
        (11.7, 11.24, 10.79, 10.3, 9.9, 9.47, 9.1, 8.96, 9.89, 11.76, 13.95, 16.21, 18.34, 19.7, 20.69, 21.04, 20.57,
         19.25, 18.04, 17.22, 16.48, 15.75, 15.11, 14.55),
        (15.4, 14.8, 14.2, 13.6, 13, 12.4, 11.84, 11.94, 13.22, 15.29, 17.55, 19.86, 22, 23.27, 24.8, 25.4, 24.6,
         23.5, 22.6, 21.9, 20.8, 20, 19.2, 18.1),
    ),
    ("650FF", "july_14"): (
        (19.67, 18.77, 17.77, 16.65, 15.47, 16.09, 18.2, 20.14, 22.25, 24.9, 28.3, 32.3, 36.2, 39.7, 42.5, 43.77,
         43.35, 41.7, 33.26, 29.61, 27.41, 25.31, 24.23, 22.45),
        (21.7, 20.1, 19, 17.8, 16.6, 17.12, 19.4, 20.94, 23.3, 26.5, 30.77, 35.22, 39.19, 42.49, 44.77, 45.78, 45.65,
         44.91, 38.29, 31.7, 28.6, 26.5, 25, 23.5),
    ),
    ("950FF", "july_14"): (
        (20.97, 20.49, 19.63, 18.75, 17.79, 18.32, 19.98, 22.07, 23.4, 24.5, 25.8, 27.06, 28.15, 29.01, 29.4, 29.29,
         29.15, 29.05, 28.45, 26.97, 25.77, 25.23, 24.41, 23.25),
        (23.4, 22.2, 21.3, 20.3, 19.3, 19.35, 21.09, 23.15, 24.4, 25.57, 26.91, 28.18, 29.13, 29.86, 30.6, 31, 31.4,
         31, 30.3, 29.1, 28.1, 27, 26, 24.9),
    ),
}
"""The six programs' (lowest, highest) hourly zone air temperature [degC] of each (case, day), for the hours ending
01:00 ... 24:00 local standard time."""

DAYS = {"feb_1": (2, 1), "july_14": (7, 14)}


def free_float_days(route="weather", transposition="perez", data_dir=None, n_jobs=1, progress=False, poas=None,
                    **model):
    """widesky's hourly zone air temperature [degC] (the hour's mean, as the programs report it) on the days of
    :data:`FREE_FLOAT_DAY_RANGE`, by :func:`~widesky.thermal.bestest.run_case` on the ``route`` ("weather" or
    "integrator"). ``poas``: integrator results by room geometry to reuse (filled in); ``model``: run_case's
    ``zone_model`` (default ISO 52016-1), ``exterior``, ``iso52016_options`` and ``diffuse_optics``.

    Returns
    -------
    dict
        (case, day) -> (24,) [degC] for the hours ending 01:00 ... 24:00 local standard time.
    """
    poas = {} if poas is None else poas
    out = {}
    for case, day in FREE_FLOAT_DAY_RANGE:
        t = run_case_on_route(case, route, transposition, data_dir, n_jobs, progress, poas, **model)["hourly"]["temp_air"]
        start = t.index - np.timedelta64(1, "h")
        month, dom = DAYS[day]
        out[(case, day)] = t.to_numpy()[(start.month == month) & (start.day == dom)]
    return out


def day_verdicts(days):
    """Each day of :func:`free_float_days` as one figure: the largest departure [K] of its 24 hours from the programs'
    hourly range (0 when every hour is inside), against 0 to 0.

    Returns
    -------
    list of Verdict
        ``quantity`` "<day>_hourly" (e.g. ``july_14_hourly``), unit K, source ``programs_days``.
    """
    out = []
    for (case, day), v in days.items():
        lo, hi = (np.asarray(x) for x in FREE_FLOAT_DAY_RANGE[(case, day)])
        worst = float(np.max(np.maximum(lo - v, 0.0) + np.maximum(v - hi, 0.0)))
        out.append(Verdict(case, f"{day}_hourly", worst, 0.0, 0.0, "K", "programs_days"))
    return out
