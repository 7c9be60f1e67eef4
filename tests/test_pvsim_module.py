"""pvsim's module layer: cover optics against the Fresnel formulas and pvlib.iam.physical, temperature
models against pvlib.temperature, Jsc against hand-computed cases, mismatch against independent
arithmetic and pvlib.spectrum.calc_spectral_mismatch_field, tandem stack rules, the inverter and DC
model against pvlib, and the hand-off to pvlib's ModelChain."""

import numpy as np
import pandas as pd
import pytest

from widesky import pvsim
from widesky.pvsim import (channel_sr, cover_iam, cover_transmittance, faiman, get_technology, pvsyst_cell,
                   short_circuit_current, spectral_mismatch)
from widesky.pvsim.spectra import ELEMENTARY_CHARGE, PLANCK, SPEED_OF_LIGHT

pvlib = pytest.importorskip("pvlib")




# --- cover optics --------------------------------------------------------------------------------

@pytest.mark.parametrize("kw", [{}, {"n_ar": 1.29}, {"n": 1.6, "K": 20.0, "L": 0.004}, {"K": 0.0}])
def test_cover_iam_matches_pvlib_physical(kw):
    a = np.linspace(0.0, 89.99, 500)
    np.testing.assert_allclose(cover_iam(a, **kw), pvlib.iam.physical(a, **kw), rtol=0, atol=1e-12)


def test_cover_fresnel_hand_values():
    n = 1.5
    # normal incidence, no absorption: T = 1 - ((n-1)/(n+1))^2 = 0.96
    assert cover_transmittance(0.0, n=n, K=0.0) == pytest.approx(0.96, rel=1e-12)
    # Brewster angle: r_p = 0, r_s = sin^2(theta_i - theta_t)/sin^2(theta_i + theta_t)
    tb = np.degrees(np.arctan(n))
    tt = np.arcsin(np.sin(np.radians(tb)) / n)
    rs = np.sin(np.radians(tb) - tt) ** 2 / np.sin(np.radians(tb) + tt) ** 2
    assert cover_transmittance(tb, n=n, K=0.0) == pytest.approx(1 - 0.5 * rs, rel=1e-12)
    # absorption along the refracted path: exp(-K L / cos theta_t)
    t60 = cover_transmittance(60.0, n=n, K=4.0, L=0.002) / cover_transmittance(60.0, n=n, K=0.0)
    ct = np.sqrt(1 - (np.sin(np.radians(60.0)) / n) ** 2)
    assert t60 == pytest.approx(np.exp(-4.0 * 0.002 / ct), rel=1e-12)
    # behind the face nothing enters
    assert cover_transmittance(95.0) == 0.0 and cover_iam(90.0) == 0.0
    # a quarter-wave-index AR layer (n_ar = sqrt(n)) raises the normal transmittance
    assert cover_transmittance(0.0, n=n, K=0.0, n_ar=np.sqrt(n)) > 0.96


@pytest.mark.parametrize("kw,match", [({"n": 0.9}, "n="), ({"K": -1.0}, "K="), ({"n_ar": 1.7}, "n_ar"),
                                      ({"L": np.nan}, "L=")])
def test_cover_bad_input(kw, match):
    with pytest.raises(ValueError, match=match):
        cover_iam(30.0, **kw)


def test_spectral_cover_iam():
    w = np.array([400.0, 800.0, 1600.0])
    a = np.array([0.0, 40.0, 70.0, 85.0])
    n = pvsim.rubin_soda_lime_index(w)
    # Rubin 1985 at 550 nm: 1.5130 - 0.003169 * 0.55^2 + 0.003962 / 0.55^2 = 1.52514
    assert pvsim.rubin_soda_lime_index(550.0) == pytest.approx(1.52514, abs=1e-5)
    m = pvsim.spectral_cover_iam(a, w, n, k=1e-7, L=0.0032)
    assert m.shape == (4, 3)
    np.testing.assert_allclose(m[0], 1.0)
    for j in range(3):   # each wavelength column is the plain IAM at that wavelength's n and K
        K = pvsim.extinction_to_absorption(1e-7, w[j])
        np.testing.assert_allclose(m[:, j], cover_iam(a, n=n[j], K=K, L=0.0032), rtol=1e-12)


