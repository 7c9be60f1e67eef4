"""The smoothness check (skymodel.generator.smoothness) and the two fixes it measures (issue 11).

References and tolerances:
- turning points: analytic profiles with known extrema (a cosine over 1.5 periods has 2, a parabola 1, a ripple below
  the 0.5 % hysteresis none);
- an analytic clear sky (the CIE standard clear sky, ISO 15469:2004 type 12 gradation and indicatrix) passes every
  criterion; the same sky with a 5 % ring pattern around the sun (period 3 deg in the angle to the sun) fails the
  almucantar and aureole criteria, and a zenith spot of 5 % fails the zenith criterion;
- the solver: with the Nakajima-Tanaka correction from 256 Legendre moments the 540 nm almucantar at view zenith 80 deg
  (sun 8 deg, 29.2 km) has spurious turning points at zero tolerance (measured 12 at 1 deg steps; all below 0.05 %
  of the radiance, so the 0.5 % check does not see them); with the tabulated phase function
  (Buras-Emde) it has one minimum, the fluxes are identical (the correction changes radiances only) and the aureole
  within 1 deg of the sun agrees within 15 % (measured: up to 13 % at 380 nm, where the 256-term series cannot follow
  the forward peak of the coarse mode, P(0) = 156 at 373 nm; 1.4-2.6 % at 540 nm on the dominant sub-problem);
- the fit (default settings: emphasis held at 1, second-difference penalty 1e-5) of that state passes the check at 380,
  540 and 1260 nm, and stays within 2 % of the solver along the almucantar (measured 0.6 % mean);
- an aureole ray counts only its checked part (above view zenith 85 deg), also where that part starts away from a
  sun below 5 deg;
- the guard band: the solver's turning points counted at half the check's hysteresis let a feature of 0.36 % in
  the solver pass at 0.6 % in the file (it fails when both are counted at 0.5 %), and not over a solver ripple of 0.1 %;
- a solver reference allows exactly the counts it holds at a profile (grid state: its own; between grid states: the
  largest of the bracketing grid states', or, for a pair solved at its own state, that solve's), and the solver's
  own sky at 29.2 km / 8 deg needs no allowance (the solver passes there, measured);
- the elevation-interpolation band: its samples lie where the evaluator looks between grid elevations and no
  direction of the state's sky does, with the radiance of the state's solar vertical at the same angle from the sun
  (analytic aureole); with it the blend of the 17 and 21 deg fits turns on a ray from a 19 deg sun no more than DISORT
  solved at 19 deg (without it 3 times against once, 1620 nm); ``band_min_elevation_deg`` keeps it off below a
  grid elevation, with the fit-cache names of the builds without and with the band (names set in the test);
- the solver's verticals and aureole rays are read on past the checked part's end (an extremum inside it whose
  reversal completes past the end is the sky's own), with analytic skies for both;
- the check flags the first default.dat (from the repository's history) at the states issue 11 names, in most
  channels, and the shipped default.dat (the seventh rebuild) passes it everywhere: every grid state and every state
  between grid points.
"""

import numpy as np
import pytest

from widesky.skymodel.generator import smoothness as S


def test_turning_points_count_reversals_beyond_the_hysteresis():
    x = np.linspace(0.0, 3.0 * np.pi, 400)
    assert S.turning_points(1.0 + 0.02 * np.cos(x)) == 2
    assert S.turning_points((x - 4.0) ** 2 + 1.0) == 1
    assert S.turning_points(np.exp(-x)) == 0
    assert S.turning_points(1.0 + 0.001 * np.cos(x)) == 0  # 0.2 % peak to peak, below the 0.5 % hysteresis
    batch = np.stack([1.0 + 0.02 * np.cos(x), np.exp(-x)])
    assert S.turning_points(batch).tolist() == [2, 0]


def _cie_clear(directions, sun_elevation_deg, ring=0.0, spot=0.0):
    """CIE standard clear sky (type 12: a=-1, b=-0.32, c=10, d=-3, e=0.45) relative radiance at east-north-up
    directions (sun at azimuth 180), with an optional ring ripple around the sun and a zenith spot."""
    v = directions / np.linalg.norm(directions, axis=-1, keepdims=True)
    s = S._enu(np.array(90.0 - sun_elevation_deg), np.array(180.0))
    g = np.arccos(np.clip(v @ s, -1, 1))
    cz = np.maximum(v[..., 2], 1e-3)
    lum = (1 + 10 * (np.exp(-3 * g) - np.exp(-3 * np.pi / 2)) + 0.45 * np.cos(g) ** 2) * (1 - np.exp(-0.32 / cz))
    lum = lum * (1 + ring * np.cos(2 * np.pi * np.degrees(g) / 3.0))
    zen = np.degrees(np.arccos(np.clip(v[..., 2], -1, 1)))
    lum = lum * (1 + spot * np.exp(-(zen / 0.5) ** 2))
    return lum[..., None]


