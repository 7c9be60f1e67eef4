"""The ray stages' faster forms (issue 36: the reflected-sun draw in C, per-block Embree calls, row functions
evaluated once per distinct normal, row gathers by ``numpy.take``) give the same numbers, bit for bit, as the numpy
code they replaced, written out here as the references."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import trimesh

from widesky.irradiance import _raysun, make_scene, raystages
from widesky.irradiance.patches import cosine_weights, orthonormal_frame, tregenza
from widesky.irradiance.rays import (_by_distinct_rows, _cosine_directions, _distinct_rows, cast_rays,
                                     reflector_bins, reflector_points, shade_cells)

_spec = importlib.util.spec_from_file_location("_sun_ref", Path(__file__).with_name("test_raystages_sun.py"))
_sun_ref = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_sun_ref)


def _canyon():
    blocks = [trimesh.creation.box(extents=(20, 8, 10)), trimesh.creation.box(extents=(20, 8, 14))]
    blocks[0].apply_translation((0, -9, 5))
    blocks[1].apply_translation((0, 9, 7))
    return make_scene(blocks[0], context=blocks[1], ground_z=0.0).geometry()


def _points(rng, H, planar):
    x = np.column_stack([rng.uniform(-12, 12, H), rng.uniform(-4.5, 4.5, H), rng.uniform(0.01, 9, H)])
    if planar:
        choices = np.array([[0, 1.0, 0], [-0.0, -1.0, -0.0], [0, -1.0, 0], [1.0, 0, 0], [0, 0, 1.0]])
        tn = choices[rng.integers(0, 5, H)]
    else:
        tn = rng.normal(size=(H, 3))
        tn[:, 2] = np.abs(tn[:, 2])
        tn /= np.linalg.norm(tn, axis=1, keepdims=True)
    return x, tn


@pytest.mark.parametrize("planar", [True, False])
@pytest.mark.parametrize("int_ids", [True, False])
def test_cell_sun_blocks_and_integer_identities_bit_for_bit(planar, int_ids, monkeypatch):
    """Integer identities (the first reflection's) and float ones (later reflections'), blocks smaller than the
    points (many Embree calls, a cell's terms spread over blocks) and points given as rows of larger arrays: the
    per-cell loop's numbers."""
    rng = np.random.default_rng(7)
    geometry = _canyon()
    H, n = 5000, 37
    x, tn = _points(rng, H, planar)
    on_g = rng.random(H) < 0.3
    x[on_g, 2] = 0.01
    tn[on_g] = (0.0, 0.0, 1.0)
    bins = reflector_bins()
    ob = np.where(on_g, 0, np.argmax(tn @ bins.T, axis=1)).astype(np.int64)
    ident = rng.integers(0, 2**31, H)
    ident = ident if int_ids else ident.astype(np.float64)
    w = rng.uniform(0.0, 0.05, H)
    pt = rng.integers(0, n, H)
    el, az = np.radians(rng.uniform(1, 80, 300)), np.radians(rng.uniform(0, 360, 300))
    sun_dirs = np.column_stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])
    sun_count = rng.integers(1, 30, 300).astype(float)
    sun_cell, G = shade_cells(sun_dirs)
    ref = _sun_ref._reference(geometry, x, tn, ob, ident, w, on_g, pt, sun_dirs, bins, sun_count, sun_cell, G, n)
    monkeypatch.setattr(raystages, "_SUN_BLOCK", 97)
    rows = rng.permutation(H + 200)[:H]                 # the points as rows of larger arrays
    xa, tna = np.zeros((H + 200, 3)), np.zeros((H + 200, 3))
    xa[rows], tna[rows] = x, tn
    ground_sun, reflect_sun = np.zeros((G, n)), np.zeros((G, n * bins.shape[0]))
    n_rays = raystages._cell_sun(geometry, xa, tna, ob, ident, w, on_g, pt, sun_dirs, bins, sun_count, sun_cell, G,
                                 ground_sun, reflect_sun, rows=rows)
    assert n_rays == ref[2] > 0
    assert np.count_nonzero(ref[0]) > 0 and np.count_nonzero(ref[1]) > 0
    np.testing.assert_array_equal(ground_sun, ref[0])
    np.testing.assert_array_equal(reflect_sun, ref[1])


def test_distinct_rows_bit_for_bit():
    v = np.array([[0, 1.0, 0], [-0.0, 1.0, -0.0], [0.6, 0.8, 0.0]])[np.array([0, 1, 2, 2, 0, 1, 1])]
    rows, nid = _distinct_rows(v)
    assert rows.shape == (3, 3)                          # signed zeros kept apart
    assert np.array_equal(rows[nid].view(np.uint64), v.view(np.uint64))
    many = np.random.default_rng(1).normal(size=(5000, 3))
    assert _distinct_rows(many) == (None, None)          # more than 4,096: evaluated row by row


