#!/usr/bin/env python
"""Mutation fuzzer for the dataset decoder (``widesky.skymodel.load_dataset`` and the C decoding and
evaluation routines behind it).

What it does
    Writes a few small valid seed datasets (:data:`SEEDS`: with and without the polarisation section, every
    section of the format, grids of one and of several points), then generates mutated copies of them and
    feeds each one to the decoder: open (header parse and validation), ``load()`` (the C decoding of the
    radiance, transmittance and polarisation blocks, sometimes of a sub-selection, for a quarter of the files
    one configuration row per decoding chunk), ``describe()``, and an
    evaluation of sky radiance (direct and table paths, which must agree wherever the direct path is
    finite), twilight radiance, transmittance and polarisation.

    Mutations (:func:`mutate`; one to four stacked per file, chosen by a seeded generator, so case ``i`` of
    a given ``--seed`` is always the same file): truncation (anywhere or at a field boundary), bit flips
    (anywhere or in the headers), byte stretches overwritten, a count field set to 0, negative, 1, 2, the
    seed's value +-1 or huge, a count changed with the bytes inserted or removed so the headers still parse
    (and sometimes the file resized to what the new counts need: inconsistent but "well-sized" files), knots
    moved next to a neighbour, channel start / width anywhere from 1e-30 to 1e5 nm, header doubles and
    transmittance floats set to NaN, +-inf, +-huge, subnormal or -0, zenith scales and half floats of the
    coefficient blocks set to hostile values, polarisation floats, chunks deleted, duplicated or inserted,
    trailing bytes, a section cut off.

    Every file must either load (and evaluate) or raise ``DatasetError`` / ``ValueError``. Anything else is
    a finding: another exception type, a warning (numpy ``RuntimeWarning`` included), a crash (a signal, a
    sanitizer report), a hang (no answer within ``--timeout`` seconds), a ``MemoryError`` (the worker runs
    under an address-space limit, ``--memory-mb``) or a resident-memory jump over 256 MB for one file, a
    table/direct mismatch, or a ``DatasetError`` that names no field or no byte offset.

How it runs
    A supervisor starts one worker process (``--worker``) and hands it a range of case numbers; the worker
    reports each case on its stdout. A crash or hang is attributed to the case in flight; its file is
    written to ``--findings`` and a fresh worker continues with the next case. One worker at a time, one
    OpenMP thread: run it under ``nice``.

Usage
    nice -n 19 python tools/fuzz_decoder.py --files 200000 --seed 1 --json fuzz.json
    # the same under AddressSanitizer + UndefinedBehaviorSanitizer with the float checks:
    nice -n 19 tools/sanitize_core.sh .venv/bin/python --run tools/fuzz_decoder.py --files 20000 --seed 2

    The summary (files run, outcomes, distinct exceptions, findings, time) is printed and, with ``--json``,
    written as JSON. Exit status 0 when there is no finding, 1 otherwise. The test suite runs a few hundred
    cases (tests/test_sky_format.py::test_seeded_mutations_never_crash).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import select
import struct
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

SEEDS = {
    # the format spec's worked example (section 6): every section, polarisation rank 2 with 5/5 knots
    "spec-small-pol": dict(visibilities=(20, 60), albedos=(0, 1), altitudes=(0,), elevations=(0, 30, 90),
                           n_channels=2, rank=2, n_sun=7, n_zen=7, n_emph=6, trans_dims=(4, 3), trans_rank=2,
                           polarisation=True, pol_rank=2, n_pol_sun=5, n_pol_zen=5),
    # no polarisation section (like the ground-level dataset); two altitudes, twilight elevations, rank 1
    "ground-nopol": dict(visibilities=(20, 40, 131.8), albedos=(0, 0.5, 1), altitudes=(0, 1000),
                         elevations=(-4.2, 0, 10, 90), n_channels=3, channel_start=320.0, channel_width=40.0,
                         rank=1, n_sun=4, n_zen=5, n_emph=3, trans_dims=(3, 2), trans_rank=1, polarisation=False),
    # one point per grid, 55 channels to 2480 nm (the SWIR layout), rank 3, the smallest polarisation
    "swir-single-pol": dict(visibilities=(60,), albedos=(0.5,), altitudes=(0,), elevations=(10, 45),
                            n_channels=55, channel_start=280.0, channel_width=40.0, rank=3, n_sun=5, n_zen=4,
                            n_emph=4, trans_dims=(2, 5), trans_rank=3, polarisation=True, pol_rank=1,
                            n_pol_sun=2, n_pol_zen=3, roughness=0.2, seed=3),
}

COUNTS = ("nVis", "nAlb", "nAlt", "nEle", "channels", "rankRad", "nSun", "nZen", "nEmph",
          "dDim", "aDim", "nVisT", "nAltT", "rankT", "rankPol", "nPSun", "nPZen")
HOSTILE_I32 = (0, -1, -2, -(2 ** 31), 1, 2, 3, 255, 4096, 65535, 65536, 2 ** 24, 2 ** 30, 2 ** 31 - 1)
HOSTILE_F64 = (float("nan"), float("inf"), -float("inf"), 1e308, -1e308, 5e-324, -5e-324, -0.0, 0.0, 1e-30,
               -1.0, 3.141592653589793, 3.1416, 1e5, -1e5)
HOSTILE_F32 = (float("nan"), float("inf"), -float("inf"), 3.4e38, -3.4e38, 1e-45, -0.0, 0.0, -1.0, 1e30, 2.0)
# raw bit patterns: signalling NaNs (a widening cast flags "invalid"), NaN payloads, the largest subnormal
HOSTILE_F64_BITS = (0x7FF0000000000001, 0xFFF0000000000001, 0x7FF8000000000001, 0x000FFFFFFFFFFFFF)
HOSTILE_F32_BITS = (0x7F800001, 0xFF800001, 0x7FC00001, 0x007FFFFF)
HOSTILE_HALF = (0x7C00, 0xFC00, 0x7E00, 0x7C01, 0x7BFF, 0xFBFF, 0x0001, 0x8000, 0x0000, 0x3C00)
KIND_WEIGHTED = tuple(range(16)) + (2, 10, 11, 11, 11, 12, 12)  # block contents more often: files that load
HOSTILE_SCALE = (0.0, -0.0, float("nan"), float("inf"), -float("inf"), 1e-300, 5e-324, -1.0, 1e300, 1e-40)


# ------------------------------------------------------------------------------------------ the layout
class Layout:
    """Where every field of a (valid) seed file lies, walked from the format spec
    (shared/spec/psm-dataset-format.md), independently of the decoder under test.

    ``fields``: name -> (offset, kind, count) with kind 'i32', 'f64', 'f32'; ``counted``: count name ->
    (count offset, array offset, item size) of each "count + array" pair; ``sections``: name -> (start, end);
    ``block``: (rank, nSun, nZen, nEmph) of a radiance block."""

    def __init__(self, b: bytes):
        self.size = len(b)
        self.fields, self.counted, self.sections = {}, {}, {}
        pos = 0

        def i32(name):
            nonlocal pos
            v = struct.unpack_from("<i", b, pos)[0]
            self.fields[name] = (pos, "i32", 1)
            pos += 4
            return v

        def arr(name, kind, n):
            nonlocal pos
            self.fields[name] = (pos, kind, n)
            pos += n * (8 if kind == "f64" else 4)

        def counted(cname, name):
            start = pos
            n = i32(cname)
            arr(name, "f64", n)
            self.counted[cname] = (start, start + 4, 8)
            return n

        nvis = counted("nVis", "visibilities")
        nalb = counted("nAlb", "albedos")
        nalt = counted("nAlt", "altitudes")
        nele = counted("nEle", "elevations")
        nch = i32("channels")
        arr("channelStart", "f64", 1)
        arr("channelWidth", "f64", 1)
        rank = i32("rankRad")
        ns = counted("nSun", "sunBreaks")
        nz = counted("nZen", "zenithBreaks")
        ne = counted("nEmph", "emphBreaks")
        self.sections["header"] = (0, pos)
        self.n_cfg = nvis * nalb * nalt * nele * nch
        self.block = (rank, ns, nz, ne)
        self.block_bytes = rank * (2 * ns + 8 + 2 * nz) + 2 * ne
        self.sections["radiance"] = (pos, pos + self.n_cfg * self.block_bytes)
        pos += self.n_cfg * self.block_bytes
        t0 = pos
        d, a, nvt, nat, rt = (i32(k) for k in ("dDim", "aDim", "nVisT", "nAltT", "rankT"))
        arr("altitudesT", "f32", nat)
        arr("visibilitiesT", "f32", nvt)
        self.counted["nAltT"] = (self.fields["nAltT"][0], self.fields["altitudesT"][0], 4)
        self.counted["nVisT"] = (self.fields["nVisT"][0], self.fields["visibilitiesT"][0], 4)
        self.sections["transmittance header"] = (t0, pos)
        arr("U", "f32", nat * d * a * rt)
        arr("V", "f32", nvt * nat * nch * rt)
        self.sections["transmittance"] = (t0, pos)
        self.pol_block_bytes = 0
        if pos < len(b):
            p0 = pos
            prank = i32("rankPol")
            nps = counted("nPSun", "polSunBreaks")
            npz = counted("nPZen", "polZenithBreaks")
            self.sections["polarisation header"] = (p0, pos)
            self.pol_block_bytes = prank * 4 * (nps + npz)
            self.sections["polarisation"] = (pos, pos + self.n_cfg * self.pol_block_bytes)
            pos += self.n_cfg * self.pol_block_bytes
        if pos != len(b):
            raise ValueError(f"seed layout: walked {pos} bytes of {len(b)}")
        # field boundaries (for truncations) and the bytes that are headers (for focused bit flips)
        self.boundaries = sorted({0, len(b)} | {o for o, _, _ in self.fields.values()}
                                 | {s for s, _ in self.sections.values()} | {e for _, e in self.sections.values()})
        self.header_ranges = [self.sections[k] for k in ("header", "transmittance header", "polarisation header")
                              if k in self.sections]


# ------------------------------------------------------------------------------------------ mutations
def _choice(rng, seq):
    return seq[int(rng.integers(0, len(seq)))]


def _header_pos(lay, rng):
    lo, hi = _choice(rng, lay.header_ranges)
    return int(rng.integers(lo, hi))


def mutate(b: bytearray, lay: Layout, rng) -> str:
    """Apply one random mutation to ``b`` (in place, which may change its length); returns what it did.
    ``lay`` is the seed's layout: after earlier stacked mutations the offsets may no longer match the
    bytes, which is one more way to make hostile files."""
    import numpy as np

    kind = int(_choice(rng, KIND_WEIGHTED))
    n = len(b)
    if n < 16:
        b.extend(rng.integers(0, 256, 16, dtype=np.uint8).tobytes())
        return "padded"
    if kind == 0:                                   # truncation anywhere
        cut = int(rng.integers(0, n))
        del b[cut:]
        return f"truncate@{cut}"
    if kind == 1:                                   # truncation at (or a few bytes around) a field boundary
        cut = max(0, min(n - 1, _choice(rng, lay.boundaries) + int(rng.integers(-3, 4))))
        del b[cut:]
        return f"truncate-field@{cut}"
    if kind == 2:                                   # bit flips anywhere
        k = int(rng.integers(1, 9))
        for _ in range(k):
            b[int(rng.integers(0, n))] ^= 1 << int(rng.integers(0, 8))
        return f"bitflip x{k}"
    if kind == 3:                                   # bit flips in the section headers
        k = int(rng.integers(1, 4))
        for _ in range(k):
            pos = min(_header_pos(lay, rng), n - 1)
            b[pos] ^= 1 << int(rng.integers(0, 8))
        return f"header-bitflip x{k}"
    if kind == 4:                                   # a count set to a hostile value
        name = _choice(rng, [c for c in COUNTS if c in lay.fields])
        off = lay.fields[name][0]
        seed_value = struct.unpack_from("<i", b, off)[0] if off + 4 <= n else 1
        v = int(_choice(rng, HOSTILE_I32 + (seed_value - 1, seed_value + 1, seed_value * 2)))
        v = max(-(2 ** 31), min(2 ** 31 - 1, v))
        if off + 4 <= n:
            struct.pack_into("<i", b, off, v)
        return f"count {name}={v}"
    if kind == 5:                                   # a count changed, bytes inserted/removed: headers parse on
        name = _choice(rng, list(lay.counted))
        coff, aoff, item = lay.counted[name]
        if coff + 4 > n:
            return "noop"
        old = struct.unpack_from("<i", b, coff)[0]
        if not 0 <= old <= 4096:                    # an earlier stacked mutation made it hostile already
            return "noop"
        delta = int(_choice(rng, (-2, -1, 1, 1, 2, 5)))
        new = max(0, old + delta)
        struct.pack_into("<i", b, coff, new)
        end = min(n, aoff + old * item)
        if new > old:                               # extend the array ascending (a plausible grid)
            fmt = "<d" if item == 8 else "<f"
            last = struct.unpack_from(fmt, b, end - item)[0] if end - item >= aoff else 0.0
            extra = b"".join(struct.pack(fmt, last + 0.5 * (j + 1)) for j in range(new - old))
            b[end:end] = extra
        else:
            del b[max(aoff, end - (old - new) * item):end]
        resize = ""
        if rng.random() < 0.5:                      # resize the file to what the new counts need
            try:
                target = Layout.expected_size(bytes(b))
            except (struct.error, ValueError, OverflowError):
                target = None
            if target is not None and 0 < target < 1 << 22:
                if target > len(b):
                    b.extend(rng.integers(0, 256, target - len(b), dtype=np.uint8).tobytes())
                else:
                    del b[target:]
                resize = f", resized to {target}"
        return f"resize-count {name} {old}->{new}{resize}"
    if kind == 6:                                   # random bytes over a stretch
        k = int(rng.integers(1, 17))
        pos = int(rng.integers(0, max(1, n - k)))
        b[pos:pos + k] = rng.integers(0, 256, k, dtype=np.uint8).tobytes()
        return f"scramble {k}@{pos}"
    if kind == 7:                                   # a knot next to its neighbour (still ascending)
        name = _choice(rng, [k for k in ("sunBreaks", "zenithBreaks", "emphBreaks", "polSunBreaks",
                                          "polZenithBreaks") if k in lay.fields])
        off, _, cnt = lay.fields[name]
        j = int(rng.integers(0, cnt - 1)) if cnt > 1 else 0
        if off + 8 * (j + 2) > n:
            return "noop"
        lo = struct.unpack_from("<d", b, off + 8 * j)[0]
        step = float(_choice(rng, (0.0, 10.0 ** -rng.uniform(4, 300))))
        struct.pack_into("<d", b, off + 8 * (j + 1), float(np.nextafter(lo, 9.0)) if step == 0 else lo + step)
        return f"knot {name}[{j + 1}] near its neighbour"
    if kind == 8:                                   # channel start or width, tiny to huge, either sign
        name = _choice(rng, ("channelStart", "channelWidth"))
        off = lay.fields[name][0]
        v = float(_choice(rng, (-1.0, 1.0))) * 10.0 ** rng.uniform(-30, 5)
        if off + 8 <= n:
            struct.pack_into("<d", b, off, v)
        return f"{name}={v:.3g}"
    if kind == 9:                                   # a header double set to a hostile value
        name = _choice(rng, [k for k, (_, t, c) in lay.fields.items() if t == "f64" and c > 0])
        off, _, cnt = lay.fields[name]
        j = int(rng.integers(0, cnt))
        if off + 8 * (j + 1) > n:
            return "noop"
        if rng.random() < 0.2:
            bits = int(_choice(rng, HOSTILE_F64_BITS))
            struct.pack_into("<Q", b, off + 8 * j, bits)
            return f"{name}[{j}]=bits 0x{bits:016x}"
        v = float(_choice(rng, HOSTILE_F64))
        struct.pack_into("<d", b, off + 8 * j, v)
        return f"{name}[{j}]={v!r}"
    if kind == 10:                                  # a transmittance float set to a hostile value
        name = _choice(rng, ("altitudesT", "visibilitiesT", "U", "V"))
        off, _, cnt = lay.fields[name]
        j = int(rng.integers(0, cnt)) if cnt else 0
        if off + 4 * (j + 1) > n:
            return "noop"
        if rng.random() < 0.2:
            bits = int(_choice(rng, HOSTILE_F32_BITS))
            struct.pack_into("<I", b, off + 4 * j, bits)
            return f"{name}[{j}]=bits 0x{bits:08x}"
        v = float(_choice(rng, HOSTILE_F32))
        struct.pack_into("<f", b, off + 4 * j, v)
        return f"{name}[{j}]={v!r}"
    if kind == 11:                                  # a zenith scale or a half of a radiance block
        rank, ns, nz, ne = lay.block
        start = lay.sections["radiance"][0] + int(rng.integers(0, lay.n_cfg)) * lay.block_bytes
        r = int(rng.integers(0, rank))
        rb = start + r * (2 * ns + 8 + 2 * nz)
        if rng.random() < 0.4:
            v = float(_choice(rng, HOSTILE_SCALE))
            if rb + 2 * ns + 8 <= n:
                struct.pack_into("<d", b, rb + 2 * ns, v)
            return f"zenithScale@{rb + 2 * ns}={v!r}"
        part = int(rng.integers(0, 3))
        pos = (rb + 2 * int(rng.integers(0, ns)) if part == 0 else rb + 2 * ns + 8 + 2 * int(rng.integers(0, nz))
               if part == 1 else start + rank * (2 * ns + 8 + 2 * nz) + 2 * int(rng.integers(0, ne)))
        h = int(_choice(rng, HOSTILE_HALF))
        if pos + 2 <= n:
            struct.pack_into("<H", b, pos, h)
        return f"half@{pos}=0x{h:04x}"
    if kind == 12:                                  # a polarisation float (or, without one, a V float)
        if "polarisation" not in lay.sections:
            lo, hi = lay.fields["V"][0], lay.sections["transmittance"][1]
        else:
            lo, hi = lay.sections["polarisation"]
        pos = lo + 4 * int(rng.integers(0, max(1, (hi - lo) // 4)))
        if pos + 4 > n:
            return "noop"
        if rng.random() < 0.2:
            bits = int(_choice(rng, HOSTILE_F32_BITS))
            struct.pack_into("<I", b, pos, bits)
            return f"f32@{pos}=bits 0x{bits:08x}"
        v = float(_choice(rng, HOSTILE_F32))
        struct.pack_into("<f", b, pos, v)
        return f"f32@{pos}={v!r}"
    if kind == 13:                                  # a chunk deleted, duplicated or inserted
        k = int(_choice(rng, (1, 2, 4, 8, 16, 64, 256)))
        pos = int(rng.integers(0, n))
        how = int(rng.integers(0, 3))
        if how == 0:
            del b[pos:pos + k]
            return f"delete {k}@{pos}"
        if how == 1:
            b[pos:pos] = b[pos:pos + k]
            return f"duplicate {k}@{pos}"
        b[pos:pos] = rng.integers(0, 256, k, dtype=np.uint8).tobytes()
        return f"insert {k}@{pos}"
    if kind == 14:                                  # trailing bytes
        k = int(_choice(rng, (1, 2, 3, 4, 8, 40, 1000)))
        b.extend(rng.integers(0, 256, k, dtype=np.uint8).tobytes() if rng.random() < 0.5 else bytes(k))
        return f"append {k}"
    # kind 15: a whole section cut off, or cut inside its header
    name = _choice(rng, list(lay.sections))
    s, e = lay.sections[name]
    cut = s if rng.random() < 0.5 else int(rng.integers(s, max(s + 1, e)))
    del b[min(cut, n):]
    return f"cut {name}@{cut}"


def _expected_size(b: bytes) -> int:
    """Size a file with these headers must have (spec section 6), or ValueError when a header is cut off."""
    pos = 0

    def i32():
        nonlocal pos
        if pos + 4 > len(b):
            raise ValueError("short")
        v = struct.unpack_from("<i", b, pos)[0]
        pos += 4
        return v

    grid = []
    for _ in range(4):
        k = i32()
        grid.append(k)
        pos += 8 * k
    nch = i32()
    pos += 16
    rank = i32()
    knots = []
    for _ in range(3):
        k = i32()
        knots.append(k)
        pos += 8 * k
    ncfg = grid[0] * grid[1] * grid[2] * grid[3] * nch
    pos += ncfg * (rank * (2 * knots[0] + 8 + 2 * knots[1]) + 2 * knots[2])
    d, a, nvt, nat, rt = (i32() for _ in range(5))
    pos += 4 * (nat + nvt + nat * d * a * rt + nvt * nat * nch * rt)
    if pos >= len(b):
        return pos
    prank = i32()
    nps = i32()
    pos += 8 * nps
    npz = i32()
    pos += 8 * npz
    return pos + ncfg * prank * 4 * (nps + npz)


Layout.expected_size = staticmethod(_expected_size)


def write_seeds(folder: Path) -> dict:
    """Write the seed datasets (no sidecar: the mutated copies have none) -> {name: (bytes, Layout)}."""
    from widesky.skymodel.synthetic import synthetic_contents
    from widesky.skymodel.writer import write_dataset

    folder.mkdir(parents=True, exist_ok=True)
    out = {}
    for name, spec in SEEDS.items():
        p = folder / f"seed-{name}.dat"
        if not p.exists():
            write_dataset(p, synthetic_contents(**spec))
        data = p.read_bytes()
        out[name] = (data, Layout(data))
    return out


def make_case(i: int, seed: int, seeds: dict):
    """Case ``i``: (seed name, mutated bytes, description, load keyword arguments). Deterministic."""
    import numpy as np

    rng = np.random.default_rng([seed, i])
    names = list(seeds)
    name = names[int(rng.integers(0, len(names)))]
    base, lay = seeds[name]
    b = bytearray(base)
    k = int(_choice(rng, (1, 1, 1, 1, 2, 2, 3, 4)))
    desc = [mutate(b, lay, rng) for _ in range(k)]
    load = {}
    r = rng.random()
    if r < 0.15:                                    # a single sky state: only the bracketing points decoded
        load = dict(visibility=float(rng.uniform(10, 150)), albedo=float(rng.uniform(0, 1)),
                    elevation=float(rng.uniform(-5, 90)))
    elif r < 0.22:
        load = dict(channels=[0, int(rng.integers(0, 3))])
    elif r < 0.27:
        load = dict(wavelength_range=(float(rng.uniform(280, 600)), float(rng.uniform(600, 2500))))
    elif r < 0.30:
        load = dict(polarisation=False)
    return name, bytes(b), "; ".join(desc), load


def chunk_bytes(i: int, seed: int):
    """Decoding chunk size for case ``i`` [bytes]: one configuration row per chunk for a quarter of the cases
    (chunk boundaries and the offsets of errors found in a later chunk), the reader's default otherwise. Drawn
    from its own stream, so the files of a seed do not depend on it."""
    import numpy as np

    return 1 if np.random.default_rng([seed, i, 1]).random() < 0.25 else None


# ------------------------------------------------------------------------------------------ one case
DEFAULT_CHUNK = 8 << 20  # the reader's DECODE_CHUNK_BYTES (set from the module in the worker)
_NUM = re.compile(r"np\.float\d+\(([^)]*)\)|-?\b\d[\d_]*(\.\d*)?([eE][-+]?\d+)?\b|-?\binf\b|\bnan\b")


def template(message: str) -> str:
    """An exception message with its numbers, arrays and file name taken out (for counting distinct ones)."""
    m = re.sub(r"\[[^\]]*\]\.\.\.", "[...]", message)
    return _NUM.sub("#", m)


def run_case(path: str, load: dict, dirs, rss0: list, chunk=None):
    """Load and evaluate one file. Returns (outcome, detail): outcome 'loaded', 'rejected' (DatasetError
    naming field and offset), 'value-error' (another ValueError), or a finding: 'exception', 'warning',
    'mismatch', 'memory', 'unclear' (a DatasetError without field or offset)."""
    import resource
    import warnings

    import numpy as np

    from widesky import skymodel
    from widesky.skymodel import DatasetError, dataset

    dataset.DECODE_CHUNK_BYTES = chunk or DEFAULT_CHUNK
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
            m = skymodel.load_dataset(path, **load)
            m.load()
            m.describe()
            vis = load.get("visibility", 40.0)
            alb = load.get("albedo", 0.5)
            ele = load.get("elevation", 20.0)
            direct = skymodel.sky_radiance(m, dirs, ele, 180.0, vis, alb, method="direct")
            table = skymodel.sky_radiance(m, dirs, ele, 180.0, vis, alb, method="table")
            if np.isfinite(direct).all():
                scale = np.abs(direct).max(axis=-1, keepdims=True) + 1e-300
                if not (np.isfinite(table).all() and np.all(np.abs(table - direct) <= 1e-6 * scale)):
                    return "mismatch", "table path differs from the direct path"
            if "elevation" not in load:
                skymodel.sky_radiance(m, dirs, -2.0, 180.0, vis, alb)
            skymodel.transmittance(m, dirs, ele, 180.0, vis, alb)
            if m.has_polarisation:
                skymodel.polarisation(m, dirs, ele, 180.0, vis, alb)
        outcome, detail = "loaded", ""
    except DatasetError as e:
        if not e.field or e.offset is None:
            outcome, detail = "unclear", f"DatasetError without field or offset: {e}"
        else:
            outcome, detail = "rejected", f"DatasetError [{e.field}] {template(e.problem)}"
    except ValueError as e:
        outcome, detail = "value-error", f"{type(e).__name__}: {template(str(e).replace(path, '<file>'))}"
    except MemoryError as e:
        outcome, detail = "memory", f"MemoryError: {e}"
    except Warning as e:
        outcome, detail = "warning", f"{type(e).__name__}: {template(str(e).replace(path, '<file>'))}"
    except Exception as e:  # noqa: BLE001 - every other exception is what we look for
        outcome, detail = "exception", f"{type(e).__name__}: {template(str(e).replace(path, '<file>'))}"
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    if rss - rss0[0] > 256 * 1024:
        outcome, detail = "memory", f"peak resident memory rose by {(rss - rss0[0]) / 1024:.0f} MB"
    rss0[0] = rss
    return outcome, detail


def worker(args):
    """Run cases [start, stop): print 'B i' before and 'R i outcome<TAB>detail' after each one."""
    import numpy as np

    from widesky import skymodel
    from widesky.skymodel import dataset

    global DEFAULT_CHUNK
    DEFAULT_CHUNK = dataset.DECODE_CHUNK_BYTES
    san = os.environ.get("WIDESKY_SANITIZED_CORE")
    if san:
        import widesky.skymodel._core as core
        if os.path.realpath(core.__file__) != os.path.realpath(san):
            sys.exit(f"expected the sanitised core {san}, imported {core.__file__}")
    seeds = write_seeds(Path(args.work) / "seeds")
    dirs = skymodel.direction_from_zenith([0, 45, 89, 120], [0, 90, 180, 270]).astype(np.float64)
    import resource
    rss0 = [resource.getrusage(resource.RUSAGE_SELF).ru_maxrss]
    path = str(Path(args.work) / "case.dat")
    print("READY", flush=True)
    for i in range(args.start, args.stop):
        _, data, _, load = make_case(i, args.seed, seeds)
        with open(path, "wb") as f:
            f.write(data)
        print(f"B {i}", flush=True)
        outcome, detail = run_case(path, load, dirs, rss0, chunk_bytes(i, args.seed))
        print(f"R {i} {outcome}\t{detail}", flush=True)


# ------------------------------------------------------------------------------------------ the supervisor
FINDINGS = ("exception", "warning", "mismatch", "memory", "unclear", "crash", "timeout")


def _limit_memory(mb):
    def f():
        import resource
        if mb and not os.environ.get("WIDESKY_SANITIZED_CORE"):  # ASan reserves terabytes of address space
            resource.setrlimit(resource.RLIMIT_AS, (mb << 20, mb << 20))
    return f


def supervise(args) -> dict:
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    findings_dir = Path(args.findings)
    seeds = write_seeds(work / "seeds")
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONHASHSEED="0")
    if os.environ.get("WIDESKY_SANITIZED_CORE"):
        # ASan refuses allocations above this (a report and an abort: a finding); RSS capped too
        env["ASAN_OPTIONS"] = (env.get("ASAN_OPTIONS", "detect_leaks=0:abort_on_error=1:halt_on_error=1")
                               + f":max_allocation_size_mb={args.memory_mb}:hard_rss_limit_mb={args.memory_mb * 2}")
    outcomes, details, findings = Counter(), Counter(), []
    per_seed = Counter()
    i, stop = args.start, args.start + args.files
    t0 = time.monotonic()
    restarts = 0
    last_report = t0
    while i < stop:
        err_path = work / "worker.stderr"
        cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--work", str(work), "--seed", str(args.seed),
               "--start", str(i), "--stop", str(stop)]
        with open(err_path, "wb") as err:
            proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err, env=env,
                                    preexec_fn=_limit_memory(args.memory_mb))
        restarts += 1
        buf = b""
        current = None
        limit = args.timeout * 10  # start-up (imports; slower under the sanitizers)
        deadline = time.monotonic() + limit
        while True:
            wait = deadline - time.monotonic()
            ready = select.select([proc.stdout], [], [], max(0.0, wait))[0] if wait > 0 else []
            if not ready:
                proc.kill()
                proc.wait()
                kind, msg = "timeout", f"no answer within {args.timeout:g} s"
                break
            chunk = os.read(proc.stdout.fileno(), 65536)
            if not chunk:
                rc = proc.wait()
                kind, msg = "crash", f"worker exited with status {rc}"
                break
            buf += chunk
            *lines, buf = buf.split(b"\n")
            for line in lines:
                s = line.decode(errors="replace")
                if s.startswith("B "):
                    current = int(s[2:])
                elif s.startswith("R "):
                    head, detail = s[2:].split("\t", 1)
                    idx, outcome = head.split(" ", 1)
                    idx = int(idx)
                    outcomes[outcome] += 1
                    if detail:
                        details[detail] += 1
                    if outcome in FINDINGS:
                        findings.append(_finding(idx, args.seed, seeds, outcome, detail, findings_dir))
                    current = None
                    i = idx + 1
            deadline = time.monotonic() + args.timeout
            if time.monotonic() - last_report > 60:
                last_report = time.monotonic()
                print(f"  {i - args.start} / {args.files} files, {time.monotonic() - t0:.0f} s, "
                      f"{sum(outcomes[f] for f in FINDINGS)} findings", file=sys.stderr, flush=True)
            if i >= stop:
                proc.wait()
                kind = None
                break
        if kind is None:
            break
        tail = err_path.read_text(errors="replace")[-4000:]
        if current is None:  # died before or between cases: not attributable to a file
            raise SystemExit(f"fuzz worker failed outside a case ({msg}):\n{tail}")
        outcomes[kind] += 1
        findings.append(_finding(current, args.seed, seeds, kind, f"{msg}\n{tail}", findings_dir))
        i = current + 1
    elapsed = time.monotonic() - t0
    rejected = sorted(((n, d) for d, n in details.items() if d.startswith(("DatasetError", "ValueError"))),
                      reverse=True)
    summary = {
        "files": sum(outcomes.values()), "seed": args.seed, "start": args.start,
        "sanitized_core": os.environ.get("WIDESKY_SANITIZED_CORE") or None,
        "seconds": round(elapsed, 1), "outcomes": dict(outcomes),
        "findings": findings, "n_findings": len(findings),
        "distinct_exceptions": len(rejected), "exceptions": [{"count": n, "message": d} for n, d in rejected],
        "worker_starts": restarts, "seeds": {k: len(v[0]) for k, v in seeds.items()},
    }
    return summary


def _finding(i, seed, seeds, kind, detail, folder: Path) -> dict:
    name, data, desc, load = make_case(i, seed, seeds)
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / f"case-{seed}-{i}.dat"
    p.write_bytes(data)
    return {"case": i, "kind": kind, "detail": detail, "seed_file": name, "mutations": desc, "load": load,
            "decode_chunk_bytes": chunk_bytes(i, seed), "file": str(p)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--files", type=int, default=10000, help="number of mutated files to run (default 10000)")
    ap.add_argument("--seed", type=int, default=1, help="random seed: case i of a seed is always the same file")
    ap.add_argument("--start", type=int, default=0, help="first case number (to split a run over time)")
    ap.add_argument("--timeout", type=float, default=20.0,
                    help="seconds one file may take before it counts as a hang (default 20)")
    ap.add_argument("--memory-mb", type=int, default=4096,
                    help="address-space limit of the worker [MiB] (default 4096)")
    ap.add_argument("--work", default=None, help="scratch folder (default: a temporary one)")
    ap.add_argument("--findings", default="fuzz-findings", help="folder for the files of findings")
    ap.add_argument("--json", default=None, help="write the summary here as JSON")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--stop", type=int, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        return worker(args)
    import tempfile
    with tempfile.TemporaryDirectory(prefix="fuzz-decoder-") as tmp:
        if args.work is None:
            args.work = tmp
        s = supervise(args)
    text = json.dumps(s, indent=1)
    if args.json:
        Path(args.json).write_text(text)
    o = s["outcomes"]
    print(f"{s['files']} files in {s['seconds']} s ({'sanitised core' if s['sanitized_core'] else 'normal build'}): "
          f"{o.get('loaded', 0)} loaded, {o.get('rejected', 0)} DatasetError, {o.get('value-error', 0)} other "
          f"ValueError, {s['n_findings']} findings; {s['distinct_exceptions']} distinct exception messages")
    for f in s["findings"][:20]:
        print(f"FINDING case {f['case']} ({f['kind']}): {f['detail'][:300]}\n  {f['mutations']} -> {f['file']}")
    return 1 if s["n_findings"] else 0


if __name__ == "__main__":
    sys.exit(main())
