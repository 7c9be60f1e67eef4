"""The rest of ASHRAE 140 (issue 38): Cases 610-650, 910-950 and the free-floating 600FF-950FF.

Geometry facts against ANSI/ASHRAE 140-2020 7.2.1-7.2.2 (window 3 m x 2 m at a 0.2 m sill, 0.5 m
from the south wall's ends or centred in the east and west walls; overhangs and fins 1.0 m deep), the
shading by ray casting against the analytic shadow of an infinite overhang, the schedules of Cases
640 and 650, the verdict logic and the exit status of ``widesky thermal bestest``, and the new cases'
results against their ranges on the weather (Perez) route, whose every figure is inside
(docs/validation/thermal-bestest-cases.md lists the routes' figures).
"""

import functools

import numpy as np
import pandas as pd
import pytest

from widesky.thermal.bestest_geometry import ROOM, WINDOW, bestest_building, window_shading


def _surface(b, kind, azimuth=None):
    return [s for s in b.surfaces if s.kind == kind
            and (azimuth is None or abs((s.azimuth - azimuth + 180) % 360 - 180) < 1)]


def test_room_geometry_south_and_eastwest():
    b = bestest_building("south")
    (win,) = _surface(b, "window")
    assert win.area == pytest.approx(12.0) and win.azimuth == pytest.approx(180.0)
    x = b.vertices[b.faces[win.faces]].reshape(-1, 3)
    assert sorted(set(np.round(x[:, 0], 6))) == [0.5, 3.5, 4.5, 7.5]          # 0.5 m from the ends
    assert x[:, 2].min() == pytest.approx(0.2) and x[:, 2].max() == pytest.approx(2.2)
    walls = {round(s.azimuth): s.area for s in _surface(b, "wall")}
    assert walls == pytest.approx({0: 21.6, 90: 16.2, 180: 9.6, 270: 16.2})
    assert sum(s.area for s in _surface(b, "roof")) == pytest.approx(48.0)
    b = bestest_building("eastwest")
    wins = {round(s.azimuth): s for s in _surface(b, "window")}
    assert sorted(wins) == [90, 270] and all(w.area == pytest.approx(6.0) for w in wins.values())
    y = b.vertices[b.faces[wins[90].faces]].reshape(-1, 3)[:, 1]
    assert (y.min(), y.max()) == pytest.approx((1.5, 4.5))                  # centred in the 6 m wall
    walls = {round(s.azimuth): s.area for s in _surface(b, "wall")}
    assert walls == pytest.approx({0: 21.6, 90: 10.2, 180: 21.6, 270: 10.2})


def test_shading_devices():
    b = bestest_building("south", "overhang")
    (sh,) = _surface(b, "shading")
    v = b.vertices[b.faces[sh.faces]].reshape(-1, 3)
    assert sh.area == pytest.approx(ROOM[0] * 1.0)                       # 8 m x 1.0 m
    assert np.ptp(v[:, 1]) == pytest.approx(1.0) and v[:, 2] == pytest.approx(ROOM[2])
    b = bestest_building("eastwest", "overhang_fins")
    (sh,) = _surface(b, "shading")
    # two 3 m x 1 m overhangs and four 1 m x 2.7 m fins (ground to roof)
    assert sh.area == pytest.approx(2 * 3.0 + 4 * 2.7)
    with pytest.raises(ValueError, match="layout="):
        bestest_building("north")
    with pytest.raises(ValueError, match="shading="):
        bestest_building("south", "awning")


def test_overhang_shadow_against_analytic():
    """Sun due south at elevation e: an overhang of depth d across the whole wall, a gap g above a
    window of height h shades the top ``d tan(e) - g`` of it (a 2-D shadow; the overhang runs past both
    windows, so no end effects with the sun in the wall's normal plane)."""
    b = bestest_building("south", "overhang")
    el = np.array([20.0, 45.0, 60.0, 70.0])
    f = window_shading(b, 90 - el, np.full(4, 180.0), samples_per_face=256)
    d, g, h = WINDOW["device_depth"], ROOM[2] - WINDOW["sill"] - WINDOW["height"], WINDOW["height"]
    shade = np.clip(d * np.tan(np.radians(el)) - g, 0, h) / h
    assert f["sunlit"][:, 0] == pytest.approx(1 - shade, abs=0.02)
    # view of the sky: a 2-D overhang seen from a window strip; below the unobstructed half-space's
    assert 0.6 < f["sky_view"][0] < 0.95 and f["ground_view"][0] == pytest.approx(1.0)
    f0 = window_shading(bestest_building("south"), 90 - el, np.full(4, 180.0))
    assert f0["sunlit"] == pytest.approx(1.0) and f0["sky_view"] == pytest.approx(1.0)


def test_fins_shade_low_side_sun():
    """East window with fins: a sun from the south-east at a grazing angle to the wall is cut by the
    south fin; the sun square to the window is not (the overhang only trims the top)."""
    b = bestest_building("eastwest", "overhang_fins")
    f = window_shading(b, np.array([80.0, 80.0]), np.array([170.0, 90.0]))
    east = f["labels"].index(next(s.label for s in _surface(b, "window", 90)))
    assert f["sunlit"][0, east] == pytest.approx(0.0, abs=0.01)
    assert f["sunlit"][1, east] > 0.9
    assert f["ground_view"][east] < 0.9                     # the fins reach the ground


