"""ISO 13790 5R1C zone model: steady state by hand, energy conservation, limits, vectorisation;
surface irradiance against pvlib's Hay-Davies; sol-air temperature by hand."""

import numpy as np
import pytest

from widesky.thermal.surface import absorbed_solar, aoi, sol_air_temperature, surface_irradiance
from widesky.thermal.zone import ZoneParameters, simulate_5r1c

P = ZoneParameters(floor_area=48.0, h_tr_w=36.0, h_tr_op=51.0, h_ve=18.0, heat_capacity=2.0e6,
                   mass_area=140.0)


def _h_eff(p):
    g = p.conductances()
    h_op = 1 / (1 / g["h_tr_em"] + 1 / g["h_tr_ms"])
    return g["h_ve"] + 1 / (1 / g["h_tr_is"] + 1 / (g["h_tr_w"] + h_op))


def test_opaque_series_conductance():
    g = P.conductances()
    assert 1 / (1 / g["h_tr_em"] + 1 / g["h_tr_ms"]) == pytest.approx(51.0, rel=1e-12)


def test_steady_heating_by_hand():
    """0 degC outside, 20 degC set-point, no gains: heating = 20 K x the network's conductance
    seen from the air node (hand formula from the series/parallel network)."""
    T = 24 * 60
    r = simulate_5r1c(P, np.zeros(T), 0.0, 0.0, 20.0, 27.0, temp_mass_start=0.0)
    assert r["heating"][-1, 0] == pytest.approx(20.0 * _h_eff(P), rel=1e-9)
    assert r["temp_air"][-1, 0] == pytest.approx(20.0, abs=1e-9)
    assert r["cooling"].max() == 0.0


def test_steady_free_float_by_hand():
    """Convective gain 1 kW at the air node, no HVAC: air rises by 1000 / H_eff."""
    T = 24 * 60
    r = simulate_5r1c(P, np.full(T, 5.0), 1000.0, 0.0, -np.inf, np.inf,
                      internal_convective_fraction=1.0, temp_mass_start=5.0)
    assert r["temp_air"][-1, 0] == pytest.approx(5.0 + 1000.0 / _h_eff(P), rel=1e-9)


def test_energy_conservation_transient():
    """Over a transient with solar, gains, heating and cooling, the energy put in equals the
    losses through the three outside conductances plus the change in stored heat (exact for the
    Crank-Nicolson scheme)."""
    rng = np.random.default_rng(1)
    T = 500
    te = 5 + 10 * np.sin(np.arange(T) / 24 * 2 * np.pi) + rng.normal(0, 1, T)
    sol = np.maximum(0, 2000 * np.sin(np.arange(T) / 24 * 2 * np.pi))
    r = simulate_5r1c(P, te, 300.0, sol, 20.0, 24.0, temp_mass_start=15.0)
    g = P.conductances()
    loss = (g["h_ve"] * (r["temp_air"][:, 0] - te) + g["h_tr_w"] * (r["temp_surface"][:, 0] - te)
            + g["h_tr_em"] * (r["temp_mass"][:, 0] - te))
    # ISO 13790 C.2 drops the share h_tr_w / (h_ms A_t) of the radiative gains (radiated straight
    # out through the windows): Phi_m + Phi_st = (1 - h_tr_w / (9.1 A_t)) Phi_rad
    lost = g["h_tr_w"] / (9.1 * P.total_area)
    put = 150.0 + (1 - lost) * (150.0 + sol) + r["heating"][:, 0] - r["cooling"][:, 0]
    stored = P.heat_capacity * (r["temp_mass_end"][-1, 0] - 15.0) / 3600.0
    assert put.sum() == pytest.approx(loss.sum() + stored, rel=1e-9)
    assert r["heating"].sum() > 0 and r["cooling"].sum() > 0


def test_zero_gain_zero_difference_limit():
    r = simulate_5r1c(P, np.full(100, 20.0), 0.0, 0.0, 20.0, 27.0, temp_mass_start=20.0)
    assert np.abs(r["heating"]).max() < 1e-9 and r["cooling"].max() == 0.0


def test_plant_limit_and_vectorised_zones():
    te = np.linspace(-10, 35, 200)
    p2 = ZoneParameters(floor_area=[48.0, 100.0], h_tr_w=[36.0, 20.0], h_tr_op=[51.0, 80.0],
                        h_ve=[18.0, 40.0], heat_capacity=[2e6, 2e7], mass_area=[140.0, 250.0])
    both = simulate_5r1c(p2, te, 200.0, 0.0, 20.0, 26.0, heating_max=1500.0)
    assert both["heating"].max() == pytest.approx(1500.0)
    one = simulate_5r1c(ZoneParameters(100.0, 20.0, 80.0, 40.0, 2e7, 250.0), te, 200.0, 0.0,
                        20.0, 26.0, heating_max=1500.0)
    assert both["cooling"][:, 1] == pytest.approx(one["cooling"][:, 0], rel=1e-12)