# --- temperature ---------------------------------------------------------------------------------

def test_temperature_models_match_pvlib():
    rng = np.random.default_rng(3)
    g, t, v = rng.uniform(0, 1100, 50), rng.uniform(-10, 40, 50), rng.uniform(0, 12, 50)
    np.testing.assert_allclose(faiman(g, t, v), pvlib.temperature.faiman(g, t, v), rtol=1e-12)
    np.testing.assert_allclose(faiman(g, t, v, u0=20.0, u1=3.0),
                               pvlib.temperature.faiman(g, t, v, u0=20.0, u1=3.0), rtol=1e-12)
    np.testing.assert_allclose(pvsyst_cell(g, t, v, u_c=25.0, u_v=1.2, module_efficiency=0.2),
                               pvlib.temperature.pvsyst_cell(g, t, v, u_c=25.0, u_v=1.2, module_efficiency=0.2),
                               rtol=1e-12)
    with pytest.raises(ValueError, match="wind_speed"):
        faiman(g, t, -1.0)
    with pytest.raises(KeyError, match="valid: freestanding"):
        pvsim.temperature_model_parameters("pvsyst", "roof")


# --- Jsc, effective irradiance, mismatch ---------------------------------------------------------

def test_jsc_hand_computed_flat_spectrum():
    """EQE 0.8 over 280-2480 nm under a flat 1 W m-2 nm-1: J = 0.8 q/(h c) (l2^2 - l1^2)/2 (exact)."""
    cell = get_technology("perc").replace(
        name="flat", eqe=pvsim.TabulatedEQE(np.array([280.0, 2480.0]), np.array([0.8, 0.8])))
    sr = channel_sr(cell)["flat"]
    j = short_circuit_current(np.ones(55), sr)
    expect = 0.8 * ELEMENTARY_CHARGE / (PLANCK * SPEED_OF_LIGHT) * 1e-9 * (2480.0 ** 2 - 280.0 ** 2) / 2
    assert j == pytest.approx(expect, rel=1e-9)
    # photon counting: one channel 600-640 nm, EQE 0.8 => J = 0.8 q * photons
    E = np.zeros(55)
    E[8] = 2.0                                     # channel 8 is 600-640 nm
    photons = 2.0 * 40.0 * 620e-9 / (PLANCK * SPEED_OF_LIGHT)
    assert short_circuit_current(E, sr) == pytest.approx(0.8 * ELEMENTARY_CHARGE * photons, rel=1e-9)


def test_effective_irradiance_and_mismatch_two_channel_arithmetic():
    """Two channels of 100 nm, SR (0.2, 0.6) A/W; reference (1.0, 0.5), field (0.5, 1.0) W m-2 nm-1."""
    edges = np.array([500.0, 600.0, 700.0])
    sr = np.array([0.2, 0.6])
    ref, field = np.array([1.0, 0.5]), np.array([0.5, 1.0])
    jref = short_circuit_current(ref, sr, edges)          # 100 (0.2 + 0.3) = 50 A m-2
    j = short_circuit_current(field, sr, edges)           # 100 (0.1 + 0.6) = 70 A m-2
    assert jref == pytest.approx(50.0) and j == pytest.approx(70.0)
    cell = get_technology("perc")
    eff = pvsim.effective_irradiance(cell, {"perc": j}, {"perc": jref})
    assert eff == pytest.approx(1400.0)
    # broadband: both 150 W m-2, so M = (70/50) / (150/150) = 1.4
    assert spectral_mismatch(eff, 150.0, 150.0) == pytest.approx(1.4)
    assert np.isnan(spectral_mismatch(eff, 0.0, 150.0))


