"""The ASHRAE 140 test room as a widesky building, and the shading of its windows by ray casting.

Geometry (ANSI/ASHRAE Standard 140-2020 section 7.2.1, Case 600, and 7.2.2 for the variants;
the 2017 edition's 5.2.1 / 5.2.2): an 8 m (east-west) x 6 m (north-south) x 2.7 m box on the
ground. Windows are 3 m wide and 2 m high with the sill 0.2 m above the floor:

* ``"south"`` (Cases 600, 610, 640, 650, 660, 670 and their 9xx counterparts): two windows in the
  south wall, 0.5 m from its ends and 2 m apart (x = 0.5-3.5 m and 4.5-7.5 m);
* ``"eastwest"`` (Cases 620, 630, 920, 930): one window centred in each of the east and west
  walls (1.5 m from either end), none to the south.

Shading devices (opaque, 1.0 m deep):

* ``"overhang"`` (Cases 610, 910): a horizontal overhang at the roof level (0.5 m above the window
  heads) across the whole 8 m of the south wall;
* ``"overhang_fins"`` (Cases 630, 930): over each east and west window an overhang at the roof
  level as wide as the window (3 m), and a vertical fin flush with each side of the window, from
  the ground to the roof level.

Coordinates: x east, y north, z up [m]; the south wall lies in the plane y = 0.

The shading factors of :func:`window_shading` are what the weather-file (Hay-Davies) route needs to
shade its beam and diffuse light: the sunlit share of each window per hour (a ray from
area-uniform points of the glass towards the sun, occluded by the scene's triangles through
Embree, :func:`widesky.irradiance.raycast.cast_rays`) and the share of the window's view of the sky
and of the ground the devices leave (cosine-weighted rays). The integrator route needs none of
this: the devices are context meshes of its scene and occlude (and reflect) every ray it casts.
"""

from __future__ import annotations

import numpy as np

from widesky.irradiance.raycast import cast_rays

from .building import Building, building_from_meshes
from .gains import building_scene

__all__ = ["LAYOUTS", "SHADINGS", "ROOM", "WINDOW", "bestest_building", "window_shading",
           "device_rectangles"]

ROOM = (8.0, 6.0, 2.7)
"""Width (x, east-west), depth (y, north-south) and height of the test room [m] (140-2020 7.2.1)."""
WINDOW = {"width": 3.0, "height": 2.0, "sill": 0.2, "south_edge": 0.5, "device_depth": 1.0}
"""Window size and placement [m] and the depth of overhangs and fins [m] (140-2020 7.2.1, 7.2.2)."""
LAYOUTS = ("south", "eastwest")
SHADINGS = (None, "overhang", "overhang_fins")


def _window_spans(layout):
    """{orientation: [(start, end) along the wall [m], ...]} for the layout."""
    w, e = WINDOW["width"], WINDOW["south_edge"]
    W, D, _ = ROOM
    if layout == "south":
        return {"south": [(e, e + w), (W - e - w, W - e)]}
    if layout == "eastwest":
        c = (D - w) / 2
        return {"east": [(c, c + w)], "west": [(c, c + w)]}
    raise ValueError(f"layout={layout!r} not one of {LAYOUTS}")


def _facades():
    """(origin, along-wall unit vector, length) per orientation; outward normal = along x up."""
    W, D, _ = ROOM
    return {"south": (np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), W),
            "east": (np.array([W, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), D),
            "north": (np.array([W, D, 0.0]), np.array([-1.0, 0.0, 0.0]), W),
            "west": (np.array([0.0, D, 0.0]), np.array([0.0, -1.0, 0.0]), D)}


def device_rectangles(layout, shading):
    """The shading devices as rectangles (p0, u, w) [m]: corners p0, p0 + u, p0 + u + w, p0 + w."""
    if shading not in SHADINGS:
        raise ValueError(f"shading={shading!r} not one of {SHADINGS}")
    spans = _window_spans(layout)
    up = np.array([0.0, 0.0, 1.0])
    H, d = ROOM[2], WINDOW["device_depth"]
    out = []
    if shading is None:
        return out
    for orient, (o, u, L) in _facades().items():
        if orient not in spans:
            continue
        normal = np.cross(u, up)
        if shading == "overhang":
            out.append((o + H * up, u * L, normal * d))
            continue
        for s0, s1 in spans[orient]:
            out.append((o + u * s0 + H * up, u * (s1 - s0), normal * d))          # overhang
            for s in (s0, s1):                                                    # fins
                out.append((o + u * s, normal * d, up * H))
    return out


