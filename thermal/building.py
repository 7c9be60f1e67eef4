"""Building input: labelled surfaces from meshes, or a box-building generator.

A building is a triangle mesh whose faces carry a surface label. A label is
``kind:zone:construction`` with ``kind`` one of :data:`KINDS` (``shading`` surfaces belong to no
zone: ``shading::``). Labels come from face groups (one label per mesh, e.g. the group names of
:func:`widesky.irradiance.make_scene`) or from the generator. Errors name the offending label: an unknown
kind, a window that lies on no wall of its zone, a zone listed without surfaces.

Geometry convention: x east, y north, z up [m]; azimuth clockwise from north (180 = south),
tilt from horizontal [deg].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["KINDS", "Surface", "Building", "ZoneSpec", "parse_label", "building_from_meshes",
           "box_building", "ORIENTATIONS"]

KINDS = ("wall", "window", "roof", "floor", "shading")
ORIENTATIONS = {"north": 0.0, "east": 90.0, "south": 180.0, "west": 270.0}


def parse_label(label):
    """Split ``kind:zone:construction``; ValueError naming the label when malformed."""
    parts = str(label).split(":")
    if len(parts) != 3:
        raise ValueError(f"surface label {label!r}: expected 'kind:zone:construction'")
    kind, zone, cons = (p.strip() for p in parts)
    if kind not in KINDS:
        raise ValueError(f"surface label {label!r}: kind {kind!r} not one of {KINDS}")
    if kind != "shading" and (not zone or not cons):
        raise ValueError(f"surface label {label!r}: a {kind} needs a zone and a construction")
    return kind, zone, cons


@dataclass(frozen=True)
class Surface:
    """One labelled planar surface.

    Attributes
    ----------
    label : str
    kind, zone, construction : str
    area : float
        [m2].
    tilt, azimuth : float
        [deg] of the outward normal.
    normal, centroid : numpy.ndarray
        (3,) unit outward normal and area-weighted centroid [m].
    faces : numpy.ndarray
        Indices of the mesh faces that form it.
    """

    label: str
    kind: str
    zone: str
    construction: str
    area: float
    tilt: float
    azimuth: float
    normal: np.ndarray
    centroid: np.ndarray
    faces: np.ndarray


@dataclass(frozen=True)
class ZoneSpec:
    """Per-zone use: floor area [m2], volume [m3], air change rate [h-1], internal gains [W] and
    set-points [degC]. ``floor_area`` and ``volume`` default to what the geometry gives."""

    name: str
    floor_area: float = None
    volume: float = None
    air_changes: float = 0.5
    internal_gains: float = 0.0
    heating_setpoint: float = 20.0
    cooling_setpoint: float = 26.0


@dataclass(frozen=True)
class Building:
    """Triangle mesh with a surface per label, and the zones.

    Attributes
    ----------
    vertices : numpy.ndarray
        (V, 3) [m].
    faces : numpy.ndarray
        (F, 3) vertex indices.
    face_surface : numpy.ndarray
        (F,) index of each face's surface in ``surfaces``.
    surfaces : tuple of Surface
    zones : dict of str to ZoneSpec
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_surface: np.ndarray
    surfaces: tuple
    zones: dict = field(default_factory=dict)

    def surfaces_of(self, kind=None, zone=None):
        """Surfaces filtered by kind and zone."""
        return [s for s in self.surfaces if (kind is None or s.kind == kind)
                and (zone is None or s.zone == zone)]

    def mesh(self, kinds=None):
        """(vertices, faces) of the surfaces of the given kinds (default all)."""
        keep = np.ones(len(self.faces), bool) if kinds is None else np.isin(
            [self.surfaces[i].kind for i in self.face_surface], list(kinds))
        return self.vertices, self.faces[keep]

    def analysis_meshes(self):
        """One (vertices, faces) per non-shading surface and their labels (for
        :func:`widesky.irradiance.make_scene` ``analysis=...``, ``groups=...``), and the shading surfaces
        as one context mesh (or None)."""
        meshes, labels = [], []
        for s in self.surfaces:
            if s.kind != "shading":
                meshes.append((self.vertices, self.faces[s.faces]))
                labels.append(s.label)
        shade = [i for i, s in enumerate(self.surfaces) if s.kind == "shading"]
        ctx = None
        if shade:
            f = np.concatenate([self.surfaces[i].faces for i in shade])
            ctx = (self.vertices, self.faces[f])
        return meshes, labels, ctx


