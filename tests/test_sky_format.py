"""The dataset format: layout, decoding, selection, and bad files.

Layout reference: shared/spec/psm-dataset-format.md section 6 gives the byte offsets of a small synthetic
file (2 vis x 2 albedo x 1 alt x 3 elev x 2 channels, rank 2, 7/7/6 knots, transmittance 4x3 rank 2,
polarisation rank 2 with 5/5 knots); our writer must produce exactly that layout.
"""

import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from widesky import skymodel
from widesky.skymodel import DatasetError
from widesky.skymodel.synthetic import synthetic_contents, write_synthetic_dataset
from widesky.skymodel.writer import write_dataset

SPEC_SMALL = dict(visibilities=(20, 60), albedos=(0, 1), altitudes=(0,), elevations=(0, 30, 90), n_channels=2,
                  rank=2, n_sun=7, n_zen=7, n_emph=6, trans_dims=(4, 3), trans_rank=2, polarisation=True,
                  pol_rank=2, n_pol_sun=5, n_pol_zen=5)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    return write_synthetic_dataset(tmp_path_factory.mktemp("fmt") / "small.dat", **SPEC_SMALL)


def test_byte_layout_matches_the_spec_example(small):
    b = small.read_bytes()
    assert len(b) == 4464  # spec: EOF at 4464
    i32 = lambda off: struct.unpack_from("<i", b, off)[0]  # noqa: E731
    assert i32(0) == 2 and i32(20) == 2 and i32(40) == 1 and i32(52) == 3  # grid counts at their offsets
    assert i32(80) == 2 and i32(100) == 2  # channels, rankRad
    assert i32(104) == 7 and i32(164) == 7 and i32(224) == 6  # break counts
    assert struct.unpack_from("<5i", b, 2292) == (4, 3, 2, 1, 2)  # dDim, aDim, nVisT, nAltT, rankT
    assert i32(2452) == 2 and i32(2456) == 5 and i32(2500) == 5  # rankPol, polSun, polZenith counts


def test_half_decoding_and_zenith_scale(tmp_path):
    """Decoding follows the reference: sun and emphasis are half floats, the zenith vector is
    float32(double(half) / zenithScale); the writer picks the scale so the zenith fits the half range."""
    c = synthetic_contents(**{**SPEC_SMALL, "polarisation": False})
    path = write_dataset(tmp_path / "h.dat", c, balance=False)
    m = skymodel.load_dataset(path)
    sun, zen, emph = m.radiance_coefficients()
    np.testing.assert_array_equal(sun, c.sun.astype(np.float16).astype(np.float32))
    np.testing.assert_array_equal(emph, c.emph.astype(np.float16).astype(np.float32))
    scale = 1.0 / np.abs(c.zen).max(axis=-1, keepdims=True)
    expect = ((c.zen * scale).astype(np.float16).astype(np.float64) / scale).astype(np.float32)
    np.testing.assert_array_equal(zen, expect)
    # half precision: relative 2^-11 of the largest element of each vector
    np.testing.assert_allclose(zen, c.zen, rtol=0, atol=float(np.abs(c.zen).max()) * 2.0 ** -11)


