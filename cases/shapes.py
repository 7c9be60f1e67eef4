"""Mesh pieces for case geometry scripts: rectangles split into quads, boxes, merged meshes.

Arrays in metres east (x), north (y), up (z); triangles as (M, 3) vertex indices.
"""

from __future__ import annotations

import numpy as np

__all__ = ["quad_grid", "box", "merge"]


def quad_grid(origin, u, v, nu, nv):
    """The rectangle ``origin + [0, 1] u + [0, 1] v`` [m] split into ``nu x nv`` quads of two triangles each;
    the triangle normals point along ``u x v``. Returns (vertices (V, 3), triangles (M, 3))."""
    o, u, v = (np.asarray(a, float) for a in (origin, u, v))
    nu, nv = int(nu), int(nv)
    if nu < 1 or nv < 1:
        raise ValueError(f"nu={nu}, nv={nv}: at least one quad along each side")
    i, j = np.meshgrid(np.arange(nu + 1), np.arange(nv + 1), indexing="ij")
    verts = (o + (i / nu)[..., None] * u + (j / nv)[..., None] * v).reshape(-1, 3)
    a, b = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    k00 = (a * (nv + 1) + b).ravel()
    k10, k11, k01 = k00 + nv + 1, k00 + nv + 2, k00 + 1
    tris = np.stack([np.stack([k00, k10, k11], 1), np.stack([k00, k11, k01], 1)], axis=1).reshape(-1, 3)
    return verts, tris


def merge(parts):
    """One mesh (vertices, triangles) from a list of (vertices, triangles)."""
    verts, tris, base = [], [], 0
    for v, f in parts:
        verts.append(np.asarray(v, float))
        tris.append(np.asarray(f) + base)
        base += len(v)
    return np.concatenate(verts), np.concatenate(tris)


def box(x0, y0, z0, x1, y1, height):
    """Walls and flat roof (no floor) of a box on [x0, x1] x [y0, y1] from z0 up ``height`` [m]; outward
    normals."""
    dx, dy = x1 - x0, y1 - y0
    return merge([quad_grid((x0, y0, z0 + height), (dx, 0, 0), (0, dy, 0), 1, 1),     # roof (+z)
                  quad_grid((x0, y0, z0), (dx, 0, 0), (0, 0, height), 1, 1),          # south wall (-y)
                  quad_grid((x1, y1, z0), (-dx, 0, 0), (0, 0, height), 1, 1),         # north wall (+y)
                  quad_grid((x1, y0, z0), (0, dy, 0), (0, 0, height), 1, 1),          # east wall (+x)
                  quad_grid((x0, y1, z0), (0, -dy, 0), (0, 0, height), 1, 1)])        # west wall (-x)
