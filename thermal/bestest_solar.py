"""ASHRAE 140's solar outputs: the light on the test room's surfaces and through its windows, against the programs.

Standard 140 asks every program for more than loads: the year's incident solar on each surface of Case 600, the
year's transmitted solar through the windows of Cases 600-670, the hourly incident solar of a clear day (14 July)
and a cloudy one (4 May), and the hourly transmitted solar of those days and of 1 February. They isolate the light
from the zone model, so a load that matches the programs for the wrong reason shows up here. The six reference
programs' figures of the 2020 edition (Denver TMY3), as published in the Standard's results workbook (RESULTS5-2A)
and converted to JSON in github.com/JasonGlazer/ashrae-140-automation
(``processed/<program>/<version>/results5-2a.json``, commits 13c830a2 and 0f1cc76d), stand below as scalar facts:
BSIMAC 9.9.0.7.4, CSE 0.861.1, DeST 2.0.20190401, EnergyPlus 9.0.1, ESP-r 13.3, TRNSYS 18.00.0001, in that order
(``None``: not reported). :func:`solar_outputs` computes widesky's same figures on either sky route and
:func:`solar_verdicts` puts each beside the programs' range.
"""

from __future__ import annotations

import numpy as np

from .bestest import (ANGLES, INTERIOR_SOLAR_ABSORPTANCE, Verdict, case_definition, case_gains, case_geometry,
                      integrator_irradiance, load_weather, solar_escape_fraction)
from .optics import hemispherical

__all__ = ["PROGRAMS", "ANNUAL_INCIDENT", "ANNUAL_TRANSMITTED", "DAY_INCIDENT", "DAY_TRANSMITTED", "DAY_HOURLY_RANGE",
           "SOLAR_SOURCE", "solar_outputs", "solar_verdicts"]

PROGRAMS = ("BSIMAC", "CSE", "DeST", "EnergyPlus", "ESP-r", "TRNSYS")
"""The six reference programs of ASHRAE 140-2020, in the order of every tuple below."""

SURFACES = ("north", "east", "south", "west", "horizontal")
"""Case 600's surfaces, in the order of ``case_gains``' (T, 5) columns."""

ANNUAL_INCIDENT = {
    "north": (453.0, 399.05, 477.31, 438.24, 432.12, 440.17),
    "east": (1061.0, 1026.99, 1016.68, 1062.16, 1054.24, 1067.94),
    "south": (1387.0, 1316.92, 1290.59, 1370.48, 1363.1, 1384.23),
    "west": (997.0, 903.07, 905.72, 967.28, 961.18, 974.47),
    "horizontal": (1670.0, 1662.53, 1667.16, 1664.34, 1665.18, 1668.98),
}
"""Case 600's annual incident solar [kWh m-2] per surface, per program."""

ANNUAL_TRANSMITTED = {
    ("600", "south"): (820.0, 825.52, 805.05, 804.02, 813.88, 822.59),
    ("610", "south"): (641.0, 665.26, 663.35, 646.13, 631.33, 661.81),
    ("620", "west"): (598.0, None, 569.39, 581.04, 591.88, 623.8),
    ("630", "west"): (438.0, None, 399.17, 419.35, 389.67, 445.55),
    ("660", "south"): (447.0, 501.31, 506.46, 436.0, 442.7, 448.49),
    ("670", "south"): (1037.0, 987.82, 994.32, 1024.2, 1028.35, 1039.23),
}
"""Annual solar transmitted through the windows of one wall [kWh m-2 of glass], per (case, wall) and program."""

DAY_INCIDENT = {
    ("july_14", "south"): (2973.7, 2739.4, 2941.7, 2974.0, 2970.5, 3046.6),
    ("july_14", "west"): (5077.1, 4895.5, 4870.3, 5126.2, 5104.0, 5177.3),
    ("july_14", "horizontal"): (8719.0, 8655.5, 8708.1, 8709.8, 8702.3, 8728.8),
    ("may_4", "south"): (1305.2, 1315.3, 1315.2, 1163.4, 1161.6, 1167.1),
    ("may_4", "west"): (1295.9, 1315.3, 1315.2, 1151.6, 1151.3, 1154.7),
    ("may_4", "horizontal"): (2192.0, 2192.1, 2192.0, 2186.4, 2187.1, 2192.0),
}
"""Case 600's incident solar over the clear day (14 July) and the cloudy day (4 May) [Wh m-2]: each program's
hourly values summed."""

