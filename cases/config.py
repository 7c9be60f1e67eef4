"""Case configuration files (TOML): the schema, and validation with errors that name the key.

A value may be written bare, in the unit the schema gives for its key, or as a string with its unit
(``visibility = "40 km"``); a string in another unit is an error naming the key and the expected unit.
An unknown or mistyped key or section is an error naming the valid keys (and the closest one); a value
out of range or not among the choices is an error naming the range or the choices.
"""

from __future__ import annotations

import difflib
import math
import os
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from widesky import pvsim
from widesky.core.paths import DataNotFoundError, data_reference
from widesky.irradiance.simulation import AEROSOL_SOURCES, GROUND_SPECTRA, SKY_DEFAULTS, SPECTRAL_MODELS
from widesky.pvsim.reference import DEFAULT_REFERENCE, REFERENCE_SPECTRA

from .glazing import GLAZING_CHOICES

__all__ = ["ConfigError", "Field", "SCHEMA", "load_config", "validate"]


class ConfigError(ValueError):
    """A case configuration is invalid; the message names the file, the key and the valid values."""


@dataclass(frozen=True)
class Field:
    """One key of the schema.

    Attributes
    ----------
    kind : str
        ``"float"``, ``"int"``, ``"bool"``, ``"str"``, ``"path"`` (relative to the case folder), ``"time"``
        (ISO 8601 local date-time), ``"list"`` (of str from ``choices``), ``"names"`` (a list of any str),
        ``"weather"`` (a weather file: relative to the case folder, or ``data:<folder>/<file>``, shipped with
        widesky, else in the reference data folder).
    default : object
        Value when the key is absent; ``REQUIRED`` makes it mandatory.
    unit : str
        Unit of a number (``""`` for dimensionless [1]).
    lo, hi : float
        Closed range of a number.
    choices : tuple of str
        Allowed strings (or list items).
    help : str
        What the key means (shown in ``widesky run --schema``).
    """

    kind: str
    default: object = None
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    choices: tuple = ()
    help: str = ""


REQUIRED = object()

_STEP_CHOICES = ("10min", "15min", "30min", "1h")
_VIEWS = ("south-east", "south-west", "north-east", "north-west", "top")