@pytest.mark.parametrize("elevation", [5.0, 30.0, 60.0])
def test_analytic_clear_sky_passes_and_artefacts_fail(elevation):
    d = S.profile_directions(elevation)
    keys = ("almucantar", "vertical", "aureole", "zenith")

    def metrics(**kw):
        rad = {k: _cie_clear(d[k], elevation, **kw) for k in keys}
        return S.profile_metrics(rad, d["aureole_valid"][..., None], elevation)

    clean = metrics()
    assert not S._fails(clean, S.REL_TOL).any(), clean
    rings = metrics(ring=0.05)
    assert rings["almucantar_tp"][0] > S.MAX_ALMUCANTAR_TP
    assert rings["aureole_tp"][0] > S.MAX_AUREOLE_TP
    assert S._fails(rings, S.REL_TOL).all()
    spot = metrics(spot=0.05)
    if 90.0 - elevation >= 15.0:
        assert spot["zenith_spot"][0] > S.ZENITH_SPOT_TOL


def test_an_aureole_ray_rising_from_a_low_sun_counts_only_its_valid_part():
    """With the sun below view zenith 85 deg the rays toward the zenith start in the excluded band and enter the
    checked part later (a suffix): a ray that falls and then rises once (the sky's own gradient) has 1 turning point
    on its valid part, whatever it holds before (reference: the count on the valid part alone)."""
    d = S.profile_directions(2.0)
    valid = d["aureole_valid"]
    assert valid[0, -1] and not valid[0, 0]  # the upward ray: invalid near the sun, valid further out
    n = valid.shape[1]
    x = np.arange(n, dtype=float)
    ray = 1.0 + 0.5 * ((x - 0.7 * n) / n) ** 2  # one minimum inside the valid part
    ray = np.where(valid[0], ray, 50.0)          # anything in the excluded band (the horizon's glare)
    aur = np.repeat(ray[None], 8, axis=0)
    rad = {"almucantar": np.ones(d["almucantar"].shape[:-1] + (1,)),
           "vertical": np.ones(d["vertical"].shape[:-1] + (1,)),
           "aureole": aur[..., None], "zenith": np.ones((len(d["zenith"]), 1))}
    m = S.profile_metrics(rad, valid[..., None], 2.0)
    assert m["aureole_tp"][0] == S.turning_points(ray[valid[0]]) == 1


def test_a_solver_reference_allows_its_own_turning_points_and_no_more():
    """A profile with 2 turning points fails by the limit (1 on an almucantar); with a reference row saying the
    solver's own sky has 2 there it passes, one more turning point still fails, and between grid states the largest
    count of the bracketing grid states applies (reference: the counts set here)."""
    d = S.profile_directions(30.0)
    x = np.linspace(0.0, 1.0, d["almucantar"].shape[1])
    alm = np.ones(d["almucantar"].shape[:-1] + (2,))
    alm[3, :, 0] = 1.0 + 0.05 * np.cos(1.5 * 2 * np.pi * x)   # channel 0, almucantar 3: 2 turning points
    alm[3, :, 1] = 1.0 + 0.05 * np.cos(2.5 * 2 * np.pi * x)   # channel 1: 4
    rad = {"almucantar": alm, "vertical": np.ones(d["vertical"].shape[:-1] + (2,)),
           "aureole": np.repeat(np.linspace(2.0, 1.0, d["aureole"].shape[1])[None, :, None], 8, 0).repeat(2, -1),
           "zenith": np.ones((len(d["zenith"]), 2))}
    tp = S.profile_turning_points(rad, d["aureole_valid"][..., None])
    assert tp["almucantar"][:, 3].tolist() == [2, 4] and tp["aureole"].max() == 0
    grid = ([20.0, 40.0], [20.0, 40.0], [0.0, 1.0])
    ref = S.reference_from_entries(S.reference_entries({(20.0, 20.0, 0.0): {
        "almucantar": np.array([[1] * 3 + [2] + [1] * 5, [1] * 3 + [3] + [1] * 5]),
        "vertical": np.zeros((2, 2), int), "aureole": np.zeros((2, 8), int)}}), grid)
    assert len(ref["tp"][(20.0, 20.0, 0.0)]["almucantar"]) == 2   # only the rows above the limit are kept
    at_grid = S.allowed_turning_points(ref, (20.0, 20.0, 0.0), 2)["almucantar"]
    assert at_grid[:, 3].tolist() == [2, 3] and at_grid[:, 0].tolist() == [1, 1]
    between = S.allowed_turning_points(ref, (28.0, 30.0, 0.5), 2)["almucantar"]   # (20, 20, 0) is a corner
    assert between[:, 3].tolist() == [2, 3]
    elsewhere = S.allowed_turning_points(ref, (40.0, 30.0, 0.5), 2)["almucantar"]  # not a corner
    assert elsewhere[:, 3].tolist() == [1, 1]
    ok = (tp["almucantar"] > at_grid).any(-1)
    assert ok.tolist() == [False, True]   # channel 0 has the reference's 2; channel 1 has 4 > 3