def test_zone_errors():
    with pytest.raises(ValueError, match="h_ve"):
        ZoneParameters(48.0, 36.0, 51.0, -1.0, 2e6, 140.0)
    with pytest.raises(ValueError, match="heating_setpoint"):
        simulate_5r1c(P, np.zeros(3), 0.0, 0.0, 25.0, 20.0)
    with pytest.raises(ValueError, match="phi_sol has 2 steps"):
        simulate_5r1c(P, np.zeros(3), 0.0, np.zeros(2))


def test_shading_device_run_by_the_zone_state():
    """A device requested every step: without any heating it is down every step and the run equals the shaded gains'
    run; never requested, the bare run; with a heating set-point it is kept up exactly in the steps after one that
    heated (checked step by step against the run's own heating), and the scheme's outputs are those of a plain run
    fed the realised gains (the switching adds no energy)."""
    T = 24 * 10
    hour = np.arange(T) % 24
    te = 8.0 + 8.0 * np.cos(2 * np.pi * (hour - 15) / 24)
    sun = np.clip(np.sin(np.pi * (hour - 6) / 12), 0, None)
    up, down = 3000.0 * sun, 450.0 * sun
    for zones in (1, 3):
        p = ZoneParameters(*(np.full(zones, v) for v in (48.0, 36.0, 51.0, 18.0, 2.0e6, 140.0)))
        col = np.repeat(up[:, None], zones, 1), np.repeat(down[:, None], zones, 1)
        warm = dict(heating_setpoint=-np.inf, cooling_setpoint=np.inf, temp_mass_start=15.0)
        r = simulate_5r1c(p, te, 0.0, col[0], phi_sol_shaded=col[1], shade_request=np.ones((T, zones), bool), **warm)
        ref = simulate_5r1c(p, te, 0.0, col[1], **warm)
        assert r["shaded"].all()
        np.testing.assert_allclose(r["temp_air"], ref["temp_air"], rtol=1e-12, atol=1e-12)
        r0 = simulate_5r1c(p, te, 0.0, col[0], phi_sol_shaded=col[1], shade_request=np.zeros(T, bool), **warm)
        assert not r0["shaded"].any()
        np.testing.assert_allclose(r0["temp_air"], simulate_5r1c(p, te, 0.0, col[0], **warm)["temp_air"], rtol=1e-12)
        req = np.ones((T, zones), bool)
        r = simulate_5r1c(p, te, 0.0, col[0], 20.0, 26.0, phi_sol_shaded=col[1], shade_request=req,
                          temp_mass_start=15.0)
        heated = r["heating"] > 0
        assert heated.any() and (~heated).any()
        np.testing.assert_array_equal(r["shaded"][1:], ~heated[:-1])
        fed = simulate_5r1c(p, te, 0.0, np.where(r["shaded"], col[1], col[0]), 20.0, 26.0, temp_mass_start=15.0)
        np.testing.assert_allclose(r["heating"], fed["heating"], rtol=1e-9, atol=1e-6)
        np.testing.assert_allclose(r["cooling"], fed["cooling"], rtol=1e-9, atol=1e-6)
    with pytest.raises(ValueError, match="give phi_sol_shaded and shade_request together"):
        simulate_5r1c(P, te, 0.0, up, phi_sol_shaded=down)
    with pytest.raises(ValueError, match="shade_request must be bool"):
        simulate_5r1c(P, te, 0.0, up, phi_sol_shaded=down, shade_request=np.ones(T))


def test_surface_irradiance_against_pvlib_haydavies():
    """Against pvlib 0.16 (independent code): beam + Hay-Davies sky diffuse + isotropic ground."""
    pvlib = pytest.importorskip("pvlib")
    rng = np.random.default_rng(3)
    n = 200
    zen = rng.uniform(0, 88, n)
    saz = rng.uniform(60, 300, n)
    dni = rng.uniform(0, 900, n)
    dhi = rng.uniform(20, 300, n)
    ghi = dni * np.cos(np.radians(zen)) + dhi
    dne = np.full(n, 1361.0)
    tilts, azs = [90.0, 90.0, 30.0, 0.0], [180.0, 90.0, 200.0, 0.0]
    ours = surface_irradiance(tilts, azs, zen, saz, dni, dhi, ghi, dne, albedo=0.2, transposition="hay-davies")
    for j, (t, a) in enumerate(zip(tilts, azs)):
        sky = pvlib.irradiance.haydavies(t, a, dhi, dni, dne, zen, saz)
        ground = pvlib.irradiance.get_ground_diffuse(t, ghi, albedo=0.2)
        beam = pvlib.irradiance.beam_component(t, a, zen, saz, dni)
        assert ours["poa_global"][:, j] == pytest.approx(beam + sky + ground, rel=1e-9, abs=1e-9)
        assert ours["poa_ground_diffuse"][:, j] == pytest.approx(ground, rel=1e-9, abs=1e-12)


