"""Rayleigh scattering by dry air after Bodhaine, Wood, Dutton & Slusser (1999), J. Atmos. Ocean. Tech. 16, 1854.

- Refractive index of standard air (Peck & Reeder 1972, Bodhaine eq. 4) with the CO2 correction (eq. 19).
- King factor of air from those of N2, O2, Ar and CO2 (Bates 1984; Bodhaine eqs. 5, 6, 23).
- Cross-section per molecule (eq. 2) at the reference density Ns = 2.546899e19 cm-3 (288.15 K, 1013.25 hPa).
- Depolarisation ratio rho = 6 (F - 1) / (7 + 3 F) and the phase function with depolarisation
  (Chandrasekhar 1950; Hansen & Travis 1974):
  P(Theta) = 3 / (4 (1 + 2 gamma)) [(1 + 3 gamma) + (1 - gamma) cos^2 Theta], gamma = rho / (2 - rho).
"""

from __future__ import annotations

import numpy as np

NS_REF = 2.546899e19  # molecules cm-3 at 288.15 K, 1013.25 hPa
DEFAULT_CO2_PPM = 360.0


def refractive_index_air(wavelength_nm, co2_ppm: float = DEFAULT_CO2_PPM) -> np.ndarray:
    """Refractive index of standard dry air [1] at wavelength [nm] (vacuum) and CO2 [ppm by volume]."""
    lam = np.asarray(wavelength_nm, float) / 1000.0
    s2 = lam ** -2
    n300 = (8060.51 + 2480990.0 / (132.274 - s2) + 17455.7 / (39.32957 - s2)) * 1e-8
    return 1.0 + n300 * (1.0 + 0.54 * (co2_ppm * 1e-6 - 0.0003))


def king_factor(wavelength_nm, co2_ppm: float = DEFAULT_CO2_PPM) -> np.ndarray:
    """King correction factor F(air) [1] (Bodhaine et al. 1999 eq. 23)."""
    lam = np.asarray(wavelength_nm, float) / 1000.0
    s2 = lam ** -2
    f_n2 = 1.034 + 3.17e-4 * s2
    f_o2 = 1.096 + 1.385e-3 * s2 + 1.448e-4 * s2 * s2
    c = co2_ppm * 1e-4  # percent by volume
    return (78.084 * f_n2 + 20.946 * f_o2 + 0.934 * 1.00 + c * 1.15) / (78.084 + 20.946 + 0.934 + c)


def depolarization_ratio(wavelength_nm, co2_ppm: float = DEFAULT_CO2_PPM) -> np.ndarray:
    """Depolarisation ratio rho [1] of air from the King factor: rho = 6 (F - 1) / (7 + 3 F)."""
    f = king_factor(wavelength_nm, co2_ppm)
    return 6.0 * (f - 1.0) / (7.0 + 3.0 * f)


def rayleigh_cross_section(wavelength_nm, co2_ppm: float = DEFAULT_CO2_PPM) -> np.ndarray:
    """Rayleigh scattering cross-section of air [cm2 per molecule] at wavelength [nm] (Bodhaine eq. 2)."""
    lam_cm = np.asarray(wavelength_nm, float) * 1e-7
    n = refractive_index_air(wavelength_nm, co2_ppm)
    n2 = n * n
    return 24.0 * np.pi ** 3 * (n2 - 1.0) ** 2 / (lam_cm ** 4 * NS_REF ** 2 * (n2 + 2.0) ** 2) * king_factor(
        wavelength_nm, co2_ppm)


def rayleigh_extinction_sea_level_km(wavelength_nm=550.0, number_density_cm3: float = NS_REF,
                                     co2_ppm: float = DEFAULT_CO2_PPM) -> np.ndarray:
    """Rayleigh extinction coefficient [km-1] at a number density [cm-3] (default: 288.15 K, 1013.25 hPa)."""
    return rayleigh_cross_section(wavelength_nm, co2_ppm) * number_density_cm3 * 1e5


def rayleigh_phase_function(cos_scattering_angle, wavelength_nm=550.0, co2_ppm: float = DEFAULT_CO2_PPM):
    """Rayleigh phase function with depolarisation [sr-1 x 4 pi], normalised so its mean over the sphere is 1."""
    rho = depolarization_ratio(wavelength_nm, co2_ppm)
    gam = rho / (2.0 - rho)
    mu = np.asarray(cos_scattering_angle, float)
    return 3.0 / (4.0 * (1.0 + 2.0 * gam)) * ((1.0 + 3.0 * gam) + (1.0 - gam) * mu * mu)


def rayleigh_moments(wavelength_nm, nmom: int, co2_ppm: float = DEFAULT_CO2_PPM) -> np.ndarray:
    """Legendre moments chi_0..chi_nmom [1] of the Rayleigh phase function, DISORT convention
    P = sum (2l+1) chi_l P_l(mu): chi_0 = 1, chi_2 = (1 - gamma) / (10 (1 + 2 gamma)), others 0."""
    rho = float(depolarization_ratio(wavelength_nm, co2_ppm))
    gam = rho / (2.0 - rho)
    m = np.zeros(nmom + 1)
    m[0] = 1.0
    if nmom >= 2:
        m[2] = (1.0 - gam) / (10.0 * (1.0 + 2.0 * gam))
    return m
