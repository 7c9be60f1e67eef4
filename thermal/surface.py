"""Shortwave on building surfaces from weather data alone, and opaque surfaces (pure numpy).

The integrator (:func:`widesky.irradiance.poa_irradiance`) is widesky's way of getting per-surface
irradiance: a spectral sky, shading and reflections from the scene. For an unobstructed box driven
by a weather file (the ASHRAE 140 cases) this module gives the weather-only route the Standard's
reference programs use: an anisotropic transposition of the file's DNI and DHI, by default Perez et al. (1990)
(circumsolar, isotropic and horizon-band parts; :data:`PEREZ_1990_COEFFICIENTS`), or Hay-Davies (1980)
(circumsolar and isotropic), plus ground-reflected light from an isotropic ground of albedo ``albedo``. The
circumsolar part is counted with the beam (it arrives from the sun's direction, so window optics take it at the
beam's angle); the horizon band is returned on its own as well, for shading and window optics of its own.

Sol-air temperature (ASHRAE Handbook Fundamentals 2017, ch. 18 eq. 30):
``t_sol_air = t_out + alpha G / h_o - eps dR / h_o`` with the long-wave deficit ``dR`` to the sky.

Units: angles [deg] (azimuth clockwise from north, 180 = south), irradiance [W m-2], temperatures
[degC], coefficients [W m-2 K-1].
"""

from __future__ import annotations

import numpy as np

from widesky.irradiance.perez_sky import PEREZ_1993_EPSILON_EDGES, perez_clearness_brightness

__all__ = ["aoi", "surface_irradiance", "perez_sky_parts", "absorbed_solar", "sol_air_temperature",
           "sky_temperature", "SIGMA", "PEREZ_1990_COEFFICIENTS", "TRANSPOSITIONS"]

SIGMA = 5.670374419e-8

TRANSPOSITIONS = ("perez", "hay-davies")
"""Transpositions of the weather route [-]: the first is the default."""

PEREZ_1990_COEFFICIENTS = np.array([
    # F11      F12      F13      F21      F22      F23        sky clearness epsilon
    [-0.008, 0.588, -0.062, -0.060, 0.072, -0.022],   # 1.000-1.065 (overcast)
    [0.130, 0.683, -0.151, -0.019, 0.066, -0.029],    # 1.065-1.230
    [0.330, 0.487, -0.221, 0.055, -0.064, -0.026],    # 1.230-1.500
    [0.568, 0.187, -0.295, 0.109, -0.152, -0.014],    # 1.500-1.950
    [0.873, -0.392, -0.362, 0.226, -0.462, 0.001],    # 1.950-2.800
    [1.132, -1.237, -0.412, 0.288, -0.823, 0.056],    # 2.800-4.500
    [1.060, -1.600, -0.359, 0.264, -1.127, 0.131],    # 4.500-6.200
    [0.678, -0.327, -0.250, 0.156, -1.377, 0.251],    # > 6.2 (clear)
])
"""(8, 6) Perez et al. (1990) irradiance coefficients ``F11, F12, F13, F21, F22, F23`` [1] per sky-clearness bin
(the bins' upper edges: :data:`widesky.irradiance.perez_sky.PEREZ_1993_EPSILON_EDGES`): Perez, Ineichen, Seals,
Michalsky, Stewart (1990), "Modeling daylight availability and irradiance components from direct and global
irradiance", Solar Energy 44(5), 271-289, Table 6 (the all-sites composite). ``F1 = max(0, F11 + F12 Delta + F13
Z)``, ``F2 = F21 + F22 Delta + F23 Z`` with the sun's zenith ``Z`` [rad] and the sky brightness ``Delta``."""


