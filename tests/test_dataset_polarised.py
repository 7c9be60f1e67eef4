"""The Monte Carlo path of ``widesky dataset build`` (skymodel.generator.dataset_mc): polarisation section, twilight
elevations, cache keys, process pool vs Dask.

A tiny polarised configuration takes every grid elevation's radiance from the Monte Carlo solver (so no DISORT run
is needed), with twilight (-3 deg) and a few paths per direction; checked: the written file has the format's
polarisation section, reproduces the Monte Carlo polarisation it was fitted to (within the fit error the sidecar
reports), gives skylight light at twilight, reads identically in widesky and the ``skylight`` package, renders with
``widesky sky render --quantity polarisation``, and a build on a local Dask cluster writes the same bytes. The
scalar default configuration keeps its cache keys (the lead's solved states stay valid).
"""

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from widesky import skymodel

ROOT = Path(__file__).resolve().parents[1]
TINY_POL = {"visibilities_km": [20.0, 131.8], "albedos": [0.0, 0.8], "elevations_deg": [-3.0, 0.0, 20.0, 60.0],
            "knots": [12, 10, 6], "rank": 2, "zenith_step_deg": 15.0, "trans_dims": [64, 16], "trans_rank": 12,
            "validation_off_grid": 0, "validation_on_grid": 0, "iterations": 2, "refine": 1,
            "description": "tiny polarised test dataset", "polarisation": True, "mc_below_elevation_deg": 90.5,
            "mc_samples": 48, "mc_zenith_step_deg": 15.0, "mc_azimuths_deg": [0.0, 10.0, 40.0, 90.0, 140.0, 180.0],
            "pol_knots": [8, 6], "pol_rank": 2}


def test_default_config_keeps_its_cache_keys():
    """The plane-parallel configuration (the third rebuild's): the same solver key (the folder of the solved states)
    and fit-cache names as before the Monte Carlo path existed, and no Monte Carlo keys in its sidecar. The default
    configuration (low sun in spherical shells, the sun-knot intervals near the sun and the zenith-knot intervals above
    the horizon halved) shares its folder."""
    from widesky.skymodel.generator.dataset_build import fit_file, load_config

    from dataclasses import replace

    default = load_config(ROOT / "skymodel" / "data" / "default-dataset.json")
    cfg = load_config(ROOT / "skymodel" / "data" / "default-dataset-plane-parallel.json")
    assert default.solver_key() == cfg.solver_key()
    assert fit_file(replace(default, sun_knot_midpoints_deg=None, sun_knot_refine_deg=None,
                            zenith_knot_midpoints_deg=None), 20.0, 10.5) == \
        fit_file(cfg, 20.0, 10.5)
    assert fit_file(default, 20.0, 10.5) != fit_file(cfg, 20.0, 10.5)   # other knots
    assert fit_file(default, 20.0, 8.0) != fit_file(cfg, 20.0, 8.0)
    assert default.mc_single_scatter_exact and default.mc_below_elevation_deg == 9.0
    assert cfg.solver_key() == "8ac5c7f1f1a7"  # the folder of the solved default states
    # the Monte Carlo keys at their defaults (off) change no cache name and no sidecar entry
    off = replace(cfg, polarisation=False, mc_below_elevation_deg=None, mc_samples=7, pol_rank=5)
    assert off.solver_key() == cfg.solver_key()
    assert fit_file(off, 20.0, 10.5) == fit_file(cfg, 20.0, 10.5)
    assert off.to_dict() == cfg.to_dict() and "polarisation" not in cfg.to_dict()
    # turned on, they do change the fit-cache name (not the DISORT states' folder)
    on = replace(cfg, polarisation=True)
    assert on.solver_key() == cfg.solver_key() and fit_file(on, 20.0, 10.5) != fit_file(cfg, 20.0, 10.5)


def test_polarised_variant_config_is_valid():
    from widesky.skymodel.generator.dataset_build import load_config
    from widesky.skymodel.generator.dataset_mc import radiance_by_mc, uses_mc

    cfg = load_config(ROOT / "skymodel" / "data" / "polarised-dataset.json")
    assert uses_mc(cfg) and cfg.polarisation
    assert min(cfg.elevations_deg) == -4.2 and radiance_by_mc(cfg, -4.2) and not radiance_by_mc(cfg, 90.0)


