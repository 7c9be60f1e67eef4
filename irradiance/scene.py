"""Scenes for the integrator: analysis faces, context geometry and a Lambertian ground plane.

Coordinates are metres in a local east-north-up frame (x east, y north, z up), e.g. UTM easting,
northing and height. The scene is recentred on its bounding-box centre (kept in float64 as
``Scene.origin``) before anything is cast to float32 for Embree, so large coordinates keep
millimetre precision.

Handling of bad geometry (documented policy, never NaN):

* empty meshes or no analysis faces: ``ValueError``;
* non-finite vertices or face indices out of range: ``ValueError`` naming the mesh;
* degenerate analysis triangles (area below ``1e-12`` of the squared scene extent): kept in the
  output with zero irradiance and ``Scene.face_valid == False``, with a ``UserWarning`` giving the count;
  they still take part in occlusion (Embree skips them);
* normals follow the triangle winding (counter-clockwise seen from the front); analysis is one-sided
  unless ``two_sided=True`` (then every face also gets a back side, ``Scene.face_side == 1``).
  Inconsistent winding is not repaired here: call ``mesh.fix_normals()`` in trimesh first;
* analysis points below the ground plane see nothing (zero irradiance; the ground is opaque).
"""

from __future__ import annotations

import os
import uuid
import warnings
from dataclasses import dataclass, field

import numpy as np
import trimesh

__all__ = ["Scene", "make_scene", "load_mesh"]


def load_mesh(obj):
    """A ``trimesh.Trimesh`` from a mesh, a file path (anything trimesh loads) or (vertices, faces).

    Parameters
    ----------
    obj : trimesh.Trimesh or str or os.PathLike or tuple
        The geometry; multi-mesh files (GLB, OBJ with groups) are concatenated.
    """
    if isinstance(obj, trimesh.Trimesh):
        return obj
    if isinstance(obj, (str, os.PathLike)):
        path = os.fspath(obj)
        if not os.path.isfile(path):
            raise ValueError(f"mesh file {path!r} " + ("is a folder" if os.path.isdir(path) else "not found"))
        suffix = os.path.splitext(path)[1].lower().lstrip(".")
        formats = [f for f in sorted(trimesh.available_formats()) if f in _MESH_SUFFIXES]
        if suffix not in formats:
            raise ValueError(f"mesh file {path!r}: the suffix {'.' + suffix if suffix else '(none)'} is not a "
                             "triangle-mesh format widesky reads; valid: " + ", ".join("." + f for f in formats))
        try:
            loaded = trimesh.load(path, force="mesh", process=False)
        except IndexError as e:           # trimesh's OBJ reader on a face indexing no vertex
            raise ValueError(f"mesh {path!r}: a face indexes a vertex that the file does "
                             f"not have ({e})") from None
        except Exception as e:             # noqa: BLE001 - trimesh's readers raise anything on a bad file
            msg = str(e).splitlines()[0] if str(e) else type(e).__name__
            raise ValueError(f"mesh file {path!r}: not a readable .{suffix} mesh ({msg})") from None
        if not isinstance(loaded, trimesh.Trimesh):
            raise ValueError(f"mesh file {path!r} holds no triangle mesh")
        if len(loaded.faces) == 0:
            raise ValueError(f"mesh file {path!r} holds no triangles (an empty or unreadable .{suffix} file)")
        return loaded
    if isinstance(obj, trimesh.Scene):
        return obj.to_mesh() if hasattr(obj, "to_mesh") else obj.dump(concatenate=True)
    if isinstance(obj, (tuple, list)) and len(obj) == 2:
        return trimesh.Trimesh(vertices=np.asarray(obj[0], dtype=float),
                               faces=np.asarray(obj[1], dtype=np.int64), process=False)
    raise TypeError(f"cannot make a mesh from {type(obj).__name__}")


