"""The brute-force reference (irradiance.reference) and the integrator against it.

* Furnace tests of the reference itself: a uniform sky gives pi L (1 + cos tilt) / 2 (midpoint
  quadrature on a 0.8-1.6 deg grid: 2e-4) and albedo pi L (1 - cos tilt) / 2 from the ground; a sun
  alone gives E cos(aoi) exactly and albedo E sin(el) (1 - cos tilt) / 2 from the ground.
* The issue's acceptance test, fast version for CI: default integrator settings against the reference
  on the two validation scenes, annual (here: 12 days spread over the year, hourly) totals of
  poa_global per analysis point: within 1 % for the unobstructed tilted plane and 2 % for the
  obstructed facade; and hourly, the reflected light's error below 10 % of the step's global at the
  95th percentile. The reference runs at reduced resolution here (sky grid 1.6 deg, reflector grid
  6 deg), measured within 0.2 % of its converged settings on these scenes; the full-year numbers
  with the converged reference are in docs/validation/irradiance-integrator.md
  (``python benchmarks/bench_poa_accuracy.py``). Sky: the embedded default PSM dataset.
"""

import numpy as np
import pandas as pd
import pytest
import trimesh

from widesky.irradiance.poa import RunOptions, poa_irradiance
from widesky.irradiance.patches import direction_from_angles
from widesky.irradiance.raycast import sun_bins
from widesky.irradiance.reference import reference_poa, validation_scenes
from widesky.irradiance.scene import make_scene
from widesky.irradiance.skies import PragueSky, SkyStates, UniformSky
from widesky.irradiance.solarposition import solar_position

WIDTH = 2200.0
STATES = SkyStates.create([10.0, 35.0, 60.0, 85.0], [90.0, 150.0, 200.0, 250.0], 40.0, 0.3)


def quad(tilt, azimuth, size=1.0):
    h = size / 2
    v = np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])
    rot = trimesh.geometry.align_vectors([0, 0, 1], direction_from_angles(90.0 - tilt, azimuth))
    return trimesh.Trimesh(v @ rot[:3, :3].T, [[0, 1, 2], [0, 2, 3]], process=False)


FAST = dict(sky_mf=8, sky_rays=2, reflect_mf=4, reflect_sky_mf=2)


@pytest.mark.parametrize("tilt", [0.0, 35.0, 90.0])
def test_reference_uniform_sky_furnace(tilt):
    scene = make_scene(quad(tilt, 200.0), ground_z=-50.0, ground_albedo=0.4, analysis_reflectance=0)
    r = reference_poa(scene, UniformSky(0.7), STATES.take([0, 2]), sky_mf=8, sky_rays=1,
                      reflect_mf=2, reflect_sky_mf=2)
    c = np.cos(np.radians(tilt))
    np.testing.assert_allclose(r.poa_sky_diffuse, np.pi * 0.7 * WIDTH * (1 + c) / 2, rtol=2e-4)
    np.testing.assert_allclose(r.poa_ground_diffuse, 0.4 * np.pi * 0.7 * WIDTH * (1 - c) / 2,
                               rtol=2e-3, atol=1e-9)
    np.testing.assert_allclose(r.poa_direct, 0.0)


@pytest.mark.parametrize("tilt, azimuth", [(30.0, 180.0), (90.0, 90.0)])
def test_reference_sun_only_furnace(tilt, azimuth):
    scene = make_scene(quad(tilt, azimuth), ground_z=-50.0, ground_albedo=0.25,
                       analysis_reflectance=0)
    E = 1.3
    r = reference_poa(scene, UniformSky(0.0, dni=E), STATES, sky_mf=4, sky_rays=1, reflect_mf=2,
                      reflect_samples=2, reflect_sky_mf=1)
    s = STATES.sun_direction
    cos_aoi = np.maximum(s @ scene.face_normal.T, 0.0)
    np.testing.assert_allclose(r.poa_direct, E * WIDTH * cos_aoi, rtol=1e-12)
    c = np.cos(np.radians(tilt))
    # midpoint quadrature of the lower hemisphere's cosine weights (6 deg cells, 2 x 2 rays): 1e-3
    np.testing.assert_allclose(r.poa_ground_diffuse,
                               0.25 * E * WIDTH * s[:, 2:3] * (1 - c) / 2 * np.ones((1, 2)),
                               rtol=1e-3)
    np.testing.assert_allclose(r.poa_sky_diffuse, 0.0, atol=1e-12)


def test_sun_bins_partition():
    """Every direction's bin representative lies within the bin's cell (about 1 deg here)."""
    rng = np.random.default_rng(3)
    d = rng.normal(size=(5000, 3))
    d[:, 2] = np.abs(d[:, 2]) + 0.01
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rep, idx = sun_bins(d, 1.0)
    ang = np.degrees(np.arccos(np.clip(np.sum(rep[idx] * d, axis=1), -1, 1)))
    assert ang.max() < 1.5
    assert rep.shape[0] < d.shape[0]
    rep0, idx0 = sun_bins(d, 0.0)
    np.testing.assert_array_equal(rep0, d)
    np.testing.assert_array_equal(idx0, np.arange(d.shape[0]))
    with pytest.raises(ValueError, match="sun_bin"):
        sun_bins(d, -1.0)


