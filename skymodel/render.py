"""Fisheye renders of the sky model: up-facing and side-facing, one channel or an sRGB composite.

Mapping: stereographic, as the reference renderer: a pixel at distance rho from the image centre (1 at
the rim) looks at an angle ``theta = 2 atan(rho)`` from the view axis, so the rim is 90 degrees off
axis. Up-facing images look at the zenith with north at the top and east on the LEFT (the sky seen from
below, as on a sky chart); side-facing images look horizontally towards ``view_azimuth`` with the zenith
at the top. Pixels outside the disc are 0.

Outputs: multi-channel OpenEXR in the spectral layout of Fichet, Pacanowski and Wilkie (2021), "An
OpenEXR Layout for Spectral Images", JCGT 10(3): one emissive channel ``S0.<wavelength>nm`` per band
centre (a comma as the decimal mark), the ``spectralLayoutVersion`` and ``emissiveUnits`` attributes,
and an RGB preview (``R``, ``G``, ``B``); and 8-bit PNG.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np
import OpenEXR

from . import _core

from .colour import channel_xyz_weights, srgb_encode, xyz_to_linear_srgb
from .dataset import SkyModel
from .evaluate import _evaluate_component, channel_indices, sun_radiance, transmittance
from .exrfile import BLOCK_BYTES, NATIVE_COMPRESSIONS, write_scanline_exr
from .pngfile import write_rgb_png

__all__ = ["QUANTITIES", "Render", "fisheye_directions", "fisheye_disc", "render_sky", "write_exr", "write_png", "render_memory_bytes",
           "check_render_memory"]

QUANTITIES = {
    "sky": ("sky radiance", "W m-2 sr-1 nm-1"),
    "sun": ("sun radiance", "W m-2 sr-1 nm-1"),
    "polarisation": ("degree of polarisation", "1"),
    "transmittance": ("transmittance to the top of the atmosphere", "1"),
}


def _view_basis(view, view_azimuth):
    """(axis, right, up) unit vectors of a view, east-north-up."""
    if view == "up":
        return np.array([[0, 0, 1.0], [-1.0, 0, 0], [0, 1.0, 0]])
    if view == "side":
        a = np.radians(view_azimuth)
        return np.array([[np.sin(a), np.cos(a), 0.0], [np.cos(a), -np.sin(a), 0.0], [0, 0, 1.0]])
    raise ValueError(f"view={view!r}: expected 'up' or 'side'")


def fisheye_disc(resolution, view="up", view_azimuth=180.0):
    """View directions of the pixels inside a stereographic fisheye's disc, and their flat pixel index.

    Parameters as :func:`fisheye_directions`.

    Returns
    -------
    directions : ndarray (m, 3)  east-north-up unit vectors, row by row
    pixels : ndarray (m,) int64  flat index (row * resolution + column) of each direction's pixel
    """
    n = int(resolution)
    if n < 1 or n > 20000:
        raise ValueError(f"resolution={resolution} outside [1, 20000] pixels")
    basis = np.ascontiguousarray(_view_basis(view, view_azimuth), dtype=np.float64)
    counts = np.empty(n, np.int64)
    _core.fisheye_counts(n, counts)
    start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    m = int(start[-1])
    dirs = np.empty((m, 3), np.float64)
    pix = np.empty(m, np.int64)
    _core.fisheye(n, basis.ravel(), start, dirs, pix)
    return dirs, pix


def fisheye_directions(resolution, view="up", view_azimuth=180.0):
    """View directions of a square stereographic fisheye image.

    Parameters
    ----------
    resolution : int
        Image width and height [pixels].
    view : {"up", "side"}
    view_azimuth : float
        Azimuth the side view looks towards [deg, clockwise from north].

    Returns
    -------
    directions : ndarray (resolution, resolution, 3)  east-north-up unit vectors (0 outside the disc)
    mask : ndarray (resolution, resolution) bool  pixels inside the disc
    """
    n = int(resolution)
    d, pix = fisheye_disc(resolution, view, view_azimuth)
    out = np.zeros((n * n, 3))
    out[pix] = d
    mask = np.zeros(n * n, bool)
    mask[pix] = True
    return out.reshape(n, n, 3), mask.reshape(n, n)


@dataclass
class Render:
    """A rendered fisheye: ``values`` (H, W, C) in the quantity's unit, per channel ``wavelengths``
    [nm] (band centres), the disc ``mask``, and the metadata of the render."""

    values: np.ndarray
    mask: np.ndarray
    wavelengths: np.ndarray
    channel_lower: np.ndarray
    channel_width: float
    quantity: str
    meta: dict = field(default_factory=dict)

    @cached_property
    def xyz(self):
        """CIE 1931 tristimulus values (H, W, 3) float32 of the channels, in the radiance unit integrated
        over wavelength [W m-2 sr-1] (computed once per render)."""
        w = channel_xyz_weights(self.channel_lower, self.channel_width).astype(np.float32)
        return self.values @ w

    @cached_property
    def _rgby(self):
        """(H, W, 4) float32: linear sRGB and CIE Y, one pass over the channels (computed once per render)."""
        w = channel_xyz_weights(self.channel_lower, self.channel_width)
        weights = np.ascontiguousarray(np.concatenate([xyz_to_linear_srgb(w), w[:, 1:2]], axis=1), np.float32)
        out = np.empty(self.values.shape[:-1] + (4,), np.float32)
        _core.colour(np.ascontiguousarray(self.values, np.float32), weights, out, 0)
        return out

    def rgb_linear(self):
        """Linear sRGB (H, W, 3) of the visible channels (CIE 1931 weighting of each band), in the
        radiance unit integrated over wavelength [W m-2 sr-1]."""
        return self._rgby[..., :3]

    def luminance_like(self):
        """CIE Y-weighted sum over the channels (H, W) [W m-2 sr-1]."""
        return self._rgby[..., 3]


def render_sky(model: SkyModel, *, sun_elevation=30.0, sun_azimuth=180.0, visibility=50.0, albedo=0.3,
               altitude=0.0, quantity="sky", channels=None, wavelengths=None, view="up", view_azimuth=180.0,
               resolution=512, threads=0, below_horizon="auto") -> Render:
    """Evaluate a fisheye image of a quantity.

    Parameters
    ----------
    model : SkyModel
    sun_elevation, sun_azimuth : float  [deg] (azimuth clockwise from north)
    visibility : float  [km]
    albedo : float  [1]
    altitude : float  [m]
    quantity : {"sky", "sun", "polarisation", "transmittance"}
    channels, wavelengths : optional
        Channel indices of the model or point wavelengths [nm]; default all loaded channels.
    view, view_azimuth, resolution : see :func:`fisheye_directions`.
    below_horizon : {"auto", "model", "dark"}
        Sky radiance and polarisation for directions below the horizon: "model" evaluates the model
        there; "dark" leaves those pixels 0 (and out of the exposure); "auto" (default) is "dark" for
        a ground-level dataset (a single altitude of 0 m, as widesky's default and the official
        ground-level dataset), whose fit holds no data below the horizon (the evaluator clamps the
        view zenith to the last knot, so the horizon's values would be repeated along circles about
        the sun), and "model" otherwise.

    Returns
    -------
    Render
    """
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity={quantity!r}: expected one of {sorted(QUANTITIES)}")
    if below_horizon not in ("auto", "model", "dark"):
        raise ValueError(f"below_horizon={below_horizon!r}: expected 'auto', 'model' or 'dark'")
    n = int(resolution)
    inside, pix = fisheye_disc(n, view, view_azimuth)
    if below_horizon == "auto":
        ground_only = len(model.altitudes) == 1 and float(model.altitudes[0]) == 0.0
        below_horizon = "dark" if ground_only else "model"
    if below_horizon == "dark" and quantity in ("sky", "polarisation") and inside.size and inside[:, 2].min() < 0:
        keep = inside[:, 2] >= 0.0
        inside, pix = np.ascontiguousarray(inside[keep]), pix[keep]
    chi = channel_indices(model, channels, wavelengths)
    state = (sun_elevation, sun_azimuth, visibility, albedo, altitude)
    img = np.zeros((n * n, chi.size), np.float32)  # pages outside the disc are never touched
    if quantity in ("sky", "polarisation"):  # the kernel writes each direction's row of the image directly
        _evaluate_component(model, "radiance" if quantity == "sky" else "polarisation", inside, *state, chi, None,
                            np.float32, img, "auto", threads, False, rows=pix)
    elif quantity == "sun":
        img[pix] = sun_radiance(model, inside, *state, channels=chi, threads=threads)
    else:
        img[pix] = transmittance(model, inside, *state, channels=chi, dtype=np.float32, threads=threads)
    mask = np.zeros(n * n, bool)
    mask[pix] = True
    img, mask = img.reshape(n, n, chi.size), mask.reshape(n, n)
    lower = model.channel_lower[chi]
    meta = dict(quantity=quantity, sun_elevation=sun_elevation, sun_azimuth=sun_azimuth, visibility=visibility,
                albedo=albedo, altitude=altitude, view=view, view_azimuth=view_azimuth,
                below_horizon=below_horizon,
                dataset=str(model.path), synthetic=model.is_synthetic)
    return Render(img, mask, lower + 0.5 * model.channel_width, lower, model.channel_width, quantity, meta)


def _render_memory_terms(n_channels, exr, exr_compression):
    """(bytes per pixel, fixed bytes) of a render and its files."""
    per_px = 4 * n_channels + 24 + 8 + 1 + 16 + 3 + 3
    if exr and exr_compression not in NATIVE_COMPRESSIONS:
        per_px += 4 * (n_channels + 3)
    return per_px, (BLOCK_BYTES if exr else 0)


def render_memory_bytes(resolution, n_channels, exr=True, exr_compression="rle") -> int:
    """Estimated peak memory of a render and its files [bytes]: the float32 image, the directions, pixel
    indices and mask, the linear sRGB + Y image, the 8-bit display image and the PNG's filtered rows,
    and (``exr``) the EXR's channel planes where the OpenEXR library writes it (``exr_compression`` other
    than "rle" and "none"; widesky's own encoder needs one 16 MB buffer)."""
    per_px, fixed = _render_memory_terms(n_channels, exr, exr_compression)
    return int(resolution) ** 2 * per_px + fixed