def test_verdict_logic():
    from widesky.thermal.bestest import verdicts
    refs = {"600": {"annual_heating": {"limits": (3750.0, 4980.0), "programs": {"A": 4000.0}},
                    "annual_cooling": {"limits": (5000.0, 6830.0), "programs": {"A": 5500.0}},
                    "peak_heating": {"programs": {"A": 3020.0, "B": 3359.0}},
                    "peak_cooling": {"programs": {"A": 5422.0, "B": 6481.0}}},
            "900FF": {"min_temperature": {"programs": {"A": 0.6, "B": 2.2}},
                      "max_temperature": {"programs": {"A": 43.3, "B": 46.0}}}}
    r = {"annual_heating": 4980.0, "annual_cooling": 4999.0, "peak_heating": 3100.0,
         "peak_cooling": 7000.0}
    v = {x.quantity: x for x in verdicts("600", r, refs)}
    assert v["annual_heating"].inside                            # on the limit: inside
    assert not v["annual_cooling"].inside and v["annual_cooling"].source == "acceptance"
    assert v["peak_heating"].inside and v["peak_heating"].source == "programs"
    assert (v["peak_heating"].low, v["peak_heating"].high) == pytest.approx((3.020, 3.359))
    assert not v["peak_cooling"].inside and v["peak_cooling"].unit == "kW"
    v = {x.quantity: x for x in verdicts("900FF", {"temp_min": 1.0, "temp_max": 42.0,
                                                    "temp_mean": 25.0}, refs)}
    assert v["min_temperature"].inside and not v["max_temperature"].inside
    assert v["mean_temperature"].inside and v["mean_temperature"].source == "programs_mean"
    with pytest.raises(ValueError, match="no reference"):
        verdicts("610", r, refs)


@pytest.mark.reference
def test_case_definitions():
    from widesky.thermal.bestest import CASES, case_definition
    assert set(CASES) >= {"610", "620", "630", "640", "650", "910", "920", "930", "940", "950",
                          "600FF", "650FF", "900FF", "950FF"}
    c600, c620, c900, c950 = (case_definition(c) for c in ("600", "620", "900", "950FF"))
    assert [w[2] for w in c620.walls] == [0.0, 6.0, 0.0, 6.0] and c620.window_area == 12.0
    assert c620.walls[2][1] == pytest.approx(21.6) and c620.walls[1][1] == pytest.approx(10.2)
    assert c620.zone.h_tr_op == pytest.approx(c600.zone.h_tr_op)   # same opaque area, moved
    assert c950.zone.heat_capacity == c900.zone.heat_capacity > 3 * c600.zone.heat_capacity
    assert c950.u_wall == c900.u_wall and c950.spec.free_floating
    assert case_definition("610").spec.shading == "overhang"
    assert case_definition("930").spec.shading == "overhang_fins"


@pytest.mark.reference
def test_schedules_640_650():
    """640: 10 degC from 23:00 to 07:00, 15 (the 07:00-08:00 ramp's mean), 20 until 23:00.
    650: no heating; fan on 18:00-07:00 (1700 m3 h-1 altitude-adjusted as the infiltration); cooling
    to 27 degC from 07:00 to 18:00 only."""
    from widesky.thermal.bestest import case_definition, setpoint_schedules
    idx = pd.date_range("2001-01-01 01:00", periods=24, freq="h")          # hour ends 01..24
    heat, cool, hve = setpoint_schedules(case_definition("640"), idx)
    assert heat[:7].tolist() == [10.0] * 7 and heat[7] == 15.0 and heat[8:23].tolist() == [20.0] * 15
    assert heat[23] == 10.0 and np.all(cool == 27.0)
    c = case_definition("650")
    heat, cool, hve = setpoint_schedules(c, idx)
    assert np.all(np.isneginf(heat))
    day = (np.arange(24) >= 7) & (np.arange(24) < 18)                     # hours beginning 07..17
    assert np.all(cool[day] == 27.0) and np.all(np.isposinf(cool[~day]))
    fan = 1200.0 * 1700.0 * (0.414 / 0.5) / 3600.0
    assert hve[~day] == pytest.approx(c.zone.h_ve + fan) and hve[day] == pytest.approx(c.zone.h_ve)
    assert (~day).sum() == 13                                                # 18:00-07:00: 13 hours
    # the case files' Modelica run (Case950.mo, revision of 12 May 2022): 1409 m3 h-1 at 1.2 kg m-3, cp 1006
    assert fan == pytest.approx(1409.0 / 3600.0 * 1.2 * 1006.0, rel=0.01)
    heat, cool, _ = setpoint_schedules(case_definition("600FF"), idx)
    assert np.all(np.isneginf(heat)) and np.all(np.isposinf(cool))


@pytest.mark.reference
def test_reference_tables_new_cases():
    from widesky.thermal.bestest import MEAN_TEMPERATURE_RANGE, read_modelica_record, reference_results
    from widesky.core.paths import data_file
    r = reference_results()
    assert r["610"]["annual_heating"]["limits"] == (3610.0, 5270.0)
    assert r["910"]["annual_cooling"]["limits"] == (860.0, 2000.0)         # listed high, low
    assert min(r["900FF"]["max_temperature"]["programs"].values()) == 43.3
    assert max(r["950FF"]["min_temperature"]["programs"].values()) == -12.5
    # the mean-temperature table's 600FF row against the data folder's own case file
    text = data_file("bestest/detailed_Cases6xx_Case600FF.mo").read_text()
    assert "meanT(Min=24.3+273.15,  Max=26.1+273.15" in text
    assert MEAN_TEMPERATURE_RANGE["600FF"] == (24.3, 26.1)


@pytest.mark.reference
@pytest.mark.parametrize("case", ["610", "620", "630", "640", "650", "920", "930"])
def test_new_cases_inside_their_ranges(case):
    """5R1C, weather (Perez) route, shading by ray casting: every figure inside (annual loads: the
    acceptance range; peaks: the six programs' range)."""
    from widesky.thermal.bestest import run_case, verdicts
    out = [v for v in verdicts(case, run_case(case, zone_model="5r1c")) if not v.inside]
    assert not out, [(v.quantity, round(v.value, 3), v.low, v.high) for v in out]


