"""Parametric external quantum efficiency (EQE) of a solar cell, 280-2480 nm.

The model is a product of four factors, each a named physical loss:

    EQE(lambda) = plateau * front(lambda) * tilt(lambda) * (1 - parasitic(lambda)) * absorption(E)

- absorption edge: the absorber's single-pass-equivalent absorptance ``1 - exp(-alpha L)`` with
  ``alpha L = ((E - E0) / edge_width)**2`` above the onset ``E0 = bandgap - tail`` (E = h c / lambda
  [eV]); zero below ``E0``. The square law fits the measured edges of c-Si (indirect, light-trapped),
  a perovskite and GaAs in ``shared/data/pv`` to 0.8-1.4 % EQE rms (docs/pvsim.md), better than a
  logistic in wavelength or energy. ``tail`` absorbs the Urbach tail and, for Si, phonon-assisted
  absorption below the gap.
- front (window) losses: a logistic cut-on at ``window_nm`` (width ``window_width_nm``) that rises
  from ``window_floor`` to 1: light absorbed in the window/emitter/TCO layers (a CdS buffer, the
  a-Si:H and ITO of heterojunctions, a heavily doped emitter); times an ultraviolet cut-on at
  ``uv_cutoff_nm`` (front layers that absorb everything below it).
- plateau: the peak collection (reflection, shading by fingers, collection losses) and a linear
  decline ``plateau_tilt`` from the window to the edge (rear recombination, free-carrier absorption).
- parasitic absorption: an optional Gaussian band ``parasitic_amplitude`` at ``parasitic_nm``.

The sub-band-gap transmittance ``transmittance_below_gap`` (the light a top cell passes to a bottom
cell) follows from the same absorption law: ``exp(-alpha L)``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from .spectra import HC_EV_NM

__all__ = ["EQEParameters", "parametric_eqe", "absorptance_edge", "transmittance_below_gap"]


@dataclass(frozen=True)
class EQEParameters:
    """Parameters of :func:`parametric_eqe` (see the module docstring for the model).

    Attributes
    ----------
    bandgap_ev : float
        Absorber band gap [eV], 0.5-3.5.
    tail_ev : float
        Absorption onset below the gap (Urbach tail, phonon absorption) [eV], >= 0.
    edge_width_ev : float
        Energy above the onset where alpha L = 1 [eV], > 0 (small: thick or strongly absorbing).
    plateau : float
        Peak collection [1], (0, 1].
    plateau_tilt : float
        Fractional decline of the plateau from the window to the edge [1], [0, 1).
    window_nm, window_width_nm, window_floor : float
        Window-layer cut-on [nm], its width [nm] (> 0) and the fraction collected below it [1], [0, 1].
    uv_cutoff_nm, uv_width_nm : float
        Ultraviolet cut-on of the front layers [nm] and its width [nm] (> 0).
    parasitic_amplitude, parasitic_nm, parasitic_width_nm : float
        Gaussian parasitic absorption band: depth [1] in [0, 1), centre [nm], standard deviation [nm] (> 0).
    """

    bandgap_ev: float
    tail_ev: float = 0.03
    edge_width_ev: float = 0.06
    plateau: float = 0.9
    plateau_tilt: float = 0.0
    window_nm: float = 350.0
    window_width_nm: float = 20.0
    window_floor: float = 0.0
    uv_cutoff_nm: float = 300.0
    uv_width_nm: float = 10.0
    parasitic_amplitude: float = 0.0
    parasitic_nm: float = 500.0
    parasitic_width_nm: float = 50.0

    _RANGES = {
        "bandgap_ev": (0.5, 3.5, True, True), "tail_ev": (0.0, 0.5, True, True),
        "edge_width_ev": (0.0, 2.0, False, True), "plateau": (0.0, 1.0, False, True),
        "plateau_tilt": (0.0, 1.0, True, False), "window_nm": (200.0, 2500.0, True, True),
        "window_width_nm": (0.0, 500.0, False, True), "window_floor": (0.0, 1.0, True, True),
        "uv_cutoff_nm": (200.0, 2500.0, True, True), "uv_width_nm": (0.0, 500.0, False, True),
        "parasitic_amplitude": (0.0, 1.0, True, False), "parasitic_nm": (200.0, 2500.0, True, True),
        "parasitic_width_nm": (0.0, 1000.0, False, True),
    }

    def __post_init__(self):
        for f in fields(self):
            lo, hi, lo_in, hi_in = self._RANGES[f.name]
            v = getattr(self, f.name)
            ok = np.isfinite(v) and (v >= lo if lo_in else v > lo) and (v <= hi if hi_in else v < hi)
            if not ok:
                br = ("[" if lo_in else "(") + f"{lo:g}, {hi:g}" + ("]" if hi_in else ")")
                raise ValueError(f"{f.name}={v!r} outside the valid range {br}")

    @property
    def edge_nm(self):
        """Wavelength of the band gap, h c / E_g [nm]."""
        return HC_EV_NM / self.bandgap_ev

    def replace(self, **changes):
        """A copy with some parameters changed (validated)."""
        return replace(self, **changes)

    def evaluate(self, wavelength):
        """EQE [1] at ``wavelength`` [nm] (:func:`parametric_eqe`)."""
        return parametric_eqe(wavelength, self)


def _alpha_l(wavelength, p: EQEParameters):
    w = np.asarray(wavelength, dtype=float)
    if np.any(~np.isfinite(w)) or np.any(w <= 0):
        raise ValueError("wavelength must be positive and finite [nm]")
    e = HC_EV_NM / w
    x = np.maximum(e - (p.bandgap_ev - p.tail_ev), 0.0) / p.edge_width_ev
    return x * x


def absorptance_edge(wavelength, p: EQEParameters):
    """The absorber's edge factor 1 - exp(-alpha L) [1] at ``wavelength`` [nm] (any shape)."""
    return -np.expm1(-_alpha_l(wavelength, p))


def transmittance_below_gap(wavelength, p: EQEParameters):
    """Fraction exp(-alpha L) [1] of the light entering the absorber that leaves it unabsorbed."""
    return np.exp(-_alpha_l(wavelength, p))


def _logistic(x):
    return 0.5 * (1.0 + np.tanh(0.5 * x))


def parametric_eqe(wavelength, p: EQEParameters):
    """External quantum efficiency of the parametric model.

    Parameters
    ----------
    wavelength : array_like
        [nm], any shape, positive.
    p : EQEParameters

    Returns
    -------
    numpy.ndarray
        EQE [1] in [0, 1], same shape as ``wavelength``.
    """
    w = np.asarray(wavelength, dtype=float)
    edge = absorptance_edge(w, p)
    front = (p.window_floor + (1.0 - p.window_floor) * _logistic((w - p.window_nm) / p.window_width_nm))
    front = front * _logistic((w - p.uv_cutoff_nm) / p.uv_width_nm)
    span = max(p.edge_nm - p.window_nm, 1.0)
    tilt = 1.0 - p.plateau_tilt * np.clip((w - p.window_nm) / span, 0.0, 1.0)
    parasitic = p.parasitic_amplitude * np.exp(-0.5 * ((w - p.parasitic_nm) / p.parasitic_width_nm) ** 2)
    return p.plateau * front * tilt * (1.0 - parasitic) * edge
