"""ASHRAE Standard 140 (BESTEST) Cases 600-670, 900-950 and the free-floating 600FF, 650FF,
900FF and 950FF with the ISO 52016-1 zone model (default) or ISO 13790's 5R1C.

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

The variants of Case 600 (ANSI/ASHRAE 140-2020 section 7.2.2; 140-2017 section 5.2.2 and 5.2.3)
are scalar facts of the standard and stand in :data:`CASE_SPECS`, :data:`SETBACK`,
:data:`VENT_SCHEDULE` and :mod:`widesky.thermal.bestest_geometry` (window placement, overhang and
fin depth 1.0 m): the heavyweight 9xx cases take Case 900's constructions; 610 adds a south
overhang, 620 moves the windows to the east and west walls, 630 adds overhangs and fins to those,
640 sets the heating back at night, 650 ventilates at night without heating and cools only by day,
and the FF cases float freely (no heating, no cooling). The annual mean zone temperatures of the
free-floating cases, in none of the data files' tables, stand in :data:`MEAN_TEMPERATURE_RANGE`
with their source.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from widesky.core.paths import data_file
from widesky.irradiance import (SKY_DEFAULTS, AngularTable, PragueSky, Response, Simulation, dni_extra,
                                fixed_offset_tz, read_epw, solar_position, sun_times)

from .bestest_geometry import ROOM, WINDOW, bestest_building, window_shading
from .exterior import (ROUGHNESS_MULTIPLIER, energyplus_wind_at_height, exterior_coefficients, hourly_u_value,
                       mowitt_forced_convection, wind_at_height, windward)
from .gains import building_scene, group_weights, irradiance_by_surface, rated_glazing_response, result_in_band_share
from .glazing import ANGLES, Gap, GlazingUnit, layer_from_broadband
from .loads import R_SE, glazing_g_table, opaque_gains, sky_losses, window_gains
from .optics import hemispherical
from .surface import sky_temperature, surface_irradiance
from .zone import ZoneParameters, simulate_5r1c
from .zone_iso52016 import (EN673_MEAN_TEMPERATURE, SIGMA, Element, Layer, box_view_factors, radiant_exchange,
                            simulate_iso52016)

__all__ = ["CASES", "GROUND_REFLECTANCE", "WEATHER_FILES", "read_mos", "read_modelica_record",
           "case_definition", "window_unit", "reference_results", "run_case", "BestestCase",
           "load_weather", "case_gains", "integrator_irradiance", "solar_escape_fraction",
           "layer_resistance", "EXTERIOR_MODELS", "CASE_SPECS", "CaseSpec", "SETBACK", "VENT_SCHEDULE",
           "MEAN_TEMPERATURE_RANGE", "LOAD_CASES", "SOURCES", "Verdict", "verdicts", "case_geometry",
           "setpoint_schedules", "construction_layers", "iso52016_elements", "ZONE_MODELS",
           "INTERIOR_SOLAR_DISTRIBUTION", "interior_solar_distribution", "ISO52016_OPTIONS", "parse_iso52016_option",
           "setback_substeps",
           "interior_longwave", "lost_share", "run_case_on_route"]


@dataclass(frozen=True)
class CaseSpec:
    """What an ASHRAE 140 case changes against Case 600 (140-2020 7.2.2; 2017 5.2.2, 5.2.3).

    ``mass``: "600" (lightweight) or "900" (heavyweight constructions); ``window``: the glazing
    records' case ("600", "660", "670"); ``layout``, ``shading``: see
    :mod:`widesky.thermal.bestest_geometry`; ``control``: "constant" (20 / 27 degC), "setback"
    (Case 640), "vent" (Case 650: night ventilation, no heating, cooling by day) or "free"
    (free floating), "vent_free" (Case 650FF).
    """

    mass: str = "600"
    window: str = "600"
    layout: str = "south"
    shading: object = None
    control: str = "constant"

    @property
    def free_floating(self):
        return self.control in ("free", "vent_free")


CASE_SPECS = {
    "600": CaseSpec(), "610": CaseSpec(shading="overhang"), "620": CaseSpec(layout="eastwest"),
    "630": CaseSpec(layout="eastwest", shading="overhang_fins"), "640": CaseSpec(control="setback"),
    "650": CaseSpec(control="vent"), "660": CaseSpec(window="660"), "670": CaseSpec(window="670"),
    "900": CaseSpec("900"), "910": CaseSpec("900", shading="overhang"),
    "920": CaseSpec("900", layout="eastwest"),
    "930": CaseSpec("900", layout="eastwest", shading="overhang_fins"),
    "940": CaseSpec("900", control="setback"), "950": CaseSpec("900", control="vent"),
    "600FF": CaseSpec(control="free"), "650FF": CaseSpec(control="vent_free"),
    "900FF": CaseSpec("900", control="free"), "950FF": CaseSpec("900", control="vent_free"),
}
"""ANSI/ASHRAE 140-2020 section 7.2.2 (Cases 610-650FF, 900-950FF; 2017 edition 5.2.2-5.2.3)."""

CASES = tuple(CASE_SPECS)
LOAD_CASES = tuple(c for c in CASES if not CASE_SPECS[c].free_floating)
"""The cases with heating and cooling (annual loads and peaks); the others float freely."""
SETBACK = {"night": 10.0, "day": 20.0, "night_start": 23, "ramp_start": 7, "ramp_end": 8}
"""Case 640/940 heating set-point [degC] (140-2020 7.2.2.1.4): 10 degC from 23:00 to 07:00, a
linear ramp to 20 degC from 07:00 to 08:00 (the hour's mean, 15 degC, in an hourly model), 20 degC
from 08:00 to 23:00; cooling 27 degC all hours."""
VENT_SCHEDULE = {"flow": 1700.0, "on": 18, "off": 7, "cooling_set_point": 27.0}
"""Case 650/950 (140-2020 7.2.2.1.5): a vent fan of 1700 m3 h-1 [m3 h-1] on from 18:00 to 07:00
(besides the infiltration; no fan heat), altitude-adjusted as the infiltration is (0.5 h-1 at sea
level -> the case file's ``airRat``): 469.2 W K-1 at rho c 1200 J m-3 K-1 (the case files' Modelica run, Case950.mo
of 12 May 2022: 1409 m3 h-1 at 1.2 kg m-3 and 1006 J kg-1 K-1, 472.5 W K-1); heating off; cooling to 27 degC from
07:00 to 18:00 only. The hours are the weather's (ending at its index): the fan runs in the 13 hours beginning
18:00-06:00, cooling in the 11 beginning 07:00-17:00. 650FF and 950FF: the same fan, no heating and no cooling."""
MEAN_TEMPERATURE_RANGE = {"600FF": (24.3, 26.1), "650FF": (17.6, 18.9), "900FF": (24.5, 25.7),
                          "950FF": (14.4, 15.0)}
"""Annual mean zone air temperature [degC], the reference programs' range (minimum, maximum)
of the 140-2020/2023 results: ``staRes.meanT`` (Min, Max) of the Modelica Buildings library's
case files (github lbl-srg/modelica-buildings, BSD-3,
Buildings/ThermalZones/Detailed/Validation/BESTEST/Cases6xx/Case600FF.mo, Case650FF.mo and
Cases9xx/Case900FF.mo, Case950FF.mo, the revisions with the 2020 weather and the 1409 m3 h-1
altitude-adjusted fan). Their minima and maxima of the minimum and maximum temperatures agree with
the User's Guide tables that :func:`reference_results` reads."""
GROUND_REFLECTANCE = 0.2          # ASHRAE 140-2020 7.2.1
INTERNAL_RADIATIVE_FRACTION = 0.6  # ASHRAE 140-2020 7.2.1: 200 W, 60 % radiative
INTERIOR_SOLAR_ABSORPTANCE = 0.6   # ASHRAE 140-2020 7.2.1: interior surfaces
INTERIOR_EMISSIVITY = 0.9          # ASHRAE 140-2020 7.2.1: interior surfaces' infrared emissivity
INTERIOR_SOLAR_DISTRIBUTION = {
    "south": {"floor": 0.642, "ceiling": 0.167, "east": 0.038, "west": 0.038, "north": 0.053, "south": 0.027,
              "lost": 0.035},
    "eastwest": {"floor": 0.642, "ceiling": 0.167, "east": 0.025, "west": 0.025, "north": 0.053, "south": 0.053,
                 "lost": 0.035},
}
"""Share of the transmitted solar absorbed by each inside surface, and lost back out through the windows [1], for
programs that do not compute it: ANSI/ASHRAE 140-2017 section 5.2.1 (Case 600, south windows; 140-2020 7.2.1) and
the Case 620 specification (east and west windows). The Standard derives them by its Informative Annex B7 method
(every beam first lands on the floor, absorptance 0.6; the reflected part by view factors, then by area and
absorptance). The 660 and 670 tables differ by less than 0.004 once the lost share is taken off; the 9xx cases
have the same inside absorptance and geometry."""
RHO_C_AIR = 1200.0                 # ISO 13790 9.3.1: rho_a c_a [J m-3 K-1]
PROGRAMS = ("BSIMAC", "CSE", "DeST", "EnergyPlus", "ESP-r", "TRNSYS")
R_SI = {"wall": 0.13, "roof": 0.10, "floor": 0.17}   # ISO 6946:2017 Table 7 [m2 K W-1]
EXTERIOR_MODELS = ("hourly", "constant")
SHADED_SAMPLES_PER_FACE = 16
"""Points per triangle of the integrator's scene for a room with shading devices (a square number): one point
(the centroid) per triangle samples a 3 m x 2 m window at two heights, 1.2 and 1.8 m below the 610 overhang, so
the overhang's shadow on it was missed until the sun stood above 49 degrees (October's noon gain cut 2 %
instead of the 16 % of the analytic shadow); 16 points per triangle sample it at 8 heights."""
ZONE_MODELS = ("5r1c", "iso52016")


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


def _construction_text(path, block=None):
    """The text of a Modelica construction record file, or of its first ``block(...)`` up to its roughness."""
    text = Path(path).read_text(encoding="latin-1")
    if block is not None:
        m = re.search(r"\b" + re.escape(block) + r"\s*\(", text)
        if not m:
            raise ValueError(f"{path}: no construction {block!r}")
        text = text[m.end():]
        text = text[:text.find("roughness_a")] if "roughness_a" in text else text
    return text


def layer_resistance(path, block=None):
    """Sum of ``x / k`` [m2 K W-1] over the layers (``Solids.Generic(x=..., k=...)``) of a Modelica
    construction record, in the whole file or in the first ``block(...)`` (e.g. ``"matExtWal"``)."""
    text = _construction_text(path, block)
    num = r"([-+]?\d*\.?\d+(?:[eE][-+]?\d+)?)"
    layers = re.findall(r"Generic\(\s*x\s*=\s*" + num + r"\s*,\s*k\s*=\s*" + num, text)
    if not layers:
        raise ValueError(f"{path}: no layers (x=..., k=...) in {block or 'the file'}")
    return float(sum(float(x) / float(k) for x, k in layers))


def construction_layers(path, block=None):
    """The layers (outside first) of a Modelica construction record as
    :class:`~widesky.thermal.zone_iso52016.Layer` (``Solids.Generic(x=, k=, c=, d=)``), in the whole
    file or in the first ``block(...)``."""
    text = _construction_text(path, block)
    num = r"([-+]?\d*\.?\d+(?:[eE][-+]?\d+)?)"
    found = re.findall(r"Generic\(\s*x\s*=\s*" + num + r"\s*,\s*k\s*=\s*" + num + r"\s*,\s*c\s*=\s*"
                       + num + r"\s*,\s*d\s*=\s*" + num, text)
    if not found:
        raise ValueError(f"{path}: no layers (x=..., k=..., c=..., d=...) in {block or 'the file'}")
    return tuple(Layer(*(float(v) for v in f)) for f in found)


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
    spec: CaseSpec = CaseSpec()
    air_changes: float = 0.414     # infiltration [h-1] (the case file's altitude-adjusted airRat)


def case_definition(case, data_dir=None) -> BestestCase:
    """Inputs of ASHRAE 140 Case ``case`` (a key of :data:`CASE_SPECS`) from the data files.

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

    The variants (:data:`CASE_SPECS`) change the mass (9xx: Case 900's), the window layout
    (620, 630: 6 m2 in each of the east and west walls instead of 12 m2 south), the shading
    devices (610, 630) and the control (640, 650, FF); their set-point and ventilation schedules
    come from :func:`setpoint_schedules`.
    """
    if case not in CASES:
        raise ValueError(f"case={case!r} not one of {CASES}")
    spec = CASE_SPECS[case]
    base = read_modelica_record(_data_file("bestest/iso13790_Cases6xx_Case600.mo", data_dir),
                                "zonHVAC")
    mass = read_modelica_record(_data_file(
        f"bestest/iso13790_Data_Case{spec.mass}Mass.mo", data_dir))
    wall = read_modelica_record(_data_file("bestest/detailed_Data_ExteriorWallCase900.mo", data_dir))
    unit = window_unit(spec.window, data_dir)
    u_win = unit.u_value()
    azi = [(180.0 + np.degrees(a)) % 360.0 for a in base["surAzi"]]   # Modelica: 0 = south
    gross = [aw + awin for aw, awin in zip(base["AWal"], base["AWin"])]
    a_win = float(np.sum(base["AWin"]))
    if spec.layout == "eastwest":                 # half the glazing in each of the east, west walls
        win = [a_win / 2 if abs(az - 90) < 1 or abs(az - 270) < 1 else 0.0 for az in azi]
    else:
        win = list(base["AWin"])
    walls = tuple((az, g - w, w) for az, g, w in zip(azi, gross, win))
    a_f = base["AFlo"]
    u_wall, u_roof, u_floor = _u_values(spec.mass, data_dir)
    h_op = (u_wall * sum(w[1] for w in walls) + u_roof * base["ARoo"] + base["b"] * u_floor * a_f)
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
                       float(heat.group(1)), float(cool.group(1)), interior, u_floor, height,
                       spec, base["airRat"])