# the mesh formats named in messages (trimesh reads a few more, e.g. point clouds, that are no use here)
_MESH_SUFFIXES = ("obj", "ply", "stl", "glb", "gltf", "off", "dae", "3mf", "3dxml", "x3d", "xaml", "dxf", "svg")


def _mesh_name(obj, name):
    """``name`` with the file it came from, for messages (e.g. ``analysis[0] (roof.obj)``)."""
    return f"{name} ({os.fspath(obj)!r})" if isinstance(obj, (str, os.PathLike)) else name


def _mesh_arrays(mesh, name):
    v = np.asarray(mesh.vertices, dtype=float).reshape(-1, 3)
    f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    if f.shape[0] == 0:
        raise ValueError(f"{name} mesh is empty (0 faces)")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} mesh has non-finite vertex coordinates")
    if f.min() < 0 or f.max() >= v.shape[0]:
        raise ValueError(f"{name} mesh has face indices outside [0, {v.shape[0] - 1}]")
    return v, f


def _triangle_points(k):
    """Barycentric (k*k, 3) centroids of the k*k congruent sub-triangles of a triangle."""
    pts = []
    for i in range(k):
        for j in range(k - i):
            pts.append(((i + 1 / 3) / k, (j + 1 / 3) / k))
            if i + j <= k - 2:
                pts.append(((i + 2 / 3) / k, (j + 2 / 3) / k))
    uv = np.array(pts)
    return np.column_stack([1.0 - uv.sum(axis=1), uv[:, 0], uv[:, 1]])


@dataclass(frozen=True, eq=False)
class Scene:
    """A ray-castable scene; build it with :func:`make_scene`.

    All coordinates are recentred: world = local + ``origin``. F analysis faces (sides), N = F * k
    analysis points (k = ``samples_per_face``), M triangles in the occluding geometry.

    Attributes
    ----------
    origin : numpy.ndarray
        (3,) recentring offset [m].
    vertices : numpy.ndarray
        (V, 3) recentred vertices [m], float64.
    triangles : numpy.ndarray
        (M, 3) vertex indices of all occluding triangles (analysis first, then context).
    reflectance : numpy.ndarray
        (M,) diffuse reflectance of each triangle [1].
    triangle_normals : numpy.ndarray
        (M, 3) unit normals (zero for degenerate triangles).
    face_triangle : numpy.ndarray
        (F,) triangle index of each analysis face.
    face_side : numpy.ndarray
        (F,) 0 front, 1 back (two-sided analysis).
    face_normal : numpy.ndarray
        (F, 3) unit normals of the analysed sides.
    face_area : numpy.ndarray
        (F,) [m2].
    face_group : numpy.ndarray
        (F,) group index into ``group_names``.
    group_names : tuple of str
        Face-group names (module, facade ...).
    face_valid : numpy.ndarray
        (F,) False for degenerate triangles (zero output).
    points : numpy.ndarray
        (N, 3) analysis points [m], face-major, ``samples_per_face`` per face.
    point_normal : numpy.ndarray
        (N, 3).
    ground_z : float
        Height of the ground plane in recentred coordinates [m].
    ground_albedo : None or float or numpy.ndarray
        Ground reflectance [1] (scalar or per channel); None uses each step's sky-state albedo.
    ray_offset : float
        Distance ray origins are moved along the normal [m].
    samples_per_face : int
        Analysis points per face.
    key : str
        Unique id (caches the Embree scene per worker process).
    """

    origin: np.ndarray
    vertices: np.ndarray
    triangles: np.ndarray
    reflectance: np.ndarray
    triangle_normals: np.ndarray
    face_triangle: np.ndarray
    face_side: np.ndarray
    face_normal: np.ndarray
    face_area: np.ndarray
    face_group: np.ndarray
    group_names: tuple
    face_valid: np.ndarray
    points: np.ndarray
    point_normal: np.ndarray
    ground_z: float
    ground_albedo: object
    ray_offset: float
    samples_per_face: int
    key: str = field(default_factory=lambda: uuid.uuid4().hex)

    @property
    def n_faces(self) -> int:
        """Number of analysed face sides F."""
        return int(self.face_triangle.shape[0])

    @property
    def n_points(self) -> int:
        """Number of analysis points N."""
        return int(self.points.shape[0])

    @property
    def point_buried(self):
        """(N,) True for points below the ground plane or on degenerate faces (they see nothing)."""
        below = self.points[:, 2] < self.ground_z - self.ray_offset
        return below | np.repeat(~self.face_valid, self.samples_per_face)

    @property
    def ray_origins(self):
        """(N, 3) points moved ``ray_offset`` along their normals (recentred) [m]."""
        return self.points + self.ray_offset * self.point_normal

    def geometry(self):
        """The arrays a ray-casting worker needs (picklable dict)."""
        return {"key": self.key, "vertices": self.vertices.astype(np.float32),
                "triangles": self.triangles.astype(np.int32), "reflectance": self.reflectance,
                "triangle_normals": self.triangle_normals, "ground_z": float(self.ground_z),
                "ray_offset": float(self.ray_offset)}


