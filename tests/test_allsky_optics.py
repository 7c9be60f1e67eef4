"""Cloud optics, haze extension and the CIE overcast sky of the all-sky model (issue 16).

References and tolerances:
* Two-stream slab: the closed form against an independent solution of the same two-stream equations
  (matrix exponential of the linear system, scipy), 1e-9; its conservative limit
  ``1 / (1 + 3 (1 - g) tau / 4)`` (Eddington, Meador & Weaver 1980), 1e-12.
* Droplet co-albedo (anomalous diffraction x 1.5) against Mie theory (miepython) for a gamma size
  distribution (effective radius 10 um, effective variance 0.1, OPAC water refractive index) within 25 %
  at 700-2100 nm; the extinction efficiency of that distribution within 3 % of its mean over
  300-1200 nm (the spectral neutrality of the sun through thin cloud).
* Liquid water k: the OPAC table value at 1000 nm (2.89e-6, Hale & Querry 1973 via OPAC), exactly.
* Saturation vapour density at 20 degC: 17.3 g m-3 (Smithsonian meteorological tables), 1 %.
* Kasten & Young (1989) air mass against pvlib's ``kastenyoung1989``, 1e-9.
* CIE overcast sky: vertical / horizontal diffuse = 0.3963 (analytic: (pi/6 + 4/9) / (7 pi / 9)),
  2 % on 145 Tregenza-Reinhart patches and 0.5 % on 2305.
* Haze: Koschmieder's extra AOD (3.912/V - 3.912/20) x 1.5 km, 1e-12; the measured beam bound.
* Rayleigh optical depth at 550 nm, sea level: 0.0973 (Bodhaine et al. 1999, Table 3), 0.5 %.
* Rayleigh spherical albedo (6S formula) against DISORT (disortpp, 16 streams, Rayleigh phase function,
  plane albedo integrated over 24 Gauss incidence angles) for tau 0.01-1, 2 %; its thin-layer limit
  ``s -> tau`` (single scattering of isotropic light, analytic), 1 %.
* Cloud-top gain: 1 without cloud (1e-12); over a black ground and an infinitely thick cloud it is
  ``1 / (1 - s_top)`` (geometric series, analytic), 1e-6; blue over red.
"""

import numpy as np
import pytest

from widesky.irradiance.cloud_optics import (DEFAULT_ASYMMETRY, US62_WATER_COLUMN, cloud_optical_depth,
                                     cloud_relative_transmittance, cloud_top_rayleigh_gain,
                                     cloud_vapour_path, droplet_coalbedo, liquid_water_k, mie_droplet_optics,
                                     transmitted_path_factor,
                                     rayleigh_optical_depth, rayleigh_spherical_albedo,
                                     saturation_vapour_density, slab_transmittance, vapour_band_deepening)
from widesky.irradiance.haze import haze_correction, relative_airmass
from widesky.irradiance.overcast_sky import cie_overcast_relative, overcast_poa_ratio
from widesky.irradiance.patches import cosine_weights, direction_from_angles, reinhart


def _two_stream_numeric(tau, coalbedo, g):
    from scipy.linalg import expm
    om = 1.0 - coalbedo
    g1 = (7.0 - om * (4.0 + 3.0 * g)) / 4.0
    g2 = -(1.0 - om * (4.0 - 3.0 * g)) / 4.0
    # d/dtau [F_down, F_up] = [[-g1, g2], [-g2, g1]] [F_down, F_up]; F_down(0) = 1, F_up(tau) = 0
    M = expm(np.array([[-g1, g2], [-g2, g1]]) * tau)
    R = -M[1, 0] / M[1, 1]
    return M[0, 0] + M[0, 1] * R


@pytest.mark.parametrize("tau,co", [(0.5, 0.0), (5.0, 1e-4), (20.0, 1e-3), (40.0, 0.02), (3.0, 0.3)])
def test_slab_transmittance_against_numeric_two_stream(tau, co):
    t = slab_transmittance(tau, co, 0.86)
    assert abs(float(t) - _two_stream_numeric(tau, co, 0.86)) < 1e-9


def test_slab_conservative_limit_and_inverse():
    tau = np.array([0.0, 1.0, 10.0, 60.0])
    g = DEFAULT_ASYMMETRY
    np.testing.assert_allclose(slab_transmittance(tau, 0.0, g), 1 / (1 + 0.75 * (1 - g) * tau), rtol=1e-12)
    np.testing.assert_allclose(cloud_optical_depth(slab_transmittance(tau, 0.0, g), g), tau, atol=1e-9)
    rel = cloud_relative_transmittance(np.array([5.0, 40.0]), np.array([0.0, 1e-4, 1e-2]))
    assert rel.shape == (2, 3) and np.all(rel[:, 0] == 1.0)
    assert np.all(np.diff(rel, axis=1) < 0) and np.all(rel[1, 1:] < rel[0, 1:])   # more absorption, less light
    with pytest.raises(ValueError, match="asymmetry"):
        slab_transmittance(1.0, 0.0, 1.0)
    with pytest.raises(ValueError, match="coalbedo"):
        slab_transmittance(1.0, -0.1)