# --------------------------------------------------------------------------- references

def reference_results(data_dir=None):
    """Reference programs' results and acceptance limits from the detailed models' User's Guide.

    Returns
    -------
    dict
        ``case -> {"annual_heating" | "annual_cooling": {"limits": (lo, hi) [kWh],
        "programs": {name: kWh}}, "peak_heating" | "peak_cooling": {"programs": {name: W}}}``;
        free-floating cases ``"max_temperature" | "min_temperature": {"programs": {name: degC}}``.
        The six programs of Standard 140's results (BSIMAC, CSE, DeST, EnergyPlus, ESP-r, TRNSYS).
        Limits are returned in order (the guide lists Case 910's cooling limits high, low).
    """
    text = _data_file("bestest/detailed_UsersGuide.mo", data_dir).read_text(encoding="latin-1")
    out = {}
    titles = {"Annual heating load (MWh)": "annual_heating", "Annual cooling load (MWh)":
              "annual_cooling", "Peak heating load (kW)": "peak_heating",
              "Peak cooling load (kW)": "peak_cooling", "Maximum temperature (&deg;C)": "max_temperature",
              "Minimum temperature (&deg;C)": "min_temperature"}
    parts = re.split(r"<b>([^<]+)</b>", text)
    for title, body in zip(parts[1::2], parts[2::2]):
        key = titles.get(title.strip())
        if key is None:
            continue
        body = body.split("</table>")[0]
        for row in re.findall(r"<tr>\s*<td>(Case\d+(?:FF)?)</td>(.*?)</tr>", body, re.S):
            cells = re.findall(r"<td[^>]*>([^<]*)</td>", row[1])
            name = row[0][4:]
            if key.startswith("annual"):
                vals = [float(c) * 1000.0 for c in cells]
                entry = {"limits": (min(vals[0], vals[1]), max(vals[0], vals[1])),
                         "programs": dict(zip(PROGRAMS, vals[2:2 + len(PROGRAMS)]))}
            else:
                scale = 1.0 if key.endswith("temperature") else 1000.0
                kw = [float(c) * scale for c in cells[0::2]]
                entry = {"programs": dict(zip(PROGRAMS, kw[:len(PROGRAMS)]))}
            out.setdefault(name, {})[key] = entry
    if not out:
        raise ValueError("detailed_UsersGuide.mo: no result tables found")
    return out