def _ripple_sky(amplitude, zenith_deg, azimuth_deg):
    """A sky constant in view zenith whose almucantars carry 1.5 periods of a cosine in relative azimuth: 2 turning
    points of relative size 2 x ``amplitude`` each (W m-2 sr-1 nm-1, one channel)."""
    az = np.asarray(azimuth_deg, float)
    return np.broadcast_to(1.0 + amplitude * np.cos(3.0 * np.pi * az / 180.0), (len(zenith_deg), len(az)))[..., None]


def test_the_guard_band_allows_a_real_feature_at_the_threshold_and_no_spurious_one():
    """The solver's turning points are counted at half the check's hysteresis (REFERENCE_REL_TOL). Reference: an
    almucantar ripple of 0.36 % peak to peak in the 'solver' (below the check's 0.5 %, above the guard band's 0.25 %)
    that the 'file' shows at 0.6 % is the sky's own and passes; counted at the check's own hysteresis it would fail;
    the same 0.6 % in the file over a solver ripple of 0.1 % (below both) fails."""
    zen, az = np.arange(0.0, 90.1, 2.0), np.arange(0.0, 180.1, 1.0)
    d = S.profile_directions(30.0)
    a_file = 0.003
    alm_az = np.degrees(np.arctan2(d["almucantar"][..., 0], d["almucantar"][..., 1]))
    rel = np.abs((alm_az - 180.0 + 180.0) % 360.0 - 180.0)
    fit = {"almucantar": (1.0 + a_file * np.cos(3.0 * np.pi * rel / 180.0))[..., None],
           "vertical": np.ones(d["vertical"].shape[:-1] + (1,)),
           "aureole": np.repeat(np.linspace(2.0, 1.0, d["aureole"].shape[1])[None, :, None], 8, 0),
           "zenith": np.ones((len(d["zenith"]), 1))}
    tp_fit = S.profile_turning_points(fit, d["aureole_valid"][..., None])["almucantar"]
    assert (tp_fit == 2).all(), tp_fit          # 0.6 % reversals: counted by the check
    grid = ([20.0], [30.0], [0.0])

    def allowed(a_solver, **kw):
        tp = S.solver_turning_points(zen, az, _ripple_sky(a_solver, zen, az), 30.0, **kw)
        ref = S.reference_from_entries(S.reference_entries({(20.0, 30.0, 0.0): tp}), grid)
        return S.allowed_turning_points(ref, (20.0, 30.0, 0.0), 1)["almucantar"]

    assert not (tp_fit > allowed(0.0018)).any()                          # the guard band: the sky's own
    assert (tp_fit > allowed(0.0018, rel_tol=S.REL_TOL, floor_fraction=S.FLOOR_FRACTION)).all()   # same hysteresis
    assert (tp_fit > allowed(0.0005)).all()                              # no such feature in the solver: spurious


def test_the_solver_reference_reads_the_verticals_on_to_the_horizon():
    """A minimum of the solver's sky just inside the checked verticals (89 deg) whose rise only completes past their
    end at 89.5 deg is the solver's own (VERTICAL_REFERENCE_HORIZON_DEG). Reference: a 'solver' antisolar vertical
    falling to 89 deg, then rising 0.17 % by 89.5 deg (below the guard band) and 1.3 % by 90 deg, as the solve at
    20 km, sun 0 deg, albedo 1, 980 nm does: counted, one more turning point than on the checked part alone; the same
    sky falling on to the horizon gets none; a minimum past 89.5 deg is not counted."""
    zen = np.array([0.0, 20.0, 40.0, 60.0, 80.0, 84.0, 86.0, 88.0, 88.5, 89.0, 89.5, 89.75, 89.95])
    az = np.array([0.0, 90.0, 180.0])
    base = np.interp(zen, [0.0, 80.0, 89.0], [1.0, 2.0, 1.0])

    def sky(tail):
        col = base.copy()
        col[zen > 89.0] = np.interp(zen[zen > 89.0], [89.0, 89.5, 89.95], tail)
        return np.repeat(col[:, None], az.size, 1)[..., None]

    rising = S.solver_turning_points(zen, az, sky([1.0, 1.0017, 1.013]), 0.0)["vertical"]
    falling = S.solver_turning_points(zen, az, sky([1.0, 0.999, 0.98]), 0.0)["vertical"]
    window = S.profile_turning_points(S.solver_profiles(zen, az, sky([1.0, 1.0017, 1.013]), 0.0),
                                      S.profile_directions(0.0)["aureole_valid"][..., None],
                                      S.REFERENCE_REL_TOL, S.REFERENCE_FLOOR_FRACTION)["vertical"]
    assert (window == 1).all() and (falling == 1).all()      # the maximum at 80 deg only
    assert (rising == 2).all()                               # + the minimum at 89 deg
    bump = S.solver_turning_points(zen, az, sky([1.0, 0.99, 1.01]), 0.0)["vertical"]   # min at 89.5, inside
    assert (bump == 2).all()
    late = np.interp(zen, [0.0, 80.0, 89.5, 89.75, 89.95], [1.0, 2.0, 1.5, 1.4, 1.5])   # min at 89.75: outside
    late_tp = S.solver_turning_points(zen, az, np.repeat(late[:, None], 3, 1)[..., None], 0.0)["vertical"]
    assert (late_tp == 1).all()


