"""Split Monte Carlo states of a dataset build (``mc_single_scatter_exact``): the low-sun sky in spherical shells.

What is checked:
- the recombination (:func:`widesky.skymodel.generator.dataset_mc.split_radiance`) on synthetic states with a known answer:
  exact where the rest (the multiple scattering) lies in its model space (cosine series in azimuth up to order 2,
  a smooth function of the view zenith), within the noise where 2 % noise is added, with no turning point along
  an almucantar beyond the noise-free sky's, and with the single scattering carried over unchanged on the fine grid;
- the configuration: split states are scalar (DISORT's physics), their key differs, validation states at split
  elevations get their own cache files, and the DISORT states keep the fit-cache names of the plain build;
- on the real atmosphere (``reference``): the exact single scattering in spherical shells tends to the
  plane-parallel one for a high sun and short slant paths (analytic limit: the shells' curvature is negligible
  when the path length is far below the Earth's radius; within 1 % at sun 40 deg, view zenith <= 60 deg), and at
  sun 0 deg it stays finite and positive to the horizon where the plane-parallel beam is extinguished.
"""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from widesky.skymodel.generator.dataset_mc import MC_AZIMUTHS_DEG, split_radiance
from widesky.skymodel.generator.smoothness import turning_points

ROOT = Path(__file__).resolve().parents[2]


def _synthetic_state(noise=0.0, seed=0):
    """A state with a known rest, a field regular at the zenith: (1 + 0.3 sin(theta) cos phi + 0.1 sin^2(theta)
    cos 2 phi) x (1 + 2 (theta/90)^2) on a Monte Carlo grid, a single scattering with an aureole, all light in
    ground order 0 (albedo-independent)."""
    th = np.unique(np.concatenate([np.arange(0.0, 89.0, 6.0), [84.0, 87.0, 88.5, 89.95]]))
    ph = np.asarray(MC_AZIMUTHS_DEG, float)
    t2 = np.unique(np.concatenate([np.arange(0.0, 89.0, 2.0), [85.5, 87.0, 88.0, 89.0, 89.95]]))
    p2 = np.unique(np.concatenate([ph, np.arange(50.0, 180.1, 5.0)]))

    def rest(t, p):
        T, P = np.meshgrid(t, np.radians(p), indexing="ij")
        S = np.sin(np.radians(T))
        return ((1.0 + 0.3 * S * np.cos(P) + 0.1 * S ** 2 * np.cos(2 * P)) * (1.0 + 2.0 * (T / 90.0) ** 2))[..., None]

    def single(t, p):
        T, P = np.meshgrid(np.radians(t), np.radians(p), indexing="ij")
        cos_g = np.cos(T) * 0.0 + np.sin(T) * np.cos(P)          # sun on the horizon at azimuth 0
        return (0.5 + 3.0 * np.exp(-np.degrees(np.arccos(np.clip(cos_g, -1, 1))) / 10.0))[..., None]

    r = rest(th, ph) * np.ones(3)
    rng = np.random.default_rng(seed)
    sd = noise * r
    tot = single(th, ph) + r + sd * rng.standard_normal(r.shape)
    stokes = np.zeros(tot.shape + (1, 4))
    stokes[..., 0, 0] = tot
    err = np.zeros_like(stokes)
    err[..., 0, 0] = np.maximum(sd, 1e-6)
    state = {"zenith": th, "azimuth": ph, "stokes": stokes, "stderr": err, "single": single(th, ph) * np.ones(3),
             "fine_zenith": t2, "fine_azimuth": p2, "single_fine": single(t2, p2) * np.ones(3)}
    return state, rest(t2, p2) * np.ones(3), single(t2, p2) * np.ones(3)


def test_split_radiance_reproduces_a_rest_in_its_model_space():
    """Noise-free rest regular at the zenith: reproduced within 0.3 % (the zenith spline's penalty bends the
    horizon's curvature by 0.22 %; a rest linear in theta^2 near the zenith and in theta at the horizon would be
    exact), the single scattering carried over unchanged."""
    state, rest, single = _synthetic_state()
    got = split_radiance(state, 0.3)
    assert got.shape == single.shape
    np.testing.assert_allclose(got - single, rest, rtol=3e-3)


