"""Solar gains per surface and hourly loads per zone of a :class:`~thermal.building.Building`.

Per surface and step (ISO 13790:2008 section 11.3, with the window's own optics instead of the
standard's F_w g_n):

* window: ``A (1 - frame) (E_direct g(aoi) + (E_sky + E_ground) g_diffuse)`` [W], with ``g`` the
  unit's solar heat gain coefficient by incidence angle (broadband route) -- or, on the spectral
  route, the integrator's irradiance weighted per channel and incoming direction by the unit's
  spectral-angular g (see :mod:`widesky.thermal.gains`);
* opaque: ``alpha R_se U A E_global`` (absorbed shortwave that reaches the zone, ``R_se = 0.04``);
* long-wave loss to the sky: ``R_se U A h_r F_r (theta_air - theta_sky)``, ``h_r = 4 eps sigma
  T_mean^3``, ``F_r = (1 + cos tilt) / 2``.

Zones are coupled to the outside only (walls between zones and intermediate floors are adiabatic).
Ground floors: ``U`` times the construction's temperature-adjustment factor ``b`` to outdoor air
(ISO 13790 8.3).

Units: areas [m2], U [W m-2 K-1], irradiance [W m-2], heat flows [W], energy [kWh], temperatures
[degC], angles [deg].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from .glazing import ANGLES, GlazingUnit
from .optics import hemispherical
from .zone import ZoneParameters, simulate_5r1c

__all__ = ["Construction", "MASS_CLASSES", "R_SE", "window_gains", "opaque_gains", "sky_losses",
           "zone_parameters", "building_loads", "LoadsResult", "glazing_g_table"]

R_SE = 0.04
"""External surface resistance [m2 K W-1] (ISO 13790 11.3.4)."""
SIGMA = 5.670374419e-8

MASS_CLASSES = {
    # ISO 13790:2008 Table 12: effective mass area A_m / A_f [1], internal capacity C_m / A_f [J m-2 K-1]
    "very light": (2.5, 80000.0), "light": (2.5, 110000.0), "medium": (2.5, 165000.0),
    "heavy": (3.0, 260000.0), "very heavy": (3.5, 370000.0),
}


@dataclass(frozen=True)
class Construction:
    """An element type's thermal and solar properties.

    Attributes
    ----------
    name : str
    u_value : float, optional
        [W m-2 K-1]; windows default to the glazing unit's EN 673 value.
    absorptance : float
        Outside solar absorptance of opaque elements [1].
    emissivity : float
        Outside long-wave emissivity [1].
    glazing : GlazingUnit, optional
        For windows.
    frame_fraction : float
        Opaque frame share of a window's area [1] (frame U taken equal to the glazing's).
    b : float
        Temperature-adjustment factor to outdoor air [1] (1: outside air; ground floors < 1).
    """

    name: str
    u_value: float = None
    absorptance: float = 0.6
    emissivity: float = 0.9
    glazing: GlazingUnit = None
    frame_fraction: float = 0.0
    b: float = 1.0

    def __post_init__(self):
        if self.u_value is None:
            if self.glazing is None:
                raise ValueError(f"construction {self.name!r}: give u_value or glazing")
            object.__setattr__(self, "u_value", float(self.glazing.u_value()))
        for name, lo, hi in (("u_value", 0.0, 10.0), ("absorptance", 0, 1), ("emissivity", 0, 1),
                             ("frame_fraction", 0, 0.99), ("b", 0, 1)):
            v = getattr(self, name)
            if not lo <= v <= hi:
                raise ValueError(f"construction {self.name!r}: {name}={v!r} outside [{lo}, {hi}]")


def glazing_g_table(unit: GlazingUnit, spectrum_wavelength, spectrum):
    """Broadband g by incidence angle of a unit, weighted by one spectrum (the rated route).

    Parameters
    ----------
    unit : GlazingUnit
    spectrum_wavelength, spectrum : array_like
        [nm], [W m-2 nm-1] (AM1.5 global for the rated value; a flat spectrum for a
        broadband-only unit).

    Returns
    -------
    angles : numpy.ndarray
        (A,) [deg].
    g : numpy.ndarray
        (A,) solar heat gain coefficient [1].
    g_diffuse : float
        Hemispherical g [1].
    tau_diffuse : float
        Hemispherical solar transmittance [1].
    """
    wl = np.asarray(spectrum_wavelength, float)
    e = np.asarray(spectrum, float)
    o = unit.optics(ANGLES, wl)
    norm = np.trapezoid(e, wl)
    g = np.trapezoid(o["shgc"] * e, wl, axis=1) / norm
    t = np.trapezoid(o["transmittance"] * e, wl, axis=1) / norm
    return ANGLES, g, float(hemispherical(ANGLES, g)), float(hemispherical(ANGLES, t))


def window_gains(area, poa_direct, poa_diffuse, aoi, g_angles, g, g_diffuse, frame_fraction=0.0):
    """Solar gain through windows [W], (T, S).

    Parameters
    ----------
    area : array_like
        (S,) window areas [m2].
    poa_direct, poa_diffuse : array_like
        (T, S) beam and diffuse (sky + reflected) irradiance on the window [W m-2].
    aoi : array_like
        (T, S) beam angle of incidence [deg] (> 90 or NaN: no beam).
    g_angles, g : array_like
        (A,) the unit's g by angle [deg], [1] (or (A, S) per surface).
    g_diffuse : float or array_like
        Hemispherical g [1], scalar or (S,).
    frame_fraction : float or array_like
        [1].
    """
    theta = np.nan_to_num(np.asarray(aoi, float), nan=90.0)
    theta = np.clip(theta, 0.0, 90.0)
    g = np.asarray(g, float)
    gb = (np.interp(theta, g_angles, g) if g.ndim == 1
          else np.stack([np.interp(theta[:, j], g_angles, g[:, j]) for j in range(g.shape[1])], 1))
    glass = np.asarray(area, float) * (1.0 - np.asarray(frame_fraction, float))
    return glass * (np.asarray(poa_direct, float) * gb + np.asarray(poa_diffuse, float)
                    * np.asarray(g_diffuse, float))


def opaque_gains(area, u_value, absorptance, poa_global, r_se=R_SE):
    """Absorbed solar that reaches the zone through opaque elements, ``alpha R_se U A E`` [W].

    ``u_value`` [W m-2 K-1] and ``r_se`` [m2 K W-1] may be per step, (T, S) (hourly outside
    coefficients, :mod:`widesky.thermal.exterior`)."""
    return (np.asarray(absorptance, float) * np.asarray(r_se, float) * np.asarray(u_value, float)
            * np.asarray(area, float) * np.asarray(poa_global, float))


def sky_losses(area, u_value, emissivity, tilt, temp_air, temp_sky, r_se=R_SE):
    """Long-wave loss to the sky through each element [W], (T, S) (ISO 13790 11.3.5).

    Parameters
    ----------
    area, u_value, emissivity, tilt : array_like
        (S,) [m2], [W m-2 K-1], [1], [deg]; ``u_value`` may be (T, S) per step.
    temp_air, temp_sky : array_like
        (T,) [degC].
    r_se : float or array_like
        Outside surface resistance [m2 K W-1], scalar or (T, S) per step (with an hourly
        ``u_value``, :mod:`widesky.thermal.exterior`).
    """
    ta = np.asarray(temp_air, float)[:, None]
    ts = np.asarray(temp_sky, float)[:, None]
    f_r = 0.5 * (1 + np.cos(np.radians(np.asarray(tilt, float))))
    h_r = 4 * np.asarray(emissivity, float) * SIGMA * (273.15 + 0.5 * (ta + ts)) ** 3
    return (np.asarray(r_se, float) * np.asarray(u_value, float) * np.asarray(area, float) * f_r
            * h_r * (ta - ts))


def _cons(constructions, s):
    try:
        return constructions[s.construction]
    except KeyError:
        raise ValueError(f"surface {s.label!r}: construction {s.construction!r} not in "
                         f"constructions {sorted(constructions)}") from None


def zone_parameters(building, constructions, mass_class="medium"):
    """5R1C parameters for every zone of ``building`` (order of ``building.zones``).

    Parameters
    ----------
    building : Building
    constructions : dict of str to Construction
    mass_class : str or dict
        A key of :data:`MASS_CLASSES` for all zones, or zone -> key.
    """
    names = list(building.zones)
    cols = {k: np.zeros(len(names)) for k in ("fa", "hw", "hop", "hve", "cm", "am")}
    for i, z in enumerate(names):
        spec = building.zones[z]
        mc = mass_class.get(z, "medium") if isinstance(mass_class, dict) else mass_class
        if mc not in MASS_CLASSES:
            raise ValueError(f"mass_class={mc!r} not one of {sorted(MASS_CLASSES)}")
        am, cm = MASS_CLASSES[mc]
        cols["fa"][i] = spec.floor_area
        cols["am"][i], cols["cm"][i] = am * spec.floor_area, cm * spec.floor_area
        cols["hve"][i] = 1200.0 * spec.air_changes * spec.volume / 3600.0
        for s in building.surfaces_of(zone=z):
            c = _cons(constructions, s)
            if s.kind == "window":
                cols["hw"][i] += c.u_value * s.area
            elif s.kind in ("wall", "roof", "floor"):
                cols["hop"][i] += c.b * c.u_value * s.area
    return ZoneParameters(cols["fa"], cols["hw"], np.maximum(cols["hop"], 1e-3),
                          np.maximum(cols["hve"], 1e-3), cols["cm"], cols["am"])


@dataclass
class LoadsResult:
    """Hourly gains and loads of a building.

    Attributes
    ----------
    surface_gains : pandas.DataFrame
        (T, S) solar gain reaching each zone through each surface [W] (windows: transmitted and
        inward-flowing absorbed; opaque: ISO 13790 absorbed share), less its long-wave sky loss.
    zone_solar, heating, cooling, temp_air : pandas.DataFrame
        (T, Z) [W], [W], [W], [degC].
    """

    surface_gains: pd.DataFrame
    zone_solar: pd.DataFrame
    heating: pd.DataFrame
    cooling: pd.DataFrame
    temp_air: pd.DataFrame

    def summary(self):
        """Per zone and in total: annual heating/cooling/solar [kWh], peaks [W] and their times."""
        dt = (self.heating.index[1] - self.heating.index[0]).total_seconds() / 3600.0
        rows = {}
        for z in self.heating.columns:
            rows[z] = {"heating_kWh": self.heating[z].sum() * dt / 1000,
                       "cooling_kWh": self.cooling[z].sum() * dt / 1000,
                       "solar_kWh": self.zone_solar[z].sum() * dt / 1000,
                       "peak_heating_W": self.heating[z].max(),
                       "peak_heating_time": self.heating[z].idxmax(),
                       "peak_cooling_W": self.cooling[z].max(),
                       "peak_cooling_time": self.cooling[z].idxmax()}
        tot_h, tot_c = self.heating.sum(axis=1), self.cooling.sum(axis=1)
        rows["total"] = {"heating_kWh": tot_h.sum() * dt / 1000, "cooling_kWh": tot_c.sum() * dt / 1000,
                         "solar_kWh": self.zone_solar.sum(axis=1).sum() * dt / 1000,
                         "peak_heating_W": tot_h.max(), "peak_heating_time": tot_h.idxmax(),
                         "peak_cooling_W": tot_c.max(), "peak_cooling_time": tot_c.idxmax()}
        return pd.DataFrame(rows).T


def building_loads(building, constructions, times, temp_air, irradiance, temp_sky=None,
                   window_gain=None, mass_class="medium", warmup_steps=24 * 14, g_spectrum=None):
    """Hourly solar gains and 5R1C loads for every zone.

    Parameters
    ----------
    building : Building
    constructions : dict of str to Construction
    times : pandas.DatetimeIndex
        (T,) step labels.
    temp_air : array_like
        (T,) outdoor air temperature [degC].
    irradiance : dict of str to array_like
        (T, S) per non-shading surface of ``building`` (its order): ``poa_direct``,
        ``poa_sky_diffuse``, ``poa_ground_diffuse`` [W m-2] and ``aoi`` [deg]
        (e.g. :func:`widesky.thermal.surface.surface_irradiance`, or the integrator's parts).
    temp_sky : array_like, optional
        (T,) sky temperature [degC]; None: no sky loss.
    window_gain : array_like, optional
        (T, W) solar gain per m2 of glass for the window surfaces [W m-2] computed elsewhere (the
        spectral route); None: broadband route from each glazing unit's g(aoi).
    mass_class : str or dict
        See :func:`zone_parameters`.
    warmup_steps : int
        Steps repeated before the period.
    g_spectrum : tuple, optional
        (wavelength [nm], spectrum [W m-2 nm-1]) weighting the broadband g; default a flat
        spectrum over each unit's own grid.

    Returns
    -------
    LoadsResult
    """
    surf = [s for s in building.surfaces if s.kind != "shading"]
    S = len(surf)
    T = len(times)
    E = {k: np.asarray(irradiance[k], float) for k in ("poa_direct", "poa_sky_diffuse",
                                                        "poa_ground_diffuse", "aoi")}
    for k, v in E.items():
        if v.shape != (T, S):
            raise ValueError(f"irradiance[{k!r}] has shape {v.shape}, expected ({T}, {S})")
    gains = np.zeros((T, S))
    wins = [j for j, s in enumerate(surf) if s.kind == "window"]
    if window_gain is not None:
        wg = np.asarray(window_gain, float)
        if wg.shape != (T, len(wins)):
            raise ValueError(f"window_gain has shape {wg.shape}, expected ({T}, {len(wins)})")
    tables = {}
    for j, s in enumerate(surf):
        c = _cons(constructions, s)
        if s.kind == "window":
            if c.glazing is None:
                raise ValueError(f"window {s.label!r}: construction {c.name!r} has no glazing")
            if window_gain is not None:
                gains[:, j] = wg[:, wins.index(j)] * s.area * (1 - c.frame_fraction)
            else:
                if c.name not in tables:
                    wl = (g_spectrum[0] if g_spectrum is not None
                          else np.linspace(300.0, 2500.0, 221))
                    sp = g_spectrum[1] if g_spectrum is not None else np.ones_like(wl)
                    tables[c.name] = glazing_g_table(c.glazing, wl, sp)
                ang, g, gd, _ = tables[c.name]
                gains[:, j] = window_gains(s.area, E["poa_direct"][:, j],
                                           E["poa_sky_diffuse"][:, j] + E["poa_ground_diffuse"][:, j],
                                           E["aoi"][:, j], ang, g, gd, c.frame_fraction)
        elif s.kind in ("wall", "roof"):
            glob = E["poa_direct"][:, j] + E["poa_sky_diffuse"][:, j] + E["poa_ground_diffuse"][:, j]
            gains[:, j] = opaque_gains(s.area, c.u_value, c.absorptance, glob)
        if temp_sky is not None and s.kind in ("wall", "roof", "window"):
            gains[:, j] -= sky_losses([s.area], [c.u_value], [c.emissivity if s.kind != "window"
                                                               else 0.84], [s.tilt], temp_air,
                                      temp_sky)[:, 0]
    zones = list(building.zones)
    M = np.zeros((S, len(zones)))
    for j, s in enumerate(surf):
        M[j, zones.index(s.zone)] = 1.0
    zone_solar = gains @ M
    params = zone_parameters(building, constructions, mass_class)
    spec = [building.zones[z] for z in zones]
    res = simulate_5r1c(params, np.asarray(temp_air, float),
                        np.array([[z.internal_gains for z in spec]]), zone_solar,
                        np.array([[z.heating_setpoint for z in spec]]),
                        np.array([[z.cooling_setpoint for z in spec]]), warmup_steps=warmup_steps)
    idx = pd.DatetimeIndex(times)

    def frame(a, cols):
        return pd.DataFrame(a, index=idx, columns=cols)
    return LoadsResult(frame(gains, [s.label for s in surf]), frame(zone_solar, zones),
                       frame(res["heating"], zones), frame(res["cooling"], zones),
                       frame(res["temp_air"], zones))
