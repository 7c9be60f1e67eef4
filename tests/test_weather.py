"""EPW, TMY3 and CSV weather readers."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from widesky import irradiance
from widesky.core.paths import data_file
from widesky.irradiance.location import Site
from widesky.irradiance.weather import (WeatherFileError, read_epw, read_tmy3, read_weather,
                                read_weather_csv, write_epw)

AMSTERDAM = "weather/NLD_Amsterdam062400_IWEC.epw"      # in the reference data folder (IWEC: not shipped)
SAMPLE = Path(irradiance.__file__).parent / "data" / "sample_golden_june.epw"


@pytest.fixture(scope="module")
def amsterdam():
    return read_epw(data_file(AMSTERDAM))


@pytest.mark.reference
def test_amsterdam_epw_header_and_shape(amsterdam):
    """The IWEC file's LOCATION line: 52.30 N, 4.77 E, UTC+1, -2 m; 8760 hourly records."""
    w = amsterdam
    assert (w.site.latitude, w.site.longitude, w.site.altitude) == (52.30, 4.77, -2.0)
    assert w.site.tz.utcoffset(None) == pd.Timedelta(hours=1)
    assert len(w.data) == 8760 and w.label == "right" and w.step == pd.Timedelta("1h")
    assert w.metadata["wmo"] == "062400" and "AMSTERDAM" in w.site.name


@pytest.mark.reference
def test_amsterdam_epw_first_record(amsterdam):
    """First data line of the file: 1995,1,1,1,60,...,5.1,1.8,79,100100,0,1415,288,0,0,0,...,
    340 (wind dir),6.7 (wind),6,6,20.0 (visibility km),420,...,0 (pw),0.0500 (aod),0,88,0.000."""
    row = amsterdam.data.iloc[0]
    assert amsterdam.data.index[0] == pd.Timestamp("1995-01-01 01:00", tz="Etc/GMT-1")
    assert row["temp_air"] == 5.1 and row["temp_dew"] == 1.8 and row["relative_humidity"] == 79
    assert row["pressure"] == 100100 and row["dni_extra"] == 1415 and row["ghi"] == 0
    assert row["wind_direction"] == 340 and row["wind_speed"] == 6.7
    assert row["visibility"] == 20.0 and row["aod"] == 0.05
    # zeros in precipitable water and albedo are fillers of IWEC files: missing by default
    assert np.isnan(row["precipitable_water"]) and np.isnan(row["albedo"])


@pytest.mark.reference
def test_amsterdam_missing_report_and_zero_policy(amsterdam):
    assert amsterdam.missing["precipitable_water"] == 8760
    assert amsterdam.missing["albedo"] == 8760
    assert amsterdam.missing["ghi"] == 0 and amsterdam.missing["dni"] == 0
    assert "precipitable_water=8760" in amsterdam.summary()
    # issue 40: a typical year mixes years; the summary names the months' years, not a backwards "1995 .. 1991" span
    first = amsterdam.summary().splitlines()[0]
    assert "a typical year of months from 1982-1999 (Jan 1995," in first and "Dec 1990)" in first
    assert "in file order 1995-01-01 01:00:00+01:00 .. 1991-01-01 00:00:00+01:00" in first
    raw = read_epw(data_file(AMSTERDAM), zero_as_missing=())
    assert (raw.data["precipitable_water"] == 0).all()
    assert raw.missing["precipitable_water"] == 0


@pytest.mark.reference
def test_amsterdam_physics_sanity(amsterdam):
    """Closure GHI = DNI cos(zenith) + DHI at mid-interval sun positions: the hourly data come
    from a model that enforces it, so the median relative residual over bright hours is small;
    night hours have no irradiance."""
    d = amsterdam.data
    sp = amsterdam.solar_position()
    cz = np.cos(np.radians(sp["apparent_zenith"]))
    bright = d["ghi"] > 200
    resid = (d["dni"] * cz + d["dhi"] - d["ghi"])[bright] / d["ghi"][bright]
    assert abs(resid.median()) < 0.05
    # intervals whose start, middle and end all have the sun below -1 deg are dark
    site = amsterdam.site
    ends = site.solar_position(d.index, label="center")["apparent_elevation"]
    starts = site.solar_position(d.index - pd.Timedelta("1h"), label="center")["apparent_elevation"]
    night = (sp["apparent_elevation"] < -1) & (ends.to_numpy() < -1) & (starts.to_numpy() < -1)
    assert night.sum() > 3000
    assert (d.loc[night, "ghi"] == 0).all()
    # annual GHI of Amsterdam: about 1000 kWh m-2 (IWEC: 980-1010)
    assert 900 < d["ghi"].sum() / 1000 < 1100


