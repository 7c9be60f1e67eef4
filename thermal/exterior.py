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
           "hourly_u_value", "ROUGHNESS_MULTIPLIER", "TERRAIN", "energyplus_wind_at_height", "windward",
           "tarp_natural_convection", "mowitt_forced_convection", "doe2_convection", "energyplus_longwave"]

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


# --------------------------------------------------------------------------- EnergyPlus's outside surface model
#
# EnergyPlus's default outside convection ("DOE-2", SurfaceConvectionAlgorithm:Outside) and its outside long-wave
# exchange, as its source applies them (checked against NREL/EnergyPlus src/EnergyPlus/ConvectionCoefficients.cc,
# 2022: InitExteriorConvectionCoeffs, Windward, CalcASHRAETARPNatural, CalcMoWITTForcedWindward/Leeward,
# CalcDOE2Forced/Windward/Leeward, RoughnessMultiplier; SurfaceGeometry.cc: SurfAirSkyRadSplit; HeatBalanceManager.cc:
# the Building object's terrain; DataEnvironment: WeatherFileWindModCoeff 1.5863 = (270/10)^0.14).

ROUGHNESS_MULTIPLIER = {"very_rough": 2.17, "rough": 1.67, "medium_rough": 1.52, "medium_smooth": 1.13,
                        "smooth": 1.11, "very_smooth": 1.0}
"""EnergyPlus's ``RoughnessMultiplier`` R_f [1] by surface roughness (ConvectionCoefficients.cc; the DOE-2 and
TARP outside models multiply the forced part by it). EnergyPlus gives glazing ``VerySmooth`` (Material.cc,
WindowMaterial:Glazing); the ASHRAE 140-2020 case files give the opaque outside surfaces ``Rough``."""

TERRAIN = {"country": (0.14, 270.0), "suburbs": (0.22, 370.0), "city": (0.33, 460.0), "ocean": (0.10, 210.0),
           "urban": (0.22, 370.0)}
"""EnergyPlus's site terrain (``Building`` object) -> (wind profile exponent [1], boundary layer height [m])
(HeatBalanceManager.cc; EnergyPlus's default is ``"suburbs"``; the weather station's own profile is
``"country"``'s with the sensor at 10 m)."""


def energyplus_wind_at_height(wind_speed, height, terrain="country", meteo_height=METEO_HEIGHT,
                              meteo_terrain="country"):
    """Wind at ``height`` [m] above ground [m s-1] by EnergyPlus's site wind profile (``OutWindSpeedAt``):
    ``v (delta_met / z_met)^a_met (z / delta)^a`` with the station's exponent and boundary layer ``a_met``,
    ``delta_met`` (``meteo_terrain``, default open country: 0.14, 270 m) and the site's ``a``, ``delta``
    (``terrain``, a key of :data:`TERRAIN`). With both ``"country"`` it equals :func:`wind_at_height`;
    EnergyPlus's default site (``"suburbs"``) gives 0.461 of the station's wind at 1.35 m against 0.756."""
    if terrain not in TERRAIN or meteo_terrain not in TERRAIN:
        raise ValueError(f"terrain={terrain!r} / meteo_terrain={meteo_terrain!r} not in {tuple(TERRAIN)}")
    v = np.asarray(wind_speed, float)
    if np.any(v < 0) or not np.all(np.isfinite(v)):
        raise ValueError("wind_speed must be finite and >= 0 m s-1")
    if not height > 0:
        raise ValueError(f"height={height!r} m must be > 0")
    a_met, d_met = TERRAIN[meteo_terrain]
    a, d = TERRAIN[terrain]
    return v * (d_met / meteo_height) ** a_met * (height / d) ** a


def windward(wind_direction, azimuth, cos_tilt):
    """True where a surface faces the wind, by EnergyPlus's rule (``Windward``): a surface with
    ``|cos tilt| >= 0.98`` (near horizontal) is always windward; otherwise it is leeward when the wind direction
    [deg, clockwise from north, where the wind comes from] is more than 90 degrees (plus 0.001) from the surface's
    outward azimuth [deg]. (The source's comment says 100 degrees; its code tests 90.)"""
    wd = np.asarray(wind_direction, float)
    diff = np.abs(wd - azimuth)
    diff = np.where(diff - 180.0 > 0.001, diff - 360.0, diff)
    lee = (np.abs(diff) - 90.0) > 0.001
    return np.logical_or(abs(cos_tilt) >= 0.98, ~lee)