def test_mismatch_against_pvlib():
    """Field spectrum = G173 direct, reference = G173 global. With 1 nm channels widesky's channel
    arithmetic equals pvlib.spectrum.calc_spectral_mismatch_field to 1e-4; on the PSM's 40 nm channels
    the binning changes M by less than 0.1 % (measured: at most 0.04 %, a-Si; docs/pvsim.md)."""
    g = pvsim.read_astm_g173()
    k = (g["wavelength"] >= 280) & (g["wavelength"] <= 2480)
    w = g["wavelength"][k]
    fine = np.arange(280.0, 2481.0, 1.0)
    e_sun = pd.Series(np.interp(fine, w, g["direct"][k]), index=fine)
    e_ref = pd.Series(np.interp(fine, w, g["global"][k]), index=fine)
    for name in ("perc", "cdte", "a_si", "gaas"):
        t = get_technology(name)
        sr = pd.Series(t.sr(fine), index=fine)
        m_pvlib = float(pvlib.spectrum.calc_spectral_mismatch_field(sr, e_sun, e_ref=e_ref))
        for edges, tol in ((np.arange(280.0, 2481.0, 1.0), 1e-4), (None, 1e-3)):
            e = pvsim.channel_edges() if edges is None else edges
            ref_c = pvsim.band_average(fine, e_ref.to_numpy(), e[:-1], e[1:])
            sun_c = pvsim.band_average(fine, e_sun.to_numpy(), e[:-1], e[1:])
            jref = pvsim.reference_currents(t, e, reference=ref_c)
            j = {name: short_circuit_current(sun_c, channel_sr(t, e)[name], e)}
            eff = pvsim.effective_irradiance(t, j, jref)
            mm = spectral_mismatch(eff, np.sum(sun_c * np.diff(e)), np.sum(ref_c * np.diff(e)))
            assert mm == pytest.approx(m_pvlib, rel=tol), (name, edges is None)


def test_effective_irradiance_is_1000_at_stc():
    ref = pvsim.am15g_channels()
    for name in pvsim.technology_names():
        t = get_technology(name)
        jref = pvsim.reference_currents(t)
        j = {k: short_circuit_current(ref * 0.5, v) for k, v in channel_sr(t).items()}
        assert pvsim.effective_irradiance(t, j, jref) == pytest.approx(500.0, rel=1e-12), name


# --- low irradiance, temperature, DC, inverter ---------------------------------------------------

def test_low_irradiance_factor():
    f = pvsim.low_irradiance_factor(np.array([1000.0, 200.0, 0.0, -5.0, 1e-30]), 0.97)
    assert f[0] == 1.0 and f[1] == pytest.approx(0.97, rel=1e-12) and f[2] == 0 and f[3] == 0
    assert f[4] == 0.0                      # clipped at zero far below
    assert pvsim.low_irradiance_factor(100.0, 1.0) == 1.0


def test_dc_and_inverter_match_pvlib():
    rng = np.random.default_rng(5)
    e, tc = rng.uniform(0, 1200, 100), rng.uniform(-5, 70, 100)
    np.testing.assert_allclose(pvsim.dc_power(e, tc, 5000.0, -0.0034),
                               pvlib.pvsystem.pvwatts_dc(e, tc, 5000.0, -0.0034), rtol=1e-12)
    pdc = np.concatenate([[0.0, -3.0], rng.uniform(1, 5500, 100)])
    np.testing.assert_allclose(pvsim.pvwatts_inverter(pdc, 5000.0),
                               pvlib.inverter.pvwatts(pdc, 5000.0), rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="pdc0"):
        pvsim.pvwatts_inverter(pdc, 0.0)


# --- tandems and bifacial ------------------------------------------------------------------------

def test_tandem_stack_rules_hand_values():
    t2, t4 = get_technology("tandem_2t"), get_technology("tandem_4t")
    vt, vb = t2.voltages
    assert vt == pytest.approx(0.8 * (1.68 - 0.45)) and vb == pytest.approx(0.8 * (1.12 - 0.42))
    cur2 = {"tandem_2t:top": np.array([100.0, 200.0]), "tandem_2t:bottom": np.array([200.0, 150.0])}
    np.testing.assert_allclose(pvsim.stack_power(t2, cur2), [100.0 * (vt + vb), 150.0 * (vt + vb)])
    free = 100 * vt + 200 * vb + 200 * vt + 150 * vb
    assert pvsim.current_mismatch_loss(t2, cur2) == pytest.approx(1 - 250.0 * (vt + vb) / free)
    cur4 = {"tandem_4t:top": np.array([100.0]), "tandem_4t:bottom": np.array([200.0])}
    assert pvsim.stack_power(t4, cur4)[0] == pytest.approx(100 * vt + 200 * vb)
    assert pvsim.current_mismatch_loss(t4, cur4) == 0.0
    with pytest.raises(ValueError, match="lack sub-cell"):
        pvsim.stack_power(t2, {"tandem_2t:top": 1.0})


