"""Per-configuration radiance tables (issue 36): a time series of sky states evaluated as the weighted sum of each
state's corner configurations' tables (:class:`widesky.skymodel.evaluate.RadianceTables`, what the integrator's
:class:`~widesky.irradiance.PragueSky` uses) gives the values of :func:`widesky.skymodel.sky_radiance` (the
reference's algorithm, tests/test_sky_exact.py) to the float32 rounding of the kept tables.

Tolerance: 1e-6 relative to each value (the tables are float32: 6e-8 per coefficient, a few coefficients summed
over at most 16 configurations; 4e-7 measured), exact zeros where the reference clamps to zero; the
solar spectrum bit for bit.
"""

import warnings

import numpy as np
import pytest

from widesky import skymodel
from widesky.irradiance.skies import PragueSky, SkyStates
from widesky.skymodel.evaluate import RadianceTables, _config_weights, _state_params


@pytest.fixture(scope="module")
def model():
    return skymodel.load_dataset()


def _states(model, T=120, seed=1):
    rng = np.random.default_rng(seed)
    el = rng.uniform(0.0, 90.0, T)
    az = rng.uniform(0.0, 360.0, T)
    vis = rng.uniform(*model.visibility_range, T)
    alb = rng.uniform(*model.albedo_range, T)
    # on knots, at the grid's ends and a hair off a knot (the reference's 1e-6 rule)
    el[:12] = rng.choice(model.elevations, 12)
    vis[8:20] = rng.choice(model.visibilities, 12)
    alb[::4] = rng.choice(model.albedos, alb[::4].size)
    el[20:24] = [0.0, 90.0, 1e-8, 45.0 + 1e-8]
    vis[24:26] = model.visibility_range
    return el, az, vis, alb, np.zeros(T)


def _directions(T, N, seed=2):
    d = np.random.default_rng(seed).normal(size=(T, N, 3))
    d[..., 2] = np.abs(d[..., 2])
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def test_corner_weights_are_the_references(model):
    el, az, vis, alb, alt = _states(model)
    cfg, w, ok = RadianceTables(model).state_corners(el, vis, alb, alt)
    assert ok.all()
    for t in range(el.size):
        c, wt = _config_weights(model, vis[t], alb[t], *_state_params(el[t], 0.0, 0.0)[2:])
        mine = {int(a): b for a, b in zip(cfg[t], w[t]) if b > 0}
        assert mine == {int(a): b for a, b in zip(c, wt) if b > 0}


def test_tables_match_sky_radiance(model):
    el, az, vis, alb, alt = _states(model)
    d = _directions(el.size, 150)
    rt = RadianceTables(model, max_bytes=0)          # the smallest cache: evaluation in parts, tables rebuilt
    order = rt.order_key(el, vis, alb, alt)
    got = np.empty((el.size, 150, model.n_channels))
    got[order] = rt.radiance(d[order], el[order], az[order], vis[order], alb[order], alt[order])
    ref = np.stack([skymodel.sky_radiance(model, d[t], el[t], az[t], vis[t], alb[t], 0.0) for t in range(el.size)])
    assert ((got == 0) == (ref == 0)).all()
    np.testing.assert_allclose(got, ref, rtol=1e-6, atol=1e-12 * ref.max())
    assert rt.built > rt.max_tables                  # the cache was exercised


def test_grouped_sums_and_fallback(model):
    """Weighted sums by row (patch means) equal the sums of the values; a sun below the horizon goes through
    sky_radiance (the twilight path)."""
    el, az, vis, alb, alt = _states(model, T=30)
    el[3] = -1.5
    d = _directions(1, 90)[0]
    rng = np.random.default_rng(5)
    rows, wts = rng.integers(0, 12, 90), rng.uniform(0.0, 1.0, 90)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                  # below the dataset's elevations: clamped, as the reference
        got = RadianceTables(model).radiance(d, el, az, vis, alb, alt, rows=rows, weights=wts)
        ref = np.zeros_like(got)
        for t in range(el.size):
            np.add.at(ref[t], rows, wts[:, None] * skymodel.sky_radiance(model, d, el[t], az[t], vis[t], alb[t]))
    np.testing.assert_allclose(got, ref, rtol=1e-6, atol=1e-12 * ref.max())


def test_direct_normal_bit_for_bit(model):
    rng = np.random.default_rng(3)
    T = 60
    el, az = rng.uniform(-5.0, 90.0, T), rng.uniform(0.0, 360.0, T)
    vis, alt = rng.uniform(20.0, 131.8, T), np.zeros(T)
    vis[:10] = model.trans_visibilities[:10]
    alt[10:13] = (10.0, 500.0, 3000.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                  # states outside the transmittance grids: clamped, both
        got = RadianceTables(model).direct_normal(el, az, vis, alt)
        ref = np.stack([skymodel.solar_direct_normal(model, el[t], az[t], vis[t], 0.2, alt[t]) for t in range(T)])
    assert np.array_equal(got, ref)


def test_prague_sky_patch_means(model):
    """PragueSky.radiance_means (the integrator's patch means) equals the mean of PragueSky.radiance's samples."""
    sky = PragueSky(model)
    el, az, vis, alb, alt = _states(model, T=30)
    st = SkyStates.create(el, az, vis, alb)
    d = _directions(1, 40)[0]
    rows = np.repeat(np.arange(10), 4)
    w = np.full(40, 0.25)
    means = sky.radiance_means(d, rows, w, st)
    samples = sky.radiance(np.broadcast_to(d, (len(st), 40, 3)), st)
    np.testing.assert_allclose(means, samples.reshape(len(st), 10, 4, -1).mean(axis=2), rtol=1e-12)
