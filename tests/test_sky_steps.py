"""The per-step sky paths of issue 36 against the ways they replace.

- ``_core.radiance_config_eval`` merges a step's corner tables once per cell it looks into and evaluates steps in
  batches, cell by cell: every value must depend only on its own step and direction (bit for bit the same whether
  a step is evaluated alone, in a batch or on two threads); the values themselves are checked against
  :func:`widesky.skymodel.sky_radiance` in tests/test_sky_tables.py (1e-6 relative).
- ``RadianceTables.direct_normal`` evaluates steps with the same transmittance knots in one kernel call: bit for bit
  :func:`widesky.skymodel.solar_direct_normal` step by step.
- ``patch_radiance(weights=None, profile=w)`` (the all-sky model's uncontracted spectral sky) equals the contraction
  with the columns ``[w | identity]`` it replaces (the first column only setting the circumsolar nodes' solid
  angles) to 1e-12 relative.
- The Perez all-weather patch shape computed in place equals :func:`perez_relative_radiance` averaged over the
  same samples (1e-13 relative).
"""

import numpy as np
import pytest

from widesky import skymodel
from widesky.irradiance.integrator import IntegratorSettings, patch_radiance
from widesky.irradiance.patches import direction_from_angles, reinhart
from widesky.irradiance.perez_sky import perez_patch_shape, perez_relative_radiance, perez_sky_coefficients
from widesky.irradiance.skies import PragueSky, SkyStates
from widesky.skymodel.evaluate import RadianceTables


@pytest.fixture(scope="module")
def model():
    return skymodel.load_dataset()


def _year_like(T=70, seed=4):
    rng = np.random.default_rng(seed)
    el = np.sort(rng.uniform(2.0, 70.0, T))
    az = rng.uniform(60.0, 300.0, T)
    vis = rng.choice([25.0, 60.0, 90.0], T)
    alb = rng.choice([0.1, 0.2, 0.5], T)
    return el, az, vis, alb, np.zeros(T)


def test_config_eval_values_depend_only_on_their_step(model):
    el, az, vis, alb, alt = _year_like()
    d = reinhart(1).subsample(2)[0].reshape(-1, 3)
    rows, wts = np.repeat(np.arange(145), 4), np.full(580, 0.25)
    rt = RadianceTables(model)
    whole = rt.radiance(d, el, az, vis, alb, alt, rows=rows, weights=wts)
    two = RadianceTables(model, threads=2).radiance(d, el, az, vis, alb, alt, rows=rows, weights=wts)
    assert np.array_equal(whole, two)
    for t in (0, 33, 69):
        alone = rt.radiance(d, el[t:t + 1], az[t:t + 1], vis[t:t + 1], alb[t:t + 1], alt[t:t + 1], rows=rows,
                            weights=wts)
        assert np.array_equal(alone[0], whole[t])
    # per-step directions (the circumsolar nodes' path): the same values as the shared directions
    per_step = rt.radiance(np.broadcast_to(d, (el.size,) + d.shape), el, az, vis, alb, alt)
    np.testing.assert_allclose(per_step.reshape(el.size, 145, 4, -1).mean(axis=2), whole, rtol=1e-12, atol=0)


def test_direct_normal_groups_bit_for_bit(model):
    el, az, vis, alb, alt = _year_like()
    got = RadianceTables(model).direct_normal(el, az, vis, alt)
    ref = np.stack([skymodel.solar_direct_normal(model, el[t], az[t], vis[t], 0.2, alt[t]) for t in range(el.size)])
    assert np.array_equal(got, ref)


def test_uncontracted_patch_radiance_is_the_spectral_columns(model):
    sky = PragueSky(model)
    el, az, vis, alb, alt = _year_like(T=24)
    st = SkyStates.create(el, az, vis, alb, alt, earth_sun_distance=np.linspace(0.985, 1.015, 24))
    patches, settings = reinhart(1), IntegratorSettings()
    w = np.asarray(sky.channel_widths, dtype=float)
    cols = np.concatenate([w[:, None], np.eye(w.size)], axis=1)
    L0, d0, c0 = patch_radiance(sky, patches, st, cols, settings)
    L1, d1, c1 = patch_radiance(sky, patches, st, None, settings, profile=w)
    for a, b in ((L0[..., 1:], L1), (d0[:, 1:], d1), (c0[:, 1:], c1)):
        assert a.shape == b.shape
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12 * np.abs(a).max())
    assert np.all(c1.sum(axis=1) > 0)                   # circumsolar light on every (sunlit) step


def test_perez_shape_in_place_equals_the_formula():
    patches = reinhart(1)
    rng = np.random.default_rng(7)
    T = 30
    s = direction_from_angles(rng.uniform(1.0, 89.0, T), rng.uniform(0.0, 360.0, T))
    eps, dl = rng.uniform(1.0, 12.0, T), rng.uniform(0.01, 0.5, T)
    eps[:4] = 1.0                                       # the overcast bin's own forms
    got = perez_patch_shape(patches, s, eps, dl, samples=4)
    d, w = patches.subsample(4)
    w = w / w.sum(axis=1, keepdims=True)
    coef = perez_sky_coefficients(eps, dl, np.arccos(np.clip(s[:, 2], 0.0, 1.0)))
    rel = perez_relative_radiance(d[None, :, :, 2], np.einsum("pnk,tk->tpn", d, s), coef[:, None, None, :])
    lp = np.einsum("tpn,pn->tp", rel, w)
    ref = lp / (lp @ patches.vector[:, 2])[:, None]
    np.testing.assert_allclose(got, ref, rtol=1e-13, atol=0)
