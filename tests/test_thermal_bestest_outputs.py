"""ASHRAE 140's other outputs (issue 38: no compensating error), against the six reference programs' published
figures (ASHRAE 140-2020 results workbook RESULTS5-2A; BSIMAC, CSE, DeST, EnergyPlus, ESP-r, TRNSYS), on both sky
routes: the light on Case 600's surfaces and through the windows of Cases 600-670 (``widesky.thermal.bestest_solar``),
the free-floating rooms hour by hour on the Standard's days (``bestest_days``) and Cases 600 and 900 month by month
(``bestest_monthly``).

The weather route (Perez 1990) is inside the programs' range on 25 of the 26 figures (the single pane's cloudy day
1.1 % under EnergyPlus's, the lowest); the integrator route misses four, each traced to a stated cause with its own
check: the north wall (the room's shadow on the ground in front of it, which the programs' unobstructed ground does
not have) and the south windows of 600 (the year and 14 July) and 610 (the all-sky sky's summer distribution, which
follows the Perez 1993 sky where the programs' transpositions follow Perez 1990: the same light through one optics
convention, parted by the angles it reaches the glass at). The free-floating rooms' hourly
temperatures on the Standard's days are inside the programs' hourly range on both routes.
"""

import functools
import warnings

import numpy as np
import pytest

from widesky.thermal.bestest_solar import (ANNUAL_INCIDENT, ANNUAL_TRANSMITTED, DAY_HOURLY_RANGE, DAY_INCIDENT,
                                           DAY_TRANSMITTED, HOURS, PROGRAMS, solar_outputs, solar_verdicts)


def test_published_tables_are_whole_and_consistent():
    """Every figure has one value per program; each day's hourly range holds every program's day (the sum of the
    hourly lows is at most the lowest day, the sum of the highs at least the highest)."""
    for table in (ANNUAL_INCIDENT, ANNUAL_TRANSMITTED, DAY_INCIDENT, DAY_TRANSMITTED):
        assert all(len(v) == len(PROGRAMS) for v in table.values())
    assert sum(v is None for vals in ANNUAL_TRANSMITTED.values() for v in vals) == 2      # CSE: no 620/630
    for key, (lo, hi) in DAY_HOURLY_RANGE.items():
        assert len(lo) == len(hi) == len(HOURS) and all(a <= b for a, b in zip(lo, hi))
        assert sum(lo) <= min(DAY_INCIDENT[key]) + 1e-6 and sum(hi) >= max(DAY_INCIDENT[key]) - 1e-6
    # the same programs' loads figures elsewhere in the package: EnergyPlus's Case 600 south incident is the
    # Perez 1990 transposition of the same weather (widesky's weather route gives 1370.0, tested below)
    assert ANNUAL_INCIDENT["south"][PROGRAMS.index("EnergyPlus")] == 1370.48


@functools.lru_cache(maxsize=None)
def _outputs(route, transposition="perez", diffuse_optics="angular"):
    with warnings.catch_warnings():          # TMY3 visibilities beyond the sky model's range: clamped
        warnings.filterwarnings("ignore", ".*clamped to the sky model's ranges", UserWarning)
        return solar_outputs(route, transposition, diffuse_optics=diffuse_optics)


def _hourly_outside(out, tolerance=0.01, floor=2.0):
    """Hours whose incident solar leaves the programs' hourly range widened by 1 % + 2 Wh m-2 (the programs'
    own hour conventions differ by about that at noon on the horizontal)."""
    bad = []
    for key, (lo, hi) in DAY_HOURLY_RANGE.items():
        for h, a, b in zip(HOURS, lo, hi):
            v = out["hourly"][key][h - 1]
            if not (a * (1 - tolerance) - floor <= v <= b * (1 + tolerance) + floor):
                bad.append((key, h, round(float(v), 1), a, b))
    return bad