def test_aoi_and_symmetry_under_sunless_sky():
    """No sun (dni = 0): a building's four walls receive the same whatever their azimuth (Hay-Davies: isotropic
    without beam; Perez keeps an overcast sky's faint circumsolar part, tests/test_thermal_perez.py)."""
    assert aoi(90, 180, 0, 123) == pytest.approx(90.0)
    n = 50
    r = surface_irradiance([90] * 4, [0, 90, 180, 270], np.full(n, 40.0),
                           np.linspace(90, 270, n), np.zeros(n), np.full(n, 150.0),
                           np.full(n, 150.0), np.full(n, 1361.0), transposition="hay-davies")
    assert r["poa_global"] == pytest.approx(np.repeat(r["poa_global"][:, :1], 4, axis=1), rel=1e-12)


def test_sol_air_by_hand():
    # ASHRAE: t_sa = t_o + alpha G / h_o (no long-wave)
    assert sol_air_temperature(30.0, 800.0, 0.6, h_out=17.0) == pytest.approx(30 + 0.6 * 800 / 17)
    # horizontal surface under a sky 20 K colder than the air loses eps sigma (T^4 - Tsky^4) / h_o
    s = 5.670374419e-8
    dr = s * ((303.15) ** 4 - (283.15) ** 4)
    assert sol_air_temperature(30.0, 0.0, 0.6, 17.0, 0.9, 10.0, 0.0) == pytest.approx(30 - 0.9 * dr / 17)
    with pytest.raises(ValueError, match="absorptance"):
        absorbed_solar(100.0, 1.5)


def test_hourly_conductances():
    """Conductance series (hourly outside coefficients): constant series reproduce the constant
    parameters exactly, and the transient energy balance stays exact with varying ones."""
    rng = np.random.default_rng(2)
    T = 400
    te = 5 + 10 * np.sin(np.arange(T) / 24 * 2 * np.pi) + rng.normal(0, 1, T)
    sol = np.maximum(0, 2000 * np.sin(np.arange(T) / 24 * 2 * np.pi))
    ref = simulate_5r1c(P, te, 300.0, sol, 20.0, 24.0, temp_mass_start=15.0)
    same = simulate_5r1c(P, te, 300.0, sol, 20.0, 24.0, temp_mass_start=15.0,
                         h_tr_w=np.full(T, 36.0), h_tr_op=np.full(T, 51.0))
    for k in ("heating", "cooling", "temp_air", "temp_mass"):
        assert same[k] == pytest.approx(ref[k], rel=1e-12, abs=1e-9)
    hw = 36.0 * rng.uniform(0.6, 1.2, T)
    hop = 51.0 * rng.uniform(0.9, 1.05, T)
    r = simulate_5r1c(P, te, 300.0, sol, 20.0, 24.0, temp_mass_start=15.0, h_tr_w=hw, h_tr_op=hop)
    h_ms = 9.1 * P.mass_area
    h_em = 1 / (1 / hop - 1 / h_ms)
    loss = (P.h_ve * (r["temp_air"][:, 0] - te) + hw * (r["temp_surface"][:, 0] - te)
            + h_em * (r["temp_mass"][:, 0] - te))
    put = (150.0 + (1 - hw / (9.1 * P.total_area)) * (150.0 + sol) + r["heating"][:, 0]
           - r["cooling"][:, 0])
    stored = P.heat_capacity * (r["temp_mass_end"][-1, 0] - 15.0) / 3600.0
    assert put.sum() == pytest.approx(loss.sum() + stored, rel=1e-9)
    assert not np.allclose(r["heating"], ref["heating"])
    with pytest.raises(ValueError, match="h_tr_w"):
        simulate_5r1c(P, te, 0.0, 0.0, h_tr_w=np.full(T - 1, 36.0))
    with pytest.raises(ValueError, match="h_tr_op"):
        simulate_5r1c(P, te, 0.0, 0.0, h_tr_op=np.full(T, 2000.0))


def test_exterior_coefficients_by_hand():
    """ISO 6946:2017 Annex C: h_c = 4 + 4 v, h_r = eps 4 sigma T^3; at 4 m s-1 and 10 degC the
    sum is 24.6 W m-2 K-1, close to the nominal 1/R_se = 25 that ISO 13790 fixes, so the hourly
    U-value equals the nominal one there; a calm hour lowers a window's U far more than a wall's."""
    from widesky.thermal.exterior import exterior_coefficients, hourly_u_value, wind_at_height
    hc, hr = exterior_coefficients(4.0, 10.0, 0.9)
    assert hc == pytest.approx(20.0) and hr == pytest.approx(0.9 * 4 * 5.670374419e-8 * 283.15 ** 3)
    assert hourly_u_value(0.51, 25.0) == pytest.approx(0.51, rel=1e-12)
    calm = sum(exterior_coefficients(0.0, -19.4, 0.84))                  # 4 + 3.2 W m-2 K-1
    assert hourly_u_value(2.88, calm, 1 / 23) / 2.88 < 0.8              # double glazing: -22 %
    assert hourly_u_value(0.51, calm) / 0.51 > 0.94                       # insulated wall: -5 %
    assert wind_at_height(5.0, 1.0) == pytest.approx(5.0 * 0.1 ** 0.14)
    with pytest.raises(ValueError, match="wind_speed"):
        exterior_coefficients(-1.0, 10.0)
    with pytest.raises(ValueError, match="u_value"):
        hourly_u_value(30.0, 10.0)
