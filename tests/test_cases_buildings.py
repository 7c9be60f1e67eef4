"""The facade and bipv cases (buildings with glazing and loads), weather files in cases, and the GLB mesh.

Physics references:
* facade: the window gains of an unobstructed one-storey box over two clear June days against a hand calculation
  with an isotropic sky: ``E = DNI cos(aoi) g(aoi) + (DHI (1 + cos tilt) / 2 + albedo GHI (1 - cos tilt) / 2)
  g_diffuse`` per step, with the model's own DNI and DHI (irradiance.model_irradiance), the sun of the sky states
  and the clear unit's AM1.5-weighted g by angle (thermal.glazing_g_table, the rated route). The integrator's sky
  is anisotropic (circumsolar and horizon brightening), so the total gain on a vertical window differs from the
  isotropic estimate: by -2.8 % (north) to +6.3 % (south) here; the test allows 10 %. The beam part alone has no
  sky model in it: it must agree to 2 % on the south window (measured -1.0 %: the spectral effect of the clear
  glass's iron band on the sky's beam against AM1.5, and the sun's disc).
* bipv: the performance ratio of the PV groups (AC energy over plane-of-array insolation times the STC rating)
  between 0.72 and 0.92, the range of the loss chain a module plant has (cover optics, temperature, low light,
  DC losses, inverter: about 0.8); the canopies lower the south windows' light below the east and west ones'.
* weather: measured DNI and DHI scale the clear sky's parts linearly, so a weather file carrying half the model's
  own DNI and DHI gives half the window gains of one carrying the model's values (to 0.1 % over the period: EPW
  rounds irradiance to whole W m-2), and the latter the clear-sky run's gains (0.2 %).
"""

import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from widesky import cases
from widesky.cases.config import ConfigError
from widesky.cases.runner import compute

SHIPPED = Path(cases.__file__).parent

FACADE = """
[case]
title = "facade, small"
[site]
latitude = 50.08
longitude = 14.42
tz = "{tz}"
[period]
start = "2024-06-20"
end = "2024-06-22"
[sky]
visibility = 40
albedo = 0.2
{weather}
[scene]
geometry = "geometry.py"
[scene.parameters]
width = 10.0
depth = 8.0
storeys = 1
wwr = 0.4
canyon = false
[thermal]
glazing = ["clear", "solar-control"]
[report]
sky_time = "2024-06-21T12:00"
views = ["south-west"]
render_size = 200
"""


def _case(folder, shipped, toml):
    shutil.copy(SHIPPED / shipped / "geometry.py", folder / "geometry.py")
    (folder / "case.toml").write_text(toml, encoding="utf-8")
    return folder


@pytest.fixture(scope="module")
def facade_run(tmp_path_factory):
    folder = _case(tmp_path_factory.mktemp("facade"), "facade", FACADE.format(tz="Europe/Prague", weather=""))
    return compute(folder, n_jobs=1, progress=False)


@pytest.fixture(scope="module")
def facade_report(tmp_path_factory):
    folder = _case(tmp_path_factory.mktemp("facade_r"), "facade", FACADE.format(tz="Europe/Prague", weather=""))
    return cases.run_case(folder, tmp_path_factory.mktemp("rep") / "r", n_jobs=1, progress=False,
                          log=lambda m: None)


def _hand(run, unit, azimuth):
    """Isotropic-sky window gain and beam gain (T,) [W m-2] of a vertical window facing ``azimuth`` [deg]."""
    import widesky.irradiance as ir
    from widesky import pvsim
    from widesky.thermal import glazing_g_table

    states = run.result.states
    dni, dhi = ir.model_irradiance(run.dataset, states, run.settings)
    el, az = np.asarray(states.sun_elevation), np.asarray(states.sun_azimuth)
    cos_i = np.where(el > 0, np.maximum(np.cos(np.radians(el)) * np.cos(np.radians(az - azimuth)), 0.0), 0.0)
    aoi = np.degrees(np.arccos(cos_i))
    ref = pvsim.widesky_am15g(run.dataset)
    edges = ref["channel_edges"]
    wl = np.arange(edges[0] + 5.0, edges[-1], 10.0)
    ang, g, g_d, _ = glazing_g_table(unit, wl, ref["scaled"][np.searchsorted(edges, wl) - 1])
    ghi = dni * np.maximum(np.sin(np.radians(el)), 0.0) + dhi
    beam = dni * cos_i * np.interp(aoi, ang, g)
    return beam + (0.5 * dhi + 0.2 * 0.5 * ghi) * g_d, beam


def test_facade_gains_against_an_isotropic_hand_calculation(facade_run):
    from widesky.thermal.gains import group_weights

    th = facade_run.thermal
    res = facade_run.result
    az = {"north": 0.0, "east": 90.0, "south": 180.0, "west": 270.0}
    per = th.orientation_gains("clear")
    assert set(per) == set(az)
    for o, (area, gain, _) in per.items():
        hand, _ = _hand(facade_run, th.units["clear"], az[o])
        assert gain.sum() / area == pytest.approx(hand.sum(), rel=0.10), o
    south = [j for j, s in enumerate(th.windows) if abs(s.azimuth - 180.0) < 1]
    w = group_weights(res, [th.windows[j].label for j in south])
    beam = (res.get("clear:spectral", "direct") @ w)[:, 0]
    _, hand_beam = _hand(facade_run, th.units["clear"], 180.0)
    assert beam.sum() == pytest.approx(hand_beam.sum(), rel=0.02)