def _orientation(normal):
    n = normal / np.linalg.norm(normal)
    tilt = float(np.degrees(np.arccos(np.clip(n[2], -1, 1))))
    az = float(np.degrees(np.arctan2(n[0], n[1])) % 360.0) if np.hypot(n[0], n[1]) > 1e-9 else 180.0
    return tilt, az


def building_from_meshes(vertices, faces, face_labels, zones=None, plane_tolerance=0.05):
    """Build a :class:`Building` from a labelled triangle mesh.

    Parameters
    ----------
    vertices : array_like
        (V, 3) [m].
    faces : array_like
        (F, 3) vertex indices; each triangle's winding gives its outward normal.
    face_labels : sequence of str
        (F,) ``kind:zone:construction`` per face. The faces of one label form one surface per
        plane (named ``label#i`` when there are several).
    zones : dict or list of ZoneSpec, optional
        Zone uses; every zone named here must have surfaces, and every zone in the labels gets a
        default ZoneSpec when not listed.
    plane_tolerance : float
        Distance [m] within which a window counts as lying on a wall of its zone.

    Raises
    ------
    ValueError
        Naming the label: malformed label, window on no wall of its zone, zone without surfaces,
        zone without any wall or roof, degenerate face.
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    labels = np.asarray(face_labels, dtype=object)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise ValueError("vertices must be (V, 3) and faces (F, 3)")
    if len(labels) != len(f):
        raise ValueError(f"face_labels has {len(labels)} entries, faces {len(f)}")
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    cross = np.cross(b - a, c - a)
    area2 = np.linalg.norm(cross, axis=1)
    if np.any(area2 <= 0):
        raise ValueError(f"face {int(np.argmin(area2))} is degenerate (zero area)")
    surfaces, face_surface = [], np.empty(len(f), np.int64)
    for label in dict.fromkeys(labels):
        kind, zone, cons = parse_label(label)
        idx = np.nonzero(labels == label)[0]
        nrm = cross[idx] / area2[idx, None]
        offs = np.einsum("ij,ij->i", nrm, a[idx])
        # one surface per plane of the label (a zone's walls share a label)
        planes = []
        for j in range(len(idx)):
            for p in planes:
                if kind == "shading" or (nrm[j] @ nrm[p[0]] > 0.999
                                         and abs(offs[j] - offs[p[0]]) < plane_tolerance):
                    p.append(j)
                    break
            else:
                planes.append([j])
        for i, p in enumerate(planes):
            sel = idx[p]
            w = area2[sel] / 2
            mean_n = (nrm[p] * w[:, None]).sum(0)
            mean_n = mean_n / np.linalg.norm(mean_n) if np.linalg.norm(mean_n) > 1e-9 else nrm[p[0]]
            cen = ((a[sel] + b[sel] + c[sel]) / 3 * w[:, None]).sum(0) / w.sum()
            tilt, az = _orientation(mean_n)
            face_surface[sel] = len(surfaces)
            name = label if len(planes) == 1 else f"{label}#{i}"
            surfaces.append(Surface(name, kind, zone, cons, float(w.sum()), tilt, az, mean_n, cen,
                                    sel))
    zone_names = {s.zone for s in surfaces if s.kind != "shading"}
    specs = {}
    for z in (zones.values() if isinstance(zones, dict) else zones or []):
        if z.name not in zone_names:
            raise ValueError(f"zone {z.name!r} has no surfaces (labelled zones: {sorted(zone_names)})")
        specs[z.name] = z
    for z in sorted(zone_names):
        specs.setdefault(z, ZoneSpec(z))
        if not any(s.kind in ("wall", "roof") and s.zone == z for s in surfaces):
            raise ValueError(f"zone {z!r} has no wall or roof")
    for s in surfaces:
        if s.kind != "window":
            continue
        on_wall = [w for w in surfaces if w.kind == "wall" and w.zone == s.zone
                   and w.normal @ s.normal > 0.999
                   and abs((s.centroid - w.centroid) @ w.normal) < plane_tolerance]
        if not on_wall:
            raise ValueError(f"window {s.label!r} lies on no wall of zone {s.zone!r}")
    b_ = Building(v, f, face_surface, tuple(surfaces), specs)
    return _with_geometry_defaults(b_)


def _with_geometry_defaults(b: Building) -> Building:
    zones = {}
    for name, z in b.zones.items():
        floor = sum(s.area for s in b.surfaces_of("floor", name))
        roof = sum(s.area for s in b.surfaces_of("roof", name))
        fa = z.floor_area if z.floor_area is not None else (floor or roof)
        if not fa:
            raise ValueError(f"zone {name!r}: give ZoneSpec.floor_area (no floor or roof surface)")
        vol = z.volume
        if vol is None:
            zs = [b.vertices[b.faces[s.faces]].reshape(-1, 3)[:, 2] for s in b.surfaces_of(zone=name)]
            zz = np.concatenate(zs)
            vol = fa * float(zz.max() - zz.min())
        zones[name] = ZoneSpec(name, fa, vol, z.air_changes, z.internal_gains, z.heating_setpoint,
                               z.cooling_setpoint)
    return Building(b.vertices, b.faces, b.face_surface, b.surfaces, zones)


def _quad(p0, u, w):
    """Four corners of the rectangle p0 + s u + t w, s, t in [0, 1] (counter-clockwise)."""
    return [p0, p0 + u, p0 + u + w, p0 + w]


class _MeshBuilder:
    def __init__(self):
        self.v, self.f, self.labels = [], [], []

    def rect(self, corners, label):
        base = len(self.v)
        self.v.extend(corners)
        self.f.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]])
        self.labels.extend([label, label])


def box_building(width=20.0, depth=12.0, floor_height=3.5, floors=1, wwr=0.3, sill=0.9,
                 overhang=0.0, fins=0.0, perimeter_zones=True, constructions=None, zone_use=None,
                 rotation=0.0):
    """A rectangular building with windows, overhangs and fins, in zones.

    Parameters
    ----------
    width, depth : float
        Plan size along x (east) and y (north) before rotation [m].
    floor_height : float
        [m].
    floors : int
        Storeys; each is one zone, or four perimeter zones (one per facade, the plan split along its
        diagonals) with ``perimeter_zones``.
    wwr : float or dict
        Window-to-wall ratio [1] (0-0.95), one value or per orientation
        (``{"south": 0.4, "north": 0.2, ...}``, missing ones 0).
    sill : float
        Window sill height above the floor [m].
    overhang, fins : float
        Depth [m] of a horizontal overhang above and of vertical fins beside each window (0: none);
        they are ``shading`` surfaces (shade and reflect, no zone; one-sided faces, which the ray
        caster occludes from both sides).
    constructions : dict, optional
        kind -> construction name (default ``wall: wall``, ``window: window``, ``roof: roof``,
        ``floor: floor``).
    zone_use : ZoneSpec, optional
        Template for every zone's use (air changes, gains, set-points); the name is replaced.
    rotation : float
        Clockwise rotation of the whole building about its centre [deg] (0: facades face N/E/S/W).

    Returns
    -------
    Building
    """
    if not (width > 0 and depth > 0 and floor_height > 0):
        raise ValueError(f"width={width!r}, depth={depth!r}, floor_height={floor_height!r} m must be > 0")
    if int(floors) != floors or floors < 1:
        raise ValueError(f"floors={floors!r} must be an integer >= 1")
    ratios = dict.fromkeys(ORIENTATIONS, 0.0)
    if isinstance(wwr, dict):
        for k, val in wwr.items():
            if k not in ORIENTATIONS:
                raise ValueError(f"wwr key {k!r} not one of {tuple(ORIENTATIONS)}")
            ratios[k] = float(val)
    else:
        ratios = dict.fromkeys(ORIENTATIONS, float(wwr))
    for k, val in ratios.items():
        if not 0 <= val <= 0.95:
            raise ValueError(f"wwr[{k!r}]={val!r} outside [0, 0.95]")
    cons = {"wall": "wall", "window": "window", "roof": "roof", "floor": "floor",
            **(constructions or {})}
    mb = _MeshBuilder()
    W, D, H = float(width), float(depth), float(floor_height)
    # facades: (orientation, origin, along-facade unit vector, length), outward normal = along x up
    facades = {"south": (np.array([0.0, 0.0, 0.0]), np.array([1.0, 0, 0]), W),
               "east": (np.array([W, 0.0, 0.0]), np.array([0, 1.0, 0]), D),
               "north": (np.array([W, D, 0.0]), np.array([-1.0, 0, 0]), W),
               "west": (np.array([0.0, D, 0.0]), np.array([0, -1.0, 0]), D)}
    up = np.array([0.0, 0.0, 1.0])
    zone_names = []
    for k in range(int(floors)):
        z0 = k * H
        for orient, (o, u, L) in facades.items():
            zone = f"f{k}_{orient}" if perimeter_zones else f"f{k}"
            if zone not in zone_names:
                zone_names.append(zone)
            p0 = o + z0 * up
            normal = np.cross(u, up)
            r = ratios[orient]
            wall_lab = f"wall:{zone}:{cons['wall']}"
            if r <= 0:
                mb.rect(_quad(p0, u * L, up * H), wall_lab)
                continue
            wa = r * L * H                                   # window area [m2]
            wh = max(H - sill - 0.3, 0.1)                    # head 0.3 m below the ceiling
            ww = wa / wh
            if ww > L - 0.1:                                 # too wide: use the full height
                ww = L - 0.1
                wh = wa / ww
                if sill + wh > H - 0.02:
                    raise ValueError(f"wwr[{orient!r}]={r!r} does not fit the facade with "
                                     f"sill={sill!r} m and floor_height={H!r} m")
            x0 = (L - ww) / 2
            mb.rect(_quad(p0, u * L, up * sill), wall_lab)                         # below
            mb.rect(_quad(p0 + up * (sill + wh), u * L, up * (H - sill - wh)), wall_lab)  # above
            mb.rect(_quad(p0 + up * sill, u * x0, up * wh), wall_lab)              # left
            mb.rect(_quad(p0 + up * sill + u * (x0 + ww), u * x0, up * wh), wall_lab)  # right
            wp = p0 + up * sill + u * x0
            mb.rect(_quad(wp, u * ww, up * wh), f"window:{zone}:{cons['window']}")
            if overhang > 0:
                top = wp + up * wh
                mb.rect(_quad(top, u * ww, normal * overhang), "shading::")
            if fins > 0:
                for x in (wp, wp + u * ww):
                    mb.rect(_quad(x, normal * fins, up * wh), "shading::")
        # roof and floor: split along the diagonals into the four perimeter zones
        c = np.array([W / 2, D / 2])
        corners = [np.array(p) for p in ((0, 0), (W, 0), (W, D), (0, D))]
        for i, orient in enumerate(("south", "east", "north", "west")):
            zone = f"f{k}_{orient}" if perimeter_zones else f"f{k}"
            a2, b2 = corners[i], corners[(i + 1) % 4]
            tri = [np.r_[a2, 0.0], np.r_[b2, 0.0], np.r_[c, 0.0]]
            if k == floors - 1:
                base = len(mb.v)
                mb.v.extend([p + up * (z0 + H) for p in tri])
                mb.f.append([base, base + 1, base + 2])
                mb.labels.append(f"roof:{zone}:{cons['roof']}")
            if k == 0:
                base = len(mb.v)
                mb.v.extend([p + up * z0 for p in tri])
                mb.f.append([base, base + 2, base + 1])
                mb.labels.append(f"floor:{zone}:{cons['floor']}")
    v = np.array(mb.v)
    if rotation:
        th = np.radians(rotation)
        cx, cy = W / 2, D / 2
        x, y = v[:, 0] - cx, v[:, 1] - cy
        # clockwise seen from above: azimuths increase by `rotation`
        v = np.c_[cx + x * np.cos(th) + y * np.sin(th), cy - x * np.sin(th) + y * np.cos(th), v[:, 2]]
    template = zone_use or ZoneSpec("template")
    fa = W * D / (4 if perimeter_zones else 1)
    zones = {z: ZoneSpec(z, fa, fa * H, template.air_changes, template.internal_gains,
                         template.heating_setpoint, template.cooling_setpoint) for z in zone_names}
    return building_from_meshes(v, np.array(mb.f), mb.labels, zones)
