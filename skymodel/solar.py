"""Extraterrestrial solar spectrum used for sun radiance.

The dataset file holds no solar spectrum (the reference implementation has one built in), so widesky
ships its own: ASTM E-490-00a (zero air mass solar spectral irradiance, ASTM International 2000 /
NREL distribution), as shipped by the Apache-2.0 PyPI package ``pyspectral`` (file
``pyspectral/data/e490_00a.dat``), re-binned by us to 1 nm bins centred on integer wavelengths
280-2500 nm (``skymodel/data/solar_e490_1nm.csv``; regenerate with
``python -m widesky.skymodel.solar E490_FILE``). A dataset's JSON sidecar may carry the spectrum it was built
with (key ``extraterrestrial``); the evaluator then uses that one instead.

Sun radiance is irradiance divided by the solid angle of the solar disc (radius 0.2667 deg, the
reference's value; limb darkening is ignored, as in the reference).
"""

from __future__ import annotations

import sys
from functools import lru_cache
from pathlib import Path

import numpy as np

from widesky.core.paths import data_file
from widesky.core.spectral import band_average

from .channels import FINE_WAVELENGTHS_NM

__all__ = ["SUN_RADIUS", "SUN_SOLID_ANGLE", "SOURCES", "extraterrestrial_spectrum", "rebin_1nm"]

SUN_RADIUS = 0.004654793
"""Angular radius of the solar disc [rad] (0.2667 deg), as in the reference implementation."""

SUN_SOLID_ANGLE = 2.0 * np.pi * (1.0 - np.cos(SUN_RADIUS))
"""Solid angle of the solar disc [sr]."""

_TABLE = Path(__file__).resolve().parent / "data" / "solar_e490_1nm.csv"


@lru_cache(maxsize=1)
def _shipped():
    data = np.loadtxt(_TABLE, delimiter=",", comments="#")
    return data[:, 0].copy(), data[:, 1].copy()


SOURCES = ("tsis1", "g173", "e490", "kurucz")
"""Named extraterrestrial spectra read from the reference data folder (:func:`extraterrestrial_spectrum`):

- ``tsis1``: TSIS-1 Hybrid Solar Reference Spectrum v2, 1 nm resolution (Coddington et al. 2023, Earth Space
  Sci. 10, e2022EA002637), ``solar/tsis1_hsrs_v2_1nm_270-2530nm.csv`` (the generator's default);
- ``g173``: the extraterrestrial column of ASTM G173-03 (Gueymard 2004 synthetic spectrum as used by SMARTS
  2.9.2), ``solar/ASTMG173.csv``; used to isolate the atmosphere in the G173 validation;
- ``e490``: ASTM E-490 (2000), ``solar/e490_00a.dat``;
- ``kurucz``: Kurucz (1992) 1 nm, ``solar/kurudz_1.0nm.dat``.

All at 1 AU. Wavelengths of TSIS-1 are in vacuum, the others in air; the difference (< 0.7 nm) is neglected
against the 40 nm channels."""


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


@lru_cache(maxsize=8)
def _fine(source, data_dir):
    """A named source averaged over the 1 nm bins 280-2480 nm (:data:`FINE_WAVELENGTHS_NM`)."""
    wl, val = _read_source(source, data_dir)
    return band_average(wl, val, FINE_WAVELENGTHS_NM - 0.5, FINE_WAVELENGTHS_NM + 0.5, outside="hold")


def extraterrestrial_spectrum(source=None, data_dir=None):
    """The extraterrestrial solar spectrum at the mean Sun-Earth distance (1 AU): widesky's one function
    for it, used by the evaluator (sun radiance) and the dataset generator.

    Parameters
    ----------
    source : str, optional
        None (default): the shipped ASTM E-490 table, 1 nm bins centred on 280, 281, ... 2500 nm (no data
        directory needed). A name of :data:`SOURCES` (``'tsis1'``, ``'g173'``,
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
    return FINE_WAVELENGTHS_NM.copy(), _fine(source, None if data_dir is None else str(data_dir)).copy()


def rebin_1nm(wavelength, irradiance, start=280, stop=2500):
    """Re-bin a spectrum to 1 nm bins centred on integer wavelengths ``start..stop`` [nm]."""
    centres = np.arange(start, stop + 1, dtype=float)
    return centres, band_average(wavelength, irradiance, centres - 0.5, centres + 0.5, outside="raise")


def _main(argv):
    """Regenerate the shipped table from an E-490 file (µm, W m-2 µm-1)."""
    if len(argv) != 1:
        print("usage: python -m widesky.skymodel.solar E490_FILE", file=sys.stderr)
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
