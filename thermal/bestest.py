"""ASHRAE Standard 140 (BESTEST) Cases 600, 660, 670 and 900 with the 5R1C zone model.

Everything case-specific is read at run time from the public files in the data directory
(``WIDESKY_DATA_DIR`` or ``../shared/data``, see docs/thermal.md): the weather year (Denver
TMY3, the 140-2020 cases'; ``weather/DRYCOLD.mos`` of the earlier editions on request), the 5R1C
parameters of the Modelica Buildings library's ISO 13790 BESTEST models (areas, air change rate,
internal gains, set-points, heat capacity and mass-area factor: ``bestest/iso13790_*.mo``), the
wall, roof and floor layers of its detailed models (U-values), the glazing records of the detailed
models (solar transmittance and reflectance per pane, thickness, emissivities, gas:
``bestest/detailed_Data_*``),
the solar absorptance and emissivity of the outside surfaces (``detailed_Data_ExteriorWallCase900``)
and the reference programs' results with the 140-2020/2023 acceptance limits (the User's Guide
tables, ``bestest/detailed_UsersGuide.mo``). Nothing from those files is stored here.

Scalar case facts that are in none of those files stand below with their source:
ground reflectance 0.2 and the internal gains' 60 % radiative share (ANSI/ASHRAE 140-2020
section 7.2.1 (Case 600): "ground reflectance 0.2"; internal gains "200 W, 60 % radiative,
40 % convective, 100 % sensible"), the interior solar absorptance 0.6 (same section, interior
surface finish).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from widesky.core.paths import data_file
from widesky.irradiance import (SKY_DEFAULTS, PragueSky, Simulation, dni_extra, fixed_offset_tz, read_epw,
                                solar_position, sun_times)

from .building import box_building
from .exterior import exterior_coefficients, hourly_u_value, wind_at_height
from .gains import building_scene, group_weights, irradiance_by_surface, rated_glazing_response
from .glazing import Gap, GlazingUnit, layer_from_broadband
from .loads import R_SE, glazing_g_table, opaque_gains, sky_losses, window_gains
from .surface import sky_temperature, surface_irradiance
from .zone import ZoneParameters, simulate_5r1c

__all__ = ["CASES", "GROUND_REFLECTANCE", "WEATHER_FILES", "read_mos", "read_modelica_record",
           "case_definition", "window_unit", "reference_results", "run_case", "BestestCase",
           "load_weather", "case_gains", "integrator_irradiance", "solar_escape_fraction",
           "layer_resistance", "EXTERIOR_MODELS"]

CASES = ("600", "660", "670", "900")
GROUND_REFLECTANCE = 0.2          # ASHRAE 140-2020 7.2.1
INTERNAL_RADIATIVE_FRACTION = 0.6  # ASHRAE 140-2020 7.2.1: 200 W, 60 % radiative
INTERIOR_SOLAR_ABSORPTANCE = 0.6   # ASHRAE 140-2020 7.2.1: interior surfaces
RHO_C_AIR = 1200.0                 # ISO 13790 9.3.1: rho_a c_a [J m-3 K-1]
PROGRAMS = ("BSIMAC", "CSE", "DeST", "EnergyPlus", "ESP-r", "TRNSYS")
R_SI = {"wall": 0.13, "roof": 0.10, "floor": 0.17}   # ISO 6946:2017 Table 7 [m2 K W-1]
EXTERIOR_MODELS = ("hourly", "constant")


def _data_file(relative, data_dir):
    return data_file(relative, data_dir)


# --------------------------------------------------------------------------- files

def read_mos(path):
    """Read a Modelica Buildings weather table (``.mos``: EPW header lines with ``#`` and 30
    tab-separated columns, C1 seconds since 1 January 00:00 standard time).

    Returns
    -------
    data : pandas.DataFrame
        Indexed by tz-aware times labelling the end of each hour (year 2001, a non-leap year);
        columns ``temp_air`` [degC], ``temp_dew`` [degC], ``relative_humidity`` [%], ``pressure``
        [Pa], ``ghi_infrared`` [W m-2] (horizontal long-wave), ``ghi``, ``dni``, ``dhi`` [W m-2],
        ``wind_speed`` [m s-1].
    site : dict
        ``latitude``, ``longitude`` [deg], ``tz`` [h], ``altitude`` [m], ``name``.
    """
    path = Path(path)
    loc = None
    rows = []
    for i, line in enumerate(path.read_text(encoding="latin-1").splitlines(), 1):
        if line.startswith("#LOCATION"):
            f = line.split(",")
            try:
                loc = {"name": f[1], "latitude": float(f[6]), "longitude": float(f[7]),
                       "tz": float(f[8]), "altitude": float(f[9])}
            except (IndexError, ValueError):
                raise ValueError(f"{path}:{i}: malformed #LOCATION line") from None
        elif line and line[0].isdigit():
            parts = line.split("\t")
            if len(parts) < 17:
                raise ValueError(f"{path}:{i}: expected 30 tab-separated columns, got {len(parts)}")
            try:
                rows.append([float(parts[j]) for j in (0, 1, 2, 3, 4, 7, 8, 9, 10, 16)])
            except ValueError:
                raise ValueError(f"{path}:{i}: non-numeric field") from None
    if loc is None or not rows:
        raise ValueError(f"{path}: no #LOCATION header or no data rows")
    a = np.array(rows)
    start = pd.Timestamp("2001-01-01", tz=fixed_offset_tz(loc["tz"]))
    idx = start + pd.to_timedelta(a[:, 0], unit="s")
    cols = ["temp_air", "temp_dew", "relative_humidity", "pressure", "ghi_infrared", "ghi", "dni",
            "dhi", "wind_speed"]
    return pd.DataFrame(a[:, 1:], index=pd.DatetimeIndex(idx), columns=cols), loc


def read_modelica_record(path, name=None):
    """Scalar and list parameters ``key=value`` / ``key={v1, v2}`` of a Modelica file.

    Parameters
    ----------
    path : path
    name : str, optional
        Only inside the first ``name(...)`` block (e.g. ``"zonHVAC"``).

    Returns
    -------
    dict of str to float or list of float
    """
    text = Path(path).read_text(encoding="latin-1")
    text = re.sub(r'"[^"]*"', '""', text)                    # drop descriptions
    if name is not None:
        m = re.search(r"\b" + re.escape(name) + r"\s*\(", text)
        if not m:
            raise ValueError(f"{path}: no block {name!r}")
        depth, i = 1, m.end()
        while depth and i < len(text):
            depth += {"(": 1, ")": -1}.get(text[i], 0)
            i += 1
        text = text[m.end():i - 1]
    out = {}
    num = r"[-+]?\d*\.?\d+(?:[eE][-+]?\d+)?"
    for key, lst, val in re.findall(r"\b(\w+)\s*=\s*(?:\{([^{}]*)\}|(" + num + r")(?![\w.]))", text):
        if lst:
            try:
                out.setdefault(key, [float(v) for v in lst.split(",")])
            except ValueError:
                continue
        else:
            out.setdefault(key, float(val))
    return out


def layer_resistance(path, block=None):
    """Sum of ``x / k`` [m2 K W-1] over the layers (``Solids.Generic(x=..., k=...)``) of a Modelica
    construction record, in the whole file or in the first ``block(...)`` (e.g. ``"matExtWal"``)."""
    text = Path(path).read_text(encoding="latin-1")
    if block is not None:
        m = re.search(r"\b" + re.escape(block) + r"\s*\(", text)
        if not m:
            raise ValueError(f"{path}: no construction {block!r}")
        text = text[m.end():]
        text = text[:text.find("roughness_a")] if "roughness_a" in text else text
    num = r"([-+]?\d*\.?\d+(?:[eE][-+]?\d+)?)"
    layers = re.findall(r"Generic\(\s*x\s*=\s*" + num + r"\s*,\s*k\s*=\s*" + num, text)
    if not layers:
        raise ValueError(f"{path}: no layers (x=..., k=...) in {block or 'the file'}")
    return float(sum(float(x) / float(k) for x, k in layers))


def _u_values(case, data_dir):
    """Nominal U-values [W m-2 K-1] of wall, roof and floor from the detailed models' layers,
    ISO 6946 inside resistances and R_se = 0.04."""
    ff = _data_file("bestest/detailed_Cases6xx_Case600FF.mo", data_dir)
    if case == "900":
        r_wall = layer_resistance(_data_file("bestest/detailed_Data_ExteriorWallCase900.mo", data_dir))
        r_floor = layer_resistance(_data_file("bestest/detailed_Data_FloorCase900.mo", data_dir))
    else:
        r_wall, r_floor = layer_resistance(ff, "matExtWal"), layer_resistance(ff, "matFlo")
    r_roof = layer_resistance(ff, "roof")
    return tuple(1.0 / (R_SI[k] + r + R_SE) for k, r in
                 (("wall", r_wall), ("roof", r_roof), ("floor", r_floor)))


def _glass(data_dir, record, substrate=None):
    p = read_modelica_record(_data_file(f"bestest/detailed_Data_{record}.mo", data_dir))
    return layer_from_broadband(record, p["tauSol"][0], p["rhoSol_a"][0], p["rhoSol_b"][0],
                                p["x"] * 1000, p["absIR_a"], p["absIR_b"], p["k"], substrate)


def window_unit(case, data_dir=None) -> GlazingUnit:
    """The case's window as a :class:`~thermal.glazing.GlazingUnit` from the detailed records
    (600, 900: 2 x Glass600, 12 mm air; 660: Glass660 low-e outside, 12 mm argon, Glass600;
    670: single Glass600). The low-e layer, a coating on clear glass whose record is broadband,
    takes the angular shape of the clear Glass600 slab (scaled-substrate rule)."""
    g600 = _glass(data_dir, "Glass600")
    if case in ("600", "900"):
        return GlazingUnit("Win600", [g600, g600], [Gap(12.0, "air")])
    if case == "660":
        return GlazingUnit("Win660", [_glass(data_dir, "Glass660", g600), g600],
                           [Gap(12.0, "argon")])
    if case == "670":
        return GlazingUnit("Win670", [g600])
    raise ValueError(f"case={case!r} not one of {CASES}")


@dataclass(frozen=True)
class BestestCase:
    """One case's inputs (see :func:`case_definition`)."""

    name: str
    zone: ZoneParameters
    window: GlazingUnit
    window_area: float
    walls: tuple          # ((azimuth [deg], opaque area [m2], window area [m2]), ...)
    roof_area: float
    u_wall: float
    u_roof: float
    u_window: float
    absorptance: float
    emissivity: float
    internal_gains: float
    heating_setpoint: float
    cooling_setpoint: float
    interior_area: float
    u_floor: float = None
    height: float = 2.7