@pytest.mark.reference
def test_weather_route_light_inside_the_programs():
    """Perez 1990 on the TMY3 file: 25 of the 26 solar figures inside the six programs' range, and every daylight
    hour of 14 July and 4 May within 1 % + 2 Wh m-2 of it. The miss: the single pane of 670 on the cloudy 4 May,
    866.6 against 876.1-1013.4 Wh m-2 (EnergyPlus the lowest): the double pane of 600 that day is on the programs'
    lowest too (694.3 against 693.9), and the single pane's light over the double pane's, 1.248, is inside the six
    programs' 1.208-1.263 (EnergyPlus's 1.263 the highest). Hay-Davies (no horizon band) puts Case 600's transmitted
    solar below all six programs (790.8 against 804.0-825.5): the check can fail."""
    out = _outputs("weather")
    bad = [(v.case, v.quantity) for v in solar_verdicts(out) if not v.inside]
    assert bad == [("670", "may_4_transmitted")]
    d = out["day_transmitted"]
    lowest = min(DAY_TRANSMITTED[("600", "may_4")])
    assert lowest <= d[("600", "may_4")] < 1.001 * lowest
    ratios = [a / b for a, b in zip(DAY_TRANSMITTED[("670", "may_4")], DAY_TRANSMITTED[("600", "may_4")])]
    assert min(ratios) <= d[("670", "may_4")] / d[("600", "may_4")] <= max(ratios)
    assert out["incident"]["south"] == pytest.approx(1370.0, abs=0.5)         # EnergyPlus 1370.48
    assert _hourly_outside(out) == []
    hd = {(v.case, v.quantity): v for v in solar_verdicts(_outputs("weather", "hay-davies"))}
    assert not hd[("600", "transmitted_south")].inside and hd[("600", "transmitted_south")].value < 800.0


@pytest.mark.reference
@pytest.mark.xfail(strict=True, reason="integrator route: the north wall's light is 5 % under the programs' lowest "
                   "(the room shades its ground) and the south windows' of 600 (the year, 14 July) and 610 0.05 %, "
                   "0.3 % and 1.9 % over their highest (the angles the all-sky sky's light reaches the glass at); "
                   "docs/validation/thermal-bestest-cases.md")
def test_integrator_route_light_inside_the_programs():
    out = _outputs("integrator")
    assert all(v.inside for v in solar_verdicts(out))


@pytest.mark.reference
def test_integrator_route_misses_are_the_stated_ones():
    """Which figures the integrator route misses, and by how much: the north wall 380 against 399-477 kWh m-2,
    600's and 610's transmitted 825.9 and 677.7 against 804.0-825.5 and 631.3-665.3 kWh m-2, 600's on 14 July
    1372.5 against 1266.9-1368.1 Wh m-2; every other figure inside.
    The 14 July and 4 May days are inside as sums; hour by hour the south wall's clear noon is up to 1.2 % over
    the programs' highest (the sky's light, within the widened range) and the west wall's mornings (hours ending
    07:00-10:00) under their lowest (its ground in the room's shadow)."""
    out = _outputs("integrator")
    bad = {(v.case, v.quantity): v for v in solar_verdicts(out) if not v.inside}
    assert set(bad) == {("600", "incident_north"), ("600", "transmitted_south"), ("610", "transmitted_south"),
                        ("600", "july_14_transmitted")}
    assert 1.0 < bad[("600", "july_14_transmitted")].value / bad[("600", "july_14_transmitted")].high < 1.01
    assert 0.93 < bad[("600", "incident_north")].value / bad[("600", "incident_north")].low < 0.97
    assert 1.0 < bad[("600", "transmitted_south")].value / bad[("600", "transmitted_south")].high < 1.005
    assert 1.01 < bad[("610", "transmitted_south")].value / bad[("610", "transmitted_south")].high < 1.03
    hours = _hourly_outside(out)              # the west wall's mornings: the sun east, its ground in the room's shadow
    assert hours and all(k[1] == "west" and 7 <= h <= 10 and v < lo for k, h, v, lo, _ in hours)


