"""Ozone absorption from temperature-dependent measured cross-sections.

Bogumil, K. et al. (2003), Measurements of molecular absorption spectra with the SCIAMACHY pre-flight model,
J. Photochem. Photobiol. A 157, 167-184: 230-1066.2 nm at 0.1 nm, sigma = (C0 + C1 (T - 273.15)
+ C2 (T - 273.15)^2) x 1e-20 cm2, read from ``ozone/crs_O3_UBremen_cf.dat`` in the data directory.
The coefficients are averaged over 1 nm bins (sigma is linear in them, so this equals the bin-mean
cross-section at any temperature). Beyond 1066 nm ozone absorption is taken as zero.
"""

from __future__ import annotations

import functools

import numpy as np

from widesky.core.spectral import band_average

from .paths import data_file

T0 = 273.15


@functools.lru_cache(maxsize=4)
def _coefficients(data_dir):
    a = np.loadtxt(data_file("ozone/crs_O3_UBremen_cf.dat", data_dir), comments="#")
    edges = np.arange(280.0, 2481.0, 1.0)
    out = np.zeros((3, len(edges) - 1))
    inside = edges[1:] <= a[-1, 0]
    for k in range(3):
        e = edges[: inside.sum() + 1]
        out[k, inside] = band_average(a[:, 0], a[:, 1 + k], e[:-1], e[1:], outside="hold")
    return out * 1e-20


def ozone_cross_section(temperature_k, data_dir=None) -> np.ndarray:
    """Ozone absorption cross-section averaged over the 1 nm bins of 280-2480 nm.

    Parameters
    ----------
    temperature_k : array_like, shape (L,)
        Temperatures [K] (valid about 190-300 K).
    data_dir : path-like, optional
        Input data directory.

    Returns
    -------
    numpy.ndarray, shape (L, 2200)
        Cross-section [cm2 per molecule] on :data:`widesky.skymodel.channels.FINE_WAVELENGTHS_NM`.
    """
    c = _coefficients(None if data_dir is None else str(data_dir))
    dt = np.atleast_1d(np.asarray(temperature_k, float))[:, None] - T0
    return np.maximum(c[0][None, :] + c[1][None, :] * dt + c[2][None, :] * dt * dt, 0.0)


def ozone_optical_depth(atmosphere, data_dir=None) -> np.ndarray:
    """Ozone absorption optical depth per layer on the 1 nm grid [1], shape (L, 2200)."""
    return ozone_cross_section(atmosphere.temperature_k, data_dir) * atmosphere.o3[:, None]