def case_definition(case, data_dir=None) -> BestestCase:
    """Inputs of ASHRAE 140 Case ``case`` ("600", "660", "670", "900") from the data files.

    Geometry, air change rate, internal gains and set-points are the Modelica ISO 13790 Case 600
    model's; the heat capacity and mass-area factor its Case600Mass (lightweight cases) or
    Case900Mass. The U-values of walls, roof and floor come from the layers of the detailed models
    (``detailed_Cases6xx_Case600FF.mo``, ``detailed_Data_ExteriorWallCase900.mo``,
    ``detailed_Data_FloorCase900.mo``) with ISO 6946 surface resistances (wall 0.510, roof 0.319,
    floor 0.039 W m-2 K-1 for Case 600), not the ISO model's rounded UWal 0.53 and URoo 0.33; the
    window U-value and g-values from our layer model of the case's glazing records (EN 673 /
    EN 410), not from the ISO model's fixed UWin and gFac. The 5R1C internal area A_t is the
    room's own (171.6 m2: floor, ceiling, walls and window), the definition of ISO 13790 7.2.2.2,
    rather than its default 4.5 A_f = 216 m2 that the low BESTEST room does not reach.
    """
    if case not in CASES:
        raise ValueError(f"case={case!r} not one of {CASES}")
    base = read_modelica_record(_data_file("bestest/iso13790_Cases6xx_Case600.mo", data_dir),
                                "zonHVAC")
    mass = read_modelica_record(_data_file(
        f"bestest/iso13790_Data_Case{'900' if case == '900' else '600'}Mass.mo", data_dir))
    wall = read_modelica_record(_data_file("bestest/detailed_Data_ExteriorWallCase900.mo", data_dir))
    unit = window_unit(case, data_dir)
    u_win = unit.u_value()
    azi = [(180.0 + np.degrees(a)) % 360.0 for a in base["surAzi"]]   # Modelica: 0 = south
    walls = tuple((az, aw, awin) for az, aw, awin in zip(azi, base["AWal"], base["AWin"]))
    a_win = float(np.sum(base["AWin"]))
    a_f = base["AFlo"]
    u_wall, u_roof, u_floor = _u_values(case, data_dir)
    h_op = (u_wall * np.sum(base["AWal"]) + u_roof * base["ARoo"] + base["b"] * u_floor * a_f)
    height = base["VRoo"] / a_f
    perim = sum(aw + awin for _, aw, awin in walls) / height
    interior = 2 * a_f + perim * height
    zone = ZoneParameters(floor_area=a_f, h_tr_w=u_win * a_win, h_tr_op=h_op,
                          h_ve=RHO_C_AIR * base["airRat"] * base["VRoo"] / 3600.0,
                          heat_capacity=mass["heaC"] * a_f, mass_area=mass["facMas"] * a_f,
                          total_area=interior)
    text = _data_file("bestest/iso13790_Cases6xx_Case600.mo", data_dir).read_text()
    cool = re.search(r"TSetCoo\(table=\[0\.0,\s*273\.15 \+ (\d+\.?\d*)\]", text)
    heat = re.search(r"TSetHea\(table=\[0\.0,\s*273\.15 \+ (\d+\.?\d*)\]", text)
    gains = re.search(r"intGai\(k=(\d+\.?\d*)\)", text)
    if not (cool and heat and gains):
        raise ValueError("iso13790_Cases6xx_Case600.mo: set-point tables or intGai not found")
    return BestestCase(case, zone, unit, a_win, walls, base["ARoo"], u_wall, u_roof,
                       u_win, wall["absSol_a"], wall["absIR_a"], float(gains.group(1)),
                       float(heat.group(1)), float(cool.group(1)), interior, u_floor, height)