def aoi(surface_tilt, surface_azimuth, solar_zenith, solar_azimuth):
    """Angle of incidence of the beam on a plane [deg] (0-180; > 90: the sun is behind it).

    Parameters
    ----------
    surface_tilt : array_like
        [deg] from horizontal (90 = vertical wall).
    surface_azimuth : array_like
        [deg] clockwise from north the plane faces.
    solar_zenith, solar_azimuth : array_like
        [deg].
    """
    t, sa = np.radians(surface_tilt), np.radians(surface_azimuth)
    z, a = np.radians(solar_zenith), np.radians(solar_azimuth)
    c = np.cos(z) * np.cos(t) + np.sin(z) * np.sin(t) * np.cos(a - sa)
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def perez_sky_parts(surface_tilt, surface_azimuth, solar_zenith, solar_azimuth, dni, dhi, dni_extra):
    """Perez et al. (1990) sky diffuse on planes: isotropic, circumsolar and horizon-band parts [W m-2].

    ``isotropic = DHI (1 - F1) (1 + cos tilt) / 2``, ``circumsolar = DHI F1 a / b`` with ``a = max(0, cos aoi)``,
    ``b = max(cos 85 deg, cos Z)``, ``horizon = DHI F2 sin tilt`` (the horizon band, negative under overcast
    skies: a horizon darker than the zenith); ``F1``, ``F2`` from :data:`PEREZ_1990_COEFFICIENTS` for the sky
    clearness ``epsilon = ((DHI + DNI) / DHI + 1.041 Z^3) / (1 + 1.041 Z^3)`` and brightness ``Delta = DHI m /
    E0`` (Kasten-Young air mass; :func:`widesky.irradiance.perez_sky.perez_clearness_brightness`, the same
    clearness and brightness as the all-sky model's angular shape). Where the three parts sum below zero on a
    plane, all three are zero (as pvlib does); with the sun at or below the horizon or no DHI the sky is
    isotropic (``F1 = F2 = 0``).

    Parameters
    ----------
    surface_tilt, surface_azimuth : array_like
        (S,) [deg].
    solar_zenith, solar_azimuth : array_like
        (T,) [deg].
    dni, dhi, dni_extra : array_like
        (T,) [W m-2].

    Returns
    -------
    dict of numpy.ndarray
        (T, S) ``isotropic``, ``circumsolar``, ``horizon`` [W m-2]; (T,) ``F1``, ``F2``, ``epsilon``,
        ``delta`` [1].
    """
    tilt = np.radians(np.atleast_1d(np.asarray(surface_tilt, float)))[None, :]
    az = np.atleast_1d(np.asarray(surface_azimuth, float))[None, :]
    zen = np.atleast_1d(np.asarray(solar_zenith, float))
    dhi = np.atleast_1d(np.asarray(dhi, float))
    eps, delta, ok = perez_clearness_brightness(dhi, dni, 90.0 - zen, dni_extra)
    k = np.searchsorted(PEREZ_1993_EPSILON_EDGES, eps, side="right")
    f = PEREZ_1990_COEFFICIENTS[k]                                     # (T, 6)
    z = np.radians(zen)
    f1 = np.where(ok, np.maximum(f[:, 0] + f[:, 1] * delta + f[:, 2] * z, 0.0), 0.0)
    f2 = np.where(ok, f[:, 3] + f[:, 4] * delta + f[:, 5] * z, 0.0)
    saz = np.atleast_1d(np.asarray(solar_azimuth, float))
    a = np.maximum(np.cos(np.radians(aoi(np.degrees(tilt), az, zen[:, None], saz[:, None]))), 0.0)
    b = np.maximum(np.cos(z), np.cos(np.radians(85.0)))[:, None]
    d = dhi[:, None]
    iso = d * (1.0 - f1[:, None]) * 0.5 * (1.0 + np.cos(tilt))
    circ = d * f1[:, None] * a / b
    hor = d * f2[:, None] * np.sin(tilt)
    keep = (iso + circ + hor) > 0
    return {"isotropic": np.where(keep, iso, 0.0), "circumsolar": np.where(keep, circ, 0.0),
            "horizon": np.where(keep, hor, 0.0), "F1": f1, "F2": f2, "epsilon": eps, "delta": delta}


