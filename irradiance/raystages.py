"""The stages of one ray-casting task (one chunk of analysis points), run by :func:`raycast._chunk_task`.

1. :func:`primary_rays` -- the stratified rays over both hemispheres in front of each point: which
   sample cells see the sky, the ground or a scene surface.
2. :func:`reflected_sky` -- one cosine-distributed secondary ray from every reflecting hit, and from
   them and the primary hits the sky, ground and reflected-sky coefficients (and the optics' terms).
3. :func:`reflected_sun` -- per shading cell one ray from every reflecting hit towards a sun bin of
   that cell: the reflected-sun factors.
4. :func:`sun_visibility` -- one ray per point and sun-position bin.

The physics and the sampling are described in :mod:`widesky.irradiance.raycast`; these functions only name
its steps. All are pure functions of their arrays and the scene's geometry dictionary: numpy, and for the
reflected sun's per-point draw and sums a small C kernel (:mod:`widesky.irradiance._raysun`, array in, array out,
numpy's operations in numpy's order). The numbers are those of the numpy code before issue 36's speed-up, bit for
bit (``tests/test_raystages_sun.py``, ``tests/test_raystages_kernels.py``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import _raysun
from .optics import optic_terms
from .patches import cosine_weights
from .rays import (_by_distinct_rows, _clear_dni, _cosine_directions, _fbincount, cast_rays, reflector_points,
                   shade_cells)

_UP = np.array([0.0, 0.0, 1.0])

__all__ = ["PrimaryRays", "Bounce", "Reflectors", "primary_rays", "reflected_sky", "reflected_sun", "sun_visibility"]


class PrimaryRays(NamedTuple):
    """The primary rays of a chunk of ``n`` points over ``2P`` patches (upper, then lower hemisphere)
    of ``K`` sample cells each."""
    exact: np.ndarray    # (n, 2P) exact projected solid angles [sr]
    flat: np.ndarray     # (2PK, 3) sample directions
    w: np.ndarray        # (n, 2PK) sample weights (cell solid angle x cos), 0 for buried points
    fi: np.ndarray       # (R,) point of each ray cast
    si: np.ndarray       # (R,) sample index of each ray cast
    o: np.ndarray        # (R, 3) ray origins
    d: np.ndarray        # (R, 3) ray directions
    down: np.ndarray     # (R,) ray points downwards
    maxd: np.ndarray     # (R,) distance to the ground plane [m] (inf upwards)
    hit: np.ndarray      # (n, 2PK) primitive hit, -1 nothing, -2 not cast
    prim: np.ndarray     # (R,) primitive hit per ray (-1: none)
    dist: np.ndarray     # (R,) hit distance [m]


class Bounce(NamedTuple):
    """The reflecting hits of the primary rays (scene surfaces and the ground)."""
    ri: np.ndarray         # (H,) index into the primary rays
    sel_scene: np.ndarray  # (H,) the hit is a scene surface (else the ground)
    x: np.ndarray          # (H, 3) reflecting points
    tn: np.ndarray         # (H, 3) their normals towards the ray
    r_pt: np.ndarray       # (H,) the analysis point of each hit
    r_share: np.ndarray    # (H,) the hit's share of its patch's exact weight [sr]
    r_rho: np.ndarray      # (H,) reflectance (1 for the ground: its albedo is applied later)
    # the ground points that walls' secondary rays reach (the ground light walls pass on, issue 39)
    g2_x: np.ndarray = None    # (H2, 3) ground points
    g2_pt: np.ndarray = None   # (H2,) the analysis point of each
    g2_w: np.ndarray = None    # (H2,) weight: the wall hit's share [sr] x the wall's reflectance
    g2_id: np.ndarray = None   # (H2,) identities of their samples (decorrelated from the wall hit's)
    # the reflecting points of the second and later reflections (``reflections`` > 1), one Reflectors per level
    deep: tuple = ()


class Reflectors(NamedTuple):
    """The reflecting points of one later reflection (the second, third ...): where the secondary rays of the
    previous level's points hit a scene surface or the ground."""
    x: np.ndarray          # (H, 3) reflecting points
    tn: np.ndarray         # (H, 3) their normals towards the ray
    ground: np.ndarray     # (H,) the point is on the ground
    pt: np.ndarray         # (H,) the analysis point of each
    w: np.ndarray          # (H,) path weight: the first hit's share [sr] x the reflectances on the path,
                           # this point's included, the ground's first albedo left out (applied later)
    alb: np.ndarray        # (H,) the path has reflected off the ground (its albedo is applied later)
    ident: np.ndarray      # (H,) identities of their samples
    w_sun: np.ndarray      # (H,) weight of the point's reflected sun: ``w``, and for a scene surface on a path
                           # that reflected off the ground also that albedo (the nominal one: the reflected-sun
                           # factors of scene surfaces carry no albedo later)


