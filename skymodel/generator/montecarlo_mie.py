"""Full scattering matrix of the OPAC aerosol mixtures for the Monte Carlo solver.

The DISORT chain needs only the phase-function moments (:mod:`widesky.skymodel.generator.aerosol`); the polarised Monte
Carlo solver needs the four independent elements of the scattering matrix of spheres (Bohren & Huffman 1983,
eq. 4.77, their S11, S12, S33, S34), from the same Mie coefficients (miepython ``an_bn``), the same OPAC size
distributions, refractive indices and mixing by number density, on a cosine grid of 2000 Gauss-Legendre nodes
plus the end points -1 and 1:

    S1 = sum_n (2n+1)/(n(n+1)) (a_n pi_n + b_n tau_n),   S2 = sum_n (2n+1)/(n(n+1)) (a_n tau_n + b_n pi_n),
    S11 = (|S2|^2 + |S1|^2) / 2,  S12 = (|S2|^2 - |S1|^2) / 2,  S33 = Re(S2 S1*),  S34 = Im(S2 S1*).

Each element is integrated over the size distribution, mixed over the components with weights (number density
per cm3) and divided by the mixture's angular integral of S11, so that P11 has mean 1 over the sphere
(int_-1^1 P11 dmu = 2 by the trapezoid rule on the grid, the rule the Monte Carlo sampler uses).
With Q = I_par - I_perp relative to the scattering plane, P12 < 0 means polarisation perpendicular to it,
as for Rayleigh scattering. Results per component and wavelength are cached under the cache directory.
"""

from __future__ import annotations

import functools
import hashlib
import json

import numpy as np
from numpy.polynomial import legendre

from widesky.core.atomic import atomic_write

from ..opac import refractive_index
from .aerosol import AREA_CUTOFF, MIE_WAVELENGTHS_NM, N_RADII, OPAC_TYPES, _pi_tau, size_distribution
from .paths import cache_dir

N_MU_MATRIX = 2000


@functools.lru_cache(maxsize=1)
def matrix_mu_grid() -> np.ndarray:
    """Cosine grid of the tabulated matrices [1], increasing from -1 to 1, shape (N_MU_MATRIX + 2,)."""
    from scipy.special import roots_legendre

    return np.concatenate([[-1.0], roots_legendre(N_MU_MATRIX)[0], [1.0]])


def _component_matrix(component, rh, wavelength_nm, data_dir):
    """Size-integrated (S11, S12, S33, S34) / k^2 per particle [um2 sr-1] (M, 4) and Csca [um2]."""
    import miepython

    sd = size_distribution(component, rh, data_dir)
    mu = matrix_mu_grid()
    r = np.geomspace(sd["r_min"], sd["r_max"], N_RADII)
    lnr = np.log(r)
    ls = np.log(sd["sigma"])
    nr = np.exp(-0.5 * ((lnr - np.log(sd["r_mod"])) / ls) ** 2) / (np.sqrt(2 * np.pi) * ls) * np.gradient(lnr)
    nr /= nr.sum()
    area = nr * r ** 2
    keep = area >= AREA_CUTOFF * area.max()
    r, nr = r[keep], nr[keep]
    m = complex(refractive_index(component, wavelength_nm, rh, data_dir))
    k = 2 * np.pi / (wavelength_nm * 1e-3)  # um-1
    xmax = k * r[-1]
    pi_all, tau_all = _pi_tau(mu, int(xmax + 4.05 * xmax ** (1 / 3) + 3))
    out = np.zeros((len(mu), 4))
    csca = 0.0
    for ri, wi in zip(r, nr):
        x = k * ri
        a, b = miepython.an_bn(m, x)
        nt = len(a)
        n = np.arange(1, nt + 1)
        f = (2 * n + 1) / (n * (n + 1.0))
        pi, tau = pi_all[:nt], tau_all[:nt]
        s1 = (f * a) @ pi + (f * b) @ tau
        s2 = (f * a) @ tau + (f * b) @ pi
        i1, i2 = np.abs(s1) ** 2, np.abs(s2) ** 2
        c = s2 * np.conj(s1)
        out += wi / k ** 2 * np.stack([0.5 * (i2 + i1), 0.5 * (i2 - i1), c.real, c.imag], axis=1)
        csca += wi * np.pi * ri ** 2 * 2.0 / x ** 2 * np.sum((2 * n + 1) * (np.abs(a) ** 2 + np.abs(b) ** 2))
    return out, csca