@pytest.mark.reference
def test_integrator_north_wall_miss_is_the_shaded_ground():
    """The room's shadow on the ground north of it, and the sky it hides from that ground, take 27 % of the north
    wall's ground-reflected light (121.6 against the unobstructed 0.2 x GHI / 2 = 167.0 kWh m-2). The programs model
    an unobstructed ground: with it in place of the integrator's own, the wall's light is inside their range."""
    from widesky.thermal.bestest import GROUND_REFLECTANCE, integrator_irradiance, load_weather
    weather, _ = load_weather("tmy3")
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*clamped to the sky model's ranges", UserWarning)
        poa = integrator_irradiance("tmy3", geometry=("south", None))
    north = {p: poa[f"poa_{p}"][:, 0].sum() / 1000.0 for p in ("direct", "sky_diffuse", "ground_diffuse")}
    open_ground = GROUND_REFLECTANCE * weather["ghi"].to_numpy().sum() / 2.0 / 1000.0          # vertical: (1 - 0) / 2
    assert north["ground_diffuse"] / open_ground == pytest.approx(0.73, abs=0.03)
    lo, hi = min(ANNUAL_INCIDENT["north"]), max(ANNUAL_INCIDENT["north"])
    assert north["direct"] + north["sky_diffuse"] + north["ground_diffuse"] < lo
    assert lo <= north["direct"] + north["sky_diffuse"] + open_ground <= hi


@pytest.mark.reference
def test_integrator_south_windows_follow_the_perez_1993_sky():
    """The south windows' summer excess is the sky's distribution: month by month the integrator's sky light on the
    south wall stays within 3 % of the Perez (1993) all-weather sky fed with the same DNI and DHI (integrated over the
    same patches), while that sky puts 4-9 % more light on the wall than the Perez (1990) transposition from April
    to August, the months whose high sun shades the windows of 610 (the programs' transpositions are Perez 1990's
    or close to it)."""
    import pandas as pd
    from widesky.irradiance import dni_extra, solar_position, sun_times
    from widesky.irradiance.patches import cosine_weights, direction_from_angles, reinhart
    from widesky.irradiance.perez_sky import perez_clearness_brightness, perez_patch_shape
    from widesky.thermal.bestest import GROUND_REFLECTANCE, integrator_irradiance, load_weather
    from widesky.thermal.surface import surface_irradiance
    weather, site = load_weather("tmy3")
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*clamped to the sky model's ranges", UserWarning)
        poa = integrator_irradiance("tmy3", geometry=("south", None))
    sp = solar_position(sun_times(weather.index, label="right"), site["latitude"], site["longitude"],
                        site["altitude"])
    zen, az = sp["zenith"].to_numpy(), sp["azimuth"].to_numpy()
    dni, dhi, ghi = (weather[k].to_numpy() for k in ("dni", "dhi", "ghi"))
    per = surface_irradiance([90.0], [180.0], zen, az, dni, dhi, ghi, dni_extra(sp["earth_sun_distance"].to_numpy()),
                             GROUND_REFLECTANCE)
    p = reinhart(1)
    sun = np.stack([direction_from_angles(90.0 - z, a) for z, a in zip(zen, az)])
    eps, delta, ok = perez_clearness_brightness(dhi, dni, 90.0 - zen, np.full(len(zen), 1361.0))
    psm93 = dhi * (perez_patch_shape(p, sun, eps, delta, ok) @ cosine_weights(p, direction_from_angles(0.0, 180.0)
                                                                               .reshape(1, 3))[0])
    month = (weather.index - pd.Timedelta("1h")).month
    m = pd.DataFrame({"integrator": poa["poa_sky_diffuse"][:, 2], "psm93": psm93,
                      "perez1990": per["poa_circumsolar"][:, 0] + per["poa_sky_diffuse"][:, 0]}).groupby(month).sum()
    assert np.all(np.abs(m["integrator"] / m["psm93"] - 1) < 0.03)
    summer = (m["psm93"] / m["perez1990"]).loc[4:8]
    assert summer.min() > 1.04 and summer.max() < 1.09