@pytest.mark.reference
@pytest.mark.parametrize("base,shaded", [("600", "610"), ("620", "630")])
def test_shading_cuts_cooling_as_the_programs_do(base, shaded):
    """The overhang (610) and the overhangs with fins (630) cut the annual cooling against the unshaded
    case by a ratio inside the six programs' ratios (610/600: 0.687-0.768; 630/620: 0.611-0.740)."""
    from widesky.thermal.bestest import reference_results, run_case
    p = reference_results()
    a, b = p[base]["annual_cooling"]["programs"], p[shaded]["annual_cooling"]["programs"]
    ratios = [b[k] / a[k] for k in a]
    ours = {m: run_case(shaded, zone_model=m)["annual_cooling"] / run_case(base, zone_model=m)["annual_cooling"]
            for m in ("5r1c", "iso52016")}
    assert all(min(ratios) <= v <= max(ratios) for v in ours.values()), (ours, min(ratios), max(ratios))


@pytest.mark.reference
def test_overhang_cut_of_the_window_gain_as_the_programs():
    """The 610 overhang's cut of the year's window gain (weather route, ray-cast shading) against the six programs'
    ratio of transmitted solar through the south windows, 610 over 600 (ASHRAE 140-2020 Tables B8-14, B8-15:
    0.775-0.824)."""
    from widesky.thermal.bestest import run_case
    cut = run_case("610")["hourly"]["solar_window"].sum() / run_case("600")["hourly"]["solar_window"].sum()
    assert 0.775 <= cut <= 0.824


@pytest.mark.reference
def test_cli_verdicts_and_exit_status(capsys):
    from widesky.cli import main
    assert main(["thermal", "bestest", "--case", "610", "650"]) == 0
    out = capsys.readouterr().out
    assert out.count("inside") >= 8 and "acceptance" in out and "every figure inside" in out
    assert main(["thermal", "bestest", "--case", "900FF"]) == 0      # ISO 52016-1, weather route (Perez)
    assert "sky weather (perez)" in capsys.readouterr().out
    assert main(["thermal", "bestest", "--case", "900FF", "--transposition", "hay-davies"]) == 1   # maximum low
    out = capsys.readouterr().out
    assert "OUTSIDE" in out and "900FF max_temperature" in out and "ISO 52016-1" in out and "hay-davies" in out
    assert main(["thermal", "bestest", "--case", "900FF", "--zone-model", "5r1c"]) == 1
    out = capsys.readouterr().out
    # a load printed to three decimals, as the programs' tables give it: 950's peak cooling with 15-min sub-steps
    # (outside by 0.006 kW, the default before the eighth pass) must not read "2.39 kW  2.05-2.39 OUTSIDE"
    assert main(["thermal", "bestest", "--case", "950", "--option", "substeps=4"]) == 1
    row = next(r for r in capsys.readouterr().out.splitlines() if "peak_cooling" in r).split()
    assert row[4:7] == ["2.054", "to", "2.388"] and len(row[2].split(".")[1]) == 3 and row[7] == "OUTSIDE"
    assert "5R1C" in out and "900FF max_temperature" in out
    assert main(["thermal", "bestest", "--case", "611"]) == 2
    assert "--case '611'" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["thermal", "bestest", "--case", "600", "--transposition", "isotropic"])
    assert e.value.code == 2 and "--transposition: invalid choice: 'isotropic'" in capsys.readouterr().err
    assert main(["thermal", "bestest", "--case", "620", "--zone-model", "iso52016"]) == 0
    assert "ISO 52016-1" in capsys.readouterr().out


@pytest.mark.reference
def test_cli_option_runs_a_measured_alternative(capsys):
    """``--option KEY=VALUE`` runs an alternative of the validation page from the command line, as run_case does
    with it (the lost share of the ASHRAE 140 table: 950's peak cooling 0.024 kW below the default's), and
    refuses a bad key, value or model in one line."""
    from widesky.cli import main
    from widesky.thermal.bestest import parse_iso52016_option, run_case
    assert main(["thermal", "bestest", "--case", "950", "--option", "lost=table"]) == 0
    out = capsys.readouterr().out
    row = next(r for r in out.splitlines() if "peak_cooling" in r).split()
    expect = run_case("950", iso52016_options={"lost": "table"})["peak_cooling"] / 1000.0
    assert "lost=table" in out.splitlines()[0] and float(row[2]) == pytest.approx(expect, abs=6e-4)
    assert float(row[2]) < run_case("950")["peak_cooling"] / 1000.0 - 0.01
    assert parse_iso52016_option("substeps=4") == ("substeps", 4)
    for argv, msg in ((["--option", "lost=x"], "lost must be one of enclosure, table, transmitted"),
                      (["--option", "lost"], "KEY one of solar"),
                      (["--option", "lost=table", "--zone-model", "5r1c"], "applies to --zone-model iso52016")):
        assert main(["thermal", "bestest", "--case", "950", *argv]) == 2
        err = capsys.readouterr().err
        assert msg in err and len(err.strip().splitlines()) == 1


