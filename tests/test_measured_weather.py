"""Measured DNI/DHI on the clear-sky model: scale factors, guards and the clearness index."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from widesky.irradiance.measured import clearness_index, measured_scale_factors


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
