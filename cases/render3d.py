"""Pictures of a scene coloured by a per-face value (Pillow only), and the coloured mesh as PLY.

Orthographic views drawn with the painter's algorithm (triangles sorted far to near, 2x supersampled):
enough for the small case scenes; context geometry is grey, shaded by its orientation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh
from PIL import Image, ImageDraw, ImageFont

__all__ = ["VIEWS", "colour_ramp", "render_scene", "write_ply", "write_glb"]

# camera azimuth [deg, clockwise from north] and elevation [deg] of the viewing position
VIEWS = {"south-east": (135.0, 30.0), "south-west": (225.0, 30.0), "north-east": (45.0, 30.0),
         "north-west": (315.0, 30.0), "top": (180.0, 89.0)}

# a monotone dark-blue -> teal -> yellow ramp (lightness increasing), anchors in sRGB
_RAMP = np.array([[0.07, 0.06, 0.29], [0.18, 0.25, 0.55], [0.13, 0.47, 0.56], [0.20, 0.64, 0.47],
                  [0.56, 0.78, 0.29], [0.99, 0.91, 0.15]])


def colour_ramp(t):
    """Colours (..., 3) in [0, 1] for values ``t`` in [0, 1] (clipped)."""
    t = np.clip(np.nan_to_num(np.asarray(t, float)), 0.0, 1.0) * (len(_RAMP) - 1)
    i = np.minimum(t.astype(int), len(_RAMP) - 2)
    f = (t - i)[..., None]
    return _RAMP[i] * (1 - f) + _RAMP[i + 1] * f


def _camera(view):
    az, el = (np.radians(v) for v in VIEWS[view])
    to_cam = np.array([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)])
    right = np.cross([0.0, 0.0, 1.0], to_cam)
    if np.linalg.norm(right) < 1e-6:
        right = np.array([1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(to_cam, right)
    return to_cam, right, up


def _zbuffer(pixels, px, height, colours, draw):
    """Rasterise triangles into ``pixels`` (H, W, 3) in place, nearest first by a depth buffer.

    ``px`` (M, 3, 2) vertex pixel coordinates, ``height`` (M, 3) vertex distance towards the camera (larger is
    nearer), ``colours`` (M, 3) uint8, ``draw`` (M,) bool. Depth is interpolated linearly (orthographic view)."""
    H, W = pixels.shape[:2]
    zbuf = np.full((H, W), -np.inf)
    for k in np.nonzero(draw)[0]:
        p, z = px[k], height[k]
        x0, y0 = np.maximum(np.floor(p.min(axis=0)).astype(int), 0)
        x1, y1 = np.minimum(np.ceil(p.max(axis=0)).astype(int) + 1, [W, H])
        if x1 <= x0 or y1 <= y0:
            continue
        (ax, ay), (bx, by), (cx, cy) = p
        area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        if abs(area) < 1e-12:
            continue
        X, Y = np.meshgrid(np.arange(x0, x1) + 0.5, np.arange(y0, y1) + 0.5)
        w0 = ((bx - X) * (cy - Y) - (by - Y) * (cx - X)) / area
        w1 = ((cx - X) * (ay - Y) - (cy - Y) * (ax - X)) / area
        w2 = 1.0 - w0 - w1
        inside = (w0 >= -1e-9) & (w1 >= -1e-9) & (w2 >= -1e-9)
        depth = w0 * z[0] + w1 * z[1] + w2 * z[2]
        sub = zbuf[y0:y1, x0:x1]
        nearer = inside & (depth > sub)
        sub[nearer] = depth[nearer]
        pixels[y0:y1, x0:x1][nearer] = colours[k]


def render_scene(vertices, triangles, face_values, *, vmin, vmax, view="south-west", size=720,
                 label="", unit="", cull=None):
    """A PIL image of the scene.

    Parameters
    ----------
    vertices : ndarray (V, 3)  [m], east-north-up
    triangles : ndarray (M, 3)  vertex indices
    face_values : ndarray (M,)  value per triangle (NaN: context, drawn grey)
    vmin, vmax : float  colour range (same unit as the values)
    view : str  a key of :data:`VIEWS`
    size : int  image width [pixels]
    label, unit : str  caption of the colour bar
    cull : ndarray (M,) of bool, optional  triangles not drawn when they face away from the camera (one-sided
        surfaces of closed solids)
    """
    if view not in VIEWS:
        raise ValueError(f"view={view!r}: expected one of {', '.join(VIEWS)}")
    to_cam, right, up = _camera(view)
    tri = np.asarray(vertices, float)[np.asarray(triangles)]                    # (M, 3, 3)
    xy = np.stack([tri @ right, tri @ up], axis=-1)                            # (M, 3, 2)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    ss = 2
    W = int(size) * ss
    bar = int(0.16 * W)
    lo, hi = xy.reshape(-1, 2).min(axis=0), xy.reshape(-1, 2).max(axis=0)
    scale = 0.92 * (W - bar) / max(hi[0] - lo[0], 1e-9)
    H = int(min(max((hi[1] - lo[1]) * scale / 0.92, 0.5 * W), 1.2 * W))
    scale = min(scale, 0.92 * H / max(hi[1] - lo[1], 1e-9))
    centre = np.array([(W - bar) / 2, H / 2])
    px = (xy - 0.5 * (lo + hi)) * scale * np.array([1.0, -1.0]) + centre
    img = Image.new("RGB", (W, H), (246, 246, 244))
    draw = ImageDraw.Draw(img)
    vals = np.asarray(face_values, float)
    t = (vals - vmin) / (vmax - vmin if vmax > vmin else 1.0)
    rgb = colour_ramp(t)
    shade = 0.55 + 0.45 * np.abs(n @ np.array([0.3, -0.5, 0.81]))
    grey = np.repeat((0.78 * shade)[:, None], 3, axis=1)
    col = np.where(np.isfinite(vals)[:, None], rgb, grey)
    # faces looking straight down (building floors) are seen from behind from every view (all lie above the
    # horizon): skip them, and the back-facing triangles ``cull`` allows
    hidden = n[:, 2] <= -0.99
    if cull is not None:
        hidden |= np.asarray(cull, bool) & (n @ to_cam < 0.0)
    rgb8 = np.round(255 * col).astype(np.uint8)
    pixels = np.asarray(img).copy()
    _zbuffer(pixels, px, tri @ to_cam, rgb8, ~hidden)
    img = Image.fromarray(pixels)
    draw = ImageDraw.Draw(img)
    # colour bar
    x0, y0, y1 = W - bar + int(0.25 * bar), int(0.12 * H), int(0.88 * H)
    for y in range(y0, y1):
        c = colour_ramp(1.0 - (y - y0) / max(y1 - y0 - 1, 1))
        draw.line([(x0, y), (x0 + int(0.22 * bar), y)], fill=tuple(int(255 * v) for v in c))
    try:
        font = ImageFont.load_default(size=12 * ss)
    except TypeError:          # Pillow < 10.1
        font = None
    draw.text((x0 + int(0.26 * bar), y0 - 6 * ss), f"{vmax:.4g}", fill=(30, 30, 30), font=font)
    draw.text((x0 + int(0.26 * bar), y1 - 6 * ss), f"{vmin:.4g}", fill=(30, 30, 30), font=font)
    draw.text((int(0.02 * W), int(0.02 * H)), f"{label} [{unit}], view from the {view}", fill=(30, 30, 30), font=font)
    return img.resize((W // ss, H // ss), Image.LANCZOS)


def _coloured_mesh(vertices, triangles, face_values, vmin, vmax):
    """A trimesh mesh with per-face RGBA colours (the ramp of :func:`render_scene`; NaN grey)."""
    vals = np.asarray(face_values, float)
    rgb = colour_ramp((vals - vmin) / (vmax - vmin if vmax > vmin else 1.0))
    rgb[~np.isfinite(vals)] = 0.7
    colours = np.concatenate([np.round(rgb * 255), np.full((len(vals), 1), 255)], axis=1).astype(np.uint8)
    return trimesh.Trimesh(np.asarray(vertices, float), np.asarray(triangles), face_colors=colours, process=False)


def write_ply(path, vertices, triangles, face_values, *, vmin, vmax):
    """Write the mesh with per-face colours (the ramp of :func:`render_scene`; NaN grey) as binary PLY."""
    _coloured_mesh(vertices, triangles, face_values, vmin, vmax).export(str(path), file_type="ply")
    return path


def write_glb(path, vertices, triangles, face_values, *, vmin, vmax):
    """Write the mesh with per-face colours as binary glTF (GLB), which browsers' and most 3D viewers open.

    glTF colours vertices, not faces: every triangle gets its own three vertices (carrying its colour), so the
    faces keep their exact colours. Coordinates as given (metres east, north, up; glTF viewers treat y as up,
    so the scene is rotated to glTF's y-up convention: x east, y up, z south).
    """
    m = _coloured_mesh(vertices, triangles, face_values, vmin, vmax)
    colours = np.repeat(m.visual.face_colors, 3, axis=0)
    v = m.vertices[m.faces.reshape(-1)]
    yup = np.column_stack([v[:, 0], v[:, 2], -v[:, 1]])
    flat = trimesh.Trimesh(yup, np.arange(len(v)).reshape(-1, 3), vertex_colors=colours, process=False)
    Path(path).write_bytes(flat.export(file_type="glb"))
    return path
