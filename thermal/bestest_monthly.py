"""ASHRAE 140's monthly loads: Cases 600 and 900 month by month against the programs.

Standard 140 asks for the monthly heating and cooling energy and the monthly peak loads of Cases 600 (light) and 900
(heavy). Where an annual figure can match the programs through a winter too warm and a summer too cool, the months
show it. The six reference programs' monthly figures of the 2020 edition (Denver TMY3; the Standard's results workbook
RESULTS5-2A, as converted in github.com/JasonGlazer/ashrae-140-automation, ``processed/<program>/<version>/
results5-2a.json``; BSIMAC, CSE, DeST, EnergyPlus, ESP-r, TRNSYS) stand below as their lowest and highest per month,
scalar facts (DeST reports no 900 heating peak from June to September; the other five give the range there).
"""

from __future__ import annotations

import numpy as np

from .bestest import Verdict, run_case_on_route

__all__ = ["MONTHLY_RANGE", "monthly_loads", "monthly_verdicts"]

MONTHLY_RANGE = {
    ("600", "heating"): (
        (655.59, 626.26, 433.5, 447.96, 112.8, 2.7, 4.8, 1.4, 51.8, 317, 575.55, 681.99),
        (734.94, 702.08, 495, 517.29, 150.73, 15.95, 16.73, 9.6, 84.82, 367.05, 645.81, 763.55),
    ),
    ("600", "cooling"): (
        (417.93, 315.42, 410.74, 218.7, 321.16, 497.45, 505.87, 606.5, 672.08, 611.13, 377.15, 386.21),
        (554.02, 398, 489, 263, 364, 578.3, 568.4, 674, 743, 681, 454.74, 503.27),
    ),
    ("600", "peak_heating"): (
        (2.978, 2.9, 2.034, 2.207, 1.569, 0.732, 0.512, 0.479, 1.114, 1.619, 2.85, 2.941),
        (3.359, 3.225, 2.287, 2.457, 1.778, 0.853, 0.619, 0.591, 1.229, 1.813, 3.255, 3.278),
    ),
    ("600", "peak_cooling"): (
        (5.422, 4.444, 4.252, 3.473, 2.774, 3.067, 3.155, 4.038, 4.911, 5.278, 5.229, 5.294),
        (6.481, 5.537, 5.148, 4.04, 3.1, 3.449, 3.64, 4.7, 5.715, 6.27, 6.194, 6.45),
    ),
    ("900", "heating"): (
        (206.1, 243.23, 102.44, 214.17, 20.1, 0, 0, 0, 0, 63.59, 251.6, 254.73),
        (291.94, 322.14, 143.84, 275.7, 37.5, 0, 0, 0, 2.1, 85.01, 318.24, 339.36),
    ),
    ("900", "cooling"): (
        (33.49, 4.72, 40.9, 12.31, 98.35, 365.82, 365.51, 485.68, 458.86, 260.85, 56.21, 38.05),
        (73.3, 24, 86.4, 29.3, 131.1, 447.5, 440.9, 532.6, 517.9, 305.57, 80.49, 73.74),
    ),
    ("900", "peak_heating"): (
        (1.903, 2.443, 1.613, 1.725, 1.124, 0, 0, 0, 0, 1.158, 2.086, 1.927),
        (2.379, 2.778, 1.858, 2.036, 1.324, 0, 0, 0, 0.194, 1.331, 2.463, 2.18),
    ),
    ("900", "peak_cooling"): (
        (1.637, 0.588, 1.143, 0.631, 1.427, 1.873, 1.83, 2.212, 2.556, 2.549, 1.683, 1.595),
        (2.242, 1.096, 1.508, 1.093, 1.555, 2.101, 2.14, 2.632, 3.137, 3.376, 2.233, 2.105),
    ),
}
"""The six programs' (lowest, highest) monthly figure of each (case, quantity), January to December: ``heating`` and
``cooling`` [kWh], ``peak_heating`` and ``peak_cooling`` [kW] (the month's largest hourly-integrated load)."""

QUANTITIES = {"heating": ("heating", "sum"), "cooling": ("cooling", "sum"), "peak_heating": ("heating", "max"),
              "peak_cooling": ("cooling", "max")}


def monthly_loads(route="weather", transposition="perez", data_dir=None, n_jobs=1, progress=False, poas=None,
                  **model):
    """widesky's monthly figures of :data:`MONTHLY_RANGE` by :func:`~widesky.thermal.bestest.run_case` on the
    ``route`` ("weather" or "integrator"); ``poas``: integrator results by room geometry to reuse (filled in);
    ``model``: run_case's ``zone_model`` (default ISO 52016-1), ``exterior``, ``iso52016_options`` and
    ``diffuse_optics``.

    Returns
    -------
    dict
        (case, quantity) -> (12,) January to December: energy [kWh], peaks [kW].
    """
    poas = {} if poas is None else poas
    out = {}
    for case in dict.fromkeys(c for c, _ in MONTHLY_RANGE):
        hourly = run_case_on_route(case, route, transposition, data_dir, n_jobs, progress, poas, **model)["hourly"]
        month = (hourly.index - np.timedelta64(1, "h")).month          # each hour's start, local standard time
        for q, (column, how) in QUANTITIES.items():
            g = hourly[column].abs().groupby(month)
            out[(case, q)] = (g.sum() if how == "sum" else g.max()).to_numpy() / 1000.0
    return out


def monthly_verdicts(monthly):
    """Each (case, quantity) of :func:`monthly_loads` as one figure: its largest departure from the programs' monthly
    range over the twelve months [%] of the range's nearer limit (0 when every month is inside), against 0 to 0.

    Returns
    -------
    list of Verdict
        ``quantity`` "monthly_<quantity>" (e.g. ``monthly_cooling``), unit %, source ``programs_monthly``.
    """
    out = []
    for (case, q), v in monthly.items():
        lo, hi = (np.asarray(x, float) for x in MONTHLY_RANGE[(case, q)])
        over = np.where(v > hi, (v - hi) / np.maximum(hi, 1e-9), 0.0)
        under = np.where(v < lo, (lo - v) / np.maximum(lo, 1e-9), 0.0)
        out.append(Verdict(case, f"monthly_{q}", float(100.0 * np.max(over + under)), 0.0, 0.0, "%",
                           "programs_monthly"))
    return out


def months_outside(monthly):
    """(case, quantity, month 1-12, value, low, high) of every month outside the programs' range."""
    found = []
    for (case, q), v in monthly.items():
        lo, hi = MONTHLY_RANGE[(case, q)]
        found += [(case, q, m + 1, float(v[m]), lo[m], hi[m]) for m in range(12) if not lo[m] <= v[m] <= hi[m]]
    return found
