"""Angular distribution of overcast skies: the CIE standard overcast sky, blended in by cloudiness.

An overcast sky is close to the CIE standard overcast sky (Moon & Spencer 1942; CIE S 011/E:2003,
type 1): radiance ``L(theta) = L_z (1 + 2 cos theta) / 3``, three times brighter at the zenith than at
the horizon, with no dependence on the sun's azimuth; not a clear sky's aureole and horizon
brightening. The all-sky model (:mod:`widesky.irradiance.allsky`) distributes its cloud-scattered light this
way: the integrator adds it as patch radiance ``DHI_cloud f(theta) / sum(f h)`` (``h`` the patches'
horizontal projected solid angles), the unobstructed-plane path through :func:`overcast_poa_ratio`.

Broken and thin cloud are brighter toward the sun than the CIE overcast sky (forward scattering by droplets,
sunlit cloud edges): :func:`perez_circumsolar_fraction` gives the share of the diffuse light that the Perez
all-weather model (Perez et al. 1990) puts in the circumsolar region, from the measured DNI and DHI; the all-sky
model traces that share of its cloud light with the sun (``AllSkyOptions.circumsolar``).
"""

from __future__ import annotations

import numpy as np

from .perez_sky import perez_clearness_brightness

__all__ = ["cie_overcast_relative", "overcast_poa_ratio", "perez_circumsolar_fraction", "PEREZ_EPSILON_EDGES",
           "PEREZ_F1", "SOLAR_CONSTANT"]

SOLAR_CONSTANT = 1361.0
"""Total solar irradiance at 1 AU [W m-2] (Kopp & Lean 2011, Geophys. Res. Lett. 38, L01706)."""

PEREZ_EPSILON_EDGES = (1.065, 1.23, 1.5, 1.95, 2.8, 4.5, 6.2)
"""Upper edges of the first seven sky-clearness bins of Perez et al. (1990) [1] (the eighth is open)."""

PEREZ_F1 = ((-0.008, 0.588, -0.062), (0.130, 0.683, -0.151), (0.330, 0.487, -0.221), (0.568, 0.187, -0.295),
            (0.873, -0.392, -0.362), (1.132, -1.237, -0.412), (1.060, -1.600, -0.359), (0.678, -0.327, -0.250))
"""Circumsolar brightness coefficients (F11, F12, F13) per sky-clearness bin: Perez, Ineichen, Seals, Michalsky &
Stewart (1990), Solar Energy 44(5), 271-289, Table 6 (all sites composite); F13 multiplies the zenith in radians."""


def cie_overcast_relative(cos_zenith):
    """CIE standard overcast sky radiance relative to the zenith, ``(1 + 2 cos theta) / 3`` [1]
    (0 below the horizon)."""
    cz = np.asarray(cos_zenith, dtype=float)
    return np.where(cz >= 0, (1.0 + 2.0 * np.clip(cz, 0.0, 1.0)) / 3.0, 0.0)


def overcast_poa_ratio(poa_weights, horizontal_weights, cos_zenith):
    """Sky diffuse on a plane relative to the diffuse horizontal irradiance under the CIE overcast sky.

    Parameters
    ----------
    poa_weights : array_like
        (P,) or (F, P) projected solid angles of the patches seen by each plane [sr]
        (:func:`widesky.irradiance.cosine_weights`).
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


def perez_circumsolar_fraction(dhi, dni, sun_elevation, dni_extra=SOLAR_CONSTANT):
    """Circumsolar share of the diffuse light in the Perez all-weather model, ``F1`` (Perez et al. 1990).

    ``F1 = max(0, F11(e) + F12(e) D + F13(e) z)`` with the sky clearness
    ``e = ((DHI + DNI) / DHI + k z^3) / (1 + k z^3)`` (``k = 1.041``, ``z`` the sun's zenith [rad]) choosing the
    bin, and the sky brightness ``D = DHI m / E0`` (``m`` the Kasten-Young relative air mass, ``E0`` the
    extraterrestrial normal irradiance). Perez's model puts ``F1 DHI`` on a plane as a point source at the sun.

    Parameters
    ----------
    dhi, dni : array_like
        (T,) measured diffuse horizontal and direct normal irradiance [W m-2] (NaN or <= 0 DHI gives 0).
    sun_elevation : array_like
        (T,) apparent sun elevation [deg] (0 at or below the horizon).
    dni_extra : array_like
        Extraterrestrial normal irradiance [W m-2], scalar or (T,) (``SOLAR_CONSTANT / r**2``).

    Returns
    -------
    numpy.ndarray
        (T,) F1 [1], >= 0.
    """
    eps, delta, ok = perez_clearness_brightness(dhi, dni, sun_elevation, dni_extra)
    z = np.radians(90.0 - np.clip(np.asarray(sun_elevation, dtype=float), 0.0, 90.0))
    c = np.asarray(PEREZ_F1)[np.searchsorted(PEREZ_EPSILON_EDGES, eps, side="right")]
    f1 = np.maximum(c[..., 0] + c[..., 1] * delta + c[..., 2] * z, 0.0)
    return np.where(ok, f1, 0.0)