SOURCES = {
    "acceptance": "acceptance range, ASHRAE 140-2023 Add. b Tables A3-1/A3-2 (Modelica Buildings "
                  "User's Guide)",
    "programs": "reference programs' range (6 programs of 140-2020/2023; Modelica Buildings "
                "User's Guide)",
    "programs_mean": "reference programs' range (140-2020/2023; staRes.meanT of the Modelica "
                     "Buildings case file)",
    "programs_solar": "reference programs' range (6 programs' solar outputs of 140-2020, results workbook "
                      "RESULTS5-2A; thermal/bestest_solar.py)",
    "programs_days": "largest departure from the reference programs' hourly range (6 programs of 140-2020, "
                     "results workbook RESULTS5-2A; thermal/bestest_days.py)",
    "programs_monthly": "largest departure from the reference programs' monthly range (6 programs of 140-2020, "
                        "results workbook RESULTS5-2A; thermal/bestest_monthly.py)",
}
"""Where each verdict's range comes from."""


@dataclass(frozen=True)
class Verdict:
    """One figure of a case against its range: ``value``, ``low``, ``high`` in ``unit`` (MWh, kW,
    degC); ``source`` a key of :data:`SOURCES`."""

    case: str
    quantity: str
    value: float
    low: float
    high: float
    unit: str
    source: str

    @property
    def inside(self) -> bool:
        return bool(self.low <= self.value <= self.high)


def verdicts(case, result, refs=None, data_dir=None):
    """Each figure of ``result`` (from :func:`run_case`) beside its range.

    Annual heating and cooling [MWh] against the standard's acceptance range; peak heating and
    cooling [kW] and the free-floating cases' minimum and maximum zone temperature [degC] against
    the six reference programs' range (the standard gives no acceptance range for them); the
    annual mean temperature [degC] against :data:`MEAN_TEMPERATURE_RANGE`. A value equal to a
    limit is inside.

    Returns
    -------
    list of Verdict
    """
    refs = reference_results(data_dir) if refs is None else refs
    if case not in refs:
        raise ValueError(f"case={case!r}: no reference results (have {sorted(refs)})")
    out = []
    if CASE_SPECS[case].free_floating:
        for q, key in (("min_temperature", "temp_min"), ("max_temperature", "temp_max")):
            prog = list(refs[case][q]["programs"].values())
            out.append(Verdict(case, q, float(result[key]), min(prog), max(prog), "degC", "programs"))
        lo, hi = MEAN_TEMPERATURE_RANGE[case]
        out.append(Verdict(case, "mean_temperature", float(result["temp_mean"]), lo, hi, "degC",
                           "programs_mean"))
        return out
    for q in ("annual_heating", "annual_cooling", "peak_heating", "peak_cooling"):
        ref = refs[case][q]
        if "limits" in ref:
            lo, hi = ref["limits"]
            src = "acceptance"
        else:
            prog = list(ref["programs"].values())
            lo, hi, src = min(prog), max(prog), "programs"
        unit = "MWh" if q.startswith("annual") else "kW"
        out.append(Verdict(case, q, float(result[q]) / 1000.0, lo / 1000.0, hi / 1000.0, unit, src))
    return out


# --------------------------------------------------------------------------- run

def case_geometry(case):
    """(layout, shading) of a case name or :class:`BestestCase` (see
    :mod:`widesky.thermal.bestest_geometry`)."""
    spec = case.spec if isinstance(case, BestestCase) else CASE_SPECS[case]
    return spec.layout, spec.shading


def setpoint_schedules(case: BestestCase, index):
    """Hourly heating and cooling set-points [degC] and ventilation conductance [W K-1] of a case.

    Parameters
    ----------
    case : BestestCase
    index : pandas.DatetimeIndex
        The weather's hour ends (local standard time); an hour ending at 08:00 is the hour from
        07:00 to 08:00.

    Returns
    -------
    heating, cooling, h_ve : numpy.ndarray
        (T,) each; -inf / inf where heating / cooling is off.
    """
    start = np.asarray((index - pd.Timedelta(hours=1)).hour)      # hour of day the step begins
    T = len(start)
    heat = np.full(T, case.heating_setpoint)
    cool = np.full(T, case.cooling_setpoint)
    h_ve = np.full(T, float(case.zone.h_ve))
    control = case.spec.control
    if control == "setback":
        sb = SETBACK
        heat = np.where((start >= sb["night_start"]) | (start < sb["ramp_start"]), sb["night"], heat)
        ramp = (start >= sb["ramp_start"]) & (start < sb["ramp_end"])
        heat = np.where(ramp, 0.5 * (sb["night"] + sb["day"]), heat)
    if control in ("vent", "vent_free"):
        v = VENT_SCHEDULE
        on = (start >= v["on"]) | (start < v["off"])
        fan = RHO_C_AIR * v["flow"] * (case.air_changes / 0.5) / 3600.0   # altitude-adjusted
        h_ve = h_ve + np.where(on, fan, 0.0)
        heat = np.full(T, -np.inf)
        cool = np.where(on, np.inf, v["cooling_set_point"])
    if control in ("free", "vent_free"):
        heat, cool = np.full(T, -np.inf), np.full(T, np.inf)
    return heat, cool, h_ve


def setback_substeps(index, substeps):
    """Case 640/940 heating set-point [degC] at the end of each of ``substeps`` sub-steps per hour (``index``: the
    hours' ends), the ramp of :data:`SETBACK` followed within its hour (10 degC until 07:00, linear to 20 degC at
    08:00, 20 degC until 23:00). Returns (T substeps,)."""
    start = np.asarray((index - pd.Timedelta(hours=1)).hour, float)
    t = (start[:, None] + np.arange(1, substeps + 1) / substeps).ravel() % 24.0    # sub-step ends [h of day]
    sb = SETBACK
    ramp = np.clip((t - sb["ramp_start"]) / (sb["ramp_end"] - sb["ramp_start"]), 0.0, 1.0)
    day = np.where(t == 0.0, 24.0, t)
    heat = sb["night"] + (sb["day"] - sb["night"]) * ramp
    return np.where(day > sb["night_start"], sb["night"], heat)