def test_facade_selective_glazing_cuts_gains_and_cooling(facade_run):
    """Solar control < clear in gain on every facade and in cooling; its spectral selectivity (NIR cut) lowers
    its gain on the east window's reddened morning beam below its AM1.5-rated g by more than the clear unit's."""
    th = facade_run.thermal
    clear, sc = th.orientation_gains("clear"), th.orientation_gains("solar-control")
    for o in clear:
        assert sc[o][1].sum() < 0.75 * clear[o][1].sum()
    cool = {n: th.loads[n].cooling.to_numpy().sum() for n in th.units}
    assert 0 < cool["solar-control"] < cool["clear"]
    from widesky.thermal.gains import group_weights
    east = [j for j, s in enumerate(th.windows) if abs(s.azimuth - 90.0) < 1]
    w = group_weights(facade_run.result, [th.windows[j].label for j in east])
    ratio = {}
    for n in th.units:
        _, hand = _hand(facade_run, th.units[n], 90.0)
        ratio[n] = float((facade_run.result.get(f"{n}:spectral", "direct") @ w)[:, 0].sum() / hand.sum())
    assert ratio["solar-control"] < ratio["clear"] - 0.03, ratio


def test_facade_report_contents(facade_report):
    names = {p.name for p in facade_report.iterdir()}
    for f in ("index.html", "timeseries.csv", "timeseries.parquet", "poa.h5", "spectral_hour.h5", "sky.exr",
              "sky.png", "scene_south-west.png", "scene.ply", "scene.glb", "loads.csv", "faces.csv"):
        assert f in names, f
    html = (facade_report / "index.html").read_text()
    assert "Glazing, window gains and loads" in html and "solar-control" in html and "peak cooling" in html
    ts = pd.read_csv(facade_report / "timeseries.csv", index_col=0)
    loads = pd.read_csv(facade_report / "loads.csv", index_col=0)
    for unit in ("clear", "solar-control"):
        total = loads[(loads.glazing == unit) & (loads.index == "total")]["cooling_kWh"].iloc[0]
        assert ts[f"{unit}:cooling [W]"].sum() / 1000.0 == pytest.approx(total, rel=1e-3)
        assert f"{unit}:window gain south [W]" in ts
    # peaks as the hour's interval in local time, inside the run's year (the EPW labels the year's last hour
    # 1 January 00:00 of the next year; loads.csv wrote that label before)
    import re
    years = {str(y) for y in pd.to_datetime(ts.index.astype(str).str[:10]).year}
    for col in ("peak_heating_hour", "peak_cooling_hour"):
        for text in loads[col]:
            assert re.fullmatch(r"\d{4}-\d\d-\d\d \d\d:\d\d-\d\d:\d\d \(UTC[+-]\d\d:\d\d\)", text), text
            assert text[:4] in years, (text, years)
    # the coloured mesh: one colour per triangle, as many triangles as the scene
    import trimesh
    glb = trimesh.load(facade_report / "scene.glb", force="mesh")
    ply = trimesh.load(facade_report / "scene.ply", process=False)
    assert len(glb.faces) == len(ply.faces)
    vc = glb.visual.vertex_colors.reshape(-1, 3, 4)
    assert np.all(vc == vc[:, :1])                     # flat colour per triangle
    assert len(np.unique(vc[:, 0], axis=0)) > 3


