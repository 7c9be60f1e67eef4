"""Pictures of a scene coloured by a per-face value (rasterised with numpy, colour bars by matplotlib), and the
coloured mesh as PLY and GLB.

Orthographic views drawn with a depth buffer (2x supersampled):
enough for the small case scenes; context geometry is grey, shaded by its orientation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh
from PIL import Image

__all__ = ["VIEWS", "FRONT_CMAP", "BACK_CMAP", "colour_ramp", "render_scene", "write_ply", "write_glb"]

# camera azimuth [deg, clockwise from north] and elevation [deg] of the viewing position
VIEWS = {"south-east": (135.0, 30.0), "south-west": (225.0, 30.0), "north-east": (45.0, 30.0),
         "north-west": (315.0, 30.0), "top": (180.0, 89.0)}

# colour maps of the renders (matplotlib's perceptually uniform maps): front faces, rear faces
FRONT_CMAP, BACK_CMAP = "viridis", "magma"


def colour_ramp(t, cmap=FRONT_CMAP):
    """Colours (..., 3) in [0, 1] for values ``t`` in [0, 1] (clipped; NaN -> 0) of the matplotlib map ``cmap``."""
    import matplotlib

    t = np.clip(np.nan_to_num(np.asarray(t, float)), 0.0, 1.0)
    return np.asarray(matplotlib.colormaps[cmap](t))[..., :3]


def _camera(view):
    az, el = (np.radians(v) for v in (VIEWS[view] if isinstance(view, str) else view))
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
                 label="", unit="", cull=None, back_values=None, back_vmin=None, back_vmax=None,
                 context=True, title=None):
    """A PIL image of the scene with a colour bar (with ticks) per side of the faces it shows.

    Parameters
    ----------
    vertices : ndarray (V, 3)  [m], east-north-up
    triangles : ndarray (M, 3)  vertex indices
    face_values : ndarray (M,)  value of each triangle's front side (NaN: context, drawn grey)
    vmin, vmax : float  colour range of the front sides (same unit as the values)
    view : str or (azimuth, elevation)  a key of :data:`VIEWS`, or the camera's direction [deg] (azimuth clockwise
        from north; a negative elevation looks up from below)
    size : int  width of the scene part of the image [pixels]
    label, unit : str  caption of the colour bars
    cull : ndarray (M,) of bool, optional  triangles not drawn when they face away from the camera (one-sided
        surfaces of closed solids)
    back_values : ndarray (M,), optional  value of each triangle's rear side (two-sided faces; NaN: none): a
        triangle seen from behind takes it, on its own colour map (:data:`BACK_CMAP`) and range
        ``back_vmin`` .. ``back_vmax``, with its own colour bar
    context : bool  draw the context (NaN) triangles
    title : str, optional  the picture's title (default: the view)
    """
    import matplotlib as mpl
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    if isinstance(view, str) and view not in VIEWS:
        raise ValueError(f"view={view!r}: expected one of {', '.join(VIEWS)}")
    to_cam, right, up = _camera(view)
    tri = np.asarray(vertices, float)[np.asarray(triangles)]                    # (M, 3, 3)
    xy = np.stack([tri @ right, tri @ up], axis=-1)                            # (M, 3, 2)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    vals = np.asarray(face_values, float)
    seen_back = n @ to_cam < 0.0
    hidden = np.zeros(len(tri), bool)
    if isinstance(view, str):
        # faces looking straight down (building floors) are seen from behind from every named view (all lie above
        # the horizon): skip them
        hidden |= n[:, 2] <= -0.99
    if cull is not None:
        hidden |= np.asarray(cull, bool) & seen_back
    if not context:
        hidden |= ~np.isfinite(vals)
    ss = 2
    W = int(size) * ss
    keep = ~hidden if (~hidden).any() else np.ones(len(tri), bool)
    lo, hi = xy[keep].reshape(-1, 2).min(axis=0), xy[keep].reshape(-1, 2).max(axis=0)
    scale = 0.94 * W / max(hi[0] - lo[0], 1e-9)
    H = int(min(max((hi[1] - lo[1]) * scale / 0.94, 0.5 * W), 1.2 * W))
    scale = min(scale, 0.94 * H / max(hi[1] - lo[1], 1e-9))
    px = (xy - 0.5 * (lo + hi)) * scale * np.array([1.0, -1.0]) + np.array([W / 2, H / 2])
    rgb = colour_ramp((vals - vmin) / (vmax - vmin if vmax > vmin else 1.0), FRONT_CMAP)
    shade = 0.55 + 0.45 * np.abs(n @ np.array([0.3, -0.5, 0.81]))
    grey = np.repeat((0.78 * shade)[:, None], 3, axis=1)
    col = np.where(np.isfinite(vals)[:, None], rgb, grey)
    use_back = np.zeros(len(tri), bool)
    if back_values is not None:
        bv = np.asarray(back_values, float)
        use_back = seen_back & np.isfinite(bv)
        brgb = colour_ramp((bv - back_vmin) / (back_vmax - back_vmin if back_vmax > back_vmin else 1.0), BACK_CMAP)
        col[use_back] = brgb[use_back]
    pixels = np.full((H, W, 3), (246, 246, 244), np.uint8)
    rgb8 = np.round(255 * col).astype(np.uint8)
    _zbuffer(pixels, px, tri @ to_cam, rgb8, ~hidden)
    scene_img = Image.fromarray(pixels).resize((W // ss, H // ss), Image.LANCZOS)
    # which sides show: a colour bar for each
    drawn = ~hidden & np.isfinite(vals)
    bars = []
    if (drawn & ~use_back).any():
        bars.append(("front" if use_back.any() or back_values is not None else "", FRONT_CMAP, vmin, vmax))
    if (drawn & use_back).any():
        bars.append(("rear", BACK_CMAP, back_vmin, back_vmax))
    w_in, h_in = W / ss / 100.0, H / ss / 100.0
    bar_in = 1.15 * max(len(bars), 1)
    with mpl.rc_context({"font.size": 11.0}):
        fig = Figure(figsize=(w_in + bar_in, h_in + 0.45), dpi=100)
        fw = w_in + bar_in
        ax = fig.add_axes((0.0, 0.0, w_in / fw, h_in / (h_in + 0.45)))
        ax.imshow(np.asarray(scene_img), interpolation="none")
        ax.set_axis_off()
        name = view if isinstance(view, str) else f"azimuth {view[0]:.0f} deg, elevation {view[1]:.0f} deg"
        if view == "top":
            name = "top (north up)"     # looked at from the south, nearly straight down: a plan's orientation
        fig.text(0.01, 1.0 - 0.08 / (h_in + 0.45), title or f"view from the {name}", va="top", fontsize=12)
        for i, (side, cmap, a, b) in enumerate(bars):
            x0 = (w_in + 0.18 + 1.15 * i) / fw
            cax = fig.add_axes((x0, 0.1, 0.17 / fw, 0.72 * h_in / (h_in + 0.45)))
            cb = fig.colorbar(ScalarMappable(Normalize(a, b if b > a else a + 1e-9), cmap), cax=cax)
            cb.ax.tick_params(labelsize=11)
            cb.ax.set_title("\n".join(t for t in (side, label, f"[{unit}]" if unit else "") if t), fontsize=10.5,
                            loc="left")
        buf = __import__("io").BytesIO()
        fig.savefig(buf, format="png")
    buf.seek(0)
    return Image.open(buf).convert("RGB")


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
