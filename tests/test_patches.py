"""Sky discretisation: exact geometry of the Tregenza / Reinhart patches (irradiance.patches)."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from widesky.irradiance.patches import angles_from_direction, cosine_weights, direction_from_angles, reinhart


@pytest.mark.parametrize("mf, count", [(1, 145), (2, 577), (3, 1297), (4, 2305)])
def test_counts_and_solid_angles(mf, count):
    p = reinhart(mf)
    assert p.n_patches == count == 144 * mf * mf + 1
    # exact: the hemisphere is 2 pi sr and its horizontal cosine weight pi (float rounding only)
    assert p.solid_angle.sum() == pytest.approx(2 * np.pi, rel=1e-12)
    assert p.vector[:, 2].sum() == pytest.approx(np.pi, rel=1e-12)
    assert np.all(p.solid_angle > 0)
    np.testing.assert_allclose(np.linalg.norm(p.directions, axis=1), 1.0, rtol=1e-12)


def test_tregenza_rings():
    p = reinhart(1)
    np.testing.assert_array_equal(p.ring_counts, [30, 30, 24, 24, 18, 12, 6, 1])
    np.testing.assert_allclose(p.ring_edges, [0, 12, 24, 36, 48, 60, 72, 84, 90])


@pytest.mark.parametrize("mf", [1, 2])
def test_index_and_subsample(mf):
    p = reinhart(mf)
    d, w = p.subsample(3)
    np.testing.assert_array_equal(p.index(d.reshape(-1, 3)), np.repeat(np.arange(p.n_patches), 9))
    np.testing.assert_allclose(w.sum(axis=1), p.solid_angle, rtol=1e-12)
    assert p.index(np.array([0.0, 1.0, -0.1])) == -1


def test_angles_roundtrip():
    alt, az = np.array([5.0, 45.0, 89.0]), np.array([0.0, 135.0, 359.0])
    a2, z2 = angles_from_direction(direction_from_angles(alt, az))
    np.testing.assert_allclose(a2, alt, atol=1e-12)
    np.testing.assert_allclose(z2, az, atol=1e-9)
    # azimuth clockwise from north: east is +x
    np.testing.assert_allclose(direction_from_angles(0.0, 90.0), [1.0, 0.0, 0.0], atol=1e-15)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 180.0), st.floats(0.0, 360.0), st.sampled_from([1, 2, 4]))
def test_cosine_weights_analytic(tilt, azimuth, mf):
    """Upper weights = pi (1 + cos tilt) / 2 and upper + lower = pi (tolerance 2e-4 sr: the Gauss-
    Legendre rule on patches cut by the face's horizon)."""
    p = reinhart(mf)
    n = direction_from_angles(90.0 - tilt, azimuth)[None, :]
    up = cosine_weights(p, n)
    lo = cosine_weights(p, n, lower=True)
    assert np.all(up >= 0) and np.all(lo >= 0)
    assert up.sum() == pytest.approx(np.pi * (1 + np.cos(np.radians(tilt))) / 2, abs=2e-4)
    assert up.sum() + lo.sum() == pytest.approx(np.pi, abs=2e-4)


def test_cosine_weights_match_fine_quadrature():
    """Per patch against a 64 x 64 midpoint rule (tolerance 5e-4 of the largest patch: both rules
    err near the kink where the face's horizon crosses the patch)."""
    p = reinhart(1)
    rng = np.random.default_rng(3)
    n = rng.normal(size=(12, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    d, w = p.subsample(64)
    ref = np.sum(np.maximum(np.einsum("fk,pqk->fpq", n, d), 0.0) * w[None], axis=2)
    np.testing.assert_allclose(cosine_weights(p, n), ref, atol=5e-4 * p.solid_angle.max())


def test_bad_mf():
    with pytest.raises(ValueError, match="mf=0"):
        reinhart(0)
