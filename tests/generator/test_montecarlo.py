"""Monte Carlo solver: analytic limits, estimator properties, reproducibility and input checks.

Tolerances are 4 standard errors of the Monte Carlo mean (seeded, deterministic) plus the stated model error.
"""

import numpy as np
import pytest

from widesky.skymodel.generator.montecarlo import STREAM_MODES, Components, MonteCarloConfig, rayleigh_slab, trace
from widesky.core.rayleigh import depolarization_ratio

PP = dict(planet_radius_km=None)


def _single_scattering_stokes(tau, sza, vz, va, rho, downward=False):
    """Analytic singly-scattered Stokes vector of a homogeneous Rayleigh slab over a black ground, unit flux
    (Chandrasekhar 1950; depolarised matrix of Hansen & Travis 1974 eq. 2.15), in the meridian frame of the view,
    computed with vectors independently of the kernel."""
    th, ph, z = np.radians(vz), np.radians(va), np.radians(sza)
    sg = -1.0 if downward else 1.0
    v = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), sg * np.cos(th)], 1)
    s = np.array([np.sin(z), 0.0, np.cos(z)])
    mu0, mu = np.cos(z), np.cos(th)
    cs = v @ s
    dl = (1 - rho) / (1 + rho / 2)
    p11 = 0.75 * dl * (1 + cs ** 2) + 1 - dl
    p12 = 0.75 * dl * (cs ** 2 - 1)
    if downward:  # reflected at the top
        amp = mu0 / (4 * np.pi * (mu0 + mu)) * (1 - np.exp(-tau / mu0 - tau / mu))
    else:  # transmitted to the ground
        amp = mu0 / (4 * np.pi * (mu0 - mu)) * (np.exp(-tau / mu0) - np.exp(-tau / mu))
    # polarisation direction of P12 < 0: perpendicular to the scattering plane (normal n = w_in x w_out)
    w_out = -v
    n = np.cross(-s[None, :], w_out)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    a = np.stack([np.cos(th) * np.cos(ph), np.cos(th) * np.sin(ph), -sg * np.sin(th)], 1)  # meridian-plane vector
    b = np.cross(w_out, a)
    chi = np.arctan2(np.sum(n * b, 1), np.sum(n * a, 1))  # angle of n from a toward b
    i = amp * p11
    lin = -amp * p12  # intensity excess along n
    return np.stack([i, lin * np.cos(2 * chi), lin * np.sin(2 * chi)], 1)


@pytest.mark.parametrize("streams", STREAM_MODES)
@pytest.mark.parametrize("downward", [False, True])
def test_first_order_matches_analytic_single_scattering(downward, streams):
    """max_order=1 is exactly single scattering: I, Q, U within 4 se of the closed form (also checks the Stokes
    rotations into the meridian frame, and U's sign under azimuth reversal)."""
    rho = float(depolarization_ratio(450.0))
    slab = Components(**{**rayleigh_slab(0.1).__dict__, "depolarisation": np.array([rho])})
    vz = np.array([0.0, 30.0, 60.0, 80.0, 60.0, 60.0, 45.0])
    va = np.array([0.0, 0.0, 90.0, 180.0, 45.0, -135.0, 135.0])
    sza = 40.0
    r = trace(slab, sza, vz, va, MonteCarloConfig(samples=40000 if downward else 3000, max_order=1, seed=3, streams=streams,
                                                       **PP),
              observer_altitude_km=10.0 if downward else 0.0, downward=downward)
    ref = _single_scattering_stokes(0.1, sza, vz, va, rho, downward)
    got, se = r.stokes[:, 0, :3], r.stderr[:, 0, :3]
    assert np.all(se[:, 0] / ref[:, 0] < 0.02)
    assert np.all(np.abs(got - ref) <= 4 * se + 1e-12), (got - ref) / ref[:, :1]
    assert np.all(r.stokes[:, 0, 3] == 0.0)  # Rayleigh makes no circular polarisation from unpolarised light


