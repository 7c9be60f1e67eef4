"""Geometry of the solar_potential case: an office block in a street, its roof and four facades analysed
on a grid of about ``cell`` metres, two neighbouring blocks as context.

Coordinates: metres east (x), north (y), up (z); the ground is z = 0.
"""

import numpy as np


def _grid(origin, u, v, nu, nv):
    """A rectangle origin + [0, 1] u + [0, 1] v split into nu x nv quads (2 triangles each); the triangle
    normals follow u x v."""
    o, u, v = (np.asarray(a, float) for a in (origin, u, v))
    i, j = np.meshgrid(np.arange(nu + 1), np.arange(nv + 1), indexing="ij")
    verts = o + (i / nu)[..., None] * u + (j / nv)[..., None] * v
    verts = verts.reshape(-1, 3)
    idx = lambda a, b: a * (nv + 1) + b  # noqa: E731
    faces = []
    for a in range(nu):
        for b in range(nv):
            faces.append([idx(a, b), idx(a + 1, b), idx(a + 1, b + 1)])
            faces.append([idx(a, b), idx(a + 1, b + 1), idx(a, b + 1)])
    return verts, np.array(faces)


def _box(x0, y0, x1, y1, height):
    """Closed box without its bottom (walls and roof), outward normals."""
    parts = [
        _grid((x0, y0, height), (x1 - x0, 0, 0), (0, y1 - y0, 0), 1, 1),          # roof (up)
        _grid((x0, y0, 0), (x1 - x0, 0, 0), (0, 0, height), 1, 1),                 # south wall (-y)
        _grid((x1, y1, 0), (x0 - x1, 0, 0), (0, 0, height), 1, 1),                 # north wall (+y)
        _grid((x1, y0, 0), (0, y1 - y0, 0), (0, 0, height), 1, 1),                 # east wall (+x)
        _grid((x0, y1, 0), (0, y0 - y1, 0), (0, 0, height), 1, 1),                 # west wall (-x)
    ]
    return _merge(parts)


def _merge(parts):
    verts, faces, base = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces.append(f + base)
        base += len(v)
    return np.concatenate(verts), np.concatenate(faces)


def build(parameters):
    """Meshes of the case: analysis groups roof and facade_<orientation>, context neighbours."""
    w = float(parameters.get("width", 24.0))       # east-west [m]
    d = float(parameters.get("depth", 14.0))       # north-south [m]
    h = float(parameters.get("height", 18.0))      # [m]
    street = float(parameters.get("street", 14.0))  # width of the street south of the block [m]
    cell = float(parameters.get("cell", 2.0))      # analysis grid [m]
    nw, nd, nh = (max(1, int(round(x / cell))) for x in (w, d, h))
    analysis = {
        "roof": _grid((0, 0, h), (w, 0, 0), (0, d, 0), nw, nd),
        "facade_south": _grid((0, 0, 0), (w, 0, 0), (0, 0, h), nw, nh),
        "facade_north": _grid((w, d, 0), (-w, 0, 0), (0, 0, h), nw, nh),
        "facade_east": _grid((w, 0, 0), (0, d, 0), (0, 0, h), nd, nh),
        "facade_west": _grid((0, d, 0), (0, -d, 0), (0, 0, h), nd, nh),
    }
    context = {
        # a taller block across the street to the south, a lower one beside it to the east
        "block_south": _box(-6.0, -street - 16.0, w + 6.0, -street, float(parameters.get("south_height", 22.0))),
        "block_east": _box(w + 10.0, -2.0, w + 30.0, d + 6.0, float(parameters.get("east_height", 12.0))),
    }
    return {"analysis": analysis, "context": context}
