"""The ground's spectral reflectance under measured weather: green vegetation or grey.

A weather file gives the ground's *broadband* albedo (an albedometer's reading, or a climatological
0.2), not its spectrum. No natural ground is spectrally flat: green vegetation, the surface of a
meteorological station's enclosure (short grass, WMO-No. 8, 2018 edition, Vol. I, section 1.3.3.1) and
of most open field sites, reflects a few per cent of visible light (chlorophyll absorption) and 40-50 % of
the near infrared beyond the red edge at about 715 nm (Knipling 1970). Reflected light from a grey ground
of the same broadband albedo is therefore far too blue. The all-sky model (:mod:`widesky.irradiance.allsky`,
option ``ground``) reflects vegetated steps with the vegetation shape below, scaled per step so that
the reflected *broadband* irradiance is the weather's albedo times the step's global horizontal
irradiance, exactly as with a grey ground (energy conserved; only the spectrum of the reflected light
changes).

A step is taken as vegetated when its broadband albedo is at most :data:`VEGETATION_MAX_ALBEDO` and the
weather reports no snow: green grass and crops have broadband albedos of 0.16-0.26 (Oke 1987, Boundary
Layer Climates, 2nd ed., Table 1.1), fresh snow 0.75-0.95 and old snow 0.40-0.70; a higher albedo is a
snow-covered or otherwise bright ground, which stays grey (snow is close to flat over 300-900 nm, where
the cells respond). The sky radiance keeps the grey albedo it is evaluated with (the sky's own
dependence on the ground's spectrum is a second-order term, docs/all-sky.md).
"""

from __future__ import annotations

import numpy as np

__all__ = ["VEGETATION_MAX_ALBEDO", "GROUND_KINDS", "vegetation_albedo_shape", "vegetated_steps",
           "ground_scales", "step_spectral_albedo"]

VEGETATION_MAX_ALBEDO = 0.30
"""Broadband albedo [1] above which a step's ground is not taken as green vegetation (grass and crops
0.16-0.26, Oke 1987, Table 1.1; snow 0.40-0.95)."""

GROUND_KINDS = ("vegetation", "grey")


def vegetation_albedo_shape(wavelength_nm, visible=0.05, near_infrared=0.45, swir=0.25, red_edge_nm=715.0,
                            edge_width_nm=15.0, water_edge_nm=1350.0):
    """Schematic spectral reflectance [1] of green vegetation (grass).

    Low in the visible (chlorophyll absorption: 0.03-0.08, a small green peak left out), a steep rise at
    the red edge near 700-730 nm to a near-infrared plateau of 0.4-0.5 (leaf mesophyll scattering), and
    lower again beyond about 1300 nm where leaf water absorbs (Knipling 1970, Remote Sens. Environ. 1,
    155; Jacquemoud & Baret 1990, Remote Sens. Environ. 34, 75): two logistic steps between the three
    levels. The all-sky model's vegetated ground (:func:`ground_scales`), ``albedo_shape`` of
    :func:`widesky.irradiance.allsky_plane.plane_poa` (only the shape matters there) or, scaled, a scene's
    per-channel ``ground_albedo``.

    Parameters
    ----------
    wavelength_nm : array_like
        Wavelengths [nm].
    visible, near_infrared, swir : float
        Reflectance levels [1] below the red edge, on the NIR plateau and beyond ``water_edge_nm``.
    red_edge_nm, edge_width_nm, water_edge_nm : float
        Centre of the red edge, width of both steps, centre of the water step [nm].
    """
    lam = np.asarray(wavelength_nm, dtype=float)
    for name, v in (("visible", visible), ("near_infrared", near_infrared), ("swir", swir)):
        if not 0.0 <= v <= 1.0:
            raise ValueError(f"{name}={v} must be within [0, 1]")
    if edge_width_nm <= 0:
        raise ValueError(f"edge_width_nm={edge_width_nm} must be > 0")
    rise = 1.0 / (1.0 + np.exp(-(lam - red_edge_nm) / edge_width_nm))
    fall = 1.0 / (1.0 + np.exp(-(lam - water_edge_nm) / (2.0 * edge_width_nm)))
    return visible + (near_infrared - visible) * rise + (swir - near_infrared) * fall


def vegetated_steps(albedo, snow_depth=None):
    """Which steps' ground is green vegetation: broadband albedo finite and at most
    :data:`VEGETATION_MAX_ALBEDO`, and no snow reported.

    Parameters
    ----------
    albedo : array_like
        (T,) broadband ground albedo [1].
    snow_depth : array_like, optional
        (T,) snow depth [cm] (NaN: not reported); a step with snow depth > 0 is not vegetated.

    Returns
    -------
    numpy.ndarray
        (T,) bool.
    """
    a = np.asarray(albedo, dtype=float)
    veg = np.isfinite(a) & (a <= VEGETATION_MAX_ALBEDO)
    if snow_depth is not None:
        s = np.broadcast_to(np.asarray(snow_depth, dtype=float), a.shape)
        veg &= ~(np.isfinite(s) & (s > 0))
    return veg


def ground_scales(shape, ghi_spectra, channel_widths, albedo, vegetated):
    """Per-step factors of the vegetation shape and of a grey ground that keep the broadband albedo.

    The spectral albedo of step t is ``a_shape[t] shape + a_grey[t]``: on vegetated steps ``a_shape =
    albedo / n`` with ``n = sum shape G w / sum G w`` (G the step's global horizontal spectrum), so that
    ``sum albedo_c G_c w_c = albedo sum G_c w_c`` (the reflected broadband irradiance of a grey ground of
    the same albedo) and ``a_grey = 0``; elsewhere ``a_shape = 0`` and ``a_grey = albedo``. A vegetated
    step whose scaled shape would exceed 1 in some channel (an extreme spectrum) or that has no light
    falls back to grey.

    Parameters
    ----------
    shape : array_like
        (C,) relative spectral reflectance [1] (:func:`vegetation_albedo_shape`).
    ghi_spectra : array_like
        (T, C) global horizontal spectral irradiance [W m-2 nm-1].
    channel_widths : array_like
        (C,) channel widths [nm].
    albedo : array_like
        (T,) broadband albedo [1].
    vegetated : array_like
        (T,) bool (:func:`vegetated_steps`).

    Returns
    -------
    (a_shape, a_grey) : (T,) [1] each.
    """
    s = np.asarray(shape, dtype=float)
    g = np.asarray(ghi_spectra, dtype=float) * np.asarray(channel_widths, dtype=float)[None, :]
    a = np.asarray(albedo, dtype=float)
    tot = g.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        n = np.where(tot > 0, (g * s[None, :]).sum(axis=1) / tot, 0.0)
        a_shape = np.where(n > 0, a / n, 0.0)
    use = np.asarray(vegetated, dtype=bool) & (n > 0) & (a_shape * s.max() <= 1.0)
    a_shape = np.where(use, a_shape, 0.0)
    return a_shape, np.where(use, 0.0, a)


def step_spectral_albedo(shape, a_shape, a_grey):
    """(T, C) spectral albedo [1] of each step from :func:`ground_scales`."""
    return (np.asarray(a_shape, dtype=float)[:, None] * np.asarray(shape, dtype=float)[None, :]
            + np.asarray(a_grey, dtype=float)[:, None])
