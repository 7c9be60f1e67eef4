"""Monte Carlo first-order methods: the quadrature of single scattering along the view ray (``first_order=
"quadrature"``, the default) against a closed form, and the new estimator against the original sampled one.

Tolerances: the deterministic part against an independent dense numerical integration of the optically thin limit
(relative 1e-4, the attenuation that the thin limit drops is below 1e-5); the two estimators against each other
within 4 standard errors of their difference (sigma = hypot of the two standard errors of the mean).
"""

from pathlib import Path

import numpy as np
import pytest

from widesky.skymodel.generator.montecarlo import STREAM_MODES, Components, MonteCarloConfig, rayleigh_slab, trace

R_EARTH = 6371.0


def _sunlit_length(vz, va, sza, top_km, n=400_000):
    """Length [km] of the part of the view ray (observer on the ground, view zenith vz, relative azimuth va [deg])
    inside the shell below top_km that sees the sun (outside the Earth's shadow cylinder), by dense midpoint
    sampling of the ray, independently of the kernel."""
    th, ph, z = np.radians(vz), np.radians(va), np.radians(sza)
    d = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    s = np.array([np.sin(z), 0.0, np.cos(z)])
    x0 = np.array([0.0, 0.0, R_EARTH])
    rt = R_EARTH + top_km
    b = x0 @ d
    t_end = -b + np.sqrt(b * b - (x0 @ x0 - rt * rt))
    t = (np.arange(n) + 0.5) * (t_end / n)
    x = x0[None, :] + t[:, None] * d[None, :]
    xs = x @ s
    perp2 = np.einsum("ij,ij->i", x, x) - xs ** 2
    lit = ~((xs < 0) & (perp2 < R_EARTH ** 2))
    return np.sum(lit) * (t_end / n)


@pytest.mark.parametrize("sza", [60.0, 92.0, 95.0])
def test_quadrature_first_order_equals_thin_spherical_single_scattering(sza):
    """Optically thin Rayleigh shell (tau 1e-7, 0-100 km, no depolarisation), sun above and 2 and 5 deg below the
    horizon: max_order=1 with the quadrature is deterministic (se 0) and equals beta P11 / (4 pi) times the sunlit
    length of the view ray (the Earth's shadow cut out), P12 likewise for the polarised part, to 1e-4."""
    tau, top = 1e-7, 100.0
    slab = rayleigh_slab(tau, thickness_km=top, n_layers=5)
    vz = np.array([0.0, 45.0, 80.0, 89.0, 60.0])
    va = np.array([0.0, 0.0, 180.0, 0.0, 90.0])
    r = trace(slab, sza, vz, va, MonteCarloConfig(samples=8, max_order=1, seed=1))
    beta = tau / top
    th, ph, z = np.radians(vz), np.radians(va), np.radians(sza)
    cs = np.sin(th) * np.cos(ph) * np.sin(z) + np.cos(th) * np.cos(z)
    p11, p12 = 0.75 * (1 + cs ** 2), 0.75 * (cs ** 2 - 1)
    length = np.array([_sunlit_length(a, b, sza, top) for a, b in zip(vz, va)])
    ref_i = beta * p11 / (4 * np.pi) * length
    assert np.all(r.stderr[:, 0, 0] <= 1e-6 * r.stokes[:, 0, 0])  # rounding of the sum of squares only
    assert np.all(length > 0)
    np.testing.assert_allclose(r.stokes[:, 0, 0], ref_i, rtol=1e-4)
    # degree of linear polarisation of single Rayleigh scattering, shadow or not
    dolp = np.hypot(r.stokes[:, 0, 1], r.stokes[:, 0, 2]) / r.stokes[:, 0, 0]
    np.testing.assert_allclose(dolp, -p12 / p11, atol=1e-6)