def test_subset_loading_gives_identical_values(tmp_path):
    path = write_synthetic_dataset(tmp_path / "s.dat", visibilities=(20, 40, 80, 131.8), albedos=(0, 0.5, 1),
                                   n_channels=8, rank=3, n_sun=10, n_zen=10, n_emph=6)
    full = skymodel.load_dataset(path)
    dirs = skymodel.direction_from_zenith([0, 30, 60, 85], [0, 90, 180, 270])
    ref = skymodel.sky_radiance(full, dirs, 25.0, 160.0, 55.0, 0.7)
    part = skymodel.load_dataset(path, visibility=55.0, albedo=0.7)
    assert part.visibilities.tolist() == [40, 80] and part.albedos.tolist() == [0.5, 1.0]
    np.testing.assert_array_equal(skymodel.sky_radiance(part, dirs, 25.0, 160.0, 55.0, 0.7), ref)
    exact = skymodel.load_dataset(path, visibility=80.0)
    assert exact.visibilities.tolist() == [80]
    rng = skymodel.load_dataset(path, visibility=(30, 90))
    assert rng.visibilities.tolist() == [20, 40, 80, 131.8][0:4]
    ch = skymodel.load_dataset(path, wavelength_range=(330, 420))
    assert ch.channel_index.tolist() == [1, 2, 3]
    np.testing.assert_array_equal(skymodel.sky_radiance(ch, dirs, 25.0, 160.0, 55.0, 0.7), ref[:, 1:4])
    ch.load()
    full.load()
    assert 0 < ch.resident_bytes < full.resident_bytes
    assert ch.resident_bytes == ch.selection_bytes()
    by_index = skymodel.load_dataset(path, channels=[0, 7])
    np.testing.assert_array_equal(skymodel.sky_radiance(by_index, dirs, 25.0, 160.0, 55.0, 0.7, wavelengths=[579.0]),
                                  ref[:, 7:8])
    with pytest.raises(ValueError, match="not loaded"):
        skymodel.sky_radiance(by_index, dirs, 25.0, 160.0, 55.0, 0.7, wavelengths=[400.0])


def test_open_is_lazy(small):
    m = skymodel.load_dataset(small)
    assert m.resident_bytes == 0
    assert "synthetic" in m.describe()
    m.load()
    assert m.resident_bytes > 0


# ---------------------------------------------------------------- bad files
def test_missing_empty_and_directory(tmp_path):
    with pytest.raises(DatasetError, match="no such file"):
        skymodel.load_dataset(tmp_path / "nope.dat")
    (tmp_path / "empty.dat").write_bytes(b"")
    with pytest.raises(DatasetError, match="empty"):
        skymodel.load_dataset(tmp_path / "empty.dat")
    with pytest.raises(DatasetError, match="directory"):
        skymodel.load_dataset(tmp_path)


def test_truncation_names_field_and_offset(small, tmp_path):
    b = small.read_bytes()
    cases = {10: "visibilities", 102: "rankRad", 2300: "nVisT", 2400: "U", 2440: "V", 4000: "polarisation"}
    for cut, field in cases.items():
        p = tmp_path / f"cut{cut}.dat"
        p.write_bytes(b[:cut])
        with pytest.raises(DatasetError) as e:
            skymodel.load_dataset(p).load()
        assert field in e.value.field and e.value.offset is not None, (cut, e.value)
    p = tmp_path / "cut_radiance.dat"
    p.write_bytes(b[:1000])
    with pytest.raises(DatasetError, match="radiance coefficients.*truncated"):
        skymodel.load_dataset(p)


def test_count_inflation_does_not_allocate(small, tmp_path):
    b = bytearray(small.read_bytes())
    for off in (0, 80, 100, 104, 2292, 2304, 2452):  # nVis, channels, rankRad, nSun, dDim, rankT, rankPol
        bad = bytearray(b)
        struct.pack_into("<i", bad, off, 2_000_000_000)
        p = tmp_path / "inflated.dat"
        p.write_bytes(bytes(bad))
        with pytest.raises(DatasetError) as e:
            skymodel.load_dataset(p).load()
        assert any(w in str(e.value) for w in ("truncated", "exceeds", "beyond the model's spectral range")), str(e.value)
        assert e.value.field and e.value.offset is not None