def test_stream_mode_key():
    """``mc_streams``: correlated in the variant (and by default), passed to every state's solver config, part of the
    cache key; "independent" keeps the key of the states solved before the stream modes existed."""
    from dataclasses import replace

    from widesky.skymodel.generator.dataset_build import BuildConfig, load_config
    from widesky.skymodel.generator.dataset_mc import mc_config, mc_key

    cfg = load_config(ROOT / "skymodel" / "data" / "polarised-dataset.json")
    assert cfg.mc_streams == BuildConfig().mc_streams == "correlated"
    assert mc_config(cfg, 51.3, -2.0).streams == "correlated"
    ind = replace(cfg, mc_streams="independent")
    assert mc_config(ind, 51.3, -2.0).streams == "independent"
    assert mc_key(ind) == "7e2aad883f02" != mc_key(cfg)  # 7e2a...: the variant's states of the 2026-12-02 build
    with pytest.raises(ValueError, match="mc_streams='crn'"):
        BuildConfig(mc_streams="crn")


def test_twilight_without_monte_carlo_is_refused():
    from widesky.skymodel.generator.dataset_build import BuildConfig

    with pytest.raises(ValueError, match="mc_below_elevation_deg"):
        BuildConfig(elevations_deg=(-2.0, 10.0))
    with pytest.raises(ValueError, match="pol_knots"):
        BuildConfig(pol_knots=(1, 5))


def test_cli_rejects_unknown_mc_key(tmp_path):
    cfg = tmp_path / "c.json"
    cfg.write_text(json.dumps({**TINY_POL, "mc_sample": 3}))
    r = subprocess.run([sys.executable, "-m", "widesky.cli", "dataset", "build", str(cfg), "-o",
                        str(tmp_path / "x.dat")], capture_output=True, text=True,
                       env={**os.environ, "WIDESKY_CACHE_DIR": str(tmp_path / "cache")})
    assert r.returncode == 2 and "mc_sample" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "x.dat").exists()


def _cache(tmp, name, monkeypatch):
    """An empty state cache sharing the user's (content-keyed) Mie tables."""
    from widesky.skymodel.generator.paths import cache_dir

    root = tmp / f"cache_{name}"
    root.mkdir()
    (root / "build").symlink_to(cache_dir(), target_is_directory=True)
    monkeypatch.setenv("WIDESKY_CACHE_DIR", str(root))
    return root


def _build(tmp, name, processes):
    from widesky.skymodel.generator.dataset_build import build_dataset, load_config

    (tmp / "tiny_pol.json").write_text(json.dumps(TINY_POL))
    out = tmp / f"{name}.dat"
    meta = build_dataset(load_config(tmp / "tiny_pol.json"), out, processes=processes, progress=False,
                         validation=False)
    return out, meta


