"""The fitter that turns sampled skies into the Prague Sky Model's form (groundwork of the default dataset).

Reference: a configuration of a synthetic dataset is exactly of the model's form, so fitting its
radiance with the same knots and rank must reproduce it; tolerance 2 % normalised mean absolute error on
held-out directions (the emphasis factor and the zenith factor share the zero angle when the sun is up, so
the alternation converges to a near-equivalent, not the identical, factorisation).
"""

import numpy as np
import pytest

import skymodel
from skymodel.generator.fit import fit_radiance, fit_transmittance, hat_weights
from skymodel.synthetic import write_synthetic_dataset

pytest.importorskip("scipy")


def test_hat_weights_reproduce_linear_interpolation():
    knots = np.array([0.0, 0.3, 1.0, 2.5])
    c = np.array([1.0, -2.0, 4.0, 0.5])
    x = np.array([-1.0, 0.0, 0.1, 0.3, 0.99, 2.5, 3.0])
    i, lo, hi = hat_weights(x, knots)
    np.testing.assert_allclose(c[i] * lo + c[i + 1] * hi, np.interp(x, knots, c), rtol=1e-14, atol=1e-15)


def test_fit_recovers_a_model_configuration(tmp_path):
    path = write_synthetic_dataset(tmp_path / "t.dat", visibilities=(20, 131.8), albedos=(0.0, 1.0), n_channels=6,
                                   rank=4, n_sun=20, n_zen=18, n_emph=10, seed=4)
    m = skymodel.load_dataset(path)
    el = float(m.elevations[8])  # grid values: a single configuration
    rng = np.random.default_rng(1)

    def sample(n):
        zen = np.degrees(np.arccos(rng.uniform(0.0, 1.0, n)))
        az = rng.uniform(0, 360, n)
        d = skymodel.directions_from_angles(zen, az)
        gamma = np.arccos(np.clip(d @ skymodel.sun_direction(el, 180.0), -1, 1))
        return gamma, np.radians(zen), skymodel.sky_radiance(m, d, el, 180.0, 20.0, 0.0)

    g, z, L = sample(3000)
    gt, zt, Lt = sample(2000)
    for ch in (0, 3, 5):
        f = fit_radiance(g, z, z, L[:, ch], m.sun_breaks, m.zenith_breaks, m.emph_breaks, 4)
        pred = f.evaluate(gt, zt, zt, m.sun_breaks, m.zenith_breaks, m.emph_breaks)
        held_out = np.abs(pred - Lt[:, ch]).sum() / Lt[:, ch].sum()
        assert f.nmae < 0.02 and held_out < 0.02, (ch, f.nmae, held_out)


def test_transmittance_factorisation_is_exact_for_low_rank():
    rng = np.random.default_rng(2)
    U = rng.uniform(0, 0.5, (2, 7, 5, 2))
    V = rng.uniform(0, 1, (3, 2, 4, 2))
    x = np.einsum("adgr,vacr->vacdg", U, V)  # (vis, alt, ch, d, a) within [0, 1]
    Uf, Vf, err = fit_transmittance(x, 2)
    assert err < 1e-6
    assert Uf.shape == (2, 7, 5, 2) and Vf.shape == (3, 2, 4, 2)


def test_refinement_never_increases_the_error():
    """The alternating-least-squares refinement (refine=2) keeps a result only when it lowers the weighted absolute
    error on the samples, so its NMAE is at most that of the plain fit (reference: the plain fit itself)."""
    rng = np.random.default_rng(7)
    g = rng.uniform(0, np.pi, 2500)
    z = np.arccos(rng.uniform(0.02, 1, 2500))
    y = (1 + 5 * np.exp(-g / 0.15)) * (1 + 1 / np.cos(z) ** 0.7) * (1 + 0.3 * np.cos(g) ** 2)
    sb = np.pi * np.linspace(0, 1, 20) ** 2
    zb = 0.5 * np.pi * (1 - (1 - np.linspace(0, 1, 14)) ** 1.6)
    eb = 0.5 * np.pi * (1 - (1 - np.linspace(0, 1, 8)) ** 1.6)
    plain = fit_radiance(g, z, z, y, sb, zb, eb, 2, iterations=3)
    refined = fit_radiance(g, z, z, y, sb, zb, eb, 2, iterations=3, refine=2)
    assert refined.nmae <= plain.nmae + 1e-12
    assert refined.nmae < 0.05


@pytest.mark.parametrize("order", [1, 2])
def test_banded_penalty_matches_the_dense_difference_operators(order):
    """The banded storage of the smoothness penalty equals the dense quadratic form built from difference matrices
    (reference: ||D_sun M||^2 + ||M D_zen^T||^2 with D of the stated order along the sun axis and second
    differences along the zenith axis), and the second-order penalty vanishes on M linear along the sun axis."""
    from skymodel.generator.fit import _regulariser_banded

    ns, nz = 6, 5
    band = nz + 1 if order == 1 else 2 * nz
    ab = _regulariser_banded(ns, nz, band, order)
    N = ns * nz
    dense = np.zeros((N, N))
    for d in range(band + 1):
        idx = np.arange(N - d)
        dense[idx, idx + d] = ab[band - d, d:]
        dense[idx + d, idx] = ab[band - d, d:]

    def diff(n, k):
        return np.diff(np.eye(n), n=k, axis=0)

    Ds, Dz = diff(ns, order), diff(nz, 2)
    ref = np.kron(Ds.T @ Ds, np.eye(nz)) + np.kron(np.eye(ns), Dz.T @ Dz)
    np.testing.assert_allclose(dense, ref, atol=1e-12)
    linear = np.outer(np.arange(ns, dtype=float), np.ones(nz)).ravel()  # M[i, j] = i
    q = linear @ dense @ linear
    assert q == (pytest.approx(0.0, abs=1e-12) if order == 2 else pytest.approx(nz * (ns - 1)))


def test_sun_penalty_order_is_checked():
    g = np.linspace(0, np.pi, 50)
    z = np.linspace(0, 1.5, 50)
    kn = np.linspace(0, np.pi, 5)
    with pytest.raises(ValueError, match="sun_penalty_order"):
        fit_radiance(g, z, z, np.ones(50), kn, kn / 2, kn / 2, 1, sun_penalty_order=3)


def test_build_config_refuses_a_bad_sun_penalty_order_before_solving(tmp_path):
    import json
    from pathlib import Path

    from skymodel.generator.dataset_build import load_config

    cfg = json.loads((Path(__file__).parents[1] / "skymodel" / "data" / "default-dataset.json").read_text())
    cfg["sun_penalty_order"] = 3
    (tmp_path / "bad.json").write_text(json.dumps(cfg))
    with pytest.raises(ValueError, match="sun_penalty_order=3"):
        load_config(tmp_path / "bad.json")
