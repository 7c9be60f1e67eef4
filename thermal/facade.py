"""Facade maps: per-face values on the building mesh as a coloured PLY and a per-face CSV.

Both files are written atomically (:func:`widesky.core.atomic.atomic_write`: a temporary file in the same
folder, then ``os.replace``).
"""

from __future__ import annotations

import numpy as np

from widesky.core import atomic

__all__ = ["write_facade_ply", "write_face_csv", "colour_map", "atomic_write"]


def colour_map(values, vmin=None, vmax=None):
    """(F, 3) uint8 colours of a perceptual blue-yellow-red ramp for (F,) values (NaN grey)."""
    v = np.asarray(values, float)
    lo = np.nanmin(v) if vmin is None else vmin
    hi = np.nanmax(v) if vmax is None else vmax
    t = np.nan_to_num(np.clip((v - lo) / (hi - lo if hi > lo else 1.0), 0, 1), nan=0.0)
    stops = np.array([[49, 54, 149], [116, 173, 209], [255, 255, 191], [244, 109, 67],
                      [165, 0, 38]], float)
    x = t * (len(stops) - 1)
    i = np.minimum(x.astype(int), len(stops) - 2)
    f = (x - i)[:, None]
    rgb = stops[i] * (1 - f) + stops[i + 1] * f
    rgb[~np.isfinite(v)] = 128
    return np.round(rgb).astype(np.uint8)


def atomic_write(path, write):
    """Write ``path`` atomically: ``write(fh)`` fills a temporary binary file
    (:func:`widesky.core.atomic.atomic_write`)."""
    with atomic.atomic_write(path) as tmp, open(tmp, "wb") as fh:
        write(fh)


def write_facade_ply(path, vertices, faces, values, vmin=None, vmax=None):
    """Binary PLY of the mesh with one colour and one float ``value`` per face.

    Parameters
    ----------
    path : path
    vertices : array_like
        (V, 3) [m].
    faces : array_like
        (F, 3) vertex indices.
    values : array_like
        (F,) per-face values (any unit, e.g. annual solar gain [kWh m-2]).
    vmin, vmax : float, optional
        Colour range (default the data's).
    """
    v = np.asarray(vertices, "<f4")
    f = np.asarray(faces, "<i4")
    val = np.asarray(values, "<f4")
    if val.shape != (len(f),):
        raise ValueError(f"values has shape {val.shape}, expected ({len(f)},) per face")
    rgb = colour_map(val, vmin, vmax)
    head = (f"ply\nformat binary_little_endian 1.0\ncomment widesky thermal facade map\n"
            f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {len(f)}\nproperty list uchar int vertex_indices\n"
            f"property uchar red\nproperty uchar green\nproperty uchar blue\n"
            f"property float value\nend_header\n").encode()
    rec = np.zeros(len(f), dtype=[("n", "u1"), ("idx", "<i4", 3), ("rgb", "u1", 3), ("val", "<f4")])
    rec["n"], rec["idx"], rec["rgb"], rec["val"] = 3, f, rgb, val

    def write(fh):
        fh.write(head)
        fh.write(v.tobytes())
        fh.write(rec.tobytes())
    atomic_write(path, write)


def write_face_csv(path, faces_table):
    """Per-face CSV (a pandas DataFrame, one row per face) written atomically."""
    text = faces_table.to_csv(index=True).encode()
    atomic_write(path, lambda fh: fh.write(text))
