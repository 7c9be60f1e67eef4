"""What the sky explorer computes: images, the spectrum of one direction, irradiance on two planes.

Pure functions of a loaded :class:`widesky.skymodel.SkyModel` and a :class:`~skymodel.explorer.params.View`.
The irradiance of an unobstructed plane (horizontal, and tilted at ``surface_tilt`` towards
``surface_azimuth``) uses the per-face integrator's own quadrature (:func:`widesky.irradiance.patch_radiance` on
Reinhart patches with their exact cosine weights, the circumsolar excess traced with the sun), so the
numbers are the ones ``widesky poa`` gives for a face with nothing around it; the ground is a
Lambertian plane of the sky state's albedo with the isotropic view factor ``(1 - cos tilt) / 2``.
"""

from __future__ import annotations

import io
import time

import numpy as np
from PIL import Image

from widesky.irradiance import IntegratorSettings, PragueSky, SkyStates, cosine_weights, patch_radiance, reinhart
from widesky.skymodel.colour import channel_xyz_weights
from widesky.skymodel.evaluate import polarisation, sky_radiance, sun_direction, sun_radiance, transmittance
from widesky.skymodel.render import QUANTITIES, Render, _display, _percentile99, fisheye_directions, render_sky

__all__ = ["render_view", "png_bytes", "linear_payload", "direction_at", "spectrum_at", "sky_patches",
           "plane_irradiance", "LUMINOUS_EFFICACY", "VISIBLE_NM"]

LUMINOUS_EFFICACY = 683.0  # [lm W-1] at 555 nm (the SI definition of the candela, 540 THz)
VISIBLE_NM = (380.0, 780.0)


def _render_channels(model, view):
    """Channel indices a render needs: the visible ones for an sRGB composite, else the one chosen."""
    if view.channel == "rgb":
        if view.quantity in ("sky", "sun"):
            lo, hi = VISIBLE_NM
            idx = np.nonzero((model.channel_lower + model.channel_width > lo) & (model.channel_lower < hi))[0]
            if idx.size:
                return idx, True
        # polarisation / transmittance have no colour: show the channel nearest 550 nm
        return np.array([int(np.argmin(np.abs(model.wavelengths - 550.0)))]), False
    wl = float(view.channel[:-2])
    return np.array([int(np.argmin(np.abs(model.wavelengths - wl)))]), False


def render_view(model, view, threads=0):
    """Render a view; returns (:class:`widesky.skymodel.render.Render`, composite flag, seconds of evaluation)."""
    chi, composite = _render_channels(model, view)
    t0 = time.perf_counter()
    r = render_sky(model, sun_elevation=view.sun_elevation, sun_azimuth=view.sun_azimuth,
                   visibility=view.visibility, albedo=view.albedo, altitude=view.altitude, quantity=view.quantity,
                   channels=chi, view=view.view, view_azimuth=view.view_azimuth, resolution=view.resolution,
                   threads=threads)
    return r, composite, time.perf_counter() - t0


def png_bytes(r: Render, composite, exposure):
    """8-bit PNG of a render as bytes (fast zlib level: the image is for the screen)."""
    buf = io.BytesIO()
    if not np.any(r.mask):
        img = np.zeros(r.mask.shape + (3,), np.uint8)
    else:
        img = _display(r, composite, exposure)
    Image.fromarray(img).save(buf, format="PNG", compress_level=1)
    return buf.getvalue()


def _reference(values, mask):
    """The value exposure 0 maps to white: the 99th percentile of the disc's positive values (as
    :func:`widesky.skymodel.render.write_png`), or None when there is none."""
    v = values[mask]
    v = v[np.isfinite(v) & (v > 0)]
    return _percentile99(v) if v.size else None