_SHADING_CACHE = {}


def _shading_factors(case: BestestCase, zenith, azimuth):
    """(T, S) sunlit share and (S,) sky, ground and horizon-band view shares per wall of the case (1 where
    the wall has no shaded window), by ray casting its devices (:func:`window_shading`)."""
    S = len(case.walls) + 1
    layout, shading = case_geometry(case)
    if shading is None:
        return np.ones((len(zenith), S)), np.ones(S), np.ones(S), np.ones(S)
    key = (layout, shading, hash(np.asarray(zenith).tobytes()), hash(np.asarray(azimuth).tobytes()))
    if key not in _SHADING_CACHE:
        b = bestest_building(layout, shading)
        f = window_shading(b, zenith, azimuth)
        sunlit, sky, gnd, hor = np.ones((len(zenith), S)), np.ones(S), np.ones(S), np.ones(S)
        az_win = {s.label: s.azimuth for s in b.surfaces if s.kind == "window"}
        for j, lab in enumerate(f["labels"]):
            i = int(np.argmin([abs((w[0] - az_win[lab] + 180) % 360 - 180) for w in case.walls]))
            sunlit[:, i], sky[i], gnd[i] = f["sunlit"][:, j], f["sky_view"][j], f["ground_view"][j]
            hor[i] = f["horizon_view"][j]
        if len(_SHADING_CACHE) > 8:
            _SHADING_CACHE.clear()
        _SHADING_CACHE[key] = (sunlit, sky, gnd, hor)
    return _SHADING_CACHE[key]


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


def horizon_g(angles, g):
    """g [1] of a vertical window for light from the horizon band: ``g(theta)`` averaged over the band's
    azimuths with the weight ``cos theta`` (the band's light reaches the glass at ``theta`` = its azimuth from
    the window's normal), ``int g cos / int cos`` over 0-90 deg."""
    th = np.linspace(0.0, 90.0, 901)
    w = np.cos(np.radians(th))
    return float(np.trapezoid(np.interp(th, angles, g) * w, th) / np.trapezoid(w, th))


def case_gains(case: BestestCase, weather, site, g_table=None, poa=None, exterior="hourly",
               transposition="perez", diffuse_optics="angular"):
    """Hourly solar gains of a case [W] split by element, from the weather (Perez or Hay-Davies) or
    from the integrator (``poa``, see :func:`integrator_irradiance`).

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
    transposition : str
        The weather route's transposition (:data:`widesky.thermal.surface.TRANSPOSITIONS`): ``"perez"``
        (Perez et al. 1990, default) or ``"hay-davies"``.
    diffuse_optics : str
        A key of :data:`DIFFUSE_OPTICS`: how the glass takes the diffuse light. ``"angular"`` (default): each route's
        own angles (below; the integrator's glass at every ray's own angle); ``"hemispherical"``: the glass's g at
        the sun's angle on the beam alone and its hemispherical g on all diffuse light, circumsolar and horizon band
        included (circumsolar light still shaded like the beam): the same convention on both routes, to compare
        their light through it.

    Shading devices (Cases 610, 630 ...): on the weather route the window's beam (with the
    circumsolar part) is scaled by its sunlit share, its isotropic sky and ground-reflected light by
    its view of the sky and of the ground that the devices leave, the Perez horizon band by its view
    of the band 0-6.5 deg above the horizon (cosine-weighted), all by ray casting the devices
    (:func:`widesky.thermal.bestest_geometry.window_shading`); the horizon band passes the glass at
    :func:`horizon_g` (its light comes in at grazing elevation from every azimuth of the window's front),
    the isotropic sky and the ground's at the hemispherical g; the light the devices reflect and
    their shade on the opaque walls are left out. On the integrator route they are in the scene
    (``poa`` must be computed for the case's geometry, :func:`case_geometry`).

    Returns
    -------
    dict of numpy.ndarray
        (T,) ``window`` (transmitted + inward-flowing absorbed, less the escaped share), (T, 5)
        ``window_walls`` the same per wall (N, E, S, W, roof; None from a ``poa`` without
        ``window_gain_walls``),
        ``opaque`` (absorbed on walls and roof, ISO 13790 11.3.4), ``sky_loss`` (long-wave to the
        sky, ISO 13790 11.3.5) [W]; ``incident_south`` [W m-2]; ``temp_sky`` [degC];
        ``h_tr_w``, ``h_tr_op`` [W K-1] the transmission conductances per hour (``"hourly"``) or
        None.
    """
    if exterior not in EXTERIOR_MODELS:
        raise ValueError(f"exterior={exterior!r} not one of {EXTERIOR_MODELS}")
    surf = [(90.0, az) for az, _, _ in case.walls] + [(0.0, 180.0)]
    if poa is not None:
        if poa.get("geometry", ("south", None)) != case_geometry(case):
            raise ValueError(f"poa was computed for the geometry {poa.get('geometry')}, case "
                             f"{case.name} needs {case_geometry(case)}")
        irr = poa
    else:
        times = sun_times(weather.index, label="right")
        sp = solar_position(times, site["latitude"], site["longitude"], site["altitude"])
        irr = surface_irradiance([s[0] for s in surf], [s[1] for s in surf],
                                 sp["zenith"].to_numpy(), sp["azimuth"].to_numpy(),
                                 weather["dni"].to_numpy(), weather["dhi"].to_numpy(),
                                 weather["ghi"].to_numpy(),
                                 dni_extra(sp["earth_sun_distance"].to_numpy()), GROUND_REFLECTANCE,
                                 transposition=transposition)
    ang, g, g_d, tau_d = _window_g(case.window) if g_table is None else g_table
    esc = solar_escape_fraction(tau_d, case.window_area, case.interior_area,
                                INTERIOR_SOLAR_ABSORPTANCE)
    win_area = np.array([w[2] for w in case.walls] + [0.0])
    opq_area = np.array([w[1] for w in case.walls] + [case.roof_area])
    u_opq = np.array([case.u_wall] * len(case.walls) + [case.u_roof])
    tilt = np.array([s[0] for s in surf])
    diffuse = irr["poa_sky_diffuse"] + irr["poa_ground_diffuse"]
    if diffuse_optics not in DIFFUSE_OPTICS:
        raise ValueError(f"diffuse_optics={diffuse_optics!r} not one of {DIFFUSE_OPTICS}")
    if poa is not None and diffuse_optics == "hemispherical":
        if "window_light_walls" not in poa:
            raise ValueError("diffuse_optics='hemispherical' needs a poa with window_light_walls "
                             "(integrator_irradiance)")
        wl = poa["window_light_walls"]
        gain = (np.interp(np.clip(wl["aoi"], 0.0, 90.0), ang, g) * wl["direct"] + g_d * wl["diffuse"])   # (T, 5)
        window_walls = gain * win_area[None, :] * (1 - esc)
        window = window_walls.sum(1)
    elif poa is not None:
        window = poa["window_gain"][case.window.name] * case.window_area * (1 - esc)
        walls = poa.get("window_gain_walls", {}).get(case.window.name)
        window_walls = None if walls is None else walls * win_area[None, :] * (1 - esc)
    else:
        sunlit, sky_v, gnd_v, hor_v = _shading_factors(case, sp["zenith"].to_numpy(),
                                                       sp["azimuth"].to_numpy())
        hor = irr["poa_horizon"]
        direct_w = irr["poa_direct"] * sunlit
        band = horizon_g(ang, g) / g_d
        if diffuse_optics == "hemispherical":        # circumsolar light at the hemispherical g, shaded as the beam
            direct_w = (irr["poa_direct"] - irr["poa_circumsolar"]) * sunlit
            band = 1.0
        diffuse_w = ((irr["poa_sky_diffuse"] - hor) * sky_v + irr["poa_ground_diffuse"] * gnd_v + hor * hor_v * band
                     + (irr["poa_direct"] * sunlit - direct_w))
        window_walls = window_gains(win_area, direct_w, diffuse_w, irr["aoi"], ang, g, g_d) * (1 - esc)
        window = window_walls.sum(1)
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
    return {"window": window, "window_walls": window_walls, "opaque": opaque, "sky_loss": sky_loss,
            "poa_global": irr["poa_global"],
            "incident_south": irr["poa_global"][:, south], "temp_sky": t_sky,
            "h_tr_w": h_w, "h_tr_op": h_op}