def test_hostile_values(small, tmp_path):
    b = bytearray(small.read_bytes())
    cases = [
        (lambda x: struct.pack_into("<i", x, 0, 0), "must be >= 1"),              # zero visibilities
        (lambda x: struct.pack_into("<i", x, 104, 1), "must be >= 2"),            # one sun break
        (lambda x: struct.pack_into("<d", x, 4, float("nan")), "non-finite"),     # NaN visibility
        (lambda x: struct.pack_into("<d", x, 12, 1.0), "ascending|> 0"),         # descending grid
        (lambda x: struct.pack_into("<d", x, 92, -40.0), "channelWidth"),         # negative width
        (lambda x: x.extend(b"\0\0"), "trailing"),                                # trailing garbage
    ]
    for mutate, msg in cases:
        bad = bytearray(b)
        mutate(bad)
        p = tmp_path / "hostile.dat"
        p.write_bytes(bytes(bad))
        with pytest.raises(DatasetError, match=msg):
            skymodel.load_dataset(p).load()
    # a zero zenith scale (division) and an infinite half: found on decode, with the block's offset
    bad = bytearray(b)
    struct.pack_into("<d", bad, 276 + 14, 0.0)  # first block: sun[7] halves (14 B), then zenithScale
    p = tmp_path / "scale.dat"
    p.write_bytes(bytes(bad))
    with pytest.raises(DatasetError, match="zenithScale") as e:
        skymodel.load_dataset(p).load()
    assert e.value.offset == 276


def test_hostile_knots_and_channels_rejected_at_open(small, tmp_path):
    """Files that passed validation before and then divided by zero in the table path, gave NaN or a late
    ValueError (issue 10): rejected at open, naming the field; no RuntimeWarning escapes (warnings are
    errors in this suite)."""
    b = bytearray(small.read_bytes())
    sun0 = struct.unpack_from("<d", b, 108)[0]  # sunBreaks[0] at 108 (count at 104)
    cases = [
        (lambda x: struct.pack_into("<d", x, 116, sun0 + 1e-300), "sunBreaks", "apart"),   # near-equal knots
        (lambda x: struct.pack_into("<d", x, 116, np.nextafter(sun0, 1.0)), "sunBreaks", "apart"),
        (lambda x: struct.pack_into("<d", x, 168 + 8, 1e-12), "zenithBreaks", "apart|ascending"),
        (lambda x: struct.pack_into("<d", x, 228 + 8 * 5, 7.0), "emphBreaks", "outside the valid range"),
        (lambda x: struct.pack_into("<d", x, 92, 1e-30), "channelWidth", r"\[1, 2220\] nm"),      # tiny width
        (lambda x: struct.pack_into("<d", x, 84, 100.0), "channelStart", "280"),                 # below 280 nm
        (lambda x: struct.pack_into("<d", x, 84, 2490.0), "channels", "2500"),                   # beyond 2500 nm
        (lambda x: struct.pack_into("<d", x, 92, 1500.0), "channels", "beyond"),
    ]
    for mutate, field, msg in cases:
        bad = bytearray(b)
        mutate(bad)
        p = tmp_path / "hostile.dat"
        p.write_bytes(bytes(bad))
        with pytest.raises(DatasetError, match=msg) as e:
            skymodel.load_dataset(p)
        assert e.value.field == field and e.value.offset is not None, e.value


@pytest.mark.parametrize("offset, field", [(2312, "altitudesT"), (2316, "visibilitiesT")])
def test_signalling_nan_grid_rejected_without_warning(small, tmp_path, offset, field):
    """A float32 signalling NaN (bits 0x7f800001) in a transmittance grid: widening it to float64 raised
    the invalid-operation flag, so numpy's RuntimeWarning escaped before the DatasetError (found by
    tools/fuzz_decoder.py, case 7087 of seed 8)."""
    b = bytearray(small.read_bytes())
    struct.pack_into("<I", b, offset, 0x7F800001)
    p = tmp_path / "snan.dat"
    p.write_bytes(bytes(b))
    with pytest.raises(DatasetError, match="non-finite") as e:
        skymodel.load_dataset(p)
    assert e.value.field == field and e.value.offset == offset


