"""Sites, time zones, interval labels and clear-sky daytime steps."""

import datetime as dt

import numpy as np
import pandas as pd
import pytest

from widesky.irradiance.location import (Location, Site, daytime_steps, ensure_tz_aware, fixed_offset_tz,
                                 infer_step, sun_times, time_range)
from widesky.irradiance.solarposition import solar_position


def test_site_validation_names_parameter_and_range():
    with pytest.raises(ValueError, match=r"latitude=95 deg outside the valid range \[-90, 90\]"):
        Site(95.0, 0.0)
    with pytest.raises(ValueError, match=r"longitude=200 deg"):
        Site(0.0, 200.0)
    with pytest.raises(ValueError, match=r"altitude=10000 m"):
        Site(0.0, 0.0, 10000.0)
    with pytest.raises(ValueError, match="not a known time zone"):
        Site(0.0, 0.0, tz="Mars/Olympus")
    with pytest.raises(ValueError, match=r"offset=15 h"):
        Site(0.0, 0.0, tz=15)
    with pytest.raises(TypeError, match="latitude must be a number"):
        Site("north", 0.0)
    assert Location is Site


def test_site_time_zone_forms():
    assert Site(0, 0, tz=-7).tz == dt.timezone(dt.timedelta(hours=-7))
    assert Site(0, 0, tz="Europe/Amsterdam").tz == "Europe/Amsterdam"
    assert fixed_offset_tz(5.5).utcoffset(None) == dt.timedelta(hours=5, minutes=30)


def test_site_pressure_standard_atmosphere():
    """ISO 2533 standard atmosphere: 101325 Pa at sea level, about 89875 Pa at 1000 m and
    about 79495 Pa at 2000 m."""
    assert Site(0, 0).pressure == pytest.approx(101325.0)
    assert Site(0, 0, 1000.0).pressure == pytest.approx(89875, rel=1e-3)
    assert Site(0, 0, 2000.0).pressure == pytest.approx(79495, rel=1e-3)


def test_naive_times_rejected_unless_tz_given():
    naive = pd.DatetimeIndex(["2021-06-01 12:00"])
    with pytest.raises(ValueError, match="tz-naive"):
        ensure_tz_aware(naive)
    aware = ensure_tz_aware(naive, "Europe/Amsterdam")
    assert str(aware.tz) == "Europe/Amsterdam"
    # a Site localizes naive times in its own zone
    s = Site(52.0, 5.0, tz="Europe/Amsterdam")
    assert s.localize(naive)[0] == pd.Timestamp("2021-06-01 10:00", tz="UTC")
    # tz-aware times are kept, not converted
    t = pd.DatetimeIndex(["2021-06-01 12:00"], tz="UTC")
    assert s.localize(t).tz == t.tz
    with pytest.raises(ValueError, match="NaT"):
        ensure_tz_aware(pd.DatetimeIndex(["2021-06-01", None], tz="UTC"))
    with pytest.raises(ValueError, match="cannot be localized"):
        ensure_tz_aware(pd.DatetimeIndex(["2021-03-28 02:30"]), "Europe/Amsterdam")


@pytest.mark.parametrize("label, shift_min", [("left", 30), ("right", -30), ("center", 0)])
def test_sun_times_mid_interval(label, shift_min):
    t = pd.date_range("2021-06-01", periods=5, freq="1h", tz="UTC")
    out = sun_times(t, label)
    assert (out - t == pd.Timedelta(minutes=shift_min)).all()
    assert (sun_times(t, label, step="15min") - t
            == pd.Timedelta(minutes=shift_min / 4)).all()


def test_sun_times_errors():
    t = pd.DatetimeIndex(["2021-06-01"], tz="UTC")
    with pytest.raises(ValueError, match="label='middle'"):
        sun_times(t, "middle")
    with pytest.raises(ValueError, match="fewer than 2"):
        sun_times(t, "left")
    with pytest.raises(ValueError, match="must be positive"):
        sun_times(t, "left", step="-1h")