@pytest.mark.reference
def test_coerce_year(amsterdam, tmp_path):
    w = read_epw(data_file(AMSTERDAM), coerce_year=2021)
    assert (w.data.index[:-1].year == 2021).all() and w.data.index[-1].year == 2022
    assert w.data.index.is_monotonic_increasing
    # a leap day in a non-leap year is reported with its line, not shifted
    bad = tmp_path / "leap.epw"
    lines = data_file(AMSTERDAM).read_text(encoding="latin-1").splitlines()
    rec = lines[8].split(",")
    rec[1], rec[2] = "2", "29"
    lines[8] = ",".join(rec)
    bad.write_text("\n".join(lines), encoding="latin-1")
    with pytest.raises(WeatherFileError, match=r"leap.epw:9: invalid date 2021-2-29"):
        read_epw(bad, coerce_year=2021)


def test_shipped_sample_reads():
    w = read_weather(SAMPLE)
    assert len(w.data) == 14 * 24 and w.label == "right"
    assert w.site.latitude == pytest.approx(39.742) and w.site.altitude == 1829.0
    assert "Synthetic" in w.metadata.get("comment", "") or "synthetic" in w.metadata["data_source"]
    d = w.data
    assert d["ghi"].max() < 1200 and (d[["ghi", "dni", "dhi"]] >= 0).all().all()
    sp = w.solar_position()
    cz = np.clip(np.cos(np.radians(sp["apparent_zenith"])), 0, None)
    np.testing.assert_allclose(d["ghi"], d["dni"] * cz + d["dhi"], atol=1.5)


def _frame(n=48, start="2021-06-01 01:00"):
    idx = pd.date_range(start, periods=n, freq="1h", tz="Etc/GMT+5")
    rng = np.random.default_rng(1)
    return pd.DataFrame({
        "ghi": rng.uniform(0, 900, n).round(), "dni": rng.uniform(0, 900, n).round(),
        "dhi": rng.uniform(0, 300, n).round(), "temp_air": rng.uniform(-5, 30, n).round(1),
        "wind_speed": rng.uniform(0, 10, n).round(1), "visibility": rng.uniform(5, 90, n).round(1),
        "aod": rng.uniform(0.02, 0.5, n).round(3), "albedo": rng.uniform(0.1, 0.8, n).round(3),
        "precipitable_water": rng.uniform(0.3, 4, n).round(2), "pressure": np.full(n, 98000.0),
    }, index=idx)


def test_epw_round_trip(tmp_path):
    df = _frame()
    site = Site(40.0, -75.0, 100.0, tz=-5, name="Test site")
    df.iloc[3, df.columns.get_loc("dni")] = np.nan
    path = tmp_path / "x.epw"
    write_epw(path, df, site, label="right")
    w = read_epw(path)
    assert (w.data.index == df.index).all()
    for col in df.columns:
        np.testing.assert_allclose(w.data[col], df[col], atol=1e-9, err_msg=col)
    assert w.missing["dni"] == 1
    # the same data labelled "left" are stamped one hour later in the file
    write_epw(path, df, site, label="left")
    assert read_epw(path).data.index[0] == df.index[0] + pd.Timedelta("1h")


def test_epw_hour_24_is_midnight_of_next_day(tmp_path):
    df = _frame(n=24, start="2021-12-31 01:00")
    path = tmp_path / "y.epw"
    write_epw(path, df, Site(0, 0, tz=-5))
    last = path.read_text().splitlines()[-1].split(",")
    assert last[:4] == ["2021", "12", "31", "24"]
    assert read_epw(path).data.index[-1] == pd.Timestamp("2022-01-01 00:00", tz="Etc/GMT+5")


def _epw_lines(tmp_path):
    df = _frame(n=5)
    path = tmp_path / "z.epw"
    write_epw(path, df, Site(0, 0, tz=-5))
    return path, path.read_text().splitlines()


@pytest.mark.parametrize("mutate, match", [
    (lambda r: r.__setitem__(14, "abc"), r":10: field 'dni': 'abc' is not a number"),
    (lambda r: r.__setitem__(3, "25"), r":10: field 'hour'=25 outside the valid range \[1, 24\]"),
    (lambda r: r.__setitem__(1, "13"), r":10: field 'month'=13"),
    (lambda r: r.__setitem__(2, "31") or r.__setitem__(1, "6"), r":10: invalid date 2021-6-31"),
    (lambda r: r.__delitem__(slice(20, None)), r":10: record has 20 fields, expected 35"),
])
def test_epw_malformed_records_report_line(tmp_path, mutate, match):
    path, lines = _epw_lines(tmp_path)
    rec = lines[9].split(",")
    mutate(rec)
    lines[9] = ",".join(rec)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(WeatherFileError, match=match):
        read_epw(path)