def test_overflowing_coefficients_raise_without_warnings(small, tmp_path):
    """A half float of inf and a tiny zenith scale that overflows float32 on division: a DatasetError at
    the block's offset, not thousands of RuntimeWarnings first."""
    b = bytearray(small.read_bytes())
    bad = bytearray(b)
    struct.pack_into("<d", bad, 276 + 14, 1e-300)  # zenithScale of the first block: zen / scale overflows
    p = tmp_path / "overflow.dat"
    p.write_bytes(bytes(bad))
    with pytest.raises(DatasetError, match="zenStored") as e:
        skymodel.load_dataset(p).load()
    assert e.value.offset == 276
    bad = bytearray(b)
    struct.pack_into("<H", bad, 276 + 2, 0x7C00)  # sun[1] of the first block = +inf
    p.write_bytes(bytes(bad))
    with pytest.raises(DatasetError, match="sunStored"):
        skymodel.load_dataset(p).load()


@pytest.mark.parametrize("content, field, msg", [
    ("{not json", None, "unreadable JSON"),
    ("[1, 2]", None, "JSON object"),
    ('{"extraterrestrial": []}', "extraterrestrial", "expected an object"),
    ('{"extraterrestrial": {"wavelength": [], "irradiance": []}}', "extraterrestrial.wavelength", "at least 2"),
    ('{"extraterrestrial": {"wavelength": [280, 2500], "irradiance": [1, NaN]}}', "extraterrestrial.irradiance",
     "non-finite"),
    ('{"extraterrestrial": {"wavelength": [280, 2500], "irradiance": [1, -1]}}', "extraterrestrial.irradiance",
     ">= 0"),
    ('{"extraterrestrial": {"wavelength": [280, 2500], "irradiance": [0, 0]}}', "extraterrestrial.irradiance",
     "not all 0"),
    ('{"extraterrestrial": {"wavelength": [300, 2500], "irradiance": [1, 1]}}', "extraterrestrial.wavelength",
     "does not cover"),
    ('{"extraterrestrial": {"wavelength": [280, 900, 800, 2500], "irradiance": [1, 1, 1, 1]}}',
     "extraterrestrial.wavelength", "ascending"),
    ('{"extraterrestrial": {"wavelength": [280, 2500], "irradiance": [1, 1, 1]}}', "extraterrestrial", "2 wavelengths"),
    ('{"extraterrestrial": {"wavelength": ["a", 2500], "irradiance": [1, 1]}}', "extraterrestrial.wavelength",
     "numbers"),
])
def test_sidecar_is_validated(small, tmp_path, content, field, msg):
    p = tmp_path / "side.dat"
    p.write_bytes(small.read_bytes())
    side = tmp_path / "side.dat.json"
    side.write_text(content)
    with pytest.raises(DatasetError, match=msg) as e:
        skymodel.load_dataset(p)
    assert e.value.path == str(side) and e.value.field == field


def test_a_valid_sidecar_spectrum_is_used(small, tmp_path):
    p = tmp_path / "side.dat"
    p.write_bytes(small.read_bytes())
    (tmp_path / "side.dat.json").write_text('{"extraterrestrial": {"wavelength": [280, 2500], "irradiance": [2, 2]}}')
    m = skymodel.load_dataset(p)
    dni = skymodel.solar_direct_normal(m, 60.0, 180.0, 40.0, 0.5)
    t = skymodel.transmittance(m, skymodel.sun_direction(60.0, 180.0)[None], 60.0, 180.0, 40.0, 0.5)[0]
    np.testing.assert_allclose(dni, 2.0 * t, rtol=1e-12)  # the flat 2 W m-2 nm-1 spectrum times T


