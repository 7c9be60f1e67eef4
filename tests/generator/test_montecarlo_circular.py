"""The sign convention of the circular Stokes parameter V of the Monte Carlo solver, against an analytic case.

Circular polarisation of skylight needs two scatterings: the first polarises the sunlight linearly, the second
(by a particle with a non-zero P34) turns the part at 45 deg to its scattering plane into circular. The case: a
plane-parallel slab of identical spheres (refractive index 1.33, size parameter 2, no Rayleigh, no ground), optical
depth 0.2, sun at 40 deg zenith, traced to second order (``max_order=2``). The reference is an independent
computation of the second-order radiance by quadrature in *electric fields* (Jones calculus), not Stokes matrices:
the sunlight as two incoherent orthogonal fields, each scattering as E_par' = S2 E_par, E_perp' = S1 E_perp with
Bohren & Huffman's amplitude functions (miepython; their section 3.2 basis: e_perp along k_out x k_in, e_par =
k x e_perp), attenuation along every segment, and the observer's V computed without any basis as

    V = i (E x E*) . k       (k the propagation direction, time factor exp(-i omega t)),

positive when the electric vector turns counterclockwise as seen by an observer looking toward the source. So the
test fixes the physical meaning of the kernel's V: V > 0 = counterclockwise rotation seen by the observer looking
at the sky (the IAU / IEEE convention's right-handed, Born & Wolf's left-handed). The same quadrature's I checks
the quadrature itself against the Monte Carlo's second order. Tolerance: 4 standard errors plus 2 % of I (quadrature).
"""

import numpy as np
import pytest

from widesky.skymodel.generator.montecarlo import Components, MonteCarloConfig, trace
from widesky.skymodel.generator.montecarlo_mie import matrix_mu_grid

M_SPHERE, X_SPHERE = 1.33 + 0.0j, 2.0
TAU, THICK_KM = 0.2, 1.0
SZA = 40.0
VIEWS = (np.array([50.0, 50.0, 30.0, 30.0, 65.0]), np.array([60.0, -60.0, 120.0, -120.0, 90.0]))


def _amplitudes(mu):
    """Bohren & Huffman's amplitude functions S1, S2 (their eq. 4.74, time factor exp(-i omega t)) at cosines ``mu``,
    summed here from miepython's Mie coefficients a_n, b_n (which follow Bohren & Huffman: a_1 ~ -2i x^3 (m^2 - 1) /
    (3 (m^2 + 2)) for a small sphere; miepython's own ``S1_S2`` returns the complex conjugates)."""
    import miepython

    mu = np.asarray(mu, float)
    a, b = miepython.an_bn(M_SPHERE, X_SPHERE)
    n_max = len(a)
    x = mu.ravel()
    pi = np.zeros((n_max, x.size))
    tau = np.zeros_like(pi)
    p_prev, p_cur = np.zeros_like(x), np.ones_like(x)  # pi_0, pi_1
    for n in range(1, n_max + 1):
        pi[n - 1] = p_cur
        tau[n - 1] = n * x * p_cur - (n + 1) * p_prev
        p_prev, p_cur = p_cur, ((2 * n + 1) * x * p_cur - (n + 1) * p_prev) / n
    n = np.arange(1, n_max + 1)
    f = (2 * n + 1) / (n * (n + 1.0))
    s1 = (f * a) @ pi + (f * b) @ tau
    s2 = (f * a) @ tau + (f * b) @ pi
    return s1.reshape(mu.shape), s2.reshape(mu.shape)


def _norm():
    """The factor that makes P11 = (|S1|^2 + |S2|^2) / 2 / norm average 1 over the sphere."""
    mu = matrix_mu_grid()
    s1, s2 = _amplitudes(mu)
    p11 = 0.5 * (np.abs(s1) ** 2 + np.abs(s2) ** 2)
    return 0.5 * float(np.sum(0.5 * (p11[1:] + p11[:-1]) * np.diff(mu)))


def _slab() -> Components:
    mu = matrix_mu_grid()
    s1, s2 = _amplitudes(mu)
    c = s2 * np.conj(s1)
    tab = np.stack([0.5 * (np.abs(s2) ** 2 + np.abs(s1) ** 2), 0.5 * (np.abs(s2) ** 2 - np.abs(s1) ** 2),
                    c.real, c.imag], axis=1) / _norm()
    e = np.full((1, 1), TAU / THICK_KM)
    return Components(levels_km=np.array([0.0, THICK_KM]), extinction=e, rayleigh=np.zeros_like(e),
                      aerosol=e.copy(), depolarisation=np.zeros(1), aerosol_table=np.zeros(1, np.int32),
                      aerosol_matrices=tab[None], albedo=np.zeros(1), channel=np.zeros(1, np.int32),
                      weight=np.ones(1))


def _scatter(E, k_in, k_out, norm):
    """Fields (..., 3) complex travelling along k_in, scattered into k_out (unit (..., 3)), amplitude normalised so
    that the intensity follows P11 / norm."""
    perp = np.cross(k_out, k_in)
    perp /= np.linalg.norm(perp, axis=-1, keepdims=True)
    par_in, par_out = np.cross(k_in, perp), np.cross(k_out, perp)
    s1, s2 = _amplitudes(np.clip(np.einsum("...i,...i->...", k_in, k_out), -1, 1))
    e_par = np.einsum("...i,...i->...", E, par_in)
    e_perp = np.einsum("...i,...i->...", E, perp)
    return ((s2 * e_par)[..., None] * par_out + (s1 * e_perp)[..., None] * perp) / np.sqrt(norm)