DIFFUSE_OPTICS = ("angular", "hemispherical")
"""How the windows take the diffuse light (:func:`case_gains`): each route's own angles, or the glass's hemispherical
value on all of it (the beam alone at its angle)."""

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


def integrator_irradiance(weather="tmy3", data_dir=None, sky=None, n_jobs=1, progress=False,
                          geometry=("south", None), quantity="shgc"):
    """Per-surface irradiance of the test room from widesky's integrator (the sky model's
    angular and spectral distribution scaled to the weather's measured DNI and DHI).

    The room (:func:`widesky.thermal.bestest_geometry.bestest_building`: 8 m x 6 m x 2.7 m, two
    3 m x 2 m windows south or one in each of the east and west walls, ASHRAE 140-2020 7.2.1-7.2.2)
    stands on a ground of albedo 0.2 with the shading devices of ``geometry`` = (layout, shading)
    (:func:`case_geometry`) as context meshes, which occlude and reflect every ray; each case's
    window is a rated-g Response (its g by angle, flat spectrum, as the records are broadband)
    applied per incoming direction; ``quantity="transmittance"`` puts the unit's solar transmittance
    by angle in its place (the transmitted light ASHRAE 140 reports).

    Returns
    -------
    dict
        (T, 5) ``poa_direct``, ``poa_sky_diffuse``, ``poa_ground_diffuse``, ``poa_global`` [W m-2]
        and ``aoi`` [deg] for the N, E, S, W walls and the roof; ``window_gain``: dict window name
        -> (T,) [W m-2 of glass] (g, or the transmittance, times the light; area-weighted over the
        windows); ``window_gain_walls``: dict window name -> (T, 5) the same per glazed wall (N, E, S,
        W, roof; 0 where a wall has no window); ``window_light_walls``: dict ``direct``, ``diffuse`` (sky and
        ground) (T, 5) [W m-2] and ``aoi`` (T, 5) [deg] on each wall's glass (area-weighted; for
        ``diffuse_optics="hemispherical"``); ``result``: the POAResult; ``geometry``: the (layout, shading)
        computed.
    """
    if quantity not in ("shgc", "transmittance"):
        raise ValueError(f"quantity={quantity!r} not one of ('shgc', 'transmittance')")
    if weather not in WEATHER_FILES or weather == "drycold":
        raise ValueError(f"weather={weather!r}: the integrator route reads the EPW ('tmy3')")
    w = read_epw(_data_file(WEATHER_FILES[weather], data_dir))
    sky = sky or PragueSky()
    layout, shading = geometry
    b = bestest_building(layout, shading)
    scene, labels = building_scene(b, ground_albedo=GROUND_REFLECTANCE,
                                   samples_per_face=SHADED_SAMPLES_PER_FACE if shading else 1)
    sim = Simulation(scene, weather=w, sky=SKY_DEFAULTS.replace(albedo=GROUND_REFLECTANCE), sky_source=sky,
                     n_jobs=n_jobs, progress=progress)
    units = {c: window_unit(c, data_dir) for c in ("600", "660", "670")}
    flat = np.array([280.0, 2500.0]), np.ones(2)
    if quantity == "shgc":
        responses = [rated_glazing_response(u, *flat, name=u.name) for u in units.values()]
    else:
        responses = [Response(u.name, *flat, unit="weight",
                              angular=AngularTable(ANGLES, u.optics(ANGLES, flat[0])["transmittance"][:, 0]))
                     for u in units.values()]
    res = sim.run(responses)
    order = []
    for az in (0.0, 90.0, 180.0, 270.0):
        order.append(next(i for i, lab in enumerate(labels) if lab.startswith("wall")
                          and abs(b.surfaces[i].azimuth - az) < 1))
    order.append(next(i for i, lab in enumerate(labels) if lab.startswith("roof")))
    irr = irradiance_by_surface(res, [labels[i] for i in order])
    win = [lab for lab in labels if lab.startswith("window")]
    area = np.array([next(s.area for s in b.surfaces if s.label == lab) for lab in win])
    M_win = group_weights(res, win) / result_in_band_share(res)          # rated g (or tau) on broadband light
    irr["window_gain"] = {u.name: res.get(u.name, "global") @ M_win @ (area / area.sum()) for u in units.values()}
    wall_of = [[round(s.azimuth) % 360 for s in b.surfaces if s.label == lab][0] for lab in win]
    irr["window_gain_walls"] = {}
    for u in units.values():
        per = res.get(u.name, "global") @ M_win                              # (T, W) [W m-2 of glass]
        walls, glass = np.zeros((per.shape[0], 5)), np.zeros(5)
        for j, az in enumerate(wall_of):                                    # area-weighted over a wall's windows
            k = (0, 90, 180, 270).index(az)
            walls[:, k] += per[:, j] * area[j]
            glass[k] += area[j]
        irr["window_gain_walls"][u.name] = walls / np.maximum(glass, 1e-12)
    light = irradiance_by_surface(res, win)                                 # (T, W) on each window's faces
    wl = {k: np.zeros((len(res.times), 5)) for k in ("direct", "diffuse", "aoi")}
    glass = np.zeros(5)
    for j, az in enumerate(wall_of):
        k = (0, 90, 180, 270).index(az)
        wl["direct"][:, k] += light["poa_direct"][:, j] * area[j]
        wl["diffuse"][:, k] += (light["poa_sky_diffuse"][:, j] + light["poa_ground_diffuse"][:, j]) * area[j]
        wl["aoi"][:, k] += light["aoi"][:, j] * area[j]
        glass[k] += area[j]
    irr["window_light_walls"] = {k: v / np.maximum(glass, 1e-12) for k, v in wl.items()}
    irr["result"] = res
    irr["geometry"] = (layout, shading)
    return irr