@pytest.mark.parametrize("streams", STREAM_MODES)
def test_degree_of_polarisation_single_scattering_limit(streams):
    """At optical depth 0.002 (multiple scattering ~0.2 %) the degree of polarisation is the single-scattering
    value Delta sin^2 / (Delta (1 + cos^2) + 4 (1 - Delta) / 3) for air's depolarisation at 550 nm (0.0279),
    within 0.005 absolute; the polarisation is perpendicular to the scattering plane within 0.5 deg."""
    rho = float(depolarization_ratio(550.0))
    slab = Components(**{**rayleigh_slab(0.002).__dict__, "depolarisation": np.array([rho])})
    vz = np.array([0.0, 20.0, 50.0, 70.0, 85.0, 50.0, 70.0])
    va = np.array([0.0, 180.0, 90.0, 120.0, 180.0, 30.0, 60.0])
    sza = 55.0
    r = trace(slab, sza, vz, va, MonteCarloConfig(samples=2000, seed=11, streams=streams, **PP))
    dl = (1 - rho) / (1 + rho / 2)
    ss = _single_scattering_stokes(0.002, sza, vz, va, rho)
    th, ph, z = np.radians(vz), np.radians(va), np.radians(sza)
    cs = np.sin(th) * np.cos(ph) * np.sin(z) + np.cos(th) * np.cos(z)
    dop = dl * (1 - cs ** 2) / (dl * (1 + cs ** 2) + 4 * (1 - dl) / 3)
    assert np.allclose(dop, np.hypot(ss[:, 1], ss[:, 2]) / ss[:, 0])  # the formula is the closed form's
    got = r.degree_of_polarisation()[:, 0]
    assert np.max(np.abs(got - dop)) < 0.005, got - dop
    aop = 0.5 * np.degrees(np.arctan2(r.stokes[:, 0, 2], r.stokes[:, 0, 1]))
    aop_ref = 0.5 * np.degrees(np.arctan2(ss[:, 2], ss[:, 1]))
    d = (aop - aop_ref + 90) % 180 - 90
    assert np.max(np.abs(d[dop > 0.1])) < 0.5


def _absorbing_slab(tau_abs, channels):
    """Rayleigh slab (tau 0.3, albedo 0.3, 3 layers) with one component per absorption optical depth."""
    base = rayleigh_slab(0.3, albedo=0.3, n_layers=3)
    k = len(tau_abs)
    ext = base.extinction + np.asarray(tau_abs, float)[None, :] / 10.0
    return Components(levels_km=base.levels_km, extinction=ext, rayleigh=np.repeat(base.rayleigh, k, 1),
                      aerosol=np.zeros_like(ext), depolarisation=np.zeros(k), aerosol_table=np.zeros(k, np.int32),
                      aerosol_matrices=base.aerosol_matrices, albedo=np.full(k, 0.3),
                      channel=np.asarray(channels, np.int32), weight=np.ones(k))


def test_hero_components_are_unbiased_against_separate_runs():
    """Two components with very different absorption (tau_abs 0 and 3: a saturated band term) traced on shared
    paths give the same radiances as each traced alone, within 4 se."""
    vz, va = np.array([0.0, 60.0, 85.0]), np.array([0.0, 90.0, 180.0])
    both = trace(_absorbing_slab([0.0, 3.0], [0, 1]), 30.0, vz, va, MonteCarloConfig(samples=8000, seed=21, **PP))
    for k, tau_abs in enumerate([0.0, 3.0]):
        alone = trace(_absorbing_slab([tau_abs], [0]), 30.0, vz, va, MonteCarloConfig(samples=8000, seed=22, **PP))
        a, b = both.stokes[:, k, 0], alone.stokes[:, 0, 0]
        se = np.hypot(both.stderr[:, k, 0], alone.stderr[:, 0, 0])
        assert np.all(b > 20 * alone.stderr[:, 0, 0])
        assert np.all(np.abs(a - b) <= 4 * se), (a - b) / se


@pytest.mark.parametrize("streams", STREAM_MODES)
def test_large_planet_equals_plane_parallel_and_twilight_needs_shells(streams):
    """Spherical shells of radius 1e7 km reproduce the plane-parallel slab within 4 se; a sun 2 deg below the
    horizon lights a spherical sky (positive radiance) and is refused for plane-parallel slabs."""
    slab = rayleigh_slab(0.25, albedo=0.2, n_layers=4, thickness_km=20.0)
    vz, va = np.array([0.0, 45.0, 80.0]), np.array([0.0, 90.0, 0.0])
    pp = trace(slab, 60.0, vz, va, MonteCarloConfig(samples=6000, seed=1, streams=streams, **PP))
    sp = trace(slab, 60.0, vz, va, MonteCarloConfig(samples=6000, seed=2, planet_radius_km=1e7, streams=streams))
    se = np.hypot(pp.stderr[:, 0, 0], sp.stderr[:, 0, 0])
    assert np.all(np.abs(pp.stokes[:, 0, 0] - sp.stokes[:, 0, 0]) <= 4 * se)
    tw = trace(slab, 92.0, vz, va, MonteCarloConfig(samples=8000, seed=3, streams=streams))
    assert np.all(tw.stokes[:, 0, 0] > 10 * tw.stderr[:, 0, 0])
    assert tw.stokes[2, 0, 0] > tw.stokes[0, 0, 0]  # brighter toward the set sun
    with pytest.raises(ValueError, match="below the horizon needs spherical"):
        trace(slab, 92.0, vz, va, MonteCarloConfig(samples=10, **PP))


