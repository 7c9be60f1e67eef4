"""ASHRAE Standard 140 Cases 600, 660, 670, 900 with the 5R1C and ISO 52016-1 models against the Standard's
acceptance limits (annual loads, 140-2020/2023 Addendum b Tables A3-1..4 as listed in the
Modelica Buildings User's Guide in ../shared/data/bestest) and the six reference programs' range
(peak loads; the guide lists no peak limits). Weather: Denver Intl AP TMY3, the file the
140-2020 cases and their published results use. Two irradiance routes: the weather file's
Perez transposition (seconds) and widesky's integrator (the default pipeline: the all-sky model at the
file's DNI and DHI, as every command; one 8760-step run shared by all cases, a few minutes).

Measured figures that fall outside are marked xfail (strict: a fix makes them fail loudly) with
the measured value; docs/thermal.md discusses them.
"""

import functools
import warnings

import pytest

from widesky.core.paths import data_file

pytestmark = [pytest.mark.reference, pytest.mark.slow]       # the ASHRAE 140 files: reference data


@functools.lru_cache(maxsize=None)
def _integrator():
    from widesky.thermal.bestest import integrator_irradiance
    with warnings.catch_warnings():       # TMY3 visibilities beyond the sky model's range: clamped
        warnings.filterwarnings("ignore", "8760 steps: clamped to the sky model's ranges",
                                UserWarning)
        return integrator_irradiance()


@functools.lru_cache(maxsize=None)
def _run(case, route="weather", exterior="hourly", zone_model="5r1c"):
    from widesky.thermal.bestest import run_case
    return run_case(case, poa=_integrator() if route == "integrator" else None, exterior=exterior,
                    zone_model=zone_model)


@functools.lru_cache(maxsize=None)
def _refs():
    from widesky.thermal.bestest import reference_results
    return reference_results()


OUTSIDE = {
    # the weather route's Perez transposition (the default since issue 38; Hay-Davies put 3 % less on the south wall
    # and gave 2.06 MWh and 2.83 kW) lands where the integrator does: 5R1C's heavy room is too damped on both routes
    ("weather", "900", "annual_cooling"): "2.25 MWh < 2.35 (5R1C, Perez)",
    ("weather", "900", "peak_heating"): "2.81 kW > 2.78 (programs' max; 5R1C, Perez)",
    # Since the one pipeline (issue 33) the integrator route runs the all-sky default; with the room's real windows
    # (issue 38: two 3 m x 2 m south windows, bestest_geometry) and the all-sky distribution of 2026-12-05 its south
    # wall sits at Perez's level (1368 kWh m-2 against 1369), yet Case 900 still misses these two: the heavyweight
    # misses are no longer a matter of the wall's light (docs/validation/thermal-bestest-cases.md)
    ("integrator", "900", "annual_cooling"): "2.27 MWh < 2.35 (all-sky default, 5R1C)",
    ("integrator", "900", "peak_heating"): "2.80 kW > 2.78 (programs' max; all-sky default)",
    # ISO 52016-1 (the default zone model since issue 38's corrections, docs/thermal.md): all 16 inside on both
    # routes since the fifth pass's inside convection (TARP opaque, ISO 15099 windows); with Table 25's the
    # integrator route's 900 cooling was 2.64 MWh > 2.60
}


def _params():
    for model in ("5r1c", "iso52016"):
        for route in ("weather", "integrator"):
            for case in ("600", "660", "670", "900"):
                for q in ("annual_heating", "annual_cooling", "peak_heating", "peak_cooling"):
                    why = OUTSIDE.get((route, case, q) if model == "5r1c" else (model, route, case, q))
                    marks = [pytest.mark.xfail(strict=True, reason=why)] if why else []
                    yield pytest.param(model, route, case, q, marks=marks, id=f"{model}-{route}-{case}-{q}")


@pytest.mark.parametrize("model,route,case,quantity", list(_params()))
def test_case_within_limits(model, route, case, quantity):
    ref = _refs()[case][quantity]
    value = _run(case, route, zone_model=model)[quantity]
    if quantity.startswith("annual"):
        lo, hi = ref["limits"]
    else:
        lo, hi = min(ref["programs"].values()), max(ref["programs"].values())
    assert lo <= value <= hi, f"Case {case} {quantity} = {value:.0f}, range [{lo:.0f}, {hi:.0f}]"


