"""Visibility <-> aerosol optical depth relation shared by the dataset generator and the sky-state logic.

The Prague Sky Model is parameterised by ground-level visibility V [km] (meteorological range).
Koschmieder's relation gives the total 550 nm extinction coefficient at the ground,
``beta_ext = 3.912 / V`` [km-1] (2 % contrast threshold); subtracting the molecular (Rayleigh)
part leaves the aerosol extinction. With an exponential aerosol profile of scale height ``H`` [km]
the aerosol optical depth at 550 nm is ``beta_aer * H``.

The generator in :mod:`widesky.skymodel.generator` builds its aerosol profile so that it integrates to exactly
:func:`aod550_from_visibility`; the sky-state logic in :mod:`widesky.irradiance` inverts the same relation.
"""

from __future__ import annotations

import numpy as np

KOSCHMIEDER_CONSTANT = 3.912
"""ln(1/0.02): visibility V [km] times ground extinction [km-1] at the 2 % contrast threshold."""

RAYLEIGH_EXTINCTION_550_KM = 0.011488
"""Sea-level Rayleigh extinction coefficient at 550 nm [km-1]: the Bodhaine et al. (1999) cross-section
4.5105e-27 cm2 (360 ppm CO2) times the number density 2.546899e19 cm-3 (288.15 K, 1013.25 hPa), as
computed by :func:`widesky.core.rayleigh.rayleigh_extinction_sea_level_km` (a test keeps them equal)."""

DEFAULT_AEROSOL_SCALE_HEIGHT_KM = 1.5
"""Scale height of the exponential aerosol extinction profile [km] used by the generator. The generator's
profile is exponential from the ground to 100 km, renormalised so that its layer optical depths sum to
exactly :func:`aod550_from_visibility` (see docs/atmosphere-and-solver.md, 'Aerosol profile')."""


def aerosol_extinction_550(visibility):
    """Aerosol extinction coefficient at 550 nm at the ground.

    Parameters
    ----------
    visibility : array_like
        Ground-level visibility (meteorological range) [km], > 0.

    Returns
    -------
    numpy.ndarray
        Aerosol extinction [km-1], clipped at 0 for visibilities beyond the Rayleigh limit
        (about 337 km).
    """
    v = np.asarray(visibility, dtype=float)
    if np.any(~(v > 0)):
        raise ValueError(f"visibility must be > 0 km, got {v[~(v > 0)].ravel()[:3]}")
    return np.maximum(KOSCHMIEDER_CONSTANT / v - RAYLEIGH_EXTINCTION_550_KM, 0.0)


def aod550_from_visibility(visibility, scale_height=DEFAULT_AEROSOL_SCALE_HEIGHT_KM):
    """Aerosol optical depth at 550 nm [1] for a visibility [km] and aerosol scale height [km]."""
    return aerosol_extinction_550(visibility) * float(scale_height)


def visibility_from_aod550(aod550, scale_height=DEFAULT_AEROSOL_SCALE_HEIGHT_KM):
    """Visibility [km] giving the aerosol optical depth ``aod550`` [1] at 550 nm (inverse of
    :func:`aod550_from_visibility`); ``aod550`` must be > 0."""
    tau = np.asarray(aod550, dtype=float)
    if np.any(~(tau > 0)):
        raise ValueError(f"aod550 must be > 0, got {tau[~(tau > 0)].ravel()[:3]}")
    return KOSCHMIEDER_CONSTANT / (tau / float(scale_height) + RAYLEIGH_EXTINCTION_550_KM)


def aod_at_wavelength(aod_ref, wavelength_ref, wavelength, angstrom):
    """Angstrom law: AOD [1] at ``wavelength`` [nm] from AOD at ``wavelength_ref`` [nm] and
    exponent ``angstrom`` [1]."""
    return np.asarray(aod_ref, float) * (np.asarray(wavelength, float) / float(wavelength_ref)) ** (
        -np.asarray(angstrom, float))