@pytest.mark.reference
@pytest.mark.slow
def test_610_integrator_route_inside_its_ranges():
    """The integrator route with the overhang in the scene (one integrator year of the shaded room): every
    figure of Case 610 inside, and the overhang cuts the year's window gain to 0.82 of the open room's, inside the
    six programs' ratio of transmitted solar, and October's noon gain as the analytic shadow does."""
    import warnings
    from widesky.thermal.bestest import integrator_irradiance, run_case, verdicts
    with warnings.catch_warnings():       # TMY3 visibilities beyond the sky model's range: clamped
        warnings.filterwarnings("ignore", ".*clamped to the sky model's ranges", UserWarning)
        poa = integrator_irradiance(geometry=("south", "overhang"))
        open_room = integrator_irradiance(geometry=("south", None))
    r = run_case("610", poa=poa)
    out = [v for v in verdicts("610", r) if not v.inside]
    assert not out, [(v.quantity, round(v.value, 3), v.low, v.high) for v in out]
    # the year's cut against the six programs' transmitted solar, 610 over 600 (ASHRAE 140-2020 Tables B8-14 and
    # B8-15: BSIMAC 641/820, CSE 665/826, DeST 663/805, EnergyPlus 646/804, ESP-r 631/814, TRNSYS 662/823:
    # 0.775-0.824); one sample per triangle gave 0.846
    cut = poa["window_gain"]["Win600"].sum() / open_room["window_gain"]["Win600"].sum()
    assert 0.77 < cut < 0.83
    # October's noon sun (41-47 degrees) shades the window's top 10-30 %: the analytic shadow and the ray-cast
    # weather route cut the noon gain to 0.84; one sample per triangle (the centroid) saw 0.98 (docs/thermal.md)
    idx = r["hourly"].index
    noon = (idx.month == 10) & np.isin((idx - pd.Timedelta(hours=1)).hour, [11, 12, 13])
    oct_cut = poa["window_gain"]["Win600"][noon].sum() / open_room["window_gain"]["Win600"][noon].sum()
    assert 0.78 < oct_cut < 0.88
    with pytest.raises(ValueError, match="geometry"):
        run_case("610", poa=open_room)                   # a poa of another room is refused


@pytest.mark.reference
@pytest.mark.parametrize("case, low, high", [("600", 804.0, 826.0), ("610", 631.0, 665.0)])
def test_transmitted_solar_inside_the_programs_spread(case, low, high):
    """The light through the south windows, the component under every load (issue 38: no compensating error):
    the year's transmitted solar per m2 of glass on the weather route (Perez; beam at the unit's tau by angle, sky,
    horizon band and ground at its hemispherical tau, shaded by the 610 overhang by ray casting) inside the six
    programs' (ASHRAE 140-2020 Tables B8-14/B8-15: BSIMAC 820/641, CSE 826/665, DeST 805/663, EnergyPlus 804/646,
    ESP-r 814/631, TRNSYS 823/662 kWh m-2 for 600/610). Measured 818.0 and 663.1; Hay-Davies (no horizon band)
    gives 790.8 for 600, below all six."""
    from widesky.thermal.bestest import (ANGLES, INTERIOR_SOLAR_ABSORPTANCE, case_definition, case_gains,
                                         load_weather, solar_escape_fraction)
    from widesky.thermal.optics import hemispherical
    c = case_definition(case)
    tau = c.window.optics(ANGLES, np.array([280.0, 2500.0]))["transmittance"][:, 0]   # broadband records: flat
    tau_d = float(hemispherical(ANGLES, tau))
    weather, site = load_weather("tmy3")
    gains = case_gains(c, weather, site, g_table=(ANGLES, tau, tau_d, tau_d))          # tau in place of g
    esc = solar_escape_fraction(tau_d, c.window_area, c.interior_area, INTERIOR_SOLAR_ABSORPTANCE)
    transmitted = gains["window"].sum() / (1.0 - esc) / c.window_area / 1000.0       # [kWh m-2 of glass]
    assert low <= transmitted <= high


@pytest.mark.reference
def test_iso52016_heavyweight_against_5r1c():
    """ISO 52016-1 puts the heavy mass behind the inside surfaces' own convection: on the weather route it
    lands Case 900's annual cooling (5R1C: 2.06 MWh, below the 2.35 limit), lifts 900FF's maximum by 1.2 K
    (5R1C: 41.9 degC; ISO 52016-1 43.2 as the hour's mean of 15-min sub-steps, 43.3 at the hourly step's ends;
    programs 43.3-46.0), and swings further than 5R1C in free float (docs/thermal.md)."""
    from widesky.thermal.bestest import run_case, verdicts
    iso = {v.quantity: v for v in verdicts("900", run_case("900", zone_model="iso52016"))}
    r5 = {v.quantity: v for v in verdicts("900", run_case("900", zone_model="5r1c"))}
    assert iso["annual_cooling"].inside and not r5["annual_cooling"].inside
    ff_iso, ff_5 = run_case("900FF", zone_model="iso52016"), run_case("900FF", zone_model="5r1c")
    assert ff_iso["temp_max"] > ff_5["temp_max"] + 1.0 and ff_5["temp_max"] < 43.3
    hourly = run_case("900FF", zone_model="iso52016", iso52016_options={"substeps": 1})
    assert 43.3 <= hourly["temp_max"] <= 46.0
    assert ff_iso["temp_max"] - ff_iso["temp_min"] > ff_5["temp_max"] - ff_5["temp_min"]
    with pytest.raises(ValueError, match="zone_model="):
        run_case("900", zone_model="iso13790")


ISO_WEATHER_OUTSIDE = {
    # ISO 52016-1 with the ASHRAE 140 solar distribution, the window gap at its temperature, 5-min sub-steps (eighth
    # pass: step-converged verdicts) and EnergyPlus's default inside convection (TARP on the opaque surfaces, ISO
    # 15099 on the windows; fifth pass, docs/validation/thermal-bestest-cases.md) evaluated once per sub-step as
    # EnergyPlus does, on the weather route with its Perez transposition: every figure inside. With 15-min sub-steps
    # (the default before) 950's peak cooling was 2.394 kW > 2.388, a discretization error of the first-order step
    # (2.383 at 5 min, 2.380 at 2 min, about 2.378 at the limit); the integrator route keeps it outside (2.399).
}


@functools.lru_cache(maxsize=None)
def _iso_weather(case, transposition="perez", **options):
    from widesky.thermal.bestest import run_case
    return run_case(case, zone_model="iso52016", iso52016_options=options or None, transposition=transposition)


