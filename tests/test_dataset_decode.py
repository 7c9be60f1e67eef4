"""Half-float decoding of datasets: the vectorised (F16C) and table converters of skymodel/_core.c, and the
project's C port of the reference loader (``_core.reference_load``, the baseline of benchmarks/bench_open.py)
as an independent cross-check of the decoded values.

Sources: IEEE 754-2008 binary16, every value of which is exactly a float32 (numpy.float16 converts it); the
reference loader's decoding rules (Wilkie et al. 2021, Vevoda et al. 2022; shared/spec/psm-dataset-format.md
section 2: sun and emphasis = float32(half), zenith = float32(double(half) / zenithScale)). Tolerance: none,
bit for bit.
"""

import struct
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from widesky import skymodel
from widesky.skymodel import DatasetError, _core
from widesky.skymodel.synthetic import write_synthetic_dataset

TABLE, F16C, REFERENCE = 1, 2, 3


def f16c_available():
    try:
        _core.half_to_float(np.zeros(1, np.uint16), np.empty(1, np.float32), F16C)
        return True
    except ValueError:
        return False


def cpu_has_f16c():
    try:
        flags = next(line for line in Path("/proc/cpuinfo").read_text().splitlines() if line.startswith("flags"))
    except (OSError, StopIteration):
        return False
    return {"f16c", "avx"} <= set(flags.split())


CONVERTERS = [TABLE] + ([F16C] if f16c_available() else [])


@contextmanager
def decoder(impl):
    before = _core.decode_impl(impl)
    try:
        yield
    finally:
        _core.decode_impl(0)
    assert before in (TABLE, F16C)


def convert(impl):
    out = np.empty(65536, np.float32)
    _core.half_to_float(np.arange(65536, dtype=np.uint16), out, impl)
    return out.view(np.uint32)


def test_f16c_path_is_used_where_the_processor_has_it():
    if sys.platform.startswith("linux") and cpu_has_f16c():
        assert f16c_available()
        with decoder(0):
            assert _core.decode_impl(0) == F16C


def test_converters_agree_on_every_half_pattern():
    """All 65,536 patterns (zeros, subnormals, normals, +-inf, quiet and signalling NaNs): the table, F16C
    (where available) and the reference loader's float(double from half) give the same bits; non-NaN values
    equal numpy's exact float16 -> float32; a NaN keeps its sign and payload and comes out quiet."""
    table = convert(TABLE)
    assert np.array_equal(convert(REFERENCE), table)
    if f16c_available():
        assert np.array_equal(convert(F16C), table)
    halves = np.arange(65536, dtype=np.uint16)
    exact = halves.view(np.float16).astype(np.float32).view(np.uint32)
    nan = np.isnan(halves.view(np.float16))
    assert nan.sum() == 2 * 1023
    assert np.array_equal(table[~nan], exact[~nan])
    assert np.array_equal(table[nan], exact[nan] | 0x00400000)
    sub = (halves & 0x7C00) == 0
    assert np.array_equal(table[sub].view(np.float32), np.ldexp((halves[sub] & 0x3FF).astype(np.float32), -24)
                          * np.where(halves[sub] & 0x8000, -1, 1))


# odd knot counts: every vector ends in a partial group of 8
SPEC = dict(visibilities=(20, 60), albedos=(0, 1), altitudes=(0,), elevations=(0, 30, 90), n_channels=3, rank=3,
            n_sun=13, n_zen=11, n_emph=7, trans_dims=(4, 3), trans_rank=2, polarisation=True, pol_rank=2,
            n_pol_sun=5, n_pol_zen=6)


@pytest.fixture(scope="module")
def edgy(tmp_path_factory):
    """A synthetic file whose first blocks hold the edge cases: subnormal halves, signed zeros, the largest
    half, and zenith scales that make float32(double / scale) subnormal or round twice."""
    path = write_synthetic_dataset(tmp_path_factory.mktemp("dec") / "edgy.dat", **SPEC)
    m = skymodel.load_dataset(path)
    ns, nz, ne, rank = 13, 11, 7, 3
    rank_bytes, block = 2 * ns + 8 + 2 * nz, m._layout.block_dtype.itemsize
    b = bytearray(path.read_bytes())
    specials = [0x0001, 0x8001, 0x03FF, 0x83FF, 0x0000, 0x8000, 0x7BFF, 0xFBFF, 0x0400, 0x3C00, 0x3555, 0x1234, 0x9876]
    for blk in range(4):
        off = m._layout.rad_offset + blk * block
        for r in range(rank):
            p = off + r * rank_bytes
            for j in range(ns):
                struct.pack_into("<H", b, p + 2 * j, specials[(j + blk + r) % len(specials)])
            struct.pack_into("<d", b, p + 2 * ns, (1e38, 3.0, -7e-5, 0.1)[(blk + r) % 4])
            for j in range(nz):
                struct.pack_into("<H", b, p + 2 * ns + 8 + 2 * j, specials[(3 * j + blk) % len(specials)])
        for j in range(ne):
            struct.pack_into("<H", b, off + rank * rank_bytes + 2 * j, specials[(j + 5 * blk) % len(specials)])
    path.write_bytes(bytes(b))
    return path