SCHEMA = {
    "case": {
        "title": Field("str", REQUIRED, help="one-line title of the report"),
        "description": Field("str", "", help="what the case shows (a paragraph of the report)"),
    },
    "site": {
        "name": Field("str", "", help="site name"),
        "latitude": Field("float", REQUIRED, "deg", -90.0, 90.0, help="north positive"),
        "longitude": Field("float", REQUIRED, "deg", -180.0, 180.0, help="east positive"),
        "altitude": Field("float", 0.0, "m", -500.0, 9000.0, help="site altitude above sea level"),
        "tz": Field("str", "UTC", help="IANA time zone name (Europe/Prague) or hours east of UTC"),
    },
    "period": {
        "start": Field("time", REQUIRED, help="first interval (local time of site.tz)"),
        "end": Field("time", REQUIRED, help="end of the period, exclusive"),
        "step": Field("str", "1h", choices=_STEP_CHOICES, help="interval length"),
    },
    "sky": {
        "visibility": Field("float", SKY_DEFAULTS.visibility, "km", 20.0, 131.8,
                            help="ground-level visibility of the clear sky (under a weather file: where it gives none)"),
        "albedo": Field("float", SKY_DEFAULTS.albedo, "", 0.0, 1.0,
                        help="ground albedo (under a weather file: where it gives none)"),
        "dataset": Field("path", "", help="Prague Sky Model dataset file (default: the embedded dataset)"),
        "weather": Field("weather", "", help="EPW or TMY3 weather file (a path relative to the case folder, or "
                         "'data:weather/<file>': a weather year shipped in the package, else one in the reference data "
                         "folder WIDESKY_DATA_DIR or ../shared/data): its site, "
                         "measured DNI/DHI scaling the sky, air temperature and wind; default none: the clear sky"),
        "spectral_model": Field("str", SKY_DEFAULTS.spectral_model, choices=SPECTRAL_MODELS,
                                help="under a weather file: 'allsky' spectra (cloud light, haze, vegetated ground; "
                                     "docs/all-sky.md) or 'clear' (clear-sky spectra scaled to the measured DNI/DHI)"),
        "aerosol": Field("str", SKY_DEFAULTS.aerosol, choices=AEROSOL_SOURCES,
                         help="under a weather file: each step's aerosol from its aerosol optical depth where valid "
                              "('aod') or from its station visibility"),
        "use_measured": Field("bool", SKY_DEFAULTS.use_measured,
                              help="under a weather file: scale to its measured DNI/DHI (false: the unscaled clear "
                                   "sky of its steps, an upper bound)"),
        "ground_spectrum": Field("str", SKY_DEFAULTS.ground_spectrum, choices=GROUND_SPECTRA,
                                 help="with the allsky spectral model: the spectrum the ground reflects, green "
                                      "vegetation where the albedo is at most 0.3 and no snow is reported (the "
                                      "weather's broadband albedo kept), or grey (docs/all-sky.md)"),
    },
    "scene": {
        "geometry": Field("path", REQUIRED, help="Python file with build(parameters) -> dict of meshes, or a mesh file"),
        "parameters": Field("table", {}, help="passed to the geometry's build()"),
        "samples_per_face": Field("int", 1, "", 1, 64, help="analysis points per face (a square number)"),
        "two_sided": Field("bool", False, help="also analyse the back of every analysis face"),
        "reflectance": Field("float", 0.2, "", 0.0, 1.0, help="diffuse reflectance of the context geometry"),
    },
    "accuracy": {
        "tolerance": Field("float", 0.02, "", 0.006, 0.5,
                           help="target relative annual error per face: picks the integrator preset"),
    },
    "pv": {
        "technologies": Field("list", ["topcon", "cdte", "cigs"], choices=(), help="cell technologies compared "
                              "(pvsim presets); the section is optional: without it a case computes irradiance only"),
        "temp_air": Field("float", 20.0, "degC", -40.0, 50.0, help="air temperature (constant: clear-sky cases carry "
                          "no weather)"),
        "wind_speed": Field("float", 1.0, "m s-1", 0.0, 30.0, help="wind speed (constant)"),
        "temperature_model": Field("str", "faiman", choices=("faiman", "pvsyst"), help="cell temperature model"),
        "dc_loss": Field("float", 0.02, "", 0.0, 0.5, help="DC losses (wiring, mismatch, soiling)"),
        "reference": Field("str", DEFAULT_REFERENCE, choices=REFERENCE_SPECTRA,
                           help="STC reference spectrum: ASTM G173-03 ('g173', shipped in the package; the default of "
                                "every front end) or the sky model's own AM1.5G ('widesky', removes the dataset's "
                                "spectral bias from the spectral gains)"),
        "groups": Field("names", [], help="the analysis groups that are PV modules (default: every group)"),
    },
    "thermal": {
        "glazing": Field("list", ["clear", "low-e", "solar-control"], choices=GLAZING_CHOICES,
                         help="glazing units compared (each in turn in every window; igdb: units are the "
                              "measured IGDB samples shipped in the package)"),
        "temp_air": Field("float", 24.0, "degC", -40.0, 50.0, help="daily mean air temperature without a weather "
                          "file (a cosine day, warmest at 15:00 local time)"),
        "temp_air_range": Field("float", 10.0, "K", 0.0, 30.0, help="daily range of that air temperature"),
        "internal_gains": Field("float", 10.0, "W m-2", 0.0, 100.0, help="internal gains per m2 of floor (constant; "
                                "schedule = 'constant' only)"),
        "schedule": Field("str", "constant", choices=("constant", "office"),
                          help="internal gains: 'constant' (internal_gains around the clock) or 'office' (people, "
                               "lighting and equipment on the ASHRAE 90.1 User's Manual office profiles, "
                               "thermal.schedules)"),
        "frame_fraction": Field("float", 0.0, "", 0.0, 0.6, help="window frame share of the window area "
                                "(ISO 10077-1: 0.3 typical)"),
        "frame_u": Field("float", 2.0, "W m-2 K-1", 0.3, 8.0, help="frame U-value (ISO 10077-1: PVC with three "
                         "chambers 2.0)"),
        "shading_factor": Field("float", 1.0, "", 0.0, 1.0, help="g of glazing with the shading device deployed / g "
                                "without it (1: no device; ISO 13790 Table 16, exterior white venetian blinds 0.15)"),
        "shading_threshold": Field("float", 200.0, "W m-2", 0.0, 1500.0, help="the device is deployed in occupied "
                                   "hours when the global irradiance on the window exceeds this"),
        "shading_control": Field("str", "solar", choices=("solar", "solar-not-heating"),
                                 help="'solar': the device down whenever the threshold asks; 'solar-not-heating': "
                                      "not while the window's zone heated in the previous hour (it keeps the sun's "
                                      "heat then)"),
        "air_changes": Field("float", 0.7, "h-1", 0.0, 20.0, help="ventilation and infiltration air changes"),
        "heating_setpoint": Field("float", 20.0, "degC", 5.0, 25.0, help="heating set-point (thermostat = 'office': "
                                  "in the thermostat's hours)"),
        "cooling_setpoint": Field("float", 26.0, "degC", 18.0, 35.0, help="cooling set-point (thermostat = 'office': "
                                  "in the thermostat's hours)"),
        "thermostat": Field("str", "constant", choices=("constant", "office"),
                            help="'constant': the set-points every hour; 'office': the set-points on weekdays "
                                 "06:00-22:00 and Saturdays 06:00-18:00, heating_setback and cooling_setup otherwise "
                                 "(the DOE reference office's thermostat hours, thermal.schedules)"),
        "heating_setback": Field("float", 15.6, "degC", 5.0, 25.0, help="heating set-point outside the thermostat's "
                                 "hours (thermostat = 'office'; the DOE reference office's 15.6)"),
        "cooling_setup": Field("float", 26.7, "degC", 18.0, 40.0, help="cooling set-point outside the thermostat's "
                               "hours (thermostat = 'office'; the DOE reference office's 26.7)"),
        "wall_u": Field("float", 0.35, "W m-2 K-1", 0.05, 5.0, help="opaque wall U-value"),
        "roof_u": Field("float", 0.25, "W m-2 K-1", 0.05, 5.0, help="roof U-value"),
        "floor_u": Field("float", 0.35, "W m-2 K-1", 0.05, 5.0, help="ground floor U-value (b = 0.5 to outdoor air)"),
        "mass": Field("str", "medium", choices=("very light", "light", "medium", "heavy", "very heavy"),
                      help="ISO 13790 heat capacity class"),
    },
    "compare": {
        "sites": Field("sites", REQUIRED, help="other sites to run the same case at: a list of tables with the "
                       "[site] keys (name, latitude, longitude, altitude, tz) and, when [sky] names a weather file, "
                       "each its own weather file (weather = ...); the [site] section is the first"),
    },
    "report": {
        "sky_time": Field("time", REQUIRED, help="the hour whose sky is rendered (spectral EXR and PNG)"),
        "views": Field("list", ["south-west", "top"], choices=_VIEWS, help="scene renders coloured by irradiance"),
        "render_size": Field("int", 720, "pixels", 128, 2048, help="width of the scene renders"),
    },
}

