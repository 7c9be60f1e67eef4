"""The stages of one ray-casting task (one chunk of analysis points), run by :func:`raycast._chunk_task`.

1. :func:`primary_rays` -- the stratified rays over both hemispheres in front of each point: which
   sample cells see the sky, the ground or a scene surface.
2. :func:`reflected_sky` -- one cosine-distributed secondary ray from every reflecting hit, and from
   them and the primary hits the sky, ground and reflected-sky coefficients (and the optics' terms).
3. :func:`reflected_sun` -- per shading cell one ray from every reflecting hit towards a sun bin of
   that cell: the reflected-sun factors.
4. :func:`sun_visibility` -- one ray per point and sun-position bin.

The physics and the sampling are described in :mod:`widesky.irradiance.raycast`; these functions only name
its steps. All are pure numpy functions of their arrays and the scene's geometry dictionary.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .optics import optic_terms
from .patches import cosine_weights
from .rays import _clear_dni, _cosine_directions, _fbincount, cast_rays, reflector_points, shade_cells

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


def _next_reflectors(geometry, x, d, t_hit, prim, w, alb, pt, ident, ground_albedo):
    """The next level's :class:`Reflectors`: where the rays ``x + t d`` of a level's reflecting points end
    (``prim`` >= 0: that scene triangle at ``t_hit``; -1: the ground plane at ``t_hit``). The path weight ``w``
    is multiplied by the reflectance reached; the ground's albedo is left to the integrator on a path's first
    ground reflection (``alb``) and is the nominal ``ground_albedo`` [1] on its second and later ones."""
    on_g = prim < 0
    rho = np.where(on_g, np.where(alb, ground_albedo, 1.0), geometry["reflectance"][np.maximum(prim, 0)])
    w2 = w * rho
    k = np.nonzero(w2 > 0)[0]
    x2, tn2 = reflector_points(geometry, x[k], d[k], t_hit[k], prim[k])
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
    q = np.where(free & ~down, patches.index(d), -1)
    for target, m in ((ground_sky, r.alb), (reflect_sky, ~r.alb)):
        ok = m & (q >= 0)
        target += _fbincount(r.pt[ok] * P + q[ok], weights=r.w[ok], minlength=n * P).reshape(n, P)
    if not follow:
        return None, r.pt.size
    h = np.nonzero((prim >= 0) | down)[0]                       # a scene surface, or the ground
    t_h = np.where(prim[h] >= 0, t[h], tmax[h])
    return (_next_reflectors(geometry, r.x[h], d[h], t_h, prim[h], r.w[h], r.alb[h], r.pt[h], r.ident[h],
                             ground_albedo), r.pt.size)


def _reflector_sun(geometry, r: Reflectors, sun_dirs, bins, sun_count, sun_cell, G, ground_sun, reflect_sun):
    """The sun on the points of a later reflection, sampled as for the first (per shading cell one ray towards
    a sun bin drawn ~ steps x clear-sky DNI x cos(binned normal, sun)); the lit ones add their weight to
    ``ground_sun`` (G, n) or ``reflect_sun`` (G, n B) in place. Returns the number of rays cast."""
    if r.pt.size == 0 or sun_dirs.shape[0] == 0 or G == 0:
        return 0
    ob = np.zeros(r.pt.size, dtype=np.int64)                         # ground: bin 0 (up)
    ob[~r.ground] = np.argmax(r.tn[~r.ground] @ bins.T, axis=1)
    return _cell_sun(geometry, r.x, r.tn, ob, r.ident, r.w_sun, r.ground, r.pt, sun_dirs, bins, sun_count,
                     sun_cell, G, ground_sun, reflect_sun)


def _cell_sun(geometry, x, tn, ob, ident, w, on_g, pt, sun_dirs, bins, sun_count, sun_cell, G, ground_sun,
              reflect_sun):
    """Per shading cell one ray from each reflecting point towards a sun bin of the cell, drawn ~ steps x
    clear-sky DNI x cos(binned normal ``ob``, sun) with the point's identity ``ident``; the lit points in front
    of their sun add their weight ``w`` at their analysis point ``pt`` to ``ground_sun`` (G, n) (``on_g``) or
    ``reflect_sun`` (G, n B) at their orientation bin, in place. Returns the number of rays cast.

    The points are visited grouped by orientation bin (a stable sort, made once): each bin's draw is one
    ``searchsorted`` on a contiguous block, and every (analysis point, bin) sum adds its terms in the points'
    given order, so the result is the same, bit for bit, as visiting them in that order bin by bin. Where the
    points have few distinct normals (planar scenes) the in-front test is a table of (normal, sun) products,
    the same products as point by point."""
    n, B = ground_sun.shape[1], bins.shape[0]
    cnt = np.ones(sun_dirs.shape[0]) if sun_count is None else np.asarray(sun_count, dtype=float)
    el_b = np.degrees(np.arcsin(np.clip(sun_dirs[:, 2], -1.0, 1.0)))
    order = np.argsort(ob.astype(np.int16 if B < 1 << 15 else np.int64), kind="stable")     # a radix sort
    ob, x32, tn, ident = ob[order], x[order].astype(np.float32), tn[order], ident[order]
    w, on_g, pt = w[order], on_g[order], pt[order]
    edges = np.searchsorted(ob, np.arange(B + 1))                    # bin b's points: edges[b]:edges[b + 1]
    present = np.nonzero(edges[1:] > edges[:-1])[0]
    out_g, out_r = pt, pt * B + ob
    normals, nid = _distinct_rows(tn)
    n_rays = 0
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
        table = nid is not None and normals.shape[0] * cg.size < ob.size // 4   # the in-front test as a table
        if use.size == present.size:                                 # every point draws: no gathers
            j, sizes = None, edges[use + 1] - edges[use]
            idj, tnj = ident, (nid if table else tn)
        else:
            sizes = edges[use + 1] - edges[use]
            j = np.repeat(edges[use] - np.cumsum(sizes) + sizes, sizes) + np.arange(int(sizes.sum()))
            idj, tnj = ident[j], (nid[j] if table else tn[j])
        u = (idj + 7919 * (g + 1)).astype(np.float64, copy=False)     # the draw, in place: the same
        u *= 0.6180339887498949                                        # operations in the same order;
        u += 0.5                                                       # u - floor(u) is exact (Sterbenz),
        u -= np.floor(u)                                               # so equal to np.mod(u, 1), 5x faster
        pick = np.empty(u.size, dtype=np.int64)
        a = 0
        for b, m in zip(use, sizes):
            ub = u[a:a + m]
            ub *= tot[b]
            pick[a:a + m] = np.searchsorted(cdf[b], ub, side="right")
            a += m
        np.minimum(pick, cg.size - 1, out=pick)
        if table:
            ahead = np.sum(normals[:, None, :] * sun_dirs[cg][None, :, :], axis=2) > 0     # (normals, C_g)
            front = np.nonzero(ahead[tnj, pick])[0]
        else:
            front = np.nonzero(np.sum(tnj * sun_dirs[cg[pick]], axis=1) > 0)[0]
        if front.size == 0:
            continue
        every = front.size == pick.size                                # every point faces its sun: no gathers
        jj = front if j is None else j[front]
        sd32 = sun_dirs[cg].astype(np.float32)                         # cast, then gathered: the same values
        lit = ~cast_rays(geometry, x32 if every and j is None else x32[jj], sd32[pick if every else pick[front]],
                         occluded=True)
        n_rays += front.size
        k = jj[lit]
        kg = k[on_g[k]]
        ks = k[~on_g[k]]
        ground_sun[g] += _fbincount(out_g[kg], weights=w[kg], minlength=n)
        reflect_sun[g] += _fbincount(out_r[ks], weights=w[ks], minlength=n * B)
    return n_rays


def _distinct_rows(v):
    """(distinct rows of ``v`` (m, 3), index (n,) of each row among them), found through one float key per row
    and checked exactly; (None, None) where two distinct rows share a key or there are more than 4,096."""
    key = v @ np.array([0.7548776662466927, 0.5698402909980532, 0.3176519753432651])
    _, first, nid = np.unique(key, return_index=True, return_inverse=True)
    rows = v[first]
    if rows.shape[0] > 4096 or not np.array_equal(rows[nid], v):
        return None, None
    return rows, nid.reshape(-1)


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
    exact = np.concatenate([cosine_weights(patches, normals),
                            cosine_weights(patches, normals, lower=True)], axis=1)   # (n, 2P)
    flat = dirs.reshape(-1, 3)
    w = np.maximum(normals @ flat.T, 0.0) * wcell.reshape(-1)[None, :]               # (n, 2PK)
    w[buried] = 0.0
    fi, si = np.nonzero(w > 0)
    o, d = origins[fi], flat[si]
    down = d[:, 2] < 0
    maxd = np.full(fi.size, np.inf)
    gz = geometry["ground_z"]
    maxd[down] = np.maximum((gz - o[down, 2]) / d[down, 2], 1e-9)
    hit = np.full((n, 2 * P * dirs.shape[1]), -2, dtype=np.int32)
    prim, dist = cast_rays(geometry, o, d, maxd, distance=True)
    hit[fi, si] = prim
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
    x, tn = reflector_points(geometry, pr.o[ri], pr.d[ri], t_hit, prim[ri])
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
    s_patch = np.where(s_free & ~sdown, patches.index(sd), -1)   # secondary ray's sky patch
    s_ground = s_free & sdown
    exact = pr.exact
    w3 = pr.w.reshape(n, 2 * P, K)
    wsum = w3.sum(axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(wsum[..., None] > 0, exact[..., None] * w3 / wsum[..., None], 0.0)
    miss = pr.hit.reshape(n, 2 * P, K) == -1
    sky = np.sum(share[:, :P] * miss[:, :P], axis=2)
    ground_geo = np.sum(share[:, P:] * miss[:, P:], axis=(1, 2))
    r_pt = fi[ri]
    r_share = share.reshape(n, -1)[r_pt, si[ri]]
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
        q = np.where(t_free, patches.index(td), -1)
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
        level = _next_reflectors(geometry, x[h], sd[h], t_h, s_prim[h], w1[h], ~sel_scene[h], r_pt[h], ident1,
                                 ground_albedo)
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
        r_ob[sel_scene] = np.argmax(tn[sel_scene] @ bins.T, axis=1)
        live = np.nonzero((r_share > 0) & (r_rho > 0))[0]
        n_rays += _cell_sun(geometry, b.x[live], tn[live], r_ob[live], ident[live], r_share[live] * r_rho[live],
                            ~sel_scene[live], r_pt[live], sun_dirs, bins, sun_count, sun_cell, G, ground_sun,
                            reflect_sun)
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
    pf, ps = np.nonzero(ok)
    o32, d32 = origins.astype(np.float32), sun_dirs.astype(np.float32)
    vis[pf, ps] = ~cast_rays(geometry, o32[pf], d32[ps], occluded=True)
    return vis, pf.size