DAY_HOURLY_RANGE = {    # hours ending 05:00 ... 20:00 local standard time; 0 in every program at the others
    ("july_14", "south"): ((0.0, 15.3, 34.4, 55.6, 139.5, 272.6, 372.0, 427.8, 433.5, 389.7, 300.4, 174.1, 64.3,
                            39.0, 18.8, 0.0),
                           (2.8, 27.1, 55.4, 82.4, 179.1, 305.8, 398.8, 449.8, 452.8, 408.9, 320.8, 197.6, 85.4,
                            57.7, 30.2, 3.3)),
    ("july_14", "west"): ((0.0, 15.3, 34.4, 55.5, 75.5, 91.9, 103.7, 110.3, 207.7, 443.4, 644.6, 771.3, 818.3,
                           758.2, 525.6, 0.0),
                          (2.8, 27.1, 55.4, 82.0, 104.1, 119.5, 133.6, 141.3, 258.9, 491.6, 683.9, 812.0, 861.6,
                           806.9, 590.3, 94.5)),
    ("july_14", "horizontal"): ((0.0, 82.0, 264.2, 465.8, 656.6, 816.1, 931.7, 996.1, 1002.0, 946.1, 835.5, 679.3,
                                 490.0, 285.8, 99.1, 0.0),
                                (5.7, 103.2, 289.9, 493.4, 682.3, 837.8, 948.0, 1005.2, 1008.0, 955.0, 848.3,
                                 697.3, 511.8, 309.3, 116.2, 7.5)),
    ("may_4", "south"): ((0.0, 7.7, 31.3, 57.2, 82.1, 103.7, 137.7, 149.3, 147.9, 136.7, 117.6, 90.0, 53.3, 26.2,
                          5.4, 0.0),
                         (0.0, 11.0, 36.4, 66.6, 94.8, 117.0, 157.8, 166.8, 166.2, 155.4, 136.2, 108.6, 62.4, 32.2,
                          7.3, 0.0)),
    ("may_4", "west"): ((0.0, 7.7, 31.3, 56.9, 80.1, 100.6, 128.1, 137.4, 141.1, 137.7, 123.3, 96.9, 54.9, 26.2,
                         5.4, 0.0),
                        (0.0, 11.0, 36.4, 66.6, 94.8, 117.0, 157.8, 166.8, 166.2, 155.4, 140.0, 114.4, 63.5, 32.2,
                         7.3, 0.0)),
    ("may_4", "horizontal"): ((0.0, 15.0, 60.0, 110.5, 156.8, 195.0, 256.4, 276.0, 274.1, 255.2, 222.0, 172.0,
                               101.9, 50.2, 10.5, 0.0),
                              (0.0, 21.2, 64.8, 114.6, 160.2, 203.2, 263.0, 278.0, 277.0, 259.0, 227.0, 181.0,
                               107.2, 54.1, 14.2, 0.0)),
}
"""The six programs' (lowest, highest) hourly incident solar [Wh m-2] for the hours ending 05:00 to 20:00 local
standard time of each day and surface (for the figure and the hour-by-hour comparison; the verdicts use the day's
sums)."""

DAY_TRANSMITTED = {
    ("600", "feb_1"): (4591.5, 4485.5, 4613.3, 4490.1, 4488.6, 4597.3),
    ("600", "may_4"): (784.4, 831.0, 802.3, 693.9, 731.3, 709.8),
    ("600", "july_14"): (1318.9, 1266.9, 1332.3, 1310.8, 1356.2, 1368.1),
    ("660", "feb_1"): (2521.4, 2705.3, 2780.6, 2442.8, 2459.3, 2521.0),
    ("660", "may_4"): (429.4, 507.2, 517.5, 377.5, 398.3, 388.8),
    ("660", "july_14"): (708.0, 785.3, 939.0, 704.9, 726.4, 733.2),
    ("670", "feb_1"): (5619.5, 5254.9, 5471.4, 5528.1, 5506.7, 5624.6),
    ("670", "may_4"): (982.8, 1004.0, 1013.4, 876.1, 911.8, 888.6),
    ("670", "july_14"): (1831.4, 1667.0, 1845.5, 1839.7, 1859.1, 1900.4),
}
"""Solar transmitted through the south windows of Cases 600, 660 and 670 over 1 February (clear, winter), 4 May and
14 July [Wh m-2 of glass]: each program's hourly values summed."""

HOURS = tuple(range(5, 21))
"""The hours (ending) of :data:`DAY_HOURLY_RANGE`."""

DAYS = {"feb_1": (2, 1), "may_4": (5, 4), "july_14": (7, 14)}

SOLAR_SOURCE = ("solar outputs of the reference programs (ASHRAE 140-2020 results workbook RESULTS5-2A; "
                "thermal/bestest_solar.py)")


def _transmittance_table(case):
    """(angles [deg], tau [1], tau_d, tau_d) of the case's window, for :func:`case_gains`' ``g_table`` (its
    transmittance in place of its g: the light through the glass, as Standard 140 reports it)."""
    tau = case.window.optics(ANGLES, np.array([280.0, 2500.0]))["transmittance"][:, 0]   # broadband records: flat
    tau_d = float(hemispherical(ANGLES, tau))
    return ANGLES, tau, tau_d, tau_d


