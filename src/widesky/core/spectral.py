"""Spectral helpers shared by every package: band averaging of tabulated curves.

One band averager for the whole of widesky (the sky's extraterrestrial spectrum, cell responses, spectral
angular tables, reference spectra against the 40 nm channels): the mean over each band of the curve that is
linear between its tabulated points, integrated exactly.

Units: wavelength [nm]; the values in any unit, which the band means keep.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["band_average", "OUTSIDE", "PLANCK", "SPEED_OF_LIGHT", "ELEMENTARY_CHARGE", "HC_EV_NM",
           "check_response_limit", "in_band_share", "STC_IRRADIANCE"]

PLANCK = 6.62607015e-34          # h [J s] (SI 2019, exact)
SPEED_OF_LIGHT = 299792458.0     # c [m s-1] (exact)
ELEMENTARY_CHARGE = 1.602176634e-19  # q [C] (exact)
HC_EV_NM = PLANCK * SPEED_OF_LIGHT / ELEMENTARY_CHARGE * 1e9  # h c / q = 1239.84 [eV nm]

_LIMIT_TOL = 1e-3                # relative slack on the physical limits (rounded tables)


def check_response_limit(wavelength, values, unit, where):
    """Refuse a response above its physical limit, naming ``where``, the wavelength and the limit: a quantum
    efficiency or a transmittance above 1, a spectral response above ``lambda / 1239.84`` A W-1 (EQE 1,
    ``q lambda / (h c)``). An EQE table in percent (maximum in (1, 100]) is named as such.

    Parameters
    ----------
    wavelength : numpy.ndarray
        (K,) [nm].
    values : numpy.ndarray
        (K,) in ``unit``: "qe" [1], "transmittance" [1], "sr" [A W-1]; "weight" has no limit.
    """
    w, v = np.asarray(wavelength, dtype=float), np.asarray(values, dtype=float)
    if unit in ("qe", "transmittance"):
        limit = np.ones_like(w)
    elif unit == "sr":
        limit = w / HC_EV_NM
    else:
        return
    over = v > limit * (1.0 + _LIMIT_TOL)
    if not over.any():
        return
    i = int(np.argmax(over))
    if unit == "sr":
        raise ValueError(f"{where}: spectral response {v[i]:g} A W-1 at {w[i]:g} nm is above the physical limit "
                         f"{limit[i]:.4f} A W-1 (an EQE of 1, q lambda / (h c)); is it an EQE, or in mA W-1?")
    hint = (" (a table in percent? divide by 100)" if unit == "qe" and 1.0 < v.max() <= 100.0 + 1e-9 else "")
    raise ValueError(f"{where}: {'EQE' if unit == 'qe' else 'transmittance'} {v[i]:g} at {w[i]:g} nm is above 1, "
                     f"the physical limit{hint}")

OUTSIDE = ("zero", "hold", "raise")
"""What :func:`band_average` takes the curve to be beyond its table: 0, its end values, or an error."""


def band_average(wavelength, values, lower_nm, upper_nm, *, axis=-1, outside="zero"):
    """Band averages of a tabulated curve: the integral over each band divided by the band's width.

    The curve is linear between its points; the integral is exact for that piecewise-linear function.

    Parameters
    ----------
    wavelength : array_like
        (K,) strictly increasing abscissae [nm], at least 2.
    values : array_like
        The curve [any unit], with an axis of length K at ``axis`` (any other axes are carried along).
    lower_nm, upper_nm : array_like
        (C,) band limits [nm], ``upper_nm > lower_nm`` (scalars give C = 1).
    axis : int
        The axis of ``values`` along ``wavelength`` (default the last).
    outside : {"zero", "hold", "raise"}
        The curve beyond ``[wavelength[0], wavelength[-1]]``: 0 (default), its end values held constant, or
        a ValueError for a band that reaches past the table.

    Returns
    -------
    numpy.ndarray
        ``values`` with the wavelength axis replaced by the C bands [same unit as ``values``].
    """
    w = np.asarray(wavelength, dtype=float)
    v = np.moveaxis(np.asarray(values, dtype=float), axis, -1)
    lo = np.atleast_1d(np.asarray(lower_nm, dtype=float))
    hi = np.atleast_1d(np.asarray(upper_nm, dtype=float))
    if outside not in OUTSIDE:
        raise ValueError(f"outside={outside!r} is not one of {OUTSIDE}")
    if w.ndim != 1 or w.size < 2 or np.any(np.diff(w) <= 0):
        raise ValueError("wavelength must be strictly increasing with >= 2 points [nm]")
    if v.shape[-1] != w.size:
        raise ValueError(f"values must have an axis of {w.size} like wavelength at axis={axis}, got "
                         f"{np.shape(values)}")
    if lo.shape != hi.shape or np.any(hi <= lo):
        raise ValueError("band limits must have equal shapes with upper_nm > lower_nm [nm]")
    if outside == "raise" and (np.any(lo < w[0]) or np.any(hi > w[-1])):
        raise ValueError(f"bands [{lo.min()}, {hi.max()}] nm outside the spectrum's range [{w[0]}, {w[-1]}] nm")
    # cumulative integral of the piecewise-linear curve at its own knots, then at arbitrary points
    seg = 0.5 * (v[..., 1:] + v[..., :-1]) * np.diff(w)
    cum = np.concatenate([np.zeros(v.shape[:-1] + (1,)), np.cumsum(seg, axis=-1)], axis=-1)

    def integral_to(x):
        xc = np.clip(x, w[0], w[-1])
        i = np.clip(np.searchsorted(w, xc, side="right") - 1, 0, w.size - 2)
        t = xc - w[i]
        slope = (v[..., i + 1] - v[..., i]) / (w[i + 1] - w[i])
        f = cum[..., i] + v[..., i] * t + 0.5 * slope * t * t
        if outside == "hold":                       # the end values, constant beyond the table
            f = f + v[..., :1] * np.minimum(x - w[0], 0.0) + v[..., -1:] * np.maximum(x - w[-1], 0.0)
        return f

    return np.moveaxis((integral_to(hi) - integral_to(lo)) / (hi - lo), -1, axis)


STC_IRRADIANCE = 1000.0
"""Irradiance of the standard AM1.5 global spectrum over its whole range [W m-2] (IEC 60904-3 normalises the
ASTM G173-03 global tilted table, which integrates to 1000.37 W m-2, to this value)."""


@functools.lru_cache(maxsize=64)
def _g173_share(lower_nm, upper_nm):
    from .paths import runtime_file
    t = np.loadtxt(runtime_file("solar/ASTMG173.csv"), delimiter=",", skiprows=2, usecols=(0, 2))
    band = float(band_average(t[:, 0], t[:, 1], lower_nm, upper_nm)[0]) * (upper_nm - lower_nm)
    return band / STC_IRRADIANCE


def in_band_share(lower_nm=280.0, upper_nm=2480.0):
    """Share [1] of a broadband (whole solar spectrum) irradiance that a spectrum over ``lower_nm``-``upper_nm``
    carries: widesky's one convention between weather files and its band-limited spectra.

    A weather file's DNI, DHI and GHI [W m-2] are broadband: pyranometers and pyrheliometers see the whole
    solar spectrum (about 285-3000 nm and beyond). widesky's sky covers ``lower_nm``-``upper_nm`` (the Prague
    Sky Model: 280-2480 nm). Everywhere in widesky:

    - a measured broadband value ``X`` [W m-2] is matched by the in-band irradiance ``X * share`` [W m-2]
      (the integrator scales its sky so, :mod:`widesky.irradiance.step_scaling`);
    - an in-band irradiance ``E`` [W m-2] stands for the broadband irradiance ``E / share`` [W m-2] (pvsim's
      plane-of-array stages and cell temperature, thermal's total shortwave).

    So a clear-sky run and a weather run give broadband values on the same footing, and a weather run's
    broadband plane-of-array irradiance is the measured DNI/DHI transposed. ``share`` is one fixed number for
    every step and part: the ASTM G173-03 global tilted (AM1.5G) irradiance over the band divided by the
    1000 W m-2 that IEC 60904-3 takes the whole spectrum to be (280-2480 nm: 992.48 / 1000 = 0.99248, the
    same quantity pvsim's STC reference uses, so an AM1.5G-shaped spectrum has effective irradiance equal to
    its broadband irradiance). The real share varies: G173's direct beam carries 99.12 % of its irradiance
    below 2480 nm, its diffuse light all of it, and water vapour moves the beyond-2480 nm part (docs/pvsim.md).

    Parameters
    ----------
    lower_nm, upper_nm : float
        The spectrum's range [nm], 0 <= lower_nm < upper_nm (ASTM G173-03 tabulates 280-4000 nm and is taken
        as 0 outside).

    Returns
    -------
    float
        The share [1].
    """
    lo, hi = float(lower_nm), float(upper_nm)
    if not (np.isfinite(hi) and 0.0 <= lo < hi):
        raise ValueError(f"spectral range {lo:g}-{hi:g} nm: the in-band share needs 0 <= lower < upper [nm]")
    return _g173_share(lo, hi)