def twelve_days():
    days = pd.Timestamp("2023-01-01") + pd.to_timedelta(np.linspace(14, 349, 12).round(), "D")
    times = pd.DatetimeIndex(np.concatenate(
        [pd.date_range(d, periods=24, freq="1h") + pd.Timedelta("30min") for d in days]))
    times = times.tz_localize("Etc/GMT-1")
    sp = solar_position(times, 50.08, 14.42)
    return SkyStates.create(sp["apparent_elevation"].to_numpy(), sp["azimuth"].to_numpy(), 40.0,
                            0.2)


@pytest.mark.slow
@pytest.mark.parametrize("name, tolerance", [("tilted_plane", 0.01), ("obstructed_facade", 0.02)])
def test_default_settings_against_reference(name, tolerance):
    states = twelve_days()
    scene = validation_scenes()[name]
    sky = PragueSky()
    ref = reference_poa(scene, PragueSky(sky.model, elevation_quantum=0), states, n_jobs=2, **FAST)
    res = poa_irradiance(scene, sky, states, run=RunOptions(n_jobs=1))
    err = res.poa_global.sum(0, dtype=np.float64) / ref.poa_global.sum(0) - 1
    assert np.all(np.isfinite(err))
    assert np.abs(err).max() < tolerance, err
    # the components the two split the same way: reflected light (within 10 % per point)
    er = res.poa_ground_diffuse.sum(0, dtype=np.float64) / ref.poa_ground_diffuse.sum(0) - 1
    assert np.abs(er).max() < 0.10, er
    # hourly: the reflected light per step, as a fraction of the step's global, where the reference
    # exceeds 50 W m-2 (95th percentile over point-steps; measured 7.3 % on the facade with the
    # shading cells, 17.4 % with the earlier three elevation bands; 0.04 % on the plane)
    g = ref.poa_global
    ok = g > 50.0
    hourly = np.abs(res.poa_ground_diffuse - ref.poa_ground_diffuse)[ok] / g[ok]
    assert np.percentile(hourly, 95) < 0.10, np.percentile(hourly, 95)


def _cover(aoi):
    """A Fresnel glass cover with absorption (n = 1.526, K = 4 m-1, L = 2 mm), relative to normal
    incidence, written from the physics so the test needs no pvlib."""
    th = np.radians(np.clip(aoi, 0.0, 89.999))
    tr = np.arcsin(np.sin(th) / 1.526)
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = np.where(th > 1e-9, (np.sin(tr - th) / np.sin(tr + th)) ** 2, (0.526 / 2.526) ** 2)
        rp = np.where(th > 1e-9, (np.tan(tr - th) / np.tan(tr + th)) ** 2, (0.526 / 2.526) ** 2)
    t = np.exp(-4.0 * 0.002 / np.cos(tr)) * (1 - 0.5 * (rs + rp))
    t0 = np.exp(-4.0 * 0.002) * (1 - (0.526 / 2.526) ** 2)
    return np.where(np.asarray(aoi) >= 90.0, 0.0, t / t0)


@pytest.mark.slow
@pytest.mark.parametrize("name, tolerance", [("tilted_plane", 0.01), ("obstructed_facade", 0.02)])
def test_optics_against_reference(name, tolerance):
    """The integrator's per-direction optics against the reference's per-ray optics (same annual
    tolerances as without optics; 4 days spread over the year), and the optic's loss itself
    (1 - with / without) within 10 % of the reference's loss per point."""
    from widesky.irradiance import Response
    states = twelve_days().take(np.concatenate([np.arange(24) + 24 * d for d in (0, 3, 6, 9)]))
    scene = validation_scenes()[name]
    sky = PragueSky()
    ref = reference_poa(scene, PragueSky(sky.model, elevation_quantum=0), states, n_jobs=2,
                        angular=_cover, **FAST)
    ref0 = reference_poa(scene, PragueSky(sky.model, elevation_quantum=0), states, n_jobs=2, **FAST)
    cover = Response("cover", [280.0, 2480.0], [1.0, 1.0], angular=_cover)
    res = poa_irradiance(scene, sky, states, responses=[cover], run=RunOptions(n_jobs=1))
    got = res.get("cover", "global").sum(0, dtype=np.float64)
    err = got / ref.poa_global.sum(0) - 1
    assert np.abs(err).max() < tolerance, err
    loss_ref = 1 - ref.poa_global.sum(0) / ref0.poa_global.sum(0)
    loss = 1 - got / res.poa_global.sum(0, dtype=np.float64)
    np.testing.assert_allclose(loss, loss_ref, rtol=0.10)
