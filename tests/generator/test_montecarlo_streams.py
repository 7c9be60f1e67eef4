"""Correlated random streams (common random numbers across view directions, ``streams="correlated"``).

What is checked: the correlated estimator is unbiased (it agrees with the independent one within 4 sigma of their
difference, sigma = the two standard errors combined; the earlier validations run in both modes in
test_montecarlo.py, test_montecarlo_validation.py and test_montecarlo_estimators.py); its error per direction is
the independent one's (the paths of one direction are still independent of each other); its error *field* is smooth
across directions: along a twilight almucantar the rms second difference of the error (two seeds, so the sky's own
curvature cancels) falls by a factor of at least 3 (measured 5.3 and 5.6 in the two channels at 1000 paths;
independent errors give sqrt(6) x the per-direction error); and the sampling frame is continuous, so that the zenith
seen at different azimuths is the same estimate.
"""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from widesky.skymodel.generator.montecarlo import MonteCarloConfig, sampling_frames, trace


def _layered(tau_abs):
    """The 8-shell atmosphere of test_montecarlo_estimators.py (Rayleigh, absorbing aerosol, one component per gas
    absorption optical depth, albedo 0.3)."""
    spec = importlib.util.spec_from_file_location("mc_estimators", Path(__file__).with_name(
        "test_montecarlo_estimators.py"))
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    return m._layered(tau_abs)


@pytest.mark.parametrize("sza", [54.0, 92.0])
def test_correlated_streams_agree_with_independent_streams(sza):
    """All orders, polarised, spherical shells, a transparent and a saturated hero component: I, Q, U of the two
    stream modes within 4 sigma of their difference, at 36 deg and with the sun 2 deg below the horizon, and the
    per-direction standard errors within 25 % of each other."""
    cp = _layered([0.0, 4.0])
    vz = np.array([0.0, 40.0, 70.0, 85.0, 89.0, 60.0])
    va = np.array([0.0, 180.0, 0.0, 90.0, 180.0, 30.0])
    n = 12000 if sza < 90 else 24000
    ind = trace(cp, sza, vz, va, MonteCarloConfig(samples=n, seed=51))
    cor = trace(cp, sza, vz, va, MonteCarloConfig(samples=n, seed=52, streams="correlated"))
    assert cor.meta["streams"] == "correlated"
    sig = np.hypot(ind.stderr, cor.stderr)[..., :3]
    diff = (cor.stokes - ind.stokes)[..., :3]
    assert np.all(cor.stokes[..., 0] > 10 * cor.stderr[..., 0])
    assert np.all(np.abs(diff) <= 4 * sig + 1e-15), diff / sig
    ratio = cor.stderr[..., 0] / ind.stderr[..., 0]
    assert 0.8 < np.sqrt(np.mean(ratio ** 2)) < 1.25, ratio


def _error_field(mode, n=1000):
    """Relative error of I of one run along the almucantar at view zenith 60 deg, relative azimuth 0-180 deg every
    3 deg, sun 2 deg below the horizon, (61, 2), from two seeds; and the rms relative standard error (2,)."""
    cp = _layered([0.0, 1.0])
    az = np.arange(0.0, 181.0, 3.0)
    vz = np.full(az.shape, 60.0)
    a, b = (trace(cp, 92.0, vz, az, MonteCarloConfig(samples=n, seed=s, streams=mode)) for s in (1, 2))
    m = 0.5 * (a.stokes[..., 0] + b.stokes[..., 0])
    se = np.sqrt(np.mean((a.stderr[..., 0] / a.stokes[..., 0]) ** 2, axis=0))
    return (a.stokes[..., 0] - b.stokes[..., 0]) / m / np.sqrt(2), se


def test_correlated_error_field_is_smooth_along_a_twilight_almucantar():
    """Same paths per direction: the per-direction error is unchanged (rms standard error within 20 %), the rms
    second difference of the error field along the almucantar 3x lower or more (measured 5.3-5.6x)."""
    e_ind, se_ind = _error_field("independent")
    e_cor, se_cor = _error_field("correlated")
    assert np.all(np.abs(se_cor / se_ind - 1) < 0.2), (se_cor, se_ind)
    d2 = lambda e: np.sqrt(np.mean(np.diff(e, 2, axis=0) ** 2, axis=0))  # noqa: E731
    gain = d2(e_ind) / d2(e_cor)
    assert np.all(gain > 3.0), gain
    # independent errors: the second difference of white noise is sqrt(6) x its rms (within the sampling error)
    ratio = d2(e_ind) / np.sqrt(np.mean(e_ind ** 2, axis=0))
    assert np.all((ratio > 1.9) & (ratio < 3.0)), ratio


def test_sampling_frames_are_continuous_and_the_zenith_is_one_estimate():
    """The azimuth reference of the correlated streams is a unit vector perpendicular to the view, continuous over
    the hemisphere (neighbours 0.5 deg apart differ by less than 0.02, the pole and the horizon included), for
    upward and downward views; at the zenith every azimuth gives the same I and degree of polarisation (1e-9)."""
    from widesky.skymodel.generator.montecarlo import _unit_views

    th, ph = np.meshgrid(np.arange(0.0, 90.01, 0.5), np.arange(-180.0, 180.01, 0.5), indexing="ij")
    for down in (False, True):
        v, _ = _unit_views(th.ravel(), ph.ravel(), down)
        u = sampling_frames(v, down)
        np.testing.assert_allclose(np.linalg.norm(u, axis=1), 1.0, atol=1e-12)
        assert np.max(np.abs(np.einsum("ij,ij->i", u, v))) < 1e-12
        u = u.reshape(th.shape + (3,))
        assert np.max(np.linalg.norm(np.diff(u, axis=0), axis=-1)) < 0.02
        assert np.max(np.linalg.norm(np.diff(u, axis=1), axis=-1)) < 0.02
    cp = _layered([0.0, 1.0])
    az = np.array([0.0, 30.0, 90.0, 150.0, -120.0])
    r = trace(cp, 92.0, np.zeros(5), az, MonteCarloConfig(samples=400, seed=3, streams="correlated"))
    i, dolp = r.stokes[..., 0], r.degree_of_polarisation()
    np.testing.assert_allclose(i, np.broadcast_to(i[:1], i.shape), rtol=1e-9)
    np.testing.assert_allclose(dolp, np.broadcast_to(dolp[:1], dolp.shape), rtol=1e-9)
    ind = trace(cp, 92.0, np.zeros(5), az, MonteCarloConfig(samples=400, seed=3))
    assert np.ptp(ind.stokes[:, 0, 0]) > 0  # independent streams: five different estimates of the zenith


def test_stream_mode_is_validated():
    with pytest.raises(ValueError, match="streams='common'"):
        MonteCarloConfig(streams="common")
