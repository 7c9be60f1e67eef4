"""Renderer, colour and the ``widesky sky`` command line."""

import re

import dataclasses

import numpy as np
import pytest

from widesky import skymodel
from widesky.skymodel.synthetic import write_synthetic_dataset
from widesky.cli import main
from widesky.skymodel.colour import channel_xyz_weights, cie1931_xyz, srgb_encode
from widesky.skymodel.render import fisheye_directions, render_sky, write_exr, write_png

# The channel-name pattern of the spectral OpenEXR layout (Fichet, Pacanowski, Wilkie 2021, JCGT 10(3),
# section 3: Stokes component, wavelength with a comma as decimal mark, unit)
SPECTRAL_CHANNEL = re.compile(r"^S([0-3])\.(\d*,?\d*([Ee][+-]?\d+)?)(Y|Z|E|P|T|G|M|k|h|da|d|c|m|u|n|p|f|a|z|y)?(m|Hz)$")


def test_stereographic_mapping():
    d, mask = fisheye_directions(201)
    c = d[100, 100]
    np.testing.assert_allclose(c, [0, 0, 1], atol=1e-12)  # centre looks at the zenith
    # stereographic: a pixel at radius rho looks 2 atan(rho) from the axis
    for col in (150, 180, 200):
        rho = ((col + 0.5) / 201 * 2 - 1)
        theta = np.degrees(np.arccos(d[100, col, 2]))
        assert theta == pytest.approx(np.degrees(2 * np.arctan(rho)), abs=1e-9)
    assert d[0, 100, 1] > 0.99  # top of the image: north, at the horizon
    assert d[100, 0, 0] > 0.99  # left: east (the sky seen from below)
    assert not mask[0, 0] and mask.mean() == pytest.approx(np.pi / 4, abs=0.01)
    s, m2 = fisheye_directions(101, view="side", view_azimuth=90.0)
    np.testing.assert_allclose(s[50, 50], [1, 0, 0], atol=1e-12)  # looking east
    assert s[0, 50, 2] > 0.99  # zenith at the top


def test_cie1931_fit_against_tabulated_values():
    """CIE 1931 2-degree observer, tabulated (CIE 015:2018 table): y(555) = 1.0000, x(600) = 1.0622,
    z(450) = 1.7721, x(450) = 0.3362; the Wyman-Sloan-Shirley fit is within 3 % of these peaks."""
    xyz = cie1931_xyz([555.0, 600.0, 450.0])
    assert xyz[0, 1] == pytest.approx(1.0, rel=0.03)
    assert xyz[1, 0] == pytest.approx(1.0622, rel=0.03)
    assert xyz[2, 2] == pytest.approx(1.7721, rel=0.03)
    assert xyz[2, 0] == pytest.approx(0.3362, rel=0.05)
    # the integral of y over the visible is 106.86 nm (CIE, 1 nm table 360-830 nm)
    w = channel_xyz_weights(np.arange(360.0, 830.0, 40.0), 40.0)
    assert w[:, 1].sum() == pytest.approx(106.86, rel=0.01)
    assert float(srgb_encode(0.0031308)) == pytest.approx(0.04045, rel=1e-3)
    assert float(srgb_encode(2.0)) == pytest.approx(1.0, abs=1e-12)


def test_render_and_files(tmp_path):
    model = skymodel.load_dataset()
    r = render_sky(model, sun_elevation=25.0, sun_azimuth=180.0, visibility=40.0, albedo=0.2, resolution=64)
    assert r.values.shape == (64, 64, model.n_channels) and r.values.dtype == np.float32
    assert np.all(r.values[~r.mask] == 0) and np.all(r.values[r.mask] >= 0)
    # the render equals a direct evaluation of the same directions
    d, mask = fisheye_directions(64)
    direct = skymodel.sky_radiance(model, d[mask][:50], 25.0, 180.0, 40.0, 0.2)
    np.testing.assert_allclose(r.values[mask][:50], direct, rtol=1e-6)
    png = write_png(tmp_path / "a.png", r)
    from PIL import Image

    img = np.asarray(Image.open(png))
    assert img.shape == (64, 64, 3) and img[r.mask].max() > 100 and img[~r.mask].max() == 0
    exr = write_exr(tmp_path / "a.exr", r)
    import OpenEXR

    with OpenEXR.File(str(exr), separate_channels=True) as f:
        header = dict(f.header())
        channels = {k: v.pixels.copy() for k, v in f.channels().items()}
    names = [n for n in channels if n.startswith("S")]
    assert len(names) == model.n_channels
    assert all(SPECTRAL_CHANNEL.match(n) for n in names)
    assert header["spectralLayoutVersion"] == "1.0" and header["emissiveUnits"] == "W.m^-2.sr^-1"
    assert {"R", "G", "B"} <= set(channels)
    k = int(np.argmin(np.abs(model.wavelengths - 550)))
    wl_text = f"{model.wavelengths[k]:.6f}".replace(".", ",")
    # half floats by default (the values fit their range): exactly numpy's rounding, within the stated error
    assert header["widesky.pixelType"] == "half" and "4.9e-4" in header["widesky.pixelError"]
    got = channels[f"S0.{wl_text}nm"]
    np.testing.assert_array_equal(got, r.values[..., k].astype(np.float16))
    v = r.values[..., k]
    assert np.all(np.abs(got.astype(np.float32) - v) <= np.maximum(2.0 ** -11 * np.abs(v), 3.0e-8))
    exact = write_exr(tmp_path / "f.exr", r, pixel_type="float", compression="zip")
    with OpenEXR.File(str(exact), separate_channels=True) as f:
        np.testing.assert_array_equal(f.channels()[f"S0.{wl_text}nm"].pixels, r.values[..., k])
        assert dict(f.header())["widesky.pixelType"] == "float"
    # a value beyond the half range makes "auto" keep 32-bit floats
    big = dataclasses.replace(r, values=r.values * np.float32(1e5))
    with OpenEXR.File(str(write_exr(tmp_path / "big.exr", big)), separate_channels=True) as f:
        assert dict(f.header())["widesky.pixelType"] == "float"