def _iso_params():
    from widesky.thermal.bestest import CASE_SPECS, LOAD_CASES
    for case in CASE_SPECS:
        qs = (("annual_heating", "annual_cooling", "peak_heating", "peak_cooling") if case in LOAD_CASES
              else ("min_temperature", "max_temperature", "mean_temperature"))
        for q in qs:
            why = ISO_WEATHER_OUTSIDE.get((case, q))
            marks = [pytest.mark.xfail(strict=True, reason=why)] if why else []
            yield pytest.param(case, q, marks=marks, id=f"{case}-{q}")


@pytest.mark.reference
@pytest.mark.parametrize("case,quantity", list(_iso_params()))
def test_iso52016_weather_route_figures(case, quantity):
    """Every figure of the 18 cases with ISO 52016-1 on the weather (Perez) route against its range: 67 of 68
    inside (Table 25's convection: 65; h_ci iterated within the sub-step: 66); the known miss is a strict xfail."""
    from widesky.thermal.bestest import verdicts
    (v,) = [v for v in verdicts(case, _iso_weather(case)) if v.quantity == quantity]
    assert v.inside, (case, quantity, round(v.value, 3), v.low, v.high)


@pytest.mark.reference
def test_iso52016_corrections_move_the_heavy_cases_the_right_way():
    """The ASHRAE 140 solar distribution with h_ci by heat-flow direction takes the night-ventilated 950FF's
    maximum from 38.0 degC (outside 36.1-37.1) into its range and 900FF's minimum up by 0.8 K; the solar
    distribution alone over-cools (900 cooling below its 2.35 MWh limit). On the weather route with Hay-Davies, where
    the corrections were made and measured (docs/validation/thermal-bestest-cases.md, the steps table)."""
    hd = "hay-davies"
    before = dict(solar="area", convection="fixed", gaps="en673", substeps=1, transposition=hd, iterate=0)
    only_solar = dict(solar="ashrae140", convection="fixed", gaps="en673", substeps=1, transposition=hd, iterate=0)
    after = dict(substeps=1, convection="direction", transposition=hd, iterate=0)   # the three corrections, as made
    assert _iso_weather("950FF", **before)["temp_max"] > 37.1 >= _iso_weather("950FF", **after)["temp_max"]
    assert _iso_weather("900FF", **after)["temp_min"] - _iso_weather("900FF", **before)["temp_min"] > 0.7
    assert (_iso_weather("900", **only_solar)["annual_cooling"] < 2350.0
            < _iso_weather("900", **after)["annual_cooling"])
    with pytest.raises(ValueError, match="iso52016 option"):
        _iso_weather("600", solar="sideways")


@pytest.mark.reference
def test_setback_ramp_sets_640s_heating_peak():
    """Case 640's set-point ramps from 10 to 20 degC between 07:00 and 08:00 (140-2020 7.2.2.1.4). At the hourly
    step the ramp hour can only hold its mean, 15 degC, and the peak (4.04 kW, 8 Feb 09:00, on the programs'
    minimum) falls in the hour after; with 15-min sub-steps following the ramp the peak is the ramp hour itself,
    26 Nov 07:00-08:00, the hour five of the six programs report, at 4.55 kW (programs 4.04-4.66). Measured on the
    Hay-Davies weather route with Table 25's convection lagged one sub-step, as the steps table of
    docs/validation/thermal-bestest-cases.md (Perez: 4.05 kW hourly). With the default's (TARP and ISO 15099) the ramp
    hour stays the peak: 4.63 kW with the lag, 4.74 with h_ci at each sub-step's own temperatures (sixth pass: the
    air jumps 2.5 K a sub-step while the surfaces stay cold, so the iterated |dT| and h_ci are larger). These at the
    15-min step of those passes; the default's 5-min step (eighth pass) keeps the ramp hour the peak, 4.53 kW."""
    hourly = _iso_weather("640", "hay-davies", substeps=1, convection="direction", iterate=0)
    sub = _iso_weather("640", "hay-davies", convection="direction", iterate=0, substeps=4)
    lagged, iterated = _iso_weather("640", substeps=4), _iso_weather("640", iterate=20, substeps=4)
    default = _iso_weather("640")
    assert 4400.0 < default["peak_heating"] < 4658.0 and default["peak_heating_time"].strftime("%m-%d %H") == "11-26 08"
    assert 4400.0 < lagged["peak_heating"] < 4658.0 < iterated["peak_heating"] < 4800.0
    assert iterated["peak_heating_time"].strftime("%m-%d %H") == "11-26 08"
    assert lagged["peak_heating_time"].strftime("%m-%d %H") == "11-26 08"
    assert hourly["peak_heating"] < 4045.0 and hourly["peak_heating_time"].strftime("%m-%d %H") == "02-08 09"
    assert 4400.0 < sub["peak_heating"] < 4658.0
    assert sub["peak_heating_time"].strftime("%m-%d %H") == "11-26 08"


def test_box_view_factors_against_closed_forms():
    """The view factors of a rectangular room: rows sum to 1, reciprocity A_i F_ij = A_j F_ji, and the cube's
    0.1998 between opposite faces and 0.2000 between adjacent ones (Incropera, Table 13.2 closed forms)."""
    from widesky.thermal.zone_iso52016 import box_view_factors
    F = box_view_factors(1.0, 1.0, 1.0)
    assert F.sum(1) == pytest.approx(np.ones(6), abs=1e-12) and np.all(np.diag(F) == 0)
    assert F[0, 1] == pytest.approx(0.19982, abs=2e-5) and F[0, 2] == pytest.approx(0.20004, abs=2e-5)
    F = box_view_factors(8.0, 6.0, 2.7)                       # floor, ceiling, north, east, south, west
    area = np.array([48.0, 48.0, 21.6, 16.2, 21.6, 16.2])
    assert F.sum(1) == pytest.approx(np.ones(6), abs=1e-12)
    assert area[:, None] * F == pytest.approx((area[:, None] * F).T, abs=1e-12)
    assert F[0, 1] == pytest.approx(0.4942, abs=1e-4)           # floor to ceiling of the ASHRAE 140 room


