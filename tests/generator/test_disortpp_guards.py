"""Guards for the known disortpp 1.2.1 defects and traps (see docs/atmosphere-and-solver.md)."""

import pathlib

import numpy as np
import pytest

disortpp = pytest.importorskip("disortpp")


def _cfg(spherical=False, nl=10, phi=(0.0, 180.0)):
    c = disortpp.DisortConfig(nl, 16)
    c.flags.use_lambertian_surface = True
    c.flags.use_user_mu = True
    c.flags.use_user_tau = True
    c.flags.use_spherical_beam = spherical
    c.num_user_tau = 1
    c.num_user_mu = 3
    c.num_phi = len(phi)
    c.num_phase_func_moments = 16
    if spherical:
        c.bottom_radius = 6371.0
    c.allocate()
    if spherical:
        c.level_altitudes = list(np.linspace(100, 0, nl + 1))
    c.delta_tau = [0.03] * nl
    c.single_scat_albedo = [0.99] * nl
    c.set_rayleigh()
    c.tau_user = [0.3]
    c.mu_user = [-0.9, -0.5, -0.2]
    c.phi_user = [float(x) for x in phi]
    c.bc.direct_beam_flux = 1.0
    c.bc.direct_beam_mu = 0.8
    c.bc.surface_albedo = 0.1
    return c


def test_pseudo_spherical_radiance_defect_in_1_2_1():
    # at 37 deg solar zenith sphericity is negligible: fluxes agree, radiances must too, but 1.2.1 returns 2-3x.
    s = disortpp.DisortSolver()
    pp, sph = s.solve(_cfg(False)), s.solve(_cfg(True))
    assert sph.flux_down[-1] == pytest.approx(pp.flux_down[-1], rel=2e-3)
    ratio = np.asarray(sph.intensity)[0] / np.asarray(pp.intensity)[0]
    assert np.all(ratio > 1.5), "disortpp pseudo-spherical radiances changed: re-check before using them"


def test_solve_spectral_keeps_fixed_user_tau():
    # per-wavelength delta_tau overrides do not move tau_user: the 'ground' output of solve_spectral is then taken
    # inside the atmosphere. A per-run solve with tau_user at the bottom gives different values.
    c = _cfg(False)
    taus = [[0.03] * 10, [0.1] * 10]
    res = disortpp.solve_spectral(c, [1e4, 2e4], delta_tau=taus)
    c2 = _cfg(False)
    c2.delta_tau = taus[1]
    c2.tau_user = [1.0]
    ground = disortpp.DisortSolver().solve(c2)
    assert abs(res[1].flux_down[-1] / ground.flux_down[-1] - 1) > 0.05


def test_nakajima_flag_alone_does_not_correct_but_buras_does():
    def run(nak, bur):
        c = disortpp.DisortConfig(1, 16)
        c.flags.use_lambertian_surface = True
        c.flags.use_user_mu = True
        c.flags.use_user_tau = True
        c.flags.intensity_corr_nakajima = nak
        c.flags.intensity_corr_buras = bur
        c.num_user_tau, c.num_user_mu, c.num_phi, c.num_phase_func_moments = 1, 1, 1, 256
        c.allocate()
        c.delta_tau, c.single_scat_albedo = [0.05], [1.0]
        c.phase_function_moments = [list(0.8 ** np.arange(257))]
        c.tau_user, c.mu_user, c.phi_user = [0.05], [-0.6], [0.0]
        c.bc.direct_beam_flux, c.bc.direct_beam_mu, c.bc.surface_albedo = 1.0, 0.6, 0.0
        return np.asarray(disortpp.DisortSolver().solve(c).intensity)[0, 0, 0]

    # exact single scattering in the forward direction: p(1) w tau / (4 pi mu0) exp(-tau/mu0), HG g = 0.8
    g, tau, mu0 = 0.8, 0.05, 0.6
    ss = (1 - g * g) / (1 - g) ** 3 / (4 * np.pi) * tau / mu0 * np.exp(-tau / mu0)
    assert run(False, False) == run(True, False)
    assert run(False, False) / ss < 0.8
    assert run(False, True) / ss == pytest.approx(1.0, abs=0.05)


