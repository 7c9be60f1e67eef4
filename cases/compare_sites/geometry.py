"""Geometry of the compare_sites case: one fixed-tilt module row on flat ground, nothing around it.

Coordinates: metres east (x), north (y), up (z). The row faces ``azimuth`` (180 = south; use 0 for a site in
the southern hemisphere) at ``tilt`` degrees, its lower edge ``clearance`` above the ground.
"""

import numpy as np


def build(parameters):
    """One analysed row ("row"); no context."""
    length = float(parameters.get("row_length", 20.0))   # [m]
    width = float(parameters.get("table_width", 2.0))    # slant height [m]
    tilt = np.radians(float(parameters.get("tilt", 30.0)))
    az = np.radians(float(parameters.get("azimuth", 180.0)))
    clearance = float(parameters.get("clearance", 0.8))  # [m]
    cells = max(1, int(round(length / float(parameters.get("cell", 2.0)))))
    along = np.array([-np.cos(az), np.sin(az), 0.0]) * length          # the row's axis (east for a south row)
    up_table = (np.array([-np.sin(az), -np.cos(az), 0.0]) * np.cos(tilt) + np.array([0, 0, 1.0]) * np.sin(tilt)) * width
    p0 = np.array([0.0, 0.0, clearance])
    i, j = np.meshgrid(np.arange(cells + 1), np.arange(3), indexing="ij")
    verts = (p0 + (i / cells)[..., None] * along + (j / 2)[..., None] * up_table).reshape(-1, 3)
    k = lambda a, b: a * 3 + b  # noqa: E731
    faces = [f for a in range(cells) for b in range(2)
             for f in ([k(a, b), k(a + 1, b), k(a + 1, b + 1)], [k(a, b), k(a + 1, b + 1), k(a, b + 1)])]
    return {"analysis": {"row": (verts, np.array(faces))}, "context": {}}