def surface_irradiance(surface_tilt, surface_azimuth, solar_zenith, solar_azimuth, dni, dhi, ghi,
                       dni_extra, albedo=0.2, transposition="perez"):
    """Irradiance on planes from a weather file, split into beam (with circumsolar), sky and ground parts.

    Parameters
    ----------
    surface_tilt, surface_azimuth : array_like
        (S,) [deg].
    solar_zenith, solar_azimuth : array_like
        (T,) [deg].
    dni, dhi, ghi, dni_extra : array_like
        (T,) [W m-2].
    albedo : float or array_like
        Ground reflectance [1], scalar or (T,).
    transposition : str
        ``"perez"`` (Perez et al. 1990, :func:`perez_sky_parts`, the default) or ``"hay-davies"`` (Hay and
        Davies 1980: anisotropy index ``DNI / E0`` of the DHI circumsolar, the rest isotropic).

    Returns
    -------
    dict of numpy.ndarray
        (T, S) [W m-2]: ``poa_direct`` (beam including the circumsolar part of the diffuse),
        ``poa_sky_diffuse`` (isotropic part and horizon band), ``poa_ground_diffuse``, ``poa_global``,
        ``poa_circumsolar`` and ``poa_horizon`` (the parts in ``poa_direct`` and ``poa_sky_diffuse``; the
        horizon band is 0 with Hay-Davies); and ``aoi`` (T, S) [deg].
    """
    if transposition not in TRANSPOSITIONS:
        raise ValueError(f"transposition={transposition!r} not one of {', '.join(TRANSPOSITIONS)}")
    tilt = np.atleast_1d(np.asarray(surface_tilt, float))[None, :]
    az = np.atleast_1d(np.asarray(surface_azimuth, float))[None, :]
    zen = np.asarray(solar_zenith, float)[:, None]
    dni, dhi, ghi, dne = (np.asarray(v, float)[:, None] for v in (dni, dhi, ghi, dni_extra))
    for name, v in (("dni", dni), ("dhi", dhi), ("ghi", ghi)):
        if np.any(v < 0) or not np.all(np.isfinite(v)):
            raise ValueError(f"{name} must be finite and >= 0 W m-2")
    theta = aoi(tilt, az, zen, np.asarray(solar_azimuth, float)[:, None])
    cos_i = np.maximum(np.cos(np.radians(theta)), 0.0)
    cos_z = np.cos(np.radians(zen))
    beam = dni * cos_i
    if transposition == "perez":
        p = perez_sky_parts(tilt[0], az[0], zen[:, 0], np.asarray(solar_azimuth, float), dni[:, 0], dhi[:, 0],
                            dne[:, 0])
        circ, hor = p["circumsolar"], p["horizon"]
        sky = p["isotropic"] + hor
    else:
        rb = cos_i / np.maximum(cos_z, 0.01745)                   # cos(89 deg) floor near the horizon
        ai = np.clip(dni / np.maximum(dne, 1.0), 0.0, 1.0)
        circ = dhi * ai * rb
        hor = np.zeros_like(circ)
        sky = dhi * (1 - ai) * 0.5 * (1 + np.cos(np.radians(tilt)))
    ground = ghi * np.asarray(albedo, float).reshape(-1, 1) * 0.5 * (1 - np.cos(np.radians(tilt)))
    direct = beam + circ
    return {"poa_direct": direct, "poa_sky_diffuse": sky,
            "poa_ground_diffuse": np.broadcast_to(ground, direct.shape).copy(),
            "poa_global": direct + sky + ground, "poa_circumsolar": circ, "poa_horizon": hor, "aoi": theta}


def absorbed_solar(poa_global, absorptance):
    """Shortwave absorbed on an opaque surface [W m-2] = absorptance [1] x incident [W m-2]."""
    a = np.asarray(absorptance, float)
    if np.any((a < 0) | (a > 1)):
        raise ValueError(f"absorptance={a!r} outside [0, 1]")
    return a * np.asarray(poa_global, float)


def sky_temperature(horizontal_infrared):
    """Effective sky temperature [degC] from the horizontal long-wave irradiance [W m-2]."""
    ir = np.asarray(horizontal_infrared, float)
    if np.any(ir <= 0):
        raise ValueError("horizontal_infrared must be > 0 W m-2")
    return (ir / SIGMA) ** 0.25 - 273.15


def sol_air_temperature(temp_air, poa_global, absorptance, h_out=17.0, emissivity=0.9,
                        temp_sky=None, surface_tilt=90.0):
    """Sol-air temperature [degC] of an opaque outside surface.

    Parameters
    ----------
    temp_air : array_like
        Outdoor air temperature [degC].
    poa_global : array_like
        Incident shortwave [W m-2].
    absorptance : float
        Solar absorptance [1].
    h_out : float
        Combined outside surface coefficient [W m-2 K-1] (ASHRAE: 17).
    emissivity : float
        Long-wave emissivity [1].
    temp_sky : array_like, optional
        Sky temperature [degC]; None: no long-wave correction.
    surface_tilt : float
        [deg]; the surface sees the sky with view factor (1 + cos tilt) / 2 and the ground (at air
        temperature) with the rest.
    """
    if h_out <= 0:
        raise ValueError(f"h_out={h_out!r} W m-2 K-1 must be > 0")
    ta = np.asarray(temp_air, float)
    t = ta + absorbed_solar(poa_global, absorptance) / h_out
    if temp_sky is not None:
        f_sky = 0.5 * (1 + np.cos(np.radians(surface_tilt)))
        tk, tsk = ta + 273.15, np.asarray(temp_sky, float) + 273.15
        d_r = f_sky * SIGMA * (tk ** 4 - tsk ** 4)
        t = t - emissivity * d_r / h_out
    return t
