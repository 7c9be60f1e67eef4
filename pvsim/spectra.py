"""Spectral bookkeeping for PV: SR <-> EQE, photon flux, band averages and the AM1.5G reference.

Conventions: wavelength [nm], spectral irradiance [W m-2 nm-1], spectral response SR [A W-1],
external quantum efficiency EQE [1]. ``qe_to_sr`` and ``sr_to_qe`` carry pvlib's names and meaning
(pvlib.spectrum.qe_to_sr / sr_to_qe): SR = EQE * lambda * q / (h c).

The reference spectrum (ASTM G173-03 / IEC 60904-3 AM1.5 global tilted) is read from a file the user
names, else from the copy shipped in the package (``widesky/data/solar/ASTMG173.csv``, pvlib's BSD-3
redistribution; :func:`widesky.core.paths.runtime_file`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from widesky.core.paths import runtime_file
from widesky.core.spectral import ELEMENTARY_CHARGE, HC_EV_NM, PLANCK, SPEED_OF_LIGHT, band_average
from widesky.skymodel.channels import CHANNEL_EDGES_NM

__all__ = ["PLANCK", "SPEED_OF_LIGHT", "ELEMENTARY_CHARGE", "HC_EV_NM", "qe_to_sr", "sr_to_qe",
           "photon_flux", "band_average", "channel_edges", "read_astm_g173", "am15g",
           "am15g_channels"]


_SR_PER_QE_PER_NM = ELEMENTARY_CHARGE / (PLANCK * SPEED_OF_LIGHT) * 1e-9   # [A W-1 nm-1]


def _wavelength_array(wavelength, n, name="wavelength"):
    w = np.asarray(wavelength, dtype=float)
    if w.shape != (n,) and w.shape != ():
        raise ValueError(f"{name} must have shape ({n},) like the curve, got {w.shape}")
    if np.any(~np.isfinite(w)) or np.any(w <= 0):
        raise ValueError(f"{name} must be positive and finite [nm], got min {np.nanmin(w)!r}")
    return w


def _normalize(a):
    m = np.max(a, axis=-1, keepdims=True) if a.ndim else a
    return a / np.where(m > 0, m, 1.0)


def _convert(values, wavelength, to_sr, normalize):
    v = np.asarray(values, dtype=float)
    w = _wavelength_array(wavelength, v.shape[-1] if v.ndim else 1)
    out = v * w * _SR_PER_QE_PER_NM if to_sr else v / (w * _SR_PER_QE_PER_NM)
    return _normalize(out) if normalize else out


def qe_to_sr(qe, wavelength, normalize=False):
    """Spectral response from quantum efficiency, SR = EQE * lambda * q / (h c).

    Parameters
    ----------
    qe : array_like (..., K)
        Quantum efficiency [1].
    wavelength : array_like (K,)
        [nm].
    normalize : bool
        Divide by the maximum along the last axis (as pvlib).

    Returns
    -------
    numpy.ndarray (..., K)
        Spectral response [A W-1] (relative [1] when normalised).
    """
    return _convert(qe, wavelength, True, normalize)


def sr_to_qe(sr, wavelength, normalize=False):
    """Quantum efficiency from spectral response, EQE = SR * h c / (q lambda).

    Parameters
    ----------
    sr : array_like (..., K)
        Spectral response [A W-1].
    wavelength : array_like (K,)
        [nm].
    normalize : bool
        Divide by the maximum along the last axis (as pvlib).

    Returns
    -------
    numpy.ndarray (..., K)
        Quantum efficiency [1].
    """
    return _convert(sr, wavelength, False, normalize)


def photon_flux(spectral_irradiance, wavelength):
    """Spectral photon flux density Phi = E lambda / (h c).

    Parameters
    ----------
    spectral_irradiance : array_like (..., K)
        [W m-2 nm-1].
    wavelength : array_like (K,)
        [nm].

    Returns
    -------
    numpy.ndarray (..., K)
        [photons s-1 m-2 nm-1].
    """
    e = np.asarray(spectral_irradiance, dtype=float)
    w = _wavelength_array(wavelength, e.shape[-1] if e.ndim else 1)
    return e * w * 1e-9 / (PLANCK * SPEED_OF_LIGHT)


def channel_edges():
    """The Prague Sky Model's channel edges: 55 channels of 40 nm, 280-2480 nm, (56,) [nm]."""
    return CHANNEL_EDGES_NM.copy()


def read_astm_g173(path=None, data_dir=None):
    """Read the ASTM G173-03 reference spectra.

    Parameters
    ----------
    path : str or Path, optional
        The CSV as distributed by NREL (two header lines; columns wavelength [nm], extraterrestrial,
        global 37 deg tilt, direct + circumsolar [W m-2 nm-1]). Default the copy shipped in the package.
    data_dir : str or Path, optional
        Read ``solar/ASTMG173.csv`` from this folder instead of the shipped copy.

    Returns
    -------
    dict
        ``wavelength`` (K,) [nm]; ``extraterrestrial``, ``global``, ``direct`` (K,) [W m-2 nm-1].
    """
    p = Path(path) if path is not None else runtime_file("solar/ASTMG173.csv", data_dir)
    try:
        df = pd.read_csv(p, skiprows=1)
    except (OSError, ValueError) as exc:
        raise ValueError(f"cannot read ASTM G173 file {str(p)!r}: {exc}") from exc
    cols = [c.strip().lower() for c in df.columns]
    need = ("wavelength", "extraterrestrial", "global", "direct")
    if tuple(cols[:4]) != need:
        raise ValueError(f"ASTM G173 file {str(p)!r}: expected columns {need}, got {tuple(cols)}")
    arr = df.to_numpy(dtype=float)
    if np.any(np.diff(arr[:, 0]) <= 0) or not np.all(np.isfinite(arr)):
        raise ValueError(f"ASTM G173 file {str(p)!r}: wavelengths must increase and values be finite")
    return {k: arr[:, i] for i, k in enumerate(need)}


def am15g(path=None, data_dir=None):
    """AM1.5 global tilted reference spectrum (ASTM G173-03): (wavelength (K,) [nm], E (K,) [W m-2 nm-1])."""
    g = read_astm_g173(path, data_dir)
    return g["wavelength"], g["global"]


def am15g_channels(edges=None, path=None, data_dir=None):
    """AM1.5G band-averaged onto channels.

    Parameters
    ----------
    edges : array_like (C+1,), optional
        Channel edges [nm] (default the PSM's 55 channels, 280-2480 nm).

    Returns
    -------
    numpy.ndarray (C,)
        Mean spectral irradiance per channel [W m-2 nm-1]; times the channel widths and summed, the
        G173 global integral over the channels' range (991.3 W m-2 for 280-2480 nm, of 1000.4 in all).
    """
    e = channel_edges() if edges is None else np.asarray(edges, dtype=float)
    w, g = am15g(path, data_dir)
    return band_average(w, g, e[:-1], e[1:])