def solar_outputs(route="weather", transposition="perez", data_dir=None, n_jobs=1, progress=False,
                  diffuse_optics="angular"):
    """widesky's counterparts of :data:`ANNUAL_INCIDENT`, :data:`ANNUAL_TRANSMITTED` and :data:`DAY_INCIDENT`.

    Parameters
    ----------
    route : {"weather", "integrator"}
        ``"weather"``: the TMY3 file's DNI and DHI transposed (``transposition``), the windows' shading devices
        by ray casting (:func:`~widesky.thermal.bestest.case_gains`); ``"integrator"``: widesky's all-sky sky and
        integrator on the room with its devices (one run per room geometry, the windows' transmittance by angle
        applied per incoming direction).
    transposition : {"perez", "hay-davies"}
        Of the weather route.
    data_dir : str, optional
    n_jobs : int
        Ray-casting processes of the integrator route.
    diffuse_optics : str
        How the windows take the diffuse light (:func:`~widesky.thermal.bestest.case_gains`; the incident figures
        do not depend on it).

    Returns
    -------
    dict
        ``incident``: surface -> Case 600's annual incident solar [kWh m-2]; ``transmitted``: (case, wall) ->
        annual transmitted solar [kWh m-2 of glass]; ``day``: (day, surface) -> the day's incident solar
        [Wh m-2]; ``day_transmitted``: (case, day) -> the day's transmitted solar [Wh m-2 of glass];
        ``hourly``: (day, surface) -> (24,) incident solar of the hours ending 01:00 ... 24:00 local standard
        time [Wh m-2].
    """
    if route not in ("weather", "integrator"):
        raise ValueError(f"route={route!r} not one of ('weather', 'integrator')")
    weather, site = load_weather("tmy3", data_dir)
    start = weather.index - np.timedelta64(1, "h")           # each hour's start, local standard time
    poas, out = {}, {"incident": {}, "transmitted": {}, "day": {}, "hourly": {}, "day_transmitted": {}}
    for case, wall in ANNUAL_TRANSMITTED:
        c = case_definition(case, data_dir)
        poa = None
        if route == "integrator":
            geo = case_geometry(c)
            if geo not in poas:
                poas[geo] = integrator_irradiance("tmy3", data_dir, n_jobs=n_jobs, progress=progress, geometry=geo,
                                                  quantity="transmittance")
            poa = poas[geo]
        table = _transmittance_table(c)
        g = case_gains(c, weather, site, g_table=table, poa=poa, transposition=transposition,
                       diffuse_optics=diffuse_optics)
        esc = solar_escape_fraction(table[3], c.window_area, c.interior_area, INTERIOR_SOLAR_ABSORPTANCE)
        k = SURFACES.index(wall)
        area = next(w[2] for w in c.walls if round(w[0]) % 360 == (0, 90, 180, 270)[k])
        through = g["window_walls"][:, k] / (1.0 - esc) / area                       # (T,) [W m-2 of glass]
        out["transmitted"][(case, wall)] = float(through.sum() / 1000.0)
        for day, (month, dom) in DAYS.items():
            if (case, day) in DAY_TRANSMITTED:
                out["day_transmitted"][(case, day)] = float(through[(start.month == month) & (start.day == dom)].sum())
        if case == "600":
            for j, s in enumerate(SURFACES):
                out["incident"][s] = float(g["poa_global"][:, j].sum() / 1000.0)
            for day, (month, dom) in DAYS.items():
                sel = np.flatnonzero((start.month == month) & (start.day == dom))
                for s in ("south", "west", "horizontal"):
                    if (day, s) not in DAY_INCIDENT:
                        continue
                    hourly = g["poa_global"][sel, SURFACES.index(s)]
                    out["hourly"][(day, s)] = hourly
                    out["day"][(day, s)] = float(hourly.sum())
    return out


def _range(values):
    v = [x for x in values if x is not None]
    return min(v), max(v)


def solar_verdicts(outputs):
    """Each figure of :func:`solar_outputs` beside the reference programs' range (a value on a limit is inside).

    Returns
    -------
    list of Verdict
        ``case`` "600" (incident, days) or the window's case, ``quantity`` e.g. ``incident_north``,
        ``transmitted_south``, ``july_14_south``, ``feb_1_transmitted``; units kWh m-2 (annual) and Wh m-2
        (days).
    """
    out = []
    for s, v in outputs["incident"].items():
        out.append(Verdict("600", f"incident_{s}", v, *_range(ANNUAL_INCIDENT[s]), "kWh m-2", "programs_solar"))
    for (case, wall), v in outputs["transmitted"].items():
        out.append(Verdict(case, f"transmitted_{wall}", v, *_range(ANNUAL_TRANSMITTED[(case, wall)]), "kWh m-2",
                           "programs_solar"))
    for (day, s), v in outputs["day"].items():
        out.append(Verdict("600", f"{day}_{s}", v, *_range(DAY_INCIDENT[(day, s)]), "Wh m-2", "programs_solar"))
    for (case, day), v in outputs["day_transmitted"].items():
        out.append(Verdict(case, f"{day}_transmitted", v, *_range(DAY_TRANSMITTED[(case, day)]), "Wh m-2",
                           "programs_solar"))
    return out