def test_generator_never_uses_defective_modes():
    src = "\n".join(p.read_text() for p in (pathlib.Path(__file__).parents[2] / "skymodel" / "build").glob("*.py"))
    assert "solve_spectral(" not in src
    assert "use_spherical_beam = True" not in src


@pytest.mark.reference
def test_isolated_nan_of_the_tabulated_correction_is_repaired():
    """disortpp 1.2.1 returns NaN for one direction of one sub-problem in the default build (300 nm sub-problem 5,
    43.374 km, sun 24.606 deg, view zenith 63.75 deg, relative azimuth 0.125 deg). run_disort re-solves that entry:
    the result must be finite and continuous with its neighbours 0.025 deg away (reference: the mean of the two
    azimuth neighbours, within 0.1 %; the radiance changes by 0.07 % over the 0.05 deg between them)."""
    import widesky.skymodel.generator.solver as solver
    from widesky.skymodel.generator.dataset_build import _problems, load_config

    cfg = load_config(pathlib.Path(__file__).parents[2] / "skymodel" / "data" / "default-dataset.json")
    probs, _, _ = _problems(43.374, cfg)
    p = probs[0][5]
    mu0 = np.cos(np.radians(90.0 - 24.606))
    th, ph = np.array([63.75]), np.array([0.1, 0.125, 0.15])
    r, _, _ = solver.run_disort(p, mu0, 0.201, th, ph, cfg.solver_config())
    assert np.isfinite(r).all()
    assert r[0, 1] == pytest.approx(0.5 * (r[0, 0] + r[0, 2]), rel=1e-3)
    # the defect is still there without the repair (if disortpp fixes it, this guard can go)
    r0, _, _ = solver.run_disort(p, mu0, 0.201, th, ph, cfg.solver_config(), repair=False)
    assert np.isnan(r0[0, 1])


def _with_azimuths(n):
    return _cfg(phi=np.linspace(0.0, 180.0, n))


def test_reused_solver_keeps_its_first_azimuth_count_in_1_2_1():
    # a DisortSolver that ran with 12 azimuths returns 12 columns for a later run with 8: the solver module keeps one
    # solver per azimuth count (solver._disort) because of it
    s = disortpp.DisortSolver()
    s.solve(_with_azimuths(12))
    assert np.asarray(s.solve(_with_azimuths(8)).intensity).shape[-1] == 12, \
        "disortpp reuses buffers differently now: re-check solver._disort"


def test_run_disort_with_fewer_azimuths_after_more_matches_a_fresh_solve():
    from widesky.skymodel.generator import solver

    class _Rayleigh:  # a SubProblem-like homogeneous layer (the interface run_disort uses)
        weight = 1.0

        def disort_layers(self):
            mom = np.zeros((4, 17))
            mom[:, 0], mom[:, 2] = 1.0, 0.1
            return np.full(4, 0.05), np.full(4, 0.99), mom

        def phase_table(self):
            return None

    cfg = solver.SolverConfig(n_streams=16, n_moments=16)
    th = np.array([0.0, 40.0, 80.0])
    many, few = np.linspace(0.0, 180.0, 30), np.array([0.0, 90.0, 180.0])
    solver.run_disort(_Rayleigh(), 0.7, 0.2, th, many, cfg)
    r, fd, _ = solver.run_disort(_Rayleigh(), 0.7, 0.2, th, few, cfg)
    solver._SOLVERS.clear()
    ref, fd_ref, _ = solver.run_disort(_Rayleigh(), 0.7, 0.2, th, few, cfg)
    assert r.shape == (3, 3)
    np.testing.assert_allclose(r, ref, rtol=1e-12)
    assert fd == pytest.approx(fd_ref, rel=1e-12)