def test_epw_malformed_headers(tmp_path):
    path, lines = _epw_lines(tmp_path)
    path.write_text("\n".join(lines[1:]))
    with pytest.raises(WeatherFileError, match="no LOCATION"):
        read_epw(path)
    path.write_text("\n".join(l for l in lines if not l.startswith("DATA PERIODS")))
    with pytest.raises(WeatherFileError, match="no DATA PERIODS"):
        read_epw(path)
    path.write_text("\n".join(lines[:8]))
    with pytest.raises(WeatherFileError, match="no data records"):
        read_epw(path)
    bad = lines[0].split(",")
    bad[6] = "north"
    path.write_text("\n".join([",".join(bad)] + lines[1:]))
    with pytest.raises(WeatherFileError, match=r":1: field 'latitude': 'north'"):
        read_epw(path)
    with pytest.raises(OSError, match="cannot read weather file"):
        read_epw(tmp_path / "absent.epw")


def test_epw_missing_codes(tmp_path):
    path, lines = _epw_lines(tmp_path)
    rec = lines[8].split(",")
    rec[13], rec[14], rec[21], rec[24], rec[29] = "9999", "9999", "999", "9999", "0.999"
    lines[8] = ",".join(rec)
    path.write_text("\n".join(lines))
    w = read_epw(path)
    row = w.data.iloc[0]
    assert np.isnan(row[["ghi", "dni", "wind_speed", "visibility", "aod"]].astype(float)).all()
    assert w.missing["ghi"] == 1 and w.missing["visibility"] == 1


def _tmy3_text():
    header = ("Date (MM/DD/YYYY),Time (HH:MM),ETR (W/m^2),ETRN (W/m^2),GHI (W/m^2),GHI source,"
              "GHI uncert (%),DNI (W/m^2),DNI source,DNI uncert (%),DHI (W/m^2),DHI source,"
              "DHI uncert (%),Dry-bulb (C),Dry-bulb source,Dry-bulb uncert (code),"
              "Pressure (mbar),Pressure source,Pressure uncert (code),Wspd (m/s),Wspd source,"
              "Wspd uncert (code),Hvis (m),Hvis source,Hvis uncert (code),Pwat (cm),Pwat source,"
              "Pwat uncert (code),AOD (unitless),AOD source,AOD uncert (code),Alb (unitless),"
              "Alb source,Alb uncert (code)")
    rows = []
    for h in range(1, 25):
        ghi = max(0, 800 - 60 * abs(h - 12.5)) if 6 < h < 20 else 0
        rows.append(f"01/01/1988,{h:02d}:00,0,0,{ghi},1,8,{ghi},1,8,{ghi // 4},1,8,"
                    f"{10 + h / 10:.1f},A,7,1013,A,7,3.1,A,7,{16000 if h != 5 else -9900},A,7,"
                    f"1.2,E,8,0.08,F,8,0.17,F,8")
    return '723650,"ALBUQUERQUE INTL ARPT",NM,-7.0,35.050,-106.617,1619\n' + header + "\n" + \
        "\n".join(rows) + "\n"


def test_tmy3(tmp_path):
    path = tmp_path / "723650TY.csv"
    path.write_text(_tmy3_text())
    w = read_weather(path)
    assert w.metadata["usaf"] == "723650" and w.site.altitude == 1619
    assert (w.site.latitude, w.site.longitude) == (35.05, -106.617)
    assert w.label == "right" and w.step == pd.Timedelta("1h") and len(w.data) == 24
    assert w.data.index[0] == pd.Timestamp("1988-01-01 01:00", tz="Etc/GMT+7")
    assert w.data.index[-1] == pd.Timestamp("1988-01-02 00:00", tz="Etc/GMT+7")
    row = w.data.iloc[11]
    assert row["pressure"] == 101300.0 and row["visibility"] == 16.0  # mbar -> Pa, m -> km
    assert row["precipitable_water"] == 1.2 and row["aod"] == 0.08 and row["albedo"] == 0.17
    assert np.isnan(w.data["visibility"].iloc[4]) and w.missing["visibility"] == 1
    assert read_tmy3(path, coerce_year=2021).data.index[0].year == 2021


