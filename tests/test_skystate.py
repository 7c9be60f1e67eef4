"""Sky state per time step and grouping of equal states."""

import types
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from widesky import irradiance
from widesky.irradiance.location import Site, daytime_steps
from widesky.irradiance.skystate import (PSM_RANGES, GroupingSteps, SkyRanges, group_sky_states,
                                 sky_ranges, sky_states)
from widesky.irradiance.weather import read_epw
from widesky.skymodel.visibility import aod550_from_visibility, aod_at_wavelength

SAMPLE = Path(irradiance.__file__).parent / "data" / "sample_golden_june.epw"

# A stand-in for a loaded dataset: the sky-state code only reads these four attributes.
GROUND_MODEL = types.SimpleNamespace(visibility_range=(20.0, 131.8), albedo_range=(0.0, 1.0),
                                     elevation_range=(0.0, 90.0), altitude_range=(0.0, 0.0))


def _solpos(elev, az=None):
    elev = np.asarray(elev, float)
    idx = pd.date_range("2021-06-01", periods=len(elev), freq="1h", tz="UTC")
    az = np.full(len(elev), 180.0) if az is None else np.asarray(az, float)
    return pd.DataFrame({"apparent_elevation": elev, "elevation": elev - 0.01, "azimuth": az},
                        index=idx)


def test_sky_ranges_duck_typing():
    r = sky_ranges(GROUND_MODEL)
    assert r.elevation_range == (0.0, 90.0) and r.altitude_range == (0.0, 0.0)
    assert sky_ranges() is PSM_RANGES and PSM_RANGES.visibility_range == (20.0, 131.8)
    with pytest.raises(TypeError, match=r"lacks the range attributes \['albedo_range'"):
        sky_ranges(types.SimpleNamespace(visibility_range=(1, 2), elevation_range=(0, 1),
                                         altitude_range=(0, 1)))
    with pytest.raises(ValueError, match="visibility_range"):
        SkyRanges(visibility_range=(50.0, 20.0))


def test_visibility_sources_and_priority():
    """Weather visibility wins where valid, then AOD converted through the generator's
    Koschmieder relation, then the default."""
    sp = _solpos([30, 30, 30, 30])
    vis = [40.0, np.nan, np.nan, 0.0]
    aod = [0.1, 0.1, np.nan, np.nan]
    w = pd.DataFrame({"visibility": vis, "aod": aod}, index=sp.index)
    s = sky_states(sp, w, default_visibility=77.0, aod_wavelength=500.0, angstrom=1.3)
    assert list(s["visibility_source"]) == ["weather", "aod", "default", "default"]
    assert s["visibility"].iloc[0] == 40.0 and s["visibility"].iloc[2] == 77.0
    # the AOD step: the visibility whose generator AOD at 550 nm equals the weather's converted AOD
    tau550 = aod_at_wavelength(0.1, 500.0, 550.0, 1.3)
    assert float(aod550_from_visibility(s["visibility"].iloc[1])) == pytest.approx(tau550, rel=1e-12)
    s2 = sky_states(sp, w, prefer="aod")
    assert list(s2["visibility_source"][:2]) == ["aod", "aod"]


def test_clamping_is_flagged_per_step():
    sp = _solpos([30, 30, 30])
    w = pd.DataFrame({"visibility": [5.0, 60.0, 500.0], "albedo": [0.3, 1.5, np.nan]},
                     index=sp.index)
    s = sky_states(sp, w, altitude=-2.0, default_albedo=0.25)
    np.testing.assert_array_equal(s["visibility"], [20.0, 60.0, 131.8])
    np.testing.assert_array_equal(s["visibility_clamped"], [True, False, True])
    np.testing.assert_array_equal(s["albedo"], [0.3, 1.0, 0.25])
    np.testing.assert_array_equal(s["albedo_clamped"], [False, True, False])
    assert s["altitude_clamped"].all() and (s["altitude"] == 0).all()


def test_low_sun_flags_full_and_ground_level_models():
    sp = _solpos([-10.0, -4.0, -1.0, 0.5, 45.0])
    full = sky_states(sp)
    np.testing.assert_array_equal(full["below_min"], [True, False, False, False, False])
    np.testing.assert_array_equal(full["has_beam"], [False, False, False, True, True])
    assert full["elevation"].iloc[0] == -4.2 and full["solar_elevation"].iloc[0] == -10.0
    ground = sky_states(sp, model=GROUND_MODEL)
    np.testing.assert_array_equal(ground["below_min"], [True, True, True, False, False])
    np.testing.assert_array_equal(ground["has_beam"], [False, False, False, True, True])
    geo = sky_states(sp, use_refraction=False)
    assert geo["solar_elevation"].iloc[4] == pytest.approx(44.99)