def test_radiant_exchange_parallel_plates_by_hand():
    """Two grey plates that see only each other exchange 4 sigma T^3 A / (1/eps_1 + 1/eps_2 - 1) per kelvin; an
    enclosure's conductances are symmetric with rows summing to zero."""
    from widesky.thermal.zone_iso52016 import SIGMA, box_view_factors, radiant_exchange
    G = radiant_exchange([2.0, 2.0], [[0.0, 1.0], [1.0, 0.0]], [0.9, 0.84], temperature=20.0)
    h = 4 * SIGMA * 293.15 ** 3 / (1 / 0.9 + 1 / 0.84 - 1)
    assert G == pytest.approx(np.array([[2 * h, -2 * h], [-2 * h, 2 * h]]), rel=1e-12)
    area = np.array([48.0, 48.0, 21.6, 16.2, 21.6, 16.2])
    G = radiant_exchange(area, box_view_factors(8.0, 6.0, 2.7), np.full(6, 0.9))
    assert G.sum(1) == pytest.approx(np.zeros(6), abs=1e-9) and G == pytest.approx(G.T, abs=1e-9)
    # the floor exchanges 4.9 W m-2 K-1 with the rest, the ISO 52016-1 star's h_ri (1 - A/A_tot) only 3.7
    assert G[0, 0] / 48.0 == pytest.approx(4.94, abs=0.01)
    with pytest.raises(ValueError, match="view_factors"):
        radiant_exchange([1.0, 1.0], [[0.0, 0.5], [1.0, 0.0]], [0.9, 0.9])


def test_iso52016_longwave_matrix_and_surface_gains_by_hand():
    """The star written as a matrix reproduces the default exchange; a heat input at a window's inside pane with the
    air held at the outdoor temperature leaves to the air by h_ci and out through the glass and the outside
    coefficient, in the ratio of those two conductances."""
    from widesky.thermal.zone_iso52016 import H_CI, H_RI, Element, Layer, simulate_iso52016
    T = 48
    wall = Element("w", "wall", 10.0, 90.0, (Layer(0.1, 1.0, 1000.0, 2000.0),))
    win = Element("g", "window", 4.0, 90.0, resistance=0.2)
    area = np.array([10.0, 4.0])
    star = H_RI * (np.diag(area) - area[:, None] * area[None, :] / area.sum())
    kw = dict(volume=30.0, warmup_steps=24)
    args = (np.full(T, 0.0), np.full(T, -5.0), 10.0, 4.0, np.zeros((T, 2)), np.full(T, 300.0), 100.0, 10.0)
    a = simulate_iso52016([wall, win], *args, 20.0, 26.0, **kw)
    b = simulate_iso52016([wall, win], *args, 20.0, 26.0, longwave=star, **kw)
    assert b["heating"] == pytest.approx(a["heating"], rel=1e-10)
    q = 400.0
    gains = np.zeros((T, 1, 2))
    gains[:, 0, 1] = q
    r = simulate_iso52016([win], np.full(T, 20.0), np.full(T, 20.0), 10.0, 0.0, np.zeros((T, 1)), np.zeros(T), 0.0,
                          0.0, 20.0, 20.0, surface_gains=gains, **kw)
    h_in, h_out = H_CI["window"] * 4.0, 4.0 / (0.2 + 1 / 10.0)
    assert r["cooling"][-1] == pytest.approx(q * h_in / (h_in + h_out), rel=1e-9)
    with pytest.raises(ValueError, match="surface_gains"):
        simulate_iso52016([win], np.zeros(3), np.zeros(3), 10.0, 0.0, np.zeros((3, 1)), np.zeros(3), 0.0, 0.0,
                          20.0, 20.0, volume=1.0, surface_gains=np.zeros((3, 2, 2)))
    with pytest.raises(ValueError, match="longwave"):
        simulate_iso52016([win], np.zeros(3), np.zeros(3), 10.0, 0.0, np.zeros((3, 1)), np.zeros(3), 0.0, 0.0,
                          20.0, 20.0, volume=1.0, longwave=np.ones((1, 1)))


@pytest.mark.reference
def test_interior_longwave_of_the_room():
    """The ASHRAE 140 room's inside long-wave conductances by view factors: symmetric, rows summing to zero, between
    a wall and its own window only through reflections (coplanar: no view), and the floor coupled at 4.9 W m-2 K-1
    where ISO 52016-1's star gives h_ri (1 - A_floor / A_total) = 3.7."""
    from widesky.thermal.bestest import case_definition, interior_longwave, iso52016_elements
    c = case_definition("900")
    els = iso52016_elements(c)
    G = interior_longwave(c, els)
    names = [el.name for el in els]
    assert G.sum(1) == pytest.approx(np.zeros(len(els)), abs=1e-9) and G == pytest.approx(G.T, abs=1e-9)
    ws, win = names.index("wall south"), names.index("window south")
    assert 0 < -G[ws, win] < 0.01 * G[ws, ws]          # coplanar: no view, exchange only through reflections
    assert G[names.index("floor"), names.index("floor")] / 48.0 == pytest.approx(4.93, abs=0.02)
    with pytest.raises(ValueError, match="iso52016 option"):
        _iso_weather("600", longwave="sideways")