def test_tmy3_malformed(tmp_path):
    path = tmp_path / "t.csv"
    text = _tmy3_text().splitlines()
    text[5] = text[5].replace("01/01/1988,04:00", "01/01/1988,4h")
    path.write_text("\n".join(text))
    with pytest.raises(WeatherFileError, match=r":6: date/time"):
        read_tmy3(path)
    text = _tmy3_text().splitlines()
    text[7] = text[7].replace(",3.1,", ",fast,")
    path.write_text("\n".join(text))
    with pytest.raises(WeatherFileError, match=r":8: field 'Wspd \(m/s\)': 'fast'"):
        read_tmy3(path)
    path.write_text("\n".join(_tmy3_text().splitlines()[:2]))
    with pytest.raises(WeatherFileError, match="2 lines"):
        read_tmy3(path)


def test_csv_with_metadata_comments(tmp_path):
    path = tmp_path / "w.csv"
    path.write_text("# latitude: 47.5\n# longitude: 8.5\n# altitude: 420\n# tz: Europe/Zurich\n"
                    "# label: left\n# name: Zurich test\n"
                    "time,ghi,dni,dhi,temp_air,visibility\n"
                    "2021-06-01 12:00,800,700,150,20.5,40\n"
                    "2021-06-01 12:15,810,,152,20.6,41\n"
                    "2021-06-01 12:30,805,702,151,20.7,42\n")
    w = read_weather(path)
    assert w.label == "left" and w.step == pd.Timedelta("15min")
    assert str(w.data.index.tz) == "Europe/Zurich" and w.site.name == "Zurich test"
    assert w.site.altitude == 420.0 and w.missing["dni"] == 1
    assert np.isnan(w.data["dni"].iloc[1])
    mid = w.sun_times()
    assert mid[0] == pd.Timestamp("2021-06-01 12:07:30", tz="Europe/Zurich")


def test_csv_timezone_rules(tmp_path):
    path = tmp_path / "n.csv"
    path.write_text("time,ghi\n2021-06-01 12:00,1\n2021-06-01 13:00,2\n")
    with pytest.raises(WeatherFileError, match="tz-naive"):
        read_weather_csv(path, latitude=1, longitude=2)
    w = read_weather_csv(path, latitude=1, longitude=2, tz=-3)
    assert w.data.index[0].utcoffset() == pd.Timedelta(hours=-3)
    path.write_text("time,ghi\n2021-06-01T12:00+02:00,1\n2021-06-01T13:00+02:00,2\n")
    w = read_weather_csv(path, latitude=1, longitude=2)
    assert w.data.index[0] == pd.Timestamp("2021-06-01 10:00", tz="UTC")
    with pytest.raises(WeatherFileError, match="no latitude"):
        read_weather_csv(path)


def test_csv_malformed(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("time,ghi,dni\n2021-06-01 12:00,1,2\n2021-06-01 13:00,x,2\n")
    with pytest.raises(WeatherFileError, match=r":3: field 'ghi': 'x'"):
        read_weather_csv(path, latitude=1, longitude=2, tz="UTC")
    path.write_text("time,ghi,dni\n2021-06-01 12:00,1,2\nyesterday,1,2\n")
    with pytest.raises(WeatherFileError, match=r":3: timestamp 'yesterday'"):
        read_weather_csv(path, latitude=1, longitude=2, tz="UTC")
    path.write_text("time,ghi,dni\n2021-06-01 12:00,1\n")
    with pytest.raises(WeatherFileError, match=r":2: record has 2 fields, header has 3"):
        read_weather_csv(path, latitude=1, longitude=2, tz="UTC")


def test_epw_sub_hourly_records(tmp_path):
    """DATA PERIODS with 4 records per hour: the minute field stamps each 15-min interval's end."""
    path, lines = _epw_lines(tmp_path)
    head = [l for l in lines[:8]]
    head[7] = head[7].replace("DATA PERIODS,1,1,", "DATA PERIODS,1,4,")
    template = lines[8].split(",")
    recs = []
    for k in range(8):
        rec = list(template)
        rec[0], rec[1], rec[2] = "2021", "6", "1"
        rec[3], rec[4] = str(k // 4 + 1), str(15 * (k % 4 + 1))
        recs.append(",".join(rec))
    path.write_text("\n".join(head + recs) + "\n")
    w = read_epw(path)
    assert w.step == pd.Timedelta("15min") and w.label == "right"
    assert w.data.index[0] == pd.Timestamp("2021-06-01 00:15", tz="Etc/GMT+5")
    assert w.data.index[-1] == pd.Timestamp("2021-06-01 02:00", tz="Etc/GMT+5")
    assert w.sun_times()[0] == pd.Timestamp("2021-06-01 00:07:30", tz="Etc/GMT+5")
    head[7] = head[7].replace("DATA PERIODS,1,4,", "DATA PERIODS,1,7,")
    path.write_text("\n".join(head + recs) + "\n")
    with pytest.raises(WeatherFileError, match=r":8: records per hour=7 does not divide 60"):
        read_epw(path)
