"""Worked case: how much the spectral glazing treatment changes gains and loads.

For one weather file, a building (default: a 20 m x 12 m one-storey office box, 40 % glazing on
every facade, four perimeter zones) and a set of glazing units, one integrator run computes the
window gains twice per unit: the spectral route (g by angle and wavelength under widesky's sky
spectrum for every step and direction) and the rated route (the unit's AM1.5-global-weighted g by
angle, applied to broadband light: what a broadband tool with the unit's own angular curve does).
Both routes see identical geometry and broadband irradiance; only the spectrum differs.

Outputs: effective g per facade orientation and month (gain / incident global on the glass) for
both routes against the rated normal-incidence g, and the annual window gains, heating and cooling
loads of the building per unit and route.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from widesky.core.paths import runtime_file
from widesky.irradiance import PragueSky, Simulation, read_weather
from widesky.irradiance.skystate import interval_months

from .building import ZoneSpec, box_building
from .gains import (building_scene, glazing_response, irradiance_by_surface, rated_glazing_response,
                    window_gain_by_surface)
from .glazing import Gap, GlazingUnit, read_igdb, read_solar_spectrum
from .loads import Construction, building_loads
from .surface import sky_temperature
from .thinfilm import solar_control_layer

__all__ = ["standard_units", "glazing_study", "office_box"]


def standard_units(data_dir=None, solar_control=False):
    """The three units of the worked case, from the IGDB samples shipped in the package (``widesky/data/glazing``;
    ``data_dir``: read the files of the same names from that folder instead).

    ``clear``: 3 mm clear / 12 mm air / 3 mm clear (NFRC 102 twice); ``low-e``: 5 mm clear /
    12.7 mm argon / Pilkington Energy Advantage low-e with its coating on surface 3;
    ``low-e #2``: the same coating on surface 2 (the solar-control position, coating facing the gap
    on the outer pane). The samples hold no spectrally selective solar-control coating;
    a user's IGDB file enters the same way. With ``solar_control=True`` a fourth unit,
    ``solar-control``: 6 mm clear with the double-silver stack of :mod:`widesky.thermal.thinfilm` on
    surface 2 / 12.7 mm argon / 6 mm clear (a documented construction, not a product).
    """
    c3 = read_igdb(runtime_file("glazing/CLEAR_3.DAT", data_dir))
    c5 = read_igdb(runtime_file("glazing/CLEAR5.LOF", data_dir))
    le = read_igdb(runtime_file("glazing/LOW-E_5.LOF", data_dir))
    units = {"clear": GlazingUnit("clear", [c3, c3], [Gap(12.0, "air")]),
             "low-e": GlazingUnit("low-e", [c5, le], [Gap(12.7, "argon")]),
             "low-e #2": GlazingUnit("low-e #2", [le.flipped(), c5], [Gap(12.7, "argon")])}
    if solar_control:
        c6 = read_igdb(runtime_file("glazing/CLEAR_6.DAT", data_dir))
        units["solar-control"] = GlazingUnit("solar-control", [solar_control_layer(c6).flipped(), c6],
                                             [Gap(12.7, "argon")])
    return units


def office_box():
    """The worked case's building: 20 m x 12 m x 3.5 m, WWR 0.4 all round, four perimeter zones,
    each 0.7 h-1, 10 W m-2 internal gains, 20 / 26 degC."""
    return box_building(20.0, 12.0, 3.5, wwr=0.4, perimeter_zones=True,
                        zone_use=ZoneSpec("use", air_changes=0.7, internal_gains=600.0,
                                          heating_setpoint=20.0, cooling_setpoint=26.0))


def _constructions(name, unit):
    """Office constructions; the window construction is named like its responses' prefix."""
    return {"wall": Construction("wall", 0.35), "roof": Construction("roof", 0.25),
            "floor": Construction("floor", 0.35, b=0.5),
            "window": Construction(name, glazing=unit)}


