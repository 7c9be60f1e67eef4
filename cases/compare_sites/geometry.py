"""Geometry of the compare_sites case: one fixed-tilt module row on flat ground, nothing around it.

Coordinates: metres east (x), north (y), up (z). The row faces ``azimuth`` (180 = south; use 0 for a site in
the southern hemisphere) at ``tilt`` degrees, its lower edge ``clearance`` above the ground.
"""

import numpy as np

from widesky.cases.shapes import quad_grid


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
    return {"analysis": {"row": quad_grid((0.0, 0.0, clearance), along, up_table, cells, 2)}, "context": {}}