# --------------------------------------------------------------------------- references

def reference_results(data_dir=None):
    """Reference programs' results and acceptance limits from the detailed models' User's Guide.

    Returns
    -------
    dict
        ``case -> {"annual_heating" | "annual_cooling": {"limits": (lo, hi) [kWh],
        "programs": {name: kWh}}, "peak_heating" | "peak_cooling": {"programs": {name: W}}}``.
        The six programs of Standard 140's results (BSIMAC, CSE, DeST, EnergyPlus, ESP-r, TRNSYS).
    """
    text = _data_file("bestest/detailed_UsersGuide.mo", data_dir).read_text(encoding="latin-1")
    out = {}
    titles = {"Annual heating load (MWh)": "annual_heating", "Annual cooling load (MWh)":
              "annual_cooling", "Peak heating load (kW)": "peak_heating",
              "Peak cooling load (kW)": "peak_cooling"}
    parts = re.split(r"<b>([^<]+)</b>", text)
    for title, body in zip(parts[1::2], parts[2::2]):
        key = titles.get(title.strip())
        if key is None:
            continue
        body = body.split("</table>")[0]
        for row in re.findall(r"<tr>\s*<td>(Case\d+)</td>(.*?)</tr>", body, re.S):
            cells = re.findall(r"<td[^>]*>([^<]*)</td>", row[1])
            name = row[0][4:]
            if key.startswith("annual"):
                vals = [float(c) * 1000.0 for c in cells]
                entry = {"limits": (vals[0], vals[1]),
                         "programs": dict(zip(PROGRAMS, vals[2:2 + len(PROGRAMS)]))}
            else:
                kw = [float(c) * 1000.0 for c in cells[0::2]]
                entry = {"programs": dict(zip(PROGRAMS, kw[:len(PROGRAMS)]))}
            out.setdefault(name, {})[key] = entry
    if not out:
        raise ValueError("detailed_UsersGuide.mo: no result tables found")
    return out


