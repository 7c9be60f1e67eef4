"""widesky's own OpenEXR writer (skymodel.exrfile, the uncompressed and RLE cases), read back with the
OpenEXR library as the independent decoder.

Round trip: every channel of the file must equal the written values exactly, after numpy's rounding to
half (IEEE round to nearest even, as the format's half) or as float32 (NaN where NaN was written).
The images are built to exercise the encoder's cases: widths that are not a multiple of the 8-pixel
transposition blocks, runs longer than the 127-byte limit, runs of exactly 2 and 3 bytes, incompressible
noise (the chunk falls back to raw storage), zeros, subnormal halves, negative values, inf and NaN.
"""

import dataclasses

import numpy as np
import pytest

from widesky.skymodel.exrfile import NATIVE_COMPRESSIONS, write_scanline_exr

OpenEXR = pytest.importorskip("OpenEXR")
pytestmark = pytest.mark.skipif(not NATIVE_COMPRESSIONS, reason="widesky's encoder runs on little-endian hosts only")


def read_exr(path):
    with OpenEXR.File(str(path), separate_channels=True) as f:
        return dict(f.header()), {k: v.pixels.copy() for k, v in f.channels().items()}


def hard_image(h, w, c, seed=0):
    """(h, w, c) float32 with long runs, short runs, noise, zeros, subnormals and negative values."""
    rng = np.random.default_rng(seed)
    v = rng.lognormal(0.0, 2.0, (h, w, c)).astype(np.float32)  # noise over many binades
    v[:, : w // 3, 0] = 0.0                                     # long runs of zero bytes
    v[:, :, 1 % c] = 1.5                                        # constant channel: runs across the line
    v[::2, ::3, 2 % c] = -v[::2, ::3, 2 % c]                    # negative values
    v[:, 1::2, 3 % c] = 3e-6                                    # subnormal halves, alternating bytes
    v[0, :3, 4 % c] = 7.0                                       # a run of exactly 3 values
    return v


def names_for(c):
    planes = {f"S0.{300 + 40 * k},000000nm": k for k in range(c)}
    planes.update({n: c + i for i, n in enumerate("RGB")})
    names = sorted(planes)
    return names, [planes[n] for n in names]


@pytest.mark.parametrize("compression", ["none", "rle"])
@pytest.mark.parametrize("pixel_type", ["half", "float"])
@pytest.mark.parametrize("shape", [(7, 37, 11), (1, 1, 1), (3, 8, 8), (2, 300, 55)])
def test_round_trip_exact(tmp_path, compression, pixel_type, shape):
    h, w, c = shape
    v = hard_image(h, w, c)
    rgb = np.ascontiguousarray(hard_image(h, w, 3, seed=1)[..., ::-1])
    names, sources = names_for(c)
    p = tmp_path / "a.exr"
    strings = {"spectralLayoutVersion": "1.0", "widesky.a.rather.long.attribute.name.over.31": "x y"}
    with open(p, "wb") as f:
        assert write_scanline_exr(f, v, rgb, names, sources, pixel_type=pixel_type, compression=compression,
                                  strings=strings) == 0
    header, ch = read_exr(p)
    assert sorted(ch) == names
    assert header["spectralLayoutVersion"] == "1.0" and header["widesky.a.rather.long.attribute.name.over.31"] == "x y"
    assert header["compression"] == (OpenEXR.RLE_COMPRESSION if compression == "rle" else OpenEXR.NO_COMPRESSION)
    dt = np.float16 if pixel_type == "half" else np.float32
    planes = np.concatenate([v, rgb], axis=-1)
    for n, s in zip(names, sources):
        assert ch[n].dtype == dt and ch[n].shape == (h, w)
        np.testing.assert_array_equal(ch[n], planes[..., s].astype(dt), err_msg=n)


def test_rle_compresses_and_noise_falls_back_to_raw(tmp_path):
    """A piecewise-constant image shrinks under RLE; pure noise does not and is stored raw (still decodes)."""
    h, w, c = 4, 64, 5
    steps = np.repeat(np.linspace(0, 1, w // 16, dtype=np.float32), 16)
    smooth = np.broadcast_to(steps[None, :, None], (h, w, c)).copy()
    noise = np.random.default_rng(3).random((h, w, c), dtype=np.float32) + np.float32(1.0)
    names, sources = names_for(c)
    sizes = {}
    for label, v in (("smooth", smooth), ("noise", noise)):
        for comp in ("none", "rle"):
            p = tmp_path / f"{label}_{comp}.exr"
            with open(p, "wb") as f:
                write_scanline_exr(f, v, None, names, sources, pixel_type="float", compression=comp, strings={})
            sizes[label, comp] = p.stat().st_size
            _, ch = read_exr(p)
            for n, s in zip(names, sources):  # without rgb the preview repeats plane 0
                np.testing.assert_array_equal(ch[n], v[..., s if s < c else 0])
    assert sizes["smooth", "rle"] < 0.8 * sizes["smooth", "none"]
    assert sizes["noise", "rle"] == sizes["noise", "none"]  # every chunk kept raw


def test_nonfinite_values(tmp_path):
    v = hard_image(3, 20, 4)
    v[0, 0, 0], v[1, 5, 1], v[2, 19, 3], v[2, 2, 2] = np.nan, np.inf, -np.inf, 1e6  # 1e6: beyond half range
    names, sources = names_for(4)
    p = tmp_path / "f.exr"
    with open(p, "wb") as f:  # float keeps them all
        assert write_scanline_exr(f, v, None, names, sources, pixel_type="float", compression="rle", strings={}) == 0
    _, ch = read_exr(p)
    np.testing.assert_array_equal(ch[names[sources.index(0)]], v[..., 0])  # NaN equal to NaN
    with open(tmp_path / "h.exr", "wb") as f:  # half, refusing overflow: counts them, writes nothing
        bad = write_scanline_exr(f, v, None, names, sources, pixel_type="half", compression="rle", strings={},
                                 overflow_ok=False)
    # NaN, +inf and -inf each in one plane, 1e6 in plane 2; R G B repeat plane 0 (its NaN counted once)
    assert bad == 4 and (tmp_path / "h.exr").stat().st_size == 0


def test_write_exr_auto_falls_back_to_float(tmp_path):
    """write_exr(pixel_type="auto") writes half floats unless a value does not fit one (then float32); an
    explicit "half" stores inf there."""
    from widesky import skymodel
    from widesky.skymodel.render import render_sky, write_exr

    r = render_sky(skymodel.load_dataset(), resolution=24)
    big = dataclasses.replace(r, values=r.values.copy())
    big.values[12, 12, 3] = 7e4
    header, ch = read_exr(write_exr(tmp_path / "a.exr", big))
    assert header["widesky.pixelType"] == "float" and ch["R"].dtype == np.float32
    header, ch = read_exr(write_exr(tmp_path / "h.exr", big, pixel_type="half"))
    assert header["widesky.pixelType"] == "half"
    assert np.isinf(max(np.abs(ch[n]).max() for n in ch if n.startswith("S0.")))


def test_blocks_of_scanlines(tmp_path, monkeypatch):
    """Scanlines coded a block at a time into one reused buffer (here 3 lines per block, the last one
    short: 2 lines) give the same file as one block; a value beyond the half range in the last block,
    refused, leaves the file as it was before the image."""
    import widesky.skymodel.exrfile as exrfile

    h, w, c = 5, 19, 6
    v = hard_image(h, w, c, seed=7)
    names, sources = names_for(c)
    whole = tmp_path / "whole.exr"
    with open(whole, "wb") as f:
        write_scanline_exr(f, v, None, names, sources, pixel_type="half", compression="rle", strings={})
    line = len(names) * w * 2
    monkeypatch.setattr(exrfile, "BLOCK_BYTES", 3 * (8 + line + line // 127 + 1))
    blocks = tmp_path / "blocks.exr"
    with open(blocks, "wb") as f:
        write_scanline_exr(f, v, None, names, sources, pixel_type="half", compression="rle", strings={})
    assert blocks.read_bytes() == whole.read_bytes()
    _, ch = read_exr(blocks)
    for n, s in zip(names, sources):
        np.testing.assert_array_equal(ch[n], v[..., s if s < c else 0].astype(np.float16))
    v[4, 3, 2] = 1e5
    late = tmp_path / "late.exr"
    with open(late, "wb") as f:
        f.write(b"kept")
        assert write_scanline_exr(f, v, None, names, sources, pixel_type="half", compression="rle", strings={},
                                  overflow_ok=False) == 1
    assert late.read_bytes() == b"kept"


@pytest.mark.parametrize("pixel_type", ["half", "float"])
@pytest.mark.parametrize("compression", ["rle", "zip"])
def test_write_exr_preview_and_spectral_channels(tmp_path, pixel_type, compression):
    """write_exr of a render, by widesky's encoder (rle) and by the OpenEXR library (zip): the RGB preview
    equals the render's linear sRGB and every S0 channel its values, after rounding to the pixel type."""
    from widesky import skymodel
    from widesky.skymodel.render import render_sky, write_exr

    r = render_sky(skymodel.load_dataset(), sun_elevation=20.0, resolution=21)
    header, ch = read_exr(write_exr(tmp_path / "a.exr", r, pixel_type=pixel_type, compression=compression))
    dt = np.float16 if pixel_type == "half" else np.float32
    for i, c in enumerate("RGB"):
        np.testing.assert_array_equal(ch[c], r.rgb_linear()[..., i].astype(dt))
    for k, wl in enumerate(r.wavelengths):
        np.testing.assert_array_equal(ch["S0." + f"{wl:.6f}".replace(".", ",") + "nm"], r.values[..., k].astype(dt))
    assert header["widesky.pixelType"] == pixel_type