def _mie_gamma(wl, k, re=10.0, ve=0.1, n=None, n_radii=150):
    import miepython as mp
    r = np.linspace(1.0, 40.0, n_radii)
    nr = r ** ((1 - 3 * ve) / ve) * np.exp(-r / (re * ve)) * np.pi * r ** 2
    out = []
    for lam, kk, nn in zip(wl, k, np.full(len(wl), 1.33) if n is None else n):
        q = np.array([mp.efficiencies_mx(complex(nn, -kk), 2 * np.pi * ri * 1000 / lam)[:2] for ri in r])
        out.append(((nr * q[:, 0]).sum() / nr.sum(), 1 - (nr * q[:, 1]).sum() / (nr * q[:, 0]).sum()))
    return np.array(out)


@pytest.mark.reference
@pytest.mark.slow
def test_droplet_optics_against_mie():
    wl = np.array([700.0, 900.0, 1000.0, 1200.0, 1500.0, 2100.0])
    k = liquid_water_k(wl)
    mie = _mie_gamma(wl, k)
    np.testing.assert_allclose(droplet_coalbedo(wl, k, 10.0), mie[:, 1], rtol=0.25)
    wl2 = np.array([300.0, 500.0, 700.0, 900.0, 1200.0])
    q = _mie_gamma(wl2, liquid_water_k(wl2))[:, 0]
    assert np.max(np.abs(q / q.mean() - 1)) < 0.03


@pytest.mark.reference
def test_liquid_water_k_table():
    assert liquid_water_k([1000.0])[0] == pytest.approx(2.89e-6, rel=1e-9)
    k = liquid_water_k([450.0, 700.0, 1000.0, 1500.0])
    assert np.all(np.diff(k) > 0)
    with pytest.raises(ValueError, match="wavelength_nm"):
        liquid_water_k([100.0])
    with pytest.raises(ValueError, match="radius_um"):
        droplet_coalbedo([500.0], [1e-9], 0.1)


def test_vapour_deepening_and_path():
    edges = np.arange(880.0, 1000.1, 40.0)                         # 880-920, 920-960, 960-1000
    f = vapour_band_deepening(edges, np.array([0.0, US62_WATER_COLUMN]))
    np.testing.assert_allclose(f[0], 1.0)
    np.testing.assert_allclose(f[1, 1], 0.46616 / 0.58234, rtol=1e-4)   # 6S T(60 deg) / T(0 deg)
    with pytest.raises(ValueError, match="not in the 6S band table"):
        vapour_band_deepening([881.0, 921.0], np.zeros(1))
    assert saturation_vapour_density(20.0) == pytest.approx(17.3, rel=0.01)
    du = cloud_vapour_path(np.array([2.0, 20.0, 40.0, 400.0]), np.array([5.0, 5.0, 5.0, 5.0]))
    assert 0 < du[0] < du[1] < du[2] <= du[3] == pytest.approx(2 * US62_WATER_COLUMN)
    assert cloud_vapour_path(np.array([40.0]), np.array([15.0]))[0] > du[2]
    # the two-stream mean path is longer than the thick-slab diffusion limit, which is 0 at tau 2
    dd = cloud_vapour_path(np.array([2.0, 20.0]), np.array([5.0, 5.0]), path="diffusion")
    assert dd[0] == 0.0 and dd[1] < du[1]
    # saturated layer of thickness H = 2/3 tau r_e / LWC = 444 m at tau 20: extra path (f - 1) H rho_sat(5 degC)
    f = transmitted_path_factor(np.array([20.0]))[0]
    assert du[1] == pytest.approx((f - 1.0) * 444.44 * saturation_vapour_density(5.0) * 1e-4, rel=1e-3)
    with pytest.raises(ValueError, match="path"):
        cloud_vapour_path(np.array([2.0]), np.array([5.0]), path="random")


def test_airmass_against_pvlib():
    import pvlib
    z = np.array([0.0, 30.0, 60.0, 80.0, 89.0])
    ref = pvlib.atmosphere.get_relative_airmass(z, model="kastenyoung1989")
    np.testing.assert_allclose(relative_airmass(90.0 - z), ref, rtol=1e-9)
    assert np.isnan(relative_airmass(-1.0))


