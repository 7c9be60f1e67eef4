"""Cover-glass optics: Fresnel transmission with absorption, an optional anti-reflection layer,
and a wavelength-dependent (spectral) incidence angle modifier.

Model (De Soto et al., Solar Energy 80 (2006) 78; Duffie & Beckman, Solar Engineering of Thermal
Processes, 3rd ed., section 5.3): unpolarised light crosses the air/cover interface (through an
optional AR layer of index ``n_ar``: both interfaces with incoherent multiple reflections between
them), then the cover of thickness L with absorption coefficient K along the refracted path,
``exp(-K L / cos theta_r)``; s and p are averaged after absorption. The incidence angle modifier is
the transmittance normalised to normal incidence (the STC rating includes the normal-incidence loss).
This is the model behind ``pvlib.iam.physical``; the tests compare the two. The interface reflectances
(:func:`fresnel_interface`) are :mod:`widesky.core.fresnel`'s, shared with thermal's glazing.
"""

from __future__ import annotations

import numpy as np

from widesky.core.fresnel import fresnel_interface

__all__ = ["fresnel_interface", "cover_transmittance", "cover_iam", "spectral_cover_iam",
           "extinction_to_absorption", "rubin_soda_lime_index"]


def _check_positive(name, value, lo=0.0, strict=True):
    v = np.asarray(value, dtype=float)
    bad = ~np.isfinite(v) | ((v <= lo) if strict else (v < lo))
    if np.any(bad):
        op = ">" if strict else ">="
        raise ValueError(f"{name}={np.asarray(value)[bad].ravel()[0]!r} must be finite and {op} {lo:g}")
    return v


def _through_interfaces(indices, cos_incidence):
    """s and p transmittance through a stack of interfaces (incoherent), and the final cos."""
    ts, tp = None, None
    c = cos_incidence
    for n1, n2 in zip(indices[:-1], indices[1:]):
        rs, rp, c2 = fresnel_interface(n1, n2, c)
        if ts is None:
            ts, tp, prs, prp = 1.0 - rs, 1.0 - rp, rs, rp
        else:
            # incoherent multiple reflections between this interface and the previous one
            ts = ts * (1.0 - rs) / (1.0 - rs * prs)
            tp = tp * (1.0 - rp) / (1.0 - rp * prp)
            prs, prp = rs, rp
        c = c2
    return ts, tp, c


def cover_transmittance(aoi, n=1.526, K=4.0, L=0.002, n_ar=None):
    """Transmittance of a cover into the cell side, Fresnel with absorption.

    Parameters
    ----------
    aoi : array_like
        Angle of incidence [deg]; >= 90 gives 0.
    n : float or array_like
        Cover refractive index [1], > 1 (an array broadcasts against ``aoi``, e.g. per wavelength).
    K : float or array_like
        Absorption coefficient of the cover [m-1], >= 0.
    L : float
        Cover thickness [m], >= 0.
    n_ar : float, optional
        Refractive index of an anti-reflection layer [1], between 1 and ``n``.

    Returns
    -------
    numpy.ndarray
        Transmittance [1].
    """
    a = np.asarray(aoi, dtype=float)
    if np.any(~np.isfinite(a)) or np.any(a < 0) or np.any(a > 180):
        raise ValueError("aoi must be finite in [0, 180] deg")
    n = _check_positive("n", n, 1.0)
    K = _check_positive("K", K, 0.0, strict=False)
    L = _check_positive("L", L, 0.0, strict=False)
    if n_ar is not None:
        n_ar = _check_positive("n_ar", n_ar, 1.0, strict=False)
        if np.any(n_ar > n):
            raise ValueError(f"n_ar={n_ar!r} must lie between 1 and the cover's n")
    c = np.cos(np.radians(np.minimum(a, 90.0)))
    indices = (1.0, n) if n_ar is None or np.allclose(n_ar, 1.0) or np.allclose(n_ar, n) else (1.0, n_ar, n)
    ts, tp, cr = _through_interfaces(indices, c)
    with np.errstate(divide="ignore"):
        absorb = np.exp(-K * L / np.where(cr > 0, cr, np.inf)) if np.any(K * L) else 1.0
    absorb = np.where(cr > 0, absorb, 0.0)
    return np.where(a >= 90.0, 0.0, 0.5 * (ts + tp) * absorb)


def cover_iam(aoi, n=1.526, K=4.0, L=0.002, n_ar=None):
    """Incidence angle modifier [1]: ``cover_transmittance(aoi) / cover_transmittance(0)``.

    Parameters as :func:`cover_transmittance` (pvlib.iam.physical's names and defaults).
    """
    t0 = cover_transmittance(0.0, n, K, L, n_ar)
    return cover_transmittance(aoi, n, K, L, n_ar) / t0


def extinction_to_absorption(k, wavelength):
    """Absorption coefficient K = 4 pi k / lambda [m-1] from the extinction coefficient k [1] at [nm]."""
    return 4.0 * np.pi * np.asarray(k, dtype=float) / (np.asarray(wavelength, dtype=float) * 1e-9)


def spectral_cover_iam(aoi, wavelength, n, k=0.0, L=0.0032, n_ar=None):
    """Angle x wavelength modifier of a cover with a wavelength-dependent index.

    Parameters
    ----------
    aoi : array_like (A,)
        [deg].
    wavelength : array_like (K,)
        [nm].
    n, k : array_like (K,) or float
        Real index and extinction coefficient at ``wavelength`` [1].
    L : float
        Thickness [m].
    n_ar : float, optional
        AR layer index [1].

    Returns
    -------
    numpy.ndarray (A, K)
        Transmittance at each angle divided by that at normal incidence, per wavelength [1] (the
        normal-incidence spectral transmittance is part of the measured EQE of a module).
    """
    a = np.asarray(aoi, dtype=float)[:, None]
    w = np.asarray(wavelength, dtype=float)
    nn = np.broadcast_to(np.asarray(n, dtype=float), w.shape)[None, :]
    K = extinction_to_absorption(np.broadcast_to(np.asarray(k, dtype=float), w.shape), w)[None, :]
    t = cover_transmittance(a, nn, K, L, n_ar)
    t0 = cover_transmittance(np.zeros((1, 1)), nn, K, L, n_ar)
    return t / np.where(t0 > 0, t0, 1.0)


def rubin_soda_lime_index(wavelength, coefficients=(1.5130, -0.003169, 2.0, 0.003962, -2.0)):
    """Real index of soda-lime glass, Rubin (Sol. Energy Mater. 12 (1985) 275):
    ``n = c0 + c1 lambda**c2 + c3 lambda**c4`` with lambda in um; defaults: Rubin's fit for clear and
    low-iron glass (valid 0.31-4.6 um). ``wavelength`` in [nm]; returns n [1]."""
    lam = np.asarray(wavelength, dtype=float) * 1e-3
    c0, c1, c2, c3, c4 = coefficients
    return c0 + c1 * lam ** c2 + c3 * lam ** c4