def tarp_natural_convection(dt, cos_tilt):
    """Walton's (TARP) natural convection of a surface [W m-2 K-1] (EnergyPlus ``CalcASHRAETARPNatural``).

    ``dt`` surface minus air [K]; ``cos_tilt`` [1] the cosine of the tilt of the face's outward normal (1: facing
    up, e.g. a roof's outside; -1: facing down, a raised floor's underside; 0: vertical). Vertical or ``dt = 0``:
    ``1.31 |dt|^(1/3)``; a warm face looking up or a cold one looking down (unstable):
    ``9.482 |dt|^(1/3) / (7.238 - |cos|)``; otherwise (stable) ``1.810 |dt|^(1/3) / (1.382 + |cos|)``. No lower
    limit (the outside model adds none). Arrays broadcast."""
    dt = np.asarray(dt, float)
    cos_tilt = np.asarray(cos_tilt, float)
    a = np.cbrt(np.abs(dt))
    c = np.abs(cos_tilt)
    unstable = (dt > 0) == (cos_tilt > 0)
    h = np.where(unstable, 9.482 * a / (7.238 - c), 1.810 * a / (1.382 + c))
    return np.where(c < 1e-9, 1.31 * a, h)


def mowitt_forced_convection(wind_speed, is_windward):
    """MoWiTT's forced convection of a smooth surface [W m-2 K-1] (Yazdanian and Klems 1994, as EnergyPlus's
    ``CalcMoWITTForcedWindward`` / ``Leeward``): ``3.26 v^0.89`` windward, ``3.55 v^0.617`` leeward, ``v`` the
    wind at the surface [m s-1]."""
    v = np.asarray(wind_speed, float)
    if np.any(v < 0) or not np.all(np.isfinite(v)):
        raise ValueError("wind_speed must be finite and >= 0 m s-1")
    return np.where(is_windward, 3.26 * v ** 0.89, 3.55 * v ** 0.617)


def doe2_convection(dt, cos_tilt, h_forced_smooth, roughness_multiplier):
    """EnergyPlus's DOE-2 outside convection [W m-2 K-1] (``InitExteriorConvectionCoeffs``, case DOE-2;
    ``CalcDOE2Forced``): ``h = h_n + R_f (sqrt(h_n^2 + h_f^2) - h_n)`` with ``h_n`` Walton's natural convection
    (:func:`tarp_natural_convection` at ``dt`` surface minus air [K] and the outward normal's ``cos_tilt``),
    ``h_f`` the smooth surface's forced part (:func:`mowitt_forced_convection`) [W m-2 K-1] and ``R_f`` the
    roughness multiplier [1] (:data:`ROUGHNESS_MULTIPLIER`)."""
    hn = tarp_natural_convection(dt, cos_tilt)
    hf = np.asarray(h_forced_smooth, float)
    return hn + roughness_multiplier * (np.sqrt(hn * hn + hf * hf) - hn)


def energyplus_longwave(temp_surface, temp_air, temp_sky, tilt, emissivity=0.9, exposed=True):
    """Outside long-wave coefficients [W m-2 K-1] as EnergyPlus linearises them (``InitExteriorConvectionCoeffs``):
    to the sky ``h_sky = eps sigma F_sky beta (T_s^4 - T_sky^4) / (T_s - T_sky)``, to the ground at the air
    temperature ``h_gnd = eps sigma F_gnd (T_s^4 - T_a^4) / (T_s - T_a)`` and to the air
    ``h_air = eps sigma F_sky (1 - beta) (T_s^4 - T_a^4) / (T_s - T_a)``, with ``F_sky = (1 + cos tilt) / 2``,
    ``F_gnd = (1 - cos tilt) / 2`` and the air/sky split ``beta = sqrt((1 + cos tilt) / 2)`` (SurfaceGeometry.cc,
    ``SurfAirSkyRadSplit``); temperatures [degC] (``T_s`` the surface's, in EnergyPlus the previous time step's),
    ``tilt`` of the outward normal [deg]. ``exposed=False``: no sky (everything at the air temperature). Arrays
    broadcast.

    Returns
    -------
    h_sky, h_ambient : numpy.ndarray
        The sky's coefficient and the ground's plus the air's (both at the outdoor air temperature).
    """
    ts = np.asarray(temp_surface, float) + 273.15
    ta = np.asarray(temp_air, float) + 273.15
    tk = np.asarray(temp_sky, float) + 273.15
    c = np.cos(np.radians(np.asarray(tilt, float)))
    f_sky = np.where(exposed, 0.5 * (1.0 + c), 0.0)
    beta = np.sqrt(0.5 * (1.0 + c))
    sk = emissivity * SIGMA * (ts * ts + tk * tk) * (ts + tk)            # (T_s^4 - T^4) / (T_s - T)
    sa = emissivity * SIGMA * (ts * ts + ta * ta) * (ts + ta)
    return f_sky * beta * sk, (1.0 - f_sky) * sa + f_sky * (1.0 - beta) * sa
