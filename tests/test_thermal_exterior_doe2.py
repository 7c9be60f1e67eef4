"""EnergyPlus's outside surface model (issue 38, seventh pass): DOE-2 convection and the outside long-wave split.

Hand values from the correlations as EnergyPlus's source states them (NREL/EnergyPlus ConvectionCoefficients.cc:
CalcASHRAETARPNatural, CalcMoWITTForcedWindward/Leeward, CalcDOE2Forced, Windward, RoughnessMultiplier,
InitExteriorConvectionCoeffs; SurfaceGeometry.cc: SurfAirSkyRadSplit; HeatBalanceManager.cc: terrain), each worked
out in the comments; a wrong constant moves each value by more than its tolerance.
"""

import math

import numpy as np
import pytest

from widesky.thermal.exterior import (ROUGHNESS_MULTIPLIER, TERRAIN, doe2_convection, energyplus_longwave,
                                      energyplus_wind_at_height, mowitt_forced_convection, tarp_natural_convection,
                                      wind_at_height, windward)
from widesky.thermal.zone_iso52016 import Element, Layer, simulate_iso52016

SIGMA = 5.670374419e-8


def test_tarp_natural_by_direction():
    # |dT| = 8 K: |dT|^(1/3) = 2
    assert tarp_natural_convection(8.0, 0.0) == pytest.approx(2.62, abs=1e-9)             # vertical 1.31 x 2
    assert tarp_natural_convection(-8.0, 0.0) == pytest.approx(2.62, abs=1e-9)
    # a roof's outside (facing up) warmer than the air: unstable, 9.482 x 2 / (7.238 - 1) = 3.040077
    assert tarp_natural_convection(8.0, 1.0) == pytest.approx(18.964 / 6.238, abs=1e-9)
    # the same roof colder than the air (a clear night): stable, 1.810 x 2 / (1.382 + 1) = 1.519731
    assert tarp_natural_convection(-8.0, 1.0) == pytest.approx(3.62 / 2.382, abs=1e-9)
    # a raised floor's underside (facing down) warmer than the air: stable; colder: unstable
    assert tarp_natural_convection(8.0, -1.0) == pytest.approx(3.62 / 2.382, abs=1e-9)
    assert tarp_natural_convection(-8.0, -1.0) == pytest.approx(18.964 / 6.238, abs=1e-9)
    assert tarp_natural_convection(0.0, 1.0) == 0.0
    # arrays broadcast, per element
    np.testing.assert_allclose(tarp_natural_convection([8.0, 8.0], [1.0, -1.0]), [18.964 / 6.238, 3.62 / 2.382])


def test_mowitt_forced():
    # v = 2 m s-1: windward 3.26 x 2^0.89 = 3.26 x 1.853176 = 6.041354;
    # leeward 3.55 x 2^0.617 = 3.55 x 1.533682 = 5.444573
    assert mowitt_forced_convection(2.0, True) == pytest.approx(3.26 * math.exp(0.89 * math.log(2)), rel=1e-12)
    assert float(mowitt_forced_convection(2.0, True)) == pytest.approx(6.04135, abs=1e-4)
    assert float(mowitt_forced_convection(2.0, False)) == pytest.approx(5.44457, abs=1e-4)
    assert float(mowitt_forced_convection(0.0, True)) == 0.0
    with pytest.raises(ValueError):
        mowitt_forced_convection(-1.0, True)


def test_roughness_multipliers():
    assert ROUGHNESS_MULTIPLIER == {"very_rough": 2.17, "rough": 1.67, "medium_rough": 1.52,
                                    "medium_smooth": 1.13, "smooth": 1.11, "very_smooth": 1.0}


def test_doe2_combination():
    # vertical, dT = 8 K: h_n = 2.62; h_f = 6: sqrt(2.62^2 + 36) = sqrt(42.8644) = 6.547091;
    # rough (1.67): 2.62 + 1.67 x (6.547091 - 2.62) = 9.178242
    assert float(doe2_convection(8.0, 0.0, 6.0, 1.67)) == pytest.approx(9.178242, abs=1e-5)
    # very smooth: MoWiTT's own sqrt(h_n^2 + h_f^2)
    assert float(doe2_convection(8.0, 0.0, 6.0, 1.0)) == pytest.approx(6.547091, abs=1e-5)
    # calm: the natural part alone, whatever the roughness
    assert float(doe2_convection(8.0, 1.0, 0.0, 2.17)) == pytest.approx(18.964 / 6.238, abs=1e-9)