def test_the_solver_reference_reads_the_aureole_rays_on_past_their_end():
    """A maximum of the solver's sky inside the checked aureole rays (10 deg from the sun) whose fall only completes
    past their end at 12 deg is the solver's own (AUREOLE_REFERENCE_READ_ON_DEG). Reference: a 'solver' sky that is a
    function of the angle from the sun alone, falling from the sun to a minimum at 5 deg, rising 2 % to a maximum at
    10 deg and falling 0.18 % by 12 deg (below the guard band) and 2 % by 15 deg, as the solve at 68.1 km, sun 5.25 deg,
    albedo 0.25, 380 nm does on its rays at +-45 deg: one more turning point than on the checked part alone; the same
    sky rising on past 12 deg gets none; a maximum past 12 deg is not counted."""
    sun = 20.0
    zen = np.arange(0.0, 90.0 + 1e-9, 0.1)
    az = np.arange(0.0, 180.0 + 1e-9, 0.1)
    Z, A = np.meshgrid(np.radians(zen), np.radians(az), indexing="ij")
    s_z = np.radians(90.0 - sun)
    gamma = np.degrees(np.arccos(np.clip(np.cos(Z) * np.cos(s_z) + np.sin(Z) * np.sin(s_z) * np.cos(A), -1, 1)))

    def count(knots, values):
        sky = np.interp(gamma, knots, values)[..., None]
        return S.solver_turning_points(zen, az, sky, sun)["aureole"][0]

    g = [0.0, 5.0, 10.0, 12.0, 15.0, 40.0]
    falling_late = [2.0, 1.0, 1.02, 1.02 * (1 - 0.0018), 1.02 * 0.98, 0.9]
    window = S.profile_turning_points(
        S.solver_profiles(zen, az, np.interp(gamma, g, falling_late)[..., None], sun),
        S.profile_directions(sun)["aureole_valid"][..., None], S.REFERENCE_REL_TOL, S.REFERENCE_FLOOR_FRACTION)
    assert (window["aureole"][0] == 1).all(), window["aureole"]       # the minimum at 5 deg only
    assert (count(g, falling_late) == 2).all()                         # + the maximum at 10 deg
    rising = [2.0, 1.0, 1.02, 1.03, 1.04, 1.1]
    assert (count(g, rising) == 1).all()
    late = count([0.0, 5.0, 13.0, 15.0, 40.0], [2.0, 1.0, 1.03, 1.0, 0.9])   # maximum at 13 deg: outside
    assert (late == 1).all()


needs_data = pytest.mark.reference         # the generator's inputs: reference data


@pytest.fixture(scope="module")
def solved_channels():
    """Solver radiance at 29.2 km, sun 8 deg, channels 380 / 540 / 1260 nm, on the build's fit directions and on
    the 80 deg almucantar (1 deg steps), with the tabulated and the Legendre-series intensity correction."""
    from widesky.skymodel.generator.dataset_build import fit_directions, load_config, _problems
    from widesky.skymodel.generator.solver import SolverConfig, run_disort

    cfg = load_config("skymodel/data/default-dataset.json")
    probs, et, _ = _problems(29.2, cfg)
    th, ph = fit_directions(8.0, cfg.zenith_step_deg)
    az = np.arange(0.0, 180.01, 1.0)
    mu0 = np.sin(np.radians(8.0))
    out = {}
    for name, sc in (("tab", SolverConfig(16, 256, True)), ("nt", SolverConfig(16, 256, True, tabulated_phase=False))):
        grid, alm, flux = [], [], []
        for c in (2, 6, 24):
            g = np.zeros((len(th), len(ph)))
            a = np.zeros((1, len(az)))
            f = 0.0
            for p in probs[c]:
                r, fd, _ = run_disort(p, mu0, 0.0, th, ph, sc)
                g += p.weight * r
                r2, _, _ = run_disort(p, mu0, 0.0, np.array([80.0]), az, sc)
                a += p.weight * r2
                f += p.weight * fd
            grid.append(g * et[c])
            alm.append(a[0] * et[c])
            flux.append(f)
        out[name] = {"grid": np.stack(grid, -1), "alm": np.stack(alm, -1), "flux": np.array(flux)}
    out["zenith"], out["azimuth"], out["az_alm"] = th, ph, az
    return out


