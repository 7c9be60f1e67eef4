"""The dataset generator (skymodel.generator.dataset_build): albedo decomposition, transmittance paths, and an end-to-end build
on a tiny grid with tiny solver settings (4 streams), checked against the solver it was fitted to.

References and tolerances:
- albedo decomposition: exact for a plane-parallel atmosphere over a Lambertian ground (module docstring); compared
  with direct DISORT runs at the same albedo, rtol 2e-3 (the ground response is interpolated in zenith on a 0.5 deg
  table; measured 6e-5 at 16 streams);
- segment path factors: a straight path from the ground to the top of the atmosphere equals the solver's slant path
  (skymodel.generator.atmosphere.slant_path_factors) to 1e-9 relative;
- the written file reproduces the fitted factors at the fit samples to half-float precision (rtol 3e-3 of the
  channel's largest value), and skylight (independent reader) gives the same values (rtol 1e-6);
- the dataset's direct normal irradiance matches the solver's spherical-path direct beam within 2 % in channels
  400-1300 nm (rank-24 fit on the default 128 x 32 grid; measured worst 1.5 %, 420 nm at 20 km and 10 deg: the
  distance interpolation of the format near the horizon).
"""

import json
import warnings

import numpy as np
import pytest

from widesky import skymodel
pytestmark = pytest.mark.reference          # the generator's inputs (AFGL, OPAC, ozone, TSIS-1): reference data

TINY = {"visibilities_km": [20.0, 131.8], "albedos": [0.0, 1.0], "elevations_deg": [10.0, 60.0],
        "knots": [16, 12, 8], "rank": 3, "n_streams": 4, "n_moments": 8, "zenith_step_deg": 15.0,
        "trans_dims": [128, 32], "trans_rank": 24, "validation_off_grid": 1, "validation_on_grid": 1, "seed": 3,
        "iterations": 3, "refine": 1, "description": "tiny test dataset"}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    import os

    from widesky.skymodel.generator.dataset_build import build_dataset, load_config

    d = tmp_path_factory.mktemp("dsb")
    (d / "tiny.json").write_text(json.dumps(TINY))
    old = os.environ.get("WIDESKY_CACHE_DIR")
    os.environ["WIDESKY_CACHE_DIR"] = str(d / "cache")
    try:
        cfg = load_config(d / "tiny.json")
        meta = build_dataset(cfg, d / "tiny.dat", processes=1, progress=False)
        yield cfg, d / "tiny.dat", meta
    finally:
        if old is None:
            os.environ.pop("WIDESKY_CACHE_DIR", None)
        else:
            os.environ["WIDESKY_CACHE_DIR"] = old


@pytest.mark.slow
def test_albedo_decomposition_matches_direct_runs(tmp_path, monkeypatch):
    from widesky.skymodel.generator.dataset_build import BuildConfig, radiance_with_albedo, solve_ground, solve_state

    monkeypatch.setenv("WIDESKY_CACHE_DIR", str(tmp_path))
    cfg = BuildConfig(n_streams=4, n_moments=8)
    th, ph = np.array([0.0, 30.0, 62.0, 85.0, 89.95]), np.array([0.0, 90.0, 180.0])
    g = solve_ground(30.0, cfg)
    s0 = solve_state(30.0, 40.0, cfg, th, ph, albedo=0.0)
    s7 = solve_state(30.0, 40.0, cfg, th, ph, albedo=0.7)
    ours = radiance_with_albedo(s0, g, 0.7)
    ref = s7["radiance"]
    assert np.all(ref >= s0["radiance"])
    np.testing.assert_allclose(ours, ref, rtol=2e-3, atol=1e-9 * ref.max())


def test_segment_to_the_top_equals_the_slant_path():
    from widesky.skymodel.generator.atmosphere import DEFAULT_LEVELS_KM, slant_path_factors
    from widesky.skymodel.generator.dataset_build import PLANET_RADIUS_M, segment_path_factors

    R = PLANET_RADIUS_M
    top = R + 1000.0 * DEFAULT_LEVELS_KM[-1]
    for zen in (0.0, 30.0, 75.0, 89.0, 90.0):
        z = np.radians(zen)
        t = -R * np.cos(z) + np.sqrt((R * np.cos(z)) ** 2 + top ** 2 - R ** 2)  # ray from the ground to the top
        px, py = t * np.sin(z), R + t * np.cos(z)
        dist = np.arctan2(px, py) * R
        ours = segment_path_factors(DEFAULT_LEVELS_KM, 0.0, [1000.0 * DEFAULT_LEVELS_KM[-1]], [dist])[0]
        ref = slant_path_factors(DEFAULT_LEVELS_KM, [zen], earth_radius_km=R / 1000.0)[0]
        np.testing.assert_allclose(ours, ref, rtol=1e-9, err_msg=f"zenith {zen}")