def test_infer_step_irregular_uses_most_common():
    t = pd.DatetimeIndex(["2021-01-01 00:00", "2021-01-01 01:00", "2021-01-01 02:00",
                          "2021-01-01 05:00"], tz="UTC")
    assert infer_step(t) == pd.Timedelta("1h")


def test_time_range_labels_and_dst():
    t = time_range("2021-03-28", "2021-03-29", "1h", tz="Europe/Amsterdam", label="left")
    assert len(t) == 23  # the spring-forward day has 23 hours
    assert (np.diff(t.asi8) == 3600 * 10**9 // {"s": 10**9, "ms": 10**6, "us": 10**3,
                                                "ns": 1}[t.unit]).all()
    r = time_range("2021-06-01", "2021-06-02", "15min", tz="UTC", label="right")
    assert len(r) == 96 and r[0] == pd.Timestamp("2021-06-01 00:15", tz="UTC")
    c = time_range("2021-06-01", "2021-06-02", "1h", tz="UTC", label="center")
    assert c[0] == pd.Timestamp("2021-06-01 00:30", tz="UTC")
    with pytest.raises(ValueError, match="must be after"):
        time_range("2021-06-02", "2021-06-01", tz="UTC")
    with pytest.raises(ValueError, match="tz-naive"):
        time_range("2021-06-01", "2021-06-02")


def test_site_solar_position_uses_mid_interval():
    s = Site(39.742476, -105.1786, 1830.14, tz=-7)
    labels = pd.DatetimeIndex(["2003-10-17 13:00:30"])  # naive, site's zone; end of 1 h interval
    sp = s.solar_position(labels, label="right", step="1h", pressure=82000.0, temperature=11.0,
                          delta_t=67.0)
    # the interval 12:00:30-13:00:30 has its middle at 12:30:30: the SPA paper's example instant
    assert sp["apparent_zenith"].iloc[0] == pytest.approx(50.11162, abs=1e-4)
    assert sp.index[0] == pd.Timestamp("2003-10-17 13:00:30", tz=dt.timezone(dt.timedelta(hours=-7)))


def test_daytime_steps_clear_sky_year():
    """A clear-sky year needs no weather file. At the equator day length is 12 h all year, so
    about half of the hourly steps are daytime; the kept steps all have the sun up."""
    s = Site(0.0, 0.0, tz="UTC")
    d = daytime_steps(s, "2021-01-01", "2022-01-01", "1h", label="left")
    assert 4300 < len(d) < 4500
    assert (d["apparent_elevation"] > 0).all()
    q = daytime_steps(s, "2021-06-01", "2021-06-02", "15min", min_elevation=10.0)
    assert (q["apparent_elevation"] > 10).all()
    assert 35 < len(q) < 45  # about 10.5 h above 10 deg at the equator
    with pytest.raises(ValueError, match="min_elevation"):
        daytime_steps(s, "2021-06-01", "2021-06-02", min_elevation=100.0)


def test_polar_site_daytime_steps():
    """Longyearbyen (78.2 N): no daytime steps in the polar night, all 24 in the midnight sun."""
    s = Site(78.22, 15.65, tz="Arctic/Longyearbyen")
    assert len(daytime_steps(s, "2021-12-20", "2021-12-21")) == 0
    assert len(daytime_steps(s, "2021-06-20", "2021-06-21")) == 24


def test_site_matches_function():
    s = Site(-33.9, 18.4, 10.0, tz="Africa/Johannesburg")
    t = pd.date_range("2021-01-01", periods=24, freq="1h", tz="Africa/Johannesburg")
    a = s.solar_position(t, label="center")
    b = solar_position(t, -33.9, 18.4, 10.0, pressure=s.pressure)
    pd.testing.assert_frame_equal(a, b)


def test_from_metadata():
    s = Site.from_metadata({"latitude": 1.0, "longitude": 2.0, "altitude": 3.0, "tz": 1.0,
                            "name": "x"})
    assert (s.latitude, s.longitude, s.altitude, s.name) == (1.0, 2.0, 3.0, "x")
    with pytest.raises(ValueError, match="lacks"):
        Site.from_metadata({"latitude": 1.0})