def test_windward_rule():
    south = 180.0
    assert windward(180.0, south, 0.0)            # wind from the south on a south wall
    assert not windward(0.0, south, 0.0)          # from the north: leeward
    assert windward(270.0, south, 0.0)            # 90 degrees off: still windward (leeward beyond 90.001)
    assert not windward(271.0, south, 0.0)
    assert windward(350.0, 0.0, 0.0)              # across north: 10 degrees
    assert not windward(100.0, 0.0, 0.0)
    assert windward(0.0, south, 1.0) and windward(0.0, south, 0.985)   # near horizontal: always windward
    assert not windward(0.0, south, 0.97)
    np.testing.assert_array_equal(windward(np.array([180.0, 0.0]), south, 0.0), [True, False])


def test_energyplus_wind_profile():
    assert TERRAIN["country"] == (0.14, 270.0) and TERRAIN["suburbs"] == (0.22, 370.0)
    # station and site both open country: v (z / 10)^0.14, as wind_at_height
    assert float(energyplus_wind_at_height(5.0, 1.35)) == pytest.approx(float(wind_at_height(5.0, 1.35)), rel=1e-12)
    # EnergyPlus's default site, suburbs: (270/10)^0.14 = 1.5863 (its WeatherFileWindModCoeff) x (1.35/370)^0.22
    assert float(energyplus_wind_at_height(1.0, 1.35, "suburbs")) == pytest.approx(1.5863 * (1.35 / 370) ** 0.22,
                                                                                 rel=1e-4)
    assert float(energyplus_wind_at_height(1.0, 1.35, "suburbs")) == pytest.approx(0.4614, abs=2e-4)
    with pytest.raises(ValueError):
        energyplus_wind_at_height(1.0, 1.35, "forest")


def test_energyplus_longwave_split():
    # all at 0 degC: the linearised coefficients sum to eps 4 sigma T^3 whatever the split
    t = 273.15
    h4 = 0.9 * 4 * SIGMA * t ** 3                                        # 4.1602 W m-2 K-1
    h_sky, h_amb = energyplus_longwave(0.0, 0.0, 0.0, 90.0, 0.9)
    # a wall: F_sky = 1/2, beta = sqrt(1/2): the sky gets 0.353553 of it, air and ground the rest
    assert float(h_sky) == pytest.approx(h4 * 0.5 * math.sqrt(0.5), rel=1e-12)
    assert float(h_sky + h_amb) == pytest.approx(h4, rel=1e-12)
    # a roof: F_sky = beta = 1, all to the sky
    h_sky, h_amb = energyplus_longwave(0.0, 0.0, 0.0, 0.0, 0.9)
    assert float(h_sky) == pytest.approx(h4, rel=1e-12) and float(h_amb) == pytest.approx(0.0, abs=1e-12)
    # linearised at the surface: h_sky (T_s - T_sky) is the exact flux eps sigma F beta (T_s^4 - T_sky^4)
    ts, tsky, ta = 10.0, -20.0, 5.0
    h_sky, h_amb = energyplus_longwave(ts, ta, tsky, 90.0, 0.9)
    f = 0.5 * math.sqrt(0.5)
    assert float(h_sky) * (ts - tsky) == pytest.approx(0.9 * SIGMA * f * ((ts + t) ** 4 - (tsky + t) ** 4), rel=1e-12)
    assert float(h_amb) * (ts - ta) == pytest.approx(0.9 * SIGMA * (1 - f) * ((ts + t) ** 4 - (ta + t) ** 4),
                                                     rel=1e-12)
    # no sky for an unexposed face
    h_sky, h_amb = energyplus_longwave(0.0, 0.0, -30.0, 90.0, 0.9, exposed=False)
    assert float(h_sky) == 0.0 and float(h_amb) == pytest.approx(h4, rel=1e-12)


