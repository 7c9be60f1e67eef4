"""The direct path's vector kernels give the same bits.

The direct path (``method="direct"``) evaluates from a channel-contiguous copy of the coefficients with an
AVX2 kernel (four channels per vector) or, where the processor has AVX-512F, an AVX-512 kernel (eight
channels per vector, up to four directions of one sun interval sharing each sun coefficient load). Both do
per channel the same IEEE operations in the same order, so their values must agree to the bit, and a call
that reuses the kept copy of the coefficients (the third call in a row with the same configurations and
channels) must give the first call's bits. The reference for the values themselves is the spec port in
tests/test_sky_exact.py (1e-12); this file checks that the choice of kernel and of copy changes nothing.
"""

import warnings
from contextlib import contextmanager

import numpy as np
import pytest

from widesky import skymodel
from widesky.skymodel import _core
from widesky.skymodel.synthetic import write_synthetic_dataset

AVX2, AVX512 = 1, 2


def available(impl):
    try:
        _core.direct_impl(impl)
        return True
    except ValueError:
        return False
    finally:
        _core.direct_impl(0)


@contextmanager
def kernel(impl):
    _core.direct_impl(impl)
    try:
        yield
    finally:
        _core.direct_impl(0)


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    path = tmp_path_factory.mktemp("isa") / "isa.dat"
    write_synthetic_dataset(path, altitudes=(0.0, 1500.0), n_channels=13, rank=5, n_sun=24, n_zen=20, n_emph=11,
                            polarisation=True, pol_rank=3, n_pol_sun=12, n_pol_zen=9, roughness=0.3, seed=11)
    m = skymodel.load_dataset(path)
    m.load()
    return m


def directions(seed):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(400, 3))
    v[:200, 2] = np.abs(v[:200, 2])
    c = np.array([0.3, -0.5, 0.8])
    w = c + 0.03 * rng.normal(size=(150, 3))  # close together: long runs in one sun interval
    return np.concatenate([v, w, np.repeat(w[:1], 5, axis=0)])


STATES = [(33.3, 150.0, 47.0, 0.37, 0.0), (-2.5, 20.0, 25.0, 0.8, 700.0), (71.0, 300.0, 120.0, 0.0, 0.0)]
CHANNELS = [[0], [3, 1, 2, 0], list(range(5)), list(range(8)), list(range(12)), list(range(13)), [12, 7, 9]]


def evaluate(m, dirs, state, ch, dtype, what):
    f = skymodel.sky_radiance if what == "radiance" else skymodel.polarisation
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
        return f(m, dirs, *state, channels=ch, dtype=dtype, method="direct", threads=1)


@pytest.mark.parametrize("what", ["radiance", "polarisation"])
def test_kernels_and_kept_copy_agree_to_the_bit(model, what):
    impls = [i for i in (AVX2, AVX512) if available(i)]
    if not impls:
        pytest.skip("no AVX2/FMA on this processor: the direct path runs its scalar loop only")
    dirs = directions(3)
    for state in STATES:
        for ch in CHANNELS:
            for dtype in (np.float64, np.float32):
                runs = []
                for impl in impls:
                    with kernel(impl):
                        # first call: a fresh copy of the call's knots; third: the kept copy of every knot
                        calls = [evaluate(model, dirs, state, ch, dtype, what) for _ in range(3)]
                    runs += calls
                for r in runs[1:]:
                    assert r.dtype == dtype and np.isfinite(r).all()
                    np.testing.assert_array_equal(r.view(np.uint8), runs[0].view(np.uint8))


def test_avx512_kernel_is_chosen_where_available():
    if not available(AVX512):
        pytest.skip("no AVX-512F on this processor")
    with kernel(0):
        assert _core.direct_impl(0) == AVX512


def test_unknown_kernel_is_refused():
    with pytest.raises(ValueError, match="direct_impl"):
        _core.direct_impl(3)
