"""Weather files: EPW, TMY3 and plain CSV with pvlib column names.

Every reader returns a :class:`WeatherData`: a DataFrame indexed by tz-aware interval labels with
pvlib's column names, the :class:`~irradiance.location.Site` from the file header, the interval label
and step, the header metadata and a report of missing values (missing-value codes become NaN and
are counted per column). Malformed files raise :class:`WeatherFileError` naming the file, line
number and field.

Columns and units (when the file has them):

=====================  =========  ==========================================================
ghi, dni, dhi          [W m-2]    global horizontal, direct normal, diffuse horizontal (interval means)
ghi_extra, dni_extra   [W m-2]    extraterrestrial horizontal / normal irradiance
temp_air, temp_dew     [degC]     dry-bulb and dew-point temperature
relative_humidity      [%]
pressure               [Pa]       station pressure
wind_speed             [m s-1]
wind_direction         [deg]      clockwise from north
total_sky_cover        [tenths]
opaque_sky_cover       [tenths]
visibility             [km]       horizontal visibility (meteorological range)
ceiling_height         [m]
precipitable_water     [cm]       (EPW stores mm; converted)
aod                    [1]        aerosol optical depth as the file gives it (broadband)
albedo                 [1]        ground albedo
snow_depth             [cm]
=====================  =========  ==========================================================
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from .location import LABELS, Site, ensure_tz_aware, fixed_offset_tz, infer_step, sun_times

__all__ = ["WeatherData", "WeatherFileError", "read_epw", "read_tmy3", "read_weather_csv",
           "read_weather", "write_epw", "WEATHER_COLUMNS"]

WEATHER_COLUMNS = ("ghi", "dni", "dhi", "ghi_extra", "dni_extra", "temp_air", "temp_dew",
                   "relative_humidity", "pressure", "wind_speed", "wind_direction", "total_sky_cover",
                   "opaque_sky_cover", "visibility", "ceiling_height", "precipitable_water", "aod",
                   "albedo", "snow_depth")
"""Columns with a defined meaning and unit (see the module docstring)."""


class WeatherFileError(ValueError):
    """A malformed weather file; the message names the file, the line number and the field."""

    def __init__(self, path, line, message):
        self.path, self.line = str(path), line
        where = f"{path}:{line}" if line is not None else str(path)
        super().__init__(f"{where}: {message}")


@dataclass(frozen=True)
class WeatherData:
    """A weather time series with its site.

    Attributes
    ----------
    data : pandas.DataFrame
        Indexed by tz-aware interval labels; pvlib column names (see :data:`WEATHER_COLUMNS`).
    site : Site
        From the file header (latitude [deg], longitude [deg], altitude [m], time zone).
    label : {"left", "right", "center"}
        What each timestamp labels (EPW and TMY3: "right", the end of the hour).
    step : pandas.Timedelta
        Interval length.
    metadata : dict
        Header fields (city, country, source, WMO/USAF id ...).
    missing : dict
        Column -> number of values that were missing codes (now NaN).
    source : str
        Path read.
    """

    data: pd.DataFrame
    site: Site
    label: str
    step: pd.Timedelta
    metadata: dict = field(default_factory=dict)
    missing: dict = field(default_factory=dict)
    source: str = ""

    def sun_times(self) -> pd.DatetimeIndex:
        """Mid-interval instants of the steps (where the sun is evaluated)."""
        return sun_times(self.data.index, self.label, self.step)

    def solar_position(self, **kwargs) -> pd.DataFrame:
        """Mid-interval solar position of every step (:meth:`Site.solar_position`), indexed like
        :attr:`data`. The pressure defaults to the site's standard pressure."""
        return self.site.solar_position(self.data.index, self.label, self.step, **kwargs)

    def summary(self) -> str:
        """A short human-readable description, including the missing-value report."""
        idx = self.data.index
        mixed = len(idx) and not idx.is_monotonic_increasing
        if mixed:          # a typical year: each month from its own year (IWEC, TMY): no span from min to max
            years = pd.Series(idx.year, index=idx.month).groupby(level=0).agg(lambda y: y.mode().iloc[0])
            span = (f"a typical year of months from {idx.year.min()}-{idx.year.max()} ("
                    + ", ".join(f"{pd.Timestamp(2001, m, 1):%b} {y}" for m, y in years.items())
                    + f"); in file order {idx[0]} .. {idx[-1]}")
        else:
            span = f"{idx[0]} .. {idx[-1]}" if len(idx) else ""
        lines = [f"{self.source or 'weather'}: {len(idx)} steps of {self.step}, label={self.label}, {span}"
                 if len(idx) else f"{self.source}: no steps",
                 f"site: lat {self.site.latitude:.4f} deg, lon {self.site.longitude:.4f} deg, "
                 f"alt {self.site.altitude:.1f} m, tz {self.site.tz}, name {self.site.name!r}"]
        miss = {k: v for k, v in self.missing.items() if v}
        lines.append("missing values: " + (", ".join(f"{k}={v}" for k, v in miss.items()) or "none"))
        return "\n".join(lines)