# --------------------------------------------------------------------------- run

def _window_g(unit):
    """g(aoi) table of a flat-spectrum (broadband-record) unit: angles, g, g_diffuse, tau_diffuse."""
    return glazing_g_table(unit, np.array([280.0, 2500.0]), np.ones(2))


def solar_escape_fraction(tau_diffuse, window_area, interior_area, absorptance):
    """Share of transmitted solar that leaves again through the windows after diffuse reflections
    in the room [1]: ``rho p / (1 - rho (1 - p))`` with ``rho = 1 - absorptance`` and ``p = tau_d
    A_w / A_int`` (uniform radiosity enclosure)."""
    rho = 1.0 - absorptance
    p = tau_diffuse * window_area / interior_area
    return rho * p / (1.0 - rho * (1.0 - p))


def case_gains(case: BestestCase, weather, site, g_table=None, poa=None, exterior="hourly"):
    """Hourly solar gains of a case [W] split by element, from the weather (Hay-Davies) or from
    the integrator (``poa``, see :func:`integrator_irradiance`).

    Parameters
    ----------
    case : BestestCase
    weather : pandas.DataFrame
        From :func:`read_mos`.
    site : dict
        From :func:`read_mos`.
    g_table : tuple, optional
        (angles [deg], g [1], g_diffuse [1], tau_diffuse [1]) to replace the window's own.
    poa : dict, optional
        From :func:`integrator_irradiance`: (T, 5) parts for the N, E, S, W walls and the roof and
        ``window_gain`` per case window (T,) [W m-2 of glass]; replaces the weather-only route.
    exterior : str
        ``"hourly"``: outside surface coefficients per hour from the wind and air temperature
        (:mod:`widesky.thermal.exterior`), with the U-values, sky loss and absorbed-solar share they give;
        ``"constant"``: ISO 13790's fixed R_se = 0.04 (EN 673's h_e = 23 for the window).

    Returns
    -------
    dict of numpy.ndarray
        (T,) ``window`` (transmitted + inward-flowing absorbed, less the escaped share),
        ``opaque`` (absorbed on walls and roof, ISO 13790 11.3.4), ``sky_loss`` (long-wave to the
        sky, ISO 13790 11.3.5) [W]; ``incident_south`` [W m-2]; ``temp_sky`` [degC];
        ``h_tr_w``, ``h_tr_op`` [W K-1] the transmission conductances per hour (``"hourly"``) or
        None.
    """
    if exterior not in EXTERIOR_MODELS:
        raise ValueError(f"exterior={exterior!r} not one of {EXTERIOR_MODELS}")
    surf = [(90.0, az) for az, _, _ in case.walls] + [(0.0, 180.0)]
    if poa is not None:
        irr = poa
    else:
        times = sun_times(weather.index, label="right")
        sp = solar_position(times, site["latitude"], site["longitude"], site["altitude"])
        irr = surface_irradiance([s[0] for s in surf], [s[1] for s in surf],
                                 sp["zenith"].to_numpy(), sp["azimuth"].to_numpy(),
                                 weather["dni"].to_numpy(), weather["dhi"].to_numpy(),
                                 weather["ghi"].to_numpy(),
                                 dni_extra(sp["earth_sun_distance"].to_numpy()), GROUND_REFLECTANCE)
    ang, g, g_d, tau_d = _window_g(case.window) if g_table is None else g_table
    esc = solar_escape_fraction(tau_d, case.window_area, case.interior_area,
                                INTERIOR_SOLAR_ABSORPTANCE)
    win_area = np.array([w[2] for w in case.walls] + [0.0])
    opq_area = np.array([w[1] for w in case.walls] + [case.roof_area])
    u_opq = np.array([case.u_wall] * len(case.walls) + [case.u_roof])
    tilt = np.array([s[0] for s in surf])
    diffuse = irr["poa_sky_diffuse"] + irr["poa_ground_diffuse"]
    if poa is not None:
        window = poa["window_gain"][case.window.name] * case.window_area * (1 - esc)
    else:
        window = window_gains(win_area, irr["poa_direct"], diffuse, irr["aoi"], ang, g, g_d).sum(1)
        window *= 1 - esc
    t_sky = sky_temperature(np.maximum(weather["ghi_infrared"].to_numpy(), 1.0))
    ta = weather["temp_air"].to_numpy()
    eps_win = case.window.layers[0].emissivity_front
    u_win, r_opq, r_win, h_w, h_op = case.u_window, R_SE, 1.0 / case.window.h_out, None, None
    if exterior == "hourly":
        v = weather["wind_speed"].to_numpy()
        v_wall = wind_at_height(v, 0.5 * case.height)
        v_roof = wind_at_height(v, case.height)
        h_e = [sum(exterior_coefficients(v_wall if t > 45 else v_roof, ta, case.emissivity))
               for t in tilt]
        r_opq = 1.0 / np.stack(h_e, 1)
        u_opq = np.stack([hourly_u_value(u, h) for u, h in zip(u_opq, h_e)], 1)
        h_e_win = sum(exterior_coefficients(v_wall, ta, eps_win))
        u_win = hourly_u_value(case.u_window, h_e_win, 1.0 / case.window.h_out)[:, None]
        r_win = 1.0 / h_e_win[:, None]
        h_w = u_win[:, 0] * case.window_area
        h_op = (u_opq * opq_area).sum(1) + case.u_floor * case.zone.floor_area
    opaque = opaque_gains(opq_area, u_opq, case.absorptance, irr["poa_global"], r_opq).sum(1)
    sky_loss = (sky_losses(opq_area, u_opq, case.emissivity, tilt, ta, t_sky, r_opq).sum(1)
                + sky_losses(win_area, u_win, eps_win, tilt, ta, t_sky, r_win).sum(1))
    south = int(np.argmin([abs(a - 180.0) for a, _, _ in case.walls]))
    return {"window": window, "opaque": opaque, "sky_loss": sky_loss,
            "incident_south": irr["poa_global"][:, south], "temp_sky": t_sky,
            "h_tr_w": h_w, "h_tr_op": h_op}


