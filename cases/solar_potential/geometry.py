"""Geometry of the solar_potential case: an office block in a street, its roof and four facades analysed
on a grid of about ``cell`` metres, two neighbouring blocks as context.

Coordinates: metres east (x), north (y), up (z); the ground is z = 0.
"""

from widesky.cases.shapes import box, quad_grid


def build(parameters):
    """Meshes of the case: analysis groups roof and facade_<orientation>, context neighbours."""
    w = float(parameters.get("width", 24.0))       # east-west [m]
    d = float(parameters.get("depth", 14.0))       # north-south [m]
    h = float(parameters.get("height", 18.0))      # [m]
    street = float(parameters.get("street", 14.0))  # width of the street south of the block [m]
    cell = float(parameters.get("cell", 2.0))      # analysis grid [m]
    nw, nd, nh = (max(1, int(round(x / cell))) for x in (w, d, h))
    analysis = {
        "roof": quad_grid((0, 0, h), (w, 0, 0), (0, d, 0), nw, nd),
        "facade_south": quad_grid((0, 0, 0), (w, 0, 0), (0, 0, h), nw, nh),
        "facade_north": quad_grid((w, d, 0), (-w, 0, 0), (0, 0, h), nw, nh),
        "facade_east": quad_grid((w, 0, 0), (0, d, 0), (0, 0, h), nd, nh),
        "facade_west": quad_grid((0, d, 0), (0, -d, 0), (0, 0, h), nd, nh),
    }
    context = {
        # a taller block across the street to the south, a lower one beside it to the east
        "block_south": box(-6.0, -street - 16.0, 0.0, w + 6.0, -street, float(parameters.get("south_height", 22.0))),
        "block_east": box(w + 10.0, -2.0, 0.0, w + 30.0, d + 6.0, float(parameters.get("east_height", 12.0))),
    }
    return {"analysis": analysis, "context": context}