@needs_data
@pytest.mark.slow
def test_tabulated_phase_correction_removes_the_solver_rings(solved_channels):
    tab, nt = solved_channels["tab"], solved_channels["nt"]
    # at zero tolerance: the ringing is small in the channel sums (below the check's 0.5 % hysteresis)
    tp_nt = S.turning_points(nt["alm"].T, 0.0, 0.0)
    tp_tab = S.turning_points(tab["alm"].T, 0.0, 0.0)
    assert tp_nt[1] > 3, tp_nt          # 540 nm: the 256-moment series rings
    assert np.all(tp_tab <= 1), tp_tab  # one minimum along the almucantar
    np.testing.assert_allclose(tab["flux"], nt["flux"], rtol=1e-12)
    # aureole: the first zenith rows around the sun (sun zenith 82 deg), azimuths within 2 deg
    th, ph = solved_channels["zenith"], solved_channels["azimuth"]
    near = (np.abs(th - 82.0) <= 1.0)[:, None] & (ph <= 2.0)[None, :]
    np.testing.assert_allclose(tab["grid"][near], nt["grid"][near], rtol=0.15)


@needs_data
@pytest.mark.slow
def test_the_solvers_own_sky_at_8_deg_is_within_the_limits(solved_channels):
    """The reference the check can allow (solver_turning_points, log-bilinear from the build's grid) has no profile
    beyond the limits at 29.2 km, sun 8 deg, 380 / 540 / 1260 nm (measured: the solver passes there), so it adds no
    allowance where the sky is plain."""
    tp = S.solver_turning_points(solved_channels["zenith"], solved_channels["azimuth"],
                                 solved_channels["tab"]["grid"], 8.0)
    assert S.reference_entries({(29.2, 8.0, 0.0): tp}) == [], tp


@needs_data
@pytest.mark.slow
def test_default_fit_settings_give_a_smooth_accurate_sky(solved_channels):
    from widesky.skymodel.evaluate import reference_angles
    from widesky.skymodel.generator.dataset_build import config_knots, fit_state, load_config
    from widesky.skymodel.generator.fit import RadianceFit

    cfg = load_config("skymodel/data/default-dataset.json")
    br = config_knots(cfg)
    sun, zen, emph, _ = fit_state(cfg, solved_channels["zenith"], solved_channels["azimuth"],
                                  solved_channels["tab"]["grid"], 8.0)
    d = S.profile_directions(8.0)
    rad = {}
    for k in ("almucantar", "vertical", "aureole", "zenith"):
        a = reference_angles(d[k].reshape(-1, 3), 8.0, 180.0)
        rad[k] = np.stack([RadianceFit(sun[c], zen[c], emph[c], 0).evaluate(a["gamma"], a["zero"], a["zero"], *br)
                           for c in range(3)], -1).reshape(d[k].shape[:-1] + (3,))
    m = S.profile_metrics(rad, d["aureole_valid"][..., None], 8.0)
    assert not S._fails(m, S.REL_TOL).any(), m
    # accuracy along the held-out 80 deg almucantar
    az = solved_channels["az_alm"]
    from widesky.skymodel.evaluate import directions_from_angles
    a = reference_angles(directions_from_angles(np.full(len(az), 80.0), 180.0 + az), 8.0, 180.0)
    fit = np.stack([RadianceFit(sun[c], zen[c], emph[c], 0).evaluate(a["gamma"], a["zero"], a["zero"], *br)
                    for c in range(3)], -1)
    ref = solved_channels["tab"]["alm"]
    assert np.mean(np.abs(fit / ref - 1)) < 0.02