def test_split_radiance_is_regular_at_the_zenith():
    """With 2 % noise on the rest the smoothed field is one value at the zenith (every azimuth: the m >= 1 terms
    vanish there) and has no spot: the zenith against the mean of the 2 deg ring differs from the noise-free sky's
    by under 0.3 % (an unconstrained spline left up to 4 % at the build's real states)."""
    clean, rest, single = _synthetic_state()
    w = np.gradient(clean["fine_azimuth"])
    assert clean["fine_zenith"][0] == 0.0 and clean["fine_zenith"][1] == 2.0

    def spot(r):
        return r[0, 0, 0] / (np.sum(w * r[1, :, 0]) / w.sum()) - 1.0

    for seed in range(3):
        state, _, _ = _synthetic_state(noise=0.02, seed=seed)
        got = split_radiance(state, 0.0)
        assert np.ptp(got[0], axis=0).max() <= 1e-12 * got[0].max()
        assert abs(spot(got) - spot(single + rest)) < 0.003, seed


def test_split_radiance_averages_the_noise_and_adds_no_ripple():
    """2 % noise on the rest: the recombined rest within 1.5 % of the truth everywhere (the fit averages 18
    azimuths and ~20 zenith rows), and no almucantar of the sky gets more turning points than the noise-free one."""
    clean, rest, single = _synthetic_state()
    ref = split_radiance(clean, 0.0)
    for seed in range(3):
        state, _, _ = _synthetic_state(noise=0.02, seed=seed)
        got = split_radiance(state, 0.0)
        assert np.abs(got - single - rest).max() / rest.max() < 0.015
        # along every almucantar (the check's zigzag count, 0.5 % tolerance)
        assert np.all(turning_points(got[..., 0]) <= turning_points(ref[..., 0])), seed


def test_split_configuration_keys_and_files():
    from widesky.skymodel.generator.dataset_build import fit_file, load_config, validation_file
    from widesky.skymodel.generator.dataset_mc import mc_config, mc_key, split_state

    plain = replace(load_config(ROOT / "skymodel" / "data" / "default-dataset.json"), mc_below_elevation_deg=None,
                    mc_single_scatter_exact=False)
    low = replace(plain, mc_below_elevation_deg=9.0)
    split = replace(low, mc_single_scatter_exact=True)
    assert split_state(split, 8.0) and not split_state(split, 10.5) and not split_state(low, 8.0)
    assert mc_config(split, 51.3, 0.0).polarised is False       # DISORT's scalar physics
    assert mc_config(low, 51.3, 0.0).polarised is True
    assert mc_key(split) != mc_key(low)
    assert validation_file(split, "off", 36.59, 4.694, 0.208).name.startswith("mcval_")
    assert validation_file(split, "on", 20.0, 13.5, 1.0).name.startswith("val_on_")
    assert validation_file(low, "off", 36.59, 4.694, 0.208).name.startswith("val_off_")
    # the DISORT states of a low-sun Monte Carlo build reuse the plain build's fits; its Monte Carlo states do not
    assert fit_file(split, 51.3, 36.0) == fit_file(plain, 51.3, 36.0)
    assert fit_file(split, 51.3, 3.0) != fit_file(plain, 51.3, 3.0) != fit_file(low, 51.3, 3.0)