def reference_arrays(path, m):
    """The C port of the reference loader's vectors, split into widesky's (sun, zen, emph, psun, pzen)."""
    rad, U, V, pol = _core.reference_load(str(path))
    rank, ns, nz, ne = m.rank, len(m.sun_breaks), len(m.zenith_breaks), len(m.emph_breaks)
    rad = np.frombuffer(rad, np.float32).reshape(-1, rank * (ns + nz) + ne)
    rr = rad[:, :rank * (ns + nz)].reshape(-1, rank, ns + nz)
    nps, npz = len(m.pol_sun_breaks), len(m.pol_zenith_breaks)
    pol = np.frombuffer(pol, np.float32).reshape(-1, m.pol_rank, nps + npz)
    return dict(sun=rr[..., :ns], zen=rr[..., ns:], emph=rad[:, rank * (ns + nz):], psun=pol[..., :nps],
                pzen=pol[..., nps:], U=np.frombuffer(U, np.float32), V=np.frombuffer(V, np.float32))


@pytest.mark.parametrize("impl", CONVERTERS)
def test_decode_matches_reference_loader_bit_for_bit(edgy, impl):
    m = skymodel.load_dataset(edgy)
    ref = reference_arrays(edgy, m)
    with decoder(impl):
        m.load()
        s, z, e = m.radiance_coefficients()
        ps, pz = m.polarisation_coefficients()
        U, V = m.transmittance_coefficients()
    got = dict(sun=s, zen=z, emph=e, psun=ps, pzen=pz, U=U, V=V)
    for k, a in got.items():
        assert np.array_equal(a.reshape(ref[k].shape).view(np.uint32), ref[k].view(np.uint32)), k
    zen = z.reshape(ref["zen"].shape)
    assert (np.abs(zen[:4]) < np.finfo(np.float32).tiny).any() and (zen[:4] != 0).any()  # subnormal results
    assert np.signbit(s.reshape(ref["sun"].shape)[:4][s.reshape(ref["sun"].shape)[:4] == 0]).any()  # -0 kept
    # a selection (channels, one visibility) decodes the same values
    sel = skymodel.load_dataset(edgy, visibility=20, channels=[0, 2])
    with decoder(impl):
        s2, z2, e2 = sel.radiance_coefficients()
    full_s = ref["sun"].reshape(m._blocks_shape() + (m.rank, -1))
    assert np.array_equal(s2.view(np.uint32), full_s[:1, :, :, :, [0, 2]].view(np.uint32))


@pytest.mark.parametrize("patch, field", [
    (lambda b, o: struct.pack_into("<H", b, o + 2 * 12, 0x7E00), "sunStored"),          # NaN, last sun value
    (lambda b, o: struct.pack_into("<d", b, o + 26 + 56, 0.0), "zenithScale"),          # rank 1's scale
    (lambda b, o: struct.pack_into("<H", b, o + 56 + 34 + 2 * 10, 0xFC00), "zenStored"),  # -inf, rank 1
    (lambda b, o: struct.pack_into("<d", b, o + 26, 1e-300), "zenStored"),              # overflow on division
    (lambda b, o: struct.pack_into("<H", b, o + 3 * 56 + 2 * 6, 0x7C01), "emphStored"),  # signalling NaN
])
def test_bad_values_reported_alike_by_every_converter(edgy, tmp_path, patch, field):
    """Each converter names the same field and block offset (a block here: 3 ranks x 56 bytes, then 7
    emphasis halves)."""
    m = skymodel.load_dataset(edgy)
    block = m._layout.block_dtype.itemsize
    assert block == 3 * 56 + 14
    b = bytearray(edgy.read_bytes())
    target = m._layout.rad_offset + 5 * block  # the sixth block: row 1, channel 2
    patch(b, target)
    p = tmp_path / "bad.dat"
    p.write_bytes(bytes(b))
    seen = set()
    for impl in CONVERTERS:
        with decoder(impl), pytest.raises(DatasetError) as err:
            skymodel.load_dataset(p).load()
        assert err.value.field == field and err.value.offset == target, err.value
        seen.add((err.value.field, err.value.offset))
    assert len(seen) == 1


@pytest.mark.parametrize("cut", [10, 300, -20])
def test_reference_port_rejects_a_truncated_file(edgy, tmp_path, cut):
    """The benchmark's baseline reads like the reference: a short read raises (naming what it was reading)
    instead of returning partly filled vectors."""
    b = edgy.read_bytes()
    p = tmp_path / "cut.dat"
    p.write_bytes(b[:cut])
    with pytest.raises(ValueError, match="reference_load: .*cannot read"):
        _core.reference_load(str(p))