def available_memory_bytes() -> int | None:
    """Memory available to a new allocation [bytes]: Linux's MemAvailable, or None where unknown."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def check_render_memory(resolution, n_channels, exr=True, option="resolution", exr_compression="rle"):
    """Refuse (ValueError naming ``option``) a render whose estimated memory exceeds what is available."""
    need = render_memory_bytes(resolution, n_channels, exr, exr_compression)
    avail = available_memory_bytes()
    if avail is not None and need > avail:
        per_px, fixed = _render_memory_terms(n_channels, exr, exr_compression)
        most = int((max(avail - fixed, 0) / per_px) ** 0.5)
        raise ValueError(f"{option} {resolution}: the render of {n_channels} channel(s) needs about {need / 1e9:.1f} GB "
                         f"of memory, {avail / 1e9:.1f} GB are available; use at most {most} pixels here")
    return need


def _percentile99(v):
    """np.percentile(v, 99) (linear interpolation between the closest ranks) by a partial sort; numpy's
    own percentile imports numpy.ma (tens of milliseconds of a command's start-up)."""
    pos = 0.99 * (v.size - 1)
    lo = int(np.floor(pos))
    hi = min(lo + 1, v.size - 1)
    part = np.partition(v, [lo, hi])
    a, b = float(part[lo]), float(part[hi])
    return a + (b - a) * (pos - lo)


def _exposure_scale(values, mask, exposure):
    v = values[mask]
    v = v[np.isfinite(v) & (v > 0)]
    ref = _percentile99(v) if v.size else 1.0
    return (2.0 ** exposure) / (ref if ref > 0 else 1.0)


@lru_cache(maxsize=1)
def _srgb8_table():
    """sRGB-encoded 8-bit value of each of 65536 linear levels in [0, 1] (16-bit steps of 1.5e-5 keep the
    result within the rounding of a direct encoding)."""
    return np.round(srgb_encode(np.arange(65536) / 65535.0) * 255.0).astype(np.uint8)


def _encode8(pixels, scale, m):
    """The first ``m`` values of the last axis of ``pixels`` (..., k) times ``scale``, clipped to [0, 1]
    (NaN to 0), to 8-bit sRGB (..., m) through the 16-bit table, in one C pass."""
    pixels = np.ascontiguousarray(pixels, np.float32)
    out = np.empty(pixels.shape[:-1] + (m,), np.uint8)
    _core.encode8(pixels, m, float(scale), _srgb8_table(), out, 0)
    return out


# anchors of the diverging "cool to warm" map (Moreland 2009, "Diverging color maps for scientific visualization",
# ISVC; 8-bit sRGB at -1, 0, +1): blue, neutral grey, red
_DIVERGING = np.array([[59, 76, 192], [221, 221, 221], [180, 4, 38]], dtype=float)


def polarisation_colours(p):
    """(...,) signed degree of polarisation [1] -> (..., 3) uint8 sRGB on a diverging map: -1 blue, 0 light grey,
    +1 red (linear between the anchors; |p| > 1 and NaN clipped to the ends / 0)."""
    x = np.clip(np.nan_to_num(np.asarray(p, dtype=float)), -1.0, 1.0)
    lo = x < 0
    t = np.abs(x)[..., None]
    end = np.where(lo[..., None], _DIVERGING[0], _DIVERGING[2])
    return np.round(_DIVERGING[1] + t * (end - _DIVERGING[1])).astype(np.uint8)


def _display(r: Render, composite, exposure):
    """8-bit display image (H, W, 3)."""
    if composite:
        rgb = r.rgb_linear()
        if not rgb.max(initial=0.0) > 0:  # zero outside the disc: the disc's maximum
            raise ValueError("the selected channels have no visible (380-780 nm) contribution: use a single channel")
        out = _encode8(r._rgby, _exposure_scale(r.luminance_like(), r.mask, exposure), 3)
    else:
        v = r.values[..., 0]
        if r.quantity == "polarisation":
            out = polarisation_colours(v * 2.0 ** exposure)
        else:
            g = _encode8(r.values, _exposure_scale(v, r.mask, exposure), 1)[..., 0]
            out = np.repeat(g[..., None], 3, axis=-1)
    out[~r.mask] = 0
    return out


def write_png(path, r: Render, *, composite=None, exposure=0.0):
    """Write an 8-bit PNG: an sRGB composite of the visible channels (``composite`` True, the default when
    the render has more than one channel), else the single channel in grey. ``exposure`` [EV] scales
    relative to the 99th percentile of the disc (polarisation: the signed degree times ``2**exposure`` on a diverging
    map, :func:`polarisation_colours`: grey 0, red +1, blue -1)."""
    if composite is None:
        composite = r.values.shape[-1] > 1
    if not composite and r.values.shape[-1] != 1:
        hint = (f" ({r.quantity} has no colour composite: choose one with --channel, e.g. --channel 550nm)"
                if r.quantity in ("polarisation", "transmittance") else "")
        raise ValueError("a single-channel PNG needs a render of exactly one channel" + hint)
    image = _display(r, composite, exposure)
    with open(path, "wb") as f:
        write_rgb_png(f, image)
    return Path(path)


HALF_MAX = 65504.0
HALF_ERROR = ("half float: relative rounding error at most 2^-11 = 4.9e-4 for |value| >= 6.1e-5, absolute at most "
              "3.0e-8 below (subnormal halves); the dataset's own coefficients are half floats too")
EXR_COMPRESSIONS = ("none", "rle", "zips", "zip", "piz", "zstd")


def _exr_channels(r: Render):
    """The file's channel names, sorted as OpenEXR stores them, and each one's plane: 0..C-1 the render's
    channels (``S0.<nm>`` at the band centres, Fichet et al. 2021), C..C+2 the preview's R, G, B."""
    C = r.values.shape[-1]
    planes = {"S0." + f"{wl:.6f}".replace(".", ",") + "nm": k for k, wl in enumerate(r.wavelengths)}
    planes.update({c: C + i for i, c in enumerate("RGB")})
    names = sorted(planes, key=str.encode)
    return names, [planes[n] for n in names]


def _exr_attributes(r: Render, half: bool) -> dict:
    name, unit = QUANTITIES[r.quantity]
    attrs = {
        "spectralLayoutVersion": "1.0",
        "emissiveUnits": "W.m^-2.sr^-1",
        "widesky.quantity": name,
        "widesky.units": unit + (" (spectral density per nm; S0 channels sample it at the band centres)"
                                 if "nm-1" in unit else ""),
        "widesky.channelWidth_nm": f"{r.channel_width:g}",
        "widesky.pixelType": "half" if half else "float",
        "widesky.pixelError": HALF_ERROR if half else "float32: relative rounding error at most 6e-8",
    }
    attrs.update({f"widesky.{k}": str(v) for k, v in r.meta.items()})
    return attrs


def write_exr(path, r: Render, *, pixel_type="auto", compression="rle", threads=0):
    """Write a multi-channel OpenEXR in the Fichet et al. 2021 spectral layout: ``S0.<nm>`` channels at
    the band centres, ``spectralLayoutVersion`` 1.0, ``emissiveUnits``, an RGB preview, and ``widesky.*``
    attributes describing the quantity, its unit, the pixel type and its error, and the sky state.

    Parameters
    ----------
    pixel_type : {"auto", "half", "float"}
        "half" stores 16-bit floats (relative error <= 4.9e-4, see ``HALF_ERROR``; half the size and
        faster to write); "auto" (default) uses half when every value is finite and rounds to a finite
        half (magnitude below 65520; the largest half is 65504), else 32-bit float.
    compression : {"rle", "none", "zips", "zip", "piz", "zstd"}
        OpenEXR compression (all lossless). "rle" (default) and "none" are written by widesky's own
        encoder (:mod:`widesky.skymodel.exrfile`, one C pass over the image); "zip" makes files about 2.5x
        smaller than "rle" and takes several times longer to write (the OpenEXR library).
    threads : int
        Threads of the encoder, or of OpenEXR's compression (0: one per core).
    """
    if pixel_type not in ("auto", "half", "float"):
        raise ValueError(f"pixel_type={pixel_type!r}: expected 'auto', 'half' or 'float'")
    if compression not in EXR_COMPRESSIONS:
        raise ValueError(f"compression={compression!r}: expected one of {EXR_COMPRESSIONS}")
    values = np.ascontiguousarray(r.values, np.float32)
    if values.shape[-1] > 1 and r.quantity in ("sky", "sun"):
        rgb = r._rgby  # linear sRGB and Y per pixel: the encoder takes the first three
    else:
        rgb = None  # the preview repeats the single (or first) channel
    names, sources = _exr_channels(r)
    if compression not in NATIVE_COMPRESSIONS:
        return _write_exr_openexr(path, r, values, rgb, names, sources, pixel_type, compression, threads)
    with open(path, "wb") as f:
        if pixel_type != "float":
            bad = write_scanline_exr(f, values, rgb, names, sources, pixel_type="half", compression=compression,
                                     strings=_exr_attributes(r, True), overflow_ok=pixel_type == "half",
                                     threads=threads)
            if not bad or pixel_type == "half":
                return Path(path)
        write_scanline_exr(f, values, rgb, names, sources, pixel_type="float", compression=compression,
                           strings=_exr_attributes(r, False), threads=threads)
    return Path(path)


def _write_exr_openexr(path, r, values, rgb, names, sources, pixel_type, compression, threads):
    """write_exr through the OpenEXR library (the compressions widesky does not encode itself)."""
    if rgb is not None:
        rgb = np.ascontiguousarray(rgb[..., :3])
    if pixel_type == "auto":
        big = max(float(np.abs(values).max(initial=0.0)), float(np.abs(rgb).max(initial=0.0)) if rgb is not None
                  else 0.0)
        pixel_type = "half" if np.isfinite(big) and big < HALF_MAX else "float"
    half = pixel_type == "half"
    H, W, C = values.shape
    planes = np.empty((C + 3, H, W), np.uint16 if half else np.float32)
    _core.planar(values, planes[:C], C)
    if rgb is not None:
        _core.planar(rgb, planes[C:], 3)
    else:
        planes[C:] = planes[0]
    if half:
        planes = planes.view(np.float16)
    header = {"compression": getattr(OpenEXR, compression.upper() + "_COMPRESSION"), "type": OpenEXR.scanlineimage}
    header.update(_exr_attributes(r, half))
    OpenEXR.set_global_thread_count(int(threads) if threads else (os.cpu_count() or 1))
    channels = {n: planes[s] for n, s in zip(names, sources)}  # without rgb, R G B repeat plane 0
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))
    return Path(path)