def test_colour_and_display_kernels():
    """The one-pass colour kernel equals the CIE 1931 weighting followed by the IEC 61966-2-1 matrix
    (float64 reference, float32 accumulation: rtol 1e-5 of the pixel's magnitude), and the one-pass 8-bit
    encoder equals the sRGB transfer function of the scaled, clipped value to one 8-bit level (the 16-bit
    table's rounding); NaN, negative and over-range values give 0, 0 and 255."""
    from widesky.skymodel.colour import xyz_to_linear_srgb
    from widesky.skymodel.render import _encode8

    model = skymodel.load_dataset()
    r = render_sky(model, sun_elevation=12.0, sun_azimuth=200.0, visibility=30.0, albedo=0.2, resolution=40)
    w = channel_xyz_weights(r.channel_lower, r.channel_width)
    xyz = r.values.astype(float) @ w
    want = np.concatenate([xyz_to_linear_srgb(xyz), xyz[..., 1:2]], axis=-1)
    got = r._rgby
    assert got.shape == (40, 40, 4) and got.dtype == np.float32
    scale = np.abs(want).max(axis=-1, keepdims=True)
    assert np.all(np.abs(got - want) <= 1e-5 * scale + 1e-30)
    np.testing.assert_array_equal(r.rgb_linear(), got[..., :3])
    v = np.array([[np.nan, -1.0, 0.0, 1e-4, 0.02, 0.5, 0.999, 2.0]], np.float32)
    enc = _encode8(v[..., None], 1.0, 1)[..., 0]
    ref = np.round(srgb_encode(np.clip(np.nan_to_num(v.astype(float), nan=0.0), 0, 1)) * 255)
    assert np.abs(enc.astype(int) - ref).max() <= 1 and enc[0, 0] == 0 and enc[0, 1] == 0 and enc[0, -1] == 255
    rng = np.random.default_rng(5)
    lin = rng.random((500, 4), np.float32) * np.float32(1.3)
    enc = _encode8(lin, 0.8, 3)
    ref = np.round(srgb_encode(np.clip(lin[:, :3].astype(float) * 0.8, 0, 1)) * 255)
    assert enc.shape == (500, 3) and np.abs(enc.astype(int) - ref).max() <= 1


