"""Hazy hours below the sky dataset's visibility range: a documented aerosol extension, not a silent clamp.

The Prague Sky Model datasets stop at 20 km visibility; station visibility in weather files falls
below that in most hours of a maritime climate (59 % of Amsterdam's IWEC daylight hours). widesky
evaluates the sky at the dataset's lowest visibility (flagged by :func:`widesky.irradiance.sky_states`) and
then corrects the *spectral shape* of that state for the aerosol the dataset does not hold
(:func:`haze_correction`), while the measured DNI and DHI keep setting the totals:

- the extra aerosol optical depth at 550 nm is Koschmieder's, as the dataset generator builds it
  (:func:`widesky.skymodel.visibility.aod550_from_visibility`, 1.5 km scale height):
  ``d_tau = aod550(V) - aod550(V_min)``, spread over wavelength by the Angstrom law;
- the beam is reddened by ``exp(-m d_tau(lambda))`` (Kasten & Young 1989 air mass ``m``);
- the light it loses is scattered: a fraction ``omega (1 + g) / 2`` of it (single-scattering
  albedo ``omega`` and the forward share of an aerosol of asymmetry ``g``; first-order scattering)
  is added to the diffuse horizontal spectrum.

Two physical limits bound the extension, each flagged per step:

- *fog*: below ``fog_visibility`` (1 km, the WMO definition of fog) the obscuration is by water
  droplets, whose extinction is spectrally flat; the aerosol part is held at its value at 1 km;
- *the measured beam*: where the sun is measured (``dni`` > 0), the extra aerosol cannot extinguish
  more beam than the measurement shows, ``m d_tau <= -ln(dni / dni_model)``: station visibility
  describes the air at the ground, often a shallow humid layer, not the column the sun shines
  through. Where the sun is hidden (``dni`` = 0) the low visibility comes with cloud, rain or mist
  and the cloud model (:mod:`widesky.irradiance.allsky`) sets the spectrum; the aerosol is not extended.

Files that carry an aerosol optical depth (EPW/TMY3 ``aod``) give the column directly:
``sky_states(..., prefer="aod")`` then keeps most hours inside the dataset's range.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from widesky.skymodel.visibility import aod550_from_visibility

__all__ = ["HazeCorrection", "haze_correction", "relative_airmass"]


class HazeCorrection(NamedTuple):
    """Per-step output of :func:`haze_correction`.

    dni, dhi : (T, C) corrected clear-sky spectra [W m-2 nm-1] (the inputs where nothing applies).
    delta_aod550 : (T,) extra aerosol optical depth at 550 nm applied [1].
    extended : (T,) bool, the aerosol was extended below the dataset's visibility.
    fog : (T,) bool, visibility below ``fog_visibility``: the aerosol was held at that visibility.
    beam_bounded : (T,) bool, the measured beam limited the extra aerosol.
    sun_hidden : (T,) bool, visibility below the range with no measured beam: not extended.
    """

    dni: np.ndarray
    dhi: np.ndarray
    delta_aod550: np.ndarray
    extended: np.ndarray
    fog: np.ndarray
    beam_bounded: np.ndarray
    sun_hidden: np.ndarray


def relative_airmass(sun_elevation):
    """Kasten & Young (1989, Appl. Opt. 28, 4735) relative air mass [1] from the apparent sun elevation
    [deg]; NaN at or below the horizon."""
    el = np.asarray(sun_elevation, dtype=float)
    z = 90.0 - el
    with np.errstate(invalid="ignore"):
        am = 1.0 / (np.cos(np.radians(z)) + 0.50572 * np.maximum(96.07995 - z, 1e-9) ** -1.6364)
    return np.where(el > 0, am, np.nan)


def haze_correction(wavelength, channel_width, dni_clear, dhi_clear, sun_elevation, visibility,
                    dni=None, min_visibility=20.0, fog_visibility=1.0, angstrom=1.3,
                    aerosol_ssa=0.9, aerosol_asymmetry=0.7) -> HazeCorrection:
    """Correct clear-sky spectra evaluated at ``min_visibility`` for a lower measured visibility.

    Parameters
    ----------
    wavelength : array_like
        (C,) channel centres [nm].
    channel_width : array_like
        (C,) channel widths [nm].
    dni_clear, dhi_clear : array_like
        (T, C) the dataset's direct normal and diffuse horizontal spectra [W m-2 nm-1] at the
        clamped visibility.
    sun_elevation : array_like
        (T,) apparent sun elevation [deg].
    visibility : array_like
        (T,) measured visibility [km], >= 0 (NaN: no correction; 0, as files report dense fog,
        counts as fog).
    dni : array_like, optional
        (T,) measured direct normal irradiance [W m-2]; bounds the extra aerosol (see module).
        Without it the extension is not bounded by the beam.
    min_visibility : float
        The dataset's lowest visibility [km] (the sky was evaluated there).
    fog_visibility : float
        Visibility [km] below which the extinction is taken as fog (spectrally flat).
    angstrom : float
        Angstrom exponent [1] of the extra aerosol.
    aerosol_ssa, aerosol_asymmetry : float
        Single-scattering albedo [1] and asymmetry parameter [1] of the extra aerosol.

    Returns
    -------
    HazeCorrection
    """
    if not 0 < float(fog_visibility) < float(min_visibility):
        raise ValueError(f"need 0 < fog_visibility < min_visibility, got fog_visibility="
                         f"{fog_visibility!r} km, min_visibility={min_visibility!r} km")
    for name, v in (("aerosol_ssa", aerosol_ssa), ("aerosol_asymmetry", aerosol_asymmetry)):
        if not 0.0 <= float(v) <= 1.0:
            raise ValueError(f"{name}={v!r} outside the valid range [0, 1]")
    lam = np.asarray(wavelength, dtype=float)
    w = np.asarray(channel_width, dtype=float)
    bn = np.asarray(dni_clear, dtype=float)
    dh = np.asarray(dhi_clear, dtype=float)
    el = np.asarray(sun_elevation, dtype=float)
    vis = np.asarray(visibility, dtype=float)
    T = el.shape[0]
    if bn.shape != (T, lam.size) or dh.shape != bn.shape:
        raise ValueError(f"dni_clear and dhi_clear must have shape ({T}, {lam.size}), got "
                         f"{bn.shape} and {dh.shape}")
    if np.any(vis[np.isfinite(vis)] < 0):
        raise ValueError(f"visibility={vis[np.isfinite(vis) & (vis < 0)][0]!r} km is negative")
    low = np.isfinite(vis) & (vis < float(min_visibility)) & (el > 0)
    fog = low & (vis < float(fog_visibility))
    v_eff = np.where(low, np.maximum(np.where(np.isfinite(vis), vis, min_visibility), fog_visibility),
                     min_visibility)
    d_tau = aod550_from_visibility(v_eff) - aod550_from_visibility(float(min_visibility))
    m = np.where(el > 0, relative_airmass(np.where(el > 0, el, 45.0)), 0.0)
    spectral = (lam / 550.0) ** (-float(angstrom))                              # (C,)
    bounded = np.zeros(T, dtype=bool)
    hidden = np.zeros(T, dtype=bool)
    if dni is not None:
        dm = np.asarray(dni, dtype=float)
        model_b = bn @ w
        hidden = low & ~(dm > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            kb = np.clip(dm / model_b, 1e-6, 1.0)
            # broadband beam loss of the extra aerosol, exp(-m d_tau_eff) with d_tau_eff the
            # irradiance-weighted mean over channels: find the largest d_tau whose loss stays within
            # the measured beam, by bisection on the monotone loss
            lo, hi = np.zeros(T), d_tau.copy()
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                tr = (bn * np.exp(-(m * mid)[:, None] * spectral[None, :])) @ w / model_b
                ok = tr >= kb
                lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
        limit = np.where(np.isfinite(lo), lo, d_tau)
        bounded = low & ~hidden & (limit < d_tau - 1e-9)
        d_tau = np.where(low & ~hidden, np.minimum(d_tau, limit), 0.0)
    d_tau = np.where(low & ~hidden, d_tau, 0.0)
    ext = np.exp(-(m * d_tau)[:, None] * spectral[None, :])                      # (T, C)
    sin_el = np.sin(np.radians(np.maximum(el, 0.0)))[:, None]
    scattered = float(aerosol_ssa) * 0.5 * (1.0 + float(aerosol_asymmetry)) * bn * sin_el * (1.0 - ext)
    return HazeCorrection(bn * ext, dh + scattered, d_tau, low & (d_tau > 0), fog, bounded, hidden)
