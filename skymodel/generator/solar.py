"""Extraterrestrial solar spectrum, band-averaged on the 1 nm grid and per 40 nm channel.

Sources (read from the data directory, see :mod:`skymodel.generator.paths`):

- ``tsis1`` (default): TSIS-1 Hybrid Solar Reference Spectrum v2, 1 nm resolution
  (Coddington et al. 2023, Earth Space Sci. 10, e2022EA002637), ``solar/tsis1_hsrs_v2_1nm_270-2530nm.csv``.
- ``g173``: the extraterrestrial column of ASTM G173-03 (Gueymard 2004 synthetic spectrum as used by SMARTS 2.9.2),
  ``solar/ASTMG173.csv``; used to isolate the atmosphere in the G173 validation.
- ``e490``: ASTM E-490 (2000), ``solar/e490_00a.dat``.
- ``kurucz``: Kurucz (1992) 1 nm, ``solar/kurudz_1.0nm.dat``.

All at 1 AU. Wavelengths of TSIS-1 are in vacuum, the others in air; the difference (< 0.7 nm) is
neglected against the 40 nm channels.
"""

from __future__ import annotations

import functools

import numpy as np

from ..solar import extraterrestrial_spectrum
from .channels import FINE_WAVELENGTHS_NM, N_CHANNELS
from .paths import data_file

SOURCES = ("tsis1", "g173", "e490", "kurucz")


def _read_source(source: str, data_dir):
    if source == "tsis1":
        a = np.loadtxt(data_file("solar/tsis1_hsrs_v2_1nm_270-2530nm.csv", data_dir), delimiter=",",
                       comments="#", skiprows=3, usecols=(0, 1))
        return a[:, 0], a[:, 1]
    if source == "g173":
        a = np.loadtxt(data_file("solar/ASTMG173.csv", data_dir), delimiter=",", skiprows=2, usecols=(0, 1))
        return a[:, 0], a[:, 1]
    if source == "e490":
        a = np.loadtxt(data_file("solar/e490_00a.dat", data_dir))
        return a[:, 0] * 1000.0, a[:, 1] / 1000.0  # um -> nm, W m-2 um-1 -> W m-2 nm-1
    if source == "kurucz":
        a = np.loadtxt(data_file("solar/kurudz_1.0nm.dat", data_dir), comments="#")
        return a[:, 0], a[:, 1] / 1000.0  # mW m-2 nm-1 -> W m-2 nm-1
    raise ValueError(f"source={source!r}: valid extraterrestrial spectra are {SOURCES}")


def _bin_average(wl, val, edges):
    """Exact mean over each [edges[i], edges[i+1]] of the piecewise-linear interpolant of (wl, val)."""
    grid = np.union1d(wl[(wl > edges[0]) & (wl < edges[-1])], edges)
    v = np.interp(grid, wl, val)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(grid))])
    at = np.interp(edges, grid, cum)
    return np.diff(at) / np.diff(edges)


@functools.lru_cache(maxsize=8)
def _fine(source, data_dir):
    wl, val = _read_source(source, data_dir)
    edges = np.arange(280.0, 2481.0, 1.0)
    return _bin_average(wl, val, edges)


def binned_source(source: str, data_dir=None):
    """A named source averaged over 1 nm bins 280-2480 nm at 1 AU: (bin centres [nm], shape (2200,),
    bin-mean irradiance [W m-2 nm-1]). Called through :func:`skymodel.solar.extraterrestrial_spectrum`,
    the one extraterrestrial-spectrum function."""
    return FINE_WAVELENGTHS_NM.copy(), _fine(source, None if data_dir is None else str(data_dir)).copy()


def channel_extraterrestrial(source: str = "tsis1", data_dir=None) -> np.ndarray:
    """Band-mean extraterrestrial spectral irradiance per channel [W m-2 nm-1], shape (55,), at 1 AU, of a
    named source (see :func:`skymodel.solar.extraterrestrial_spectrum`)."""
    _, e = extraterrestrial_spectrum(source, data_dir)
    return e.reshape(N_CHANNELS, 40).mean(axis=1)


def earth_sun_distance_factor(day_of_year) -> np.ndarray:
    """Eccentricity correction (r0/r)^2 [1] for a day of year [1-366], Spencer (1971) Fourier series."""
    g = 2.0 * np.pi * (np.asarray(day_of_year, float) - 1.0) / 365.0
    return (1.000110 + 0.034221 * np.cos(g) + 0.001280 * np.sin(g) + 0.000719 * np.cos(2 * g)
            + 0.000077 * np.sin(2 * g))