def test_segment_below_the_horizon_is_continuous():
    from widesky.skymodel.generator.atmosphere import DEFAULT_LEVELS_KM
    from widesky.skymodel.generator.dataset_build import segment_path_factors

    d = np.linspace(0.0, 600e3, 61)
    f = segment_path_factors(DEFAULT_LEVELS_KM, 0.0, np.zeros_like(d), d).sum(axis=1)
    assert np.all(np.diff(f) > 0) and np.all(np.isfinite(f))


@pytest.mark.slow
def test_tiny_build_reproduces_its_fit(tiny):
    from widesky.skymodel.generator.dataset_build import load_state, config_knots, direction_samples, fit_all, state_file

    cfg, path, meta = tiny
    m = skymodel.load_dataset(path)
    assert not m.is_synthetic and m.metadata["config"]["rank"] == 3
    fitted = fit_all(cfg, processes=1, progress=False)
    sb, zb, eb = config_knots(cfg)
    v, e, ia = 131.8, 60.0, 1
    s = load_state(state_file(cfg, v, e))
    smp = direction_samples(s["zenith"], s["azimuth"], e)
    ours = skymodel.sky_radiance(m, smp["directions"], e, 180.0, v, cfg.albedos[ia])
    from widesky.skymodel.generator.fit import RadianceFit
    for c in (2, 20, 40):
        f = RadianceFit(fitted["sun"][-1, ia, 0, -1, c], fitted["zen"][-1, ia, 0, -1, c],
                        fitted["emph"][-1, ia, 0, -1, c], 0.0)
        ref = f.evaluate(smp["gamma"], smp["zero"], smp["zero"], sb, zb, eb)
        np.testing.assert_allclose(ours[:, c], ref, rtol=0, atol=3e-3 * ref.max())


@pytest.mark.slow
def test_tiny_build_agrees_with_skylight(tiny):
    prague = pytest.importorskip("skylight.prague")
    _, path, _ = tiny
    m = skymodel.load_dataset(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = prague.PragueSkyModelManager()
        ref.initialise(str(path))
    rng = np.random.default_rng(5)
    dirs = rng.normal(size=(40, 3))
    dirs[:, 2] = np.abs(dirs[:, 2])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    el, az, vis, alb = 33.0, 140.0, 45.0, 0.4
    params = prague.PragueSkyModelManager.compute_parameters(np.zeros(3), dirs, np.radians(el), np.radians(90 - az),
                                                             vis, alb)
    theirs = ref.sky_radiance(params, m.wavelengths).T
    ours = skymodel.sky_radiance(m, dirs, el, az, vis, alb)
    np.testing.assert_allclose(ours, theirs, rtol=1e-6, atol=1e-9 * np.abs(theirs).max())
    t_theirs = ref.transmittance(params, m.wavelengths, np.finfo(float).max).T
    t_ours = skymodel.transmittance(m, dirs, el, az, vis, alb)
    np.testing.assert_allclose(t_ours, t_theirs, rtol=1e-6, atol=1e-9)


@pytest.mark.slow
def test_tiny_build_direct_beam_and_error_report(tiny):
    from widesky.skymodel.generator.dataset_build import load_state, state_file

    cfg, path, meta = tiny
    m = skymodel.load_dataset(path)
    wl = m.wavelengths
    sel = (wl >= 400) & (wl <= 1300)
    for v, e in ((20.0, 10.0), (131.8, 60.0)):
        s = load_state(state_file(cfg, v, e))
        dni = skymodel.solar_direct_normal(m, e, 180.0, v, 0.0)
        np.testing.assert_allclose(dni[sel], s["dni"][sel], rtol=0.02)
    errs = meta["errors"]
    assert errs["n_states"]["all"] == 2
    assert len(errs["all"]["nmae_mean"]) == 55 and np.all(np.isfinite(errs["all"]["nmae_mean"]))
    # the smoothness check runs over the 2 x 2 x 2 grid and the 1 x 1 x 1 state between (report, not a pass/fail here:
    # 4 streams and rank 3 are not the default's settings)
    sm = meta["smoothness"]
    assert sm["grid"]["states"] == 8 and sm["between"]["states"] == 1
    assert 0 < sm["grid"]["checked_pairs"] <= 8 * 55
    # the between-grid pairs failing by the bracketing rule were solved at their own state and judged against it
    bref = meta["smoothness_between_reference"]
    failing_by_bracket = sm["between"].get("failing_pairs_by_bracketing_states", 0)
    assert len(bref["examined"]) <= failing_by_bracket and sm["between"]["failing_pairs"] <= failing_by_bracket
    et = m.metadata["extraterrestrial"]
    assert et["wavelength"][0] == 280.0 and et["wavelength"][-1] == 2480.0