def _float(path, lineno, name, text):
    try:
        v = float(text)
    except ValueError:
        raise WeatherFileError(path, lineno, f"field {name!r}: {text!r} is not a number") from None
    if math.isnan(v) or math.isinf(v):
        raise WeatherFileError(path, lineno, f"field {name!r}: {text!r} is not finite")
    return v


def _int(path, lineno, name, text, lo, hi):
    try:
        v = int(float(text))
    except ValueError:
        raise WeatherFileError(path, lineno, f"field {name!r}: {text!r} is not an integer") from None
    if not lo <= v <= hi:
        raise WeatherFileError(path, lineno, f"field {name!r}={v} outside the valid range [{lo}, {hi}]")
    return v


def _read_lines(path):
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise OSError(f"cannot read weather file {path}: {exc.strerror or exc}") from exc
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    return text.splitlines()


# ----------------------------------------------------------------------------------------------
# EPW (EnergyPlus weather format; EnergyPlus "Auxiliary Programs", chapter "Weather Converter")
# ----------------------------------------------------------------------------------------------
# (column, name, missing-value code or None, scale to our unit). Values >= code are missing.
_EPW_FIELDS = [
    (6, "temp_air", 99.9, 1.0), (7, "temp_dew", 99.9, 1.0), (8, "relative_humidity", 999.0, 1.0),
    (9, "pressure", 999999.0, 1.0), (10, "ghi_extra", 9999.0, 1.0), (11, "dni_extra", 9999.0, 1.0),
    (12, "ghi_infrared", 9999.0, 1.0), (13, "ghi", 9999.0, 1.0), (14, "dni", 9999.0, 1.0),
    (15, "dhi", 9999.0, 1.0), (16, "global_hor_illum", 999999.0, 1.0),
    (17, "direct_normal_illum", 999999.0, 1.0), (18, "diffuse_horizontal_illum", 999999.0, 1.0),
    (19, "zenith_luminance", 9999.0, 1.0), (20, "wind_direction", 999.0, 1.0),
    (21, "wind_speed", 999.0, 1.0), (22, "total_sky_cover", 99.0, 1.0),
    (23, "opaque_sky_cover", 99.0, 1.0), (24, "visibility", 9999.0, 1.0),
    (25, "ceiling_height", 99999.0, 1.0), (28, "precipitable_water", 999.0, 0.1),
    (29, "aod", 0.999, 1.0), (30, "snow_depth", 999.0, 1.0), (32, "albedo", 999.0, 1.0),
    (33, "precipitation", 999.0, 1.0),
]
_EPW_NFIELDS = 35
_EPW_ZERO_AS_MISSING = ("precipitable_water", "aod", "albedo")