def test_sky_states_argument_errors():
    sp = _solpos([10, 20])
    with pytest.raises(ValueError, match="same index"):
        sky_states(sp, pd.DataFrame({"visibility": [1.0]}))
    with pytest.raises(ValueError, match=r"default_albedo=2"):
        sky_states(sp, default_albedo=2)
    with pytest.raises(ValueError, match=r"default_visibility=0 km"):
        sky_states(sp, default_visibility=0)
    with pytest.raises(ValueError, match="prefer="):
        sky_states(sp, prefer="both")
    with pytest.raises(ValueError, match="lacks the column 'azimuth'"):
        sky_states(sp.drop(columns="azimuth"))
    with pytest.raises(ValueError, match="grouping step elevation=0"):
        GroupingSteps(elevation=0)


def test_grouping_rounds_within_half_a_step_and_wraps_azimuth():
    sp = _solpos([10.0, 10.1, 10.2, 30.0, 30.0, -30.0], [359.7, 0.2, 0.4, 180.0, 180.0, 0.0])
    w = pd.DataFrame({"visibility": [50.0, 50.4, 50.0, 50.0, 52.0, 50.0]}, index=sp.index)
    s = sky_states(sp, w)
    g = group_sky_states(s, GroupingSteps(elevation=0.25, azimuth=1.0, visibility=0.02))
    inv = g.inverse
    assert inv[5] == -1  # below the model's minimum elevation: not evaluated
    assert inv[0] == inv[1] and inv[1] != inv[2]  # 359.7 and 0.2 deg share the 0 deg bin
    assert inv[3] != inv[4]  # 50 and 52 km are more than 2 % apart
    assert g.n_groups == 4 and g.n_evaluated == 5 and g.states["count"].sum() == 5
    # group state = members' mean: circular for azimuth (359.7 and 0.2 -> 359.95), geometric
    # for visibility
    assert g.states.loc[inv[0], "azimuth"] == pytest.approx(359.95)
    assert g.states.loc[inv[0], "elevation"] == pytest.approx(10.05)
    assert g.states.loc[inv[0], "visibility"] == pytest.approx(np.sqrt(50.0 * 50.4))
    vals = g.expand(np.arange(g.n_groups, dtype=float) * 10.0, fill=-1.0)
    np.testing.assert_array_equal(vals, np.where(inv >= 0, inv * 10.0, -1.0))
    assert g.expand(np.ones((g.n_groups, 3))).shape == (6, 3)
    with pytest.raises(ValueError, match="leading dimension"):
        g.expand(np.ones(3))
    g2 = group_sky_states(s, GroupingSteps(azimuth=None))
    assert g2.states["azimuth"].isna().all() and g2.n_groups == 4  # 10.0 and 10.1 deg merge


@settings(max_examples=40, deadline=None)
@given(data=st.lists(st.tuples(st.floats(-4.2, 90), st.floats(0, 359.999), st.floats(20, 131.8),
                               st.floats(0, 1)), min_size=1, max_size=60),
       de=st.sampled_from([0.1, 0.25, 0.5]), dv=st.sampled_from([0.01, 0.02, 0.05]))
def test_grouping_error_bounds(data, de, dv):
    """A step's state differs from its group's (the members' mean) by less than one step."""
    el, az, vis, alb = (np.array(x) for x in zip(*data))
    s = sky_states(_solpos(el, az), pd.DataFrame({"visibility": vis, "albedo": alb},
                                                 index=_solpos(el).index))
    steps = GroupingSteps(elevation=de, azimuth=1.0, visibility=dv, albedo=0.01)
    g = group_sky_states(s, steps)
    rep = g.states.iloc[g.inverse]
    assert np.all(np.abs(rep["elevation"].to_numpy() - s["elevation"].to_numpy()) <= de + 1e-9)
    daz = (rep["azimuth"].to_numpy() - s["azimuth"].to_numpy() + 180) % 360 - 180
    assert np.all(np.abs(daz) <= 1.0 + 1e-9)
    ratio = rep["visibility"].to_numpy() / s["visibility"].to_numpy()
    assert np.all(np.abs(np.log(ratio)) <= np.log1p(dv) + 1e-12)
    assert np.all(np.abs(rep["albedo"].to_numpy() - s["albedo"].to_numpy()) <= 0.01 + 1e-9)
    # grouped states stay inside the model's ranges
    assert rep["visibility"].between(20.0, 131.8).all() and rep["elevation"].between(-4.2, 90).all()
    assert g.states["count"].sum() == len(data)