def _layered(tau_abs):
    """8 layers 0-80 km: Rayleigh (tau 0.25, scale height 8 km), isotropic aerosol (tau 0.15, scale height 2 km,
    single-scattering albedo 0.9), one component per gas absorption optical depth (uniform in the lowest 10 km),
    albedo 0.3."""
    lv = np.linspace(0.0, 80.0, 9)
    zm = 0.5 * (lv[1:] + lv[:-1])
    dz = np.diff(lv)
    ray = np.exp(-zm / 8.0)
    ray *= 0.25 / np.sum(ray * dz)
    aer = np.exp(-zm / 2.0)
    aer *= 0.15 / np.sum(aer * dz)
    k = len(tau_abs)
    gas = np.where(zm < 10.0, 1.0, 0.0) / 10.0
    ext = (ray + aer)[:, None] + gas[:, None] * np.asarray(tau_abs, float)[None, :]
    base = rayleigh_slab(0.1)
    return Components(levels_km=lv, extinction=ext, rayleigh=np.repeat(ray[:, None], k, 1),
                      aerosol=np.repeat(0.9 * aer[:, None], k, 1), depolarisation=np.full(k, 0.03),
                      aerosol_table=np.zeros(k, np.int32), aerosol_matrices=base.aerosol_matrices,
                      albedo=np.full(k, 0.3), channel=np.arange(k, dtype=np.int32), weight=np.ones(k))


@pytest.mark.parametrize("streams", STREAM_MODES)
@pytest.mark.parametrize("sza", [54.0, 92.0])
def test_quadrature_estimator_agrees_with_sampled_estimator(sza, streams):
    """All orders, polarised, in spherical shells, two hero components (a transparent one and a saturated gas term,
    tau_abs 0 and 4): the new estimator (first order by quadrature, sunlit-importance first vertex and free paths
    through the shadow) and the original one give the same I, Q, U within 4 sigma of their difference, at 36 deg
    and with the sun 2 deg below the horizon."""
    cp = _layered([0.0, 4.0])
    vz = np.array([0.0, 40.0, 70.0, 85.0, 89.0, 60.0])
    va = np.array([0.0, 180.0, 0.0, 90.0, 180.0, 30.0])
    n = 12000 if sza < 90 else 24000
    new = trace(cp, sza, vz, va, MonteCarloConfig(samples=n, seed=41, streams=streams))
    old = trace(cp, sza, vz, va, MonteCarloConfig(samples=n, seed=42, first_order="sampled", streams=streams))
    sig = np.hypot(new.stderr, old.stderr)[..., :3]
    diff = (new.stokes - old.stokes)[..., :3]
    assert np.all(new.stokes[..., 0] > 10 * new.stderr[..., 0])
    assert np.all(np.abs(diff) <= 4 * sig + 1e-15), diff / sig


def test_first_order_method_is_validated():
    with pytest.raises(ValueError, match="first_order"):
        MonteCarloConfig(first_order="exact")
    with pytest.raises(ValueError, match="quadrature_step_km"):
        MonteCarloConfig(quadrature_step_km=0.0)


def test_dataset_states_choose_the_estimator_by_what_they_provide():
    """A build's Monte Carlo states whose radiance is used (below mc_below_elevation_deg) trace with the quadrature,
    polarisation-only states with the sampled first order, and the choice is part of the cache key."""
    from dataclasses import replace

    from widesky.skymodel.generator.dataset_build import load_config
    from widesky.skymodel.generator.dataset_mc import mc_config, mc_key

    cfg = load_config(Path(__file__).resolve().parents[2] / "skymodel" / "data" / "polarised-dataset.json")
    assert mc_config(cfg, 51.3, -2.0).first_order == "quadrature"
    assert mc_config(cfg, 51.3, 4.5).first_order == "quadrature"
    assert mc_config(cfg, 51.3, 36.0).first_order == "sampled"
    assert mc_key(replace(cfg, mc_below_elevation_deg=3.0)) != mc_key(cfg)
