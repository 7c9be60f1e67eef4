"""The reflected sun's sampling visits its points by orientation bin (issue 36, ``raystages._cell_sun``): the
same rays and the same sums, bit for bit, as the loop it replaced (written out below as the reference: per shading
cell, every point with a positive cell weight in its bin draws a sun bin, those in front of it cast a ray, the
lit ones add their weight in the points' order)."""

import numpy as np
import pytest
import trimesh

from widesky.irradiance import make_scene
from widesky.irradiance.rays import _clear_dni, _fbincount, cast_rays, reflector_bins, shade_cells
from widesky.irradiance.raystages import _cell_sun


def _reference(geometry, x, tn, ob, ident, w, on_g, pt, sun_dirs, bins, sun_count, sun_cell, G, n):
    """The per-cell loop before issue 36 (its later-reflection form), in the points' own order."""
    B = bins.shape[0]
    ground_sun, reflect_sun = np.zeros((G, n)), np.zeros((G, n * B))
    el_b = np.degrees(np.arcsin(np.clip(sun_dirs[:, 2], -1.0, 1.0)))
    n_rays = 0
    for g in range(G):
        cg = np.nonzero(sun_cell == g)[0]
        if cg.size == 0:
            continue
        wq = (sun_count[cg] * _clear_dni(el_b[cg]))[None, :] * np.maximum(bins @ sun_dirs[cg].T, 0.0)
        cdf = np.cumsum(wq, axis=1)
        tot = cdf[:, -1]
        j = np.nonzero(tot[ob] > 0)[0]
        u = np.mod(0.5 + (ident[j] + 7919 * (g + 1)) * 0.6180339887498949, 1.0)
        pick = np.empty(j.size, dtype=np.int64)
        for b in np.unique(ob[j]):
            m = ob[j] == b
            pick[m] = np.minimum(np.searchsorted(cdf[b], u[m] * tot[b], side="right"), cg.size - 1)
        sd = sun_dirs[cg[pick]]
        front = np.nonzero(np.sum(tn[j] * sd, axis=1) > 0)[0]
        if front.size == 0:
            continue
        jj = j[front]
        lit = ~cast_rays(geometry, x[jj].astype(np.float32), sd[front].astype(np.float32), occluded=True)
        n_rays += front.size
        wl = w[jj] * lit
        gg = on_g[jj]
        ground_sun[g] += _fbincount(pt[jj[gg]], weights=wl[gg], minlength=n)
        reflect_sun[g] += _fbincount(pt[jj[~gg]] * B + ob[jj[~gg]], weights=wl[~gg], minlength=n * B)
    return ground_sun, reflect_sun, n_rays


@pytest.mark.parametrize("planar", [True, False])
def test_cell_sun_equals_the_per_cell_loop_bit_for_bit(planar):
    rng = np.random.default_rng(36)
    blocks = [trimesh.creation.box(extents=(20, 8, 10)), trimesh.creation.box(extents=(20, 8, 14))]
    blocks[0].apply_translation((0, -9, 5))
    blocks[1].apply_translation((0, 9, 7))
    geometry = make_scene(blocks[0], context=blocks[1], ground_z=0.0).geometry()
    H, n = 6000, 40
    x = np.column_stack([rng.uniform(-12, 12, H), rng.uniform(-4.5, 4.5, H), rng.uniform(0.01, 9, H)])
    if planar:                          # a canyon's few normals: the in-front test as a table
        choices = np.array([[0, 1.0, 0], [0, -1.0, 0], [1.0, 0, 0], [0, 0, 1.0]])
        tn = choices[rng.integers(0, 4, H)]
    else:                               # every normal distinct: point by point
        tn = rng.normal(size=(H, 3))
        tn[:, 2] = np.abs(tn[:, 2])
        tn /= np.linalg.norm(tn, axis=1, keepdims=True)
    on_g = rng.random(H) < 0.3
    x[on_g, 2] = 0.01
    tn[on_g] = (0.0, 0.0, 1.0)
    bins = reflector_bins()
    ob = np.where(on_g, 0, np.argmax(tn @ bins.T, axis=1)).astype(np.int64)
    ident = rng.integers(0, 2**31, H).astype(np.float64)
    w = rng.uniform(0.0, 0.05, H)
    pt = rng.integers(0, n, H)
    el, az = np.radians(rng.uniform(1, 80, 400)), np.radians(rng.uniform(0, 360, 400))
    sun_dirs = np.column_stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])
    sun_count = rng.integers(1, 30, 400).astype(float)
    sun_cell, G = shade_cells(sun_dirs)
    ref = _reference(geometry, x, tn, ob, ident, w, on_g, pt, sun_dirs, bins, sun_count, sun_cell, G, n)
    ground_sun, reflect_sun = np.zeros((G, n)), np.zeros((G, n * bins.shape[0]))
    n_rays = _cell_sun(geometry, x, tn, ob, ident, w, on_g, pt, sun_dirs, bins, sun_count, sun_cell, G,
                       ground_sun, reflect_sun)
    assert n_rays == ref[2] > 0
    assert np.count_nonzero(ref[0]) > 0 and np.count_nonzero(ref[1]) > 0
    np.testing.assert_array_equal(ground_sun, ref[0])
    np.testing.assert_array_equal(reflect_sun, ref[1])