def test_clear_sky_year_grouping_reduces_work():
    """A clear-sky (default visibility and albedo) 15-min year at 45 N: sun paths repeat around
    the solstices, so many steps share a rounded state; without azimuth even more do."""
    site = Site(45.0, 7.0, tz="UTC")
    sp = daytime_steps(site, "2021-01-01", "2022-01-01", "15min", min_elevation=-4.0)
    s = sky_states(sp)
    g = group_sky_states(s)
    assert g.n_evaluated == len(sp)
    assert g.reduction > 1.3
    np.testing.assert_allclose(g.states["visibility"], 50.0)  # a constant input is kept exactly
    assert group_sky_states(s, GroupingSteps(azimuth=None)).reduction > 10


def test_sample_weather_sky_states():
    w = read_epw(SAMPLE)
    sp = w.solar_position()
    s = sky_states(sp, w, altitude=w.site.altitude)
    assert (s["visibility_source"] == "weather").all()
    assert s["visibility"].between(20, 131.8).all()
    assert (s["albedo"] == 0.2).all() and (s["altitude"] == 1829.0).all()
    day = s["has_beam"]
    assert 14 * 13 <= day.sum() <= 14 * 16  # about 14.5-15 h of daylight in mid-June at 40 N
    g = group_sky_states(s)
    assert g.n_evaluated == int((~s["below_min"]).sum())


def test_cli_sun_skystates(capsys, tmp_path):
    import argparse

    from widesky.commands import sun as cli_sun
    parser = argparse.ArgumentParser(prog="widesky")
    cli_sun.register(parser.add_subparsers(dest="command"))
    out_csv = tmp_path / "states.csv"
    args = parser.parse_args(["sun", "skystates", "sample", "--azimuth-step", "0", "--csv", str(out_csv)])
    assert args.func(args) == 0
    text = capsys.readouterr().out
    assert "336 steps" in text and "distinct skies" in text and "visibility source" in text
    states = pd.read_csv(out_csv, index_col=0)
    assert len(states) == 336 and "has_beam" in states.columns


def test_real_dataset_object_provides_the_ranges(tmp_path):
    """A loaded skymodel.SkyModel (here a small synthetic dataset) works as ``model``."""
    try:
        from widesky import skymodel
        from widesky.skymodel.synthetic import write_synthetic_dataset
        model = skymodel.load_dataset(write_synthetic_dataset(
            tmp_path / "s.dat", visibilities=(20.0, 131.8), albedos=(0.0, 1.0), n_channels=2))
    except Exception as exc:  # the dataset code belongs to skymodel; skip if it is not usable here
        pytest.skip(f"skymodel dataset unavailable: {exc}")
    sp = _solpos([-10.0, 10.0, 50.0])
    s = sky_states(sp, pd.DataFrame({"visibility": [10.0, 60.0, 200.0]}, index=sp.index), model=model)
    assert sky_ranges(model).visibility_range == tuple(model.visibility_range)
    np.testing.assert_array_equal(s["visibility"], [20.0, 60.0, 131.8])
    g = group_sky_states(s, model=model)
    assert g.n_evaluated == int((~s["below_min"]).sum())


