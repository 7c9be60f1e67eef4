"""A minimal 8-bit RGB PNG writer (zlib from the standard library), for the renderer's display images.

The file is the PNG format's signature, an IHDR chunk (width, height, bit depth 8, colour type 2: RGB, no
interlace), one IDAT chunk holding the zlib stream of the scanlines, and IEND; every chunk carries its
length and a CRC-32 of its type and data. Each scanline is stored with the "Up" filter (type 2: each byte
minus the byte above it, mod 256; the first row's "above" is 0), which suits the smooth vertical
gradients of sky images and is one numpy operation over the whole image; zlib level 1. The tests read
the files back with Pillow.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

__all__ = ["write_rgb_png"]

SIGNATURE = b"\x89PNG\r\n\x1a\n"
FILTER_UP = 2


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def write_rgb_png(f, image, level=1):
    """Write ``image`` (H, W, 3) uint8 as a PNG to the open binary file ``f``."""
    img = np.ascontiguousarray(image, np.uint8)
    if img.ndim != 3 or img.shape[2] != 3 or img.shape[0] < 1 or img.shape[1] < 1:
        raise ValueError(f"image of shape {img.shape}: expected (H, W, 3) with H, W >= 1")
    h, w, _ = img.shape
    rows = np.empty((h, 1 + 3 * w), np.uint8)
    rows[:, 0] = FILTER_UP
    flat = img.reshape(h, 3 * w)
    rows[0, 1:] = flat[0]
    np.subtract(flat[1:], flat[:-1], out=rows[1:, 1:])  # uint8 arithmetic wraps: mod 256
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    f.write(SIGNATURE + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", zlib.compress(rows.data, level)) + _chunk(b"IEND", b""))