def _next_reflectors(geometry, x, d, t_hit, prim, w, alb, pt, ident, ground_albedo, rows=None):
    """The next level's :class:`Reflectors`: where the rays ``x + t d`` of a level's reflecting points end
    (``prim`` >= 0: that scene triangle at ``t_hit``; -1: the ground plane at ``t_hit``). The path weight ``w``
    is multiplied by the reflectance reached; the ground's albedo is left to the integrator on a path's first
    ground reflection (``alb``) and is the nominal ``ground_albedo`` [1] on its second and later ones.
    ``rows``: the rays' rows of ``x`` and ``d`` (default: all, in order), so the callers gather them once."""
    on_g = prim < 0
    rho = np.where(on_g, np.where(alb, ground_albedo, 1.0), geometry["reflectance"][np.maximum(prim, 0)])
    w2 = w * rho
    k = np.nonzero(w2 > 0)[0]
    kx = k if rows is None else rows[k]
    x2, tn2 = reflector_points(geometry, np.take(x, kx, axis=0), np.take(d, kx, axis=0), t_hit[k], prim[k])
    alb2 = alb[k] | on_g[k]
    w_sun = w2[k] * np.where(alb2 & ~on_g[k], ground_albedo, 1.0)
    return Reflectors(x2, tn2, on_g[k], pt[k], w2[k], alb2, _second_identity(ident[k]), w_sun)


def _reflector_sky(geometry, patches, r: Reflectors, follow, ground_albedo, ground_sky, reflect_sky):
    """One cosine-distributed ray from each point of ``r`` (fixed by its identity): where it escapes into sky
    patch ``q`` the path weight is added at (analysis point, ``q``) to ``ground_sky`` (paths that reflected
    off the ground: times the albedo in the integrator) or ``reflect_sky``, in place. Returns the next
    level's :class:`Reflectors` (the points these rays reach; None unless ``follow``) and the rays cast."""
    if r.pt.size == 0:
        return (r if follow else None), 0
    n, P = ground_sky.shape
    d = _cosine_directions(r.tn, r.ident)
    tmax = np.full(r.pt.size, np.inf)
    down = d[:, 2] < 0
    tmax[down] = np.maximum((geometry["ground_z"] - r.x[down, 2]) / d[down, 2], 1e-9)
    if follow:
        prim, t = cast_rays(geometry, r.x, d, tmax, distance=True)
        free = prim < 0
    else:
        free = ~cast_rays(geometry, r.x, d, tmax, occluded=True)
    q = _patch_index(patches, d, free & ~down)
    for target, m in ((ground_sky, r.alb), (reflect_sky, ~r.alb)):
        ok = m & (q >= 0)
        target += _fbincount(r.pt[ok] * P + q[ok], weights=r.w[ok], minlength=n * P).reshape(n, P)
    if not follow:
        return None, r.pt.size
    h = np.nonzero((prim >= 0) | down)[0]                       # a scene surface, or the ground
    t_h = np.where(prim[h] >= 0, t[h], tmax[h])
    return (_next_reflectors(geometry, r.x, d, t_h, prim[h], r.w[h], r.alb[h], r.pt[h], r.ident[h],
                             ground_albedo, rows=h), r.pt.size)