@needs_data
@pytest.mark.slow
def test_sun_knot_midpoints_remove_the_scallops_on_a_low_sun_aureole_ray():
    """The product form's piecewise-linear factors scallop along the ray rising from a low sun, and halving the
    sun-knot intervals at 0.5-9.5 deg removes it. Reference: the exact singly scattered sky in spherical shells (the
    part of a split low-sun state that carries the aureole; 20 km, sun 3 deg, 500 and 540 nm) solved on the build's
    fit grid, fitted with the default dataset's settings, and solved again directly along the check's ray (position
    angle 0: azimuth 0, view zenith 85-75 deg, as checked). Measured: the fit with the configuration's earlier knots
    has 4 turning points at 540 nm where the solver's ray has none; with the midpoints none (and at 500 nm 2, as the
    solver's)."""
    from dataclasses import replace

    from widesky.skymodel.evaluate import reference_angles
    from widesky.skymodel.generator.dataset_build import config_knots, fit_directions, fit_state, load_config
    from widesky.skymodel.generator.dataset_mc import single_scatter
    from widesky.skymodel.generator.fit import RadianceFit

    cfg = load_config("skymodel/data/default-dataset.json")
    cfg = replace(cfg, sun_knot_midpoints_deg=None, sun_knot_refine_deg=None)   # the knots before the midpoints
    mid = replace(cfg, sun_knot_midpoints_deg=(0.5, 9.5))
    ele, ch = 3.0, [5, 6]
    th, ph = fit_directions(ele)
    rad = single_scatter(20.0, ele, th, ph, cfg, channels=ch)
    d = S.profile_directions(ele)
    ray = d["aureole"][0][d["aureole_valid"][0]]     # the checked part, below view zenith 85 deg
    ray_zen = np.degrees(np.arccos(ray[:, 2]))
    exact = single_scatter(20.0, ele, ray_zen, [0.0], cfg, channels=ch)[:, 0, :]        # (48, 2)
    tp_exact = S.turning_points(exact.T)
    a = reference_angles(ray, ele, 180.0)
    tp = {}
    for name, c in (("knots", cfg), ("midpoints", mid)):
        br = config_knots(c)
        sun, zen, emph, _ = fit_state(c, th, ph, rad, ele)   # with the midpoints, samples filling the halved cells
        fit = np.stack([RadianceFit(sun[k], zen[k], emph[k], 0).evaluate(a["gamma"], a["zero"], a["zero"], *br)
                        for k in range(len(ch))], -1)
        tp[name] = S.turning_points(fit.T)
    assert tp_exact[1] <= 1, tp_exact    # 540 nm: falls from the sun (500 nm: 2, the sky's own band above the horizon)
    assert tp["knots"][1] >= tp_exact[1] + 2, (tp, tp_exact)      # the scallops at 540 nm
    assert np.all(tp["midpoints"] <= np.maximum(tp_exact, S.MAX_AUREOLE_TP)), (tp, tp_exact)


@pytest.mark.slow
def test_default_dataset_passes_the_smoothness_check():
    """The whole check (every grid state and every state between grid points, all channels with measurable energy:
    about 15 s) against the solver's own turning points and the between-grid solves that the build wrote into the
    sidecar."""
    import json

    from widesky import skymodel
    from widesky.skymodel.dataset import default_dataset_path

    model = skymodel.load_dataset()
    meta = json.loads(default_dataset_path().with_name("default.dat.json").read_text())
    sref = meta["smoothness_reference"]
    assert sref["rel_tol"] == S.REFERENCE_REL_TOL   # rows counted with the guard band and today's read-on rule
    assert sref["aureole_read_on_deg"] == S.AUREOLE_REFERENCE_READ_ON_DEG
    assert tuple(sref["vertical_read_on_deg"]) == S.VERTICAL_REFERENCE_HORIZON_DEG
    ref = S.reference_from_entries(meta["smoothness_reference"]["rows"],
                                   (model.visibilities, model.elevations, model.albedos),
                                   meta.get("smoothness_between_reference"))
    summary = S.summarise(S.check_dataset(model, reference=ref), model.wavelengths)
    # the sidecar's summary is this check's (the build ran it on the same file)
    for g in ("grid", "between"):
        assert summary[g]["failing_pairs"] == meta["smoothness"][g]["failing_pairs"], (g, summary[g])
    assert summary["grid"]["failing_pairs"] == 0 and summary["between"]["failing_pairs"] == 0, summary


def test_band_samples_lie_in_the_interpolation_band_and_copy_the_solar_vertical():
    """The elevation-interpolation band of a grid state (dataset_build.band_samples): every sample is a pair (gamma,
    view zenith) that no direction of the state's own sky has, gamma < |zenith - zs|, and that a sun up to the
    neighbouring grid elevation asks for, gamma >= |zenith - zs| - delta on that side; its value is the radiance at
    the same gamma on the state's solar vertical. Reference: a sky that depends on gamma alone (an analytic aureole,
    1 / (gamma + 1 deg)), whose band values must equal that function of the sample's gamma (within 0.5 %: PCHIP
    interpolation in log radiance along the vertical); no band without neighbours."""
    from widesky.skymodel.evaluate import direction_from_zenith, reference_angles
    from widesky.skymodel.generator.dataset_build import BAND_GAMMAS_DEG, band_samples, fit_directions

    ele = 17.0
    th, ph = fit_directions(ele)
    T, P = np.meshgrid(th, ph, indexing="ij")
    g = np.degrees(reference_angles(direction_from_zenith(T.ravel(), 180.0 + P.ravel()), ele, 180.0)["gamma"])
    rad = (1.0 / (g + 1.0)).reshape(len(th), len(ph), 1)
    b = band_samples(th, ph, rad, ele, (4.0, 3.5), 15.0)
    zs = 90.0 - ele
    gam, zen = np.degrees(b["gamma"]), np.degrees(b["zero"])
    assert len(gam) > 20 and gam.max() <= 15.0 and np.isin(np.round(gam, 6), np.round(BAND_GAMMAS_DEG, 6)).all()
    d = np.abs(zen - zs)   # the altitude-corrected zenith is within 0.3 deg of the view zenith here
    assert np.all(gam < d + 0.3) and np.all(gam >= d - np.where(zen < zs, 4.0, 3.5) - 0.3)
    np.testing.assert_allclose(b["values"][:, 0], 1.0 / (gam + 1.0), rtol=5e-3)
    assert len(band_samples(th, ph, rad, ele, (0.0, 0.0), 15.0)["gamma"]) == 0


