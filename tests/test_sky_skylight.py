"""Cross-check against an independent implementation of the same model: the PyPI package ``skylight``
(E. Gkanias, a separate Python port of the Prague Sky Model; test dependency only).

Tolerance 1e-6 relative, as the issue asks. skylight keeps the decoded zenith coefficients in double
precision, whereas the reference implementation (and widesky) keeps them as float32 after the division
by the zenith scale; that alone makes the two differ by up to about 1e-7 relative. A second check rounds
skylight's coefficients to float32 the way the reference stores them and then agrees to 1e-12.
"""

import warnings

import numpy as np
import pytest

from widesky import skymodel
from widesky.skymodel.synthetic import write_synthetic_dataset

skylight_prague = pytest.importorskip("skylight.prague")
Manager = skylight_prague.PragueSkyModelManager

CASES = {
    # name: synthetic dataset parameters (every interpolation level, ranks 1/3/6, polarisation on/off)
    "rank3_pol_alt": dict(visibilities=(20, 40, 90, 131.8), albedos=(0, 0.5, 1), altitudes=(0, 2000, 8000),
                          n_channels=5, rank=3, n_sun=13, n_zen=17, n_emph=9, polarisation=True, seed=21),
    "rank1_ground": dict(visibilities=(25, 70), albedos=(0.1, 0.9), altitudes=(0,), n_channels=3, rank=1,
                         n_sun=5, n_zen=4, n_emph=3, polarisation=False, seed=22),
    "rank6_swir": dict(visibilities=(20, 131.8), albedos=(0.3,), altitudes=(0,), n_channels=55, rank=6,
                       n_sun=30, n_zen=30, n_emph=20, polarisation=True, pol_rank=3, seed=23),
}

STATES = [(35.0, 200.0, 33.0, 0.37, 0.0), (2.5, 80.0, 95.0, 0.8, 1200.0), (-2.7, 300.0, 131.8, 0.0, 50.0),
          (80.0, 10.0, 20.0, 1.0, 7000.0)]


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request, tmp_path_factory):
    path = write_synthetic_dataset(tmp_path_factory.mktemp("sl") / f"{request.param}.dat", **CASES[request.param])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # skylight warns when a file has no polarisation section
        ref = Manager()
        ref.initialise(str(path))
    return request.param, skymodel.load_dataset(path), ref


def _dirs(seed, n=60):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v[: 2 * n // 3, 2] = np.abs(v[: 2 * n // 3, 2])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _params(dirs, el, az, vis, alb, alt):
    return Manager.compute_parameters(np.array([0.0, 0.0, alt]), dirs, np.radians(el), np.radians(90.0 - az),
                                      vis, alb)


def _quiet(fn, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
        return fn(*a, **k)


@pytest.mark.parametrize("state", STATES)
def test_sky_radiance_agrees_with_skylight(case, state):
    name, m, ref = case
    dirs = _dirs(1)
    el, az, vis, alb, alt = state
    theirs = ref.sky_radiance(_params(dirs, *state), m.wavelengths).T
    for method in ("direct", "table"):
        ours = _quiet(skymodel.sky_radiance, m, dirs, el, az, vis, alb, alt, method=method)
        np.testing.assert_allclose(ours, theirs, rtol=1e-6, atol=1e-9 * np.abs(theirs).max())


def test_float32_storage_explains_the_difference(case):
    """With skylight's coefficients rounded to float32 as the reference stores them: agreement to 1e-12."""
    name, m, ref = case
    data = ref._PragueSkyModelManager__data_rad
    ref._PragueSkyModelManager__data_rad = data.astype(np.float32).astype(np.float64)
    try:
        dirs = _dirs(2)
        for state in STATES:
            theirs = ref.sky_radiance(_params(dirs, *state), m.wavelengths).T
            ours = _quiet(skymodel.sky_radiance, m, dirs, *state)
            np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-13 * np.abs(theirs).max())
    finally:
        ref._PragueSkyModelManager__data_rad = data


@pytest.mark.parametrize("state", STATES)
def test_polarisation_and_transmittance_agree_with_skylight(case, state):
    name, m, ref = case
    dirs = _dirs(3, 40)
    el, az, vis, alb, alt = state
    p = _params(dirs, *state)
    if m.has_polarisation:
        theirs = ref.polarisation(p, m.wavelengths).T
        ours = _quiet(skymodel.polarisation, m, dirs, el, az, vis, alb, alt)
        np.testing.assert_allclose(ours, theirs, rtol=1e-6, atol=1e-12)
    else:
        with pytest.raises(ValueError, match="no polarisation"):
            skymodel.polarisation(m, dirs, el, az, vis, alb, alt)
    for dist in (np.finfo(float).max, 2500.0):
        theirs = np.stack([ref.transmittance(p, np.array([w]), dist)[0] for w in m.wavelengths], axis=-1)
        ours = _quiet(skymodel.transmittance, m, dirs, el, az, vis, alb, alt, distance=dist)
        np.testing.assert_allclose(ours, theirs, rtol=1e-6, atol=1e-12)


def test_sun_radiance_differs_only_by_the_extraterrestrial_table(case):
    """Inside the solar disc both give extraterrestrial radiance x transmittance; the tables differ (the
    reference's built-in table vs widesky's ASTM E-490), so the ratio must equal the tables' ratio."""
    name, m, ref = case
    el, az, vis, alb, alt = 40.0, 135.0, 50.0, 0.5, 0.0
    s = skymodel.sun_direction(el, az)[None]
    wl = np.clip(m.wavelengths, 300, 2400)
    ours = _quiet(skymodel.sun_radiance, m, s, el, az, vis, alb, alt, wavelengths=wl)[0]
    theirs = ref.sun_radiance(_params(s, el, az, vis, alb, alt), wl)[:, 0]
    e_wl, e = skymodel.extraterrestrial_spectrum()
    ours_et = np.interp(wl, e_wl, e) / skymodel.SUN_SOLID_ANGLE
    their_et = np.interp(wl, skylight_prague.prague.SUN_RAD_START + np.arange(len(skylight_prague.prague.SUN_RAD_TABLE)),
                         skylight_prague.prague.SUN_RAD_TABLE)
    np.testing.assert_allclose(ours / theirs, ours_et / their_et, rtol=1e-6)