# sections that are filled with defaults only when the file has them
OPTIONAL_SECTIONS = ("pv", "compare", "thermal")


def _technology_choices():
    return tuple(pvsim.technology_names())


_NUM_UNIT = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([^\d\s].*?)?\s*$")


def _suggest(key, valid):
    """The closest valid name (similarity, ties and near-ties broken by a shared beginning), if any is close."""
    def score(v):
        prefix = len(os.path.commonprefix([key.lower(), v.lower()]))
        return difflib.SequenceMatcher(None, key.lower(), v.lower()).ratio() + 0.2 * prefix
    best = max(valid, key=score, default=None)
    return f" (did you mean '{best}'?)" if best is not None and score(best) >= 0.6 else ""


def _number(where, f: Field, raw):
    if isinstance(raw, bool):
        raise ConfigError(f"{where} = {raw!r}: expected a number{_unit_text(f)}")
    if isinstance(raw, str):
        m = _NUM_UNIT.match(raw)
        if not m:
            raise ConfigError(f"{where} = {raw!r}: expected a number{_unit_text(f)}")
        unit = (m.group(2) or "").strip()
        if unit != f.unit and not (unit in ("", "1") and f.unit == ""):
            raise ConfigError(f"{where} = {raw!r}: unit {unit or '(none)'!r} is not valid here; "
                              f"expected {f.unit or 'a dimensionless number'}" + (f" (e.g. '{f.lo:g} {f.unit}')" if f.unit else ""))
        value = float(m.group(1))
    elif isinstance(raw, (int, float)):
        value = float(raw)
    else:
        raise ConfigError(f"{where} = {raw!r}: expected a number{_unit_text(f)}")
    if f.kind == "int":
        if value != int(value):
            raise ConfigError(f"{where} = {raw!r}: expected an integer")
        value = int(value)
    if (f.lo is not None and value < f.lo) or (f.hi is not None and value > f.hi):
        u = f" {f.unit}" if f.unit else ""
        raise ConfigError(f"{where} = {raw!r} outside the valid range [{f.lo:g}, {f.hi:g}]{u}")
    return value