def test_band_min_elevation_keeps_the_band_off_below_it_and_the_cache_names_of_both_kinds_of_state():
    """``band_min_elevation_deg`` (dataset_build.has_band): the band only for grid elevations at or above it. A state
    below it is fitted and cached exactly as without the band (the same fit-cache name), one at or above it exactly
    as with the band everywhere (the same name), so the two earlier builds' cached fits serve it; the key needs
    ``band_max_gamma_deg`` and is written to the sidecar only where set (reference: the names and values set here)."""
    from dataclasses import replace

    from widesky.skymodel.generator.dataset_build import BuildConfig, fit_file, has_band

    plain = BuildConfig()
    band = replace(plain, band_max_gamma_deg=15.0, band_weight=0.03)
    part = replace(band, band_min_elevation_deg=10.5)
    assert not has_band(plain, 20.0) and has_band(band, 0.0) and has_band(band, 20.0)
    assert not has_band(part, 8.0) and has_band(part, 10.5) and has_band(part, 90.0)
    assert fit_file(part, 20.0, 8.0) == fit_file(plain, 20.0, 8.0) != fit_file(band, 20.0, 8.0)
    assert fit_file(part, 20.0, 10.5) == fit_file(band, 20.0, 10.5) != fit_file(plain, 20.0, 10.5)
    assert "band_min_elevation_deg" not in band.to_dict() and part.to_dict()["band_min_elevation_deg"] == 10.5
    with pytest.raises(ValueError, match="band_min_elevation_deg"):
        replace(plain, band_min_elevation_deg=10.5)
    with pytest.raises(ValueError, match="band_min_elevation_deg"):
        replace(band, band_min_elevation_deg=95.0)


@needs_data
def test_the_interpolation_band_removes_the_extra_turning_points_between_17_and_21_deg():
    """Between grid elevations the evaluator blends the bracketing states' fits at the query's own angles. Reference:
    DISORT (the build's solver and settings) at 20 km, albedo 0, 1620 nm, solved at 17, 21 and 19 deg on the build's
    fit directions. The ray from a sun at 19 deg toward the horizon (position angle 180 deg) in the blend of the 17
    and 21 deg fits turns 3 times without the band (measured, with the fifth rebuild's knots) where the sky solved at
    19 deg turns once; with the band (out to 15 deg from the sun, weight 0.03) the blend turns no more than the solve,
    and so it does without the band with the shipped knots (the zenith-knot intervals at 80-89.7 deg halved, and
    since the seventh rebuild the sun-knot intervals at 3.5-8.5 deg halved again: measured once each)."""
    from dataclasses import replace

    from widesky.skymodel.evaluate import reference_angles
    from widesky.skymodel.generator.dataset_build import config_knots, fit_state, load_config, solve_state
    from widesky.skymodel.generator.fit import RadianceFit

    shipped = load_config("skymodel/data/default-dataset.json")
    cfg = replace(shipped, zenith_knot_midpoints_deg=None, sun_knot_refine_deg=None)   # the fifth rebuild's knots
    ch = [33]   # 1620 nm
    solved = {e: solve_state(20.0, e, cfg, channels=ch) for e in (17.0, 19.0, 21.0)}
    d = S.profile_directions(19.0)
    ray = d["aureole"][4]
    a = reference_angles(ray, 19.0, 180.0)
    tp = {}
    for name, c in (("no band", replace(cfg, band_max_gamma_deg=None)),
                    ("band", replace(cfg, band_max_gamma_deg=15.0, band_weight=0.03)),
                    ("shipped", shipped)):
        br = config_knots(c)
        blend = 0.0
        for e in (17.0, 21.0):
            s = solved[e]
            sun, zen, emph, _ = fit_state(c, s["zenith"], s["azimuth"], s["radiance"][..., ch], e)
            blend = blend + 0.5 * RadianceFit(sun[0], zen[0], emph[0], 0).evaluate(a["gamma"], a["zero"], a["zero"],
                                                                                  *br)
        tp[name] = int(S.turning_points(blend))
    s = solved[19.0]
    own = S.solver_turning_points(s["zenith"], s["azimuth"], s["radiance"][..., ch], 19.0)["aureole"][0, 4]
    assert d["aureole_valid"][4].all()
    assert own <= S.MAX_AUREOLE_TP and tp["no band"] > own + 1, (tp, own)
    assert tp["band"] <= max(own, S.MAX_AUREOLE_TP), (tp, own)
    assert tp["shipped"] <= max(own, S.MAX_AUREOLE_TP), (tp, own)