@pytest.mark.reference
def test_single_scatter_tends_to_plane_parallel_for_a_high_sun():
    from widesky.skymodel.generator.dataset_build import load_config
    from widesky.skymodel.generator.dataset_mc import single_scatter
    from widesky.skymodel.generator.montecarlo import MonteCarloConfig, solve_sky_mc
    from widesky.skymodel.generator.solver import SkyState

    cfg = load_config(ROOT / "skymodel" / "data" / "default-dataset.json")
    th, ph = np.array([0.0, 30.0, 60.0]), np.array([0.0, 45.0, 120.0, 180.0])
    sph = single_scatter(29.2, 40.0, th, ph, cfg)
    T, P = np.meshgrid(th, ph, indexing="ij")
    pp = solve_sky_mc(SkyState(40.0, visibility_km=29.2, ground_albedo=0.0), cfg.spec(), T.ravel(), P.ravel(), None,
                      MonteCarloConfig(samples=1, polarised=False, max_order=1, ground_orders=0,
                                       planet_radius_km=None), solar_elevation_deg=40.0)
    pp = pp.stokes[..., 0].reshape(sph.shape)
    lit = pp > 1e-6 * pp.max()
    assert np.abs(sph[lit] / pp[lit] - 1).max() < 0.01
    low = single_scatter(29.2, 0.0, np.array([60.0, 85.0, 89.95]), np.array([0.0, 90.0, 180.0]), cfg)
    assert np.all(np.isfinite(low)) and np.all(low[:, :, 7] > 0)


def test_split_validation_job_writes_its_state(tmp_path, monkeypatch):
    """The build's job for a validation state at a split elevation solves it with the split reference and caches it
    under the Monte Carlo key (the solve itself replaced by a stub returning a marked state)."""
    from widesky.skymodel.generator import dataset_build
    from widesky.skymodel.generator.cache import load_state

    monkeypatch.setenv("WIDESKY_CACHE_DIR", str(tmp_path))
    cfg = replace(dataset_build.load_config(ROOT / "skymodel" / "data" / "default-dataset.json"),
                  mc_below_elevation_deg=9.0, mc_single_scatter_exact=True)
    calls = []

    def fake(vis, ele, alb, config, data_dir=None):
        calls.append((vis, ele, alb))
        return {"radiance": np.full((2, 2, 55), 7.0), "solved_elevation": ele}

    monkeypatch.setattr(dataset_build, "solve_split_validation", fake)
    kind, vis, ele, path = dataset_build._solve_job(("val_off", cfg, 36.59, 4.694, 0.208))
    assert calls == [(36.59, 4.694, 0.208)] and path.name.startswith("mcval_")
    assert load_state(path)["radiance"][0, 0, 0] == 7.0


def test_split_configuration_refuses_what_it_cannot_build():
    from widesky.skymodel.generator.dataset_build import BuildConfig

    with pytest.raises(ValueError, match="mc_single_scatter_exact needs mc_below_elevation_deg"):
        BuildConfig(mc_single_scatter_exact=True)
    with pytest.raises(ValueError, match="no polarisation"):
        BuildConfig(mc_single_scatter_exact=True, mc_below_elevation_deg=9.0, polarisation=True)
    assert BuildConfig(mc_single_scatter_exact=True, mc_below_elevation_deg=9.0).mc_single_scatter_exact


def test_smooth_across_visibility_keeps_a_cubic_and_averages_noise():
    """A cubic in log visibility comes back exactly (11 visibilities 20-131.8 km); independent noise on 11 states is
    cut to sqrt(4 / 11) of its rms (the least-squares projection onto 4 parameters), here within 10 % over 20,000
    series; fewer visibilities than the degree needs lower the degree (2 states come back unchanged)."""
    from widesky.skymodel.generator.dataset_mc import smooth_across_visibility

    vis = np.geomspace(20.0, 131.8, 11)
    x = np.log(vis)
    cubic = (0.3 + 0.2 * x - 0.05 * x ** 2 + 0.01 * x ** 3)[:, None] * np.ones((1, 4))
    np.testing.assert_allclose(smooth_across_visibility(cubic, vis), cubic, rtol=1e-10)
    noise = np.random.default_rng(1).standard_normal((11, 20000))
    ratio = np.sqrt(np.mean(smooth_across_visibility(noise, vis) ** 2) / np.mean(noise ** 2))
    assert abs(ratio / np.sqrt(4 / 11) - 1) < 0.1, ratio
    two = np.array([[1.0, 2.0], [3.0, 5.0]])
    np.testing.assert_allclose(smooth_across_visibility(two, [20.0, 40.0]), two)
    with pytest.raises(ValueError):
        smooth_across_visibility(two, [20.0, 40.0, 60.0])
    # evaluated between the visibilities (the between-grid reference of the smoothness check): the same cubic
    at = [22.0, 38.68, 119.97]
    xa = np.log(at)
    want = (0.3 + 0.2 * xa - 0.05 * xa ** 2 + 0.01 * xa ** 3)[:, None] * np.ones((1, 4))
    np.testing.assert_allclose(smooth_across_visibility(cubic, vis, at_km=at), want, rtol=1e-10)