def _second_order_quadrature(view_zenith, view_azimuth, n_mu=160, n_phi=144, n_s=48):
    """(I, V) of the second order at the observer (bottom of the slab) per unit solar irradiance [sr-1]."""
    beta = TAU / THICK_KM
    H = THICK_KM
    z0 = np.radians(SZA)
    sun = np.array([np.sin(z0), 0.0, np.cos(z0)])
    mu0 = np.cos(z0)
    th, ph = np.radians(view_zenith), np.radians(view_azimuth)
    v = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    # backward direction u from the first vertex to the second: mu_u = +-t^2 (dense near the horizon), phi uniform
    t, wt = np.polynomial.legendre.leggauss(n_mu)
    t, wt = 0.5 * (t + 1), 0.5 * wt
    mus = np.concatenate([t ** 2, -(t ** 2)])
    wmu = np.concatenate([2 * t * wt, 2 * t * wt])
    phis = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    MU, PHI = np.meshgrid(mus, phis, indexing="ij")
    sin_u = np.sqrt(1 - MU ** 2)
    u = np.stack([sin_u * np.cos(PHI), sin_u * np.sin(PHI), MU], axis=-1)
    w_dir = wmu[:, None] * (2 * np.pi / n_phi)
    # geometry: s1 along v to z1 = s1 mu_v; from there s2 along u; the sun's path to the top from z2
    xs, ws = np.polynomial.legendre.leggauss(n_s)
    z1 = 0.5 * H * (xs + 1)
    wz = 0.5 * H * ws
    mv = v[2]
    G = np.zeros_like(MU)
    for zz, w in zip(z1, wz):
        ell = np.where(MU > 0, (H - zz) / np.maximum(MU, 1e-300), zz / np.maximum(-MU, 1e-300))
        c = beta * (1 - MU / mu0)
        inner = np.where(np.abs(c * ell) > 1e-9, -np.expm1(-c * ell) / np.where(c == 0, 1, c), ell)
        G += w / mv * np.exp(-beta * zz / mv) * np.exp(-beta * (H - zz) / mu0) * inner
    norm = _norm()
    k0, k1, k2 = -sun, -u, np.broadcast_to(-v, u.shape)
    basis = np.cross(k0, [0.0, 1.0, 0.0])
    basis /= np.linalg.norm(basis)
    out_i = out_v = 0.0
    for e_in in (basis, np.cross(k0, basis)):  # unpolarised: two incoherent orthogonal fields
        E = np.broadcast_to(e_in.astype(complex), u.shape)
        E = _scatter(E, np.broadcast_to(k0, u.shape), k1, norm)
        E = _scatter(E, k1, k2, norm)
        i = np.sum(np.abs(E) ** 2, axis=-1)
        vv = np.real(1j * np.einsum("...i,...i->...", np.cross(E, np.conj(E)), k2))
        out_i = out_i + 0.5 * i
        out_v = out_v + 0.5 * vv
    f = (beta / (4 * np.pi)) ** 2 * G * w_dir
    return float(np.sum(f * out_i)), float(np.sum(f * out_v))


@pytest.fixture(scope="module")
def second_order():
    cp = _slab()
    cfg = dict(samples=120000, planet_radius_km=None, polarised=True)
    r2 = trace(cp, SZA, *VIEWS, MonteCarloConfig(max_order=2, seed=11, **cfg))
    r1 = trace(cp, SZA, *VIEWS, MonteCarloConfig(max_order=1, seed=12, **cfg))
    return r1, r2


@pytest.mark.slow
def test_first_order_has_no_circular_polarisation(second_order):
    r1, _ = second_order
    assert np.all(r1.stokes[:, 0, 3] == 0.0)


@pytest.mark.slow
def test_circular_polarisation_sign_and_size_against_jones_quadrature(second_order):
    r1, r2 = second_order
    for j, (vz, va) in enumerate(zip(*VIEWS)):
        i_q, v_q = _second_order_quadrature(vz, va)
        i_mc = r2.stokes[j, 0, 0] - r1.stokes[j, 0, 0]
        se_i = np.hypot(r2.stderr[j, 0, 0], r1.stderr[j, 0, 0])
        assert abs(i_mc - i_q) <= 4 * se_i + 0.02 * i_q, (vz, va, i_mc, i_q, se_i)
        v_mc, se_v = r2.stokes[j, 0, 3], r2.stderr[j, 0, 3]
        assert abs(v_mc - v_q) <= 4 * se_v + 0.02 * abs(v_q) + 1e-4 * i_q, (vz, va, v_mc, v_q, se_v)
        if abs(v_q) > 5 * se_v:
            assert np.sign(v_mc) == np.sign(v_q)
    # mirror symmetry about the sun's vertical: V changes sign, I does not
    assert np.sign(r2.stokes[0, 0, 3]) == -np.sign(r2.stokes[1, 0, 3])