def _unit_text(f):
    return f" in {f.unit}" if f.unit else ""


def _finite_numbers(where, raw):
    """Refuse nan and inf anywhere in a free-form table (TOML has them; no geometry parameter means them): named by
    its key, before the geometry script turns it into a mesh with non-finite vertices."""
    items = raw.items() if isinstance(raw, dict) else enumerate(raw) if isinstance(raw, list) else ()
    for key, value in items:
        name = f"{where}.{key}" if isinstance(raw, dict) else f"{where}[{key}]"
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(f"{name} = {value}: expected a finite number")
        _finite_numbers(name, value)


def _value(where, f: Field, raw, folder: Path):
    if f.kind in ("float", "int"):
        return _number(where, f, raw)
    if f.kind == "bool":
        if not isinstance(raw, bool):
            raise ConfigError(f"{where} = {raw!r}: expected true or false")
        return raw
    if f.kind == "sites":
        if not isinstance(raw, list) or not raw or not all(isinstance(x, dict) for x in raw):
            raise ConfigError(f"{where}: expected a list of tables such as "
                              "[{name = \"Madrid\", latitude = 40.4, longitude = -3.7, tz = \"Europe/Madrid\"}]")
        out = []
        keys = {**SCHEMA["site"], "weather": SCHEMA["sky"]["weather"]}
        for i, entry in enumerate(raw):
            item = {}
            for key in entry:
                if key not in keys:
                    raise ConfigError(f"{where}[{i}]: unknown key {key}{_suggest(key, keys)}; valid keys: "
                                      f"{', '.join(keys)}")
            item["weather"] = _value(f"{where}[{i}].weather", keys["weather"], entry.get("weather", ""), folder)
            for key, sf in SCHEMA["site"].items():
                if key in entry:
                    item[key] = _value(f"{where}[{i}].{key}", sf, entry[key], folder)
                elif sf.default is REQUIRED:
                    raise ConfigError(f"{where}[{i}].{key} is required ({sf.help})")
                else:
                    item[key] = sf.default
            out.append(item)
        return out
    if f.kind == "names":
        items = [raw] if isinstance(raw, str) else raw
        if not isinstance(items, list) or not all(isinstance(x, str) and x for x in items):
            raise ConfigError(f"{where} = {raw!r}: expected a list of names")
        return items
    if f.kind == "weather":
        return _weather_path(where, raw, folder)
    if f.kind == "table":
        if not isinstance(raw, dict):
            raise ConfigError(f"{where}: expected a table")
        _finite_numbers(where, raw)
        return dict(raw)
    if f.kind == "list":
        items = [raw] if isinstance(raw, str) else raw
        if not isinstance(items, list) or not all(isinstance(x, str) for x in items):
            raise ConfigError(f"{where} = {raw!r}: expected a list of strings from {', '.join(f.choices)}")
        bad = [x for x in items if x not in f.choices]
        if bad:
            raise ConfigError(f"{where}: {bad[0]!r} is not valid; expected items from {', '.join(f.choices)}")
        return items
    if not isinstance(raw, str):
        raise ConfigError(f"{where} = {raw!r}: expected a string")
    if f.choices and raw not in f.choices:
        raise ConfigError(f"{where} = {raw!r}: expected one of {', '.join(f.choices)}{_suggest(raw, f.choices)}")
    if f.kind == "path":
        if not raw:
            return None
        p = (folder / raw).resolve()
        if not p.exists():
            raise ConfigError(f"{where} = {raw!r}: no such file {p}")
        return p
    if f.kind == "time":
        try:
            t = pd.Timestamp(raw)
        except (ValueError, TypeError):
            t = pd.NaT
        if t is pd.NaT:
            raise ConfigError(f"{where} = {raw!r}: expected an ISO 8601 date or date-time, e.g. 2024-06-21T12:00")
        if t.tzinfo is not None:
            raise ConfigError(f"{where} = {raw!r}: give local time without an offset (site.tz sets the zone)")
        return t
    return raw