@pytest.mark.parametrize("k", [1, 2, 5])
def test_row_functions_once_per_distinct_normal(k):
    """Argmax over the orientation bins, the exact projected solid angles and the orthonormal frames, evaluated
    once per distinct normal (one distinct normal: twice, as a matrix product), equal those of every row."""
    rng = np.random.default_rng(k)
    pool = rng.normal(size=(k, 3))
    pool /= np.linalg.norm(pool, axis=1, keepdims=True)
    v = pool[rng.integers(0, k, 3000)]
    bins, patches = reflector_bins(), tregenza()
    for f in (lambda t: np.argmax(t @ bins.T, axis=1), lambda t: cosine_weights(patches, t),
              lambda t: cosine_weights(patches, t, lower=True)):
        assert np.array_equal(_by_distinct_rows(f, v), f(v))
    for a, b in zip(_by_distinct_rows(orthonormal_frame, v), orthonormal_frame(v)):
        assert np.array_equal(a.view(np.uint64), b.view(np.uint64))
    one = v[:1]                                          # a single row: as it is
    assert np.array_equal(_by_distinct_rows(lambda t: t @ bins.T, one), one @ bins.T)


def test_cosine_directions_and_reflector_points_as_before():
    rng = np.random.default_rng(3)
    geometry = _canyon()
    n = 20000
    normals = np.array([[0, 1.0, 0], [0, -1.0, 0], [1.0, 0, 0], [0, 0, 1.0]])[rng.integers(0, 4, n)]
    ids = rng.integers(0, 2**32, n).astype(np.float64)
    # the directions before issue 36
    u1 = np.mod(0.5 + ids * 0.7548776662466927, 1.0)
    u2 = np.mod(0.5 + ids * 0.5698402909980532, 1.0)
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    local = np.column_stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(1 - u1, 0.0))])
    t, b = orthonormal_frame(normals)
    ref = local[:, :1] * t + local[:, 1:2] * b + local[:, 2:3] * normals
    assert np.array_equal(_cosine_directions(normals, ids).view(np.uint64), ref.view(np.uint64))
    # the reflector points before issue 36, for rays cast from above the canyon's ground
    o = np.column_stack([rng.uniform(-15, 15, n), rng.uniform(-4, 4, n), rng.uniform(0.5, 9, n)])
    d = ref * np.where(ref[:, 2:3] > 0, -1.0, 1.0)
    tmax = (geometry["ground_z"] - o[:, 2]) / d[:, 2]
    prim, dist = cast_rays(geometry, o, d, tmax, distance=True)
    t_hit = np.where(prim >= 0, dist, tmax)
    eps = geometry["ray_offset"]
    tn = np.zeros((n, 3))
    tn[prim < 0] = (0.0, 0.0, 1.0)
    scene = prim >= 0
    tn_s = geometry["triangle_normals"][prim[scene]]
    flip = np.sum(tn_s * d[scene], axis=1) > 0
    tn[scene] = np.where(flip[:, None], -tn_s, tn_s)
    x_ref = o + (t_hit - np.minimum(eps, 0.5 * t_hit))[:, None] * d + eps * tn
    assert scene.any() and (~scene).any()
    x, tn2 = reflector_points(geometry, o, d, t_hit, prim)
    assert np.array_equal(x.view(np.uint64), x_ref.view(np.uint64))
    assert np.array_equal(tn2.view(np.uint64), tn.view(np.uint64))


def test_sun_visibility_as_before():
    rng = np.random.default_rng(4)
    geometry = _canyon()
    n, S = 300, 200
    origins = np.column_stack([rng.uniform(-10, 10, n), np.full(n, -4.9), rng.uniform(0.5, 9, n)])
    normals = np.tile([0.0, 1.0, 0.0], (n, 1))
    buried = rng.random(n) < 0.1
    el, az = np.radians(rng.uniform(-5, 80, S)), np.radians(rng.uniform(0, 360, S))
    sun_dirs = np.column_stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])
    ok = (normals @ sun_dirs.T > 0) & ~buried[:, None] & (sun_dirs[:, 2] > 0)[None, :]
    pf, ps = np.nonzero(ok)
    ref = np.zeros((n, S), dtype=bool)
    ref[pf, ps] = ~cast_rays(geometry, origins.astype(np.float32)[pf], sun_dirs.astype(np.float32)[ps],
                             occluded=True)
    vis, n_rays = raystages.sun_visibility(geometry, origins, normals, buried, sun_dirs)
    assert n_rays == pf.size > 0 and ref.any() and not ref[ok].all()
    np.testing.assert_array_equal(vis, ref)


def test_kernel_rejects_inconsistent_arrays():
    z = np.zeros
    with pytest.raises(ValueError, match="_raysun"):    # tn of the wrong length
        _raysun.draw(0, 1, z(4), True, np.array([0, 4], dtype=np.int64), z(1, np.int64), z(1, np.int64),
                     np.ones(1, np.int64), z(1, np.int64), z(1, np.int64), np.array([0, 1], dtype=np.int64),
                     z(1, np.int64), z(1), z(1), z(1025, np.int32), z((1, 3)), z((1, 3), np.float32), z((3, 3)),
                     z((4, 3), np.float32), z((4, 3), np.float32), z((4, 3), np.float32), z(4, np.int64),
                     z(4, np.int32))
    with pytest.raises(IndexError, match="_raysun"):    # a ray's point outside the points
        _raysun.accumulate(1, np.array([9], dtype=np.int64), z(1, np.int32), z(1, bool), z(4, bool),
                           z(4, np.int64), z(4, np.int64), z(4), 1, z(4), z(8))