def component_matrix(component: str, relative_humidity: int, wavelength_nm: float, data_dir=None):
    """Cached :func:`_component_matrix` at one of :data:`MIE_WAVELENGTHS_NM` [nm]."""
    rh = relative_humidity if component == "waso" else 0
    sd = size_distribution(component, rh, data_dir)
    m = refractive_index(component, wavelength_nm, rh, data_dir)
    key = hashlib.sha1(json.dumps([component, rh, sd, float(wavelength_nm), N_MU_MATRIX, N_RADII, AREA_CUTOFF,
                                   round(float(m.real), 6), round(float(m.imag), 9), 1]).encode()).hexdigest()[:16]
    path = cache_dir() / f"miematrix_{component}{rh:02d}_{wavelength_nm:.0f}_{key}.npz"
    if path.exists():
        z = np.load(path)
        return z["matrix"], float(z["csca"])
    mat, csca = _component_matrix(component, rh, float(wavelength_nm), None if data_dir is None else str(data_dir))
    with atomic_write(path) as tmp:  # pool or Dask workers may race to fill the cache: each writes its own file
        np.savez(tmp, matrix=mat, csca=csca)
    return mat, csca


@functools.lru_cache(maxsize=256)
def _mixture_at_grid(opac_type, relative_humidity, wavelength_nm, data_dir):
    tot = None
    for comp, number in OPAC_TYPES[opac_type].items():
        mat, _ = component_matrix(comp, relative_humidity, wavelength_nm, data_dir)
        tot = number * mat if tot is None else tot + number * mat
    mu = matrix_mu_grid()
    norm = np.trapezoid(tot[:, 0], mu) if hasattr(np, "trapezoid") else np.trapz(tot[:, 0], mu)
    return tot * (2.0 / norm)


def mixture_matrix(opac_type: str, relative_humidity: int, wavelength_nm: float, data_dir=None) -> np.ndarray:
    """Normalised scattering matrix (P11, P12, P33, P34) [1] of an OPAC mixture on :func:`matrix_mu_grid`,
    shape (M, 4), linearly interpolated in wavelength [nm] between the Mie wavelengths (as the moments are)."""
    if opac_type not in OPAC_TYPES:
        raise ValueError(f"opac_type={opac_type!r}: valid types are {tuple(OPAC_TYPES)}")
    w = float(wavelength_nm)
    if not (MIE_WAVELENGTHS_NM[0] <= w <= MIE_WAVELENGTHS_NM[-1]):
        raise ValueError(f"wavelength_nm={w} outside [{MIE_WAVELENGTHS_NM[0]}, {MIE_WAVELENGTHS_NM[-1]}] nm")
    j = int(np.clip(np.searchsorted(MIE_WAVELENGTHS_NM, w) - 1, 0, len(MIE_WAVELENGTHS_NM) - 2))
    w0, w1 = MIE_WAVELENGTHS_NM[j], MIE_WAVELENGTHS_NM[j + 1]
    f = (w - w0) / (w1 - w0)
    dd = None if data_dir is None else str(data_dir)
    a = _mixture_at_grid(opac_type, relative_humidity, float(w0), dd)
    if f <= 0:
        return a.copy()
    b = _mixture_at_grid(opac_type, relative_humidity, float(w1), dd)
    return (1 - f) * a + f * b


def legendre_moment(table: np.ndarray, order: int) -> float:
    """Legendre moment chi_l = (1/2) int P11 P_l dmu [1] of a tabulated P11 (trapezoid rule), for checks."""
    mu = matrix_mu_grid()
    c = np.zeros(order + 1)
    c[order] = 1.0
    y = table[:, 0] * legendre.legval(mu, c)
    return 0.5 * float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(mu)))