def test_chunked_decoding_equals_whole_file_decoding(tmp_path, monkeypatch):
    """Decoding in chunks (here forced to one configuration row at a time) gives the same arrays as
    decoding the whole selection at once with numpy (the reference's float32(double(half)/scale))."""
    import widesky.skymodel.dataset as ds

    path = write_synthetic_dataset(tmp_path / "c.dat", visibilities=(20, 40, 131.8), albedos=(0, 0.5, 1),
                                   n_channels=6, rank=3, n_sun=9, n_zen=8, n_emph=5, polarisation=True, seed=4)
    m = skymodel.load_dataset(path, visibility=(30, 50), albedo=0.7, channels=[1, 2, 4])
    lay = m._layout
    ne = len(m.file_elevations)
    assert m.visibilities.tolist() == [20, 40, 131.8] and m.albedos.tolist() == [0.5, 1.0]
    blk = np.frombuffer(path.read_bytes(), lay.block_dtype, 3 * 3 * ne * 6,
                        lay.rad_offset).reshape(3, 3, 1, ne, 6)[:, 1:3][..., [1, 2, 4]]
    monkeypatch.setattr(ds, "DECODE_CHUNK_BYTES", 1)
    sun, zen, emph = m.radiance_coefficients()
    np.testing.assert_array_equal(sun, blk["r"]["sun"].astype(np.float32))
    np.testing.assert_array_equal(zen, (blk["r"]["zen"].astype(np.float64)
                                        / blk["r"]["scale"][..., None]).astype(np.float32))
    np.testing.assert_array_equal(emph, blk["emph"].astype(np.float32))
    assert sun.dtype == zen.dtype == emph.dtype == np.float32
    assert m.resident_bytes == sun.nbytes + zen.nbytes + emph.nbytes


FUZZER = Path(__file__).resolve().parents[1] / "tools" / "fuzz_decoder.py"


def test_seeded_mutations_never_crash(tmp_path):
    """A short run of the decoder's mutation fuzzer (tools/fuzz_decoder.py; its long runs are reported in
    docs/skymodel.md, "Hostile files"): truncated, bit-flipped, count-inflated, resized and scrambled files,
    near-equal knots, hostile channel widths and starts, header doubles, transmittance floats, zenith scales
    and half floats, from seeds with and without polarisation. Every file is either rejected with
    DatasetError (naming field and offset) or ValueError, with no warning first, or loads and evaluates, its
    table path agreeing with its direct path; the worker process never crashes (a segfault or sanitizer abort
    shows as a finding), hangs or allocates without bound."""
    n = 600
    out = tmp_path / "fuzz.json"
    proc = subprocess.run([sys.executable, str(FUZZER), "--files", str(n), "--seed", "2026", "--work",
                           str(tmp_path / "work"), "--findings", str(tmp_path / "findings"), "--json", str(out)],
                          capture_output=True, text=True, timeout=600,
                          cwd=tmp_path)  # not the repository root, so the installed package is imported
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    s = json.loads(out.read_text())
    assert s["files"] == n and s["n_findings"] == 0, s["findings"]
    o = s["outcomes"]
    assert o["rejected"] > n // 4 and o["loaded"] > n // 10  # both outcomes are exercised
    assert s["distinct_exceptions"] > 40


def test_single_sky_state_decodes_only_what_it_uses(tmp_path):
    """visibility, albedo and elevation given: only the bracketing grid points are decoded (2 x 2 x 2
    configurations per channel here) and the values equal those of the whole file."""
    path = write_synthetic_dataset(tmp_path / "s.dat", visibilities=(20, 40, 80, 131.8), albedos=(0, 0.5, 1),
                                   n_channels=5, rank=2, n_sun=8, n_zen=8, n_emph=6, polarisation=True, seed=5)
    full = skymodel.load_dataset(path).load()
    one = skymodel.load_dataset(path, visibility=55.0, albedo=0.7, elevation=12.5).load()
    assert one.visibilities.tolist() == [40, 80] and one.albedos.tolist() == [0.5, 1.0]
    lo, hi = one.elevations
    assert lo <= 12.5 <= hi and len(one.elevations) == 2
    dirs = skymodel.direction_from_zenith([0, 30, 60, 85, 100], [0, 90, 180, 270, 45])
    for f in (skymodel.sky_radiance, skymodel.polarisation, skymodel.transmittance):
        np.testing.assert_array_equal(f(one, dirs, 12.5, 160.0, 55.0, 0.7), f(full, dirs, 12.5, 160.0, 55.0, 0.7))
    sun_full = full.radiance_coefficients()[0]
    assert one.radiance_coefficients()[0].nbytes * len(full.file_elevations) * 4 * 3 == sun_full.nbytes * 2 * 2 * 2
    assert one.resident_bytes == one.selection_bytes() < full.resident_bytes / 4