def iso52016_elements(case: BestestCase, data_dir=None, hourly_gaps=True):
    """The case's construction elements for :func:`~widesky.thermal.zone_iso52016.simulate_iso52016`:
    N, E, S, W walls (opaque areas), roof, floor (its outside facing outdoor air, no sun: the raised
    floor of the detailed models), one window per glazed wall; layers from the detailed models' records
    (Case 600FF's, or Case 900's wall and floor); windows 2 m high (140-2020's 3 m x 2 m); the window's
    surface-to-surface resistance from its EN 673
    gaps (:meth:`~widesky.thermal.glazing.GlazingUnit.gap_conductances`) and the panes' conduction."""
    ff = _data_file("bestest/detailed_Cases6xx_Case600FF.mo", data_dir)
    if case.spec.mass == "900":
        wall = construction_layers(_data_file("bestest/detailed_Data_ExteriorWallCase900.mo", data_dir))
        floor = construction_layers(_data_file("bestest/detailed_Data_FloorCase900.mo", data_dir))
    else:
        wall, floor = construction_layers(ff, "matExtWal"), construction_layers(ff, "matFlo")
    roof = construction_layers(ff, "roof")
    names = {0: "north", 90: "east", 180: "south", 270: "west"}
    els = [Element(f"wall {names.get(round(az), az)}", "wall", a, 90.0, wall, absorptance=case.absorptance,
                   emissivity=case.emissivity) for az, a, _ in case.walls]
    els.append(Element("roof", "roof", case.roof_area, 0.0, roof, absorptance=case.absorptance,
                       emissivity=case.emissivity))
    els.append(Element("floor", "floor", case.zone.floor_area, 180.0, floor, exposed=False))
    unit = case.window
    r_panes = sum(lay.thickness_mm * 1e-3 / lay.conductivity for lay in unit.layers)
    gaps = ()
    if hourly_gaps:               # EN 673's gas conduction, its radiation at the hour's gap temperature
        eff = [1.0 / (1.0 / a.emissivity_back + 1.0 / b.emissivity_front - 1.0)
               for a, b in zip(unit.layers[:-1], unit.layers[1:])]
        gaps = tuple((float(h - 4 * SIGMA * e * EN673_MEAN_TEMPERATURE ** 3), e)
                     for h, e in zip(unit.gap_conductances(), eff))
    else:
        r_panes += float(np.sum(1.0 / unit.gap_conductances()))
    eps = case.window.layers[0].emissivity_front
    for az, _, aw in case.walls:
        if aw > 0:
            els.append(Element(f"window {names.get(round(az), az)}", "window", aw, 90.0, resistance=r_panes,
                               gaps=gaps, emissivity=eps, height=WINDOW["height"]))
    return els


def interior_solar_distribution(case: BestestCase, elements):
    """(E,) share of the transmitted solar on each element's inside surface [1] from
    :data:`INTERIOR_SOLAR_DISTRIBUTION` (the case's window layout), normalised over the surfaces (the share
    that leaves through the windows is taken off by :func:`solar_escape_fraction`); windows get none."""
    table = INTERIOR_SOLAR_DISTRIBUTION[case.spec.layout]
    names = {"wall north": "north", "wall east": "east", "wall south": "south", "wall west": "west",
             "roof": "ceiling", "floor": "floor"}
    share = np.array([table.get(names.get(el.name, ""), 0.0) for el in elements])
    return share / share.sum()


def interior_longwave(case: BestestCase, elements):
    """(E, E) long-wave exchange conductances between the elements' inside surfaces [W K-1]
    (:func:`~widesky.thermal.zone_iso52016.radiant_exchange`): the view factors of the 8 m x 6 m x 2.7 m box
    (:func:`~widesky.thermal.zone_iso52016.box_view_factors`), a wall's share split between its opaque part and its
    window by area (coplanar: no view), emissivity 0.9 of the opaque surfaces (ASHRAE 140-2020 7.2.1: interior
    infrared emissivity) and the glass's own (the records' absIR_b), linearised at 20 degC."""
    faces = ("floor", "ceiling", "north", "east", "south", "west")
    F6 = box_view_factors(*ROOM)
    face = [("ceiling" if el.kind == "roof" else "floor" if el.kind == "floor" else el.name.split()[-1])
            for el in elements]
    area = np.array([el.area for el in elements])
    idx = np.array([faces.index(f) for f in face])
    gross = np.array([area[idx == k].sum() for k in range(6)])
    F = F6[idx][:, idx] * (area / gross[idx])[None, :]
    eps_glass = case.window.layers[-1].emissivity_back
    eps = np.array([eps_glass if el.kind == "window" else INTERIOR_EMISSIVITY for el in elements])
    return radiant_exchange(area, F, eps)


ISO52016_OPTIONS = {"solar": ("ashrae140", "area"), "convection": ("tarp-iso15099", "direction", "fixed", "tarp"),
                    "gaps": ("hourly", "en673"), "substeps": (12, 4, 1, 2, 6, 30, 60), "longwave": ("star", "view"),
                    "glass": ("g", "panes"), "lost": ("enclosure", "table", "transmitted"),
                    "air": ("sea_level", "site"), "iterate": (0, 1, 2, 3, 5, 10, 20),
                    "exterior": ("iso6946", "doe2"), "longwave_out": ("iso6946", "energyplus")}
"""Choices of the ISO 52016-1 run (first: the default): where the transmitted solar lands
(:data:`INTERIOR_SOLAR_DISTRIBUTION` or by opaque area), the inside convection (``"tarp-iso15099"``, the default
since the fifth pass: EnergyPlus's default inside model as EnergyPlus applies it, Walton's TARP correlations on the
opaque surfaces and ISO 15099's on the windows, 2 m high, at the weather file's station pressure; ``"direction"``:
ISO 52016-1 Table 25 with floor and ceiling by the heat flow's direction, the default before; ``"fixed"``: Table 25
by kind; ``"tarp"``: Walton's on every surface, windows included), the windows' gap conductance (at the hour's
temperature, or EN 673's) and the sub-steps per hour (12: 5-min implicit steps with the weather's instantaneous
values interpolated, the Case 640/940 set-point ramp followed within its hour (:func:`setback_substeps`) and the
hourly means reported, the default since the eighth pass: implicit Euler is first order and 15-min steps (4, the
default before) left up to 0.42 K and 0.15 kW against the step-converged figures, 5-min steps 0.14 K and 0.05 kW
with every verdict the converged one's; 1: one step an hour, the Case 640 ramp hour at its mean 15 degC, the
results at the hour's end) and ``iterate``, the re-solves per sub-step (0: h_ci from the previous sub-step's
temperatures, as EnergyPlus
evaluates its inside coefficients once per zone time step, from the previous step's inside surface temperatures
(``InitSurfaceHeatBalance`` -> ``InitInteriorConvectionCoeffs``); N > 0: re-evaluated at the sub-step's own
temperatures and re-solved, at most N times or until no h_ci moves by over 1e-3 W m-2 K-1, 8 solves at most in the
BESTEST cases: measured in the sixth pass, 2.8x the run time, not the default). The alternatives measured and not kept (docs/validation/thermal-bestest-cases.md,
hypothesis table): ``longwave="view"`` (:func:`interior_longwave`, view factors and script-F instead of ISO 52016-1's
area-weighted star), ``glass="panes"`` (:func:`_window_panes`: the solar absorbed in the panes on the window's
nodes, only the transmitted part spread by the table), ``lost="table"`` (the table's 0.035 lost back out through
the windows instead of the enclosure formula's 0.028), ``lost="transmitted"`` (the enclosure formula's share taken
off the transmitted light only, ``tau_d / g_d`` of the g-value gain, not off the absorbed part that flows in as heat:
:func:`lost_share`) and ``air="site"`` (the air node's rho c at the site's density, 0.828 of 1200 J m-3 K-1).
The outside surfaces (issue 38, seventh pass): ``exterior`` the outside convection, ``"iso6946"`` ISO 6946:2017 Annex
C's ``4 + 4 v`` or ``"doe2"`` EnergyPlus's default DOE-2 model as EnergyPlus applies it
(:func:`~widesky.thermal.exterior.doe2_convection`: Walton's natural part at the previous sub-step's outside
surface-air difference, MoWiTT's forced part windward or leeward by the hour's wind direction against the surface's
azimuth, the roughness multiplier of the case files' ``Rough`` 1.67 on the opaque surfaces and of ``VerySmooth`` 1.0
on the glass, the wind at each surface's centroid, walls 1.35 m, windows 1.2 m, roof 2.7 m, by EnergyPlus's profile
with the site's terrain as the station's, open country, as the Standard's unobstructed site at the station; the
raised floor's underside at zero wind); ``longwave_out`` the outside long-wave exchange, ``"iso6946"``
``eps 4 sigma T_air^3`` with the sky's share (1 + cos tilt) / 2 or ``"energyplus"`` EnergyPlus's sky, air and ground
split linearised at the previous sub-step's surface temperature
(:func:`~widesky.thermal.exterior.energyplus_longwave`)."""