WEATHER_FILES = {"tmy3": "weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw",
                 "drycold": "weather/DRYCOLD.mos"}
"""The two Denver weather years: ``tmy3`` drives the 140-2020/2023 cases and their published
results (the ``weaDat`` of the case files), ``drycold`` is the weather of the earlier editions."""


def load_weather(weather="tmy3", data_dir=None):
    """(data, site) of a BESTEST weather year; ``weather`` a key of :data:`WEATHER_FILES`.

    Returns the columns of :func:`read_mos` (indexed by hour ends) and the site dict.
    """
    if weather not in WEATHER_FILES:
        raise ValueError(f"weather={weather!r} not one of {sorted(WEATHER_FILES)}")
    path = _data_file(WEATHER_FILES[weather], data_dir)
    if weather == "drycold":
        return read_mos(path)
    w = read_epw(path)
    site = {"name": w.site.name, "latitude": w.site.latitude, "longitude": w.site.longitude,
            "altitude": w.site.altitude, "tz": w.site.tz.utcoffset(None).total_seconds() / 3600}
    return w.data, site


def integrator_irradiance(weather="tmy3", data_dir=None, sky=None, n_jobs=1, progress=False):
    """Per-surface irradiance of the Case 600 box from widesky's integrator (the sky model's
    angular and spectral distribution scaled to the weather's measured DNI and DHI).

    The box (8 m x 6 m x 2.7 m, 12 m2 of south glazing, ASHRAE 140-2020 7.2.1) stands on a ground
    of albedo 0.2; each case's window is a rated-g Response (its g by angle, flat spectrum, as the
    records are broadband) applied per incoming direction.

    Returns
    -------
    dict
        (T, 5) ``poa_direct``, ``poa_sky_diffuse``, ``poa_ground_diffuse``, ``poa_global`` [W m-2]
        and ``aoi`` [deg] for the N, E, S, W walls and the roof; ``window_gain``: dict window name
        -> (T,) [W m-2 of glass]; ``result``: the POAResult.
    """
    if weather not in WEATHER_FILES or weather == "drycold":
        raise ValueError(f"weather={weather!r}: the integrator route reads the EPW ('tmy3')")
    w = read_epw(_data_file(WEATHER_FILES[weather], data_dir))
    sky = sky or PragueSky()
    b = box_building(8.0, 6.0, 2.7, wwr={"south": 12.0 / 21.6}, sill=0.2, perimeter_zones=False)
    scene, labels = building_scene(b, ground_albedo=GROUND_REFLECTANCE)
    sim = Simulation(scene, weather=w, sky=SKY_DEFAULTS.replace(albedo=GROUND_REFLECTANCE), sky_source=sky,
                     n_jobs=n_jobs, progress=progress)
    units = {c: window_unit(c, data_dir) for c in ("600", "660", "670")}
    flat = np.array([280.0, 2500.0]), np.ones(2)
    responses = [rated_glazing_response(u, *flat, name=u.name) for u in units.values()]
    res = sim.run(responses)
    order = []
    for az in (0.0, 90.0, 180.0, 270.0):
        order.append(next(i for i, lab in enumerate(labels) if lab.startswith("wall")
                          and abs(b.surfaces[i].azimuth - az) < 1))
    order.append(next(i for i, lab in enumerate(labels) if lab.startswith("roof")))
    irr = irradiance_by_surface(res, [labels[i] for i in order])
    win = [lab for lab in labels if lab.startswith("window")]
    M = group_weights(res, win)[:, 0]
    irr["window_gain"] = {u.name: res.get(u.name, "global") @ M for u in units.values()}
    irr["result"] = res
    return irr