def _reflector_sun(geometry, r: Reflectors, sun_dirs, bins, sun_count, sun_cell, G, ground_sun, reflect_sun):
    """The sun on the points of a later reflection, sampled as for the first (per shading cell one ray towards
    a sun bin drawn ~ steps x clear-sky DNI x cos(binned normal, sun)); the lit ones add their weight to
    ``ground_sun`` (G, n) or ``reflect_sun`` (G, n B) in place. Returns the number of rays cast."""
    if r.pt.size == 0 or sun_dirs.shape[0] == 0 or G == 0:
        return 0
    ob = np.zeros(r.pt.size, dtype=np.int64)                         # ground: bin 0 (up)
    ob[~r.ground] = _by_distinct_rows(lambda t: np.argmax(t @ bins.T, axis=1),
                                      np.compress(~r.ground, r.tn, axis=0))
    return _cell_sun(geometry, r.x, r.tn, ob, r.ident, r.w_sun, r.ground, r.pt, sun_dirs, bins, sun_count,
                     sun_cell, G, ground_sun, reflect_sun)


#: Reflecting points per block of :func:`_cell_sun` (every cell's rays of a block in one Embree call).
_SUN_BLOCK = 8192
#: Buckets of the draw's search tables (the C kernel's ``NBUCKET``).
_SUN_BUCKETS = 1024


