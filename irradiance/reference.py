"""Brute-force plane-of-array irradiance at a few points: the validation reference of the integrator.

Where :func:`widesky.irradiance.poa.poa_irradiance` averages the sky over patches, applies a patch's
visible fraction to its mean radiance, traces the circumsolar excess with the sun, bins sun positions
and lights every reflector like an unshaded surface of its orientation bin, this module integrates
the same light transport (direct sun, sky, one Lambertian reflection) with none of those shortcuts,
step by step, by midpoint quadrature on dense direction grids and a ray per direction:

* **Direct**: a ray towards the sun per point and step; ``E_n max(0, n . s) v``.
* **Sky**: the sky model evaluated every step at the centres of a fine Reinhart grid (``sky_mf``;
  16 gives 36,865 cells of about 0.8 deg), each cell's visibility and cosine from ``sky_rays**2``
  rays (computed once), and at the nodes of a sun-centred polar quadrature (the circumsolar disc of
  ``disc_radius``: log-spaced rings from 0.02 deg, ``disc_sectors`` per ring, a ray per node, point
  and step); grid cells whose centre lies inside the disc are replaced by the disc, with a
  first-order correction for the area by which the cells and the disc differ:
  ``sum L(w) v(w) max(0, n . w) dw``.
* **Reflected** (one bounce, Lambertian): ``reflect_samples**2`` rays per cell of a Reinhart grid
  (``reflect_mf``) over the whole sphere in front of the point, sharing the cell's exact projected
  solid angle (:func:`widesky.irradiance.patches.cosine_weights`); every ray that reaches the ground
  plane or a scene surface gives a reflector point ``y`` with its own irradiance, computed per step:
  a sun ray from ``y`` (exact shadowing on the ground and on the walls), its sky through a Reinhart
  grid (``reflect_sky_mf``) with a ray per cell, the circumsolar excess of the disc traced with
  the sun at this second level, and for scene surfaces the light of the unshaded ground they see
  (the ground-then-wall path, a second-order term). The reflector's radiance is
  ``reflectance E(y) / pi``.

This costs a sky-model evaluation of ~40,000 directions and some 10^4 rays per point and step: a
reference for small scenes and validation, not a production path. The sky source is used as given:
pass ``PragueSky(..., elevation_quantum=0)`` for exact sky states.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field

import numpy as np
import trimesh
from tqdm.auto import tqdm

from .patches import cosine_weights, direction_from_angles, orthonormal_frame, reinhart
from .rays import cast_rays, reflector_points
from .scene import make_scene
from .skies import SkyStates

__all__ = ["reference_poa", "ReferenceResult"]


@dataclass(eq=False)
class ReferenceResult:
    """Brute-force irradiance at the selected points, arrays shaped (T, n).

    Attributes
    ----------
    poa_global, poa_direct, poa_sky_diffuse, poa_ground_diffuse : numpy.ndarray
        Irradiance [W m-2] (channels contracted with ``weights``; broadband by default);
        ``poa_ground_diffuse`` holds all reflected light (ground and scene surfaces), as in
        :class:`widesky.irradiance.result.POAResult`.
    points : numpy.ndarray
        (n,) indices of the scene's analysis points.
    disc_correction : numpy.ndarray
        (T, n) the edge correction of the circumsolar disc included in ``poa_sky_diffuse`` [W m-2].
    n_rays : int
        Rays cast.
    timings : dict
        Seconds: ``geometry`` (rays computed once), ``steps`` (per-step work), ``total``.
    """

    poa_global: np.ndarray
    poa_direct: np.ndarray
    poa_sky_diffuse: np.ndarray
    poa_ground_diffuse: np.ndarray
    points: np.ndarray
    disc_correction: np.ndarray
    n_rays: int = 0
    timings: dict = field(default_factory=dict)


def _disc_nodes(radius, rings, sectors, inner=0.02):
    """Sun-centred polar quadrature: (Q,) angular distance [rad], position angle [rad], solid
    angle [sr], and the mask of the outer ring. A cap of radius ``inner`` [deg] around the sun is
    one node; ``rings`` log-spaced annuli out to ``radius`` [deg] carry ``sectors`` nodes each at
    their solid-angle midpoints."""
    edges = np.radians(np.concatenate([[0.0], np.geomspace(inner, radius, rings + 1)]))
    a, b = edges[1:-1], edges[2:]
    mid = np.arccos(0.5 * (np.cos(a) + np.cos(b)))
    th = (np.arange(sectors) + 0.5) * 2 * np.pi / sectors
    r = np.concatenate([[0.0], np.repeat(mid, sectors)])
    t = np.concatenate([[0.0], np.tile(th, rings)])
    om = np.concatenate([[2 * np.pi * (1 - np.cos(edges[1]))],
                         np.repeat(2 * np.pi * (np.cos(a) - np.cos(b)) / sectors, sectors)])
    outer = np.zeros(r.size, dtype=bool)
    outer[-sectors:] = True
    return r, t, om, outer


def _trace(geom, origins, dirs):
    """Cast rays; returns (kind, index, distance): kind 0 sky, 1 ground, 2 scene triangle."""
    down = dirs[:, 2] < 0
    maxd = np.full(dirs.shape[0], np.inf)
    maxd[down] = np.maximum((geom["ground_z"] - origins[down, 2]) / dirs[down, 2], 1e-9)
    prim, dist = cast_rays(geom, origins, dirs, maxd, distance=True)
    kind = np.where(prim >= 0, 2, np.where(down, 1, 0))
    dist = np.where(kind == 1, maxd, dist)
    return kind, prim, dist


def _hemisphere_rays(geom, origins, normals, dirs, w_dir):
    """Rays from every origin along every direction in front of its normal.

    Returns the flat (point, direction) pairs in front with their weights ``w_dir max(0, n . d)``
    and what each ray reaches (kind, triangle, distance).
    """
    chunk = max(1, 4_000_000 // max(dirs.shape[0], 1))
    out = []
    for i0 in range(0, origins.shape[0], chunk):
        c = normals[i0:i0 + chunk] @ dirs.T
        pi, di = np.nonzero(c > 0)
        kind, prim, dist = _trace(geom, origins[i0 + pi], dirs[di])
        out.append((pi + i0, di, w_dir[di] * c[pi, di], kind, prim, dist))
    cat = [np.concatenate([o[j] for o in out]) for j in range(6)]
    return cat


_CONTEXT: dict = {}


def _optic(angular, cos):
    """The optic at the incidence angles of cosines ``cos`` (1 without an optic; 0 behind)."""
    if angular is None:
        return 1.0
    c = np.asarray(cos, dtype=float)
    f = np.asarray(angular(np.degrees(np.arccos(np.clip(c, 0.0, 1.0)))), dtype=float)
    return np.where(c > 0, f, 0.0)


def _chunk_worker(t0, t1):
    return _steps(_CONTEXT, t0, t1)


def _steps(ctx, t0, t1):
    """The per-step work for steps t0:t1 (serial or in a worker process)."""
    sky, states, W = ctx["sky"], ctx["states"].take(slice(t0, t1)), ctx["W"]
    geom = ctx["geom"]
    Tc = len(states)
    n = ctx["origins"].shape[0]
    out = {q: np.zeros((Tc, n)) for q in ("direct", "sky", "refl", "corr")}
    n_rays = 0
    el = states.sun_elevation
    lit = el > ctx["min_el"]
    if not np.any(lit):
        return out, n_rays
    s = states.sun_direction
    u, v = orthonormal_frame(s)
    r, th, om, outer = ctx["disc"]
    qd = (np.cos(r)[None, :, None] * s[:, None, :]
          + (np.sin(r) * np.cos(th))[None, :, None] * u[:, None, :]
          + (np.sin(r) * np.sin(th))[None, :, None] * v[:, None, :])            # (Tc, Q, 3)
    q_up = qd[..., 2] > 0
    g1, g2 = ctx["g1_dirs"], ctx["g2_dirs"]
    n1, n2 = g1.shape[0], g2.shape[0]
    dirs = np.concatenate([np.broadcast_to(g1, (Tc, n1, 3)), np.broadcast_to(g2, (Tc, n2, 3)),
                           np.where(q_up[..., None], qd, (0.0, 0.0, 1.0))], axis=1)
    L = np.zeros((Tc, dirs.shape[1]))
    li = np.nonzero(lit)[0]
    for a in range(0, li.size, 4):                  # bounds the (t, directions, channels) block
        sel = li[a:a + 4]
        L[sel] = sky.radiance(dirs[sel], states.take(sel)) @ W
    L1, L2, Lq = L[:, :n1], L[:, n1:n1 + n2], L[:, n1 + n2:]
    Lq = np.where(q_up, Lq, 0.0)
    dni = np.zeros(Tc)
    dni[li] = np.asarray(sky.direct_normal(states.take(li)), dtype=float) @ W
    dni = np.where(el > 0, dni, 0.0)

    # level 1, sky grid outside the disc + the disc with a ray per node
    cos_rad = np.cos(np.radians(ctx["disc_radius"]))
    excl = (s @ g1.T) > cos_rad                                                    # (Tc, n1)
    A1 = ctx["A1"]                                                                 # (n1, n) w v
    W1 = ctx["W1"]                                                                 # (n1, n) w
    sky1 = np.where(excl, 0.0, L1) @ A1
    origins, normals = ctx["origins"], ctx["normals"]
    w_q = om[None, :] * q_up                                                       # (Tc, Q)
    disc = np.zeros((Tc, n))
    ring_lv = np.zeros((Tc, n))
    ring_w = np.zeros((Tc, n))
    for i in range(n):
        c = qd @ normals[i]                                                        # (Tc, Q)
        ok = (c > 0) & q_up & lit[:, None]
        ti, qi = np.nonzero(ok)
        vis = np.zeros(ok.shape)
        if ti.size:
            vis[ti, qi] = ~cast_rays(geom, np.broadcast_to(origins[i], (ti.size, 3)),
                                     qd[ti, qi], occluded=True)
            n_rays += ti.size
        f = Lq * vis * c.clip(min=0.0) * w_q * _optic(ctx["angular"], c)
        disc[:, i] = f.sum(axis=1)
        ring_lv[:, i] = np.sum((Lq * vis * w_q)[:, outer], axis=1)
        ring_w[:, i] = np.sum(w_q[:, outer], axis=1)
    # the excluded grid cells cover a slightly different area than the disc: add (area of the
    # cells - area of the disc), both cosine-weighted, times the disc edge's mean radiance x vis
    wcells = excl.astype(float) @ W1                                               # (Tc, n)
    cosw_disc = np.zeros((Tc, n))
    for i in range(n):
        ci = qd @ normals[i]
        cosw_disc[:, i] = np.sum(w_q * np.maximum(ci, 0.0) * _optic(ctx["angular"], ci), axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        edge = np.where(ring_w > 0, ring_lv / ring_w, 0.0)
    corr = (wcells - cosw_disc) * edge
    out["sky"] = sky1 + disc + corr
    out["corr"] = corr

    # direct
    vis_s = np.zeros((Tc, n))
    cs_n = s @ normals.T
    ok = (cs_n > 0) & (el > 0)[:, None]
    ti, pi = np.nonzero(ok)
    if ti.size:
        vis_s[ti, pi] = ~cast_rays(geom, origins[pi], s[ti], occluded=True)
        n_rays += ti.size
    out["direct"] = dni[:, None] * np.maximum(cs_n, 0.0) * vis_s * _optic(ctx["angular"], cs_n)

    # reflected: second level at every reflector point y
    Y = ctx["y_pos"].shape[0]
    if Y:
        up = el > 0
        # the disc's edge radiance (mean over the outer ring above the horizon); the excess above
        # it is traced with the sun at this second level
        w_out = om[outer][None, :] * q_up[:, outer]
        has_edge = up & (w_out.sum(axis=1) > 0)
        l_edge = np.full(Tc, np.inf)
        l_edge[has_edge] = (np.sum(Lq[:, outer] * w_out, axis=1)[has_edge]
                            / w_out.sum(axis=1)[has_edge])
        cs_exc = np.sum(np.maximum(Lq - l_edge[:, None], 0.0) * w_q, axis=1)      # (Tc,)
        cs_exc = np.where(up, cs_exc, 0.0)
        inside2 = (s @ g2.T) > cos_rad
        L2c = np.where(inside2, np.minimum(L2, l_edge[:, None]), L2)
        E_y = L2c @ ctx["A2"]                                                      # (Tc, Y)
        # unshaded ground radiance for the ground-then-wall path
        L1c = np.where((s @ g1.T) > cos_rad, np.minimum(L1, l_edge[:, None]), L1)
        ghi = (dni + cs_exc) * np.maximum(s[:, 2], 0.0) + L1c @ ctx["g1_h"]
        alb = ctx["ground_albedo"] if ctx["ground_albedo"] is not None else states.albedo
        lg = np.broadcast_to(alb, (Tc,)) * ghi / np.pi
        E_y += lg[:, None] * ctx["y_ground_view"][None, :]
        cy = s @ ctx["y_normal"].T                                                 # (Tc, Y)
        oky = (cy > 0) & up[:, None]
        ti, yi = np.nonzero(oky)
        vis_y = np.zeros((Tc, Y))
        if ti.size:
            vis_y[ti, yi] = ~cast_rays(geom, ctx["y_pos"][yi], s[ti], occluded=True)
            n_rays += ti.size
        E_y += (dni + cs_exc)[:, None] * np.maximum(cy, 0.0) * vis_y
        rho = np.where(ctx["y_ground"][None, :], np.broadcast_to(alb, (Tc,))[:, None],
                       ctx["y_refl"][None, :])
        out["refl"] = (rho * E_y / np.pi) @ ctx["B1"]                              # (Tc, n)
    return out, n_rays


def reference_poa(scene, sky, states: SkyStates, *, points=None, weights=None, sky_mf=16,
                  sky_rays=4, disc_radius=5.0, disc_rings=12, disc_sectors=16, reflect_mf=8,
                  reflect_samples=1, reflect_sky_mf=2, time_chunk=8, n_jobs=1, progress=False,
                  angular=None):
    """Brute-force per-step irradiance at a few analysis points (see the module docstring).

    Parameters
    ----------
    scene : Scene
        The scene (any size; only ``points`` are computed).
    sky : sky source
        E.g. ``PragueSky(elevation_quantum=0)`` (exact states), ``AnalyticSky()``.
    states : SkyStates
        T sky states.
    points : array_like of int, optional
        Analysis point indices (default all: keep scenes small).
    weights : array_like, optional
        (C,) contraction of the channels [1] (default: channel widths, i.e. broadband W m-2).
    sky_mf : int
        Reinhart subdivision of the sky grid (16: 36,865 cells of about 0.8 deg), where the sky
        model is evaluated every step.
    sky_rays : int
        ``k``: k x k visibility rays per cell of that grid (4: about 0.2 deg apart).
    disc_radius : float
        Radius of the circumsolar disc integrated with a sun-centred quadrature [deg].
    disc_rings, disc_sectors : int
        Rings (log-spaced from 0.02 deg) and sectors of that quadrature.
    reflect_mf : int
        Reinhart subdivision of the grid whose rays find the reflector points (both hemispheres).
    reflect_samples : int
        ``k``: k x k rays per cell of that grid.
    reflect_sky_mf : int
        Reinhart subdivision of the reflectors' own sky and ground grids.
    time_chunk : int
        Steps per block.
    n_jobs : int
        Processes for the per-step work (fork; 1 runs here).
    progress : bool
        Progress bar.
    angular : callable, optional
        An incidence-angle optic ``f(aoi_deg) -> factor [1]`` applied per ray at the analysis
        point: to the sun at its angle of incidence, to every sky-grid ray and circumsolar node at
        its angle, and to every ray that reaches a reflector at the angle it arrives (the
        integrator's ``Response.angular``, here without the integrator's approximations).

    Returns
    -------
    ReferenceResult
    """
    t_start = time.perf_counter()
    if scene.ground_albedo is not None and np.ndim(scene.ground_albedo) != 0:
        raise ValueError("reference_poa supports a scalar ground_albedo (or None) only")
    C = sky.n_channels
    if weights is None:
        W = np.diff(np.asarray(sky.channel_edges, dtype=float))
    else:
        W = np.asarray(weights, dtype=float) * np.diff(np.asarray(sky.channel_edges, dtype=float))
    if W.shape != (C,):
        raise ValueError(f"weights must have shape ({C},), got {np.shape(weights)}")
    pts = np.arange(scene.n_points) if points is None else np.asarray(points, dtype=int).ravel()
    geom = scene.geometry()
    origins = scene.ray_origins[pts]
    normals = scene.point_normal[pts]
    n = pts.size
    n_rays = 0

    # level 1: sky grid; radiance at the cell centres, visibility and cosine from k x k rays per
    # cell (the visible part of a cell an occluder's edge cuts is resolved to the sub-cells)
    g1p = reinhart(sky_mf)
    g1 = g1p.directions
    sub_d, sub_w = g1p.subsample(sky_rays)
    cell = np.repeat(np.arange(g1.shape[0]), sub_d.shape[1])
    pi_, di, w, kind, _, _ = _hemisphere_rays(geom, origins, normals, sub_d.reshape(-1, 3),
                                              sub_w.reshape(-1))
    n_rays += pi_.size
    w = w * _optic(angular, np.sum(normals[pi_] * sub_d.reshape(-1, 3)[di], axis=1))
    A1 = np.zeros((g1.shape[0], n))
    W1 = np.zeros((g1.shape[0], n))
    np.add.at(W1, (cell[di], pi_), w)
    sky_ray = kind == 0
    np.add.at(A1, (cell[di[sky_ray]], pi_[sky_ray]), w[sky_ray])

    # level 1, reflection: k x k rays per cell over the sphere; every hit is a reflector point
    rp = reinhart(reflect_mf)
    rd, rw = rp.subsample(reflect_samples)
    rd, rw = rd.reshape(-1, 3), rw.reshape(-1)
    rd_lo = rd.copy()
    rd_lo[:, 2] *= -1.0
    rdir = np.concatenate([rd, rd_lo])
    rwt = np.concatenate([rw, rw])
    pi_, di, w, kind, prim, dist = _hemisphere_rays(geom, origins, normals, rdir, rwt)
    n_rays += pi_.size
    # each cell's exact projected solid angle, split between its rays in front of the point
    kk = reflect_samples * reflect_samples
    exact = np.concatenate([cosine_weights(rp, normals), cosine_weights(rp, normals, lower=True)],
                           axis=1)                                          # (n, 2 P_r)
    ncell = 2 * rp.n_patches
    key = pi_ * ncell + di // kk
    wsum = np.bincount(key, weights=w, minlength=n * ncell)
    w = exact.reshape(-1)[key] * w / wsum[key]
    # cells the face's horizon cuts with none of their rays in front (slivers): their weight goes to
    # the point's other rays of the same hemisphere
    hemi = (di // kk >= rp.n_patches).astype(np.int64)
    got = np.bincount(pi_ * 2 + hemi, weights=w, minlength=2 * n)
    want = np.stack([exact[:, :rp.n_patches].sum(1), exact[:, rp.n_patches:].sum(1)], 1).ravel()
    w = w * np.where(got > 0, want / np.where(got > 0, got, 1.0), 0.0)[pi_ * 2 + hemi]
    w = w * _optic(angular, np.sum(normals[pi_] * rdir[di], axis=1))
    hit = kind > 0
    pi_, di, w, kind, prim, dist = (a[hit] for a in (pi_, di, w, kind, prim, dist))
    d = rdir[di]
    y_ground = kind == 1
    y_pos, y_norm = reflector_points(geom, origins[pi_], d, dist, np.where(y_ground, -1, prim))
    y_refl = np.zeros(pi_.size)
    y_refl[~y_ground] = geom["reflectance"][prim[~y_ground]]
    Y = pi_.size
    B1 = np.zeros((Y, n))
    B1[np.arange(Y), pi_] = w

    # level 2: every reflector's sky (and, for scene surfaces, unshaded ground) through a grid
    g2p = reinhart(reflect_sky_mf)
    g2 = g2p.directions
    g2_lo = g2.copy()
    g2_lo[:, 2] *= -1.0
    A2 = np.zeros((g2.shape[0], Y))
    y_ground_view = np.zeros(Y)
    if Y:
        pi2, di2, w2, kind2, _, _ = _hemisphere_rays(geom, y_pos, y_norm, g2, g2p.solid_angle)
        n_rays += pi2.size
        ok = kind2 == 0
        np.add.at(A2, (di2[ok], pi2[ok]), w2[ok])
        wall = np.nonzero(~y_ground)[0]
        if wall.size:
            pi3, di3, w3, kind3, _, _ = _hemisphere_rays(geom, y_pos[wall], y_norm[wall], g2_lo,
                                                         g2p.solid_angle)
            n_rays += pi3.size
            ok = kind3 == 1
            y_ground_view[wall] = np.bincount(pi3[ok], weights=w3[ok], minlength=wall.size)
    t_geom = time.perf_counter() - t_start

    ctx = {"sky": sky, "states": states, "W": W, "geom": geom, "origins": origins,
           "normals": normals, "g1_dirs": g1, "g2_dirs": g2, "A1": A1, "W1": W1,
           "g1_h": g1p.vector[:, 2], "A2": A2, "B1": B1, "y_pos": y_pos, "y_normal": y_norm,
           "y_ground": y_ground, "y_refl": y_refl, "y_ground_view": y_ground_view,
           "ground_albedo": scene.ground_albedo, "disc_radius": float(disc_radius),
           "disc": _disc_nodes(disc_radius, disc_rings, disc_sectors),
           "min_el": getattr(sky, "min_sun_elevation", 0.0), "angular": angular}
    T = len(states)
    bounds = [(a, min(a + time_chunk, T)) for a in range(0, T, time_chunk)]
    # skip chunks with no lit step cheaply
    bounds = [(a, b) for a, b in bounds if np.any(states.sun_elevation[a:b] > ctx["min_el"])]
    res = {q: np.zeros((T, n)) for q in ("direct", "sky", "refl", "corr")}
    bar = None
    if progress:
        bar = tqdm(total=len(bounds), unit="chunk", desc="reference")

    def take(a, b, r):
        nonlocal n_rays
        out, nr = r
        n_rays += nr
        for q in res:
            res[q][a:b] = out[q]
        if bar is not None:
            bar.update(1)

    if n_jobs is None:
        n_jobs = os.cpu_count() or 1
    if n_jobs > 1 and len(bounds) > 1:
        _CONTEXT.clear()
        _CONTEXT.update(ctx)
        try:
            with ProcessPoolExecutor(n_jobs, mp_context=multiprocessing.get_context("fork")) as ex:
                for (a, b), r in zip(bounds, ex.map(_chunk_worker, *zip(*bounds))):
                    take(a, b, r)
        finally:
            _CONTEXT.clear()
    else:
        for a, b in bounds:
            take(a, b, _steps(ctx, a, b))
    if bar is not None:
        bar.close()
    glob = res["direct"] + res["sky"] + res["refl"]
    t_total = time.perf_counter() - t_start
    return ReferenceResult(poa_global=glob, poa_direct=res["direct"], poa_sky_diffuse=res["sky"],
                           poa_ground_diffuse=res["refl"], points=pts,
                           disc_correction=res["corr"], n_rays=int(n_rays),
                           timings={"geometry": t_geom, "steps": t_total - t_geom,
                                    "total": t_total})


def _grid_quads(nx, nz, width, height):
    """Vertices and triangles of a vertical nx x nz grid of quads facing -y (south), lower left
    corner at the origin, x east, z up."""
    xs, zs = np.linspace(0.0, width, nx + 1), np.linspace(0.0, height, nz + 1)
    X, Z = np.meshgrid(xs, zs, indexing="ij")
    v = np.column_stack([X.ravel(), np.zeros(X.size), Z.ravel()])
    idx = np.arange(v.shape[0]).reshape(nx + 1, nz + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    # counter-clockwise seen from the south (-y): normal -y
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return v, f


def validation_scenes():
    """The two scenes of the integrator's validation against this reference.

    ``"tilted_plane"``: a 2 m x 1 m plane tilted 35 deg towards south (azimuth 180), centre 1.2 m
    above the ground, nothing else (it still shades the ground below it); 2 analysis triangles.

    ``"obstructed_facade"``: the south facade (12 m wide, 9 m tall, 3 x 2 quads: 12 triangles) of a
    12 x 10 x 9 m building, facing a 15 m tall, 30 m wide building 14 m to the south and an 8 m tall
    one to the south-east (reflectance 0.3; facade 0.2).

    Both stand on a ground plane at z = 0 whose albedo comes from the sky states.

    Returns
    -------
    dict of str to Scene
    """
    scenes = {}
    # tilted plane
    n = direction_from_angles(90.0 - 35.0, 180.0)
    v = np.array([[-1.0, -0.5, 0.0], [1.0, -0.5, 0.0], [1.0, 0.5, 0.0], [-1.0, 0.5, 0.0]])
    rot = trimesh.geometry.align_vectors([0, 0, 1], n)
    v = v @ rot[:3, :3].T + (0.0, 0.0, 1.2)
    plane = trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)
    scenes["tilted_plane"] = make_scene(plane, ground_z=0.0, analysis_reflectance=0.1)
    # obstructed facade
    fv, ff = _grid_quads(3, 2, 12.0, 9.0)
    facade = trimesh.Trimesh(fv + (-6.0, 0.0, 0.0), ff, process=False)
    body = trimesh.creation.box(extents=(12.0, 10.0, 9.0))
    body.apply_translation((0.0, 5.0 + 0.01, 4.5))          # its south face 1 cm behind the facade
    south = trimesh.creation.box(extents=(30.0, 8.0, 15.0))
    south.apply_translation((-4.0, -14.0 - 4.0, 7.5))
    south_east = trimesh.creation.box(extents=(10.0, 10.0, 8.0))
    south_east.apply_translation((16.0, -12.0 - 5.0, 4.0))
    scenes["obstructed_facade"] = make_scene(facade, [body, south, south_east], ground_z=0.0,
                                             analysis_reflectance=0.2, context_reflectance=0.3)
    return scenes