def _check_epw_sequence(path, stamps, years, linenos, step):
    """Every record must follow the previous one by exactly ``step``: a duplicated, missing or out-of-order
    record is an error naming its line. A change of the year field (a typical-year file stitches months
    of different years) is accepted where the calendar continues (month, day, hour and minute one step on)."""
    if len(stamps) < 2:
        return
    ok = np.asarray((stamps[1:] - stamps[:-1]) == step)
    for k in np.flatnonzero(~ok & (np.diff(years) != 0)):
        try:  # the previous record taken in the next record's year
            prev = stamps[k].replace(year=int(years[k + 1]))
        except ValueError:  # 29 February in a non-leap year
            continue
        ok[k] = (stamps[k + 1] - prev) == step
    if ok.all():
        return
    k = int(np.flatnonzero(~ok)[0])
    a, b, la, lb = stamps[k], stamps[k + 1], int(linenos[k]), int(linenos[k + 1])
    if b == a:
        problem = f"duplicates the timestamp {b} of line {la}"
    elif b < a:
        problem = f"timestamp {b} comes before line {la}'s {a}: records must be in time order"
    elif np.any(later := (np.arange(len(stamps)) > k + 1) & (years == years[k + 1]) & (stamps < b)):
        j = int(np.flatnonzero(later)[0])
        problem = (f"timestamp {b} is out of time order: line {int(linenos[j])} later in the file has the earlier "
                   f"{stamps[j]}")
    else:
        gap = (b - a) // step - 1
        problem = (f"timestamp {b} follows line {la}'s {a} by {b - a}: {gap} record(s) of the {step} step "
                   "missing")
    raise WeatherFileError(path, lb, f"record {problem}")


# Physical ranges of weather fields that are not missing codes (EnergyPlus "Auxiliary Programs", Weather Converter:
# radiation is >= 0, wind speed 0-40 m s-1, relative humidity 0-110 %); irradiances above 2000 W m-2 exceed any
# measurement (the solar constant is 1361 W m-2; cloud enhancement stays below about 1900 W m-2 at the ground).
_PHYSICAL_RANGES = {"ghi_extra": (0.0, None), "dni_extra": (0.0, None), "ghi_infrared": (0.0, None),
               "ghi": (0.0, 2000.0), "dni": (0.0, 2000.0), "dhi": (0.0, 2000.0), "wind_speed": (0.0, None),
               "relative_humidity": (0.0, 110.0), "visibility": (0.0, None)}


def _check_range(path, name, v, missing, linenos, col=None):
    """Refuse a value of ``name`` outside its physical range (:data:`_PHYSICAL_RANGES`) that is not a missing code,
    naming the file, the line and the field."""
    if name not in _PHYSICAL_RANGES:
        return
    lo, hi = _PHYSICAL_RANGES[name]
    out = ~missing & ((v < lo) | (False if hi is None else v > hi))
    if out.any():
        k = int(np.flatnonzero(out)[0])
        rng = f"[{lo:g}, {hi:g}]" if hi is not None else f">= {lo:g}"
        where = f" (column {col + 1})" if col is not None else ""
        raise WeatherFileError(path, int(linenos[k]), f"field {name!r}{where} = {v[k]:g} outside the valid range {rng}")