def test_a_between_state_solved_at_itself_replaces_the_bracketing_allowance():
    """A (state, channel) pair between grid points that the build solved at its own state
    (smoothness_between.between_reference) is judged against that solve, in both directions: where the solve turns
    twice the pair may (though no bracketing grid state allows it), and where the bracketing grid states allow 3 but
    the solve has none, the limit applies; other channels and states keep the bracketing rule (reference: the counts
    set here)."""
    grid = ([20.0, 40.0], [20.0, 40.0], [0.0, 1.0])
    rows = [[20.0, 20.0, 0.0, 1, "almucantar", 3, 3]]                       # a grid corner allows 3 on channel 1
    state = (28.0, 30.0, 0.5)
    between = {"examined": [[28.0, 30.0, 0.5, 0], [28.0, 30.0, 0.5, 1]],
               "rows": [[28.0, 30.0, 0.5, 0, "aureole", 2, 2]]}             # the own solve: 2 on channel 0's ray 2
    plain = S.allowed_turning_points(S.reference_from_entries(rows, grid), state, 3)
    ref = S.reference_from_entries(rows, grid, between)
    own = S.allowed_turning_points(ref, state, 3)
    assert plain["aureole"][0, 2] == 1 and own["aureole"][0, 2] == 2
    assert plain["almucantar"][1, 3] == 3 and own["almucantar"][1, 3] == S.MAX_ALMUCANTAR_TP
    assert own["almucantar"][2, 3] == 1 and own["aureole"][2, 2] == 1         # channel 2 was not solved: unchanged
    other = S.allowed_turning_points(ref, (32.0, 30.0, 0.5), 3)             # another state between: bracketing rule
    assert other["almucantar"][1, 3] == 3
    assert S.allowed_turning_points(ref, state, 3, own=False)["almucantar"][1, 3] == 3


def test_turning_point_indices_are_the_counted_extrema():
    """The diagnostic positions agree with the vectorised count, and sit at the analytic extrema (reference: a cosine
    over 1.5 periods on 400 samples has its minimum at x = pi and its maximum at 2 pi)."""
    x = np.linspace(0.0, 3.0 * np.pi, 400)
    y = 1.0 + 0.02 * np.cos(x)
    idx = S.turning_point_indices(y)
    assert len(idx) == S.turning_points(y) == 2
    np.testing.assert_allclose(x[idx], [np.pi, 2 * np.pi], atol=x[1] - x[0])
    rng = np.random.default_rng(3)
    for _ in range(50):
        r = np.cumsum(rng.normal(size=120)) * 0.01 + 5.0
        for tol in (0.0025, 0.005, 0.02):
            assert len(S.turning_point_indices(r, tol)) == S.turning_points(r, tol)


FIRST_FILE_COMMIT = "aec288f"
"""The commit holding the default.dat that issue 11 was filed against (the first file: 29,652,372 bytes)."""


@pytest.fixture(scope="module")
def first_file(tmp_path_factory):
    """The first default.dat, from the repository's history (skips where the checkout has no history)."""
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    out = tmp_path_factory.mktemp("first") / "first.dat"
    try:
        blob = subprocess.run(["git", "-C", str(root), "show", f"{FIRST_FILE_COMMIT}:skymodel/data/default.dat"],
                              capture_output=True, check=True, timeout=120).stdout
    except (OSError, subprocess.SubprocessError):
        pytest.skip(f"the first default.dat (commit {FIRST_FILE_COMMIT}) is not in this checkout's history")
    out.write_bytes(blob)
    return out


@pytest.mark.slow
def test_the_check_flags_the_file_the_issue_was_filed_against(first_file):
    """Issue 11: the check must flag the first file. Against the shipped file's own solver reference (guard band
    included) it fails at the states the issue names (measured: 29.2 km / 8 deg, 13 turning points on the 540 nm
    80 deg almucantar; 40 km / 45 deg, a 110 % zenith spot at 1260 nm), in most checked channels."""
    import json

    from widesky import skymodel
    from widesky.skymodel.dataset import default_dataset_path

    old = skymodel.load_dataset(first_file)
    assert len(old.elevations) == 17 and len(old.visibilities) == 11   # the same grid as today's file
    meta = json.loads(default_dataset_path().with_name("default.dat.json").read_text())
    ref = S.reference_from_entries(meta["smoothness_reference"]["rows"],
                                   (old.visibilities, old.elevations, old.albedos))
    res = S.check_states(old, [(29.2, 8.0, 0.5), (40.0, 45.0, 0.3), (30.0, 8.0, 0.3)], reference=ref)
    wl = np.asarray(old.wavelengths)
    for r in res:
        assert r["fails"][r["checked"]].mean() > 0.5, (r["visibility"], r["elevation"], r["fails"].sum())
    assert res[0]["fails"][wl == 540.0].all() and res[1]["fails"][wl == 1260.0].all()
    assert res[1]["zenith_spot"][wl == 1260.0][0] > 0.5
