"""Shortwave on building surfaces from weather data alone, and opaque surfaces (pure numpy).

The integrator (:func:`widesky.irradiance.poa_irradiance`) is widesky's way of getting per-surface
irradiance: a spectral sky, shading and reflections from the scene. For an unobstructed box driven
by a weather file (the ASHRAE 140 cases) this module gives the weather-only route the Standard's
reference programs use: the Hay-Davies (1980) anisotropic transposition, whose circumsolar part is
counted with the beam (it arrives from the sun's direction, so window optics take it at the beam's
angle), plus ground-reflected light from an isotropic ground of albedo ``albedo``.

Sol-air temperature (ASHRAE Handbook Fundamentals 2017, ch. 18 eq. 30):
``t_sol_air = t_out + alpha G / h_o - eps dR / h_o`` with the long-wave deficit ``dR`` to the sky.

Units: angles [deg] (azimuth clockwise from north, 180 = south), irradiance [W m-2], temperatures
[degC], coefficients [W m-2 K-1].
"""

from __future__ import annotations

import numpy as np

__all__ = ["aoi", "surface_irradiance", "absorbed_solar", "sol_air_temperature",
           "sky_temperature", "SIGMA"]

SIGMA = 5.670374419e-8


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


def surface_irradiance(surface_tilt, surface_azimuth, solar_zenith, solar_azimuth, dni, dhi, ghi,
                       dni_extra, albedo=0.2):
    """Hay-Davies irradiance on planes, split into beam (with circumsolar), sky and ground parts.

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

    Returns
    -------
    dict of numpy.ndarray
        (T, S) [W m-2]: ``poa_direct`` (beam including the circumsolar part of the diffuse),
        ``poa_sky_diffuse`` (isotropic part), ``poa_ground_diffuse``, ``poa_global``; and ``aoi``
        (T, S) [deg].
    """
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
    rb = cos_i / np.maximum(cos_z, 0.01745)                   # cos(89 deg) floor near the horizon
    ai = np.clip(dni / np.maximum(dne, 1.0), 0.0, 1.0)
    beam = dni * cos_i
    circ = dhi * ai * rb
    iso = dhi * (1 - ai) * 0.5 * (1 + np.cos(np.radians(tilt)))
    ground = ghi * np.asarray(albedo, float).reshape(-1, 1) * 0.5 * (1 - np.cos(np.radians(tilt)))
    direct = beam + circ
    return {"poa_direct": direct, "poa_sky_diffuse": iso,
            "poa_ground_diffuse": np.broadcast_to(ground, direct.shape).copy(),
            "poa_global": direct + iso + ground, "aoi": theta}


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