def make_scene(analysis, context=(), *, groups=None, analysis_reflectance=0.1,
               context_reflectance=0.2, ground_z=None, ground_albedo=None, samples_per_face=1,
               two_sided=False):
    """Build a :class:`Scene` from analysis meshes, context meshes and a ground plane.

    Parameters
    ----------
    analysis : mesh or path or list of them
        Analysis geometry (trimesh meshes, files or (vertices, faces)); each face is analysed and
        also occludes and reflects.
    context : mesh or path or list of them
        Occluding, reflecting geometry that is not analysed (buildings, terrain, trees).
    groups : list of str, optional
        One group name per analysis mesh (default ``"mesh0"``, ``"mesh1"`` ...); results aggregate
        per group.
    analysis_reflectance, context_reflectance : float or list of float
        Diffuse reflectance [1] of the analysis / context meshes (scalar, or one per mesh).
    ground_z : float, optional
        World height of the ground plane [m]; default the lowest vertex of the scene.
    ground_albedo : float or array_like, optional
        Ground reflectance [1], scalar or (C,) per channel; default: each step's sky-state albedo.
    samples_per_face : int
        Analysis points per face: a square number k**2 (1, 4, 9 ...) of sub-triangle centroids.
    two_sided : bool
        Analyse the back side of every analysis face as well.
    """
    if not isinstance(analysis, (list, tuple)) or (len(analysis) == 2 and
                                                   isinstance(analysis, tuple) and
                                                   np.ndim(analysis[1]) == 2):
        analysis = [analysis]
    if not isinstance(context, (list, tuple)) or (len(context) == 2 and isinstance(context, tuple)
                                                  and np.ndim(context[1]) == 2):
        context = [context]
    if len(analysis) == 0:
        raise ValueError("no analysis geometry given")
    k = int(round(np.sqrt(samples_per_face)))
    if k < 1 or k * k != samples_per_face:
        raise ValueError(f"samples_per_face={samples_per_face} must be a square number (1, 4, 9 ...)")
    groups = list(groups) if groups is not None else [f"mesh{i}" for i in range(len(analysis))]
    if len(groups) != len(analysis):
        raise ValueError(f"groups has {len(groups)} names for {len(analysis)} analysis meshes")

    def per_mesh(v, n, name):
        v = np.atleast_1d(np.asarray(v, dtype=float))
        if v.size == 1:
            v = np.full(n, float(v[0]))
        if v.shape != (n,) or np.any((v < 0) | (v > 1)):
            raise ValueError(f"{name} must be in [0, 1], scalar or one per mesh; got {v}")
        return v

    a_refl = per_mesh(analysis_reflectance, len(analysis), "analysis_reflectance")
    c_refl = per_mesh(context_reflectance, len(context), "context_reflectance") if context else []

    verts, tris, refl, tri_group = [], [], [], []
    base = 0
    for i, m in enumerate(analysis):
        v, f = _mesh_arrays(load_mesh(m), _mesh_name(m, f"analysis[{i}]"))
        verts.append(v)
        tris.append(f + base)
        refl.append(np.full(len(f), a_refl[i]))
        tri_group.append(np.full(len(f), i))
        base += len(v)
    n_analysis = sum(len(t) for t in tris)
    for i, m in enumerate(context):
        v, f = _mesh_arrays(load_mesh(m), _mesh_name(m, f"context[{i}]"))
        verts.append(v)
        tris.append(f + base)
        refl.append(np.full(len(f), c_refl[i]))
        base += len(v)
    vertices = np.concatenate(verts)
    triangles = np.concatenate(tris)
    reflectance = np.concatenate(refl)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    origin = 0.5 * (lo + hi)
    local = vertices - origin
    extent = float(np.max(hi - lo))
    extent = extent if extent > 0 else 1.0

    tri_v = local[triangles]
    cross = np.cross(tri_v[:, 1] - tri_v[:, 0], tri_v[:, 2] - tri_v[:, 0])
    area2 = np.linalg.norm(cross, axis=1)
    degenerate = area2 <= 2e-12 * extent ** 2
    tri_n = np.zeros_like(cross)
    tri_n[~degenerate] = cross[~degenerate] / area2[~degenerate, None]

    face_tri = np.arange(n_analysis)
    group = np.concatenate(tri_group)
    sides = [np.zeros(n_analysis, dtype=np.int8)]
    if two_sided:
        face_tri = np.concatenate([face_tri, face_tri])
        group = np.concatenate([group, group])
        sides.append(np.ones(n_analysis, dtype=np.int8))
    side = np.concatenate(sides)
    sign = np.where(side == 1, -1.0, 1.0)
    valid = ~degenerate[face_tri]
    n_deg = int(np.count_nonzero(degenerate[:n_analysis]))
    if n_deg:
        warnings.warn(f"{n_deg} degenerate analysis triangle(s) (zero area): their irradiance is "
                      "reported as 0 and Scene.face_valid is False", UserWarning, stacklevel=2)
    face_n = tri_n[face_tri] * sign[:, None]
    face_n[~valid] = (0.0, 0.0, 1.0)
    face_area = 0.5 * area2[face_tri]

    bary = _triangle_points(k)                                            # (k*k, 3)
    fv = tri_v[face_tri]                                                  # (F, 3, 3)
    points = np.einsum("sj,fjk->fsk", bary, fv).reshape(-1, 3)
    point_n = np.repeat(face_n, k * k, axis=0)

    # ray offset: well above float32 rounding at the scene's largest recentred coordinate
    max_abs = float(np.max(np.abs(local))) if local.size else 1.0
    ulp = float(np.spacing(np.float32(max(max_abs, 1.0))))
    ray_offset = max(1e-6 * extent, 64.0 * ulp)

    gz = float(lo[2] if ground_z is None else ground_z) - float(origin[2])
    if ground_albedo is not None:
        ga = np.asarray(ground_albedo, dtype=float)
        if np.any((ga < 0) | (ga > 1)) or not np.all(np.isfinite(ga)):
            raise ValueError(f"ground_albedo must be within [0, 1], got {ground_albedo}")
        ground_albedo = float(ga) if ga.ndim == 0 else ga
    return Scene(origin=origin, vertices=local, triangles=triangles, reflectance=reflectance,
                 triangle_normals=tri_n, face_triangle=face_tri, face_side=side, face_normal=face_n,
                 face_area=face_area, face_group=group, group_names=tuple(groups), face_valid=valid,
                 points=points, point_normal=point_n, ground_z=gz, ground_albedo=ground_albedo,
                 ray_offset=ray_offset, samples_per_face=k * k)