@pytest.mark.reference
def test_the_routes_part_at_the_angles_of_their_diffuse_light():
    """Through one convention (the glass's transmittance or g at the sun's angle on the beam alone, its hemispherical
    value on all diffuse light), the two routes pass the same light: Case 600's transmitted solar 820.5 (integrator)
    and 820.8 kWh m-2 of glass (weather route), within 0.2 %. Each route's own angles part them: the weather route
    puts Perez 1990's circumsolar light at the sun's angle (a point source, grazing on the south glass in summer:
    818.0), the integrator takes its sky's light at each ray's own angle (nearer the glass's normal: 825.9). Case
    950's peak cooling, the one load figure outside on the integrator route, moves with the convention alone by as
    much as it is out: 2.376 and 2.389 kW (integrator, weather) through the common one, 2.399 and 2.383 through each
    route's own, against the programs' 2.054-2.388. With a glass whose g does not vary with the angle the
    convention cannot matter, and on the weather route it does not."""
    from widesky.thermal.bestest import (ANGLES, case_definition, case_gains, load_weather, reference_results,
                                         run_case_on_route)
    tr = {(route, optics): _outputs(route, "perez", optics)["transmitted"][("600", "south")]
          for route in ("weather", "integrator") for optics in ("angular", "hemispherical")}
    assert tr[("integrator", "hemispherical")] == pytest.approx(tr[("weather", "hemispherical")], rel=0.002)
    assert 1.004 < tr[("integrator", "angular")] / tr[("integrator", "hemispherical")] < 1.01
    assert 0.994 < tr[("weather", "angular")] / tr[("weather", "hemispherical")] < 0.998
    low, high = min(ANNUAL_TRANSMITTED[("600", "south")]), max(ANNUAL_TRANSMITTED[("600", "south")])
    assert low <= tr[("integrator", "hemispherical")] <= high < tr[("integrator", "angular")]
    top = max(reference_results()["950"]["peak_cooling"]["programs"].values()) / 1000.0       # EnergyPlus 2.388
    poas = {}
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*clamped to the sky model's ranges", UserWarning)
        peak = {(route, optics): run_case_on_route("950", route, poas=poas, diffuse_optics=optics)["peak_cooling"]
                / 1000.0 for route in ("weather", "integrator") for optics in ("angular", "hemispherical")}
    assert peak[("integrator", "hemispherical")] < top < peak[("integrator", "angular")]
    assert all(abs(v - top) < 0.015 for v in peak.values()), peak
    assert peak[("integrator", "angular")] - peak[("integrator", "hemispherical")] > 0.015
    # a glass with g(angle) = g_d everywhere: the two conventions give the same gains (the weather route; the
    # integrator's own convention takes the unit's g at every ray's angle, not a table)
    c = case_definition("950")
    weather, site = load_weather("tmy3")
    flat = (ANGLES, np.full(len(ANGLES), 0.7), 0.7, 0.6)
    a, b = (case_gains(c, weather, site, g_table=flat, diffuse_optics=o)["window"]
            for o in ("angular", "hemispherical"))
    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)
    with pytest.raises(ValueError, match="diffuse_optics='sky' not one of"):
        case_gains(c, weather, site, diffuse_optics="sky")


