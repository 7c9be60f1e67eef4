"""User-supplied EQE or SR curves: validation, CSV reading and tabulated cells.

A curve is a table of wavelength [nm] (strictly increasing, positive, finite) and values: EQE [1] in
[0, 1] or SR [A W-1] in [0, q lambda / (h c)] (the SR of an EQE of 1). Bad curves raise ValueError
naming the file, the row's wavelength and the rule broken.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .spectra import qe_to_sr, sr_to_qe
from .technologies import CellTechnology

__all__ = ["validate_curve", "read_curve_csv", "TabulatedEQE", "cell_from_csv"]

_TOL = 1e-6


def validate_curve(wavelength, values, unit="qe", where="curve"):
    """Check a response curve; return ``(wavelength (K,) [nm], eqe (K,) [1])``.

    Parameters
    ----------
    wavelength : array_like (K,)
        [nm], strictly increasing, > 0, K >= 2.
    values : array_like (K,)
        EQE [1] (``unit="qe"``) or SR [A W-1] (``unit="sr"``).
    unit : {"qe", "sr"}
    where : str
        What to call the curve in error messages (e.g. the file name).
    """
    if unit not in ("qe", "sr"):
        raise ValueError(f"unit={unit!r} must be 'qe' or 'sr'")
    w = np.asarray(wavelength, dtype=float).ravel()
    v = np.asarray(values, dtype=float).ravel()
    if w.size != v.size or w.size < 2:
        raise ValueError(f"{where}: needs >= 2 (wavelength, value) pairs, got {w.size} and {v.size}")
    bad = ~np.isfinite(w) | ~np.isfinite(v) | (w <= 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"{where}: row {i + 1} (wavelength {w[i]!r} nm, value {v[i]!r}) is not finite "
                         "or has a wavelength <= 0")
    d = np.diff(w)
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0)) + 1
        raise ValueError(f"{where}: wavelengths must be strictly increasing; row {i + 1} has {w[i]!r} nm "
                         f"after {w[i - 1]!r} nm")
    if np.any(v < 0):
        i = int(np.argmax(v < 0))
        raise ValueError(f"{where}: negative {unit.upper()} {v[i]!r} at {w[i]!r} nm (valid range >= 0)")
    qe = v if unit == "qe" else sr_to_qe(v, w)
    if np.any(qe > 1.0 + _TOL):
        i = int(np.argmax(qe > 1.0 + _TOL))
        limit = "1" if unit == "qe" else f"{float(qe_to_sr(1.0, w[i])):.4f} A W-1 (EQE 1)"
        raise ValueError(f"{where}: {unit.upper()} {v[i]!r} at {w[i]!r} nm exceeds {limit}; "
                         "for a relative SR pass the absolute curve or scale it (valid EQE range [0, 1])")
    return w, np.minimum(qe, 1.0)


def read_curve_csv(path, unit="qe"):
    """Read a curve from CSV: two columns (wavelength [nm], value), one header line or none; lines
    starting with ``#`` are comments. Returns ``(wavelength [nm], eqe [1])`` (SR converted)."""
    p = Path(path)
    try:
        df = pd.read_csv(p, comment="#", header=None)
    except (OSError, ValueError) as exc:
        raise ValueError(f"cannot read curve file {str(p)!r}: {exc}") from exc
    try:
        float(df.iloc[0, 0])
    except (ValueError, TypeError, IndexError):
        df = df.iloc[1:]                       # a header line
    if df.shape[1] < 2:
        raise ValueError(f"{str(p)!r}: needs two columns wavelength_nm,value; got {df.shape[1]}")
    try:
        arr = df.iloc[:, :2].to_numpy(dtype=float)
    except ValueError as exc:
        raise ValueError(f"{str(p)!r}: non-numeric entry ({exc})") from exc
    return validate_curve(arr[:, 0], arr[:, 1], unit, where=str(p))


@dataclass(frozen=True, eq=False)
class TabulatedEQE:
    """A measured EQE [1] at ``wavelength`` [nm]: linear between points, 0 outside them."""

    wavelength: np.ndarray
    qe: np.ndarray

    def __post_init__(self):
        w, q = validate_curve(self.wavelength, self.qe, "qe", where="TabulatedEQE")
        object.__setattr__(self, "wavelength", w)
        object.__setattr__(self, "qe", q)

    def evaluate(self, wavelength):
        """EQE [1] at ``wavelength`` [nm] (any shape)."""
        return np.interp(np.asarray(wavelength, dtype=float), self.wavelength, self.qe, left=0.0, right=0.0)


def cell_from_csv(path, unit="qe", name=None, eta_stc=0.20, gamma_pdc=-0.0035, low_irradiance_200=0.97,
                  bifaciality=0.0):
    """A :class:`~pvsim.technologies.CellTechnology` from a measured EQE or SR file.

    Parameters
    ----------
    path : str or Path
        CSV as :func:`read_curve_csv`.
    unit : {"qe", "sr"}
        EQE [1] or SR [A W-1].
    name : str, optional
        Default the file's stem.
    eta_stc, gamma_pdc, low_irradiance_200, bifaciality :
        As :class:`~pvsim.technologies.CellTechnology` ([1], [1/K], [1], [1]).
    """
    w, q = read_curve_csv(path, unit)
    nm = name or Path(path).stem
    return CellTechnology(nm, nm, TabulatedEQE(w, q), eta_stc=eta_stc, gamma_pdc=gamma_pdc,
                          low_irradiance_200=low_irradiance_200, bifaciality=bifaciality,
                          sources={"eqe": f"measured curve {Path(path).name}"})