def linear_payload(r: Render, composite):
    """The render before its display mapping, for the page to apply the exposure itself.

    Returns ``(kind, reference, data)``: ``kind`` "rgb" (linear sRGB, 3 values per pixel), "grey" (the one
    channel, 1 value per pixel) or "signed" (the signed degree of polarisation [1], NaN outside the disc);
    ``reference`` the value that exposure 0 maps to white (the disc's 99th percentile of CIE Y, or of the
    channel, as :func:`widesky.skymodel.render.write_png`; 1 for "signed") in the quantity's unit
    (W m-2 sr-1 for "rgb"); ``data`` the values divided by ``reference`` as little-endian IEEE half floats
    (2 bytes a value, row by row; values above 65504 x reference, 16 EV over white, become infinite, i.e. white).
    The page maps a value ``x`` to the PNG's 8-bit value as the server does: ``float32(x * 2**EV)`` clipped to
    [0, 1], rounded to 16 bits, then the sRGB table; the half float's rounding (at most 2^-11 relative)
    changes an 8-bit value by at most one level.
    """
    if composite:
        rgby = r._rgby
        ref = _reference(rgby[..., 3], r.mask)
        if ref is None or not rgby[..., :3].max(initial=0.0) > 0:
            raise ValueError("the selected channels have no visible (380-780 nm) contribution: use a single channel")
        values, kind = rgby[..., :3], "rgb"
    elif r.quantity == "polarisation":
        values, kind, ref = r.values[..., :1], "signed", 1.0
    else:
        values, kind = r.values[..., :1], "grey"
        ref = _reference(r.values[..., 0], r.mask) or 1.0
    with np.errstate(over="ignore"):
        data = (values * np.float32(1.0 / ref)).astype("<f2")
    if kind == "signed":
        data[~r.mask] = np.nan
    return kind, float(ref), data.tobytes()


def direction_at(view, u, v):
    """East-north-up unit vector of the image position (u, v) in [0, 1] (u right, v down), the same
    stereographic mapping as the render; None outside the fisheye disc."""
    n = int(view.resolution)
    col, row = min(int(u * n), n - 1), min(int(v * n), n - 1)
    dirs, mask = fisheye_directions(n, view.view, view.view_azimuth)
    if not mask[row, col]:
        return None
    return dirs[row, col]


def spectrum_at(model, view, direction, threads=0):
    """Every channel of the view's quantity (and of sky radiance, transmittance, sun radiance) at one
    direction.

    Returns
    -------
    dict
        ``wavelength_nm`` (C,), ``sky_radiance`` and ``sun_radiance`` [W m-2 sr-1 nm-1],
        ``transmittance`` [1], ``polarisation`` [1] (None without that section), ``zenith_deg`` and
        ``azimuth_deg`` of the direction [deg], ``gamma_deg`` its angle from the sun [deg], and ``below_horizon``.
    """
    d = np.asarray(direction, float).reshape(1, 3)
    state = (view.sun_elevation, view.sun_azimuth, view.visibility, view.albedo, view.altitude)
    out = {"wavelength_nm": model.wavelengths.tolist()}
    below = bool(d[0, 2] < 0.0)
    ground_only = len(model.altitudes) == 1 and float(model.altitudes[0]) == 0.0
    if below and ground_only:
        out["sky_radiance"] = [0.0] * model.n_channels   # no data below the horizon: as the render, dark
    else:
        out["sky_radiance"] = sky_radiance(model, d, *state, threads=threads)[0].tolist()
    out["sun_radiance"] = sun_radiance(model, d, *state, threads=threads)[0].tolist()
    out["transmittance"] = transmittance(model, d, *state, threads=threads)[0].tolist()
    out["polarisation"] = (polarisation(model, d, *state, threads=threads)[0].tolist()
                           if model.has_polarisation else None)
    s = sun_direction(view.sun_elevation, view.sun_azimuth)
    out["zenith_deg"] = float(np.degrees(np.arccos(np.clip(d[0, 2], -1, 1))))
    out["azimuth_deg"] = float(np.degrees(np.arctan2(d[0, 0], d[0, 1])) % 360.0)
    out["gamma_deg"] = float(np.degrees(np.arccos(np.clip(d[0] @ s, -1, 1))))
    out["below_horizon"] = below
    out["quantity"] = view.quantity
    out["unit"] = QUANTITIES[view.quantity][1]
    return out


def _plane_normal(tilt, azimuth):
    t, a = np.radians(tilt), np.radians(azimuth)
    return np.array([np.sin(t) * np.sin(a), np.sin(t) * np.cos(a), np.cos(t)])


_PATCH_CACHE = {}


def _patches(mf):
    if mf not in _PATCH_CACHE:
        p = reinhart(mf)
        _PATCH_CACHE[mf] = (p, cosine_weights(p, np.array([[0.0, 0.0, 1.0]]))[0])
    return _PATCH_CACHE[mf]