@pytest.mark.reference
def test_lost_share_of_the_transmitted_light():
    """The share of the window's g-value gain lost back out through the windows: the enclosure formula's
    ``rho p / (1 - rho (1 - p))`` (rho 0.4, p = tau_d 12 / 171.6) on the whole gain, the table's 0.035, or the
    formula's share of the transmitted light only (tau_d / g_d of the gain: Win600's absorbed part, 9.6 % of g_d,
    flows in as heat and cannot leave by reflection)."""
    from widesky.thermal.bestest import _window_g, case_definition, lost_share
    c = case_definition("900")
    _, _, g_d, tau_d = _window_g(c.window)
    p = tau_d * 12.0 / 171.6
    esc = 0.4 * p / (1 - 0.4 * (1 - p))
    assert lost_share(c) == pytest.approx((esc, esc), rel=1e-12) and esc == pytest.approx(0.0276, abs=5e-4)
    assert lost_share(c, "table") == pytest.approx((0.035, esc), rel=1e-12)
    assert lost_share(c, "transmitted") == pytest.approx((esc * tau_d / g_d, esc), rel=1e-12)
    assert 1 - tau_d / g_d == pytest.approx(0.096, abs=0.002)
    with pytest.raises(ValueError, match="lost="):
        lost_share(c, "sideways")


def test_iso15099_window_convection_by_hand():
    """ISO 15099:2003 8.3.2.2 (EnergyPlus's window treatment under TARP), by hand for a 2 m vertical pane 10 K
    below 20 degC air at 101325 Pa: film 290.65 K, ISO 15099 Annex B air k 0.0254274 W m-1 K-1, mu 1.808111e-5 Pa
    s, c_p 1006.3196 J kg-1 K-1, rho = p 28.97 / (8314.462 T_f) 1.214676 kg m-3; Ra = rho^2 H^3 g c_p dT /
    (T_f mu k) = 8.720e9, below Ra_cv = 2.5e5 exp(0.72 90)^(1/5) = 1.06e11: Nu = 0.56 Ra^(1/4) = 171.13,
    h = Nu k / H = 2.1757 W m-2 K-1 (Walton's vertical 1.31 x 10^(1/3) = 2.82). At Denver's 83460 Pa (Ra x 0.6785)
    1.9746. A skylight (tilt 0, H 1 m) 10 K colder than the air, unstable: 0.13 Ra^(1/3) k / H = 3.4019; 10 K
    warmer, stable (theta 180): film 295.65 K, Ra 1.00638e9, 0.58 Ra^(1/5) k / H = 0.94593."""
    from widesky.thermal.zone_iso52016 import _tarp, iso15099_window_convection as h15099
    assert h15099(-10.0, 90.0, 2.0, 20.0) == pytest.approx(2.17566, rel=2e-5)
    assert h15099(-10.0, 90.0, 2.0, 20.0, 83460.0) == pytest.approx(1.97456, rel=2e-5)
    assert _tarp(-10.0, 90.0) == pytest.approx(2.8224, rel=1e-4)
    assert h15099(-10.0, 0.0, 1.0, 20.0) == pytest.approx(3.40190, rel=2e-5)
    assert h15099(10.0, 0.0, 1.0, 20.0) == pytest.approx(0.945932, rel=2e-5)
    assert h15099(-10.0, 0.0, 3.0, 20.0) == pytest.approx(3.40190, rel=2e-5)     # turbulent: H drops out
    assert h15099(0.0, 90.0, 2.0, 20.0) == 0.1                                   # EnergyPlus's lower limit


def test_tarp_iso15099_puts_iso15099_on_the_windows_only():
    """``convection="tarp-iso15099"``: a window-only zone held at 20 degC with 0 degC outside settles where its
    loss is the series of ISO 15099's h at the pane's own difference, the glass and the outside coefficient; a zone
    without windows runs exactly as with ``"tarp"``; a window without its height is refused."""
    from widesky.thermal.zone_iso52016 import Element, Layer, iso15099_window_convection, simulate_iso52016
    T = 72
    win = Element("g", "window", 6.0, 90.0, resistance=0.15, height=2.0)
    run = dict(volume=30.0, warmup_steps=48, air_pressure=83460.0)
    args = (np.zeros(T), np.zeros(T), 8.0, 0.0, np.zeros((T, 1)), np.zeros(T), 0.0, 0.0, 20.0, 20.0)
    r = simulate_iso52016([win], *args, convection="tarp-iso15099", **run)
    h = iso15099_window_convection(r["temp_surface"][-1] - 20.0, 90.0, 2.0, 20.0, 83460.0)
    assert r["heating"][-1] == pytest.approx(6.0 * 20.0 / (1 / h + 0.15 + 1 / 8.0), rel=1e-4)
    tarp = simulate_iso52016([win], *args, convection="tarp", **run)
    assert tarp["heating"][-1] > r["heating"][-1] + 5.0
    wall = Element("w", "wall", 10.0, 90.0, (Layer(0.1, 1.0, 1000.0, 2000.0),))
    roof = Element("r", "roof", 10.0, 0.0, (Layer(0.1, 1.0, 1000.0, 2000.0),))
    args2 = (np.zeros(T), np.zeros(T), 8.0, 0.0, np.zeros((T, 2)), np.full(T, 200.0), 100.0, 5.0, 20.0, 26.0)
    a = simulate_iso52016([wall, roof], *args2, convection="tarp", **run)
    b = simulate_iso52016([wall, roof], *args2, convection="tarp-iso15099", **run)
    assert np.array_equal(a["heating"], b["heating"])
    with pytest.raises(ValueError, match="height="):
        simulate_iso52016([Element("g", "window", 6.0, 90.0, resistance=0.15)], *args,
                          convection="tarp-iso15099", **run)


