"""widesky's own OpenEXR scanline writer for the uncompressed and RLE cases (the renderer's default).

Writing a 1000 x 1000 spectral image (55 channels plus RGB, 116 MB of half floats) through the OpenEXR
library takes a channel-plane copy of the image and about half a second of RLE coding on two cores; here
one C pass (``_core.exr_lines``, OpenMP over scanlines) reads the pixel-interleaved float32 image, rounds
to half, codes each scanline and hands back the finished chunks, which are written after the header and
the offset table. The file is a standard single-part scanline OpenEXR (version 2): magic, version, the
header's attributes, a table of each chunk's file offset, the chunks in increasing y (one scanline each:
int32 y, int32 data size, data). The tests read every file written here back with the OpenEXR library.

Little-endian hosts only (the values are copied as they lie in memory); elsewhere
:func:`skymodel.render.write_exr` uses the OpenEXR library.
"""

from __future__ import annotations

import struct
import sys

import numpy as np

from . import _core

__all__ = ["NATIVE_COMPRESSIONS", "write_scanline_exr"]

NATIVE_COMPRESSIONS = {"none": 0, "rle": 1} if sys.byteorder == "little" else {}
_PIXEL_TYPE = {"half": 1, "float": 2}  # the format's codes (0 is uint)


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
    values : ndarray (H, W, C) float32, C-contiguous  the image's planes, pixel-interleaved
    rgb : ndarray (H, W, 3) float32 or None  three more planes (source indices C, C+1, C+2)
    names : list of str  the file's channel names, sorted as the format requires
    sources : sequence of int  for each name, its plane (0..C-1 in ``values``, C..C+2 in ``rgb``)
    pixel_type : {"half", "float"}
    compression : {"none", "rle"}
    strings : dict  extra string attributes
    overflow_ok : bool
        With half pixels, False makes the call write nothing and return the count of values that do
        not fit a half float (beyond 65504 after rounding, inf or NaN) when there are any.
    threads : int  encoder threads (0: one per core)

    Returns
    -------
    int  values that became inf or NaN as half floats (0 for float pixels); nothing was written when
    this is not 0 and ``overflow_ok`` is False
    """
    h, w, c = values.shape
    nk = len(names)
    line = nk * w * (2 if pixel_type == "half" else 4)
    slot = 8 + line + line // 127 + 1
    chunks = np.empty((h, slot), np.uint8)  # pages past each chunk's end are never touched
    sizes = np.empty(h, np.int64)
    bad = _core.exr_lines(values, rgb, h, w, c, np.asarray(sources, np.int32), int(pixel_type == "half"),
                          NATIVE_COMPRESSIONS[compression], chunks, sizes, int(threads))
    if bad and not overflow_ok:
        return bad
    head = exr_header(names, w, h, pixel_type, compression, strings)
    offsets = len(head) + 8 * h + np.concatenate([[0], np.cumsum(sizes[:-1])]) if h else np.zeros(0, np.int64)
    f.write(head)
    f.write(np.asarray(offsets, "<u8").tobytes())
    for y in range(h):
        f.write(chunks[y, : sizes[y]])
    return bad