def read_epw(path, coerce_year=None, zero_as_missing=_EPW_ZERO_AS_MISSING) -> WeatherData:
    """Read an EnergyPlus weather (EPW) file.

    Parameters
    ----------
    path : str or Path
        The ``.epw`` file.
    coerce_year : int or None
        Replace every record's year with this one (typical-year files mix years). ``None`` keeps
        the years of the file.
    zero_as_missing : tuple of str
        Columns where 0 means "not measured" and becomes NaN (counted in ``missing``). By default
        ``precipitable_water``, ``aod`` and ``albedo``: many files (IWEC among them) fill them with 0,
        which no real atmosphere or ground has. Pass ``()`` to keep zeros.

    Returns
    -------
    WeatherData
        ``label="right"``: the timestamp is the end of the interval (EPW hour 1 is 00:00-01:00
        local standard time). Precipitable water is converted from mm to cm.

    Raises
    ------
    WeatherFileError
        Missing LOCATION or DATA PERIODS header, short records, non-numeric fields or invalid
        dates, each with the line number.
    """
    lines = _read_lines(path)
    meta, per_hour, data_start = {}, 1, None
    for i, line in enumerate(lines[:64]):
        fields = next(csv.reader([line])) if line else [""]
        key = fields[0].strip().upper()
        if key == "LOCATION":
            if len(fields) < 10:
                raise WeatherFileError(path, i + 1, f"LOCATION has {len(fields)} fields, expected 10")
            meta.update(city=fields[1].strip(), state=fields[2].strip(), country=fields[3].strip(),
                        data_source=fields[4].strip(), wmo=fields[5].strip())
            meta["latitude"] = _float(path, i + 1, "latitude", fields[6])
            meta["longitude"] = _float(path, i + 1, "longitude", fields[7])
            meta["tz_offset"] = _float(path, i + 1, "time zone", fields[8])
            meta["altitude"] = _float(path, i + 1, "elevation", fields[9])
        elif key == "DATA PERIODS":
            if len(fields) < 3:
                raise WeatherFileError(path, i + 1, "DATA PERIODS lacks the records-per-hour field")
            per_hour = _int(path, i + 1, "records per hour", fields[2], 1, 60)
            if 60 % per_hour:
                raise WeatherFileError(path, i + 1, f"records per hour={per_hour} does not divide 60")
            data_start = i + 1
            break
    if "latitude" not in meta:
        raise WeatherFileError(path, None, "no LOCATION header line: not an EPW file?")
    if data_start is None:
        raise WeatherFileError(path, None, "no DATA PERIODS header line within the first 64 lines")

    recs = [(i + 1, lines[i].split(",")) for i in range(data_start, len(lines)) if lines[i].strip()]
    if not recs:
        raise WeatherFileError(path, None, "no data records after DATA PERIODS")
    for lineno, fields in recs:
        if len(fields) < _EPW_NFIELDS:
            raise WeatherFileError(path, lineno, f"record has {len(fields)} fields, expected {_EPW_NFIELDS}")
    cols = [c for c, _, _, _ in _EPW_FIELDS]
    try:  # fast path; on failure, find and report the first bad line
        when = np.array([f[:5] for _, f in recs], dtype=float)
        values = np.array([[f[c] for c in cols] for _, f in recs], dtype=float)
        if not (np.all(np.isfinite(values)) and np.all(np.isfinite(when))):
            raise ValueError
    except ValueError:
        for lineno, fields in recs:
            for j, name in enumerate(("year", "month", "day", "hour", "minute")):
                _float(path, lineno, name, fields[j])
            for col, name, _, _ in _EPW_FIELDS:
                _float(path, lineno, name, fields[col])
        raise  # pragma: no cover (the loop above always finds the bad field)
    linenos = np.array([n for n, _ in recs])
    for j, (name, lo, hi) in enumerate((("year", 1678, 2261), ("month", 1, 12), ("day", 1, 31),
                                        ("hour", 1, 24), ("minute", 0, 60))):
        bad = (when[:, j] < lo) | (when[:, j] > hi) | (when[:, j] != np.round(when[:, j]))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise WeatherFileError(path, int(linenos[k]), f"field {name!r}={recs[k][1][j]} outside "
                                                          f"the valid range [{lo}, {hi}]")
    when = when.astype(np.int64)
    if coerce_year is not None:
        when[:, 0] = int(coerce_year)
    dates = pd.to_datetime(pd.DataFrame({"year": when[:, 0], "month": when[:, 1], "day": when[:, 2]}),
                           errors="coerce")
    if dates.isna().any():
        k = int(np.flatnonzero(dates.isna().to_numpy())[0])
        raise WeatherFileError(path, int(linenos[k]), f"invalid date {when[k, 0]}-{when[k, 1]}-{when[k, 2]}")
    if per_hour == 1:
        offset = pd.to_timedelta(when[:, 3], unit="h")
    else:
        offset = pd.to_timedelta(when[:, 3] - 1, unit="h") + pd.to_timedelta(when[:, 4], unit="min")
    stamps = pd.DatetimeIndex(dates) + offset
    _check_epw_sequence(path, stamps, when[:, 0], linenos, pd.Timedelta(minutes=60 // per_hour))
    missing = {}
    columns = {}
    for j, (_, name, code, scale) in enumerate(_EPW_FIELDS):
        v = values[:, j]
        bad = v >= code - 1e-9 if code >= 1 else np.isclose(v, code) | (v >= 999.0)
        _check_range(path, name, v, bad, linenos, _EPW_FIELDS[j][0])
        if name in zero_as_missing:
            bad |= v == 0.0
        missing[name] = int(bad.sum())
        columns[name] = np.where(bad, np.nan, v * scale)
    tz = fixed_offset_tz(meta["tz_offset"])
    index = stamps.tz_localize(tz)
    data = pd.DataFrame(columns, index=index)
    name = ", ".join(p for p in (meta["city"], meta["country"]) if p and p != "-")
    site = Site(meta["latitude"], meta["longitude"], meta["altitude"], tz, name)
    return WeatherData(data, site, "right", pd.Timedelta(minutes=60 // per_hour), meta, missing, str(path))


def _fmt(v, code, digits):
    return f"{code:g}" if not np.isfinite(v) else f"{v:.{digits}f}"


def write_epw(path, data: pd.DataFrame, site: Site, label="right", comment="", source="widesky"):
    """Write an hourly EPW file from pvlib-named columns (inverse of :func:`read_epw`).

    Parameters
    ----------
    path : str or Path
        Output file.
    data : pandas.DataFrame
        Hourly rows on a tz-aware index labelled per ``label``; columns among
        :data:`WEATHER_COLUMNS` (missing columns and NaN are written as EPW missing-value codes;
        precipitable_water [cm] is written in mm).
    site : Site
        Written to the LOCATION line; its time zone must be a fixed offset (EPW files use local
        standard time) and the data are converted to it.
    label : {"left", "right", "center"}
        What the index labels; EPW records are stamped with the interval end.
    comment : str
        Text for the COMMENTS 1 line.
    source : str
        Data source field of the LOCATION line.
    """
    idx = ensure_tz_aware(data.index, name="data.index")
    if label not in LABELS:
        raise ValueError(f"label={label!r} is not one of {LABELS}")
    off = pd.Timestamp("2001-01-01", tz=site.tz).utcoffset()
    if off is None or (pd.Timestamp("2001-07-01", tz=site.tz).utcoffset() != off):
        raise ValueError(f"site.tz={site.tz!r} must be a fixed offset for EPW (local standard time)")
    step = infer_step(idx) if len(idx) > 1 else pd.Timedelta("1h")
    if step != pd.Timedelta("1h"):
        raise ValueError(f"write_epw writes hourly data; the index step is {step}")
    ends = {"right": idx, "left": idx + step, "center": idx + step / 2}[label].tz_convert(site.tz)
    hours = off.total_seconds() / 3600.0
    out = io.StringIO()
    city = (site.name or "widesky site").replace(",", " ")
    out.write(f"LOCATION,{city},-,-,{source},000000,{site.latitude:.4f},{site.longitude:.4f},"
              f"{hours:g},{site.altitude:.1f}\n")
    out.write("DESIGN CONDITIONS,0\nTYPICAL/EXTREME PERIODS,0\nGROUND TEMPERATURES,0\n")
    out.write("HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0\n")
    out.write(f"COMMENTS 1,{comment.replace(chr(10), ' ')}\nCOMMENTS 2,\n")
    first, last = ends[0] - step, ends[-1] - step
    out.write(f"DATA PERIODS,1,1,Data,{first.day_name()},{first.month:2d}/{first.day:2d},"
              f"{last.month:2d}/{last.day:2d}\n")
    cols = {name: (data[name].to_numpy(dtype=float) if name in data else np.full(len(idx), np.nan))
            for _, name, _, _ in _EPW_FIELDS}
    for k, end in enumerate(ends):
        start = end - step  # the EPW date is that of the interval start; hour 24 ends at midnight
        rec = [str(start.year), str(start.month), str(start.day), str(start.hour + 1), "60",
               "?9?9?9?9E0?9?9?9?9?9?9?9?9?9?9?9?9?9?9?9*9*9?9?9?9"]
        vals = {}
        for _, name, code, scale in _EPW_FIELDS:
            v = cols[name][k] / scale
            vals[name] = _fmt(v, code, 3 if name in ("aod", "albedo") else 1)
        order = [name for _, name, _, _ in _EPW_FIELDS]
        rec += [vals[n] for n in order[:20]]  # columns 6..25
        rec += ["9", "999999999"]  # present weather observation and codes
        rec += [vals["precipitable_water"], vals["aod"], vals["snow_depth"], "99", vals["albedo"],
                vals["precipitation"], "99"]
        out.write(",".join(rec) + "\n")
    Path(path).write_text(out.getvalue(), encoding="ascii")


# ----------------------------------------------------------------------------------------------
# TMY3 (Wilcox & Marion 2008, "Users Manual for TMY3 Data Sets", NREL/TP-581-43156)
# ----------------------------------------------------------------------------------------------
_TMY3_FIELDS = {  # header name -> (our name, scale to our unit)
    "ETR (W/m^2)": ("ghi_extra", 1.0), "ETRN (W/m^2)": ("dni_extra", 1.0),
    "GHI (W/m^2)": ("ghi", 1.0), "DNI (W/m^2)": ("dni", 1.0), "DHI (W/m^2)": ("dhi", 1.0),
    "TotCld (tenths)": ("total_sky_cover", 1.0), "OpqCld (tenths)": ("opaque_sky_cover", 1.0),
    "Dry-bulb (C)": ("temp_air", 1.0), "Dew-point (C)": ("temp_dew", 1.0),
    "RHum (%)": ("relative_humidity", 1.0), "Pressure (mbar)": ("pressure", 100.0),
    "Wdir (degrees)": ("wind_direction", 1.0), "Wspd (m/s)": ("wind_speed", 1.0),
    "Hvis (m)": ("visibility", 1e-3), "CeilHgt (m)": ("ceiling_height", 1.0),
    "Pwat (cm)": ("precipitable_water", 1.0), "AOD (unitless)": ("aod", 1.0),
    "Alb (unitless)": ("albedo", 1.0), "Lprecip depth (mm)": ("precipitation", 1.0),
}
_TMY3_MISSING = (-9900.0, -9999.0)


def read_tmy3(path, coerce_year=None) -> WeatherData:
    """Read an NREL TMY3 CSV file.

    Parameters
    ----------
    path : str or Path
        The file: line 1 is the station header (USAF, name, state, time zone [h], latitude [deg],
        longitude [deg], elevation [m]), line 2 the column names, then one line per hour
        ("MM/DD/YYYY,HH:MM,...", 01:00 to 24:00 local standard time).
    coerce_year : int or None
        Replace every record's year with this one.

    Returns
    -------
    WeatherData
        ``label="right"``; pressure converted from mbar to Pa, visibility from m to km. Values
        -9900 and -9999 become NaN.
    """
    lines = _read_lines(path)
    if len(lines) < 3:
        raise WeatherFileError(path, None, f"{len(lines)} lines; a TMY3 file has 2 header lines and data")
    head = next(csv.reader([lines[0]]))
    if len(head) < 7:
        raise WeatherFileError(path, 1, f"station header has {len(head)} fields, expected 7")
    meta = {"usaf": head[0].strip(), "city": head[1].strip(), "state": head[2].strip()}
    meta["tz_offset"] = _float(path, 1, "time zone", head[3])
    meta["latitude"] = _float(path, 1, "latitude", head[4])
    meta["longitude"] = _float(path, 1, "longitude", head[5])
    meta["altitude"] = _float(path, 1, "elevation", head[6])
    names = [c.strip() for c in next(csv.reader([lines[1]]))]
    if len(names) < 2 or not names[0].startswith("Date") or not names[1].startswith("Time"):
        raise WeatherFileError(path, 2, f"column header starts {names[:2]}, expected Date, Time")
    wanted = [(j, *_TMY3_FIELDS[n]) for j, n in enumerate(names) if n in _TMY3_FIELDS]
    stamps, rows, linenos = [], [], []
    for i in range(2, len(lines)):
        if not lines[i].strip():
            continue
        lineno = i + 1
        fields = lines[i].split(",")
        if len(fields) < len(names):
            raise WeatherFileError(path, lineno, f"record has {len(fields)} fields, expected {len(names)}")
        try:
            month, day, year = (int(x) for x in fields[0].split("/"))
            hh, mm = (int(x) for x in fields[1].split(":"))
        except ValueError:
            raise WeatherFileError(path, lineno, f"date/time {fields[0]!r} {fields[1]!r} is not "
                                                 f"MM/DD/YYYY HH:MM") from None
        if not (0 <= hh <= 24 and 0 <= mm < 60):
            raise WeatherFileError(path, lineno, f"time {fields[1]!r} outside 00:00-24:00")
        if coerce_year is not None:
            year = int(coerce_year)
        try:
            date = pd.Timestamp(year=year, month=month, day=day)
        except ValueError as exc:
            raise WeatherFileError(path, lineno, f"invalid date {fields[0]!r}: {exc}") from None
        stamps.append(date + pd.Timedelta(hours=hh, minutes=mm))
        rows.append([_float(path, lineno, names[j], fields[j]) for j, _, _ in wanted])
        linenos.append(lineno)
    values = np.array(rows, dtype=float).reshape(len(rows), len(wanted))
    columns, missing = {}, {}
    for k, (j, name, scale) in enumerate(wanted):
        v = values[:, k]
        bad = np.isin(v, _TMY3_MISSING)
        _check_range(path, name, v * scale, bad, linenos, j)
        missing[name] = int(bad.sum())
        columns[name] = np.where(bad, np.nan, v * scale)
    tz = fixed_offset_tz(meta["tz_offset"])
    data = pd.DataFrame(columns, index=pd.DatetimeIndex(stamps).tz_localize(tz))
    site = Site(meta["latitude"], meta["longitude"], meta["altitude"], tz,
                ", ".join(p for p in (meta["city"], meta["state"]) if p))
    step = infer_step(data.index) if len(data) > 1 else pd.Timedelta("1h")
    return WeatherData(data, site, "right", step, meta, missing, str(path))


# ----------------------------------------------------------------------------------------------
# Plain CSV with pvlib column names
# ----------------------------------------------------------------------------------------------
_CSV_META_KEYS = ("latitude", "longitude", "altitude", "tz", "name", "label", "step")


def read_weather_csv(path, tz=None, label=None, step=None, latitude=None, longitude=None,
                     altitude=None, name=None) -> WeatherData:
    """Read a CSV whose columns carry pvlib names and units (see the module docstring).

    The file may start with ``# key: value`` comment lines giving ``latitude`` [deg],
    ``longitude`` [deg], ``altitude`` [m], ``tz``, ``name``, ``label`` and ``step``; keyword
    arguments override them. Then a header line whose first column holds timestamps (ISO 8601;
    with a UTC offset, or naive and taken in ``tz``). Empty cells are missing values.

    Parameters
    ----------
    path : str or Path
        The file.
    tz : str, tzinfo, float or None
        Time zone of naive timestamps (required for them if the file gives none).
    label : {"left", "right", "center"} or None
        Interval label of the timestamps; default from the file, else "center".
    step : str or None
        Interval length; default from the file, else inferred.
    latitude, longitude : float or None
        Site [deg]; required (here or in the file).
    altitude : float or None
        Site altitude [m]; default 0.
    name : str or None
        Site name.
    """
    lines = _read_lines(path)
    meta, first = {}, 0
    for i, line in enumerate(lines):
        s = line.strip()
        if not s.startswith("#"):
            first = i
            break
        body = s.lstrip("#").strip()
        if ":" in body:
            key, value = (p.strip() for p in body.split(":", 1))
            if key.lower() in _CSV_META_KEYS:
                meta[key.lower()] = value
    else:
        raise WeatherFileError(path, None, "no header line")
    given = dict(tz=tz, label=label, step=step, latitude=latitude, longitude=longitude,
                 altitude=altitude, name=name)
    meta.update({k: v for k, v in given.items() if v is not None})
    for key in ("latitude", "longitude"):
        if key not in meta:
            raise WeatherFileError(path, None, f"no {key}: give it as '# {key}: value' or {key}=")
    for key in ("latitude", "longitude", "altitude"):
        if key in meta and isinstance(meta[key], str):
            meta[key] = _float(path, None, key, meta[key])
    tz_meta = meta.get("tz")
    if isinstance(tz_meta, str):
        try:
            tz_meta = float(tz_meta)
        except ValueError:
            pass
    header = next(csv.reader([lines[first]]))
    header = [h.strip() for h in header]
    rows = list(csv.reader(lines[first + 1:]))
    stamps, values = [], []
    for k, fields in enumerate(rows):
        lineno = first + 2 + k
        if not fields or not any(f.strip() for f in fields):
            continue
        if len(fields) != len(header):
            raise WeatherFileError(path, lineno, f"record has {len(fields)} fields, header has {len(header)}")
        stamps.append((lineno, fields[0].strip()))
        row = []
        for j in range(1, len(header)):
            text = fields[j].strip()
            row.append(np.nan if text == "" else _float(path, lineno, header[j], text))
        values.append(row)
    if not values:
        raise WeatherFileError(path, None, "no data records")
    try:
        index = pd.DatetimeIndex(pd.to_datetime([s for _, s in stamps], format="ISO8601"))
    except (ValueError, TypeError):
        for lineno, s in stamps:  # find the offending line
            try:
                pd.Timestamp(s)
            except ValueError:
                raise WeatherFileError(path, lineno, f"timestamp {s!r} is not ISO 8601") from None
        raise WeatherFileError(path, None, "timestamps mix time zones; use one UTC offset") from None
    try:
        index = ensure_tz_aware(index, tz_meta, name=f"timestamps of {path}")
    except ValueError as exc:
        raise WeatherFileError(path, None, str(exc)) from None
    arr = np.array(values, dtype=float).reshape(len(values), len(header) - 1)
    data = pd.DataFrame(arr, index=index, columns=header[1:])
    missing = {c: int(data[c].isna().sum()) for c in data.columns}
    lab = meta.get("label", "center")
    if lab not in LABELS:
        raise WeatherFileError(path, None, f"label={lab!r} is not one of {LABELS}")
    stp = pd.Timedelta(meta["step"]) if "step" in meta else (
        infer_step(index) if len(index) > 1 else pd.Timedelta("1h"))
    site_tz = tz_meta if tz_meta is not None else index.tz
    site = Site(meta["latitude"], meta["longitude"], meta.get("altitude", 0.0), site_tz,
                meta.get("name", ""))
    return WeatherData(data, site, lab, stp, meta, missing, str(path))


def read_weather(path, **kwargs) -> WeatherData:
    """Read a weather file, choosing the reader by content: EPW (first line ``LOCATION,``),
    TMY3 (second line starting ``Date (MM/DD/YYYY)``), else CSV with pvlib names. Keyword
    arguments go to the chosen reader."""
    lines = _read_lines(path)[:2]
    if lines and lines[0].upper().startswith("LOCATION,"):
        return read_epw(path, **kwargs)
    if len(lines) > 1 and lines[1].startswith("Date (MM/DD/YYYY)"):
        return read_tmy3(path, **kwargs)
    kinds = "EPW (first line LOCATION,...), TMY3 or CSV with pvlib column names"
    with open(path, "rb") as fh:
        head = fh.read(4096)
    if b"\0" in head or (head and sum(b < 0x09 or 0x0d < b < 0x20 for b in head) > len(head) // 100):
        raise WeatherFileError(path, None, f"not a weather file (binary data); expected {kinds}")
    if Path(path).suffix.lower() in (".epw", ".tm3", ".tmy3"):
        first = lines[0][:40] if lines else ""
        raise WeatherFileError(path, 1, f"not a weather file: the first line {first!r} starts no LOCATION header "
                                        f"(EPW) and the second no 'Date (MM/DD/YYYY)' header (TMY3); expected {kinds}")
    try:
        return read_weather_csv(path, **kwargs)
    except WeatherFileError as exc:
        if "no latitude" in str(exc) or "no header" in str(exc):
            why = str(exc).split(": ", 1)[1]
            raise WeatherFileError(path, None, f"not an EPW or TMY3 file, and as a CSV weather file {why} "
                                               f"(expected {kinds})") from None
        raise
