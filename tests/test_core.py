"""widesky.core's shared helpers: band averaging, Fresnel and slab optics, atomic writes."""

import os
import stat

import numpy as np
import pytest

from widesky.core.atomic import atomic_outputs, atomic_write
from widesky.core.fresnel import fresnel_interface, invert_slab, slab
from widesky.core.spectral import band_average


def test_band_average_axis_and_outside_modes():
    w = np.array([300.0, 310.0, 320.0])
    v = np.array([[1.0, 2.0, 3.0], [0.0, 0.0, 10.0]])
    # exact for the piecewise-linear curve; the same along axis 0 as along the last axis
    got = band_average(w, v, [300.0, 305.0], [320.0, 315.0])
    np.testing.assert_allclose(got, [[2.0, 2.0], [2.5, 1.25]], rtol=1e-14)
    np.testing.assert_array_equal(band_average(w, v.T, [300.0, 305.0], [320.0, 315.0], axis=0), got.T)
    # beyond the table: 0, the end values held, or an error naming the range
    assert band_average(w, v[0], [290.0], [300.0])[0] == 0.0
    assert band_average(w, v[0], [290.0], [300.0], outside="hold")[0] == pytest.approx(1.0, rel=1e-14)
    assert band_average(w, v[0], [310.0], [330.0], outside="hold")[0] == pytest.approx(2.75, rel=1e-14)
    with pytest.raises(ValueError, match=r"outside the spectrum's range \[300.0, 320.0\] nm"):
        band_average(w, v[0], [310.0], [330.0], outside="raise")
    with pytest.raises(ValueError, match="outside="):
        band_average(w, v[0], [310.0], [320.0], outside="clamp")


def test_fresnel_interface_limits():
    n = 1.5
    rs, rp, ct = fresnel_interface(1.0, n, np.array([1.0, 0.0]))
    assert rs[0] == pytest.approx(0.04, rel=1e-12) and rp[0] == pytest.approx(0.04, rel=1e-12)
    assert rs[1] == 1.0 and rp[1] == 1.0                         # grazing incidence
    rs, rp, ct = fresnel_interface(n, 1.0, np.cos(np.radians(60.0)))   # beyond the critical angle (41.8 deg)
    assert rs == 1.0 and rp == 1.0 and ct == 0.0


def test_slab_inverts():
    wl = np.array([500.0, 1000.0, 2000.0])
    n, k = np.array([1.52, 1.50, 1.48]), np.array([1e-7, 5e-7, 2e-6])
    T, R = slab(n, k, 4.0, wl, [0.0])
    n2, k2 = invert_slab(T[0], R[0], 4.0, wl)
    np.testing.assert_allclose(n2, n, rtol=1e-9)
    np.testing.assert_allclose(k2, k, rtol=1e-6)
    with pytest.raises(ValueError, match="aoi"):
        slab(n, k, 4.0, wl, [91.0])


def test_atomic_write_replaces_on_success_and_cleans_up_on_error(tmp_path):
    target = tmp_path / "out.npz"
    with atomic_write(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".npz" and tmp != target
        np.savez(tmp, a=np.arange(3))
    with np.load(target) as z:
        np.testing.assert_array_equal(z["a"], np.arange(3))
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~umask      # as a plain open() makes it
    with pytest.raises(RuntimeError), atomic_outputs(tmp_path / "a.txt", tmp_path / "b.txt") as (ta, tb):
        ta.write_text("a")
        raise RuntimeError("half-way")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.npz"]       # nothing written, no temporary left