def _roof_zone(**kw):
    """A roof-only zone held at 20 degC under 0 degC air, steady: returns the last step's heating [W]."""
    roof = Element("roof", "roof", 10.0, 0.0, (Layer(0.1, 1.0, 100.0, 100.0),), absorptance=0.0, emissivity=0.9)
    T = 300
    kw.setdefault("h_re", 0.0)
    r = simulate_iso52016([roof], np.zeros(T), kw.pop("temp_sky", np.zeros(T)), kw.pop("h_ce"), kw.pop("h_re"),
                          np.zeros((T, 1)), 0.0, 0.0, 0.0, 20.0, 20.0, volume=30.0, convection="fixed", **kw)
    return r["heating"][-1]


def _steady(h_out):
    """Heat flow [W m-2] of the roof held at 20 degC under 0 degC air, inside 5.0 (Table 25, up), layer R = 0.1,
    outside h_out(T_s) [W m-2 K-1] at its own outside surface temperature (bisection on T_s)."""
    lo, hi = 0.0, 20.0
    for _ in range(200):
        ts = 0.5 * (lo + hi)
        q_in = (20.0 - ts) / (1 / 5.0 + 0.1)
        if q_in > h_out(ts) * ts:
            lo = ts
        else:
            hi = ts
    return h_out(ts) * ts


def test_zone_doe2_steady_state():
    # the roof's outside warmer than the air looks up: unstable Walton plus the rough surface's forced part
    hf = 3.0
    q = _steady(lambda ts: float(doe2_convection(ts, 1.0, hf, 1.67)))
    heat = _roof_zone(h_ce=hf, exterior_convection="doe2", roughness=[1.67])
    assert heat == pytest.approx(10.0 * q, rel=1e-6)
    # the stable correlation (a wrong direction) gives a different load, by more than the tolerance
    q_wrong = _steady(lambda ts: float(doe2_convection(ts, -1.0, hf, 1.67)))
    assert abs(q_wrong - q) / q > 1e-3
    # the default: h_ce as given, unchanged
    assert _roof_zone(h_ce=7.0) == pytest.approx(10.0 * _steady(lambda ts: 7.0), rel=1e-6)


def test_zone_energyplus_longwave_steady_state():
    # sky at -20 degC, air at 0: the roof's long-wave linearised at its own temperature, convection fixed 7
    def h_out_and_flux(ts):
        h_sky, h_amb = energyplus_longwave(ts, 0.0, -20.0, 0.0, 0.9)
        return float(h_sky), float(h_amb)
    lo, hi = -20.0, 20.0
    for _ in range(200):
        ts = 0.5 * (lo + hi)
        h_sky, h_amb = h_out_and_flux(ts)
        q_out = 7.0 * ts + h_amb * ts + h_sky * (ts + 20.0)
        if (20.0 - ts) / 0.3 > q_out:
            lo = ts
        else:
            hi = ts
    q = (20.0 - ts) / 0.3
    T = 300
    heat = _roof_zone(h_ce=7.0, h_re=99.0, temp_sky=np.full(T, -20.0), exterior_longwave="energyplus")
    assert heat == pytest.approx(10.0 * q, rel=1e-6)


def test_zone_bad_values():
    roof = Element("roof", "roof", 10.0, 0.0, (Layer(0.1, 1.0, 100.0, 100.0),))
    args = ([roof], np.zeros(3), np.zeros(3), 1.0, 1.0, np.zeros((3, 1)), 0.0, 0.0, 0.0, 20.0, 20.0)
    with pytest.raises(ValueError, match="exterior_convection"):
        simulate_iso52016(*args, volume=30.0, exterior_convection="mowitt")
    with pytest.raises(ValueError, match="exterior_longwave"):
        simulate_iso52016(*args, volume=30.0, exterior_longwave="iso6946")
    with pytest.raises(ValueError, match="roughness"):
        simulate_iso52016(*args, volume=30.0, exterior_convection="doe2", roughness=[1.67, 1.0])


@pytest.mark.reference
def test_bestest_option_bad_value():
    from widesky.thermal.bestest import ISO52016_OPTIONS, run_case
    assert ISO52016_OPTIONS["exterior"][0] == "iso6946" and ISO52016_OPTIONS["longwave_out"][0] == "iso6946"
    with pytest.raises(ValueError, match="exterior"):
        run_case("600", iso52016_options={"exterior": "tarp"})
