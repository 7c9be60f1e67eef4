"""The table paths over part of the sky (issue 36): the daytime table is built only over the cells in the
range of the call's angles, and ``auto`` builds it for small calls whose directions are close together.
Reference: the direct path (the reference's arithmetic, itself checked against the spec port in
test_sky_exact.py), to the tolerance the table path is held to there (1e-11 relative, 1e-12 of the largest
value); and the values must not depend on the number of threads."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from widesky import skymodel
from widesky.skymodel.evaluate import KERNEL_INFO
from widesky.skymodel.render import fisheye_disc
from widesky.skymodel.synthetic import write_synthetic_dataset


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    d = tmp_path_factory.mktemp("ranges")
    full = write_synthetic_dataset(d / "full.dat", visibilities=(20, 45.5, 131.8), albedos=(0, 1),
                                   altitudes=(0, 1000, 6000), n_channels=4, channel_start=300, rank=3, n_sun=9,
                                   n_zen=11, n_emph=7, polarisation=True, pol_rank=2, n_pol_sun=6, n_pol_zen=5,
                                   roughness=0.4, seed=11)
    # large random terms: configurations change sign inside cells (the separately clamped terms)
    rough = write_synthetic_dataset(d / "rough.dat", visibilities=(20, 131.8), albedos=(0, 1), n_channels=2,
                                    rank=4, n_sun=8, n_zen=9, n_emph=6, roughness=3.0, seed=9)
    return {"full": skymodel.load_dataset(full), "rough": skymodel.load_dataset(rough)}


def _cluster(rng, zenith_deg, azimuth_deg, spread_deg, n):
    z, a = np.radians(zenith_deg), np.radians(azimuth_deg)
    c = np.array([np.sin(z) * np.sin(a), np.sin(z) * np.cos(a), np.cos(z)])
    v = c + np.radians(spread_deg) * rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1)[:, None]


STATES = [(33.3, 150.0, 47.0, 0.37), (5.0, 10.0, 25.0, 0.9), (71.0, 250.0, 120.0, 0.0)]


@pytest.mark.parametrize("which", ["full", "rough"])
def test_table_over_the_calls_cells_equals_direct(models, which):
    """Clusters of directions (a few degrees wide, so the table covers a few cells) anywhere on the sphere,
    around the sun and at the zenith: the table built over their range gives the direct path's values."""
    m = models[which]
    rng = np.random.default_rng(5)
    centres = [(0.0, 0.0, 0.5), (30.0, 150.0, 2.0), (56.7, 150.0, 1.0), (89.5, 80.0, 3.0), (120.0, 300.0, 4.0),
               (178.0, 10.0, 1.0), (60.0, 20.0, 0.2)]
    clamped = 0
    for state in STATES:
        for zen, az, spread in centres:
            dirs = _cluster(rng, zen, az, spread, 200)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
                a = skymodel.sky_radiance(m, dirs, *state, method="direct")
                b = skymodel.sky_radiance(m, dirs, *state, method="table")
                assert KERNEL_INFO["path"] == 2
                c = skymodel.sky_radiance(m, dirs, *state, method="table", dtype=np.float32)
            np.testing.assert_allclose(b, a, rtol=1e-11, atol=1e-12 * np.abs(a).max())
            np.testing.assert_allclose(c, a, rtol=2e-7, atol=1e-7 * np.abs(a).max())
            clamped += int((a == 0).sum())
            if which == "full":
                p = skymodel.polarisation(m, dirs, *state, method="direct")
                q = skymodel.polarisation(m, dirs, *state, method="table")
                np.testing.assert_allclose(q, p, rtol=1e-10, atol=1e-11 * np.abs(p).max())
    if which == "rough":
        assert clamped > 0  # the clamp is exercised


def test_auto_builds_the_table_for_close_directions(models):
    """A small call of close directions: auto takes the table (cheaper than the direct path there), a
    single direction the direct path; both give the direct path's values."""
    m = models["full"]
    rng = np.random.default_rng(8)
    dirs = _cluster(rng, 40.0, 200.0, 2.0, 300)
    a = skymodel.sky_radiance(m, dirs, *STATES[0], method="direct")
    b = skymodel.sky_radiance(m, dirs, *STATES[0])
    assert KERNEL_INFO["path"] == 2
    np.testing.assert_allclose(b, a, rtol=1e-11, atol=1e-12 * np.abs(a).max())
    skymodel.sky_radiance(m, dirs[:1], *STATES[0])
    assert KERNEL_INFO["path"] == 1


def test_table_paths_do_not_depend_on_the_thread_count(models):
    """Dense up- and side-facing fisheyes, daytime and twilight tables, radiance and polarisation: the
    same values, bit for bit, on 1 and 2 threads (blocks and cell groups do not depend on the threads)."""
    m = models["full"]
    for view in ("up", "side"):
        dirs, _ = fisheye_disc(120, view, 150.0)
        for state in ((33.3, 150.0, 47.0, 0.37), (-2.5, 150.0, 47.0, 0.37)):
            for f in (skymodel.sky_radiance, skymodel.polarisation):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
                    one = f(m, dirs, *state, method="table", threads=1)
                    two = f(m, dirs, *state, method="table", threads=2)
                np.testing.assert_array_equal(one, two)


@pytest.mark.filterwarnings("ignore::widesky.skymodel.SkyStateClampedWarning")
def test_streamed_float32_output_equals_the_rounded_float64_values(models):
    """Above 2**20 float32 values in order, the daytime and twilight tables stream each block of rows to the
    output (non-temporal stores from 16-byte boundaries, plain copies at the edges): the same values as the
    float64 output rounded to float32, bit for bit, into outputs starting 0 to 3 floats past a 16-byte
    boundary, on 1 and 2 threads, and nothing written outside the output."""
    m = models["full"]
    dirs, _ = fisheye_disc(600, "up", 150.0)
    n, nc = dirs.shape[0], m.n_channels
    assert n * nc >= 2**20
    for state, off in ((STATES[0], 0), (STATES[0], 1), (STATES[0], 2), (STATES[0], 3), ((-2.5, 150.0, 47.0, 0.37), 1)):
        ref = skymodel.sky_radiance(m, dirs, *state, method="table").astype(np.float32)
        buf = np.full(n * nc + 8, np.nan, np.float32)
        start = off + (-buf.ctypes.data // 4) % 4  # off floats past a 16-byte boundary
        out = buf[start:start + n * nc].reshape(n, nc)
        for threads in (1, 2):
            out[...] = np.nan
            skymodel.sky_radiance(m, dirs, *state, method="table", dtype=np.float32, out=out, threads=threads)
            np.testing.assert_array_equal(out, ref)
        assert np.isnan(buf[:start]).all() and np.isnan(buf[start + n * nc:]).all()