@pytest.mark.parametrize("mf,tol", [(1, 0.02), (4, 0.005)])
def test_cie_overcast_vertical_ratio(mf, tol):
    p = reinhart(mf)
    n = direction_from_angles(np.array([0.0, 90.0]), np.array([180.0, 0.0]))   # vertical, horizontal
    w = cosine_weights(p, n)
    r = overcast_poa_ratio(w, p.vector[:, 2], p.directions[:, 2])
    exact = (np.pi / 6 + 4 / 9) / (7 * np.pi / 9)
    assert abs(r[0] / exact - 1) < tol and abs(r[1] - 1) < 1e-12
    assert cie_overcast_relative(1.0) == 1.0 and cie_overcast_relative(0.0) == pytest.approx(1 / 3)


def _hazy_inputs():
    edges = np.arange(280.0, 2480.1, 40.0)
    lam = 0.5 * (edges[1:] + edges[:-1])
    w = np.diff(edges)
    bn = np.tile(np.exp(-0.5 * ((lam - 700) / 500) ** 2), (4, 1))
    dh = 0.3 * bn * (lam / 500.0) ** -2
    return lam, w, bn, dh


def test_haze_koschmieder_and_policies():
    lam, w, bn, dh = _hazy_inputs()
    el = np.array([30.0, 30.0, 30.0, 30.0])
    vis = np.array([40.0, 10.0, 0.5, 10.0])
    h = haze_correction(lam, w, bn, dh, el, vis)
    np.testing.assert_allclose(h.delta_aod550[:2], [0.0, (3.912 / 10 - 3.912 / 20) * 1.5], rtol=1e-12)
    np.testing.assert_allclose(h.delta_aod550[2], (3.912 / 1 - 3.912 / 20) * 1.5, rtol=1e-12)   # fog
    assert list(h.fog) == [False, False, True, False]
    np.testing.assert_allclose(h.dni[0], bn[0])
    blue, red = np.argmin(np.abs(lam - 420)), np.argmin(np.abs(lam - 900))
    assert h.dni[1, blue] / bn[1, blue] < h.dni[1, red] / bn[1, red] < 1       # reddened beam
    assert np.all(h.dhi[1] >= dh[1]) and h.dhi[1, blue] > dh[1, blue]         # scattered light added
    # the measured beam bounds the aerosol: a beam as bright as the clear model's admits none
    model = bn @ w
    hb = haze_correction(lam, w, bn, dh, el, vis, dni=np.array([np.nan, model[1], 0.0, 0.5 * model[3]]))
    assert hb.delta_aod550[1] == pytest.approx(0.0, abs=1e-6) and hb.beam_bounded[1]
    assert hb.sun_hidden[2] and hb.delta_aod550[2] == 0.0
    tr = (hb.dni[3] @ w) / model[3]
    assert tr >= 0.5 - 1e-6 and hb.delta_aod550[3] <= h.delta_aod550[3]
    with pytest.raises(ValueError, match="negative"):
        haze_correction(lam, w, bn, dh, el, np.array([-1.0, 1, 1, 1]))
    with pytest.raises(ValueError, match="fog_visibility"):
        haze_correction(lam, w, bn, dh, el, vis, fog_visibility=30.0)


def _disort_spherical_albedo(tau, n_streams=16, n_mu=24):
    """Spherical albedo of a conservative Rayleigh layer over a black ground by DISORT: the plane albedo
    ``F_up / (mu0 F0)`` integrated ``2 int r(mu0) mu0 dmu0`` with Gauss-Legendre nodes."""
    from widesky.skymodel.generator.validation import rayleigh_layer_fluxes

    x, wq = np.polynomial.legendre.leggauss(n_mu)
    total = 0.0
    for mu0, wi in zip(0.5 * (x + 1.0), 0.5 * wq):
        up = rayleigh_layer_fluxes(tau, 1.0 - 1e-9, mu0, n_streams)[1]
        total += 2.0 * wi * mu0 * up / (np.pi * mu0)
    return total


def test_rayleigh_depth_and_spherical_albedo():
    assert float(rayleigh_optical_depth(550.0)) == pytest.approx(0.0973, rel=5e-3)
    assert float(rayleigh_optical_depth(550.0, 0.8)) == pytest.approx(0.8 * 0.0973, rel=5e-3)
    assert float(rayleigh_spherical_albedo(1e-3)) == pytest.approx(1e-3, rel=1e-2)
    for tau in (0.01, 0.1, 0.36, 1.0):
        assert float(rayleigh_spherical_albedo(tau)) == pytest.approx(_disort_spherical_albedo(tau), rel=0.02)
    with pytest.raises(ValueError, match="pressure_ratio"):
        rayleigh_optical_depth(550.0, 2.0)


