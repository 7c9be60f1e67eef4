"""Coated glass from a thin-film stack: a spectrally selective (silver) solar-control layer.

The data directory holds no solar-control coating, so this module builds one from a documented
construction: a dielectric / silver / dielectric / silver / dielectric stack (the classic
double-silver solar-control design) on a clear pane, computed per wavelength with the
characteristic-matrix method of thin-film optics (coherent films, normal incidence; Macleod,
*Thin-Film Optical Filters*, ch. 2) and combined incoherently with the thick substrate.

Materials (scalar facts, cited):

* silver: the Drude model with Ordal et al.'s infrared fit (Appl. Opt. 22, 1099 (1983), Table I:
  plasma frequency 72 700 cm-1, damping 145 cm-1), plus the thin-film boundary scattering
  ``v_F / d`` (v_F = 1.39e6 m s-1, Ashcroft & Mermin, *Solid State Physics*, Table 2.1) that
  raises the damping of a 10-15 nm film about five-fold. The 4d interband background of silver
  (below ~ 350 nm, and a few units of permittivity in the visible) is left out
  (``eps_inf`` = 1 by default), so visible values are approximate;
* dielectric: a non-absorbing film of constant index (zinc oxide, n = 2.0 in the visible, the
  usual seed and spacer layer of silver coatings);
* substrate: the clear pane's own n, k (e.g. inverted from an IGDB file).

The coated layer returned is an ordinary coated :class:`~thermal.glazing.GlazingLayer`: its
normal-incidence T, Rfront (film side), Rback, and the substrate's n, k for the scaled-substrate
angular rule. Its long-wave emissivity is the stack's normal absorptance at 10 um over the
substrate taken as a black absorber of index ``n_substrate_ir`` (an estimate; the hemispherical
value of a metal coating is some 20 % higher).

Units: wavelengths [nm], thicknesses [nm] for films and [mm] for the substrate, wavenumbers [cm-1].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .glazing import GlazingLayer

__all__ = ["drude_index", "SILVER_ORDAL", "Film", "stack_optics", "coated_layer_from_stack",
           "DOUBLE_SILVER", "solar_control_layer"]

SILVER_ORDAL = {"plasma_cm": 72700.0, "damping_cm": 145.0, "fermi_velocity": 1.39e6}
"""Silver: Drude plasma frequency and damping [cm-1] (Ordal et al. 1983, Table I) and Fermi
velocity [m s-1] (Ashcroft & Mermin Table 2.1)."""
C_CM = 2.99792458e10


def drude_index(wavelength_nm, plasma_cm, damping_cm, eps_inf=1.0):
    """Complex refractive index ``n + i k`` of a Drude metal.

    ``eps = eps_inf - wp^2 / (w^2 + i w g)`` with the frequencies as wavenumbers [cm-1].

    Parameters
    ----------
    wavelength_nm : array_like
        [nm].
    plasma_cm, damping_cm : float
        Plasma frequency and damping [cm-1].
    eps_inf : float
        Background permittivity [1].
    """
    w = 1e7 / np.asarray(wavelength_nm, float)
    if np.any(w <= 0) or plasma_cm <= 0 or damping_cm <= 0:
        raise ValueError("wavelength_nm, plasma_cm and damping_cm must be > 0")
    eps = eps_inf - plasma_cm ** 2 / (w ** 2 + 1j * w * damping_cm)
    n = np.sqrt(eps)
    return np.where(n.imag < 0, -n, n)


@dataclass(frozen=True)
class Film:
    """One coherent film: ``material`` "silver" or a constant index (float), thickness [nm]."""

    material: object
    thickness_nm: float

    def __post_init__(self):
        if not self.thickness_nm >= 0:
            raise ValueError(f"thickness_nm={self.thickness_nm!r} must be >= 0 nm")
        if not (self.material == "silver" or isinstance(self.material, (int, float))):
            raise ValueError(f"material={self.material!r}: 'silver' or a refractive index")

    def index(self, wavelength_nm):
        """(K,) complex index n + i k [1]."""
        wl = np.asarray(wavelength_nm, float)
        if self.material == "silver":
            d = max(self.thickness_nm, 1e-3) * 1e-9
            extra = SILVER_ORDAL["fermi_velocity"] / d / (2 * np.pi * C_CM)
            return drude_index(wl, SILVER_ORDAL["plasma_cm"], SILVER_ORDAL["damping_cm"] + extra)
        return np.full(wl.shape, complex(self.material))


def _amplitudes(films, n_in, n_out, wl):
    """Amplitude r, t of a film stack from medium n_in to n_out (normal incidence), (K,)."""
    B = np.ones(wl.shape, complex)
    C = np.asarray(n_out, complex) * np.ones(wl.shape)
    # characteristic matrices applied from the exit side towards the entrance (exp(-i w t) waves)
    for f in reversed(films):
        N = f.index(wl)
        d = 2 * np.pi * N * f.thickness_nm / wl
        B, C = np.cos(d) * B - 1j * np.sin(d) / N * C, -1j * N * np.sin(d) * B + np.cos(d) * C
    n0 = np.asarray(n_in, complex)
    den = n0 * B + C
    return (n0 * B - C) / den, 2 * n0 / den


def stack_optics(films, wavelength_nm, n_in=1.0, n_out=1.5):
    """Intensity T, R (from ``n_in``) and R' (from ``n_out``) of a film stack between two
    non-absorbing media [1], (K,) each; ``films`` listed from the ``n_in`` side."""
    wl = np.asarray(wavelength_nm, float)
    n_in = np.broadcast_to(np.asarray(n_in, float), wl.shape)
    n_out = np.broadcast_to(np.asarray(n_out, float), wl.shape)
    r, t = _amplitudes(films, n_in, n_out, wl)
    r2, _ = _amplitudes(list(reversed(films)), n_out, n_in, wl)
    return n_out / n_in * np.abs(t) ** 2, np.abs(r) ** 2, np.abs(r2) ** 2


def coated_layer_from_stack(name, films, substrate, n_substrate_ir=1.5):
    """A coated layer: ``films`` (listed from the air side) on the front of ``substrate``.

    Parameters
    ----------
    name : str
    films : sequence of Film
    substrate : GlazingLayer
        Uncoated clear pane (its n, k per wavelength, thickness [mm], emissivity).
    n_substrate_ir : float
        Substrate index at 10 um for the emissivity estimate [1].

    Returns
    -------
    GlazingLayer
        Coated, on the substrate's wavelength grid [nm]; front = film side.
    """
    if substrate.coated:
        raise ValueError(f"substrate={substrate.name!r} must be an uncoated layer")
    wl = substrate.wavelength
    n_s, k_s = np.asarray(substrate.n, float), np.asarray(substrate.k, float)
    Ta, Ra, Ra2 = stack_optics(films, wl, 1.0, n_s)
    Rg = ((n_s - 1) / (n_s + 1)) ** 2                      # bare glass/air face
    tau = np.exp(-4 * np.pi * k_s * substrate.thickness_mm * 1e6 / wl)
    den = 1 - Ra2 * Rg * tau ** 2
    T = Ta * tau * (1 - Rg) / den
    Rf = Ra + Ta ** 2 * tau ** 2 * Rg / den
    Rb = Rg + (1 - Rg) ** 2 * tau ** 2 * Ra2 / den
    T_ir, R_ir, _ = stack_optics(films, np.array([10000.0]), 1.0, n_substrate_ir)
    emissivity = float(1 - R_ir[0])
    return GlazingLayer(name, wl, T, Rf, Rb, substrate.thickness_mm, emissivity,
                        substrate.emissivity_back, substrate.conductivity, True, n_s, k_s)


DOUBLE_SILVER = (Film(2.0, 35.0), Film("silver", 12.0), Film(2.0, 75.0), Film("silver", 14.0),
                 Film(2.0, 35.0))
"""The documented solar-control stack, from the air side: ZnO 35 nm / Ag 12 nm / ZnO 75 nm /
Ag 14 nm / ZnO 35 nm (a double-silver design of typical layer thicknesses)."""


def solar_control_layer(substrate, films=DOUBLE_SILVER, name="double-silver solar control"):
    """The :data:`DOUBLE_SILVER` coating on ``substrate`` (coating on the front)."""
    return coated_layer_from_stack(name, films, substrate)