@pytest.mark.reference
def test_cli_solar_verdicts(capsys, tmp_path):
    """``widesky thermal bestest --solar`` prints the 17 solar figures with their verdicts after the case's, counts
    them in the exit status and writes them to ``--json``; the sources line names the programs' solar outputs only
    when they were checked."""
    import json
    from widesky.cli import main
    assert main(["thermal", "bestest", "--case", "600", "--solar", "--json", str(tmp_path / "b.json")]) == 1
    out = capsys.readouterr().out
    rows = [r.split() for r in out.splitlines() if "programs_solar" in r and not r.startswith("sources")]
    assert len(rows) == 26 and sum(r[-2] == "inside" for r in rows) == 25
    assert out.splitlines()[-1] == "1 figure(s) outside their range: 670 may_4_transmitted" and "RESULTS5-2A" in out
    saved = json.loads((tmp_path / "b.json").read_text())
    assert saved["solar"]["610 transmitted_south"]["value"] == pytest.approx(663.1, abs=0.1)
    assert main(["thermal", "bestest", "--case", "600", "--solar", "--transposition", "hay-davies"]) == 1
    assert "600 transmitted_south" in capsys.readouterr().out.splitlines()[-1]
    assert main(["thermal", "bestest", "--case", "600"]) == 0
    assert "RESULTS5-2A" not in capsys.readouterr().out
    assert main(["thermal", "bestest", "--case", "600", "--solar", "--weather", "drycold"]) == 2
    err = capsys.readouterr().err
    assert "--solar with --weather drycold" in err and len(err.strip().splitlines()) == 1
    assert main(["thermal", "bestest", "--case", "600", "--monthly", "--weather", "drycold"]) == 2
    assert "--monthly with --weather drycold" in capsys.readouterr().err
    assert main(["thermal", "bestest", "--case", "950FF", "--days", "--monthly"]) == 1
    out = capsys.readouterr().out
    assert "months outside the programs' range:" in out and "  900 cooling Jun: 362.1 kWh, programs 365.82 to 447.5" in out
    assert main(["thermal", "bestest", "--case", "950FF", "--days"]) == 0
    out = capsys.readouterr().out
    assert "950FF  july_14_hourly" in out and "programs_days" in out and "every figure inside" in out


@pytest.mark.reference
@pytest.mark.parametrize("route", ["weather", "integrator"])
def test_free_floating_days_hour_by_hour(route):
    """The free-floating rooms' hourly air temperature on the Standard's days (600FF and 900FF on 1 February, 650FF
    and 950FF with the night fan on 14 July): every one of the 96 hours inside the six programs' hourly range, on both
    routes. A room 1 K too warm in the afternoon (the 950FF day's band is 0.9-1.6 K wide then) would fail, and the
    5R1C network (its one mass node) leaves every day, by 0.75-1.13 K."""
    from widesky.thermal.bestest_days import FREE_FLOAT_DAY_RANGE, day_verdicts, free_float_days
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*clamped to the sky model's ranges", UserWarning)
        days = free_float_days(route)
    assert set(days) == set(FREE_FLOAT_DAY_RANGE) and all(len(v) == 24 for v in days.values())
    assert all(v.inside and v.value == 0.0 for v in day_verdicts(days))
    hot = {k: v + 1.0 for k, v in days.items()}
    assert not day_verdicts(hot)[3].inside                                # 950FF, 14 July, 1 K warmer
    if route == "weather":        # a real model that misses: 5R1C's single mass node, 0.75-1.13 K outside every day
        r5 = day_verdicts(free_float_days(route, zone_model="5r1c"))
        assert all(not v.inside and 0.5 < v.value < 1.5 for v in r5)


@pytest.mark.reference
@pytest.mark.parametrize("route", ["weather", "integrator"])
def test_monthly_loads_near_the_programs(route):
    """Cases 600 and 900 month by month (heating, cooling, their peaks; 96 figures a route): every month within 5 % of
    the six programs' monthly range, and most inside it (weather route 81 of 96, integrator route 86). The pattern the
    months show (docs/validation/thermal-bestest-cases.md): on the weather route the heavy room cools 1-5 % less than
    every program from May to July and heats up to 3 % more in April and May, which its annual figures (inside) do not
    show; the integrator route's extra summer light on the south glass brings 900's months inside and lifts 600's
    summer peaks over the programs' by up to 3.9 %. A room 10 % short of cooling in one month would fail."""
    from widesky.thermal.bestest_monthly import MONTHLY_RANGE, monthly_loads, monthly_verdicts, months_outside
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*clamped to the sky model's ranges", UserWarning)
        monthly = monthly_loads(route)
    assert set(monthly) == set(MONTHLY_RANGE) and all(len(v) == 12 for v in monthly.values())
    assert all(v.value < 5.0 for v in monthly_verdicts(monthly))
    assert len(months_outside(monthly)) <= {"weather": 15, "integrator": 10}[route]
    short = dict(monthly)
    short[("900", "cooling")] = monthly[("900", "cooling")] * np.where(np.arange(12) == 6, 0.9, 1.0)
    assert max(v.value for v in monthly_verdicts(short)) > 5.0