def _weather_path(where, raw, folder):
    """A weather file: '' -> None; 'data:<relative>' shipped in the package, else in the reference data folder; else
    relative to the case folder."""
    if not isinstance(raw, str):
        raise ConfigError(f"{where} = {raw!r}: expected a file name")
    if not raw:
        return None
    if raw.startswith("data:"):
        try:
            return data_reference(raw)
        except DataNotFoundError as exc:
            raise ConfigError(f"{where} = {exc} (set WIDESKY_DATA_DIR, or remove the key for the clear sky)") from None
        except ValueError as exc:
            raise ConfigError(f"{where} = {raw!r}: {exc}") from None
    p = (folder / raw).expanduser().resolve()
    if not p.is_file():
        raise ConfigError(f"{where} = {raw!r}: no such file {p}")
    return p


def validate(data: dict, folder, source="case.toml") -> dict:
    """Check a parsed configuration against :data:`SCHEMA` and fill defaults.

    Returns a dict section -> key -> converted value (numbers in the schema's units, paths resolved
    against ``folder``, times as naive local ``pandas.Timestamp``).

    Raises
    ------
    ConfigError
        Naming ``source``, the section and key, and the valid keys, range, unit or choices.
    """
    folder = Path(folder)
    out = {}
    for section in data:
        if section not in SCHEMA:
            raise ConfigError(f"{source}: unknown section [{section}]{_suggest(section, SCHEMA)}; "
                              f"valid sections: {', '.join(SCHEMA)}")
        if not isinstance(data[section], dict):
            raise ConfigError(f"{source}: {section} must be a section [{section}], not a value")
    for section, fields in SCHEMA.items():
        if section in OPTIONAL_SECTIONS and section not in data:
            out[section] = None
            continue
        given = data.get(section, {})
        for key in given:
            if key not in fields:
                raise ConfigError(f"{source}: unknown key {section}.{key}{_suggest(key, fields)}; "
                                  f"valid keys in [{section}]: {', '.join(fields)}")
        vals = {}
        for key, f in fields.items():
            where = f"{source}: {section}.{key}"
            if section == "pv" and key == "technologies":
                f = Field(f.kind, f.default, choices=_technology_choices(), help=f.help)
            if key in given:
                vals[key] = _value(where, f, given[key], folder)
            elif f.default is REQUIRED:
                raise ConfigError(f"{where} is required ({f.help})")
            else:
                vals[key] = None if f.kind in ("path", "weather") and not f.default else f.default
        out[section] = vals
    if out["period"]["end"] <= out["period"]["start"]:
        raise ConfigError(f"{source}: period.end = {out['period']['end']} must be after period.start = "
                          f"{out['period']['start']}")
    if out["compare"] is not None:
        with_weather = [s["weather"] is not None for s in out["compare"]["sites"]]
        if any(with_weather) != (out["sky"]["weather"] is not None) or len(set(with_weather)) > 1:
            raise ConfigError(f"{source}: compare.sites: give every site a weather file when [sky] names one "
                              "(sky.weather), and none otherwise (the clear sky at every site)")
    th = out["thermal"]
    if th is not None:
        office = th["thermostat"] == "office"
        stray = [k for k in ("heating_setback", "cooling_setup") if k in data["thermal"] and not office]
        if stray:
            raise ConfigError(f"{source}: thermal.{stray[0]} applies only with thermal.thermostat = 'office' (the "
                              "'constant' thermostat holds the set-points every hour)")
        order = (("heating_setback", "heating_setpoint", "cooling_setpoint", "cooling_setup") if office
                 else ("heating_setpoint", "cooling_setpoint"))
        if any(th[a] > th[b] for a, b in zip(order, order[1:])):
            raise ConfigError(f"{source}: thermal: " + " <= ".join(f"{k} ({th[k]:g} degC)" for k in order)
                              + " does not hold")
    k = int(round(out["scene"]["samples_per_face"] ** 0.5))
    if k * k != out["scene"]["samples_per_face"]:
        raise ConfigError(f"{source}: scene.samples_per_face = {out['scene']['samples_per_face']}: expected a "
                          "square number (1, 4, 9, 16 ...)")
    return out


def load_config(folder) -> dict:
    """Read and validate ``<folder>/case.toml`` (see :func:`validate`)."""
    folder = Path(folder)
    path = folder / "case.toml"
    if not path.is_file():
        raise ConfigError(f"{folder}: no case.toml (a case is a folder with a case.toml)")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    return validate(data, folder, source=str(path))
