"""Atmosphere, Rayleigh, ozone, solar spectrum and aerosol profile of skymodel.generator."""

import numpy as np
import pytest

from widesky.skymodel import visibility
from widesky.core import rayleigh
from widesky.skymodel.generator import atmosphere, solar
from widesky.skymodel.generator.aerosol import aerosol_layer_fractions
from widesky.skymodel.channels import CHANNEL_EDGES_NM, fine_slice


def test_rayleigh_matches_hansen_travis_optical_depth():
    # Hansen & Travis (1974) eq. 2.29: tau(1013.25 hPa) = 0.008569 lam^-4 (1 + 0.0113 lam^-2 + 0.00013 lam^-4),
    # lam in um. Bodhaine et al. (1999) differ from it by < 1 % over 400-1000 nm; column = 1013.25 hPa / (m g).
    lam = np.array([400.0, 550.0, 700.0, 1000.0])
    lu = lam / 1000
    ht = 0.008569 * lu ** -4 * (1 + 0.0113 * lu ** -2 + 0.00013 * lu ** -4)
    column = 101325.0 / (28.9644e-3 / 6.02214076e23 * 9.80665) * 1e-4  # molecules cm-2
    ours = rayleigh.rayleigh_cross_section(lam) * column
    np.testing.assert_allclose(ours, ht, rtol=0.01)


def test_rayleigh_depolarisation_and_moments():
    # Bodhaine et al. (1999): depolarisation of air about 0.028-0.029 in the visible, rising into the UV
    rho = rayleigh.depolarization_ratio([300.0, 550.0, 2000.0])
    assert 0.027 < rho[1] < 0.030 and rho[0] > rho[1] > rho[2]
    mu = np.linspace(-1, 1, 20001)
    p = rayleigh.rayleigh_phase_function(mu, 550.0)
    assert abs(np.trapezoid(p, mu) / 2 - 1) < 1e-8  # normalised
    chi2 = np.trapezoid(p * 0.5 * (3 * mu ** 2 - 1), mu) / 2
    assert abs(chi2 - rayleigh.rayleigh_moments(550.0, 4)[2]) < 1e-8


def test_visibility_constant_is_bodhaine():
    assert visibility.RAYLEIGH_EXTINCTION_550_KM == pytest.approx(
        float(rayleigh.rayleigh_extinction_sea_level_km(550.0)), rel=1e-4)


@pytest.mark.parametrize("h", [0.5, 1.5, 3.0])
def test_aerosol_profile_integrates_to_koschmieder_aod(h):
    levels = atmosphere.DEFAULT_LEVELS_KM
    f = aerosol_layer_fractions(levels, h)
    for v in (20.0, 23.0, 50.0, 131.8):
        aod = visibility.aod550_from_visibility(v, h)
        assert np.sum(aod * f) == pytest.approx(aod, rel=1e-14)
    assert np.all(np.diff(f[:5] / np.diff(levels)[:5]) < 0)  # extinction decreases upward


def test_slant_path_factors():
    z = np.array([0.0, 60.0, 90.0])
    f = atmosphere.slant_path_factors(atmosphere.DEFAULT_LEVELS_KM, z)
    np.testing.assert_allclose(f[0], 1.0, rtol=1e-12)
    assert np.all(f[1] < 2.0) and np.all(f[1] > 1.9)  # curvature shortens the 1/cos path (most at the top)
    assert f[1][0] > 1.999
    h = atmosphere.DEFAULT_LEVELS_KM[1]  # horizontal ray: path through the first shell sqrt(2 R h + h^2)
    assert f[2][0] == pytest.approx(np.sqrt(2 * 6371.0 * h + h * h) / h, rel=1e-9)
    assert np.all(np.isfinite(f[2]))
    with pytest.raises(ValueError, match="zenith_deg"):
        atmosphere.slant_path_factors(atmosphere.DEFAULT_LEVELS_KM, [95.0])


@pytest.mark.reference
def test_afgl_us_standard_columns_and_scaling():
    a = atmosphere.standard_atmosphere("us")
    # AFGL US standard: PW 1.44 cm and O3 345.6 DU to 120 km (data MANIFEST); 0-100 km with log-linear layers
    assert a.precipitable_water_cm == pytest.approx(1.44, rel=0.02)
    assert a.ozone_du == pytest.approx(345.6, rel=0.01)
    assert a.air.sum() == pytest.approx(2.15e25, rel=0.01)  # p0 / (m g)
    b = atmosphere.standard_atmosphere("us", precipitable_water=1.4164, ozone=0.3438, ozone_unit="atm-cm")
    assert b.precipitable_water_cm == pytest.approx(1.4164, rel=1e-12)
    assert b.ozone_du == pytest.approx(343.8, rel=1e-12)
    with pytest.raises(ValueError, match="profile"):
        atmosphere.standard_atmosphere("xx")
    with pytest.raises(ValueError, match="precipitable_water"):
        atmosphere.standard_atmosphere("us", precipitable_water=-1)


@pytest.mark.reference
def test_ozone_band_transmittance_is_spectrally_averaged():
    # the 280-320 nm trap: exp(-mean tau) is ~0 while the band transmittance is ~0.25 (6S: 0.252 at SZA 0, US62)
    from widesky.skymodel.generator.ozone import ozone_optical_depth

    a = atmosphere.standard_atmosphere("us")
    tau = ozone_optical_depth(a).sum(axis=0)
    _, et = solar.extraterrestrial_spectrum("tsis1")
    s = fine_slice(0)
    t_band = np.sum(et[s] * np.exp(-tau[s])) / et[s].sum()
    assert np.exp(-tau[s].mean()) < 1e-3
    assert t_band == pytest.approx(0.252, rel=0.15)
    s = fine_slice(1)  # 320-360 nm, 6S 0.960
    assert np.sum(et[s] * np.exp(-tau[s])) / et[s].sum() == pytest.approx(0.960, abs=0.015)  # ours 0.972


@pytest.mark.reference
def test_extraterrestrial_integrals():
    # MANIFEST: TSIS-1 280-2480 nm = 1308.4 W m-2
    _, e = solar.extraterrestrial_spectrum("tsis1")
    assert e.sum() == pytest.approx(1308.4, abs=0.2)
    ch = solar.channel_extraterrestrial("tsis1")
    assert ch.shape == (55,) and ch.sum() * 40 == pytest.approx(e.sum(), rel=1e-12)
    assert len(CHANNEL_EDGES_NM) == 56
    with pytest.raises(ValueError, match="source"):
        solar.extraterrestrial_spectrum("sun")