def parse_iso52016_option(text):
    """``"KEY=VALUE"`` -> (key, value) of :data:`ISO52016_OPTIONS` (the value in its own type, e.g. ``4`` for
    ``substeps=4``); ValueError naming the text and what is valid otherwise."""
    key, eq, value = str(text).partition("=")
    if not eq or key not in ISO52016_OPTIONS:
        raise ValueError(f"{text!r}: expected KEY=VALUE with KEY one of {', '.join(ISO52016_OPTIONS)}")
    choices = ISO52016_OPTIONS[key]
    for c in choices:
        if str(c) == value:
            return key, c
    raise ValueError(f"{text!r}: {key} must be one of {', '.join(map(str, choices))}")


def lost_share(case: BestestCase, lost="enclosure"):
    """(lost, esc): the share of the window's g-value gain [1] that the ISO 52016-1 run takes off as lost back out
    through the windows (``lost``: a choice of :data:`ISO52016_OPTIONS`), and the share :func:`case_gains` took off
    (the enclosure formula :func:`solar_escape_fraction`, on the whole g-value gain). ``"enclosure"``: the same;
    ``"table"``: :data:`INTERIOR_SOLAR_DISTRIBUTION`'s lost share; ``"transmitted"``: the enclosure formula's share
    of the transmitted light only, ``esc tau_d / g_d`` (hemispherical; the inward-flowing absorbed part of g is heat
    from the panes, which no reflection sends back out)."""
    _, _, g_d, tau_d = _window_g(case.window)
    esc = solar_escape_fraction(tau_d, case.window_area, case.interior_area, INTERIOR_SOLAR_ABSORPTANCE)
    if lost == "table":
        return INTERIOR_SOLAR_DISTRIBUTION[case.spec.layout]["lost"], esc
    if lost == "transmitted":
        return esc * tau_d / g_d, esc
    if lost != "enclosure":
        raise ValueError(f"lost={lost!r} not one of {ISO52016_OPTIONS['lost']}")
    return esc, esc


def _window_panes(c: BestestCase, elements, g_gain, poa_global, lost):
    """The window gain of :func:`case_gains` (g: transmitted plus the inward-flowing part of the absorbed) split
    into the transmitted light, which the room's surfaces absorb (less the share that leaves again), and the solar
    absorbed in each pane, put on the window's outer (first pane) and inner (last pane) surface node, whose flow
    inward the zone's own network then decides. ``g_gain`` (T,) [W]: the g-value gain before any loss back out;
    ``lost`` [1]: the transmitted share lost back out. Returns ``solar_in`` (T,) [W] and ``surface_gains`` (T, E, 2)
    [W].
    The split uses the unit's hemispherical transmittance and per-pane absorptance over its g (EN 410 layer model,
    flat spectrum as the records are broadband); a single pane's absorbed solar goes half to each face. Windows
    share it by area times their wall's incident irradiance."""
    flat = np.array([280.0, 2500.0]), np.ones(2)
    o = c.window.optics(ANGLES, flat[0])
    t_d = float(hemispherical(ANGLES, o["transmittance"][:, 0]))
    a_d = np.array([float(hemispherical(ANGLES, a[:, 0])) for a in o["absorbed"]])
    g_d = float(hemispherical(ANGLES, o["shgc"][:, 0]))
    solar_in = g_gain * t_d / g_d * (1 - lost)
    absorbed = g_gain[:, None] * a_d[None, :] / g_d         # (T, panes) [W]
    out, inn = (absorbed[:, 0], absorbed[:, -1]) if len(a_d) > 1 else (0.5 * absorbed[:, 0], 0.5 * absorbed[:, 0])
    T, E = len(g_gain), len(elements)
    sg = np.zeros((T, E, 2))
    wins = [i for i, el in enumerate(elements) if el.kind == "window"]
    names = ["north", "east", "south", "west"]
    weight = np.stack([elements[i].area * poa_global[:, names.index(elements[i].name.split()[-1])]
                       for i in wins], 1)
    share = weight / np.maximum(weight.sum(1, keepdims=True), 1e-9)
    for k, i in enumerate(wins):
        sg[:, i, 0] = out * share[:, k]
        sg[:, i, 1] = inn * share[:, k]
    return solar_in, sg


def _run_iso52016(c, weather, gains, heat, cool, h_ve, warmup_steps, data_dir, options=None):
    opt = {k: v[0] for k, v in ISO52016_OPTIONS.items()}
    for k, v in (options or {}).items():
        if k not in ISO52016_OPTIONS or v not in ISO52016_OPTIONS[k]:
            raise ValueError(f"iso52016 option {k}={v!r} not one of {ISO52016_OPTIONS}")
        opt[k] = v
    els = iso52016_elements(c, data_dir, hourly_gaps=opt["gaps"] == "hourly")
    dist = interior_solar_distribution(c, els) if opt["solar"] == "ashrae140" else None
    lw = interior_longwave(c, els) if opt["longwave"] == "view" else None
    # the share of the transmitted solar lost back out through the windows: case_gains' enclosure formula, or the
    # ASHRAE 140 table's beside its distribution, or the formula's on the transmitted light only (lost_share)
    lost, esc = lost_share(c, "enclosure" if opt["lost"] == "table" and opt["solar"] != "ashrae140" else opt["lost"])
    solar_in, panes = gains["window"] * (1 - lost) / (1 - esc), None
    if opt["glass"] == "panes":                   # _window_panes takes the lost share off the transmitted part itself
        lost = esc if opt["lost"] == "transmitted" else lost
        solar_in, panes = _window_panes(c, els, gains["window"] / (1 - esc), gains["poa_global"], lost)
    # the air node's rho c at the site's density, as the infiltration's (0.5 h-1 -> the case file's airRat)
    rho_c = RHO_C_AIR * (c.air_changes / 0.5 if opt["air"] == "site" else 1.0)
    ta = weather["temp_air"].to_numpy()
    v = weather["wind_speed"].to_numpy()
    n_wall = len(c.walls)
    h_ce, h_re, sol = [], [], []
    doe2 = opt["exterior"] == "doe2"
    if doe2:
        if "wind_direction" not in weather:
            raise ValueError("iso52016 option exterior='doe2' needs the weather's wind_direction column (TMY3 EPW)")
        w_dir = weather["wind_direction"].to_numpy()
        compass = {"north": 0.0, "east": 90.0, "south": 180.0, "west": 270.0}
    for i, el in enumerate(els):
        height = c.height if el.kind == "roof" else 0.5 * c.height
        # the raised floor's underside: outdoor air at zero wind (the case files' conOpa, v = 0, May 2022 revision)
        wind = np.zeros_like(v) if el.kind == "floor" else wind_at_height(v, height)
        hc, hr = exterior_coefficients(wind, ta, el.emissivity)
        if doe2:        # the smooth surface's forced part at the centroid's wind; the step adds Walton's natural part
            z = (c.height if el.kind == "roof" else WINDOW["sill"] + 0.5 * WINDOW["height"] if el.kind == "window"
                 else 0.5 * c.height)
            wind = np.zeros_like(v) if el.kind == "floor" else energyplus_wind_at_height(v, z, "country")
            side = el.name.split()[-1]
            az = compass.get(side, 0.0) if el.kind in ("roof", "floor") or side in compass else float(side)
            hc = mowitt_forced_convection(wind, windward(w_dir, az, np.cos(np.radians(el.tilt))))
        h_ce.append(hc)
        h_re.append(hr)
        sol.append(gains["poa_global"][:, i] if i <= n_wall else np.zeros(len(ta)))
    rough = np.array([ROUGHNESS_MULTIPLIER["very_smooth" if el.kind == "window" else "rough"] for el in els])
    if opt["substeps"] > 1 and c.spec.control == "setback":
        heat = setback_substeps(weather.index, opt["substeps"])
    return simulate_iso52016(els, ta, gains["temp_sky"], np.stack(h_ce, 1), np.stack(h_re, 1),
                             np.stack(sol, 1), solar_in, c.internal_gains, h_ve, heat, cool,
                             volume=c.zone.floor_area * c.height,
                             internal_radiative_fraction=INTERNAL_RADIATIVE_FRACTION,
                             air_capacity_per_volume=rho_c, warmup_steps=warmup_steps,
                             temp_start=20.0, solar_distribution=dist, convection=opt["convection"],
                             substeps=opt["substeps"], longwave=lw, surface_gains=panes, iterate=opt["iterate"],
                             air_pressure=weather["pressure"].to_numpy() if "pressure" in weather else 101325.0,
                             exterior_convection="doe2" if doe2 else "given", roughness=rough,
                             exterior_longwave="energyplus" if opt["longwave_out"] == "energyplus" else "given")