def _cell_sun(geometry, x, tn, ob, ident, w, on_g, pt, sun_dirs, bins, sun_count, sun_cell, G, ground_sun,
              reflect_sun, rows=None):
    """Per shading cell one ray from each reflecting point towards a sun bin of the cell, drawn ~ steps x
    clear-sky DNI x cos(binned normal ``ob``, sun) with the point's identity ``ident``; the lit points in front
    of their sun add their weight ``w`` at their analysis point ``pt`` to ``ground_sun`` (G, n) (``on_g``) or
    ``reflect_sun`` (G, n B) at their orientation bin, in place. Returns the number of rays cast.

    The points are visited grouped by orientation bin (a stable sort, made once), and every (analysis point,
    bin) sum of a cell adds its terms in the points' given order from zero, then to the cell's row, so the result
    is the same, bit for bit, as visiting them in that order bin by bin, cell by cell. The per-point work (the
    draw, the in-front test, packing the rays, the sums of the lit ones) is :mod:`widesky.irradiance._raysun`'s,
    numpy's operations in numpy's order, over blocks of :data:`_SUN_BLOCK` points (every cell's draws of a
    block while its points are in cache; one Embree call per block). ``rows``: the points' rows of ``x`` and
    ``tn`` (default: all, in order), so that they are gathered once."""
    n, B = ground_sun.shape[1], bins.shape[0]
    cnt = np.ones(sun_dirs.shape[0]) if sun_count is None else np.asarray(sun_count, dtype=float)
    el_b = np.degrees(np.arcsin(np.clip(sun_dirs[:, 2], -1.0, 1.0)))
    order = np.argsort(ob.astype(np.int16 if B < 1 << 15 else np.int64), kind="stable")     # a radix sort
    ob = ob[order]
    edges = np.searchsorted(ob, np.arange(B + 1)).astype(np.int64)  # bin b's points: edges[b]:edges[b + 1]
    present = np.nonzero(edges[1:] > edges[:-1])[0]
    # the active cells: their sun bins' cumulative weights per orientation bin, the bins drawn from, the search
    # tables (numpy's searchsorted of the same products u tot at u = k / _SUN_BUCKETS, as the kernel forms them)
    cells, cdfs, tots, uses, tabs, sds = [], [], [], [], [], []
    ku = np.arange(_SUN_BUCKETS + 1) / _SUN_BUCKETS
    for g in range(G):
        cg = np.nonzero(sun_cell == g)[0]
        if cg.size == 0:
            continue
        wq = (cnt[cg] * _clear_dni(el_b[cg]))[None, :] * np.maximum(bins @ sun_dirs[cg].T, 0.0)
        cdf = np.cumsum(wq, axis=1)                                   # (B, C_g)
        tot = cdf[:, -1]
        use = present[tot[present] > 0]
        if use.size == 0:
            continue
        cells.append((7919 * (g + 1), g, cg.size))
        cdfs.append(cdf.reshape(-1))
        tots.append(tot)
        uses.append(use)
        tabs.extend(np.searchsorted(cdf[b], ku * tot[b], side="right") for b in use)
        sds.append(sun_dirs[cg])
    if not cells:
        return 0
    i64 = lambda v: np.ascontiguousarray(v, dtype=np.int64)           # noqa: E731
    cell_k, cell_g, cell_C = (i64(c) for c in zip(*cells))
    cdf_off = i64(np.cumsum([0] + [c.size for c in cdfs[:-1]]))
    sd_off = i64(np.cumsum([0] + list(cell_C[:-1])))
    use_off = i64(np.cumsum([0] + [u.size for u in uses]))
    use_all, tot_all, cdf_all = i64(np.concatenate(uses)), np.concatenate(tots), np.concatenate(cdfs)
    tab_all = np.ascontiguousarray(np.concatenate(tabs), dtype=np.int32)
    sd_all = np.ascontiguousarray(np.concatenate(sds), dtype=np.float64)
    sd32_all = sd_all.astype(np.float32)                               # cast, then gathered: the same values
    xr = order if rows is None else rows[order]
    x32 = np.take(x, xr, axis=0).astype(np.float32)       # (row gathers by numpy.take: the same rows, faster)
    tn = np.ascontiguousarray(np.take(tn, xr, axis=0), dtype=np.float64)
    ident = ident[order]
    ident_float = ident.dtype.kind == "f"
    ident = np.ascontiguousarray(ident, dtype=np.float64 if ident_float else np.int64)
    w = np.ascontiguousarray(w[order], dtype=np.float64)
    on_g = np.ascontiguousarray(on_g[order], dtype=bool)
    pt = pt[order].astype(np.int64, copy=False)
    out_g, out_r = pt, pt * B + ob.astype(np.int64, copy=False)
    m, Gc = x32.shape[0], len(cells)
    cap = min(m, _SUN_BLOCK) * Gc
    xo, do = np.empty((cap, 3), np.float32), np.empty((cap, 3), np.float32)
    jj, gid = np.empty(cap, np.int64), np.empty(cap, np.int32)
    tmp_g, tmp_r = np.zeros((G, n)), np.zeros((G, n * B))
    n_rays = 0
    for a0 in range(0, m, _SUN_BLOCK):
        a1 = min(a0 + _SUN_BLOCK, m)
        front = _raysun.draw(a0, a1, ident, ident_float, edges, cell_k, cell_g, cell_C, cdf_off, sd_off, use_off,
                             use_all, tot_all, cdf_all, tab_all, sd_all, sd32_all, tn, x32, xo, do, jj, gid)
        if front == 0:
            continue
        occ = np.ascontiguousarray(cast_rays(geometry, xo[:front], do[:front], occluded=True), dtype=bool)
        n_rays += front
        _raysun.accumulate(front, jj, gid, occ, on_g, out_g, out_r, w, G, tmp_g, tmp_r)
    # each cell's sums added to its row once (a row holds no -0.0, so adding a cell's zeros changes nothing)
    ground_sun += tmp_g
    reflect_sun += tmp_r
    return n_rays


def _patch_index(patches, d, sel):
    """``numpy.where(sel, patches.index(d), -1)``, the index computed for the selected rows only (row by row:
    the same values)."""
    q = np.full(sel.shape[0], -1, dtype=np.int64)
    k = np.nonzero(sel)[0]
    if k.size:
        q[k] = patches.index(np.take(d, k, axis=0))
    return q


