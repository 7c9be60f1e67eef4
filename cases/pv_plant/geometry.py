"""Geometry of the pv_plant case: fixed-tilt module rows on a south-facing slope, a farm building to the
south-east casting morning shade on the first rows.

Coordinates: metres east (x), north (y), up (z). The slope rises towards the north at ``slope`` degrees; the
rows run east-west and face south (azimuth 180) at ``tilt`` degrees, their lower edge ``clearance`` above the
slope; analysed two-sided (front and rear).
"""

import numpy as np

from widesky.cases.shapes import box, quad_grid


def build(parameters):
    """Module rows row1 (south) ... rowN, the slope and the building as context."""
    rows = int(parameters.get("rows", 4))
    length = float(parameters.get("row_length", 24.0))    # east-west [m]
    width = float(parameters.get("table_width", 2.2))     # slant height of a table [m]
    pitch = float(parameters.get("pitch", 6.0))           # row spacing along the ground, north-south [m]
    tilt = np.radians(float(parameters.get("tilt", 25.0)))
    slope = np.radians(float(parameters.get("slope", 5.0)))
    clearance = float(parameters.get("clearance", 0.8))   # [m]
    cell = float(parameters.get("cell", 2.0))             # analysis grid along the row [m]
    ground = lambda y: y * np.tan(slope)  # noqa: E731   slope height [m] at north coordinate y
    analysis = {}
    for r in range(rows):
        y0 = r * pitch
        p0 = (0.0, y0, ground(y0) + clearance)
        u = (length, 0.0, 0.0)                                              # along the row (east)
        v = (0.0, width * np.cos(tilt), width * np.sin(tilt))               # up the table (north, up)
        analysis[f"row{r + 1}"] = quad_grid(p0, u, v, max(1, int(round(length / cell))), 2)
    # the slope: a plane from 20 m south of the first row to 15 m north of the last, 20 m beyond each row end
    ys, yn, xw, xe = -20.0, (rows - 1) * pitch + 15.0, -20.0, length + 20.0
    slope_mesh = quad_grid((xw, ys, ground(ys)), (xe - xw, 0, 0), (0, yn - ys, ground(yn) - ground(ys)), 4, 4)
    # a farm building south-east of the first row, standing on the slope
    bx, by = length + 3.0, -14.0
    building = box(bx, by, ground(by) - 0.5, bx + 12.0, by + 9.0, float(parameters.get("building_height", 8.0)))
    return {"analysis": analysis, "context": {"slope": slope_mesh, "building": building}}