def bestest_building(layout="south", shading=None) -> Building:
    """The test room with the windows of ``layout`` and the devices of ``shading`` (module doc).

    Labels: ``wall:room:wall`` (one surface per facade, ``#i``), ``window:room:window``,
    ``roof:room:roof``, ``floor:room:floor`` and ``shading::`` for the devices.
    """
    spans = _window_spans(layout)
    devices = device_rectangles(layout, shading)
    W, D, H = ROOM
    sill, top = WINDOW["sill"], WINDOW["sill"] + WINDOW["height"]
    up = np.array([0.0, 0.0, 1.0])
    verts, faces, labels = [], [], []

    def rect(p0, u, w, label):
        b = len(verts)
        verts.extend([p0, p0 + u, p0 + u + w, p0 + w])
        faces.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]])
        labels.extend([label, label])

    for orient, (o, u, L) in _facades().items():
        wins = sorted(spans.get(orient, []))
        if not wins:
            rect(o, u * L, up * H, "wall:room:wall")
            continue
        rect(o, u * L, up * sill, "wall:room:wall")                      # below the sills
        rect(o + up * top, u * L, up * (H - top), "wall:room:wall")      # above the heads
        edges = [0.0] + [x for s in wins for x in s] + [L]
        for a, b in zip(edges[0::2], edges[1::2]):                       # piers between windows
            if b - a > 1e-9:
                rect(o + u * a + up * sill, u * (b - a), up * (top - sill), "wall:room:wall")
        for s0, s1 in wins:
            rect(o + u * s0 + up * sill, u * (s1 - s0), up * (top - sill), "window:room:window")
    rect(np.array([0.0, 0.0, H]), np.array([W, 0.0, 0.0]), np.array([0.0, D, 0.0]), "roof:room:roof")
    rect(np.zeros(3), np.array([0.0, D, 0.0]), np.array([W, 0.0, 0.0]), "floor:room:floor")
    for p0, u, w in devices:
        rect(p0, u, w, "shading::")
    return building_from_meshes(np.array(verts), np.array(faces), labels)


HORIZON_BAND = 6.5
"""Width of the horizon band [deg] whose view :func:`window_shading` measures (Perez, Seals, Ineichen, Stewart,
Menicucci 1987, Solar Energy 39(3), 221-231: the horizon brightening's band)."""


def _cosine_directions(n):
    """(n*n, 3) stratified cosine-weighted unit directions about +z (one per cell of an n x n grid
    of (sin^2 theta, phi))."""
    c = (np.arange(n) + 0.5) / n
    u, v = np.meshgrid(c, c, indexing="ij")
    s = np.sqrt(u.ravel())
    phi = 2 * np.pi * v.ravel()
    return np.c_[s * np.cos(phi), s * np.sin(phi), np.sqrt(1.0 - u.ravel())]


def _frame(normal):
    n = normal / np.linalg.norm(normal)
    a = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    t = np.cross(a, n)
    t /= np.linalg.norm(t)
    return np.stack([t, np.cross(n, t), n])              # rows: tangent, bitangent, normal