def test_cloud_top_rayleigh_gain():
    lam = np.array([400.0, 550.0, 700.0, 1000.0])
    g = cloud_top_rayleigh_gain(lam, np.array([0.0, 5.0, 30.0]), albedo=0.2)
    np.testing.assert_allclose(g[0], 1.0, rtol=1e-12)
    assert np.all(np.diff(g[1:], axis=1) < 0) and np.all(g[2] > g[1])     # bluer, and more under thicker cloud
    s_top = rayleigh_spherical_albedo(rayleigh_optical_depth(lam, 0.8))
    np.testing.assert_allclose(cloud_top_rayleigh_gain(lam, np.array([1e9]), albedo=0.0)[0], 1 / (1 - s_top),
                               rtol=1e-6)
    with pytest.raises(ValueError, match="albedo"):
        cloud_top_rayleigh_gain(lam, np.array([1.0]), albedo=1.5)


@pytest.mark.slow
def test_two_stream_mean_path_against_disort():
    """Mean path of transmitted light in a conservative slab (g 0.86), in units of its thickness, by the
    equivalence theorem: the two-stream slab against the project's DISORT (16 streams, a beam at 40 deg,
    black ground), within 10 %."""
    pytest.importorskip("disortpp")
    from widesky.skymodel.generator.cloud_reference import _Layers
    from widesky.skymodel.generator.solver import SolverConfig, run_disort
    cfg = SolverConfig(16, 16, intensity_correction=False)
    mu0, g, eps = np.sin(np.radians(40.0)), 0.86, 1e-4

    def flux(tau, c):
        layers = _Layers(np.array([tau]), np.array([1.0 - c]), (g ** np.arange(17))[None, :])
        _, fd, fb = run_disort(layers, mu0, 0.0, np.array([0.0]), np.array([0.0]), cfg, repair=False)
        return fd + fb
    taus = np.array([3.0, 10.0, 20.0, 40.0, 80.0])
    disort = np.array([-(np.log(flux(t, eps)) - np.log(flux(t, 0.0))) / (eps * t) for t in taus])
    np.testing.assert_allclose(transmitted_path_factor(taus, g), disort, rtol=0.10)
    assert np.all(np.diff(disort) > 0) and disort[2] > 2.5          # far above the diffusion limit's 1.4


@pytest.mark.reference
@pytest.mark.slow
def test_shipped_droplet_table_against_mie():
    """The shipped Mie table (irradiance/data) against an independent Mie average (600 radii 1-40 um; 150
    are too few for the absorption at 1000 nm, whose resonances need the fine grid): extinction shape within
    1 %, co-albedo within 5 %."""
    from widesky.skymodel.opac import refractive_index
    wl = np.array([450.0, 1000.0, 1500.0, 2100.0])
    ext, co, g = mie_droplet_optics(wl)
    w5 = np.append(wl, 550.0)
    m = refractive_index("stco", w5, 0)
    mie = _mie_gamma(w5, -m.imag, n=m.real, n_radii=600)
    np.testing.assert_allclose(ext, mie[:-1, 0] / mie[-1, 0], rtol=0.01)
    np.testing.assert_allclose(co[1:], mie[1:-1, 1], rtol=0.05)
    assert np.all((g > 0.84) & (g < 0.875)) and g[0] > g[2]           # forward peak weakens into the NIR


def test_exponential_integrals_against_scipy():
    """E1 and E3 (numpy, no scipy at run time) against scipy.special (Cephes): E1 within 2e-8 relative over
    1e-8..50 (Abramowitz & Stegun 5.1.56's bound above 1, the series below), E3 within 1e-6 up to x = 5 (the
    recurrence loses digits to cancellation as x grows; Rayleigh optical depths stay below 1.3), E3(0) = 1/2."""
    special = pytest.importorskip("scipy.special")
    from widesky.irradiance.cloud_optics import exponential_integral_1, exponential_integral_3
    x = np.logspace(-8, np.log10(50.0), 3000)
    np.testing.assert_allclose(exponential_integral_1(x), special.exp1(x), rtol=2e-8, atol=0)
    x5 = x[x <= 5.0]
    np.testing.assert_allclose(exponential_integral_3(x5), special.expn(3, x5), rtol=1e-6, atol=0)
    assert float(exponential_integral_3(0.0)) == 0.5
    with pytest.raises(ValueError, match="x must be > 0"):
        exponential_integral_1(np.array([0.0]))
