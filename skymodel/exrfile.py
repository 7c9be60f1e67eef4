"""widesky's own OpenEXR scanline writer for the uncompressed and RLE cases (the renderer's default).

Writing a 1000 x 1000 spectral image (55 channels plus RGB, 116 MB of half floats) through the OpenEXR
library takes a channel-plane copy of the image and its RLE coding (0.94 s of CPU on one thread, against
0.24 s here: docs/benchmarks.md). Here one C pass (``_core.exr_lines``, OpenMP over scanlines) reads the
pixel-interleaved float32 image, rounds to half, codes each scanline and hands back the finished chunks,
a block of scanlines at a time into one reused buffer; they are written after the header and the offset
table. The file is a standard single-part scanline OpenEXR (version 2): magic, version, the header's
attributes, a table of each chunk's file offset, the chunks in increasing y (one scanline each: int32 y,
int32 data size, data). The tests read every file written here back with the OpenEXR library.

Little-endian hosts only (the values are copied as they lie in memory); elsewhere
:func:`widesky.skymodel.render.write_exr` uses the OpenEXR library.
"""

from __future__ import annotations

import struct
import sys

import numpy as np

from . import _core

__all__ = ["NATIVE_COMPRESSIONS", "write_scanline_exr"]

NATIVE_COMPRESSIONS = {"none": 0, "rle": 1} if sys.byteorder == "little" else {}
_PIXEL_TYPE = {"half": 1, "float": 2}  # the format's codes (0 is uint)
BLOCK_BYTES = 16 << 20  # the chunk buffer: as many scanlines as fit are coded per call


def _attribute(name: str, kind: str, payload: bytes) -> bytes:
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(payload)) + payload


def _chlist(names, pixel_type) -> bytes:
    code = _PIXEL_TYPE[pixel_type]
    # name, pixel type, pLinear (1 byte) and 3 reserved bytes, x and y sampling; a 0 byte ends the list
    return b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", code, 0, 1, 1) for n in names) + b"\0"


def exr_header(names, width, height, pixel_type, compression, strings) -> bytes:
    """Magic, version and header of a single-part scanline file; ``names`` in file (sorted) order,
    ``strings`` the extra string attributes {name: text}."""
    box = struct.pack("<4i", 0, 0, width - 1, height - 1)
    attrs = [_attribute("channels", "chlist", _chlist(names, pixel_type)),
             _attribute("compression", "compression", bytes([NATIVE_COMPRESSIONS[compression]])),
             _attribute("dataWindow", "box2i", box), _attribute("displayWindow", "box2i", box),
             _attribute("lineOrder", "lineOrder", b"\0"),
             _attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
             _attribute("screenWindowCenter", "v2f", struct.pack("<2f", 0.0, 0.0)),
             _attribute("screenWindowWidth", "float", struct.pack("<f", 1.0))]
    attrs += [_attribute(k, "string", str(v).encode()) for k, v in strings.items()]
    longest = max(len(n.encode()) for n in [*names, *strings, "screenWindowCenter"])
    flags = 0x400 if longest > 31 else 0  # "long names": attribute or channel names of 32 to 255 bytes
    return b"\x76\x2f\x31\x01" + struct.pack("<i", 2 | flags) + b"".join(attrs) + b"\0"


def write_scanline_exr(f, values, rgb, names, sources, *, pixel_type, compression, strings, overflow_ok=True, threads=0):
    """Write an OpenEXR image to the open binary file ``f``.

    Parameters
    ----------
    f : binary file open for writing, seekable  (the image starts at its current position)
    values : ndarray (H, W, C) float32, C-contiguous  the image's planes, pixel-interleaved
    rgb : ndarray (H, W, 3) float32 or None  three more planes (C, C+1, C+2; None: copies of plane 0)
    names : list of str  the file's C + 3 channel names, sorted as the format requires
    sources : sequence of int  for each name, its plane: a permutation of 0 .. C+2
    pixel_type : {"half", "float"}
    compression : {"none", "rle"}
    strings : dict  extra string attributes
    overflow_ok : bool
        With half pixels, False makes the call stop at the first block of scanlines holding values that
        do not fit a half float (beyond 65504 after rounding, inf or NaN), truncate the file back to
        where the image started and return their count.
    threads : int  encoder threads (0: one per core)

    Returns
    -------
    int  values that became inf or NaN as half floats (0 for float pixels); nothing is left written when
    this is not 0 and ``overflow_ok`` is False
    """
    h, w, c = values.shape
    line = len(names) * w * (2 if pixel_type == "half" else 4)
    slot = 8 + line + line // 127 + 1
    block = max(1, min(h, BLOCK_BYTES // slot))  # one buffer for every block: its memory is touched once
    chunks = np.empty((block, slot), np.uint8)
    sizes = np.empty(h, np.int64)
    src = np.asarray(sources, np.int32)
    start = f.tell()
    head = exr_header(names, w, h, pixel_type, compression, strings)
    f.write(head)
    f.write(bytes(8 * h))  # the offset table, filled in at the end
    bad = 0
    for y0 in range(0, h, block):
        y1 = min(h, y0 + block)
        bad += _core.exr_lines(values[y0:y1], None if rgb is None else rgb[y0:y1], y0, y1 - y0, w, c, src,
                               int(pixel_type == "half"), NATIVE_COMPRESSIONS[compression], chunks[: y1 - y0],
                               sizes[y0:y1], int(threads))
        if bad and not overflow_ok:
            f.seek(start)
            f.truncate()
            return bad
        for y in range(y1 - y0):
            f.write(chunks[y, : sizes[y0 + y]])
    end = f.tell()
    offsets = start + len(head) + 8 * h + np.concatenate([[0], np.cumsum(sizes[:-1])]) if h else sizes
    f.seek(start + len(head))
    f.write(np.asarray(offsets, "<u8").tobytes())
    f.seek(end)
    return bad
