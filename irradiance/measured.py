"""Measured weather on a clear-sky model (an approximation).

The Prague Sky Model describes cloudless skies. When measured ``dni`` and ``dhi`` are given, widesky
keeps the model's clear-sky *spectral and angular shape* and rescales it per step, as
bifacial_radiance and Radiance's ``gendaymtx``/``gensdaymtx`` rescale their sky models:

- the sun spectrum by ``sun_scale = dni / model_dni``;
- the sky radiance by ``sky_scale = dhi / model_dhi``;

where ``model_dni`` and ``model_dhi`` [W m-2] are the model's own broadband direct-normal and
diffuse-horizontal irradiance for the step's sky state. (Overcast skies are far closer to uniform
than a scaled clear sky: the all-sky path, :mod:`widesky.irradiance.allsky`, blends toward the CIE overcast
sky for that.)

This is an approximation: clouds change the spectrum (diffuse light under overcast is bluer, water
absorption bands deepen) and the angular distribution in ways a scaled clear sky does not capture.

Guards: the model's values go to zero at low sun, where a ratio would blow up. Denominators are
floored at ``min_model_dni``/``min_model_dhi`` and the factors capped at ``max_scale``; every
step where a guard acted is flagged and the irradiance the scaled model then misses is returned
(``unmatched_dni``, ``unmatched_dhi``) so the loss can be reported, never hidden.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["MeasuredScaling", "measured_scale_factors", "clearness_index"]


class MeasuredScaling(NamedTuple):
    """Per-step outputs of :func:`measured_scale_factors` (arrays of the broadcast shape).

    Attributes
    ----------
    sun_scale, sky_scale : numpy.ndarray
        Multipliers [1] of the model's sun spectrum and sky radiance.
    sun_guarded, sky_guarded : numpy.ndarray
        bool: a floor or the cap acted (the match is not exact).
    unmatched_dni, unmatched_dhi : numpy.ndarray
        Measured minus reproduced irradiance [W m-2] (``dni - sun_scale * model_dni``), 0 where the
        match is exact.
    """

    sun_scale: np.ndarray
    sky_scale: np.ndarray
    sun_guarded: np.ndarray
    sky_guarded: np.ndarray
    unmatched_dni: np.ndarray
    unmatched_dhi: np.ndarray


def _nonneg(name, value):
    v = np.asarray(value, dtype=float)
    bad = np.isfinite(v) & (v < 0)
    if np.any(bad):
        raise ValueError(f"{name}={v[bad].ravel()[0]:g} W m-2 is negative; irradiance must be >= 0")
    return v


def _ratio(measured, model, floor, max_scale, missing):
    denom = np.maximum(model, floor)
    raw = measured / denom
    scale = np.minimum(raw, max_scale)
    guarded = (model < floor) | (raw > max_scale)
    guarded &= measured > 0  # nothing to match: scale 0 is exact
    nan = ~np.isfinite(measured) | ~np.isfinite(model)
    if missing == "clear":
        scale = np.where(nan, 1.0, scale)
        guarded = np.where(nan, True, guarded)
    else:
        scale = np.where(nan, np.nan, scale)
    unmatched = np.where(nan, np.nan, measured - scale * model)
    return scale, guarded, unmatched


def measured_scale_factors(model_dni, model_dhi, dni, dhi, min_model_dni=5.0, min_model_dhi=2.0,
                           max_scale=4.0, missing="nan") -> MeasuredScaling:
    """Per-step scale factors that make a clear-sky model reproduce measured DNI and DHI.

    Parameters
    ----------
    model_dni : array_like
        The model's clear-sky direct normal irradiance per step [W m-2], >= 0.
    model_dhi : array_like
        The model's clear-sky diffuse horizontal irradiance per step [W m-2], >= 0.
    dni, dhi : array_like
        Measured direct normal and diffuse horizontal irradiance [W m-2], >= 0 (NaN = missing).
    min_model_dni, min_model_dhi : float
        Floors [W m-2] of the model values used as denominators (low sun).
    max_scale : float
        Cap of both factors [1] (a measured value more than ``max_scale`` times the clear-sky
        model's is not a cloud effect the shape can carry: cloud enhancement of diffuse light
        reaches 2-4x).
    missing : {"nan", "clear"}
        Steps with NaN input: "nan" gives NaN factors, "clear" keeps the clear sky (factor 1,
        flagged as guarded).

    Returns
    -------
    MeasuredScaling
    """
    if missing not in ("nan", "clear"):
        raise ValueError(f"missing={missing!r} is not one of ('nan', 'clear')")
    for name, v in (("min_model_dni", min_model_dni), ("min_model_dhi", min_model_dhi)):
        if not float(v) > 0:
            raise ValueError(f"{name}={v!r} W m-2 must be > 0")
    if not float(max_scale) >= 1.0:
        raise ValueError(f"max_scale={max_scale!r} must be >= 1")
    mdni, mdhi = _nonneg("model_dni", model_dni), _nonneg("model_dhi", model_dhi)
    dni, dhi = _nonneg("dni", dni), _nonneg("dhi", dhi)
    mdni, mdhi, dni, dhi = np.broadcast_arrays(mdni, mdhi, dni, dhi)
    sun, sun_g, un_dni = _ratio(dni, mdni, float(min_model_dni), float(max_scale), missing)
    sky, sky_g, un_dhi = _ratio(dhi, mdhi, float(min_model_dhi), float(max_scale), missing)
    return MeasuredScaling(sun, sky, sun_g, sky_g, un_dni, un_dhi)


def clearness_index(ghi, solar_zenith, dni_extra, min_cos_zenith=0.065, max_clearness_index=2.0):
    """Clearness index kt = ghi / (dni_extra cos(zenith)) [1] (pvlib's definition and guards).

    Parameters
    ----------
    ghi : array_like
        Global horizontal irradiance [W m-2].
    solar_zenith : array_like
        Solar zenith angle [deg].
    dni_extra : array_like
        Extraterrestrial normal irradiance [W m-2] (:func:`widesky.irradiance.solarposition.dni_extra`).
    min_cos_zenith : float
        Floor of cos(zenith) [1] (86.27 deg by default).
    max_clearness_index : float
        Cap [1].

    Returns
    -------
    numpy.ndarray
        In [0, ``max_clearness_index``]; NaN where ``ghi`` is NaN.
    """
    cz = np.maximum(np.cos(np.radians(np.asarray(solar_zenith, dtype=float))), float(min_cos_zenith))
    kt = np.asarray(ghi, dtype=float) / (np.asarray(dni_extra, dtype=float) * cz)
    return np.clip(kt, 0.0, float(max_clearness_index))
