"""Measured DNI/DHI on the clear-sky model: scale factors, guards and the isotropic blend."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from irradiance.measured import (blend_toward_isotropic, clearness_index, isotropic_blend_weight,
                                 measured_scale_factors)


def test_scaling_reproduces_measured_irradiance():
    model_dni = np.array([850.0, 700.0, 300.0])
    model_dhi = np.array([90.0, 110.0, 60.0])
    dni = np.array([800.0, 120.0, 0.0])
    dhi = np.array([95.0, 300.0, 110.0])
    r = measured_scale_factors(model_dni, model_dhi, dni, dhi)
    np.testing.assert_allclose(r.sun_scale * model_dni, dni)
    np.testing.assert_allclose(r.sky_scale * model_dhi, dhi)
    assert not r.sun_guarded.any() and not r.sky_guarded.any()
    np.testing.assert_array_equal(r.unmatched_dni, 0.0)


def test_low_sun_guards_do_not_blow_up_and_report_the_loss():
    model_dni = np.array([0.0, 1e-6, 2.0, 50.0])
    model_dhi = np.array([0.0, 1e-6, 1.0, 30.0])
    dni = np.array([0.0, 3.0, 20.0, 400.0])
    dhi = np.array([0.0, 1.0, 12.0, 40.0])
    r = measured_scale_factors(model_dni, model_dhi, dni, dhi, min_model_dni=5.0, min_model_dhi=2.0,
                               max_scale=4.0)
    assert np.all(np.isfinite(r.sun_scale)) and r.sun_scale.max() <= 4.0
    np.testing.assert_array_equal(r.sun_guarded, [False, True, True, True])
    assert r.sun_scale[0] == 0.0  # nothing measured, nothing to match: exact
    assert r.sun_scale[1] == pytest.approx(3.0 / 5.0)  # floored denominator
    assert r.sun_scale[3] == 4.0 and r.unmatched_dni[3] == pytest.approx(400.0 - 200.0)
    np.testing.assert_allclose(r.unmatched_dni, dni - r.sun_scale * model_dni)
    np.testing.assert_array_equal(r.sky_guarded, [False, True, True, False])


def test_missing_values_policy():
    r = measured_scale_factors([800.0, 800.0], [100.0, 100.0], [np.nan, 700.0], [80.0, np.nan])
    assert np.isnan(r.sun_scale[0]) and np.isnan(r.sky_scale[1]) and np.isnan(r.unmatched_dni[0])
    c = measured_scale_factors([800.0, 800.0], [100.0, 100.0], [np.nan, 700.0], [80.0, np.nan],
                               missing="clear")
    assert c.sun_scale[0] == 1.0 and c.sun_guarded[0] and c.sky_scale[1] == 1.0


@pytest.mark.parametrize("kwargs, match", [
    (dict(dni=-1.0), r"dni=-1 W m-2 is negative"),
    (dict(model_dhi=-2.0), r"model_dhi=-2 W m-2"),
    (dict(min_model_dni=0.0), r"min_model_dni=0.0 W m-2 must be > 0"),
    (dict(max_scale=0.5), r"max_scale=0.5 must be >= 1"),
    (dict(missing="zero"), r"missing='zero'"),
])
def test_errors(kwargs, match):
    args = dict(model_dni=800.0, model_dhi=100.0, dni=700.0, dhi=90.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        measured_scale_factors(**args)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 1100), st.floats(0, 400), st.floats(0, 1100),
                          st.floats(0, 700)), min_size=1, max_size=30))
def test_scaled_model_never_exceeds_measured(rows):
    mdni, mdhi, dni, dhi = (np.array(x) for x in zip(*rows))
    r = measured_scale_factors(mdni, mdhi, dni, dhi)
    for un, meas, g in ((r.unmatched_dni, dni, r.sun_guarded), (r.unmatched_dhi, dhi, r.sky_guarded)):
        assert np.all(un >= -1e-9 * (1 + meas)) and np.all(un <= meas + 1e-9)
        assert np.all(np.abs(un[~g]) <= 1e-9 * (1 + meas[~g]))
    assert np.all((r.sun_scale >= 0) & (r.sun_scale <= 4.0))


def test_clearness_index():
    # kt = 800 / (1361 cos 30 deg) = 0.67875
    assert float(clearness_index(800.0, 30.0, 1361.0)) == pytest.approx(800 / (1361 * np.cos(np.pi / 6)))
    # guards: cos(zenith) floored at 0.065 and kt capped at 2 near the horizon
    assert float(clearness_index(50.0, 89.9, 1361.0)) == pytest.approx(50 / (1361 * 0.065))
    assert float(clearness_index(500.0, 89.9, 1361.0)) == 2.0
    assert np.isnan(clearness_index(np.nan, 30.0, 1361.0))


def test_blend_weight():
    w = isotropic_blend_weight([0.8, 0.65, 0.45, 0.25, 0.1, np.nan])
    np.testing.assert_allclose(w[:5], [0.0, 0.0, 0.5, 1.0, 1.0])
    assert np.isnan(w[5])
    with pytest.raises(ValueError, match="kt_overcast"):
        isotropic_blend_weight(0.5, kt_clear=0.2, kt_overcast=0.4)


def _hemisphere(n_theta=18, n_phi=36):
    """Exact-solid-angle lat-long patches of the upper hemisphere."""
    t = np.linspace(0, np.pi / 2, n_theta + 1)
    om_ring = 2 * np.pi * (np.cos(t[:-1]) - np.cos(t[1:])) / n_phi
    theta = 0.5 * (t[:-1] + t[1:])
    # cos of the ring centre, corrected so sum(cos * omega) over the ring is exact
    cz_ring = np.pi * (np.sin(t[1:]) ** 2 - np.sin(t[:-1]) ** 2) / (2 * np.pi * (np.cos(t[:-1]) - np.cos(t[1:])))
    om = np.repeat(om_ring, n_phi)
    cz = np.repeat(cz_ring, n_phi)
    phi = np.tile((np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi, n_theta)
    return om, cz, np.repeat(theta, n_phi), phi


def test_blend_furnace_and_dhi_preserved():
    om, cz, theta, phi = _hemisphere()
    assert om.sum() == pytest.approx(2 * np.pi) and (om * cz).sum() == pytest.approx(np.pi)
    # furnace: a uniform sky is unchanged by any blend
    uniform = np.full((3, om.size, 2), 7.0)
    np.testing.assert_allclose(blend_toward_isotropic(uniform, np.array([0, 0.5, 1]), om, cz), 7.0)
    # a circumsolar-peaked, horizon-brightened spectral sky: DHI per channel is preserved exactly
    sun = np.array([np.sin(np.radians(30)), 0, np.cos(np.radians(60))])
    d = np.stack([np.sin(theta) * np.sin(phi), np.sin(theta) * np.cos(phi), np.cos(theta)], -1)
    cosg = d @ (sun / np.linalg.norm(sun))
    shape = (1 + 10 * np.exp(-3 * np.arccos(np.clip(cosg, -1, 1)))) * (1 + 0.5 * (1 - cz))
    L = np.stack([shape[:, None] * np.array(s) for s in ([1.0, 0.5], [2.0, 0.7])])  # (2 steps, n, 2 ch)
    w = np.array([0.3, 1.0])
    B = blend_toward_isotropic(L, w, om, cz)
    dhi = np.einsum("p,spc->sc", om * cz, L)
    np.testing.assert_allclose(np.einsum("p,spc->sc", om * cz, B), dhi, rtol=1e-12)
    np.testing.assert_allclose(B[1], np.broadcast_to(dhi[1] / np.pi, B[1].shape), rtol=1e-12)
    # partial blend flattens the peak
    assert B[0].max() < L[0].max() and B[0].min() > L[0].min()
    with pytest.raises(ValueError, match="weight outside"):
        blend_toward_isotropic(L, np.array([0.3, 1.5]), om, cz)
    with pytest.raises(ValueError, match="weight has shape"):
        blend_toward_isotropic(L, np.array([0.3]), om, cz)