def glazing_study(weather_path, units=None, building=None, *, sky=None, n_jobs=1, progress=False,
                  data_dir=None, result_path=None):
    """Spectral against rated glazing gains and the loads they cause, for one weather file.

    Parameters
    ----------
    weather_path : path
        EPW or TMY3 file (:func:`widesky.irradiance.read_weather`).
    units : dict of str to GlazingUnit, optional
        Default :func:`standard_units`.
    building : Building, optional
        Default :func:`office_box`; its windows all use construction ``window``.
    sky : irradiance.PragueSky, optional
    n_jobs : int
        Ray-casting processes.
    progress : bool
    data_dir : path, optional
        A folder to read the AM1.5 spectrum and the default units from instead of the shipped copies.
    result_path : path, optional
        HDF5 file the integrator result streams to.

    Returns
    -------
    dict
        ``effective_g``: DataFrame indexed by (unit, orientation, month) with columns ``spectral``,
        ``rated_route``, ``rated_normal`` [1] (an hour's month: its interval's start's); ``annual``: DataFrame
        indexed by (unit, route) with
        ``window_gain_kWh``, ``heating_kWh``, ``cooling_kWh``, ``peak_cooling_W``;
        ``incident``: (T, W) global on each window [W m-2]; ``times``; ``site``.
    """
    units = units or standard_units(data_dir)
    building = building or office_box()
    w = read_weather(weather_path)
    sky = sky or PragueSky()
    sw, se = read_solar_spectrum(data_dir)
    scene, labels = building_scene(building)
    sim = Simulation(scene, weather=w, sky_source=sky, n_jobs=n_jobs, progress=progress)
    responses = []
    for name, u in units.items():
        responses.append(glazing_response(u, f"{name}:spectral"))
        responses.append(rated_glazing_response(u, sw, se, f"{name}:rated"))
    res = sim.run(responses, output=result_path)
    irr = irradiance_by_surface(res, labels)
    surf = [s for s in building.surfaces if s.kind != "shading"]
    wins = [j for j, s in enumerate(surf) if s.kind == "window"]
    incident = irr["poa_global"][:, wins]
    orient = [_orientation_name(surf[j].azimuth) for j in wins]
    area = np.array([surf[j].area for j in wins])
    month = interval_months(w.data.index, w.label, w.step)    # by the interval's start (EPW: labelled by its end)
    data = w.data
    t_sky = (sky_temperature(np.maximum(data["ghi_infrared"].to_numpy(), 1.0))
             if "ghi_infrared" in data else None)
    rows, annual = [], {}
    for name, u in units.items():
        cons = _constructions(name, u)
        gn = u.rated(sw, se)["shgc"]
        per = {}
        for route in ("spectral", "rated"):
            wg = window_gain_by_surface(res, labels, building, cons, route)   # (T, W)
            per[route] = wg
            lr = building_loads(building, cons, data.index, data["temp_air"].to_numpy(), irr,
                                temp_sky=t_sky, window_gain=wg)
            s = lr.summary().loc["total"]
            annual[(name, route)] = {"window_gain_kWh": float((wg * area).sum() / 1000.0),
                                     "heating_kWh": float(s["heating_kWh"]),
                                     "cooling_kWh": float(s["cooling_kWh"]),
                                     "peak_cooling_W": float(s["peak_cooling_W"])}
        for o in ("north", "east", "south", "west"):
            cols = [k for k, x in enumerate(orient) if x == o]
            for m in range(1, 13):
                sel = month == m
                inc = (incident[sel][:, cols] * area[cols]).sum()
                if inc <= 0:
                    continue
                rows.append({"unit": name, "orientation": o, "month": m,
                             "spectral": (per["spectral"][sel][:, cols] * area[cols]).sum() / inc,
                             "rated_route": (per["rated"][sel][:, cols] * area[cols]).sum() / inc,
                             "rated_normal": gn})
    eff = pd.DataFrame(rows).set_index(["unit", "orientation", "month"])
    ann = pd.DataFrame(annual).T
    ann.index.names = ["unit", "route"]
    return {"effective_g": eff, "annual": ann, "incident": incident, "times": data.index,
            "site": w.site, "weather": str(Path(weather_path).name)}


def _orientation_name(azimuth):
    names = ("north", "east", "south", "west")
    return names[int(((azimuth + 45.0) % 360.0) // 90.0)]