def sky_patches(model, view, mf=2, threads=0):
    """The sky state's radiance on the quadrature patches: ``(Lp (P, C) [W m-2 sr-1 nm-1], direct normal (C,)
    [W m-2 nm-1], circumsolar excess (C,) [W m-2 nm-1])``; zeros with the sun below the model's range. A
    tilted plane's irradiance is a weighted sum of these, so a change of plane needs no new sky evaluation."""
    sky = PragueSky(model, elevation_quantum=0.0, threads=threads)
    patches, _ = _patches(mf)
    C = model.n_channels
    if view.sun_elevation > sky.min_sun_elevation:
        states = SkyStates.create(view.sun_elevation, view.sun_azimuth, view.visibility, view.albedo,
                                  view.altitude)
        Lp, dn, cs = patch_radiance(sky, patches, states, None, IntegratorSettings(mf=mf))
        return Lp[0], dn[0], cs[0]                                        # (P, C), (C,), (C,)
    return np.zeros((patches.n_patches, C)), np.zeros(C), np.zeros(C)


def plane_irradiance(model, view, responses=None, mf=2, sky=None):
    """Spectral irradiance of an unobstructed horizontal plane and of the view's tilted plane.

    Parameters
    ----------
    model : skymodel.SkyModel
    view : View
        Sky state, ``surface_tilt`` and ``surface_azimuth`` [deg].
    responses : dict of str to (ndarray (C,), str), optional
        Name -> (weights per channel [1 or lm W-1], output unit); each global spectrum is integrated
        against each. ``broadband`` (unit weights, W m-2) and ``illuminance`` (CIE 1931 y x 683 lm W-1,
        lx) are always included.
    mf : int
        Reinhart subdivision of the sky quadrature (2: 577 patches).
    sky : tuple, optional
        :func:`sky_patches` of this model, view and ``mf``, if already computed (the explorer keeps them per
        sky state); computed here otherwise (with all cores).

    Returns
    -------
    dict
        ``wavelength_nm`` (C,); for ``horizontal`` and ``tilted``: ``direct``, ``sky_diffuse``,
        ``ground_diffuse``, ``global`` spectra [W m-2 nm-1] and ``integrated``: response name ->
        value of the global spectrum, ``broadband``: part -> [W m-2]; ``aoi_deg`` of the tilted plane [deg]; ``units`` per response.
    """
    patches, w_h = _patches(mf)
    C = model.n_channels
    Lp, dn, cs = sky if sky is not None else sky_patches(model, view, mf)
    s = sun_direction(view.sun_elevation, view.sun_azimuth)
    n = _plane_normal(view.surface_tilt, view.surface_azimuth)
    cos_h = max(float(s[2]), 0.0)
    cos_t = max(float(s @ n), 0.0)
    w_t = cosine_weights(patches, n[None, :])[0]
    hor_direct = dn * cos_h
    hor_sky = Lp.T @ w_h + cs * cos_h
    ghi = hor_direct + hor_sky
    parts = {
        "horizontal": {"direct": hor_direct, "sky_diffuse": hor_sky, "ground_diffuse": np.zeros(C)},
        "tilted": {"direct": dn * cos_t, "sky_diffuse": Lp.T @ w_t + cs * cos_t,
                   "ground_diffuse": view.albedo * ghi * (1.0 - np.cos(np.radians(view.surface_tilt))) / 2.0},
    }
    width = np.full(C, model.channel_width)
    resp = {"broadband": (np.ones(C), "W m-2"),
            "illuminance": (LUMINOUS_EFFICACY * channel_xyz_weights(model.channel_lower, model.channel_width)[:, 1]
                            / model.channel_width, "lx")}
    resp.update(responses or {})
    out = {"wavelength_nm": model.wavelengths.tolist(), "units": {k: u for k, (_, u) in resp.items()},
           "aoi_deg": float(np.degrees(np.arccos(np.clip(s @ n, -1, 1))))}
    for plane, p in parts.items():
        p["global"] = p["direct"] + p["sky_diffuse"] + p["ground_diffuse"]
        block = {k: v.tolist() for k, v in p.items()}
        block["integrated"] = {k: float(np.sum(p["global"] * w * width)) for k, (w, _) in resp.items()}
        block["broadband"] = {k: float(np.sum(v * width)) for k, v in p.items()}          # [W m-2]
        out[plane] = block
    return out
