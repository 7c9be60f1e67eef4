"""Optics of one glazing layer per wavelength and angle of incidence (pure numpy).

Uncoated glass is a slab of refractive index ``n`` and extinction coefficient ``k``: Fresnel
reflection at both faces (s and p polarisation), Beer-Lambert absorption along the refracted path
and incoherent multiple reflections inside the slab (Rubin 1985, Sol. Energy Mater. 12, 275; the
route of ISO 15099:2003 section 7 and LBNL WINDOW/Optics for uncoated layers). The two polarisations
are averaged per layer (unpolarised light; the error of averaging per layer instead of through the
whole stack is below 0.005 in transmittance for clear double glazing up to 70 deg).

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

__all__ = ["fresnel_interface", "slab", "invert_slab", "coated_angular", "equivalent_slab",
           "hemispherical"]


def _check_aoi(aoi):
    aoi = np.asarray(aoi, dtype=float)
    bad = ~np.isfinite(aoi) | (aoi < 0) | (aoi > 90)
    if np.any(bad):
        raise ValueError(f"aoi={aoi[bad].ravel()[0]!r} deg outside [0, 90]")
    return aoi


def fresnel_interface(n, aoi):
    """Reflectance of an air/dielectric interface for s and p polarisation.

    Parameters
    ----------
    n : array_like
        Real refractive index of the dielectric [1] (>= 1).
    aoi : array_like
        Angle of incidence in air [deg], 0-90; broadcast against ``n``.

    Returns
    -------
    rs, rp : numpy.ndarray
        Interface reflectance for s and p polarised light [1].
    cos_t : numpy.ndarray
        Cosine of the refraction angle inside the dielectric [1].
    """
    n = np.asarray(n, dtype=float)
    if np.any(n < 1):
        raise ValueError(f"n={float(np.min(n))!r} outside [1, inf)")
    th = np.radians(_check_aoi(aoi))
    ci = np.cos(th)
    st = np.sin(th) / n
    ct = np.sqrt(np.maximum(1.0 - st * st, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = ((ci - n * ct) / (ci + n * ct)) ** 2
        rp = ((n * ci - ct) / (n * ci + ct)) ** 2
    grazing = ci <= 1e-12
    rs = np.where(grazing, 1.0, rs)
    rp = np.where(grazing, 1.0, rp)
    return rs, rp, ct


def slab(n, k, thickness_mm, wavelength_nm, aoi):
    """Transmittance and reflectance of an uncoated, non-scattering slab in air.

    Parameters
    ----------
    n, k : array_like
        Refractive index and extinction coefficient [1] per wavelength (K,).
    thickness_mm : float
        Slab thickness [mm].
    wavelength_nm : array_like
        (K,) wavelengths [nm].
    aoi : array_like
        (A,) angles of incidence [deg].

    Returns
    -------
    T, R : numpy.ndarray
        (A, K) transmittance and reflectance [1] (the same from both sides), unpolarised.
    """
    if not np.isfinite(thickness_mm) or thickness_mm <= 0:
        raise ValueError(f"thickness_mm={thickness_mm!r} outside (0, inf)")
    n = np.asarray(n, dtype=float)[None, :]
    k = np.asarray(k, dtype=float)[None, :]
    if np.any(k < 0):
        raise ValueError(f"k={float(np.min(k))!r} outside [0, inf)")
    lam = np.asarray(wavelength_nm, dtype=float)[None, :]
    aoi = np.atleast_1d(_check_aoi(aoi))[:, None]
    rs, rp, ct = fresnel_interface(n, aoi)
    alpha = 4.0 * np.pi * k / (lam * 1e-6)                      # [mm-1]
    with np.errstate(divide="ignore", over="ignore"):
        tau = np.where(ct > 1e-12, np.exp(-alpha * thickness_mm / np.maximum(ct, 1e-12)), 0.0)
    T = np.zeros(np.broadcast(rs, tau).shape)
    R = np.zeros_like(T)
    for r in (rs, rp):
        den = 1.0 - (r * tau) ** 2
        ok = den > 1e-15                                       # den = 0 only for r = 1 (grazing)
        q = np.where(ok, (1 - r) ** 2 / np.where(ok, den, 1.0), 0.0)
        T += 0.5 * q * tau
        R += 0.5 * (r + q * r * tau ** 2)
    return T, R


def invert_slab(T0, R0, thickness_mm, wavelength_nm):
    """Refractive index and extinction coefficient of a slab from its normal T and R.

    Inverts the normal-incidence slab equations of :func:`slab` (interface reflectance
    ``r = ((n - 1) / (n + 1))**2``, internal transmittance ``tau = exp(-4 pi k d / lambda)``)::

        T = (1 - r)^2 tau / (1 - r^2 tau^2),  R = r + r T tau

    Parameters
    ----------
    T0, R0 : array_like
        (K,) normal transmittance and reflectance [1], ``T0 + R0 <= 1``.
    thickness_mm : float
        [mm].
    wavelength_nm : array_like
        (K,) [nm].

    Returns
    -------
    n, k : numpy.ndarray
        (K,) [1]. Where T0 = 0 the slab is opaque: k is set so tau = 1e-9 and n from R0.
    """
    T0 = np.asarray(T0, dtype=float)
    R0 = np.asarray(R0, dtype=float)
    if np.any((T0 < 0) | (R0 < 0) | (T0 + R0 > 1 + 1e-9)):
        raise ValueError("T0 and R0 must be >= 0 with T0 + R0 <= 1")
    # eliminate tau: with R = r + r T tau -> tau = (R - r) / (r T); substitute into T's equation.
    # Quadratic in r:  (2 - R) r^2 - (1 + 2 R - R^2 + T^2) r + R = 0 (the smaller root is physical).
    a = 2.0 - R0
    b = -(1.0 + 2.0 * R0 - R0 ** 2 + T0 ** 2)
    disc = np.maximum(b * b - 4 * a * R0, 0.0)
    r = (-b - np.sqrt(disc)) / (2 * a)
    r = np.clip(r, 1e-8, 0.999)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(T0 > 0, (R0 - r) / (r * np.maximum(T0, 1e-12)), 0.0)
        tau = np.where((T0 > 0) & ~(tau > 0), T0 / (1 - r) ** 2, tau)   # R0 ~ r: weak inter-reflection
    tau = np.clip(tau, 1e-9, 1.0)
    sr = np.sqrt(r)
    n = (1 + sr) / (1 - sr)
    k = -np.log(tau) * np.asarray(wavelength_nm, dtype=float) * 1e-6 / (4 * np.pi * thickness_mm)
    return n, k


def coated_angular(T0, Rf0, Rb0, n_sub, k_sub, thickness_mm, wavelength_nm, aoi):
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
    Tu, Ru = slab(n_sub, k_sub, thickness_mm, wavelength_nm, aoi)
    Tu0, Ru0 = slab(n_sub, k_sub, thickness_mm, wavelength_nm, [0.0])
    with np.errstate(invalid="ignore", divide="ignore"):
        shape_t = np.where(Tu0 > 0, Tu / Tu0, 0.0)
        shape_r = np.where(Ru0 < 1, (Ru - Ru0) / (1 - Ru0), 1.0)
    T = np.asarray(T0, dtype=float)[None, :] * shape_t
    out = [T]
    for R0 in (Rf0, Rb0):
        R0 = np.asarray(R0, dtype=float)[None, :]
        R = R0 + (1 - R0) * shape_r
        out.append(np.minimum(R, 1.0 - T))
    return tuple(out)


def equivalent_slab(T0, Rf0, Rb0, thickness_mm, wavelength_nm, aoi):
    """Angular optics of a layer traced as the uncoated slab with the same normal T and R.

    The second route used to bound the uncertainty of :func:`coated_angular`: the normal values
    (front and back reflectance averaged) are inverted by :func:`invert_slab` into an n, k slab,
    whose angular ratios then scale the layer's own normal values as in :func:`coated_angular`.

    Parameters and returns as :func:`coated_angular` without the substrate.
    """
    n, k = invert_slab(T0, 0.5 * (np.asarray(Rf0) + np.asarray(Rb0)), thickness_mm, wavelength_nm)
    return coated_angular(T0, Rf0, Rb0, n, k, thickness_mm, wavelength_nm, aoi)


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