@pytest.mark.parametrize("kind,convection", [("wall", "tarp"), ("window", "tarp-iso15099")])
def test_iterated_convection_is_the_correlation_at_the_steps_own_temperatures(kind, convection):
    """``iterate``: one element alone (a 10 m2 wall of 0.1 m concrete-like layer, or a 2 m high window) and the air
    of 30 m3, both at 20 degC, -10 degC outside, one free-floating hour. The h_ci the step used follows from the
    air node's balance by hand, ``h = C_air (T_air - 20) / dt / (A (T_s - T_air))`` (one element: no long-wave
    exchange, no ventilation, no gains). Iterated, it equals the correlation (Walton's vertical 1.31 |dT|^(1/3),
    ISO 15099's for the window) at the step's own surface-air difference within 2e-3 W m-2 K-1 (tolerance 1e-3 on
    the iteration); with the one-step lag it is the correlation at the start's zero difference, EnergyPlus's lower
    limit 0.1, and the check fails by more than 1 W m-2 K-1."""
    from widesky.thermal.zone_iso52016 import (Element, Layer, _tarp, iso15099_window_convection,
                                               simulate_iso52016)
    el = (Element("w", "wall", 10.0, 90.0, (Layer(0.1, 1.0, 1000.0, 2000.0),)) if kind == "wall"
          else Element("g", "window", 10.0, 90.0, resistance=0.15, height=2.0))
    corr = ((lambda dt, ta: _tarp(dt, 90.0)) if kind == "wall"
            else (lambda dt, ta: iso15099_window_convection(dt, 90.0, 2.0, ta, 101325.0)))
    args = ([-10.0], [-10.0], 20.0, 0.0, np.zeros((1, 1)), [0.0], 0.0, 0.0, -np.inf, np.inf)
    run = dict(volume=30.0, convection=convection, temp_start=20.0)

    def h_used(r):
        ta, ts = r["temp_air"][0], r["temp_surface"][0]
        return 1200.0 * 30.0 * (ta - 20.0) / 3600.0 / (10.0 * (ts - ta)), ts - ta, ta
    it = simulate_iso52016([el], *args, iterate=20, **run)
    h, dt, ta = h_used(it)
    assert dt < -1.0 and h == pytest.approx(corr(dt, ta), abs=2e-3)
    assert len(it["h_ci_change"]) >= 2 and it["h_ci_change"][0] > 1.0 and it["h_ci_change"][-1] <= 1e-3
    lag = simulate_iso52016([el], *args, **run)
    h0, dt0, ta0 = h_used(lag)
    assert h0 == pytest.approx(0.1, abs=1e-6) and abs(h0 - corr(dt0, ta0)) > 1.0
    assert len(lag["h_ci_change"]) == 0
    with pytest.raises(ValueError, match="iterate="):
        simulate_iso52016([el], *args, iterate=-1, **run)


@pytest.mark.reference
def test_tarp_trades_the_heavy_misses_for_the_single_pane_peak():
    """Walton's (TARP) inside convection instead of ISO 52016-1 Table 25 (docs/validation/thermal-bestest-cases.md,
    third pass): the night-ventilated heavy room's peak cooling falls by 0.1 kW towards the programs' 2.05-2.39 and
    the 950FF minimum into its range, but the single pane's convection at its large difference lifts Case 670's peak
    heating above the programs' 4.22 kW. As measured then, h_ci lagged one sub-step."""
    base, tarp = {}, {}
    for case in ("670", "950", "950FF"):
        base[case] = _iso_weather(case, convection="direction", iterate=0)
        tarp[case] = _iso_weather(case, convection="tarp", iterate=0)
    assert tarp["950"]["peak_cooling"] < base["950"]["peak_cooling"] - 80.0
    assert tarp["950FF"]["temp_min"] < -12.5 < base["950FF"]["temp_min"]
    assert base["670"]["peak_heating"] <= 4221.0 < tarp["670"]["peak_heating"]


@pytest.mark.reference
def test_energyplus_convection_keeps_the_single_pane_peak():
    """EnergyPlus's default inside convection as EnergyPlus applies it (``"tarp-iso15099"``, the default since the
    fifth pass: Walton's correlations on the opaque surfaces, ISO 15099 8.3.2.2 on the windows) against ISO
    52016-1 Table 25 (``"direction"``) and Walton's on every surface (``"tarp"``), weather (Perez) route: the heavy
    misses come in as with Walton's everywhere (950FF minimum -12.57 degC, 910 heating 2.05 MWh, 950's peak 2.53 ->
    2.39 kW), but the single pane's laminar ISO 15099 coefficient (about 2.0 W m-2 K-1 at 15 K on a 2 m pane at
    Denver's pressure, against Walton's 3.2) keeps Case 670's peak heating at Table 25's 4.13 kW (programs
    3.65-4.22; Walton's everywhere 4.47), and Case 600's heating falls into the six programs' 3.99-4.50 MWh. As
    measured then, h_ci lagged one sub-step (iterate=0, the default; iterated, sixth pass, not kept: 670 4.13 kW,
    950 2.389, 950FF -12.585 degC, 910 2.05 MWh, 600 4.43)."""
    from widesky.thermal.bestest import reference_results
    e = {c: _iso_weather(c, iterate=0) for c in ("600", "670", "910", "950", "950FF")}
    t25 = {c: _iso_weather(c, convection="direction", iterate=0) for c in ("600", "670", "950")}
    tarp = _iso_weather("670", convection="tarp", iterate=0)
    assert abs(e["670"]["peak_heating"] - t25["670"]["peak_heating"]) < 20.0
    assert e["670"]["peak_heating"] <= 4221.0 < tarp["peak_heating"]
    assert e["950"]["peak_cooling"] < t25["950"]["peak_cooling"] - 100.0
    assert e["950FF"]["temp_min"] < -12.5 and e["910"]["annual_heating"] < 2300.0
    programs = reference_results()["600"]["annual_heating"]["programs"]
    assert min(programs.values()) <= e["600"]["annual_heating"] <= max(programs.values()) < t25["600"]["annual_heating"]
