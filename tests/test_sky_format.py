"""The dataset format: layout, decoding, selection, and bad files.

Layout reference: shared/spec/psm-dataset-format.md section 6 gives the byte offsets of a small synthetic
file (2 vis x 2 albedo x 1 alt x 3 elev x 2 channels, rank 2, 7/7/6 knots, transmittance 4x3 rank 2,
polarisation rank 2 with 5/5 knots); our writer must produce exactly that layout.
"""

import struct
import subprocess
import sys

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


MUTATION_SCRIPT = r"""
import sys, struct, warnings
import numpy as np
from widesky import skymodel
from widesky.skymodel import DatasetError
src, work, seed, n = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
base = open(src, "rb").read()
rng = np.random.default_rng(seed)
dirs = skymodel.direction_from_zenith([0, 45, 89, 120], [0, 90, 180, 270])
counts = {"rejected": 0, "loaded": 0}
warnings.simplefilter("ignore", skymodel.SkyStateClampedWarning)
warnings.simplefilter("error", RuntimeWarning)   # a numpy warning reaching the user is a failure
KNOTS = [(104, 7), (164, 7), (224, 6)]            # (count offset, n) of sunBreaks, zenithBreaks, emphBreaks
F64 = [4, 12, 24, 32, 44, 56, 64, 72, 84, 92]     # header doubles: grids, channelStart, channelWidth
for i in range(n):
    b = bytearray(base)
    kind = i % 7
    if kind == 0:                          # truncation anywhere
        b = b[: int(rng.integers(0, len(b)))]
    elif kind == 1:                        # bit flips
        for _ in range(int(rng.integers(1, 6))):
            pos = int(rng.integers(0, len(b)))
            b[pos] ^= 1 << int(rng.integers(0, 8))
    elif kind == 2:                        # an i32 field set to a hostile count
        off = int(rng.choice([0, 20, 40, 52, 80, 100, 104, 164, 224, 2292, 2296, 2300, 2304, 2308, 2452, 2456, 2500]))
        struct.pack_into("<i", b, off, int(rng.choice([0, -1, 1, 2, 3, 255, 65536, 2**31 - 1])))
    elif kind == 3:                        # random bytes over a stretch
        pos = int(rng.integers(0, len(b) - 8))
        b[pos:pos + 8] = rng.integers(0, 256, 8, dtype=np.uint8).tobytes()
    elif kind == 4:                        # a knot moved almost onto its neighbour (still ascending)
        cnt, nk = KNOTS[int(rng.integers(0, 3))]
        j = int(rng.integers(0, nk - 1))
        lo = struct.unpack_from("<d", b, cnt + 4 + 8 * j)[0]
        step = float(rng.choice([0.0, 10.0 ** -rng.uniform(6, 300)]))
        struct.pack_into("<d", b, cnt + 4 + 8 * (j + 1), np.nextafter(lo, 9.0) if step == 0 else lo + step)
    elif kind == 5:                        # channel width or start anywhere, tiny to huge
        off = int(rng.choice([84, 92]))
        struct.pack_into("<d", b, off, float(rng.choice([-1, 1])) * 10.0 ** rng.uniform(-30, 5))
    else:                                  # a header double set to a hostile value
        struct.pack_into("<d", b, int(rng.choice(F64)), float(rng.choice(
            [np.nan, np.inf, -np.inf, 1e308, -1e308, 5e-324, -0.0, 1e-30])))
    p = f"{work}/m{i % 16}.dat"
    open(p, "wb").write(bytes(b))
    try:
        m = skymodel.load_dataset(p)
        m.load()
        direct = skymodel.sky_radiance(m, dirs, 20.0, 180.0, 40.0, 0.5, method="direct")
        table = skymodel.sky_radiance(m, dirs, 20.0, 180.0, 40.0, 0.5, method="table")
        if np.isfinite(direct).all():      # the table path must agree wherever the direct path is finite
            scale = np.abs(direct).max(axis=-1, keepdims=True) + 1e-300
            if not (np.isfinite(table).all() and np.all(np.abs(table - direct) <= 1e-6 * scale)):
                print("MISMATCH", i, file=sys.stderr)
                sys.exit(3)
        skymodel.sky_radiance(m, dirs, -2.0, 180.0, 40.0, 0.5)
        skymodel.transmittance(m, dirs, 20.0, 180.0, 40.0, 0.5)
        if m.has_polarisation:
            skymodel.polarisation(m, dirs, 20.0, 180.0, 40.0, 0.5)
        counts["loaded"] += 1
    except (DatasetError, ValueError) as e:
        counts["rejected"] += 1
print(counts["rejected"], counts["loaded"])
"""


def test_seeded_mutations_never_crash(small, tmp_path):
    """Thousands of truncated, bit-flipped, count-inflated and scrambled files, near-equal knots, hostile
    channel widths and starts and hostile header doubles: every one is either rejected with
    DatasetError/ValueError, with no numpy RuntimeWarning first, or loads and evaluates, its table path
    agreeing with its direct path; the process never crashes (run in a subprocess so a segfault or abort
    would show as a failed exit code), hangs or exhausts memory."""
    n = 3000
    proc = subprocess.run([sys.executable, "-c", MUTATION_SCRIPT, str(small), str(tmp_path), "2026", str(n)],
                          capture_output=True, text=True, timeout=600,
                          cwd=tmp_path)  # not the repository root, so the installed package is imported
    assert proc.returncode == 0, proc.stderr[-3000:]
    rejected, loaded = (int(x) for x in proc.stdout.split())
    assert rejected + loaded == n
    assert rejected > n // 4 and loaded > 100  # both outcomes are exercised


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