def _second_identity(ids):
    """Identities (float64, < 2**32) of a second sample drawn at a point reached by a ray of identity ``ids``:
    a multiplicative hash (Knuth's golden-ratio constant), so the second sample is not correlated with the
    first (the R2 sequence of :func:`widesky.irradiance.rays._cosine_directions` indexed by ``ids`` plus a
    constant would be the same set of samples shifted, and the wall rays that reach the ground are a biased
    subset of them)."""
    h = np.asarray(ids, dtype=np.int64).astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)
    return (h >> np.uint64(32)).astype(np.float64)


def primary_rays(geometry, origins, normals, buried, patches, dirs, wcell):
    """Cast the primary rays; returns the :class:`PrimaryRays`."""
    P = patches.n_patches
    n = origins.shape[0]
    exact = _by_distinct_rows(lambda v: np.concatenate([cosine_weights(patches, v),
                                                        cosine_weights(patches, v, lower=True)], axis=1),
                              normals)                                              # (n, 2P)
    flat = dirs.reshape(-1, 3)
    w = np.maximum(normals @ flat.T, 0.0) * wcell.reshape(-1)[None, :]               # (n, 2PK)
    w[buried] = 0.0
    cast = w > 0
    fi, si = np.nonzero(cast)
    o, d = np.take(origins, fi, axis=0), np.take(flat, si, axis=0)
    down = d[:, 2] < 0
    maxd = np.full(fi.size, np.inf)
    gz = geometry["ground_z"]
    maxd[down] = np.maximum((gz - o[down, 2]) / d[down, 2], 1e-9)
    hit = np.full((n, 2 * P * dirs.shape[1]), -2, dtype=np.int32)
    prim, dist = cast_rays(geometry, o, d, maxd, distance=True)
    hit[cast] = prim                                   # the (fi, si) of nonzero(cast), in its order
    return PrimaryRays(exact, flat, w, fi, si, o, d, down, maxd, hit, prim, dist)