def window_shading(building: Building, solar_zenith, solar_azimuth, samples_per_face=64,
                   hemisphere_grid=48):
    """Shading of each window surface of ``building`` by everything else in it, by ray casting.

    Parameters
    ----------
    building : Building
    solar_zenith, solar_azimuth : array_like
        (T,) [deg] (azimuth clockwise from north).
    samples_per_face : int
        Points per triangle of the glass (a square number; area-uniform sub-triangle centroids).
    hemisphere_grid : int
        n: n x n cosine-weighted directions per point for the view factors.

    Returns
    -------
    dict
        ``labels``: the window surfaces' labels (W,); ``sunlit``: (T, W) area share of each window
        the sun reaches [1] (1 with the sun behind the window or below the horizon, where the beam
        is zero anyway); ``sky_view``, ``ground_view``: (W,) the window's cosine-weighted view
        of the sky and of the ground as a share of an unobstructed plane's of the same tilt [1];
        ``horizon_view``: (W,) its cosine-weighted view of the horizon band (the Perez transposition's
        horizon brightening, taken as the band 0-6.5 deg above the horizon of Perez et al. 1987) as a share
        of an unobstructed plane's [1].
    """
    wins = [s for s in building.surfaces if s.kind == "window"]
    if not wins:
        raise ValueError("building has no window surfaces")
    scene, labels = building_scene(building, samples_per_face=samples_per_face)
    geo = scene.geometry()
    k = scene.samples_per_face
    face_of_point = np.repeat(np.arange(scene.n_faces), k)
    group_of_point = scene.face_group[face_of_point]
    weight_of_point = scene.face_area[face_of_point] / k
    names = list(scene.group_names)
    zen = np.radians(np.asarray(solar_zenith, float))
    azi = np.radians(np.asarray(solar_azimuth, float))
    sun = np.c_[np.sin(zen) * np.sin(azi), np.sin(zen) * np.cos(azi), np.cos(zen)]
    T = len(zen)
    sunlit = np.ones((T, len(wins)))
    sky_view, ground_view = np.ones(len(wins)), np.ones(len(wins))
    horizon_view = np.ones(len(wins))
    dirs0 = _cosine_directions(hemisphere_grid)
    h_el = np.radians(HORIZON_BAND * (np.arange(3) + 0.5) / 3)                  # the band's mid-strata
    h_az = 2 * np.pi * (np.arange(4 * hemisphere_grid) + 0.5) / (4 * hemisphere_grid)
    h_el, h_az = (x.ravel() for x in np.meshgrid(h_el, h_az, indexing="ij"))
    h_dirs0 = np.c_[np.cos(h_el) * np.sin(h_az), np.cos(h_el) * np.cos(h_az), np.sin(h_el)]
    for j, s in enumerate(wins):
        sel = np.nonzero((group_of_point == names.index(s.label)) & (scene.face_side[face_of_point] == 0))[0]
        org = scene.ray_origins[sel]
        wgt = weight_of_point[sel] / weight_of_point[sel].sum()
        nrm = s.normal / np.linalg.norm(s.normal)
        lit = np.nonzero((sun[:, 2] > 0) & (sun @ nrm > 0))[0]
        if len(lit):
            o = np.repeat(org, len(lit), axis=0)
            d = np.tile(sun[lit], (len(org), 1))
            hit = cast_rays(geo, o, d, occluded=True).reshape(len(org), len(lit))
            sunlit[lit, j] = wgt @ (~hit)
        dirs = dirs0 @ _frame(nrm)
        o = np.repeat(org, len(dirs), axis=0)
        d = np.tile(dirs, (len(org), 1))
        hit = cast_rays(geo, o, d, occluded=True).reshape(len(org), len(dirs))
        up = dirs[:, 2] > 0
        free_sky = up.mean()
        free_ground = 1.0 - free_sky
        sky_view[j] = (wgt @ (~hit[:, up])).sum() / len(dirs) / free_sky if free_sky else 1.0
        ground_view[j] = ((wgt @ (~hit[:, ~up])).sum() / len(dirs) / free_ground
                          if free_ground else 1.0)
        cos_h = h_dirs0 @ nrm
        front = cos_h > 0
        if np.any(front):
            hd, hw = h_dirs0[front], cos_h[front] / cos_h[front].sum()
            hit = cast_rays(geo, np.repeat(org, len(hd), axis=0), np.tile(hd, (len(org), 1)),
                            occluded=True).reshape(len(org), len(hd))
            horizon_view[j] = wgt @ (~hit) @ hw
    return {"labels": [s.label for s in wins], "sunlit": sunlit, "sky_view": sky_view,
            "ground_view": ground_view, "horizon_view": horizon_view}