def run_case(case, data_dir=None, weather="tmy3", warmup_steps=24 * 31, g_table=None, poa=None,
             exterior="hourly", zone_model="iso52016", iso52016_options=None, transposition="perez",
             diffuse_optics="angular"):
    """Simulate ASHRAE 140 Case ``case`` for a weather year (hourly, 8760 steps).

    ``weather``: a key of :data:`WEATHER_FILES`, or a (data, site) pair as :func:`load_weather`.
    ``poa``: per-surface irradiance from :func:`integrator_irradiance` (same weather and the
    case's :func:`case_geometry`) instead of the weather-only route, whose transposition is ``transposition``
    (``"perez"``, default, or ``"hay-davies"``, :func:`case_gains`). ``exterior``:
    outside surface coefficients, see :func:`case_gains`. Set-points and ventilation follow the
    case's control (:func:`setpoint_schedules`). ``zone_model``: ``"iso52016"`` (the default: ISO
    52016-1's balance per element, :mod:`widesky.thermal.zone_iso52016`, with the
    layers of :func:`iso52016_elements` and hourly outside coefficients; ``exterior`` then does not apply;
    ``iso52016_options``: choices of :data:`ISO52016_OPTIONS`, by default the first of each; it misses fewer
    figures than 5R1C, docs/thermal.md) or ``"5r1c"`` (ISO 13790's network). ``diffuse_optics``: how the windows
    take the diffuse light (:func:`case_gains`).

    Returns
    -------
    dict
        ``annual_heating``, ``annual_cooling`` [kWh]; ``peak_heating``, ``peak_cooling`` [W] and
        ``peak_heating_time``, ``peak_cooling_time`` (end of the hour); ``temp_min``,
        ``temp_max``, ``temp_mean`` [degC] the zone air's hourly minimum, maximum and annual mean;
        ``hourly``: DataFrame of
        ``heating``, ``cooling`` [W], ``temp_air`` [degC], ``solar_window``, ``solar_opaque``,
        ``sky_loss`` [W] (``attrs["h_ci_change"]``: the ISO 52016-1 run's convergence of its within-step
        iteration, :func:`~widesky.thermal.zone_iso52016.simulate_iso52016`); ``case``: the :class:`BestestCase`.
    """
    c = case if isinstance(case, BestestCase) else case_definition(case, data_dir)
    weather, site = load_weather(weather, data_dir) if isinstance(weather, str) else weather
    gains = case_gains(c, weather, site, g_table, poa, exterior, transposition, diffuse_optics)
    phi_sol = gains["window"] + gains["opaque"] - gains["sky_loss"]
    heat, cool, h_ve = setpoint_schedules(c, weather.index)
    if zone_model not in ZONE_MODELS:
        raise ValueError(f"zone_model={zone_model!r} not one of {ZONE_MODELS}")
    if zone_model == "iso52016":
        r = _run_iso52016(c, weather, gains, heat, cool, h_ve, warmup_steps, data_dir, iso52016_options)
        res = {k: r[k][:, None] for k in ("heating", "cooling", "temp_air")}
        res["h_ci_change"] = r["h_ci_change"]
    else:
        res = simulate_5r1c(c.zone, weather["temp_air"].to_numpy(), c.internal_gains, phi_sol,
                            heat, cool, h_ve=h_ve,
                            internal_convective_fraction=1 - INTERNAL_RADIATIVE_FRACTION,
                            warmup_steps=warmup_steps, h_tr_w=gains["h_tr_w"],
                            h_tr_op=gains["h_tr_op"])
    hourly = pd.DataFrame({"heating": res["heating"][:, 0], "cooling": res["cooling"][:, 0],
                           "temp_air": res["temp_air"][:, 0], "solar_window": gains["window"],
                           "solar_opaque": gains["opaque"], "sky_loss": gains["sky_loss"]},
                          index=weather.index)
    hourly.attrs["h_ci_change"] = tuple(map(float, res.get("h_ci_change", ())))   # ISO 52016-1, iterate > 0
    return {"annual_heating": hourly["heating"].sum() / 1000.0,
            "annual_cooling": hourly["cooling"].sum() / 1000.0,
            "peak_heating": hourly["heating"].max(), "peak_cooling": hourly["cooling"].max(),
            "peak_heating_time": hourly["heating"].idxmax(),
            "peak_cooling_time": hourly["cooling"].idxmax(),
            "annual_incident_south": gains["incident_south"].sum() / 1000.0,
            "temp_min": hourly["temp_air"].min(), "temp_max": hourly["temp_air"].max(),
            "temp_mean": hourly["temp_air"].mean(),
            "hourly": hourly, "case": c}


def run_case_on_route(case, route="weather", transposition="perez", data_dir=None, n_jobs=1, progress=False,
                      poas=None, **model):
    """:func:`run_case` (TMY3) on a sky ``route``: ``"weather"`` (the file transposed by ``transposition``) or
    ``"integrator"`` (:func:`integrator_irradiance` of the case's room geometry, computed once per geometry into
    ``poas``, a dict to share between calls); ``model``: :func:`run_case`'s ``zone_model``, ``exterior``,
    ``iso52016_options`` and ``diffuse_optics``."""
    if route not in ("weather", "integrator"):
        raise ValueError(f"route={route!r} not one of ('weather', 'integrator')")
    poa = None
    if route == "integrator":
        poas = {} if poas is None else poas
        geo = case_geometry(case)
        if geo not in poas:
            poas[geo] = integrator_irradiance("tmy3", data_dir, n_jobs=n_jobs, progress=progress, geometry=geo)
        poa = poas[geo]
    return run_case(case, data_dir, poa=poa, transposition=transposition, **model)
