"""Responses: what a face does with the light it receives (spectral weighting and angular optics).

A :class:`Response` holds spectral values on their own wavelength grid with their unit, averaged
onto the sky's channels by integrating the piecewise-linear curve over each channel's band
(:meth:`Response.channel_weights`: a curve with an edge inside a 40 nm band gets the band's true
mean, not its value at the centre), and an optional angular part applied by the integrator per
incoming direction (:mod:`widesky.irradiance.optics`):

* a callable ``f(aoi_deg) -> factor [1]`` (e.g. a Fresnel cover's incidence-angle modifier);
* an :class:`AngularTable` of (angle [deg], factor [1]), linearly interpolated;
* a :class:`SpectralAngularTable` of angle [deg] x wavelength [nm] (glazing from a
  spectral-angular calculation): the full factor at that angle and wavelength (not divided by its
  value at normal incidence); the response's ``values`` multiply it, so pass ``values = 1`` for a
  pure table.

Units of the contraction output: ``"sr"`` (spectral response [A W-1]) and ``"qe"`` (quantum
efficiency [1], converted to SR = qe lambda q / (h c)) give [A m-2]; ``"transmittance"`` and
``"weight"`` ([1]) give [W m-2].
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from widesky.core.spectral import band_average, check_response_limit

__all__ = ["Response", "AngularTable", "SpectralAngularTable", "UNITS", "OUTPUT_UNITS",
           "band_average", "HC_OVER_Q"]

#: h c / q [W A-1 nm]: SR [A W-1] = qe lambda[nm] / HC_OVER_Q (CODATA 2018 exact constants).
HC_OVER_Q = 6.62607015e-34 * 299792458.0 / 1.602176634e-19 * 1e9

UNITS = ("sr", "qe", "transmittance", "weight")
#: The unit of a response's contracted irradiance.
OUTPUT_UNITS = {"sr": "A m-2", "qe": "A m-2", "transmittance": "W m-2", "weight": "W m-2"}


def _curve(name, x, y, xname="wavelength", xunit="nm", allow_negative=False):
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float)
    if x.size < 2:
        raise ValueError(f"{name}: {xname} needs at least 2 values, got {x.size}")
    if y.shape[0] != x.size:
        raise ValueError(f"{name}: {x.size} {xname}s but {y.shape[0]} values")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: {xname} has NaN or infinite values")
    bad = np.nonzero(np.diff(x) <= 0)[0]
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{name}: {xname}s must be strictly ascending; {x[i]:g} {xunit} is followed "
                         f"by {x[i + 1]:g} {xunit}")
    if not np.all(np.isfinite(y)):
        i = int(np.argwhere(~np.isfinite(y))[0][0])
        raise ValueError(f"{name}: value at {x[i]:g} {xunit} is {y.reshape(x.size, -1)[i][0]}, "
                         "expected a finite number")
    if not allow_negative and np.any(y < 0):
        i = int(np.argwhere(y < 0)[0][0])
        raise ValueError(f"{name}: value {y.reshape(x.size, -1)[i].min():g} at {x[i]:g} {xunit} is "
                         "negative (valid: >= 0)")
    return x, y


@dataclass(frozen=True, eq=False)
class AngularTable:
    """An incidence-angle factor as a table, linearly interpolated (constant beyond its ends).

    Parameters
    ----------
    angle_deg : array_like
        (A,) strictly ascending incidence angles [deg] within [0, 90].
    factor : array_like
        (A,) factor [1], >= 0 (its value at 90 deg is used as given).
    """

    angle_deg: np.ndarray
    factor: np.ndarray

    def __post_init__(self):
        a, f = _curve("AngularTable", self.angle_deg, self.factor, "angle", "deg")
        if a[0] < 0 or a[-1] > 90:
            raise ValueError(f"AngularTable: angles [{a[0]:g}, {a[-1]:g}] deg outside [0, 90]")
        object.__setattr__(self, "angle_deg", a)
        object.__setattr__(self, "factor", f.ravel())

    def __call__(self, aoi_deg):
        """Factor [1] at ``aoi_deg`` [deg] (any shape)."""
        return np.interp(aoi_deg, self.angle_deg, self.factor)


@dataclass(frozen=True, eq=False)
class SpectralAngularTable:
    """A factor by incidence angle and wavelength (e.g. glazing transmittance from a
    spectral-angular calculation): the full factor, not relative to normal incidence.

    Parameters
    ----------
    angle_deg : array_like
        (A,) strictly ascending incidence angles [deg] within [0, 90].
    wavelength_nm : array_like
        (K2,) strictly ascending wavelengths [nm].
    factor : array_like
        (A, K2) factor [1], >= 0.
    """

    angle_deg: np.ndarray
    wavelength_nm: np.ndarray
    factor: np.ndarray

    def __post_init__(self):
        a = np.asarray(self.angle_deg, dtype=float).ravel()
        w = np.asarray(self.wavelength_nm, dtype=float).ravel()
        f = np.asarray(self.factor, dtype=float)
        if f.shape != (a.size, w.size):
            raise ValueError(f"SpectralAngularTable: factor has shape {f.shape}, expected "
                             f"(angles, wavelengths) = ({a.size}, {w.size})")
        _curve("SpectralAngularTable", a, f, "angle", "deg")
        _curve("SpectralAngularTable", w, f.T, "wavelength", "nm")
        if a[0] < 0 or a[-1] > 90:
            raise ValueError(f"SpectralAngularTable: angles [{a[0]:g}, {a[-1]:g}] deg outside [0, 90]")
        object.__setattr__(self, "angle_deg", a)
        object.__setattr__(self, "wavelength_nm", w)
        object.__setattr__(self, "factor", f)

    def channel_table(self, lower_nm, upper_nm):
        """(A, C) the factor band-averaged over each channel, at the table's angles."""
        return band_average(self.wavelength_nm, self.factor, lower_nm, upper_nm)