@pytest.mark.parametrize("shape", [(1, 1, 3), (5, 7, 3), (64, 33, 3)])
def test_png_writer_round_trip(tmp_path, shape):
    """widesky's PNG writer (skymodel.pngfile) read back with Pillow: the same pixels, exactly."""
    from PIL import Image

    from widesky.skymodel.pngfile import write_rgb_png

    img = np.random.default_rng(sum(shape)).integers(0, 256, shape, dtype=np.uint8)
    img[: shape[0] // 2] = img[0]  # repeated rows: the Up filter's zero differences
    with open(tmp_path / "a.png", "wb") as f:
        write_rgb_png(f, img)
    back = Image.open(tmp_path / "a.png")
    assert back.mode == "RGB"
    np.testing.assert_array_equal(np.asarray(back), img)
    with open(tmp_path / "b.png", "wb") as f, pytest.raises(ValueError, match="expected"):
        write_rgb_png(f, img[..., :2])


def test_percentile99_equals_numpy():
    from widesky.skymodel.render import _percentile99

    rng = np.random.default_rng(2)
    for n in (1, 2, 100, 12345):
        v = rng.lognormal(size=n).astype(np.float32)
        assert _percentile99(v) == pytest.approx(float(np.percentile(v, 99.0)), rel=1e-6)


def test_render_quantities(tmp_path):
    model = skymodel.load_dataset()
    kw = dict(sun_elevation=40.0, sun_azimuth=120.0, visibility=60.0, albedo=0.5, resolution=48)
    t = render_sky(model, quantity="transmittance", wavelengths=[550.0], **kw)
    assert np.all((t.values[t.mask] >= 0) & (t.values[t.mask] <= 1))
    # the default dataset has no polarisation section (scalar solver): render polarisation from a synthetic one
    pmodel = model if model.has_polarisation else skymodel.load_dataset(write_synthetic_dataset(
        tmp_path / "pol.dat", n_channels=8, rank=2, n_sun=8, n_zen=8, n_emph=6, polarisation=True, seed=1))
    p = render_sky(pmodel, quantity="polarisation", channels=[5], **kw)
    assert np.isfinite(p.values).all()
    png = write_png(tmp_path / "pol.png", p)
    assert png.stat().st_size > 0
    from widesky.skymodel.render import polarisation_colours
    c = polarisation_colours(np.array([-1.0, -0.5, 0.0, 0.5, 1.0, 3.0, np.nan])).astype(int)
    assert c[2].tolist() == [221, 221, 221] and c[6].tolist() == c[2].tolist()      # 0 (and NaN): neutral grey
    assert c[4, 0] > c[4, 2] and c[0, 2] > c[0, 0]                                   # +1 red, -1 blue
    assert c[5].tolist() == c[4].tolist()                                            # clipped at 1
    assert 0 < abs(c[3] - c[2]).sum() < abs(c[4] - c[2]).sum()                        # monotone in |p|
    s = render_sky(model, quantity="sun", **{**kw, "resolution": 1200})  # pixels of about 0.16 deg here
    hit = s.values[..., 10] > 0
    assert 1 <= hit.sum() < 50  # a 0.53 deg disc covers a handful of pixels at this resolution
    with pytest.raises(ValueError, match="quantity"):
        render_sky(model, quantity="nonsense", **kw)


def test_side_view_below_horizon(tmp_path):
    """A ground-level dataset holds no sky below the horizon: 'auto' leaves those pixels dark, 'model'
    evaluates the model there; a dataset with several altitudes keeps the model by default."""
    model = skymodel.load_dataset()
    kw = dict(sun_elevation=10.0, sun_azimuth=180.0, visibility=40.0, albedo=0.2, resolution=32, view="side")
    d, disc = fisheye_directions(32, "side")
    below = disc & (d[..., 2] < 0)
    r = render_sky(model, **kw)
    assert r.meta["below_horizon"] == "dark"
    assert np.all(r.values[below] == 0) and not np.any(r.mask[below])
    assert np.all(r.values[disc & (d[..., 2] > 0)].sum(axis=-1) > 0)
    m = render_sky(model, below_horizon="model", **kw)
    assert np.all(m.values[below].sum(axis=-1) > 0)
    multi = skymodel.load_dataset(write_synthetic_dataset(tmp_path / "alt.dat", n_channels=4, rank=2, n_sun=8,
                                                          n_zen=8, n_emph=6, altitudes=(0.0, 1000.0), seed=2))
    assert render_sky(multi, **kw).meta["below_horizon"] == "model"
    with pytest.raises(ValueError, match="below_horizon"):
        render_sky(model, below_horizon="grey", **kw)


def test_cli_render_and_info(tmp_path, capsys):
    out = tmp_path / "sky.png"
    assert main(["sky", "render", "--resolution", "40", "--elevation", "12", "--output", str(out)]) == 0
    assert out.exists() and out.with_suffix(".exr").exists()
    captured = capsys.readouterr()
    # the default dataset is physical (generated by `widesky dataset build`): no synthetic note
    assert ("SYNTHETIC" in captured.err) == skymodel.load_dataset().is_synthetic and "wrote" in captured.out
    assert main(["sky", "render", "--resolution", "32", "--channel", "550nm", "--quantity", "transmittance",
                 "--view", "side", "--output", str(tmp_path / "t.exr")]) == 0
    assert main(["sky", "info", "--load"]) == 0
    info = capsys.readouterr().out
    assert "55 x 40 nm from 280 nm" in info and "resident" in info
    # errors are reported, not raised
    assert main(["sky", "render", "--channel", "3000nm", "--output", str(tmp_path / "x.png")]) == 2
    assert "outside the dataset's range" in capsys.readouterr().err
    assert main(["sky", "info", str(tmp_path / "missing.dat")]) == 2