def test_calm_night_lowers_the_heating_peak():
    """The coldest hour of the year (31 Dec, 24:00, -19.4 degC) is calm (wind 0 m s-1): hourly
    outside coefficients (ISO 6946 Annex C) cut the window U-value there, so the peak falls
    against the constant-R_se model, most for the single pane of Case 670 (whose peak moves to
    a windy cold morning)."""
    for case, at_least in (("600", 0.05), ("670", 0.25)):
        hourly, const = _run(case), _run(case, exterior="constant")
        t = const["peak_heating_time"]
        assert t.strftime("%m-%d %H") == "01-01 00"                   # end of 31 December
        assert const["peak_heating"] - hourly["hourly"]["heating"][t] > at_least * 1500
        assert const["peak_heating"] - hourly["peak_heating"] > at_least * 1000


def test_layer_u_values_by_hand():
    """U-values from the detailed models' layers (x / k) with ISO 6946 R_si and R_se = 0.04:
    the Case 600 wall is 9 mm siding (k 0.14), 66 mm fibreglass (0.04), 12 mm plasterboard (0.16)."""
    from widesky.thermal.bestest import case_definition, layer_resistance
    r = layer_resistance(data_file("bestest/detailed_Cases6xx_Case600FF.mo"), "matExtWal")
    assert r == pytest.approx(0.009 / 0.14 + 0.066 / 0.04 + 0.012 / 0.16, rel=1e-12)
    c = case_definition("600")
    assert c.u_wall == pytest.approx(1 / (0.13 + r + 0.04), rel=1e-12)
    assert c.u_roof == pytest.approx(1 / (0.10 + 0.019 / 0.14 + 0.1118 / 0.04 + 0.010 / 0.16
                                          + 0.04), rel=1e-12)
    r900 = layer_resistance(data_file("bestest/detailed_Data_ExteriorWallCase900.mo"))
    assert r900 == pytest.approx(0.009 / 0.14 + 0.0615 / 0.04 + 0.100 / 0.51, rel=1e-12)
    assert c.zone.total_area == pytest.approx(2 * 48 + 2 * (8 + 6) * 2.7)
    with pytest.raises(ValueError, match="no construction"):
        layer_resistance(data_file("bestest/detailed_Cases6xx_Case600FF.mo"), "nothere")


def test_heavy_mass_damps_loads():
    """Case 900 (heavy) needs less heating and cooling than Case 600 and has a lower cooling peak,
    as every reference program finds."""
    a, b = _run("600"), _run("900")
    assert b["annual_heating"] < a["annual_heating"] and b["annual_cooling"] < a["annual_cooling"]
    assert b["peak_cooling"] < 0.6 * a["peak_cooling"]


def test_reference_tables_parsed():
    r = _refs()
    assert r["600"]["annual_heating"]["limits"] == (3750.0, 4980.0)
    assert r["600"]["annual_heating"]["programs"]["EnergyPlus"] == pytest.approx(4324.0)
    assert r["900"]["peak_cooling"]["programs"]["TRNSYS"] > 2000


def test_case_inputs_from_files():
    from widesky.thermal.bestest import case_definition
    c = case_definition("600")
    assert c.window_area == 12.0 and c.zone.floor_area == 48.0
    assert [w[0] for w in c.walls] == pytest.approx([0.0, 90.0, 180.0, 270.0])
    assert c.walls[2][2] == 12.0                                   # the window faces south
    assert c.heating_setpoint == 20.0 and c.cooling_setpoint == 27.0 and c.internal_gains == 200.0
    with pytest.raises(ValueError, match="case="):
        case_definition("611")


def test_read_mos_drycold():
    """The DRYCOLD table: 8760 hours, Denver-Stapleton header, coldest hour -24.4 degC (4 Jan)."""
    from widesky.thermal.bestest import read_mos
    data, site = read_mos(data_file("weather/DRYCOLD.mos"))
    assert len(data) == 8760 and site["latitude"] == pytest.approx(39.76)
    assert data["temp_air"].min() == pytest.approx(-24.4)
    assert data["temp_air"].idxmin().strftime("%m-%d") == "01-04"
    assert data["ghi"].max() < 1400 and data["ghi_infrared"].min() > 100
