"""Embree ray casting of the daylight-coefficient matrix and of sun visibility (computed once).

For every analysis point the hemisphere in front of it is cut into the sky patches (upper hemisphere)
and their mirror images (lower hemisphere). ``k x k`` stratified rays per patch (equal solid angle cells)
estimate which fraction of the patch's *exact* projected solid angle (:func:`patches.cosine_weights`)
is open sky, ground or a scene surface::

    coefficient[f, p] = W_exact[f, p] * sum_s w_fs v_fs / sum_s w_fs,   w_fs = cell_solid_angle * cos

so an unobstructed face gets the exact projected solid angles (furnace-exact) and an obstructed one a
stratified estimate of the visible part. Rays that hit a scene surface feed one-bounce reflection:
their share times the surface's reflectance is accumulated per orientation bin of the hit surface's
normal (42 bins). Rays down that miss the scene reach the ground plane. Every reflecting point (scene
hit or ground) gets one cosine-distributed secondary ray: whether it escapes the scene estimates the
point's open fraction, which scales its (unshaded) irradiance in the integrator, so a closed box stays
dark and the ground between rows or in a courtyard is dimmed by its own sky view (a proxy for its
shading, exact for fully open and fully enclosed reflectors). A ray towards the sun per step (and per
point) gives sun visibility, packed to bits.

Embree (through embreex) is single-threaded and holds the GIL, so the work is split into independent
tasks over chunks of points that each worker process runs on its own copy of the scene (cached per
process): a local process pool by default, or any ``concurrent.futures.Executor`` (e.g.
``dask.distributed.Client.get_executor()``).
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
import multiprocessing

import numpy as np

from .patches import cosine_weights, direction_from_angles, reinhart

__all__ = ["Coefficients", "compute_coefficients", "reflector_bins", "cast_rays"]

_SCENE_CACHE: dict = {}


def reflector_bins():
    """(42, 3) orientation bins for reflecting surfaces: up, down and 8 azimuths at tilts 30-150 deg."""
    dirs = [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0)]
    for tilt in (30.0, 60.0, 90.0, 120.0, 150.0):
        for az in np.arange(0.0, 360.0, 45.0):
            dirs.append(tuple(direction_from_angles(90.0 - tilt, az)))
    return np.array(dirs)


def _embree_scene(geometry):
    key = geometry["key"]
    sc = _SCENE_CACHE.get(key)
    if sc is None:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh
        sc = rtcore_scene.EmbreeScene()
        TriangleMesh(scene=sc, vertices=np.ascontiguousarray(geometry["vertices"], dtype=np.float32),
                     indices=np.ascontiguousarray(geometry["triangles"], dtype=np.int32))
        _SCENE_CACHE.clear()              # one scene per process at a time
        _SCENE_CACHE[key] = sc
    return sc


def cast_rays(geometry, origins, directions, max_distance=None, *, occluded=False,
              distance=False, batch=1 << 20):
    """Cast rays through the scene.

    Parameters
    ----------
    geometry : dict
        ``Scene.geometry()``.
    origins, directions : numpy.ndarray
        (n, 3) recentred origins [m] and unit directions.
    max_distance : numpy.ndarray, optional
        (n,) ray lengths [m]; hits beyond are misses.
    occluded : bool
        Only test for any hit (faster); returns a bool array.
    distance : bool
        Also return the hit distance (n,) [m] (``inf`` for a miss).
    batch : int
        Rays per Embree call.

    Returns
    -------
    numpy.ndarray
        (n,) index of the first triangle hit (-1 for a miss), or (n,) bool when ``occluded``;
        with ``distance``, a tuple (index, distance).
    """
    sc = _embree_scene(geometry)
    n = origins.shape[0]
    out = np.empty(n, dtype=bool if occluded else np.int32)
    dist = np.full(n, np.inf) if distance else None
    for i in range(0, n, batch):
        o = np.ascontiguousarray(origins[i:i + batch], dtype=np.float32)
        d = np.ascontiguousarray(directions[i:i + batch], dtype=np.float32)
        kw = {}
        if max_distance is not None:
            md = np.minimum(max_distance[i:i + batch], 1e30)
            kw["dists"] = np.ascontiguousarray(md, dtype=np.float32)
        if occluded:
            out[i:i + batch] = sc.run(o, d, query="OCCLUDED", **kw) >= 0
        elif distance:
            res = sc.run(o, d, output=1, **kw)
            out[i:i + batch] = res["primID"]
            dist[i:i + batch] = np.where(res["primID"] >= 0, res["tfar"], np.inf)
        else:
            out[i:i + batch] = sc.run(o, d, **kw)
    return (out, dist) if distance else out


def _cosine_directions(normals, ids):
    """Cosine-distributed unit directions (n, 3) about unit normals (n, 3), one per integer id.

    The samples come from the R2 low-discrepancy sequence (Roberts 2018) indexed by ``ids``, so a
    ray's secondary direction depends only on its identity (deterministic, independent of chunking).
    """
    ids = np.asarray(ids, dtype=np.float64)
    u1 = np.mod(0.5 + ids * 0.7548776662466927, 1.0)
    u2 = np.mod(0.5 + ids * 0.5698402909980532, 1.0)
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    local = np.column_stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(1 - u1, 0.0))])
    ref = np.where(np.abs(normals[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    t = np.cross(ref, normals)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(normals, t)
    return local[:, :1] * t + local[:, 1:2] * b + local[:, 2:3] * normals


@dataclass(frozen=True, eq=False)
class Coefficients:
    """Per-point geometry factors, computed once per scene and patch scheme.

    Attributes
    ----------
    sky : numpy.ndarray
        (N, P) float32 visibility-weighted projected solid angle of each sky patch [sr].
    ground : numpy.ndarray
        (N,) projected solid angle of visible ground, times the open fraction of the ground points
        seen [sr].
    reflect : numpy.ndarray
        (N, B) projected solid angle of scene surfaces per orientation bin of their normal, times their
        reflectance and open fraction [sr].
    bins : numpy.ndarray
        (B, 3) bin normals.
    sun_visible : numpy.ndarray
        (N, ceil(S / 8)) uint8, bits (``numpy.packbits`` along axis 1) of sun visibility for the S
        sun directions given.
    n_sun : int
        S.
    n_rays : int
        Rays cast.
    seconds : float
        Wall time of the ray casting [s].
    """

    sky: np.ndarray
    ground: np.ndarray
    reflect: np.ndarray
    bins: np.ndarray
    sun_visible: np.ndarray
    n_sun: int
    n_rays: int
    seconds: float

    def sun_visibility(self, start=0, stop=None):
        """(N, stop - start) bool sun visibility for sun directions ``start:stop``."""
        stop = self.n_sun if stop is None else stop
        b0 = start // 8
        bits = np.unpackbits(self.sun_visible[:, b0:(stop + 7) // 8], axis=1)
        return bits[:, start - 8 * b0: start - 8 * b0 + (stop - start)].astype(bool)


def _sample_directions(mf, k):
    patches = reinhart(mf)
    d, w = patches.subsample(k)                                        # (P, K, 3), (P, K)
    d_lo = d.copy()
    d_lo[..., 2] *= -1.0
    return patches, np.concatenate([d, d_lo]), np.concatenate([w, w])  # (2P, K, 3), (2P, K)


def _chunk_task(geometry, origins, normals, buried, mf, k, sun_dirs, bins, first=0):
    """Coefficients for one chunk of points (runs in a worker process)."""
    t0 = time.perf_counter()
    patches, dirs, wcell = _sample_directions(mf, k)
    P, K = patches.n_patches, dirs.shape[1]
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
    hit = np.full((n, 2 * P * K), -2, dtype=np.int32)
    prim, dist = cast_rays(geometry, o, d, maxd, distance=True)
    hit[fi, si] = prim
    n_rays = fi.size
    # one bounce: the open fraction of every reflecting point (scene hit or ground), from one
    # cosine-distributed secondary ray per hit, its direction fixed by the ray's identity
    on_ground = (prim < 0) & down
    refl_ray = (prim >= 0) | on_ground
    ri = np.nonzero(refl_ray)[0]
    tn = np.zeros((ri.size, 3))
    sel_scene = prim[ri] >= 0
    tn[~sel_scene] = (0.0, 0.0, 1.0)
    tn_s = geometry["triangle_normals"][prim[ri[sel_scene]]]
    flip = np.sum(tn_s * d[ri[sel_scene]], axis=1) > 0
    tn[sel_scene] = np.where(flip[:, None], -tn_s, tn_s)          # the side the ray sees
    t_hit = np.where(sel_scene, dist[ri], maxd[ri])
    x = o[ri] + t_hit[:, None] * d[ri] + geometry["ray_offset"] * tn
    sd = _cosine_directions(tn, (fi[ri] + first) * (2 * P * K) + si[ri])
    smax = np.full(ri.size, np.inf)
    sdown = sd[:, 2] < 0
    smax[sdown] = np.maximum((gz - x[sdown, 2]) / sd[sdown, 2], 1e-9)
    open_ = np.zeros(fi.size)
    open_[ri] = ~cast_rays(geometry, x, sd, smax, occluded=True)
    n_rays += ri.size
    open_hit = np.zeros((n, 2 * P * K))
    open_hit[fi, si] = open_
    w3 = w.reshape(n, 2 * P, K)
    wsum = w3.sum(axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(wsum[..., None] > 0, exact[..., None] * w3 / wsum[..., None], 0.0)
    hit3 = hit.reshape(n, 2 * P, K)
    miss = hit3 == -1
    sky = np.sum(share[:, :P] * miss[:, :P], axis=2)
    open3 = open_hit.reshape(n, 2 * P, K)
    ground = np.sum(share[:, P:] * miss[:, P:] * open3[:, P:], axis=(1, 2))
    ground_geo = np.sum(share[:, P:] * miss[:, P:], axis=(1, 2))
    # patches with a positive exact weight but no sample in front of the face (slivers at the face's
    # horizon): use the face's mean open fraction of that hemisphere
    sliver = (wsum <= 0) & (exact > 0)
    if np.any(sliver):
        tot_up, tot_lo = share[:, :P].sum(axis=(1, 2)), share[:, P:].sum(axis=(1, 2))
        with np.errstate(invalid="ignore", divide="ignore"):
            f_up = np.where(tot_up > 0, sky.sum(axis=1) / tot_up, 1.0)
            f_lo = np.where(tot_lo > 0, ground_geo / tot_lo, 1.0)
        sky = sky + np.where(sliver[:, :P], exact[:, :P] * f_up[:, None], 0.0)
        ground = ground + np.sum(np.where(sliver[:, P:], exact[:, P:], 0.0), axis=1) * f_lo
    sky[buried] = 0.0
    ground[buried] = 0.0

    B = bins.shape[0]
    reflect = np.zeros(n * B)
    hf, hs = np.nonzero(hit >= 0)
    if hf.size:
        prim_h = hit[hf, hs]
        tn = geometry["triangle_normals"][prim_h]
        rd = flat[hs]
        tn = np.where((np.sum(tn * rd, axis=1) > 0)[:, None], -tn, tn)   # the side the ray sees
        b = np.argmax(tn @ bins.T, axis=1)
        wts = (share.reshape(n, -1)[hf, hs] * geometry["reflectance"][prim_h]
               * open_hit[hf, hs])
        reflect += np.bincount(hf * B + b, weights=wts, minlength=n * B)
    reflect = reflect.reshape(n, B)

    # sun visibility
    S = sun_dirs.shape[0]
    vis = np.zeros((n, S), dtype=bool)
    if S:
        cs = normals @ sun_dirs.T
        ok = (cs > 0) & ~buried[:, None] & (sun_dirs[:, 2] > 0)[None, :]
        pf, ps = np.nonzero(ok)
        vis[pf, ps] = ~cast_rays(geometry, origins[pf], sun_dirs[ps], occluded=True)
        n_rays += pf.size
    return {"sky": sky.astype(np.float32), "ground": ground, "reflect": reflect,
            "sun": np.packbits(vis, axis=1), "n_rays": n_rays,
            "seconds": time.perf_counter() - t0}


def _default_executor(n_jobs):
    ctx = multiprocessing.get_context("fork" if os.name == "posix" else "spawn")
    return ProcessPoolExecutor(max_workers=n_jobs, mp_context=ctx)


def compute_coefficients(scene, *, mf=1, rays_per_patch=2, sun_directions=None, n_jobs=None,
                         chunk_size=None, executor=None, progress=False):
    """Daylight coefficients, ground and reflection factors and sun visibility of every point.

    Parameters
    ----------
    scene : Scene
        The scene.
    mf : int
        Reinhart subdivision of the sky (1 = 145 patches).
    rays_per_patch : int
        ``k``: k x k rays per patch and hemisphere.
    sun_directions : array_like, optional
        (S, 3) ENU unit vectors towards the sun (one per daylight step).
    n_jobs : int, optional
        Worker processes (default: all cores); 1 runs in this process.
    chunk_size : int, optional
        Points per task; default bounds a task's working memory to a few hundred MB.
    executor : concurrent.futures.Executor, optional
        Runs the tasks instead of a local process pool.
    progress : bool
        Show a progress bar.

    Returns
    -------
    Coefficients
    """
    t0 = time.perf_counter()
    sun = np.zeros((0, 3)) if sun_directions is None else np.asarray(sun_directions, float)
    sun = sun.reshape(-1, 3)
    bins = reflector_bins()
    geom = scene.geometry()
    origins, normals, buried = scene.ray_origins, scene.point_normal, scene.point_buried
    n = scene.n_points
    if chunk_size is None:
        n_dirs = 2 * (144 * mf * mf + 1) * rays_per_patch ** 2
        chunk_size = int(max(32, min(2000, 4_000_000 // n_dirs)))
        if n_jobs != 1:       # at least two tasks per worker for balance
            chunk_size = int(max(32, min(chunk_size, -(-n // (2 * (os.cpu_count() or 1))))))
    bounds = [(i, min(i + chunk_size, n)) for i in range(0, n, chunk_size)]
    args = [(geom, origins[a:b], normals[a:b], buried[a:b], mf, rays_per_patch, sun, bins, a)
            for a, b in bounds]
    n_jobs = (os.cpu_count() or 1) if n_jobs is None else int(n_jobs)
    bar = None
    if progress:
        from tqdm.auto import tqdm
        bar = tqdm(total=n, unit="point", desc="ray casting")
    results = [None] * len(args)
    own = None
    try:
        if executor is None and (n_jobs <= 1 or len(args) == 1):
            for i, a in enumerate(args):
                results[i] = _chunk_task(*a)
                if bar is not None:
                    bar.update(bounds[i][1] - bounds[i][0])
        else:
            ex = executor if executor is not None else _default_executor(n_jobs)
            own = ex if executor is None else None
            futs = {ex.submit(_chunk_task, *a): i for i, a in enumerate(args)}
            from concurrent.futures import as_completed
            for f in as_completed(futs):
                i = futs[f]
                results[i] = f.result()
                if bar is not None:
                    bar.update(bounds[i][1] - bounds[i][0])
    finally:
        if own is not None:
            own.shutdown()
        if bar is not None:
            bar.close()
    return Coefficients(sky=np.concatenate([r["sky"] for r in results]),
                        ground=np.concatenate([r["ground"] for r in results]),
                        reflect=np.concatenate([r["reflect"] for r in results]),
                        bins=bins, sun_visible=np.concatenate([r["sun"] for r in results]),
                        n_sun=int(sun.shape[0]), n_rays=int(sum(r["n_rays"] for r in results)),
                        seconds=time.perf_counter() - t0)