@pytest.mark.parametrize("label, shift", [("right", "1h"), ("left", "0h"), ("center", "30min")])
def test_a_period_holds_the_steps_whose_interval_starts_in_it(label, shift):
    """Weather steps belong to a period [start, end) by their interval, whatever the label: a full year of
    end-labelled hours (EPW, TMY3: the hour ending Jan 1 01:00 .. the one ending Dec 31 24:00) is 8760 steps,
    not 8759; a start-labelled series keeps start <= t < end. The steps chosen are exactly those of a site's
    period with the same label (time_range), here in the southern hemisphere at UTC+2, where Dec 31 24:00
    local is 22:00 UTC."""
    from widesky.irradiance.location import fixed_offset_tz, time_range
    from widesky.irradiance.weather import WeatherData
    site = Site(-33.97, 18.60, 46.0, fixed_offset_tz(2), "Cape Town")
    labels = pd.date_range("2021-01-01", periods=8760, freq="1h", tz=site.tz) + pd.Timedelta(shift)
    wd = WeatherData(pd.DataFrame({"visibility": 40.0}, index=labels), site, label, pd.Timedelta("1h"))
    for start, end, n in (("2021-01-01", "2022-01-01", 8760), ("2021-12-31", "2022-01-01", 24),
                          ("2021-06-21 06:00", "2021-06-21 18:00", 12)):
        s = irradiance.sky_states_for(wd, start, end, model=GROUND_MODEL, warn=False)
        assert len(s) == n, (label, start, end)
        assert s.times.equals(time_range(start, end, "1h", tz=site.tz, label=label))
    year = irradiance.sky_states_for(wd, "2021-01-01", "2022-01-01", model=GROUND_MODEL, warn=False).times
    assert year[-1] == pd.Timestamp("2021-12-31 23:00", tz=site.tz) + pd.Timedelta(shift)
    # the period's bounds alone: from start to the file's end, and from the file's start to end
    assert len(irradiance.sky_states_for(wd, "2021-12-31", None, model=GROUND_MODEL, warn=False)) == 24
    assert len(irradiance.sky_states_for(wd, None, "2021-01-02", model=GROUND_MODEL, warn=False)) == 24


def test_a_steps_month_is_its_intervals_start():
    """End-labelled hours (EPW, TMY3) are grouped by the start of their interval: the hour labelled 1 Feb 00:00
    (31 Jan 23:00-24:00) is January's and the one labelled 1 Jan 00:00 of the next year (31 Dec 23:00-24:00) is
    December's; a synthetic year whose last January hour alone carries a value puts it in January, not
    February. Start-labelled and centre-labelled steps give the same months."""
    from widesky.irradiance.skystate import interval_months, interval_starts
    tz = "Etc/GMT+7"
    ends = pd.date_range("2023-01-01 01:00", "2024-01-01 00:00", freq="1h", tz=tz)        # 8760 EPW labels
    assert len(ends) == 8760
    m = interval_months(ends, "right")
    assert m[ends.get_loc(pd.Timestamp("2023-02-01 00:00", tz=tz))] == 1
    assert m[-1] == 12 and m[0] == 1
    assert np.bincount(m, minlength=13)[1:].tolist() == [24 * d for d in (31, 28, 31, 30, 31, 30, 31, 31, 30, 31,
                                                                         30, 31)]
    v = np.zeros(len(ends))
    v[ends.get_loc(pd.Timestamp("2023-02-01 00:00", tz=tz))] = 5.0               # 31 Jan 23:00-24:00
    per_month = np.array([v[m == k].sum() for k in range(1, 13)])
    assert per_month[0] == 5.0 and per_month[1:].sum() == 0.0
    starts = ends - pd.Timedelta("1h")
    assert interval_starts(ends, "right").equals(starts)
    assert interval_starts(ends, "right", "1h").equals(starts)
    np.testing.assert_array_equal(interval_months(starts, "left"), m)
    np.testing.assert_array_equal(interval_months(starts + pd.Timedelta("30min"), "center", "1h"), m)
    with pytest.raises(ValueError, match="label"):
        interval_months(ends, "end")


def test_interval_text_names_an_end_labelled_hour_by_its_interval():
    """The EPW hour labelled 1 Jan 00:00 is 31 Dec 23:00-24:00; a start-labelled 2-hour step crossing midnight ends
    at 01:00, not "24:00"; a centre label is half a step after the start."""
    from widesky.irradiance.skystate import interval_text
    t = pd.Timestamp("2024-01-01 00:00", tz="Etc/GMT+7")
    assert interval_text(t, "right", "1h") == "31 Dec 23:00-24:00"
    assert interval_text(t, "right", "1h", "%Y-%m-%d %H:%M") == "2023-12-31 23:00-24:00"
    assert interval_text(pd.Timestamp("2023-06-30 23:00", tz="UTC"), "left", "2h") == "30 Jun 23:00-01:00"
    assert interval_text(pd.Timestamp("2023-06-30 12:30", tz="UTC"), "center", "1h") == "30 Jun 12:00-13:00"
