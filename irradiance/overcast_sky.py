"""Angular distribution of overcast skies: the CIE standard overcast sky, blended in by cloudiness.

An overcast sky is close to the CIE standard overcast sky (Moon & Spencer 1942; CIE S 011/E:2003,
type 1): radiance ``L(theta) = L_z (1 + 2 cos theta) / 3``, three times brighter at the zenith than at
the horizon, with no dependence on the sun's azimuth; not a clear sky's aureole and horizon
brightening. The all-sky model (:mod:`irradiance.allsky`) distributes its cloud-scattered light this
way: the integrator adds it as patch radiance ``DHI_cloud f(theta) / sum(f h)`` (``h`` the patches'
horizontal projected solid angles), the unobstructed-plane path through :func:`overcast_poa_ratio`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cie_overcast_relative", "overcast_poa_ratio"]


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