class Response:
    """A named spectral response with its unit and an optional angular optic.

    Parameters
    ----------
    name : str
        Name of the result it gives (unique within a run).
    wavelength : array_like
        (K,) strictly ascending wavelengths [nm].
    values : array_like
        (K,) values >= 0 in ``unit``.
    unit : {"sr", "qe", "transmittance", "weight"}
        Spectral response [A W-1], quantum efficiency [1], transmittance [1] or weight [1].
    angular : None, callable, AngularTable or SpectralAngularTable
        Optic applied per incoming direction (see the module docstring).
    """

    def __init__(self, name, wavelength, values, unit="weight", angular=None):
        name = str(name)
        if not name or any(c in name for c in "/=\n"):
            raise ValueError(f"response name={name!r}: must be non-empty without '/', '=' or newlines")
        if unit not in UNITS:
            raise ValueError(f"response {name!r}: unit={unit!r} is not one of {UNITS}")
        wl, v = _curve(f"response {name!r}", wavelength, values)
        if v.ndim != 1:
            raise ValueError(f"response {name!r}: values must be one-dimensional, got {v.shape}")
        check_response_limit(wl, v, unit, f"response {name!r}")
        if not (angular is None or callable(angular) or isinstance(angular, SpectralAngularTable)):
            raise TypeError(f"response {name!r}: angular must be None, a callable, an AngularTable "
                            f"or a SpectralAngularTable, got {type(angular).__name__}")
        self.name, self.wavelength, self.values, self.unit = name, wl, v, unit
        self.angular = angular

    def __repr__(self):
        kind = "none" if self.angular is None else type(self.angular).__name__
        return (f"Response({self.name!r}, {self.wavelength[0]:g}-{self.wavelength[-1]:g} nm, "
                f"unit={self.unit!r}, angular={kind})")

    @property
    def output_unit(self) -> str:
        """"A m-2" or "W m-2"."""
        return OUTPUT_UNITS[self.unit]

    @property
    def spectral_angular(self) -> bool:
        """True when the optic depends on angle and wavelength together."""
        return isinstance(self.angular, SpectralAngularTable)

    @classmethod
    def unit_weight(cls, name="broadband"):
        """Weight 1 over 280-2480 nm (the Prague Sky Model's range), no optics: broadband [W m-2]."""
        return cls(name, [280.0, 2480.0], [1.0, 1.0], unit="weight")

    @classmethod
    def from_csv(cls, path, name=None, unit="sr", angular=None):
        """Read a response from a CSV file with columns ``wavelength_nm,value``.

        One header line and ``#`` comments are allowed; ``,`` or ``;`` separate the columns.
        Errors name the file and line: non-numeric rows, NaN, negative values, non-ascending
        wavelengths, fewer than two rows.

        Parameters
        ----------
        path : str or path-like
            The file.
        name : str, optional
            Default: the file's stem.
        unit : {"sr", "qe", "transmittance", "weight"}
            Unit of the values (see :class:`Response`).
        angular : optional
            Optic (see :class:`Response`).
        """
        rows, lines_of = [], []
        try:
            with open(path, encoding="utf-8-sig") as f:
                lines = f.read().splitlines()
        except OSError as e:
            raise ValueError(f"response file {path}: {e.strerror}") from None
        header_seen = False
        for n, line in enumerate(lines, 1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            # ';' separates the columns of a table written with decimal commas ("400;0,52"): read those as points
            parts = ([x.strip().replace(",", ".") for x in line.split(";")] if ";" in line
                     else [x.strip() for x in line.split(",")])
            try:
                if len(parts) < 2:
                    raise ValueError
                rows.append((float(parts[0]), float(parts[1])))
                lines_of.append(n)
            except ValueError:
                if rows or header_seen:
                    raise ValueError(f"response file {path}, line {n}: expected 'wavelength_nm,value', "
                                     f"got {line[:60]!r}") from None
                header_seen = True
        if len(rows) < 2:
            raise ValueError(f"response file {path}: fewer than two data rows (wavelength_nm,value)")
        a = np.array(rows, dtype=float)
        for j, what in ((0, "wavelength"), (1, "value")):
            bad = ~np.isfinite(a[:, j])
            if bad.any():
                i = int(np.argmax(bad))
                raise ValueError(f"response file {path}, line {lines_of[i]}: {what} is {a[i, j]}")
        down = np.nonzero(np.diff(a[:, 0]) <= 0)[0]
        if down.size:
            i = int(down[0]) + 1
            raise ValueError(f"response file {path}, line {lines_of[i]}: wavelength {a[i, 0]:g} nm "
                             f"not above the previous {a[i - 1, 0]:g} nm (must be strictly ascending)")
        neg = np.nonzero(a[:, 1] < 0)[0]
        if neg.size:
            i = int(neg[0])
            raise ValueError(f"response file {path}, line {lines_of[i]}: value {a[i, 1]:g} is "
                             "negative (valid: >= 0)")
        if name is None:
            name = os.path.splitext(os.path.basename(os.fspath(path)))[0]
        try:
            check_response_limit(a[:, 0], a[:, 1], unit, f"response file {path} (unit {unit})")
        except ValueError as exc:
            raise ValueError(str(exc)) from None
        return cls(name, a[:, 0], a[:, 1], unit=unit, angular=angular)

    def channel_weights(self, lower_nm, upper_nm):
        """(C,) band-averaged weights: the integral of the curve over each band / its width.

        In the output unit per nm of the sky's spectral quantity: [1] for transmittance and weight,
        [A W-1] for SR and QE (QE converted to SR before averaging). The curve is 0 outside its
        wavelength range (a cell responds nowhere else); a range that overlaps none of the bands
        is an error.

        Parameters
        ----------
        lower_nm, upper_nm : array_like
            (C,) channel limits [nm].
        """
        lo = np.asarray(lower_nm, dtype=float).ravel()
        hi = np.asarray(upper_nm, dtype=float).ravel()
        if self.wavelength[-1] <= lo.min() or self.wavelength[0] >= hi.max():
            raise ValueError(f"response {self.name!r}: its range {self.wavelength[0]:g}-"
                             f"{self.wavelength[-1]:g} nm misses the channels used "
                             f"({lo.min():g}-{hi.max():g} nm)")
        v = self.values
        if self.unit == "qe":
            v = v * self.wavelength / HC_OVER_Q
        return band_average(self.wavelength, v, lo, hi)

    def angular_factor(self, aoi_deg, lower_nm, upper_nm):
        """(N, C) angular factor [1] at incidence angles ``aoi_deg`` (N,) [deg] per channel.

        1 where the response has no optic; angles are clipped to [0, 90] deg; NaN angles give 0.
        A :class:`SpectralAngularTable` is band-averaged over each channel, then interpolated
        linearly in angle.
        """
        a = np.asarray(aoi_deg, dtype=float).ravel()
        C = np.asarray(lower_nm).size
        nan = ~np.isfinite(a)
        ac = np.clip(np.where(nan, 0.0, a), 0.0, 90.0)
        if self.angular is None:
            out = np.ones((a.size, C))
        elif self.spectral_angular:
            tab = self.angular.channel_table(lower_nm, upper_nm)           # (A, C)
            ang = self.angular.angle_deg
            out = np.stack([np.interp(ac, ang, tab[:, c]) for c in range(C)], axis=1)
        else:
            f = np.asarray(self.angular(ac), dtype=float).reshape(a.size)
            out = np.broadcast_to(f[:, None], (a.size, C)).copy()
        out[nan] = 0.0
        return out
