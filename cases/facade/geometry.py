"""Geometry of the facade case: an office block in an east-west street canyon.

The block (``widesky.thermal.box_building``: storeys of four perimeter zones, one window band per facade and storey) has
a street of ``street`` metres on its south and north sides, each lined by a block of ``opposite_height``; a lower
block stands across a side street to the east. Coordinates: metres east (x), north (y), up (z); the ground is
z = 0.
"""

from widesky.cases.shapes import box
from widesky.thermal import box_building


def build(parameters):
    """The office block as a ``building`` (its surfaces are the analysis groups) and the street's blocks as
    context."""
    w = float(parameters.get("width", 30.0))             # east-west [m]
    d = float(parameters.get("depth", 14.0))             # north-south [m]
    storeys = int(parameters.get("storeys", 4))
    fh = float(parameters.get("floor_height", 3.5))      # [m]
    wwr = float(parameters.get("wwr", 0.5))              # window-to-wall ratio [1]
    street = float(parameters.get("street", 16.0))       # street width south and north of the block [m]
    h_opp = float(parameters.get("opposite_height", 15.0))
    building = box_building(w, d, fh, floors=storeys, wwr=wwr, perimeter_zones=True)
    context = {
        "block across the street (south)": box(-10.0, -street - 14.0, 0.0, w + 10.0, -street, h_opp),
        "block across the street (north)": box(-10.0, d + street, 0.0, w + 10.0, d + street + 14.0, h_opp),
        "block east": box(w + 12.0, -4.0, 0.0, w + 30.0, d + 4.0, float(parameters.get("east_height", 9.0))),
    }
    if not parameters.get("canyon", True):       # the block alone (tests: an unobstructed building)
        context = {}
    return {"building": building, "context": context}
