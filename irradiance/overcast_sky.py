"""Angular distribution of overcast skies: the CIE standard overcast sky, blended in by cloudiness.

An overcast sky is close to the CIE standard overcast sky (Moon & Spencer 1942; CIE S 011/E:2003,
type 1): radiance ``L(theta) = L_z (1 + 2 cos theta) / 3``, three times brighter at the zenith than at
the horizon, with no dependence on the sun's azimuth; not a clear sky's aureole and horizon
brightening. :func:`blend_toward_overcast` moves a clear-sky radiance distribution toward it by a
per-step weight (the all-sky cloud index of :mod:`irradiance.allsky`), keeping the spectral diffuse
horizontal irradiance of every channel, circumsolar light included, so measured DHI stays matched.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cie_overcast_relative", "blend_toward_overcast", "overcast_poa_ratio"]


def cie_overcast_relative(cos_zenith):
    """CIE standard overcast sky radiance relative to the zenith, ``(1 + 2 cos theta) / 3`` [1]
    (0 below the horizon)."""
    cz = np.asarray(cos_zenith, dtype=float)
    return np.where(cz >= 0, (1.0 + 2.0 * np.clip(cz, 0.0, 1.0)) / 3.0, 0.0)


def blend_toward_overcast(sky_radiance, weight, horizontal_weights, cos_zenith, circumsolar=None,
                          sun_elevation=None):
    """Blend a sky's angular shape toward the CIE overcast sky, keeping its spectral DHI.

    ``L' = (1 - w) L + w DHI_L f / H_f`` per channel and ``circumsolar' = (1 - w) circumsolar``,
    with ``f`` the CIE overcast shape, ``H_f = sum(f h)`` and ``DHI_L = sum(L h)`` (``h`` the patches'
    horizontal projected solid angles) plus the circumsolar light on the horizontal: the diffuse
    horizontal irradiance of ``L``.

    Parameters
    ----------
    sky_radiance : array_like
        (T, P, C) patch radiance [W m-2 sr-1 nm-1].
    weight : array_like
        (T,) weight of the overcast shape [1] in [0, 1].
    horizontal_weights : array_like
        (P,) projected solid angles on the horizontal [sr] (``SkyPatches.vector[:, 2]``).
    cos_zenith : array_like
        (P,) cosines of the patch centres' zenith angles [1] (``SkyPatches.directions[:, 2]``).
    circumsolar : array_like, optional
        (T, C) circumsolar normal irradiance [W m-2 nm-1] traced with the sun (see
        :func:`irradiance.patch_radiance`); needs ``sun_elevation`` (T,) [deg].

    Returns
    -------
    radiance : numpy.ndarray
        (T, P, C) blended patch radiance.
    circumsolar : numpy.ndarray or None
        (T, C) reduced circumsolar irradiance.
    """
    L = np.asarray(sky_radiance, dtype=float)
    w = np.asarray(weight, dtype=float)
    proj = np.asarray(horizontal_weights, dtype=float)
    cz = np.asarray(cos_zenith, dtype=float)
    if L.ndim != 3:
        raise ValueError(f"sky_radiance must have shape (T, P, C), got {L.shape}")
    if w.shape != L.shape[:1] or np.any((w < 0) | (w > 1)):
        raise ValueError(f"weight must have shape ({L.shape[0]},) within [0, 1]")
    dhi = np.einsum("p,tpc->tc", proj, L)
    cs = None
    if circumsolar is not None:
        if sun_elevation is None:
            raise ValueError("circumsolar needs sun_elevation")
        cs = np.asarray(circumsolar, dtype=float)
        dhi = dhi + cs * np.sin(np.radians(np.maximum(np.asarray(sun_elevation, float), 0.0)))[:, None]
        cs = (1.0 - w)[:, None] * cs
    f = cie_overcast_relative(cz)
    over = dhi[:, None, :] * (f / (f * proj).sum())[None, :, None]
    wb = w[:, None, None]
    return (1.0 - wb) * L + wb * over, cs


def overcast_poa_ratio(poa_weights, horizontal_weights, cos_zenith):
    """Sky diffuse on a plane relative to the diffuse horizontal irradiance under the CIE overcast sky.

    Parameters
    ----------
    poa_weights : array_like
        (P,) or (F, P) projected solid angles of the patches seen by each plane [sr]
        (:func:`irradiance.cosine_weights`).
    horizontal_weights : array_like
        (P,) the patches' projected solid angles on the horizontal [sr] (``SkyPatches.vector[:, 2]``).
    cos_zenith : array_like
        (P,) cosines of the patch centres' zenith angles [1] (``SkyPatches.directions[:, 2]``).

    Returns
    -------
    numpy.ndarray
        () or (F,) ratio [1]: 1 for a horizontal plane, about 0.40 for a vertical one
        (the analytic value for the continuous CIE overcast sky is 0.3963; Moon & Spencer).
    """
    f = cie_overcast_relative(cos_zenith)
    h = (f * np.asarray(horizontal_weights, dtype=float)).sum()
    return np.asarray(poa_weights, dtype=float) @ f / h
