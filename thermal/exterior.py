"""Hourly outside surface coefficients and the U-values they give.

ISO 13790 (and EN 673 for glazing) use one constant outside surface resistance, ``R_se = 0.04``
m2 K W-1 (``h_e`` about 25 W m-2 K-1, the value of ISO 6946 Annex C at a wind speed of 4 m s-1).
On a calm night the real coefficient is a third of that, so an element's U-value falls (most for
glazing, whose own resistance is small) exactly when the heating peaks. These functions give the
coefficient per step from the wind and the air temperature, and the U-value and outside surface
resistance that go with it:

* ``h_c = 4 + 4 v`` (convection), ``h_r = eps 4 sigma T_m^3`` (long-wave; ISO 6946:2017 Annex C,
  eqs. C.5-C.6 and Table C.1; ``T_m`` taken as the outdoor air temperature), ``h_e = h_c + h_r``;
* ``v`` the wind near the surface: the weather station's 10 m wind brought to the element's height
  by the power law of ASHRAE Handbook Fundamentals 2017 ch. 24 eq. (4) with the station's and the
  site's terrain both open country (exponent 0.14, boundary layer 270 m: ``v = v_10 (z/10)^0.14``);
* ``U(t) = 1 / (1/U_n - R_se,n + 1/h_e(t))``: the element's resistance without its nominal outside
  resistance, plus the hourly one.

The long-wave loss to the sky (ISO 13790 11.3.5, :func:`widesky.thermal.loads.sky_losses`) and the
absorbed solar that reaches the zone (11.3.4, :func:`widesky.thermal.loads.opaque_gains`) then take
``R_se(t) = 1 / h_e(t)`` with ``U(t)``.

Units: wind [m s-1], heights [m], temperatures [degC], coefficients [W m-2 K-1], resistances
[m2 K W-1].
"""

from __future__ import annotations

import numpy as np

__all__ = ["WIND_EXPONENT", "METEO_HEIGHT", "wind_at_height", "exterior_coefficients",
           "hourly_u_value"]

SIGMA = 5.670374419e-8
WIND_EXPONENT = 0.14
"""Power-law exponent of open country (ASHRAE Fundamentals 2017 ch. 24 Table 1) [1]."""
METEO_HEIGHT = 10.0
"""Height of the weather station's wind measurement [m] (TMY3, EPW)."""


def wind_at_height(wind_speed, height, exponent=WIND_EXPONENT, meteo_height=METEO_HEIGHT):
    """Wind speed at ``height`` [m s-1] from the station's ``wind_speed`` [m s-1] at
    ``meteo_height`` [m], same terrain: ``v (height / meteo_height) ** exponent``."""
    v = np.asarray(wind_speed, float)
    if np.any(v < 0) or not np.all(np.isfinite(v)):
        raise ValueError("wind_speed must be finite and >= 0 m s-1")
    if not height > 0:
        raise ValueError(f"height={height!r} m must be > 0")
    return v * (height / meteo_height) ** exponent


def exterior_coefficients(wind_speed, temp_air, emissivity=0.9):
    """Outside convective and radiative surface coefficients [W m-2 K-1] (ISO 6946:2017 C.5-C.6).

    Parameters
    ----------
    wind_speed : array_like
        Wind near the surface [m s-1] (see :func:`wind_at_height`).
    temp_air : array_like
        Outdoor air temperature [degC] (the mean radiant temperature of the formula).
    emissivity : float
        Long-wave emissivity of the outside surface [1].

    Returns
    -------
    h_c, h_r : numpy.ndarray
        ``4 + 4 v`` and ``emissivity 4 sigma T^3``.
    """
    if not 0 < emissivity <= 1:
        raise ValueError(f"emissivity={emissivity!r} outside (0, 1]")
    v = np.asarray(wind_speed, float)
    if np.any(v < 0) or not np.all(np.isfinite(v)):
        raise ValueError("wind_speed must be finite and >= 0 m s-1")
    t = np.asarray(temp_air, float) + 273.15
    return 4.0 + 4.0 * v, emissivity * 4.0 * SIGMA * t ** 3


def hourly_u_value(u_value, h_out, r_se_nominal=0.04):
    """U-value with the outside coefficient ``h_out`` [W m-2 K-1] instead of the nominal one.

    Parameters
    ----------
    u_value : float
        Nominal thermal transmittance [W m-2 K-1], computed with ``r_se_nominal``.
    h_out : array_like
        Outside surface coefficient per step [W m-2 K-1].
    r_se_nominal : float
        Outside surface resistance inside ``u_value`` [m2 K W-1] (ISO 6946 and ISO 13790: 0.04;
        EN 673 glazing: 1/23).

    Returns
    -------
    numpy.ndarray
        ``1 / (1/u_value - r_se_nominal + 1/h_out)`` [W m-2 K-1].
    """
    h = np.asarray(h_out, float)
    if np.any(h <= 0):
        raise ValueError("h_out must be > 0 W m-2 K-1")
    r_in = 1.0 / u_value - r_se_nominal
    if not u_value > 0 or r_in <= 0:
        raise ValueError(f"u_value={u_value!r} W m-2 K-1 must be > 0 and below 1/r_se_nominal = "
                         f"{1 / r_se_nominal:.1f}")
    return 1.0 / (r_in + 1.0 / h)