def test_between_elevation_bracket_uses_the_evaluators_weights():
    """The split between-grid reference (skymodel.generator.smoothness_between) blends the bracketing grid elevations
    with the evaluator's linear weights (skymodel.evaluate: linear in elevation between grid values)."""
    from widesky.skymodel.generator.smoothness_between import _elevation_bracket

    grid = [0.0, 1.0, 2.0, 3.0, 4.5, 6.0, 8.0, 10.5]
    assert _elevation_bracket(grid, 2.5) == [(2.0, 0.5), (3.0, 0.5)]
    (e0, w0), (e1, w1) = _elevation_bracket(grid, 5.25)
    assert (e0, e1) == (4.5, 6.0) and abs(w0 - 0.5) < 1e-12 and abs(w1 - 0.5) < 1e-12
    (e0, w0), (e1, w1) = _elevation_bracket(grid, 7.0)
    assert (e0, e1) == (6.0, 8.0) and abs(w1 - 0.5) < 1e-12
    from widesky.skymodel.evaluate import _reference_lookup

    for q in (0.5, 3.75, 9.25, 9.9):
        i, f = _reference_lookup(q, np.asarray(grid))
        assert _elevation_bracket(grid, q) == [(grid[i], 1.0 - f), (grid[i + 1], f)]


def test_rest_across_visibility_lowers_the_noise_of_each_state():
    """Synthetic split states at 11 visibilities, the same rest with 2 % independent noise each: after smoothing
    across visibility every state's rest is closer to the truth (rms over the sky) than its own smoothed rest,
    by about sqrt(4 / 11) on average (tolerance: below 0.8 of it)."""
    from widesky.skymodel.generator.dataset_mc import rest_across_visibility, split_rest

    vis = tuple(np.geomspace(20.0, 131.8, 11))
    cfg = type("Cfg", (), {"visibilities_km": vis})()
    states, truth = [], None
    for i in range(len(vis)):
        st, rest, _ = _synthetic_state(noise=0.02, seed=10 + i)
        states.append(st)
        truth = rest
    xv = rest_across_visibility(cfg, 0.0, 0.0, states=states)
    own = np.stack([split_rest(m, 0.0) for m in states])
    e_own = np.sqrt(np.mean((own - truth) ** 2, axis=(1, 2, 3)))
    e_xv = np.sqrt(np.mean((xv - truth) ** 2, axis=(1, 2, 3)))
    assert np.mean(e_xv / e_own) < 0.8, e_xv / e_own


def test_split_validation_runs_after_the_grid_states(tmp_path, monkeypatch):
    """solve_all runs the split validation states (which read every visibility's Monte Carlo state of their elevation)
    in a second pool, after every grid state; the other jobs in the first."""
    from widesky.skymodel.generator import dataset_build

    monkeypatch.setenv("WIDESKY_CACHE_DIR", str(tmp_path))
    cfg = replace(dataset_build.load_config(ROOT / "skymodel" / "data" / "default-dataset.json"),
                  mc_below_elevation_deg=9.0, mc_single_scatter_exact=True)
    phases = []

    def fake_pool(fn, jobs, processes, progress, desc):
        phases.append([(j[0], j[3]) for j in jobs])
        return iter([(j[0], j[2], j[3], None) for j in jobs])

    monkeypatch.setattr(dataset_build, "pool_map", fake_pool)
    dataset_build.solve_all(cfg, processes=2, progress=False)
    assert len(phases) == 2
    first, second = phases
    assert second and all(k.startswith("val_") and e < 9.0 for k, e in second)
    assert any(k == "mc" for k, _ in first)
    assert not any(k.startswith("val_") and e < 9.0 for k, e in first)