def run_case(case, data_dir=None, weather="tmy3", warmup_steps=24 * 31, g_table=None, poa=None,
             exterior="hourly"):
    """Simulate ASHRAE 140 Case ``case`` for a weather year (hourly, 8760 steps).

    ``weather``: a key of :data:`WEATHER_FILES`, or a (data, site) pair as :func:`load_weather`.
    ``poa``: per-surface irradiance from :func:`integrator_irradiance` (same weather) instead of
    the weather-only Hay-Davies route. ``exterior``: outside surface coefficients, see
    :func:`case_gains`.

    Returns
    -------
    dict
        ``annual_heating``, ``annual_cooling`` [kWh]; ``peak_heating``, ``peak_cooling`` [W] and
        ``peak_heating_time``, ``peak_cooling_time`` (end of the hour); ``hourly``: DataFrame of
        ``heating``, ``cooling`` [W], ``temp_air`` [degC], ``solar_window``, ``solar_opaque``,
        ``sky_loss`` [W]; ``case``: the :class:`BestestCase`.
    """
    c = case if isinstance(case, BestestCase) else case_definition(case, data_dir)
    weather, site = load_weather(weather, data_dir) if isinstance(weather, str) else weather
    gains = case_gains(c, weather, site, g_table, poa, exterior)
    phi_sol = gains["window"] + gains["opaque"] - gains["sky_loss"]
    res = simulate_5r1c(c.zone, weather["temp_air"].to_numpy(), c.internal_gains, phi_sol,
                        c.heating_setpoint, c.cooling_setpoint,
                        internal_convective_fraction=1 - INTERNAL_RADIATIVE_FRACTION,
                        warmup_steps=warmup_steps, h_tr_w=gains["h_tr_w"],
                        h_tr_op=gains["h_tr_op"])
    hourly = pd.DataFrame({"heating": res["heating"][:, 0], "cooling": res["cooling"][:, 0],
                           "temp_air": res["temp_air"][:, 0], "solar_window": gains["window"],
                           "solar_opaque": gains["opaque"], "sky_loss": gains["sky_loss"]},
                          index=weather.index)
    return {"annual_heating": hourly["heating"].sum() / 1000.0,
            "annual_cooling": hourly["cooling"].sum() / 1000.0,
            "peak_heating": hourly["heating"].max(), "peak_cooling": hourly["cooling"].max(),
            "peak_heating_time": hourly["heating"].idxmax(),
            "peak_cooling_time": hourly["cooling"].idxmax(),
            "annual_incident_south": gains["incident_south"].sum() / 1000.0,
            "hourly": hourly, "case": c}
