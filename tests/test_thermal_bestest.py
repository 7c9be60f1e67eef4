"""ASHRAE Standard 140 Cases 600, 660, 670, 900 with the 5R1C model against the Standard's
acceptance limits (annual loads, 140-2020/2023 Addendum b Tables A3-1..4 as listed in the
Modelica Buildings User's Guide in ../shared/data/bestest) and the six reference programs' range
(peak loads; the guide lists no peak limits). Weather: Denver Intl AP TMY3, the file the
140-2020 cases and their published results use.

Measured figures that fall outside are marked xfail (strict: a fix makes them fail loudly) with
the measured value; docs/thermal.md discusses them.
"""

import functools

import pytest

try:
    from skymodel.generator.paths import data_file
    data_file("bestest/detailed_UsersGuide.mo")
    data_file("weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw")
    HAVE_DATA = True
except Exception:                     # noqa: BLE001
    HAVE_DATA = False

pytestmark = [pytest.mark.reference, pytest.mark.slow,
              pytest.mark.skipif(not HAVE_DATA, reason="../shared/data not available")]


@functools.lru_cache(maxsize=None)
def _run(case):
    from thermal.bestest import run_case
    return run_case(case)


@functools.lru_cache(maxsize=None)
def _refs():
    from thermal.bestest import reference_results
    return reference_results()


OUTSIDE = {("600", "annual_heating"): "5.24 MWh > 4.98 (constant EN 673 outside coefficient, "
                                      "ISO 13790 sky loss)",
           ("900", "annual_cooling"): "2.00 MWh < 2.35",
           ("600", "peak_heating"): "3.56 kW > 3.36 (programs' max)",
           ("670", "peak_heating"): "4.66 kW > 4.22 (programs' max)",
           ("900", "peak_heating"): "3.04 kW > 2.78 (programs' max)"}


def _params():
    for case in ("600", "660", "670", "900"):
        for q in ("annual_heating", "annual_cooling", "peak_heating", "peak_cooling"):
            marks = ([pytest.mark.xfail(strict=True, reason=OUTSIDE[(case, q)])]
                     if (case, q) in OUTSIDE else [])
            yield pytest.param(case, q, marks=marks, id=f"{case}-{q}")


@pytest.mark.parametrize("case,quantity", list(_params()))
def test_case_within_limits(case, quantity):
    ref = _refs()[case][quantity]
    value = _run(case)[quantity]
    if quantity.startswith("annual"):
        lo, hi = ref["limits"]
    else:
        lo, hi = min(ref["programs"].values()), max(ref["programs"].values())
    assert lo <= value <= hi, f"Case {case} {quantity} = {value:.0f}, range [{lo:.0f}, {hi:.0f}]"


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
    from thermal.bestest import case_definition
    c = case_definition("600")
    assert c.window_area == 12.0 and c.zone.floor_area == 48.0
    assert [w[0] for w in c.walls] == pytest.approx([0.0, 90.0, 180.0, 270.0])
    assert c.walls[2][2] == 12.0                                   # the window faces south
    assert c.heating_setpoint == 20.0 and c.cooling_setpoint == 27.0 and c.internal_gains == 200.0
    with pytest.raises(ValueError, match="case="):
        case_definition("610")