def test_tandem_bandgap_optimum():
    """Under AM1.5G the 2T stack's STC efficiency peaks for a top gap in 1.64-1.75 eV (published
    optimum for perovskite on Si about 1.67-1.73 eV: Hoerantner et al., ACS Energy Lett. 2 (2017) 2506);
    the 4T stack is far less sensitive to the top gap than the 2T."""
    gaps = np.round(np.arange(1.5, 1.801, 0.02), 3)
    t2 = get_technology("tandem_2t")
    t4 = get_technology("tandem_4t")
    e2 = [pvsim.tandem_stc_efficiency(t2.with_top_bandgap(g)) for g in gaps]
    e4 = [pvsim.tandem_stc_efficiency(t4.with_top_bandgap(g)) for g in gaps]
    assert 1.64 <= gaps[int(np.argmax(e2))] <= 1.75
    assert np.ptp(e4) < 0.5 * np.ptp(e2)
    assert 0.22 < max(e2) < 0.30          # perovskite/Si modules 26-27 % (efficiency tables v64)


def test_bifacial_sum():
    np.testing.assert_allclose(pvsim.bifacial_effective_irradiance([800.0], [100.0], 0.7), [870.0])
    with pytest.raises(ValueError, match="bifaciality"):
        pvsim.bifacial_effective_irradiance(1.0, 1.0, 1.5)


# --- pvlib ModelChain hand-off -------------------------------------------------------------------

def test_modelchain_takes_widesky_columns():
    """widesky's effective irradiance, poa_global, temp_air and wind_speed run through pvlib's
    ModelChain.run_model_from_effective_irradiance with the same models (Faiman, PVWatts DC and
    inverter) give widesky's cell temperature, DC and AC power to 1e-9."""
    times = pd.date_range("2024-06-21 04:00", "2024-06-21 20:00", freq="h", tz="Etc/GMT-1")
    x = np.linspace(0, np.pi, len(times))
    poa = 950.0 * np.sin(x)
    eff = 0.97 * poa
    temp_air = 18 + 8 * np.sin(x)
    wind = 1.0 + 2 * np.cos(x) ** 2
    pdc0 = 4000.0
    tc = faiman(poa, temp_air, wind)
    dc = pvsim.dc_power(eff, tc, pdc0, -0.0034)
    ac = pvsim.pvwatts_inverter(dc, pdc0 / 0.96)
    from pvlib.location import Location
    from pvlib.modelchain import ModelChain
    from pvlib.pvsystem import PVSystem
    system = PVSystem(surface_tilt=35, surface_azimuth=180,
                      module_parameters={"pdc0": pdc0, "gamma_pdc": -0.0034},
                      temperature_model_parameters={"u0": 25.0, "u1": 6.84},
                      inverter_parameters={"pdc0": pdc0 / 0.96})
    mc = ModelChain(system, Location(50.08, 14.42, tz="Etc/GMT-1"), aoi_model="no_loss",
                    spectral_model="no_loss", temperature_model="faiman", dc_model="pvwatts",
                    ac_model="pvwatts", losses_model="no_loss")
    data = pd.DataFrame({"effective_irradiance": eff, "poa_global": poa, "temp_air": temp_air,
                         "wind_speed": wind}, index=times)
    mc.run_model_from_effective_irradiance(data)
    np.testing.assert_allclose(mc.results.cell_temperature.to_numpy(), tc, rtol=1e-9)
    np.testing.assert_allclose(mc.results.dc.to_numpy(), dc, rtol=1e-9)
    np.testing.assert_allclose(mc.results.ac.to_numpy(), ac, rtol=1e-9, atol=1e-9)
