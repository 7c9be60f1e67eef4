"""Geometry of the bipv case: a small office building with PV on its roof and on its south facade.

The building (``widesky.thermal.box_building``, storeys of four perimeter zones, one window band per facade and storey)
carries three PV groups, each an analysis group of its own:

* ``pv roof``: rows of south-facing tables tilted ``roof_tilt`` on the flat roof, ``roof_rows`` of them;
* ``pv overhang``: a PV canopy over every south window, ``overhang_depth`` deep, tilted ``overhang_tilt`` to the
  south (it generates and shades the window below it);
* ``pv spandrel``: vertical PV cladding on the south wall below every window (the sill band), 0.1 m off the wall.

A lower neighbour stands to the south-east. Coordinates: metres east (x), north (y), up (z); the ground is z = 0.
The window geometry follows ``box_building``: sill 0.9 m above the floor, head 0.3 m below the ceiling, centred.
"""

import numpy as np

from widesky.cases.shapes import box, merge, quad_grid
from widesky.thermal import box_building


def build(parameters):
    """The building (its surfaces are analysis groups), the three PV groups, and the neighbour as context."""
    w = float(parameters.get("width", 20.0))             # east-west [m]
    d = float(parameters.get("depth", 12.0))             # north-south [m]
    storeys = int(parameters.get("storeys", 3))
    fh = float(parameters.get("floor_height", 3.5))      # [m]
    wwr = float(parameters.get("wwr", 0.3))
    cell = float(parameters.get("cell", 2.0))            # PV analysis grid [m]
    sill = 0.9
    building = box_building(w, d, fh, floors=storeys, wwr=wwr, sill=sill, perimeter_zones=True)
    height = storeys * fh
    # roof rows (tables facing south), 0.4 m above the roof at their lower edge
    rows = int(parameters.get("roof_rows", 3))
    tilt = np.radians(float(parameters.get("roof_tilt", 15.0)))
    table = float(parameters.get("table_width", 1.7))
    pitch = (d - 1.0) / rows
    roof = [quad_grid((0.5, 0.5 + r * pitch, height + 0.4), (w - 1.0, 0.0, 0.0),
                      (0.0, table * np.cos(tilt), table * np.sin(tilt)), max(1, int(round((w - 1.0) / cell))), 1)
            for r in range(rows)]
    # south windows of box_building: width from the window area, centred
    wh = fh - sill - 0.3
    ww = min(wwr * w * fh / wh, w - 0.1)
    x0 = (w - ww) / 2.0
    depth = float(parameters.get("overhang_depth", 1.0))
    ot = np.radians(float(parameters.get("overhang_tilt", 20.0)))
    overhang, spandrel = [], []
    nx = max(1, int(round(ww / cell)))
    for k in range(storeys):
        top = k * fh + sill + wh + 0.05                  # just above the window head
        outer = (x0, -0.05 - depth * np.cos(ot), top - depth * np.sin(ot))
        overhang.append(quad_grid(outer, (ww, 0.0, 0.0), (0.0, depth * np.cos(ot), depth * np.sin(ot)), nx, 1))
        spandrel.append(quad_grid((0.0, -0.1, k * fh + 0.05), (w, 0.0, 0.0), (0.0, 0.0, sill - 0.1),
                                  max(1, int(round(w / cell))), 1))
    analysis = {"pv roof": merge(roof), "pv overhang": merge(overhang), "pv spandrel": merge(spandrel)}
    context = {"neighbour": box(w + 8.0, -26.0, 0.0, w + 22.0, -14.0, float(parameters.get("neighbour_height", 8.0)))}
    return {"building": building, "analysis": analysis, "context": context}
