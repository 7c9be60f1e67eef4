"""Layered clear-sky atmosphere from the AFGL 1986 constituent profiles.

Anderson, G. P. et al. (1986), AFGL Atmospheric Constituent Profiles (0-120 km), AFGL-TR-86-0110.
Six climates: ``us`` (US standard 1976), ``t`` (tropical), ``ms``/``mw`` (mid-latitude summer/winter),
``ss``/``sw`` (sub-arctic summer/winter), read from ``atmosphere/afgl<name>.dat`` in the data directory.

Number densities are interpolated log-linearly in altitude and integrated exactly over each layer
(sub-sampled at 10 m). Water vapour and ozone columns can be rescaled to a target precipitable
water [cm] and ozone column [DU or atm-cm]; the profile shapes are kept.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from .paths import data_file

PROFILES = ("us", "t", "ms", "mw", "ss", "sw")
DEFAULT_LEVELS_KM = np.array([0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0,
                              10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0,
                              60.0, 70.0, 80.0, 100.0])
"""Default level altitudes [km], ground to 100 km, 31 layers, 250 m thick near the ground."""

AVOGADRO = 6.02214076e23
DOBSON_MOLEC_CM2 = 2.686763e16  # molecules cm-2 per Dobson unit
H2O_MOLAR_MASS = 18.01528  # g mol-1
EARTH_RADIUS_KM = 6371.0


@functools.lru_cache(maxsize=12)
def read_afgl(profile: str = "us", data_dir=None):
    """Read an AFGL profile.

    Returns a dict of arrays ordered by increasing altitude: ``z`` [km], ``p`` [hPa], ``T`` [K] and number
    densities ``air``, ``o3``, ``o2``, ``h2o``, ``co2``, ``no2`` [cm-3].
    """
    if profile not in PROFILES:
        raise ValueError(f"profile={profile!r}: valid AFGL profiles are {PROFILES}")
    a = np.loadtxt(data_file(f"atmosphere/afgl{profile}.dat", data_dir), comments="#")[::-1]
    names = ("z", "p", "T", "air", "o3", "o2", "h2o", "co2", "no2")
    return {k: a[:, i].copy() for i, k in enumerate(names)}


@dataclass(frozen=True)
class Atmosphere:
    """A layered atmosphere, layers ordered from the ground up.

    Attributes
    ----------
    levels_km : (L+1,) level altitudes [km], increasing from the ground.
    temperature_k : (L,) layer temperature, density-weighted [K].
    pressure_hpa : (L,) layer pressure, density-weighted [hPa].
    air, o3, o2, h2o, co2 : (L,) layer columns [molecules cm-2].
    profile : AFGL profile name.
    """

    levels_km: np.ndarray
    temperature_k: np.ndarray
    pressure_hpa: np.ndarray
    air: np.ndarray
    o3: np.ndarray
    o2: np.ndarray
    h2o: np.ndarray
    co2: np.ndarray
    profile: str = "us"
    meta: dict = field(default_factory=dict, compare=False)

    @property
    def n_layers(self) -> int:
        return len(self.temperature_k)

    @property
    def thickness_km(self) -> np.ndarray:
        """Layer thickness [km], shape (L,)."""
        return np.diff(self.levels_km)

    @property
    def precipitable_water_cm(self) -> float:
        """Water vapour column [cm of precipitable water]."""
        return float(self.h2o.sum() * H2O_MOLAR_MASS / AVOGADRO)

    @property
    def ozone_du(self) -> float:
        """Ozone column [DU]."""
        return float(self.o3.sum() / DOBSON_MOLEC_CM2)

    @property
    def h2o_cm(self) -> np.ndarray:
        """Layer water vapour [cm precipitable water], shape (L,)."""
        return self.h2o * H2O_MOLAR_MASS / AVOGADRO


def standard_atmosphere(profile: str = "us", precipitable_water=None, ozone=None, ozone_unit: str = "DU",
                        levels_km=None, data_dir=None) -> Atmosphere:
    """Build a layered atmosphere from an AFGL profile.

    Parameters
    ----------
    profile : str
        AFGL climate: ``'us'`` (default), ``'t'``, ``'ms'``, ``'mw'``, ``'ss'``, ``'sw'``.
    precipitable_water : float, optional
        Target water vapour column [cm]; ``None`` keeps the profile's own (US standard: 1.42 cm).
    ozone : float, optional
        Target ozone column in ``ozone_unit``; ``None`` keeps the profile's own (US standard: 345 DU).
    ozone_unit : str
        ``'DU'`` [DU] or ``'atm-cm'`` [atm-cm] (1 atm-cm = 1000 DU).
    levels_km : array_like, optional
        Level altitudes [km] from 0 (ground) increasing to at most 120; default :data:`DEFAULT_LEVELS_KM`.
    data_dir : path-like, optional
        Input data directory.

    Returns
    -------
    Atmosphere
    """
    levels = DEFAULT_LEVELS_KM if levels_km is None else np.asarray(levels_km, float)
    if levels.ndim != 1 or len(levels) < 2 or levels[0] != 0.0 or np.any(np.diff(levels) <= 0) or levels[-1] > 120:
        raise ValueError(f"levels_km must increase strictly from 0 to at most 120 km, got {levels}")
    prof = read_afgl(profile, None if data_dir is None else str(data_dir))
    z = prof["z"]
    cols = {}
    nsub = np.maximum(np.ceil(np.diff(levels) / 0.01).astype(int), 1)
    t_layer = np.empty(len(levels) - 1)
    p_layer = np.empty(len(levels) - 1)
    for name in ("air", "o3", "o2", "h2o", "co2"):
        cols[name] = np.empty(len(levels) - 1)
    for i in range(len(levels) - 1):
        zz = np.linspace(levels[i], levels[i + 1], nsub[i] + 1)
        dz_cm = (zz[1] - zz[0]) * 1e5
        w = np.full(len(zz), dz_cm)
        w[0] = w[-1] = 0.5 * dz_cm
        dens = {}
        for name in ("air", "o3", "o2", "h2o", "co2"):
            dens[name] = np.exp(np.interp(zz, z, np.log(np.maximum(prof[name], 1e-30))))
            cols[name][i] = np.sum(w * dens[name])
        tt = np.interp(zz, z, prof["T"])
        pp = np.exp(np.interp(zz, z, np.log(prof["p"])))
        t_layer[i] = np.sum(w * dens["air"] * tt) / cols["air"][i]
        p_layer[i] = np.sum(w * dens["air"] * pp) / cols["air"][i]
    meta = {"profile": profile, "native_pw_cm": cols["h2o"].sum() * H2O_MOLAR_MASS / AVOGADRO,
            "native_ozone_du": cols["o3"].sum() / DOBSON_MOLEC_CM2}
    if precipitable_water is not None:
        pw = float(precipitable_water)
        if not (0.0 <= pw <= 15.0):
            raise ValueError(f"precipitable_water={pw} cm outside the valid range [0, 15]")
        cols["h2o"] = cols["h2o"] * (pw / meta["native_pw_cm"])
    if ozone is not None:
        if ozone_unit not in ("DU", "atm-cm"):
            raise ValueError(f"ozone_unit={ozone_unit!r}: use 'DU' or 'atm-cm'")
        du = float(ozone) * (1000.0 if ozone_unit == "atm-cm" else 1.0)
        if not (0.0 <= du <= 1000.0):
            raise ValueError(f"ozone={ozone} {ozone_unit} outside the valid range [0, 1000] DU")
        cols["o3"] = cols["o3"] * (du / meta["native_ozone_du"])
    return Atmosphere(levels_km=levels.copy(), temperature_k=t_layer, pressure_hpa=p_layer, profile=profile,
                      meta=meta, **cols)


def slant_path_factors(levels_km, zenith_deg, earth_radius_km: float = EARTH_RADIUS_KM) -> np.ndarray:
    """Geometric path length through each spherical shell divided by the shell thickness (no refraction).

    Parameters
    ----------
    levels_km : (L+1,) level altitudes [km], ground first.
    zenith_deg : array_like, shape (N,)
        Zenith angle of the ray at the ground [deg], 0-90.
    earth_radius_km : float
        Earth radius [km].

    Returns
    -------
    numpy.ndarray, shape (N, L)
        Path factor per layer [1]; the plane-parallel value is 1/cos(zenith) for every layer.
    """
    th = np.radians(np.atleast_1d(np.asarray(zenith_deg, float)))
    if np.any((th < 0) | (th > np.pi / 2 + 1e-12)):
        raise ValueError(f"zenith_deg={zenith_deg!r} outside [0, 90]")
    r = earth_radius_km + np.asarray(levels_km, float)
    b = (earth_radius_km * np.sin(th))[:, None]  # impact parameter
    s = np.sqrt(np.maximum(r[None, :] ** 2 - b ** 2, 0.0))
    return np.diff(s, axis=1) / np.diff(r)[None, :]
