"""Fresnel and slab optics shared by pvsim (cover glass) and thermal (glazing layers), pure numpy.

- :func:`fresnel_interface`: s and p reflectances of one dielectric interface (Born & Wolf, Principles of Optics,
  section 1.5), and the cosine of the refraction angle; total internal reflection and grazing incidence give 1.
- :func:`slab`: an uncoated, non-scattering slab in air: Fresnel reflection at both faces, Beer-Lambert
  absorption along the refracted path and incoherent multiple reflections inside (Rubin 1985, Sol. Energy
  Mater. 12, 275; the route of ISO 15099:2003 section 7 and LBNL WINDOW/Optics for uncoated layers).
- :func:`invert_slab`: the slab's n and k from its normal-incidence T and R.

Units: wavelength [nm], thickness [mm], angles [deg], optical quantities [1].
"""

from __future__ import annotations

import numpy as np

__all__ = ["fresnel_interface", "slab", "invert_slab"]

_GRAZING_COS = 1e-12
"""Cosines of incidence at or below this are grazing: both reflectances are 1 [1]."""


def _check_aoi(aoi):
    """``aoi`` [deg] as a float array after checking it is finite and within [0, 90]; ValueError naming it."""
    aoi = np.asarray(aoi, dtype=float)
    bad = ~np.isfinite(aoi) | (aoi < 0) | (aoi > 90)
    if np.any(bad):
        raise ValueError(f"aoi={aoi[bad].ravel()[0]!r} deg outside [0, 90]")
    return aoi


def fresnel_interface(n1, n2, cos_incidence):
    """Reflectances of one dielectric interface.

    Parameters
    ----------
    n1, n2 : float or array_like
        Refractive indices of the incidence and transmission media [1] (broadcast together).
    cos_incidence : array_like
        Cosine of the incidence angle in medium 1 [1], in [0, 1] (clipped to it).

    Returns
    -------
    r_s, r_p : numpy.ndarray
        Reflectances for s and p polarisation [1] (1 at grazing incidence and under total internal
        reflection).
    cos_refraction : numpy.ndarray
        Cosine of the refraction angle in medium 2 [1] (total internal reflection: 0).
    """
    ci = np.clip(np.asarray(cos_incidence, dtype=float), 0.0, 1.0)
    sin_t = n1 / n2 * np.sqrt(1.0 - ci * ci)
    ct = np.sqrt(np.clip(1.0 - sin_t * sin_t, 0.0, 1.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = ((n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)) ** 2
        rp = ((n1 * ct - n2 * ci) / (n1 * ct + n2 * ci)) ** 2
    full = (sin_t >= 1.0) | (ci <= _GRAZING_COS)
    rs = np.where(full | ~np.isfinite(rs), 1.0, rs)
    rp = np.where(full | ~np.isfinite(rp), 1.0, rp)
    return rs, rp, ct


def slab(n, k, thickness_mm, wavelength_nm, aoi, polarised=False):
    """Transmittance and reflectance of an uncoated, non-scattering slab in air.

    Parameters
    ----------
    n, k : array_like
        Refractive index (>= 1) and extinction coefficient (>= 0) [1] per wavelength (K,).
    thickness_mm : float
        Slab thickness [mm].
    wavelength_nm : array_like
        (K,) wavelengths [nm].
    aoi : array_like
        (A,) angles of incidence [deg], 0-90.
    polarised : bool
        Return the s and p values separately.

    Returns
    -------
    T, R : numpy.ndarray
        (A, K) transmittance and reflectance [1] (the same from both sides), unpolarised; with
        ``polarised``: ((T_s, R_s), (T_p, R_p)).
    """
    if not np.isfinite(thickness_mm) or thickness_mm <= 0:
        raise ValueError(f"thickness_mm={thickness_mm!r} outside (0, inf)")
    n = np.asarray(n, dtype=float)[None, :]
    if np.any(n < 1):
        raise ValueError(f"n={float(np.min(n))!r} outside [1, inf)")
    k = np.asarray(k, dtype=float)[None, :]
    if np.any(k < 0):
        raise ValueError(f"k={float(np.min(k))!r} outside [0, inf)")
    lam = np.asarray(wavelength_nm, dtype=float)[None, :]
    aoi = np.atleast_1d(_check_aoi(aoi))[:, None]
    rs, rp, ct = fresnel_interface(1.0, n, np.cos(np.radians(aoi)))
    alpha = 4.0 * np.pi * k / (lam * 1e-6)                      # [mm-1]
    with np.errstate(divide="ignore", over="ignore"):
        tau = np.where(ct > 1e-12, np.exp(-alpha * thickness_mm / np.maximum(ct, 1e-12)), 0.0)
    out = []
    for r in (rs, rp):
        den = 1.0 - (r * tau) ** 2
        ok = den > 1e-15                                       # den = 0 only for r = 1 (grazing)
        q = np.where(ok, (1 - r) ** 2 / np.where(ok, den, 1.0), 0.0)
        out.append((q * tau, r + q * r * tau ** 2))
    if polarised:
        return tuple(out)
    return 0.5 * (out[0][0] + out[1][0]), 0.5 * (out[0][1] + out[1][1])


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