@pytest.fixture(scope="module")
def tiny_pol(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    tmp = tmp_path_factory.mktemp("pol")
    try:
        _cache(tmp, "pool", mp)
        out, meta = _build(tmp, "pool", processes=2)
        yield tmp, out, meta
    finally:
        mp.undo()


@pytest.mark.reference
@pytest.mark.slow
def test_polarised_build_has_polarisation_and_twilight(tiny_pol):
    _, out, meta = tiny_pol
    m = skymodel.load_dataset(out)
    assert m.has_polarisation and m.elevations[0] == -3.0
    mc = meta["monte_carlo"]
    assert mc["radiance_elevations_deg"] == [-3.0, 0.0, 20.0, 60.0]
    assert len(mc["polarisation"]["fit_mae_median_per_channel"]) == 55
    # twilight: the sky 3 deg after sunset is lit (blue channel), dimmer than at sunset (48 paths per direction: the
    # direction dependence is checked on the variant file, test_variant_twilight_glow_faces_the_sun)
    d = skymodel.directions_from_angles(np.array([80.0, 80.0]), np.array([180.0, 0.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
        tw = skymodel.sky_radiance(m, d, -3.0, 180.0, 50.0, 0.5, wavelengths=[460.0])[:, 0]
        ss = skymodel.sky_radiance(m, d, 0.0, 180.0, 50.0, 0.5, wavelengths=[460.0])[:, 0]
    assert np.all(tw > 0) and np.all(tw < ss)


@pytest.mark.reference
@pytest.mark.slow
def test_polarisation_reproduces_the_monte_carlo_it_was_fitted_to(tiny_pol):
    """At a grid state the file's polarisation equals the Monte Carlo target -P = -Q_s / I within the fit's mean
    absolute error (solid-angle weighted, the sidecar's figure) plus 0.01; at 90 deg from a sun at 20 deg the visible
    sky is strongly polarised (Rayleigh: positive, above 0.3) and less so 10 deg from the sun."""
    from widesky.skymodel.generator.dataset_build import direction_samples, load_config
    from widesky.skymodel.generator.dataset_mc import mc_file, stored_polarisation
    from widesky.skymodel.generator.cache import load_state

    tmp, out, meta = tiny_pol
    cfg = load_config(tmp / "tiny_pol.json")
    m = skymodel.load_dataset(out)
    state = load_state(mc_file(cfg, 131.8, 20.0))
    p, _ = stored_polarisation(state, 0.8)
    smp = direction_samples(state["zenith"], state["azimuth"], 20.0)
    ours = skymodel.polarisation(m, smp["directions"], 20.0, 180.0, 131.8, 0.8)  # (N, 55)
    target = -p.reshape(-1, 55)
    w = smp["weights"][:, None]
    mae = np.sum(w * np.abs(ours - target), axis=0) / np.sum(w)
    assert np.all(mae <= 0.01 + 2 * np.max(meta["monte_carlo"]["polarisation"]["fit_mae_median_per_channel"]))
    # physics: channel 500-540 nm, 90 deg from the sun vs 10 deg from it (the sun in the south at 20 deg)
    d = skymodel.directions_from_angles(np.array([20.0, 70.0]), np.array([0.0, 180.0]))
    pol = skymodel.polarisation(m, d, 20.0, 180.0, 131.8, 0.0, wavelengths=[520.0])[:, 0]
    assert pol[0] > 0.3 and pol[1] < pol[0]


@pytest.mark.reference
@pytest.mark.slow
def test_polarised_build_agrees_with_skylight(tiny_pol):
    sl = pytest.importorskip("skylight.prague")
    _, out, _ = tiny_pol
    m = skymodel.load_dataset(out)
    ref = sl.PragueSkyModelManager()
    ref.initialise(str(out))
    rng = np.random.default_rng(4)
    d = rng.normal(size=(30, 3))
    d[:, 2] = np.abs(d[:, 2])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for el, az, vis, alb in ((-2.0, 200.0, 40.0, 0.3), (35.0, 120.0, 100.0, 0.7)):
        p = sl.PragueSkyModelManager.compute_parameters(np.zeros(3), d, np.radians(el), np.radians(90.0 - az), vis,
                                                         alb)
        np.testing.assert_allclose(skymodel.polarisation(m, d, el, az, vis, alb), ref.polarisation(p, m.wavelengths).T,
                                   rtol=1e-6, atol=1e-12)
        theirs = ref.sky_radiance(p, m.wavelengths).T
        np.testing.assert_allclose(skymodel.sky_radiance(m, d, el, az, vis, alb), theirs, rtol=1e-6,
                                   atol=1e-9 * np.abs(theirs).max())


@pytest.mark.reference
@pytest.mark.slow
def test_render_polarisation_on_the_polarised_build(tiny_pol, tmp_path):
    _, out, _ = tiny_pol
    png = tmp_path / "pol.png"
    r = subprocess.run([sys.executable, "-m", "widesky.cli", "sky", "render", "--dataset", str(out), "--quantity",
                        "polarisation", "--channel", "440nm", "--elevation", "-2", "--resolution", "64", "--no-exr", "--output",
                        str(png)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert png.stat().st_size > 0


@pytest.mark.reference
@pytest.mark.slow
def test_polarised_build_on_dask_is_byte_identical(tiny_pol, tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")
    from widesky.skymodel.generator.dask_scheduler import SCHEDULER_ENV

    _, pool_out, _ = tiny_pol
    _cache(tmp_path, "dask", monkeypatch)
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # distributed's own deprecation and port warnings
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                      dashboard_address=None) as cluster:
            monkeypatch.setenv(SCHEDULER_ENV, cluster.scheduler_address)
            dask_out, _ = _build(tmp_path, "dask", processes=2)
            monkeypatch.delenv(SCHEDULER_ENV)
    assert dask_out.read_bytes() == pool_out.read_bytes()


VARIANT = ROOT / "skymodel" / "data" / "polarised.dat"
needs_variant = pytest.mark.skipif(not VARIANT.exists(), reason="polarised variant not built (skymodel/data/polarised.dat)")


@needs_variant
def test_variant_reads_identically_in_skylight():
    """The shipped polarised + twilight variant (built with skymodel/data/polarised-dataset.json): widesky and the
    independent ``skylight`` reader give the same radiance and polarisation (1e-6 relative, as for the reference
    datasets in tests/test_sky_skylight.py), twilight included."""
    sl = pytest.importorskip("skylight.prague")
    m = skymodel.load_dataset(VARIANT)
    assert m.has_polarisation and m.elevations[0] == -4.2 and m.elevations[-1] == 90.0
    ref = sl.PragueSkyModelManager()
    ref.initialise(str(VARIANT))
    rng = np.random.default_rng(9)
    d = rng.normal(size=(40, 3))
    d[:, 2] = np.abs(d[:, 2])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for el, az, vis, alb in ((-3.1, 250.0, 33.0, 0.2), (1.0, 90.0, 131.8, 0.9), (47.0, 180.0, 70.0, 0.5)):
        p = sl.PragueSkyModelManager.compute_parameters(np.zeros(3), d, np.radians(el), np.radians(90.0 - az), vis,
                                                         alb)
        np.testing.assert_allclose(skymodel.polarisation(m, d, el, az, vis, alb), ref.polarisation(p, m.wavelengths).T,
                                   rtol=1e-6, atol=1e-12)
        theirs = ref.sky_radiance(p, m.wavelengths).T
        np.testing.assert_allclose(skymodel.sky_radiance(m, d, el, az, vis, alb), theirs, rtol=1e-6,
                                   atol=1e-9 * np.abs(theirs).max())


@needs_variant
def test_variant_twilight_glow_and_polarisation_pattern():
    """Physics of the variant at 500-540 nm, visibility 51.3 km, albedo 0.5: 2 deg after sunset the horizon sky toward
    the sun is brighter than away from it; at sunset the zenith (90 deg from the sun) is strongly polarised (clear
    skies: 0.6-0.8 at 90 deg from the sun, Coulson 1988, "Polarization and Intensity of Light in the Atmosphere",
    ch. 5: here between 0.45 and 0.9 for a continental aerosol) and the sky 10 deg from the sun weakly (< 0.25)."""
    m = skymodel.load_dataset(VARIANT)
    toward_away = skymodel.directions_from_angles(np.array([86.0, 86.0]), np.array([180.0, 0.0]))
    r = skymodel.sky_radiance(m, toward_away, -2.0, 180.0, 51.3, 0.5, wavelengths=[520.0])[:, 0]
    assert r[0] > 1.5 * r[1] > 0
    d = skymodel.directions_from_angles(np.array([0.0, 80.0]), np.array([0.0, 180.0]))
    p = skymodel.polarisation(m, d, 0.0, 180.0, 51.3, 0.5, wavelengths=[520.0])[:, 0]
    assert 0.45 < p[0] < 0.9 and abs(p[1]) < 0.25


def test_resampled_monte_carlo_radiance_keeps_the_samples_and_adds_no_extremum():
    """``mc_fit_resample``: the shape-preserving interpolation onto the fit grid reproduces the state's samples at its
    own nodes (1e-12), stays inside the range of every pair of neighbouring samples (no new ring), and refuses a
    target outside the state's grid; the fit grid contains the state's grid, and the key renames the fit cache."""
    from dataclasses import replace

    from widesky.skymodel.generator.dataset_build import fit_file, load_config
    from widesky.skymodel.generator.dataset_mc import fit_grid, resample_radiance

    rng = np.random.default_rng(5)
    th = np.array([0.0, 10.0, 20.0, 40.0, 70.0, 84.0, 89.95])
    ph = np.array([0.0, 2.0, 6.0, 12.0, 22.0, 35.0, 55.0, 80.0, 130.0, 180.0])
    rad = np.exp(rng.normal(size=(len(th), len(ph), 3)))
    cfg = replace(load_config(ROOT / "skymodel" / "data" / "polarised-dataset.json"), mc_fit_resample=True)
    t2, p2 = fit_grid({"zenith": th, "azimuth": ph}, cfg)
    assert set(th) <= set(t2) and set(ph) <= set(p2) and len(t2) > 3 * len(th) and len(p2) > 3 * len(ph)
    out = resample_radiance(th, ph, rad, t2, p2)
    i, j = np.searchsorted(t2, th), np.searchsorted(p2, ph)
    np.testing.assert_allclose(out[np.ix_(i, j)], rad, rtol=1e-12)
    row = resample_radiance(th, ph, rad, th, p2)  # along the azimuths of the state's own zeniths
    k = np.clip(np.searchsorted(ph, p2, side="right") - 1, 0, len(ph) - 2)
    lo, hi = np.minimum(rad[:, k], rad[:, k + 1]), np.maximum(rad[:, k], rad[:, k + 1])
    assert np.all((row >= lo * (1 - 1e-12)) & (row <= hi * (1 + 1e-12)))
    with pytest.raises(ValueError, match="outside the source grid"):
        resample_radiance(th, ph, rad, [0.0, 90.0], ph)
    assert fit_file(cfg, 51.3, -2.0) != fit_file(replace(cfg, mc_fit_resample=False), 51.3, -2.0)
    t0, p0 = fit_grid({"zenith": th, "azimuth": ph}, replace(cfg, mc_fit_resample=False))
    assert np.array_equal(t0, th) and np.array_equal(p0, ph)  # off: the state's own grid, as before
