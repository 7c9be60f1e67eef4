"""Optical constants of the OPAC components (Hess, Koepke & Schult 1998, Bull. Am. Meteorol. Soc. 79, 831, "OPAC").

The complex refractive index of an OPAC component (``inso``, ``waso``, ``soot``; ``stco``, the stratus-continental
water cloud, for liquid water) by wavelength, read from the reference data folder
(``aerosol_opac/refractive_indices/<comp><rh>_refr.dat``, not shipped: :mod:`widesky.core.paths`). Shared by the
dataset generator's aerosol Mie optics (:mod:`widesky.skymodel.generator.aerosol`) and the all-sky model's
cloud-droplet optics (:mod:`widesky.irradiance.cloud_optics`).

Units: wavelength [nm], refractive index [1], relative humidity [%].
"""

from __future__ import annotations

import functools

import numpy as np

from widesky.core.paths import data_file

__all__ = ["HUMIDITIES", "humidity_tag", "refractive_index"]

HUMIDITIES = (0, 50, 70, 80, 90, 95, 98, 99)
"""Relative humidities [%] of OPAC's tables of the water-soluble component (WASO)."""


def humidity_tag(component, rh):
    """The relative humidity [%] of the table to read for ``component``: ``rh`` for WASO (one of
    :data:`HUMIDITIES`, else ValueError), 0 for the components that do not take up water."""
    if component != "waso":
        return 0
    if rh not in HUMIDITIES:
        raise ValueError(f"relative_humidity={rh}: OPAC tables exist for {HUMIDITIES} %")
    return rh


@functools.lru_cache(maxsize=32)
def _refr_table(component, rh, data_dir):
    a = np.loadtxt(data_file(f"aerosol_opac/refractive_indices/{component}{rh:02d}_refr.dat", data_dir))
    return a[:, 0] * 1000.0, a[:, 1], np.abs(a[:, 2])


def refractive_index(component: str, wavelength_nm, relative_humidity: int = 50, data_dir=None) -> np.ndarray:
    """Complex refractive index n - i k [1] of an OPAC component at wavelengths [nm] (linear interpolation)."""
    rh = humidity_tag(component, relative_humidity)
    wl, n, k = _refr_table(component, rh, None if data_dir is None else str(data_dir))
    w = np.asarray(wavelength_nm, float)
    return np.interp(w, wl, n) - 1j * np.exp(np.interp(w, wl, np.log(np.maximum(k, 1e-12))))