def reflected_sky(geometry, pr: PrimaryRays, patches, K, normals, buried, first, optics=None, optic_kq=4,
                  reflections=1, ground_albedo=0.2):
    """Secondary rays from the reflecting hits and the sky-side coefficients.

    One bounce: every reflecting point (scene hit or ground) casts one cosine-distributed secondary
    ray, its direction fixed by the ray's identity; where it escapes to the sky it makes the
    reflector's sky irradiance a one-sample estimate pi L(patch) (so the reflected sky is a daylight
    coefficient of that patch), where it hits the scene it brings nothing (one reflection). Where a wall's
    ray reaches the ground, the ground light the wall passes on is traced as the scene lets it be (issue 39):
    the ground point casts one cosine-distributed ray to the sky, which adds the wall hit's share times
    the wall's reflectance to ``ground_sky`` at the patch it escapes into (times the albedo in the
    integrator, as the ground's own light), and :func:`reflected_sun` traces its sun. ``reflect_ground``
    (the unshaded ground radiance's coefficient before 2026-12-05) is zero.

    ``reflections`` > 1 follows the paths further (:mod:`widesky.irradiance.raycast`): the point a secondary ray
    reaches (scene surface or ground) is the next reflection's reflecting point, with the path weight times its
    reflectance, and casts its own sky ray (here) and sun rays (:func:`reflected_sun`), up to ``reflections``
    reflecting points per path (the wall-then-ground path of ``reflections=1`` is the second level's ground
    points). ``ground_albedo`` [1] is the nominal albedo of a path's second and later ground reflections and of
    the sun reflected by a scene surface on a path that reflected off the ground (the integrator applies the
    step's albedo to a path's first ground reflection).

    Returns
    -------
    (dict of coefficient arrays, Bounce, gsh, extra, n_rays) where ``gsh`` (n,) is each point's share
    of ground hits and ``extra`` (n,) the ground share of its lower-hemisphere slivers.
    """
    P = patches.n_patches
    n = pr.w.shape[0]
    fi, si, prim = pr.fi, pr.si, pr.prim
    on_ground = (prim < 0) & pr.down
    refl_ray = (prim >= 0) | on_ground
    ri = np.nonzero(refl_ray)[0]
    sel_scene = prim[ri] >= 0
    t_hit = np.where(sel_scene, pr.dist[ri], pr.maxd[ri])
    x, tn = reflector_points(geometry, np.take(pr.o, ri, axis=0), np.take(pr.d, ri, axis=0), t_hit, prim[ri])
    sd = _cosine_directions(tn, (fi[ri] + first) * (2 * P * K) + si[ri])
    smax = np.full(ri.size, np.inf)
    sdown = sd[:, 2] < 0
    smax[sdown] = np.maximum((geometry["ground_z"] - x[sdown, 2]) / sd[sdown, 2], 1e-9)
    deeper = reflections > 1
    if deeper:
        s_prim, s_dist = cast_rays(geometry, x, sd, smax, distance=True)
        s_free = s_prim < 0
    else:
        s_free = ~cast_rays(geometry, x, sd, smax, occluded=True)
    s_patch = _patch_index(patches, sd, s_free & ~sdown)   # secondary ray's sky patch
    s_ground = s_free & sdown
    exact = pr.exact
    w3 = pr.w.reshape(n, 2 * P, K)
    wsum = w3.sum(axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = exact[..., None] * w3                  # np.where(wsum > 0, exact w3 / wsum, 0), in place
        np.divide(share, wsum[..., None], out=share)
        share[~(wsum > 0)] = 0.0
    miss = pr.hit.reshape(n, 2 * P, K) == -1
    sky = np.sum(share[:, :P] * miss[:, :P], axis=2)
    ground_geo = np.sum(share[:, P:] * miss[:, P:], axis=(1, 2))
    r_pt = fi[ri]
    r_share = np.take(share.reshape(-1), r_pt * share.shape[1] * K + si[ri])    # share[r_pt, si]
    r_rho = np.ones(ri.size)
    r_rho[sel_scene] = geometry["reflectance"][prim[ri[sel_scene]]]
    to_sky = s_patch >= 0
    gs = ~sel_scene & to_sky
    ground_sky = _fbincount(r_pt[gs] * P + s_patch[gs], weights=r_share[gs],
                             minlength=n * P).reshape(n, P)
    ws = sel_scene & to_sky
    reflect_sky = _fbincount(r_pt[ws] * P + s_patch[ws], weights=r_share[ws] * r_rho[ws],
                              minlength=n * P).reshape(n, P)
    wg = np.nonzero(sel_scene & s_ground & (r_rho > 0) & (r_share > 0) & (not deeper))[0]
    reflect_ground = np.zeros(n)
    # patches with a positive exact weight but no sample in front of the face (slivers at the face's
    # horizon): the face's mean visible fraction of that hemisphere; a lower sliver's ground is lit
    # like the point's other ground hits
    sliver = (wsum <= 0) & (exact > 0)
    extra = np.zeros(n)
    gsh = _fbincount(r_pt[~sel_scene], weights=r_share[~sel_scene], minlength=n)
    sliver_fac = np.ones(n)
    if np.any(sliver):
        tot_up, tot_lo = share[:, :P].sum(axis=(1, 2)), share[:, P:].sum(axis=(1, 2))
        with np.errstate(invalid="ignore", divide="ignore"):
            f_up = np.where(tot_up > 0, sky.sum(axis=1) / tot_up, 1.0)
            f_lo = np.where(tot_lo > 0, ground_geo / tot_lo, 1.0)
        sky = sky + np.where(sliver[:, :P], exact[:, :P] * f_up[:, None], 0.0)
        extra = np.sum(np.where(sliver[:, P:], exact[:, P:], 0.0), axis=1) * f_lo
        with np.errstate(invalid="ignore", divide="ignore"):
            sliver_fac = np.where(gsh > 0, 1.0 + extra / np.where(gsh > 0, gsh, 1.0), 1.0)
            ground_sky *= sliver_fac[:, None]
    # the ground light walls pass on: the ground point a wall's secondary ray reaches sees the sky as the
    # scene lets it (one cosine ray; its sun in reflected_sun), added after the slivers' scaling, which is
    # for the point's own ground hits
    g2_x, _tn2 = reflector_points(geometry, x[wg], sd[wg], smax[wg], np.full(wg.size, -1))
    g2_pt, g2_w = r_pt[wg], r_share[wg] * r_rho[wg]
    g2_id = _second_identity((fi[ri[wg]] + first) * (2 * P * K) + si[ri[wg]])
    n_g2 = wg.size
    if wg.size:
        td = _cosine_directions(np.broadcast_to(_UP, (wg.size, 3)), g2_id)
        t_free = ~cast_rays(geometry, g2_x, td, np.full(wg.size, np.inf), occluded=True)
        q = _patch_index(patches, td, t_free)
        ok = q >= 0
        ground_sky += _fbincount(g2_pt[ok] * P + q[ok], weights=g2_w[ok], minlength=n * P).reshape(n, P)
    deep = []
    if deeper:
        # the later reflections: the first level's secondary rays that reach a surface (a point's own ground
        # hits with the slivers' share, as above)
        w1 = r_share * r_rho * np.where(sel_scene, 1.0, sliver_fac[r_pt])
        h = np.nonzero(((s_prim >= 0) | s_ground) & (w1 > 0))[0]
        t_h = np.where(s_prim[h] >= 0, s_dist[h], smax[h])
        ident1 = (fi[ri[h]] + first) * (2 * P * K) + si[ri[h]]
        level = _next_reflectors(geometry, x, sd, t_h, s_prim[h], w1[h], ~sel_scene[h], r_pt[h], ident1,
                                 ground_albedo, rows=h)
        for depth in range(2, reflections + 1):
            deep.append(level)
            level, n_cast = _reflector_sky(geometry, patches, level, depth < reflections, ground_albedo,
                                           ground_sky, reflect_sky)
            n_g2 += n_cast
    sky_optic = reflect_optic = None
    if optics is not None and optics.n:
        sky_optic, reflect_optic = optic_terms(optics, patches, normals, exact, w3, pr.flat,
                                               miss, r_pt, si[ri], r_share, kq=optic_kq)
        sky_optic[:, buried] = 0.0
    sky[buried] = 0.0
    ground_sky[buried] = 0.0
    reflect_sky[buried] = 0.0
    reflect_ground[buried] = 0.0
    coeffs = {"sky": sky, "ground_sky": ground_sky, "reflect_sky": reflect_sky,
              "reflect_ground": reflect_ground, "sky_optic": sky_optic, "reflect_optic": reflect_optic}
    return (coeffs, Bounce(ri, sel_scene, x, tn, r_pt, r_share, r_rho, g2_x, g2_pt, g2_w, g2_id, tuple(deep)),
            gsh, extra, ri.size + n_g2)


def reflected_sun(geometry, b: Bounce, sun_dirs, bins, sun_count, sun_cell, n, ident, buried, gsh, extra):
    """Sun on the reflectors: per shading cell, one ray per reflecting hit towards a sun bin of the
    cell drawn ~ steps x clear-sky DNI x cos(binned reflector normal, sun), fixed by the ray's
    identity ``ident`` (H,); the lit hits carry the cell's reflected sun.

    Returns
    -------
    (ground_sun (G, n), reflect_sun (G, n, B), n_rays)
    """
    B = bins.shape[0]
    S = sun_dirs.shape[0]
    if sun_cell is None:
        sun_cell, G = shade_cells(sun_dirs)
    else:
        sun_cell = np.asarray(sun_cell)
        G = int(sun_cell.max()) + 1 if sun_cell.size else 0
    ground_sun = np.zeros((G, n))
    reflect_sun = np.zeros((G, n * B))
    n_rays = 0
    sel_scene, tn, r_pt, r_share, r_rho = b.sel_scene, b.tn, b.r_pt, b.r_share, b.r_rho
    if S and b.ri.size and G:
        r_ob = np.zeros(b.ri.size, dtype=np.int64)                   # ground: bin 0 (up)
        r_ob[sel_scene] = _by_distinct_rows(lambda t: np.argmax(t @ bins.T, axis=1),
                                            np.compress(sel_scene, tn, axis=0))
        live = np.nonzero((r_share > 0) & (r_rho > 0))[0]
        n_rays += _cell_sun(geometry, b.x, tn, r_ob[live], ident[live], r_share[live] * r_rho[live],
                            ~sel_scene[live], r_pt[live], sun_dirs, bins, sun_count, sun_cell, G, ground_sun,
                            reflect_sun, rows=live)
    if np.any(extra > 0):
        # sliver patches of the lower hemisphere: their ground share at the band's mean sunlit
        # share of the point's ground hits
        with np.errstate(invalid="ignore", divide="ignore"):
            ground_sun *= np.where(gsh > 0, 1.0 + extra / np.where(gsh > 0, gsh, 1.0), 1.0)[None, :]
    n_rays += _wall_ground_sun(geometry, b, sun_dirs, bins, sun_count, sun_cell, G, ground_sun)
    for level in b.deep:                                              # the later reflections
        n_rays += _reflector_sun(geometry, level, sun_dirs, bins, sun_count, sun_cell, G, ground_sun, reflect_sun)
    ground_sun[:, buried] = 0.0
    reflect_sun = reflect_sun.reshape(G, n, B)
    reflect_sun[:, buried] = 0.0
    return ground_sun, reflect_sun, n_rays


def _wall_ground_sun(geometry, b: Bounce, sun_dirs, bins, sun_count, sun_cell, G, ground_sun):
    """The sun on the ground points that walls' secondary rays reach: per shading cell one ray towards a
    sun bin of the cell drawn as for the point's own ground hits (orientation bin 0, up), the lit ones adding
    their weight to ``ground_sun`` (G, n) in place. Returns the number of rays cast."""
    if b.g2_x is None or b.g2_x.shape[0] == 0 or sun_dirs.shape[0] == 0 or G == 0:
        return 0
    cnt = np.ones(sun_dirs.shape[0]) if sun_count is None else np.asarray(sun_count, dtype=float)
    el_b = np.degrees(np.arcsin(np.clip(sun_dirs[:, 2], -1.0, 1.0)))
    n_rays = 0
    for g in range(G):
        cg = np.nonzero(sun_cell == g)[0]
        if cg.size == 0:
            continue
        cdf = np.cumsum(cnt[cg] * _clear_dni(el_b[cg]) * np.maximum(sun_dirs[cg] @ bins[0], 0.0))
        if not cdf[-1] > 0:
            continue
        u = np.mod(0.5 + (b.g2_id + 7919 * (g + 1)) * 0.6180339887498949, 1.0)
        pick = np.minimum(np.searchsorted(cdf, u * cdf[-1], side="right"), cg.size - 1)
        sd = sun_dirs[cg[pick]]
        front = np.nonzero(sd[:, 2] > 0)[0]
        if front.size == 0:
            continue
        lit = ~cast_rays(geometry, b.g2_x[front].astype(np.float32), sd[front].astype(np.float32),
                         occluded=True)
        n_rays += front.size
        ground_sun[g] += _fbincount(b.g2_pt[front], weights=b.g2_w[front] * lit, minlength=ground_sun.shape[1])
    return n_rays


def sun_visibility(geometry, origins, normals, buried, sun_dirs):
    """Whether each point sees each sun-position bin: (n, S) bool, and the number of rays cast."""
    n, S = origins.shape[0], sun_dirs.shape[0]
    vis = np.zeros((n, S), dtype=bool)
    if not S:
        return vis, 0
    cs = normals @ sun_dirs.T
    ok = (cs > 0) & ~buried[:, None] & (sun_dirs[:, 2] > 0)[None, :]
    per_point = np.count_nonzero(ok, axis=1)                          # the pairs in row-major order
    o32, d32 = origins.astype(np.float32), sun_dirs.astype(np.float32)
    ps = np.nonzero(ok.reshape(-1))[0] % S
    vis[ok] = ~cast_rays(geometry, np.repeat(o32, per_point, axis=0), np.take(d32, ps, axis=0), occluded=True)
    return vis, int(per_point.sum())
