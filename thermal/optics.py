"""Optics of one glazing layer per wavelength and angle of incidence (pure numpy).

Uncoated glass is a slab of refractive index ``n`` and extinction coefficient ``k``: Fresnel
reflection at both faces (s and p polarisation), Beer-Lambert absorption along the refracted path
and incoherent multiple reflections inside the slab (Rubin 1985, Sol. Energy Mater. 12, 275; the
route of ISO 15099:2003 section 7 and LBNL WINDOW/Optics for uncoated layers): :func:`slab`,
:func:`invert_slab` and :func:`fresnel_interface`, shared with pvsim's cover glass, live in
:mod:`widesky.core.fresnel` and are re-exported here. Multi-layer units
carry the s and p polarisations through the stack separately (``polarised=True``) and average at
the end: averaging per layer instead would underestimate the solar transmittance of clear double
glazing by 0.025 at 60 deg and 0.031 at 70 deg (measured, docs/thermal.md).

A coated layer has measured normal-incidence spectra only (IGDB/Optics files: T, Rfront, Rback).
Its angular behaviour is obtained from its substrate: the layer keeps its own normal-incidence
values and follows the angular *shape* of the uncoated substrate slab (n, k inverted from the
substrate's own normal spectra, or the coated layer's if no substrate is given)::

    T(theta)  = T(0) * Tu(theta) / Tu(0)
    R(theta)  = R(0) + (1 - R(0)) * (Ru(theta) - Ru(0)) / (1 - Ru(0))

so that T -> 0 and R -> 1 at grazing incidence and the layer's energy balance holds. This is the
"scaled uncoated substrate" approximation; thin-film stacks of real low-e and solar-control
coatings deviate from it. Its uncertainty is estimated in :func:`coated_angular` docs and in
docs/thermal.md by the spread against a second route, the equivalent slab (the coated layer's own
normal T and R inverted into an n, k slab and traced by Fresnel).

Units: wavelength [nm], thickness [mm], angles [deg], optical quantities [1].
"""

from __future__ import annotations

import numpy as np

from widesky.core.fresnel import fresnel_interface, invert_slab, slab

__all__ = ["fresnel_interface", "slab", "invert_slab", "coated_angular", "equivalent_slab",
           "hemispherical"]


def coated_angular(T0, Rf0, Rb0, n_sub, k_sub, thickness_mm, wavelength_nm, aoi, polarised=False):
    """Angular optics of a coated layer by the scaled-substrate rule (module docstring).

    Parameters
    ----------
    T0, Rf0, Rb0 : array_like
        (K,) normal transmittance and front/back reflectance of the coated layer [1].
    n_sub, k_sub : array_like
        (K,) the uncoated substrate's refractive index and extinction coefficient [1]
        (e.g. from :func:`invert_slab` on the substrate's file).
    thickness_mm : float
        Substrate thickness [mm].
    wavelength_nm : array_like
        (K,) [nm].
    aoi : array_like
        (A,) [deg].
    polarised : bool
        Apply the substrate's s and p shapes separately and return ((T, Rf, Rb)_s, (...)_p).

    Returns
    -------
    T, Rf, Rb : numpy.ndarray
        (A, K) [1]; ``T + R <= 1`` on each side.

    Notes
    -----
    Uncertainty: the rule is exact for an uncoated layer (it reproduces :func:`slab`), and for
    coated layers it is an approximation. docs/thermal.md measures its spread against the
    equivalent-slab route (:func:`equivalent_slab`) for the sample low-e layer.
    """
    pol = slab(n_sub, k_sub, thickness_mm, wavelength_nm, aoi, polarised=True)
    Tu0, Ru0 = slab(n_sub, k_sub, thickness_mm, wavelength_nm, [0.0])
    res = []
    for Tu, Ru in (pol if polarised else [tuple(0.5 * (a + b) for a, b in zip(*pol))]):
        with np.errstate(invalid="ignore", divide="ignore"):
            shape_t = np.where(Tu0 > 0, Tu / Tu0, 0.0)
            shape_r = np.where(Ru0 < 1, (Ru - Ru0) / (1 - Ru0), 1.0)
        T = np.asarray(T0, dtype=float)[None, :] * shape_t
        out = [T]
        for R0 in (Rf0, Rb0):
            R0 = np.asarray(R0, dtype=float)[None, :]
            out.append(np.minimum(R0 + (1 - R0) * shape_r, 1.0 - T))
        res.append(tuple(out))
    return tuple(res) if polarised else res[0]


def equivalent_slab(T0, Rf0, Rb0, thickness_mm, wavelength_nm, aoi, polarised=False):
    """Angular optics of a layer traced as the uncoated slab with the same normal T and R.

    The second route used to bound the uncertainty of :func:`coated_angular`: the normal values
    (front and back reflectance averaged) are inverted by :func:`invert_slab` into an n, k slab,
    whose angular ratios then scale the layer's own normal values as in :func:`coated_angular`.

    Parameters and returns as :func:`coated_angular` without the substrate.
    """
    n, k = invert_slab(T0, 0.5 * (np.asarray(Rf0) + np.asarray(Rb0)), thickness_mm, wavelength_nm)
    return coated_angular(T0, Rf0, Rb0, n, k, thickness_mm, wavelength_nm, aoi, polarised)


def hemispherical(aoi_deg, values):
    """Hemispherical (diffuse, cosine-weighted) average of an angular quantity.

    ``2 * integral_0^90 f(theta) cos(theta) sin(theta) dtheta`` by the trapezoid rule in
    ``sin^2(theta)``.

    Parameters
    ----------
    aoi_deg : array_like
        (A,) increasing angles [deg] from 0 to 90.
    values : array_like
        (A, ...) the quantity [any unit] at those angles.

    Returns
    -------
    numpy.ndarray
        (...) the diffuse value [same unit].
    """
    a = np.asarray(aoi_deg, dtype=float)
    if a[0] != 0 or a[-1] != 90 or np.any(np.diff(a) <= 0):
        raise ValueError("aoi_deg must increase from 0 to 90 deg")
    s2 = np.sin(np.radians(a)) ** 2
    v = np.asarray(values, dtype=float)
    w = np.diff(s2)
    mid = 0.5 * (v[1:] + v[:-1])
    return np.tensordot(w, mid, axes=(0, 0))