def _check_charts(rep):
    """tests/test_cases.py's ``check_charts`` (every chart recomputed from the result file it shows)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("_widesky_test_cases", Path(__file__).with_name("test_cases.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.check_charts(rep)


def test_thermal_and_bipv_charts_show_their_result_files(facade_report, bipv_report):
    """Issue 40: the window-gain and cooling charts (and the bipv report's PV and irradiance charts) hold the
    numbers of timeseries.csv and faces.csv; the first screen gives the building's loads."""
    assert {"window-gain", "cooling-load", "hour-spectrum"} <= set(_check_charts(facade_report))
    assert {"window-gain", "cooling-load", "hour-spectrum"} <= set(_check_charts(bipv_report))
    html = (facade_report / "index.html").read_text()
    glance = html[html.index('<div class="glance">'):html.index("<h2>Run</h2>")]
    loads = pd.read_csv(facade_report / "loads.csv", index_col=0)
    for unit in ("clear", "solar-control"):
        total = loads[(loads.glazing == unit) & (loads.index == "total")]["cooling_kWh"].iloc[0]
        assert f"{unit} glazing: cooling <b>{total / 1000:.2f} MWh</b>" in glance


def test_thermal_section_needs_a_building(tmp_path):
    folder = _case(tmp_path, "solar_potential", FACADE.format(tz="Europe/Prague", weather="")
                   .replace("canyon = false", ""))
    with pytest.raises(ConfigError, match=r"\[thermal\].*no 'building'"):
        compute(folder, n_jobs=1, progress=False)


def test_thermal_glazing_is_validated(tmp_path):
    folder = _case(tmp_path, "facade", FACADE.format(tz="Europe/Prague", weather="")
                   .replace('glazing = ["clear", "solar-control"]', 'glazing = ["clear", "tinted"]'))
    with pytest.raises(ConfigError, match=r"thermal.glazing: 'tinted' is not valid; expected items from clear, "
                                          r"low-e, solar-control"):
        cases.load_config(folder)


@pytest.mark.parametrize("extra, message", [
    ('thermostat = "office"\nheating_setpoint = 20.0\nheating_setback = 22.0',
     r"thermal: heating_setback \(22 degC\) <= heating_setpoint \(20 degC\) <= cooling_setpoint \(26 degC\) <= "
     r"cooling_setup \(26.7 degC\) does not hold"),
    ('heating_setpoint = 25.0\ncooling_setpoint = 22.0',
     r"thermal: heating_setpoint \(25 degC\) <= cooling_setpoint \(22 degC\) does not hold"),
    ('cooling_setup = 30.0', r"thermal.cooling_setup applies only with thermal.thermostat = 'office'"),
    ('thermostat = "night"', r"thermal.thermostat = 'night': expected one of constant, office"),
])
def test_thermostat_settings_are_validated(tmp_path, extra, message):
    """Set-points out of order (a set-back above the occupied set-point, heating above cooling) and a set-back
    without the office thermostat that would apply it are refused, naming the keys."""
    folder = _case(tmp_path, "facade", FACADE.format(tz="Europe/Prague", weather="")
                   .replace('glazing = ["clear", "solar-control"]', 'glazing = ["clear"]\n' + extra))
    with pytest.raises(ConfigError, match=message):
        cases.load_config(folder)


# ---- weather files -----------------------------------------------------------------------------------------

def _epw(path, run, factor, temp_air, dhi_factor=None):
    """An EPW on the steps of ``run`` carrying ``factor`` x the sky model's own DNI and ``dhi_factor`` (default
    ``factor``) x its DHI, broadband: the model's 280-2480 nm values / the in-band share (issue 35)."""
    import widesky.irradiance as ir
    from widesky.core.spectral import in_band_share
    dni, dhi = ir.model_irradiance(run.dataset, run.result.states, run.settings)
    dni, dhi = dni / in_band_share(280.0, 2480.0), dhi / in_band_share(280.0, 2480.0)
    el = np.asarray(run.result.states.sun_elevation)
    fd = factor if dhi_factor is None else dhi_factor
    data = pd.DataFrame({"dni": factor * dni, "dhi": fd * dhi,
                         "ghi": factor * dni * np.maximum(np.sin(np.radians(el)), 0) + fd * dhi,
                         "temp_air": np.full(len(dni), temp_air), "wind_speed": 1.0}, index=run.result.times)
    site = ir.Site(50.08, 14.42, 200.0, tz=1.0, name="test site")
    ir.write_epw(path, data, site, label="left")
    return path


@pytest.mark.slow
def test_weather_file_scales_the_gains(tmp_path, facade_run):
    runs = {}
    for factor in (1.0, 0.5):
        folder = tmp_path / f"w{factor}"
        folder.mkdir()
        _epw(folder / "w.epw", facade_run, factor, 30.0)
        # a grey ground as in the clear-sky run (the all-sky default reflects a vegetated ground's spectrum)
        _case(folder, "facade", FACADE.format(tz="1", weather='weather = "w.epw"\nground_spectrum = "grey"'))
        runs[factor] = compute(folder, n_jobs=1, progress=False)
    a, b = (runs[f].thermal for f in (1.0, 0.5))
    assert "weather file w.epw" in runs[1.0].weather
    # EPW stores irradiance in whole W m-2, so per step the halving holds to that rounding
    assert np.allclose(b.window_gain["clear"], 0.5 * a.window_gain["clear"], rtol=5e-3, atol=0.5)
    assert b.window_gain["clear"].sum() == pytest.approx(0.5 * a.window_gain["clear"].sum(), rel=1e-3)
    assert a.window_gain["clear"].sum() > 0
    assert np.all(a.temp_air == 30.0)                   # the file's air temperature, not the design day
    # the file's sky at 1x is the clear sky it was made from: the gains equal the clear-sky run's (same steps)
    assert a.window_gain["clear"].sum() == pytest.approx(facade_run.thermal.window_gain["clear"].sum(), rel=2e-3)


@pytest.mark.slow
def test_weather_cases_use_the_allsky_spectra_by_default(tmp_path, facade_run):
    """Under a weather file a case uses the all-sky spectra (docs/all-sky.md) by default, as every command does
    (SKY_DEFAULTS); `spectral_model = "clear"` keeps the clear-sky spectra. A cloudy file (the model's DNI x 0.2,
    DHI x 2.5) moves the clear window's spectral gain but not the measured horizontal totals."""
    runs = {}
    for model in ("default", "clear"):
        folder = tmp_path / model
        folder.mkdir()
        _epw(folder / "w.epw", facade_run, 0.2, 20.0, dhi_factor=2.5)
        extra = "" if model == "default" else f'\nspectral_model = "{model}"'
        _case(folder, "facade", FACADE.format(tz="1", weather=f'weather = "w.epw"{extra}'))
        runs[model] = compute(folder, n_jobs=1, progress=False)
    assert "all-sky spectra" in runs["default"].weather and "clear-sky spectra" in runs["clear"].weather
    a, c = (runs[m].thermal.window_gain["clear"].sum() for m in ("default", "clear"))
    assert a != pytest.approx(c, rel=1e-3)              # the spectral and angular shape moved
    assert 0.7 < a / c < 1.3
    (tmp_path / "clear" / "case.toml").write_text(FACADE.format(tz="1", weather='weather = "w.epw"\n'
                                                                                 'spectral_model = "cloudy"'))
    with pytest.raises(ConfigError, match="spectral_model"):
        cases.load_config(tmp_path / "clear")


def _no_data(monkeypatch, tmp_path):
    """Hide the reference data folder (no WIDESKY_DATA_DIR, no ../shared/data), as on a user's machine."""
    import widesky.core.paths as paths
    monkeypatch.delenv("WIDESKY_DATA_DIR", raising=False)
    monkeypatch.setattr(paths, "_REPO_SIBLING", tmp_path / "no-shared-data")
    assert not paths.has_data()


def test_facade_runs_without_the_data_directory(tmp_path, monkeypatch, facade_run):
    """The shipped cases' default (clear sky, built-in glazing, the sky model's AM1.5 reference) reads no data file:
    the same numbers with the data directory hidden."""
    _no_data(monkeypatch, tmp_path)
    run = compute(_case(tmp_path, "facade", FACADE.format(tz="Europe/Prague", weather="")), n_jobs=1, progress=False)
    np.testing.assert_allclose(run.thermal.window_gain["clear"], facade_run.thermal.window_gain["clear"], rtol=1e-6)
    assert run.weather.startswith("clear sky") and "upper bound" in run.weather


def test_weather_key_errors(tmp_path, monkeypatch):
    folder = _case(tmp_path, "facade", FACADE.format(tz="Europe/Prague", weather='weather = "nothere.epw"'))
    with pytest.raises(ConfigError, match=r"sky.weather = 'nothere.epw': no such file"):
        cases.load_config(folder)
    _no_data(monkeypatch, tmp_path)
    (folder / "case.toml").write_text(FACADE.format(tz="Europe/Prague", weather='weather = "data:weather/x.epw"'))
    with pytest.raises(ConfigError, match=r"sky.weather = 'data:weather/x.epw'.*remove the key for the clear sky"):
        cases.load_config(folder)


@pytest.mark.slow
def test_facade_runs_on_a_tmy3_file_of_the_data_directory(tmp_path):
    """``data:weather/<file>``: the Denver TMY3 year ships in the package."""
    toml = FACADE.format(tz="Europe/Prague", weather='weather = "data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw"')
    folder = _case(tmp_path, "facade", toml.replace("2024-06-21T", "2024-07-02T"))
    with pytest.raises(ConfigError, match=r"a leap year, and the file has no 29 February; choose a period in a "
                                          r"common year \(e.g. 2023\)"):
        compute(folder, n_jobs=1, progress=False)
    toml = toml.replace('start = "2024-06-20"', 'start = "2023-07-01"').replace('end = "2024-06-22"',
                                                                                'end = "2023-07-04"')
    toml = toml.replace('sky_time = "2024-06-21T12:00"', 'sky_time = "2023-07-02T12:00"')
    run = compute(_case(tmp_path, "facade", toml), n_jobs=1, progress=False)
    assert "Denver" in run.weather and abs(run.site.latitude - 39.83) < 0.01
    assert len(run.result.times) == 72
    t = run.thermal.temp_air
    assert np.ptp(t) > 5 and 5 < t.mean() < 35          # the file's July air temperature, not a constant
    assert run.thermal.window_gain["clear"].sum() > 0


# ---- the facade study: schedules, sky, frames, blinds, energy balance (issue 38) ------------------------------

DENVER = 'weather = "data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw"'
FEATURES = """
schedule = "office"
frame_fraction = 0.3
frame_u = 2.0
shading_factor = 0.15
shading_threshold = 200.0
"""


def _features_toml(start="2023-07-03", end="2023-07-10", sky_time="2023-07-04T12:00"):
    toml = FACADE.format(tz="-7", weather=DENVER).replace('glazing = ["clear", "solar-control"]',
                                                          'glazing = ["clear", "solar-control"]' + FEATURES)
    return (toml.replace('start = "2024-06-20"', f'start = "{start}"').replace('end = "2024-06-22"', f'end = "{end}"')
            .replace('sky_time = "2024-06-21T12:00"', f'sky_time = "{sky_time}"'))


@pytest.fixture(scope="module")
def facade_week(tmp_path_factory):
    """A July week in Denver (TMY3) with office schedules, frames and blinds: a Monday to a Sunday."""
    folder = _case(tmp_path_factory.mktemp("facade_week"), "facade", _features_toml())
    return compute(folder, n_jobs=1, progress=False)


def test_office_schedule_totals_against_the_published_profiles():
    """The ASHRAE 90.1 User's Manual office profiles (DOE reference office BLDG_OCC_SCH, BLDG_LIGHT_SCH,
    BLDG_EQUIP_SCH) summed by hand from their published hourly values: a weekday holds 10.2 h of full occupancy,
    11.3 h of full lighting and 15.0 h of full equipment; a Saturday 3.5, 4.3 and 8.75; a Sunday 0, 1.2 and 7.2.
    2023 has 260 weekdays, 52 Saturdays and 53 Sundays: 2834, 3225.2 and 4736.6 equivalent full-load hours; with the
    stated densities (75 W per 18.58 m2, 6.89 and 8.07 W m-2) 71.89 kWh m-2 of internal gains; 2912 occupied hours
    (occupancy >= 0.5: weekdays 08:00-18:00, Saturdays 08:00-14:00)."""
    from widesky.thermal.schedules import office_gains, occupied_hours, profile_fractions
    times = pd.date_range("2023-01-01", periods=8760, freq="h", tz="-07:00")
    f = profile_fractions(times)
    assert f["occupancy"].sum() == pytest.approx(2834.0, abs=1e-9)
    assert f["lighting"].sum() == pytest.approx(3225.2, abs=1e-9)
    assert f["equipment"].sum() == pytest.approx(4736.6, abs=1e-9)
    g = office_gains(times)
    assert g["people"].sum() / 1000 == pytest.approx(2834.0 * 75.0 / 18.58 / 1000, rel=1e-12)
    assert g["total"].sum() / 1000 == pytest.approx(71.89, abs=0.01)
    occ = occupied_hours(times)
    assert occ.sum() == 2912
    monday = np.asarray((times.day_of_week == 0) & (times.day_of_year == 2))
    assert list(np.nonzero(occ & monday)[0] - 24) == list(range(8, 18))
    # the same hours stamped at their end (an EPW's convention) give the same schedule one stamp later
    np.testing.assert_array_equal(profile_fractions(times + pd.Timedelta(hours=1), label="right")["occupancy"],
                                  f["occupancy"])
    with pytest.raises(ValueError, match="people_m2"):
        office_gains(times, densities={"people_m2": 0.0})


def test_office_thermostat_against_the_published_schedule():
    """The DOE reference office's thermostat (HTGSETP_SCH / CLGSETP_SCH, Deru et al. 2011): 21.0 / 24.0 degC on
    weekdays 06:00-22:00 and Saturdays 06:00-18:00, 15.6 / 26.7 degC otherwise and all Sunday. 2023 has 260 weekdays
    and 52 Saturdays: 260 x 16 + 52 x 12 = 4784 hours at the occupied set-points, 3976 set back."""
    from widesky.thermal.schedules import office_setpoints
    times = pd.date_range("2023-01-01", periods=8760, freq="h", tz="-07:00")
    heat, cool = office_setpoints(times)
    on = heat == 21.0
    assert on.sum() == 4784 and np.array_equal(on, cool == 24.0)
    assert np.all(heat[~on] == 15.6) and np.all(cool[~on] == 26.7)
    hour = {str(t)[:13]: (h, c) for t, h, c in zip(times, heat, cool)}
    assert hour["2023-01-02 05"] == (15.6, 26.7) and hour["2023-01-02 06"] == (21.0, 24.0)      # Monday
    assert hour["2023-01-02 21"] == (21.0, 24.0) and hour["2023-01-02 22"] == (15.6, 26.7)
    assert hour["2023-01-07 17"] == (21.0, 24.0) and hour["2023-01-07 18"] == (15.6, 26.7)      # Saturday
    assert hour["2023-01-08 12"] == (15.6, 26.7)                                                # Sunday
    # an EPW's stamps (the interval end) give the same hours one stamp later; the set-points can be the case's
    h_right, _ = office_setpoints(times + pd.Timedelta(hours=1), label="right")
    np.testing.assert_array_equal(h_right, heat)
    h20, c26 = office_setpoints(times, heating=20.0, cooling=26.0, heating_setback=12.0, cooling_setup=30.0)
    assert set(h20) == {20.0, 12.0} and set(c26) == {26.0, 30.0} and np.array_equal(h20 == 20.0, on)
    with pytest.raises(ValueError, match="heating_setback <= heating <= cooling <= cooling_setup"):
        office_setpoints(times, heating_setback=22.0)
    with pytest.raises(ValueError, match="cooling=nan degC must be finite"):
        office_setpoints(times, cooling=float("nan"))


def test_office_thermostat_holds_its_set_points_in_the_zones():
    """Two January weeks at 0 degC outside with no sun and no internal gains: with the office thermostat every zone's
    air stays between the hour's set-points, sits on 21 degC whenever it heats in the thermostat's hours and on 15.6
    degC overnight and on Sunday once the mass has cooled; the set-back needs less heat than 21 degC every hour,
    and the building's heating peaks in a morning recovery hour (06:00-07:00)."""
    from widesky.thermal.building import ZoneSpec, box_building
    from widesky.thermal.loads import Construction, building_loads
    from widesky.thermal.schedules import office_setpoints
    b = box_building(20, 12, 3.5, floors=2, wwr=0.3, zone_use=ZoneSpec("u", internal_gains=0.0))
    surf = [s for s in b.surfaces if s.kind != "shading"]
    T = 24 * 14
    times = pd.date_range("2023-01-02", periods=T, freq="h", tz="-07:00")     # from a Monday 00:00-01:00
    zero = {k: np.zeros((T, len(surf))) for k in ("poa_direct", "poa_sky_diffuse", "poa_ground_diffuse")}
    zero["aoi"] = np.full((T, len(surf)), 90.0)
    from widesky.cases.glazing import glazing_units
    cons = {"wall": Construction("wall", 0.3), "roof": Construction("roof", 0.2),
            "floor": Construction("floor", 0.3, b=0.5),
            "window": Construction("window", glazing=glazing_units(["low-e"])["low-e"])}
    ta = np.zeros(T)
    heat, cool = office_setpoints(times)
    r = building_loads(b, cons, times, ta, zero, setpoints=(heat, cool))
    t_air, q = r.temp_air.to_numpy(), r.heating.to_numpy()
    assert np.all(t_air >= heat[:, None] - 1e-6) and np.all(t_air <= cool[:, None] + 1e-6)
    on = heat == 21.0
    np.testing.assert_allclose(t_air[on], 21.0, atol=1e-6)            # 0 degC outside: it heats every such hour
    sunday = np.asarray((times.day_of_week == 6) & (times.hour >= 6))
    np.testing.assert_allclose(t_air[sunday], 15.6, atol=1e-6)
    flat = building_loads(b, cons, times, ta, zero, setpoints=(np.full(T, 21.0), np.full(T, 24.0)))
    assert q.sum() < 0.9 * flat.heating.to_numpy().sum()
    total = q.sum(1)
    assert times[int(np.argmax(total))].hour == 6
    with pytest.raises(ValueError, match=r"setpoints must be \(heating, cooling\), each \(336,\)"):
        building_loads(b, cons, times, ta, zero, setpoints=(heat[:-1], cool))


def test_sky_temperature_from_the_weather_file():
    """T_sky = (IR_h / sigma)^(1/4): 0 degC at sigma 273.15^4 = 315.66 W m-2. The Denver TMY3 file's horizontal
    infrared is Clark & Allen's (1978) clear-and-cloudy sky emissivity from its dew point and opaque sky cover,
    eps = (0.787 + 0.764 ln(T_dp / 273)) (1 + 0.0224 N - 0.0035 N^2 + 0.00028 N^3) (as in the EnergyPlus Engineering
    Reference, "Sky radiation"): the sky temperature thermal takes from the file agrees with it within 0.3 K every
    hour, and the sky is 12.9 K colder than the air on average."""
    import widesky.irradiance as ir
    from widesky.irradiance.simulation import weather_path
    from widesky.thermal import sky_temperature
    sigma = 5.670374419e-8
    assert sky_temperature(sigma * 273.15 ** 4) == pytest.approx(0.0, abs=1e-9)
    assert sigma * 273.15 ** 4 == pytest.approx(315.66, abs=0.01)
    d = ir.read_weather(weather_path("data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw")).data
    n = d["opaque_sky_cover"].to_numpy(float)
    eps = ((0.787 + 0.764 * np.log((d["temp_dew"].to_numpy(float) + 273.15) / 273.0))
           * (1 + 0.0224 * n - 0.0035 * n ** 2 + 0.00028 * n ** 3))
    t_ca = (eps * (d["temp_air"].to_numpy(float) + 273.15) ** 4) ** 0.25 - 273.15
    t_sky = sky_temperature(d["ghi_infrared"].to_numpy(float))
    assert np.max(np.abs(t_sky - t_ca)) < 0.3
    assert np.mean(d["temp_air"].to_numpy(float) - t_sky) == pytest.approx(12.9, abs=0.1)


def test_shading_rule_frames_and_sky_on_a_week(facade_week):
    """The blinds are down exactly in the occupied hours whose global irradiance on that window exceeds 200 W m-2,
    and then pass 0.15 of the bare gain; the glass is 70 % of the window area, the window U is the area-weighted
    U_w = 0.7 U_g + 0.3 U_f, the frame's absorbed solar alpha R_se U_f A_f E; the sky loss uses the file's sky."""
    from widesky.cases.building_loads import shading_factors
    from widesky.thermal.loads import zone_parameters
    from widesky.thermal.schedules import occupied_hours
    th = facade_week.thermal
    times = facade_week.result.times
    occ = occupied_hours(times, label="right")          # an EPW's time stamps: the interval end
    assert np.array_equal(th.occupied, occ) and 0 < occ.sum() < len(times)
    stamp = times[np.argmax(occ)]                        # Monday 3 July: 08:00-09:00, stamped 09:00
    assert str(stamp)[:16] == "2023-07-03 09:00"
    want = occ[:, None] & (th.incident > 200.0)
    assert all(np.array_equal(th.deployed[n], want) for n in th.units)
    assert want.any() and (~want & (th.incident > 200)).any()
    for name in th.units:
        np.testing.assert_allclose(th.window_gain[name], np.where(want, 0.15, 1.0) * th.bare_gain[name], rtol=1e-12)
        lr = th.loads[name]
        for j, w in enumerate(th.windows):
            np.testing.assert_allclose(lr.parts["transmitted"][w.label], th.window_gain[name][:, j] * w.area * 0.7,
                                       rtol=1e-12)
            e = th.incident[:, j]
            np.testing.assert_allclose(lr.parts["opaque"][w.label], 0.6 * 0.04 * 2.0 * 0.3 * w.area * e, rtol=1e-6)
        assert lr.parts["sky_loss"].to_numpy().sum() > 0
    np.testing.assert_allclose(th.window_area, [0.7 * w.area for w in th.windows])
    d, e = shading_factors([[250.0, 150.0], [250.0, 201.0]], [False, True], 200.0, 0.15)
    assert d.tolist() == [[False, False], [True, True]] and e.tolist() == [[1, 1], [0.15, 0.15]]
    # the window's U: area-weighted glass and frame
    from widesky.cases.building_loads import _constructions
    tcfg = facade_week.config["thermal"]
    unit = th.units["clear"]
    cons = _constructions(tcfg, "clear", unit)
    assert cons["window"].window_u == pytest.approx(0.7 * unit.u_value() + 0.3 * 2.0, rel=1e-12)
    b = _building(facade_week)
    hw = zone_parameters(b, cons).h_tr_w
    assert hw.sum() == pytest.approx(cons["window"].window_u * sum(w.area for w in th.windows), rel=1e-12)
    assert 5.0 < np.mean(th.temp_air - th.temp_sky) < 30.0          # a July week's sky, colder than the air


def _building(run):
    from widesky.cases.building_loads import prepare_building
    from widesky.cases.runner import build_geometry
    geo = build_geometry(run.config["scene"]["geometry"], run.config["scene"]["parameters"])
    return prepare_building(geo["building"], run.config["thermal"])


def _closure(th):
    for name in th.units:
        bal = th.loads[name].balance()
        tot = bal.loc["total"]
        scale = tot["heating"] + tot["cooling"] + tot["internal"]
        assert abs(tot["residual"]) < 1e-6 * scale, (name, tot["residual"])
        assert np.all(np.abs(bal["residual"]) < 1e-6 * scale)
        s = th.loads[name].summary().loc["total"]
        assert tot["heating"] == pytest.approx(s["heating_kWh"], rel=1e-12)
    return bal


def test_energy_balance_closes_on_a_week(facade_week):
    bal = _closure(facade_week.thermal)
    assert bal.loc["total", "sky_loss"] > 0 and bal.loc["total", "solar_opaque"] > 0


@pytest.mark.slow
def test_shipped_facade_case_is_an_annual_study(tmp_path):
    """The shipped case: the Denver TMY3 year (8760 hourly steps), office schedules, frames, blinds and the sky's
    long-wave loss; its energy balance closes (the sum of gains and losses equals heating minus cooling less the
    storage, to 1e-6 of the throughput; the mass stores under 0.5 % of the heating over the year); every chart of
    its report (the facade balance, spectral against rated per month, monthly loads) shows its result files."""
    rep = cases.run_case(SHIPPED / "facade", tmp_path / "r", n_jobs=1, progress=False, log=lambda m: None)
    ts = pd.read_csv(rep / "timeseries.csv", index_col=0)
    assert len(ts) == 8760 and "building:temp_sky [degC]" in ts
    ids = set(_check_charts(rep))
    assert {"facade-balance", "spectral-rated", "loads-monthly", "window-gain", "cooling-daily"} <= ids
    html = (rep / "index.html").read_text()
    for text in ("Peak loads per zone", "Gains and losses per facade", "Energy balance of the building",
                 "Spectral against rated glazing, per month", "ASHRAE 90.1 User&#x27;s Manual office",
                 "21 / 24 degC on weekdays 06:00-22:00 and Saturdays 06:00-18:00, 15.6 / 26.7 degC otherwise",
                 "unless its zone heated in the previous hour"):
        assert text in html, text
    run = compute(SHIPPED / "facade", n_jobs=1, progress=False)
    bal = _closure(run.thermal)
    assert abs(bal.loc["total", "storage"]) < 5e-3 * bal.loc["total", "heating"]
    assert int(run.thermal.occupied.sum()) == 2912


# ---- bipv -------------------------------------------------------------------------------------------------

BIPV = """
[case]
title = "bipv, small"
[site]
latitude = 50.08
longitude = 14.42
tz = "Europe/Prague"
[period]
start = "2024-06-20"
end = "2024-06-22"
[scene]
geometry = "geometry.py"
[scene.parameters]
width = 12.0
depth = 8.0
storeys = 1
cell = 4.0
roof_rows = 2
[pv]
technologies = ["topcon", "cigs"]
groups = ["pv roof", "pv overhang", "pv spandrel"]
[thermal]
glazing = ["low-e"]
[report]
sky_time = "2024-06-21T12:00"
views = ["south-west"]
render_size = 200
"""


@pytest.fixture(scope="module")
def bipv_report(tmp_path_factory):
    folder = _case(tmp_path_factory.mktemp("bipv"), "bipv", BIPV)
    return cases.run_case(folder, tmp_path_factory.mktemp("rep") / "r", n_jobs=1, progress=False,
                          log=lambda m: None)


def test_bipv_report_yield_and_gains(bipv_report):
    html = (bipv_report / "index.html").read_text()
    assert "PV yield per technology" in html and "Glazing, window gains and loads" in html
    assert "pv roof, pv overhang, pv spandrel" in html
    ts = pd.read_csv(bipv_report / "timeseries.csv", index_col=0)
    faces = pd.read_csv(bipv_report / "faces.csv", index_col=0)
    from widesky import pvsim
    label = pvsim.get_technology("topcon").label
    row = re.search(rf"<tr><td>{re.escape(label)}</td><td>([\d.]+)</td><td>([\d.]+)</td>", html)
    kwp = float(row.group(2))
    pv = faces.label.str.startswith("pv ")
    assert set(faces.label[pv]) == {"pv roof", "pv overhang", "pv spandrel"}
    h_poa = float((faces.insolation_kwh_m2 * faces.area_m2)[pv].sum() / faces.area_m2[pv].sum())  # [kWh m-2]
    ac = ts["plant:topcon:ac [W]"].sum() / 1000.0                                     # 1 h steps -> [kWh]
    # performance ratio: AC energy / (POA insolation / 1 kW m-2 x STC rating); cover optics, temperature, low
    # light, 2 % DC and the inverter put a module plant at about 0.8 (independent of the sky)
    pr = ac / (h_poa * kwp)
    assert 0.72 < pr < 0.92, pr
    # the canopies shade the south window: less light per m2 on it than on the east and west windows
    s = faces.insolation_kwh_m2[faces.label == "window south"].mean()
    assert s < faces.insolation_kwh_m2[faces.label == "window east"].mean()
    assert s < faces.insolation_kwh_m2[faces.label == "window west"].mean()


# ---- compare_sites with weather files --------------------------------------------------------------------

COMPARE = """
[case]
title = "sites with weather"
[site]
latitude = 40.0
longitude = -105.0
tz = "UTC"
[compare]
sites = [{{ name = "other", latitude = 0.0, longitude = 0.0{other} }}]
[period]
start = "2023-07-01"
end = "2023-07-02"
[sky]
{weather}
[scene]
geometry = "geometry.py"
[scene.parameters]
row_length = 6.0
cell = 3.0
[pv]
technologies = ["topcon", "a_si"]
[report]
sky_time = "2023-07-01T12:00"
views = ["south-west"]
render_size = 160
"""


def test_compare_sites_weather_all_or_none(tmp_path):
    folder = _case(tmp_path, "compare_sites", COMPARE.format(other="", weather='weather = "w.epw"'))
    (folder / "w.epw").write_text("LOCATION,x\n")
    with pytest.raises(ConfigError, match=r"compare.sites: give every site a weather file when \[sky\] names one"):
        cases.load_config(folder)
    (folder / "case.toml").write_text(COMPARE.format(other=', weather = "w.epw"', weather=""))
    with pytest.raises(ConfigError, match=r"compare.sites: give every site a weather file"):
        cases.load_config(folder)


@pytest.mark.reference
@pytest.mark.slow
def test_compare_sites_on_tmy3_files(tmp_path_factory):
    """Each site on its own TMY3 file: the sites are the files' (Denver, Chicago), the yields differ."""
    toml = COMPARE.format(other=', weather = "data:weather/USA_IL_Chicago-OHare.Intl.AP.725300_TMY3.epw"',
                          weather='weather = "data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw"')
    folder = _case(tmp_path_factory.mktemp("cmp"), "compare_sites", toml)
    rep = cases.run_case(folder, tmp_path_factory.mktemp("rep") / "r", n_jobs=1, progress=False, log=lambda m: None)
    sites = pd.read_csv(rep / "sites.csv", index_col=0)
    assert len(sites.columns) == 2 and "Denver" in sites.columns[0] and "Chicago" in sites.columns[1]
    assert (sites.iloc[:, 0] != sites.iloc[:, 1]).all()
    html = (rep / "index.html").read_text()
    assert "39.83" in html and "41.98" in html              # the files' latitudes in the sites table


def test_builtin_glazing_units_have_the_documented_values():
    """cases/glazing.py states these values; the pane's energy balance closes; the coatings rank as their kinds."""
    from widesky import pvsim
    from widesky.cases.glazing import clear_glass_nk, glazing_units, unit_summary
    from widesky.thermal import GlazingUnit, layer_from_nk

    ref = pvsim.widesky_am15g()
    wl = np.arange(280.0, 2500.1, 10.0)
    pane = GlazingUnit("pane", [layer_from_nk("clear 6 mm", wl, *clear_glass_nk(wl), 6.0)])
    p = unit_summary(pane, ref["channel_edges"], ref["scaled"])
    assert p["t_visible"] == pytest.approx(0.885, abs=0.005) and p["t_solar"] == pytest.approx(0.81, abs=0.005)
    want = {"clear": (2.72, 0.74, 0.79), "low-e": (1.09, 0.62, 0.73), "solar-control": (1.06, 0.42, 0.64)}
    units = glazing_units(list(want))
    for name, (u, g, tv) in want.items():
        s = unit_summary(units[name], ref["channel_edges"], ref["scaled"])
        assert (s["u_value"], s["g_normal"], s["t_visible"]) == pytest.approx((u, g, tv), abs=0.006), name
        o = units[name].optics()
        np.testing.assert_allclose(o["transmittance"] + o["reflectance"] + o["absorbed"].sum(axis=0), 1.0,
                                   atol=1e-9)
    with pytest.raises(ValueError, match=r"glazing 'tinted' is not valid; expected items from clear"):
        glazing_units(["tinted"])


# ---- hours and months of end-labelled weather steps ---------------------------------------------------------

def test_the_report_hour_is_the_step_holding_sky_time():
    """report.sky_time picks the step whose interval [start, start + 1 h) holds it, whatever the label: with EPW
    or TMY3 end labels, 09:00 and 09:59 pick the hour labelled 10:00 (09:00-10:00), 10:00 the next; with start
    labels the hour labelled 09:00. Before the fix an end-labelled 09:00 picked the hour labelled 09:00
    (08:00-09:00)."""
    from widesky.cases.runner import report_hour
    tz = "Etc/GMT+7"
    ends = pd.date_range("2023-06-21 01:00", "2023-06-22 00:00", freq="1h", tz=tz)
    step = pd.Timedelta("1h")
    at = lambda s: pd.Timestamp(s, tz=tz)  # noqa: E731
    assert ends[report_hour(ends, "right", step, at("2023-06-21 09:00"))] == at("2023-06-21 10:00")
    assert ends[report_hour(ends, "right", step, at("2023-06-21 09:59"))] == at("2023-06-21 10:00")
    assert ends[report_hour(ends, "right", step, at("2023-06-21 10:00"))] == at("2023-06-21 11:00")
    assert ends[report_hour(ends, "right", step, at("2023-06-21 23:30"))] == at("2023-06-22 00:00")   # 23:00-24:00
    assert report_hour(ends, "right", step, at("2023-06-22 00:00")) is None          # after the last hour
    assert report_hour(ends, "right", step, at("2023-06-20 23:59")) is None
    starts = ends - step
    assert starts[report_hour(starts, "left", step, at("2023-06-21 09:00"))] == at("2023-06-21 09:00")


def test_thermal_report_months_and_peak_hours_by_the_intervals_start():
    """The thermal report's monthly loads and spectral-vs-rated months group an end-labelled series by each
    hour's start: a synthetic building whose only load is in the hour ending 1 Feb 00:00 shows it in January; the
    peak in the hour labelled 1 Jan 00:00 (end label) reads "31 Dec 23:00-24:00", not "01 Jan 00:00"."""
    from types import SimpleNamespace

    from widesky.cases.charts import ChartBook
    from widesky.cases.report_thermal import _fmt_time, _monthly_loads_chart, _routes_html
    tz = "Etc/GMT+7"
    ends = pd.date_range("2023-01-01 01:00", "2024-01-01 00:00", freq="1h", tz=tz)
    jan_last = ends.get_loc(pd.Timestamp("2023-02-01 00:00", tz=tz))
    heat = np.zeros((len(ends), 1))
    heat[jan_last] = 2e6                                            # 2 MWh in 31 Jan 23:00-24:00
    loads = SimpleNamespace(heating=pd.DataFrame(heat, columns=["z"]),
                            cooling=pd.DataFrame(np.zeros_like(heat), columns=["z"]))
    gain = np.zeros((len(ends), 1))
    gain[jan_last] = 1000.0
    th = SimpleNamespace(units={"clear": None}, loads={"clear": loads}, bare_gain={"clear": gain},
                         rated_gain={"clear": 2 * gain}, window_area=np.array([1.0]))
    book = ChartBook()
    _monthly_loads_chart(th, ends, 1.0, book, "right")
    _routes_html(th, ends, 1.0, book, "right")
    charts = {c["id"]: c for c in book.charts}
    heating = charts["loads-monthly"]["series"]["clear heating"]
    assert heating[0] == pytest.approx(2.0) and sum(heating[1:]) == 0.0
    assert charts["spectral-rated"]["series"]["clear"][0] == pytest.approx(-50.0)
    assert charts["spectral-rated"]["series"]["clear"][1] is None       # no February gain: NaN, written as null
    old = ChartBook()                                               # read as start labels: February's
    _monthly_loads_chart(th, ends, 1.0, old, "left")
    assert old.charts[0]["series"]["clear heating"][1] == pytest.approx(2.0)
    step = pd.Timedelta("1h")
    assert _fmt_time(ends[-1], "right", step) == "31 Dec 23:00-24:00"
    assert _fmt_time(ends[jan_last], "right", step) == "31 Jan 23:00-24:00"
    assert _fmt_time(pd.Timestamp("2023-07-17 15:00", tz=tz), "left", step) == "17 Jul 15:00-16:00"


@pytest.mark.slow
def test_a_weather_cases_report_hour_holds_sky_time(tmp_path, facade_run):
    """A case on an EPW (hours labelled by their end): report.sky_time 09:00 renders the hour 09:00-10:00, the
    step labelled 10:00, with the sun at 09:30 (pvlib's independent SPA: apparent elevation and azimuth within
    0.02 deg); before the fix it rendered 08:00-09:00 (sun at 08:30, about 10 deg lower)."""
    import pvlib
    _epw(tmp_path / "w.epw", facade_run, 1.0, 20.0)
    _case(tmp_path, "facade", FACADE.format(tz="1", weather='weather = "w.epw"')
          .replace('sky_time = "2024-06-21T12:00"', 'sky_time = "2024-06-21T09:00"'))
    run = compute(tmp_path, n_jobs=1, progress=False)
    t = run.result.times[run.hour_index]
    assert t == pd.Timestamp("2024-06-21 10:00", tz=t.tz) and run.label == "right"
    sp = pvlib.solarposition.get_solarposition(pd.DatetimeIndex([t - pd.Timedelta("30min")]), run.site.latitude,
                                               run.site.longitude, run.site.altitude)
    assert run.hour_sun[0] == pytest.approx(float(sp["apparent_elevation"].iloc[0]), abs=0.02)
    assert run.hour_sun[1] == pytest.approx(float(sp["azimuth"].iloc[0]), abs=0.02)
