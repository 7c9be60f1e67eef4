"""Ray primitives of the integrator's ray casting (:mod:`widesky.irradiance.raycast`,
:mod:`widesky.irradiance.raystages`): the Embree scene of a process, ray casting, reflector hit points,
deterministic secondary directions, sun-position bins and the reflector shading cells.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh

from .patches import _TREGENZA_COUNTS, angles_from_direction, direction_from_angles, orthonormal_frame

__all__ = ["cast_rays", "reflector_points", "reflector_bins", "sun_bins", "shade_band", "shade_cells",
           "SHADE_BANDS", "SHADE_SECTORS"]

_SCENE_CACHE: dict = {}
"""The Embree scene of this process, by the scene's key (one at a time)."""

#: Sun-elevation band edges [deg] of the reflector shading cells and the azimuth sector width [deg]
#: of each band (cells are narrower where the sun moves faster across the sky and shadows change most).
SHADE_BANDS = (0.0, 10.0, 20.0, 35.0, 50.0, 90.0)
SHADE_SECTORS = (30.0, 30.0, 45.0, 60.0, 120.0)


def _clear_dni(elevation):
    """Relative clear-sky direct normal irradiance [1] (Meinel 0.7 ** AM ** 0.678, Kasten-Young air
    mass): only the weighting of sun-position bins for the reflector shading samples."""
    el = np.asarray(elevation, dtype=float)
    zen = 90.0 - el
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        am = 1.0 / (np.cos(np.radians(zen)) + 0.50572 * np.maximum(96.07995 - zen, 1e-6) ** -1.6364)
        return np.where(el > 0, 0.7 ** (np.where(el > 0, am, 1.0) ** 0.678), 0.0)


def shade_band(elevation):
    """Index of the :data:`SHADE_BANDS` band of sun elevations [deg] (-1 at or below 0)."""
    el = np.asarray(elevation, dtype=float)
    b = np.searchsorted(np.asarray(SHADE_BANDS), el, side="left") - 1
    return np.where(el > 0, np.clip(b, 0, len(SHADE_BANDS) - 2), -1)


def shade_cells(sun_directions):
    """Reflector shading cell of each sun direction: (n,) index into the occupied cells (-1 at or
    below the horizon) and their number G.

    A cell is an elevation band of :data:`SHADE_BANDS` times an azimuth sector of that band's
    :data:`SHADE_SECTORS` width [deg]; cells no direction falls in are dropped, the others numbered
    in (band, sector) order.
    """
    d = np.asarray(sun_directions, dtype=float).reshape(-1, 3)
    el = np.degrees(np.arcsin(np.clip(d[:, 2], -1.0, 1.0)))
    az = np.mod(np.degrees(np.arctan2(d[:, 0], d[:, 1])), 360.0)
    band = shade_band(el)
    width = np.asarray(SHADE_SECTORS)[np.maximum(band, 0)]
    raw = np.where(band >= 0, band * 64 + np.floor(az / width).astype(int), -1)
    up = raw >= 0
    cells, inv = np.unique(raw[up], return_inverse=True)
    out = np.full(d.shape[0], -1)
    out[up] = inv.reshape(-1)
    return out, int(cells.size)


def reflector_bins():
    """(42, 3) orientation bins for reflecting surfaces: up, down and 8 azimuths at tilts 30-150 deg."""
    dirs = [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0)]
    for tilt in (30.0, 60.0, 90.0, 120.0, 150.0):
        for az in np.arange(0.0, 360.0, 45.0):
            dirs.append(tuple(direction_from_angles(90.0 - tilt, az)))
    return np.array(dirs)