@pytest.mark.parametrize("streams", STREAM_MODES)
def test_ground_orders_give_every_albedo_from_one_run(streams):
    """A run over a white ground split by order of ground reflection (``ground_orders``) reproduces separate runs at
    albedo 0.6 (Rayleigh slab tau 0.3, polarised, plane-parallel) within 4 se, and exactly its own orders at a = 0 / 1;
    spherical shells with a sun below the horizon too."""
    from widesky.skymodel.generator.montecarlo import stokes_at_albedo

    vz, va = np.array([10.0, 40.0, 60.0, 80.0, 40.0]), np.array([0.0, 30.0, 90.0, 140.0, 180.0])
    direct = trace(rayleigh_slab(0.3, 0.6), 50.0, vz, va, MonteCarloConfig(samples=20000, seed=5, streams=streams,
                                                                           **PP))
    orders = trace(rayleigh_slab(0.3, 0.0), 50.0, vz, va, MonteCarloConfig(samples=20000, seed=6, ground_orders=4,
                                                                           streams=streams, **PP))
    assert orders.stokes.shape == (5, 1, 4, 4)
    v, se = stokes_at_albedo(orders.stokes, 0.6, orders.stderr)
    tol = 4 * np.hypot(se, direct.stderr) + 1e-12
    assert np.all(np.abs(v - direct.stokes)[..., :3] <= tol[..., :3])
    np.testing.assert_allclose(stokes_at_albedo(orders.stokes, 0.0), orders.stokes[:, :, 0])
    np.testing.assert_allclose(stokes_at_albedo(orders.stokes, 1.0), orders.stokes.sum(axis=2))
    sph = MonteCarloConfig(samples=4000, seed=7, streams=streams)
    d2 = trace(rayleigh_slab(0.3, 0.6), 92.0, vz, va, sph)
    o2 = trace(rayleigh_slab(0.3, 0.0), 92.0, vz, va, MonteCarloConfig(samples=4000, seed=8, ground_orders=3,
                                                                      streams=streams))
    v2, se2 = stokes_at_albedo(o2.stokes, 0.6, o2.stderr)
    assert np.all(np.abs(v2 - d2.stokes)[..., 0] <= 4 * np.hypot(se2, d2.stderr)[..., 0] + 1e-15)
    with pytest.raises(ValueError, match="albedo"):
        stokes_at_albedo(orders.stokes, 1.5)
    with pytest.raises(ValueError, match="ground_orders"):
        MonteCarloConfig(ground_orders=-1)


@pytest.mark.parametrize("streams", STREAM_MODES)
def test_reproducible_and_thread_independent(streams):
    slab = rayleigh_slab(0.3, albedo=0.1, n_layers=2)
    vz, va = np.array([0.0, 50.0, 70.0, 30.0]), np.array([0.0, 90.0, 180.0, 45.0])
    a = trace(slab, 30.0, vz, va, MonteCarloConfig(samples=200, seed=7, threads=1, streams=streams, **PP))
    b = trace(slab, 30.0, vz, va, MonteCarloConfig(samples=200, seed=7, threads=2, streams=streams, **PP))
    c = trace(slab, 30.0, vz, va, MonteCarloConfig(samples=200, seed=8, threads=1, streams=streams, **PP))
    assert np.array_equal(a.stokes, b.stokes)
    assert not np.array_equal(a.stokes, c.stokes)


def test_bad_input_names_the_parameter():
    slab = rayleigh_slab(0.1)
    with pytest.raises(ValueError, match="samples=0"):
        MonteCarloConfig(samples=0)
    with pytest.raises(ValueError, match="planet_radius_km=10"):
        MonteCarloConfig(planet_radius_km=10.0)
    with pytest.raises(ValueError, match="solar_zenith_deg=120"):
        trace(slab, 120.0, [0.0], [0.0])
    with pytest.raises(ValueError, match="view_zenith_deg"):
        trace(slab, 30.0, [95.0], [0.0])
    with pytest.raises(ValueError, match="observer_altitude_km=11"):
        trace(slab, 30.0, [0.0], [0.0], observer_altitude_km=11.0)
    with pytest.raises(ValueError, match="tau=0"):
        rayleigh_slab(0.0)


@pytest.mark.reference
def test_mie_matrix_consistent_with_the_disort_chain():
    """The tabulated aerosol matrix has P11 normalised to mean 1 over the sphere, its asymmetry parameter is the
    DISORT chain's first Legendre moment (same Mie coefficients, independent angular sums) within 0.5 %, P12 / P11
    lies in [-1, 1] and vanishes in the exact forward and backward directions."""
    from widesky.skymodel.generator.aerosol import opac_mixture
    from widesky.skymodel.generator.montecarlo_mie import legendre_moment, matrix_mu_grid, mixture_matrix

    for lam in (500.0, 1620.0):
        t = mixture_matrix("continental_average", 50, lam)
        mu = matrix_mu_grid()
        assert abs(np.sum(0.5 * (t[1:, 0] + t[:-1, 0]) * np.diff(mu)) - 2.0) < 1e-12
        g_ref = opac_mixture("continental_average", 50).at(lam)[2][0, 1]
        assert abs(legendre_moment(t, 1) / g_ref - 1) < 0.005
        assert np.all(np.abs(t[:, 1]) <= t[:, 0] * (1 + 1e-9))
        assert abs(t[0, 1] / t[0, 0]) < 1e-6 and abs(t[-1, 1] / t[-1, 0]) < 1e-6