def sun_bins(sun_directions, size=1.0):
    """Group sun directions into sky cells of about ``size`` degrees.

    The cells are a Reinhart subdivision of the sky (:func:`widesky.irradiance.patches.reinhart`) with
    ``mf = round(90 / (7 size))`` (ring height ``90 / (7 mf + 0.5)`` deg); each occupied cell is
    represented by the normalised mean of its members, so a member lies within about one cell
    diagonal of its representative (measured for an hourly year at 50 N and ``size=1``: 3.4x fewer
    directions, mean 0.24 deg, max 0.70 deg from the representative; the sun's disc has a radius of
    0.27 deg).

    Parameters
    ----------
    sun_directions : array_like
        (S, 3) ENU unit vectors towards the sun.
    size : float
        Cell size [deg]; 0 gives one bin per direction (exact).

    Returns
    -------
    representatives : numpy.ndarray
        (S_b, 3) unit vectors, one per occupied bin.
    index : numpy.ndarray
        (S,) bin of each direction (int64).
    """
    s = np.asarray(sun_directions, dtype=float).reshape(-1, 3)
    if not size >= 0:
        raise ValueError(f"sun_bin={size} deg must be >= 0")
    if size == 0 or s.shape[0] == 0:
        return s.copy(), np.arange(s.shape[0], dtype=np.int64)
    mf = max(1, int(round(90.0 / (7.0 * float(size)))))
    # the cell of reinhart(mf).index, without building the patch set: ring of height h (the last
    # is the zenith cap), mf * Tregenza count azimuth sectors per ring
    h = 90.0 / (7 * mf + 0.5)
    alt, az = angles_from_direction(s)
    ring = np.clip(np.floor(alt / h).astype(np.int64), 0, 7 * mf)
    counts = np.array([mf * _TREGENZA_COUNTS[r // mf] for r in range(7 * mf)] + [1])
    col = np.minimum((az / 360.0 * counts[ring]).astype(np.int64), counts[ring] - 1)
    cells = ring * (mf * 30) + col                                      # unique per (ring, col)
    cells = np.where(s[:, 2] > 0, cells, -1 - np.arange(s.shape[0]))  # below the horizon: own bin
    _, index = np.unique(cells, return_inverse=True)
    index = index.reshape(-1).astype(np.int64)
    rep = np.zeros((int(index.max()) + 1, 3))
    np.add.at(rep, index, s)
    rep /= np.linalg.norm(rep, axis=1, keepdims=True)
    return rep, index


def _embree_scene(geometry):
    key = geometry["key"]
    sc = _SCENE_CACHE.get(key)
    if sc is None:
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


def _fbincount(idx, weights, minlength):
    """``numpy.bincount`` that stays float64 when there is nothing to count."""
    return np.bincount(idx, weights=weights, minlength=minlength).astype(float, copy=False)


def reflector_points(geometry, origins, directions, t_hit, prim):
    """Points where rays reach a reflector, moved off it on the side the ray came from.

    Parameters
    ----------
    geometry : dict
        ``Scene.geometry()``.
    origins, directions : numpy.ndarray
        (n, 3) recentred ray origins [m] and unit directions.
    t_hit : numpy.ndarray
        (n,) hit distances [m].
    prim : numpy.ndarray
        (n,) triangle hit (-1: the ground plane).

    Returns
    -------
    tuple of numpy.ndarray
        (n, 3) points [m] and (n, 3) unit normals of the side the ray sees (the ground's is up).

    The point is backed off along the ray (the segment before the hit is free, so this stays on the
    ray's side even at a box's edge, where the float32 hit can land a rounding error outside the
    adjacent wall) and then off the surface along the seen normal (for grazing rays).
    """
    eps = geometry["ray_offset"]
    scene = prim >= 0
    if np.any(scene):       # every row's normal and in-front test (row by row, the same values), then selected
        tn = np.take(geometry["triangle_normals"], np.where(scene, prim, 0), axis=0)
        p = tn * directions
        flip = (p[:, 0] + p[:, 1]) + p[:, 2] > 0         # numpy's sum over the axis of 3, in its order
        np.negative(tn, out=tn, where=(flip & scene)[:, None])
    else:
        tn = np.empty((prim.size, 3))
    tn[~scene] = (0.0, 0.0, 1.0)
    back = np.minimum(eps, 0.5 * t_hit)
    x = (t_hit - back)[:, None] * directions            # origins + this + eps tn, in that order
    x += origins
    x += eps * tn
    return x, tn


def _distinct_rows(v):
    """(distinct rows of ``v`` (m, 3) float64, index (n,) of each row among them), bit for bit (signed zeros
    apart): one 64-bit key per row from its bits, hashed (``pandas.factorize``), then checked; (None, None) where
    two rows with different bits share a key or there are more than 4,096."""
    v = np.ascontiguousarray(v, dtype=np.float64)
    b = v.view(np.uint64)
    key = np.zeros(b.shape[0], dtype=np.uint64)
    for j, c in enumerate((0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9)):
        key ^= b[:, j]
        key ^= key >> np.uint64(31)                   # the high bits (sign, exponent) mixed into the low ones
        key *= np.uint64(c)
    nid, uniq = pd.factorize(key)
    if uniq.size > 4096:
        return None, None
    rows = np.empty((uniq.size, 3))
    rows[nid] = v
    if not np.array_equal(np.take(rows, nid, axis=0).view(np.uint64), b):
        return None, None
    return rows, nid


def _by_distinct_rows(f, v):
    """``f(v)`` for a row-wise function ``f`` of (m, 3) rows (each output row a function of its input row alone),
    evaluated once per distinct row of ``v`` and gathered: the same values where ``v`` (planar scenes) has few
    distinct rows (normals). ``f`` may return a tuple of arrays. A lone distinct row is evaluated twice, so that
    a matrix product with it stays numpy's matrix-matrix product (BLAS gemm, whose rows do not depend on the
    others'), not the matrix-vector path, whose rounding differs (``tests/test_raystages_sun.py``); one row in
    ``v`` is evaluated as it is."""
    if v.shape[0] < 2:
        return f(v)
    rows, nid = _distinct_rows(v)
    if rows is None or 4 * rows.shape[0] > v.shape[0]:
        return f(v)
    if rows.shape[0] == 1:
        rows = np.repeat(rows, 2, axis=0)
    out = f(rows)
    return tuple(np.take(o, nid, axis=0) for o in out) if isinstance(out, tuple) else np.take(out, nid, axis=0)


def _cosine_directions(normals, ids):
    """Cosine-distributed unit directions (n, 3) about unit normals (n, 3), one per integer id.

    The samples come from the R2 low-discrepancy sequence (Roberts 2018) indexed by ``ids``, so a
    ray's secondary direction depends only on its identity (deterministic, independent of chunking).
    """
    ids = np.asarray(ids, dtype=np.float64)
    # u = frac(0.5 + ids c): u - floor(u) is exact (Sterbenz), so equal to numpy.mod(u, 1) and faster; in place
    u1 = ids * 0.7548776662466927
    u1 += 0.5
    u1 -= np.floor(u1)
    phi = ids * 0.5698402909980532
    phi += 0.5
    phi -= np.floor(phi)
    phi *= 2 * np.pi
    r = np.sqrt(u1)
    z = np.subtract(1, u1, out=u1)
    np.sqrt(np.maximum(z, 0.0, out=z), out=z)
    t, b = _by_distinct_rows(orthonormal_frame, np.asarray(normals, dtype=float))
    out = (r * np.cos(phi))[:, None] * t               # x t + y b + z n, in that order
    out += (r * np.sin(phi))[:, None] * b
    out += z[:, None] * normals
    return out
