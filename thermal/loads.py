"""Solar gains per surface and hourly loads per zone of a :class:`~thermal.building.Building`.

Per surface and step (ISO 13790:2008 section 11.3, with the window's own optics instead of the
standard's F_w g_n):

* window: ``A (1 - frame) F_sh (E_direct g(aoi) + (E_sky + E_ground) g_diffuse)`` [W], with ``g`` the
  unit's solar heat gain coefficient by incidence angle (broadband route) -- or, on the spectral
  route, the integrator's irradiance weighted per channel and incoming direction by the unit's
  spectral-angular g (see :mod:`widesky.thermal.gains`), and ``F_sh`` the shading device's reduction factor of
  the step (1 when it is not deployed; ISO 13790 11.4.3);
* opaque: ``alpha R_se U A E_global`` (absorbed shortwave that reaches the zone, ``R_se = 0.04``); a window's
  frame (its share ``frame`` of the window area, ``U_f``) counts as opaque;
* long-wave loss to the sky: ``R_se U A h_r F_r (theta_air - theta_sky)``, ``h_r = 4 eps sigma
  T_mean^3``, ``F_r = (1 + cos tilt) / 2``.

A window's transmittance is area-weighted over glass and frame (ISO 10077-1 eq. 1 without the spacer's linear
term): ``U_w = (1 - frame) U_g + frame U_f``.

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
from .zone import H_MS, ZoneParameters, simulate_5r1c

__all__ = ["Construction", "MASS_CLASSES", "R_SE", "window_gains", "opaque_gains", "sky_losses",
           "zone_parameters", "building_loads", "LoadsResult", "BALANCE_TERMS", "SHADING_RULES",
           "glazing_g_table"]

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
        Opaque frame share of a window's area [1].
    frame_u : float, optional
        Frame thermal transmittance U_f [W m-2 K-1]; default the glazing's U (no frame effect on U).
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
    frame_u: float = None

    def __post_init__(self):
        if self.u_value is None:
            if self.glazing is None:
                raise ValueError(f"construction {self.name!r}: give u_value or glazing")
            object.__setattr__(self, "u_value", float(self.glazing.u_value()))
        if self.frame_u is None:
            object.__setattr__(self, "frame_u", float(self.u_value))
        for name, lo, hi in (("u_value", 0.0, 10.0), ("absorptance", 0, 1), ("emissivity", 0, 1),
                             ("frame_fraction", 0, 0.99), ("b", 0, 1), ("frame_u", 0.0, 10.0)):
            v = getattr(self, name)
            if not lo <= v <= hi:
                raise ValueError(f"construction {self.name!r}: {name}={v!r} outside [{lo}, {hi}]")

    @property
    def window_u(self):
        """Whole-window U_w = (1 - frame_fraction) U_g + frame_fraction U_f [W m-2 K-1] (the element's
        ``u_value`` for an opaque construction)."""
        if self.glazing is None:
            return float(self.u_value)
        return (1.0 - self.frame_fraction) * self.u_value + self.frame_fraction * self.frame_u


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
                cols["hw"][i] += c.window_u * s.area
            elif s.kind in ("wall", "roof", "floor"):
                cols["hop"][i] += c.b * c.u_value * s.area
    return ZoneParameters(cols["fa"], cols["hw"], np.maximum(cols["hop"], 1e-3),
                          np.maximum(cols["hve"], 1e-3), cols["cm"], cols["am"])


SHADING_RULES = ("solar", "solar-not-heating")
"""Rules of an operable shading device (:func:`building_loads`): down wherever requested, or also kept up while the
window's zone heats."""

BALANCE_TERMS = ("internal", "solar_transmitted", "solar_opaque", "sky_loss", "radiated_out", "ventilation",
                 "transmission_windows", "transmission_opaque", "heating", "cooling", "storage")
"""Terms of :meth:`LoadsResult.balance` [kWh]: gains positive as named, losses positive as named."""


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
    parts : dict of str to pandas.DataFrame, optional
        (T, S) per surface [W]: ``transmitted`` (through the glass, after shading), ``opaque`` (absorbed solar
        that reaches the zone through walls, roofs and window frames) and ``sky_loss`` (long-wave loss to the sky,
        >= 0 when the sky is colder than the air); ``surface_gains = transmitted + opaque - sky_loss``.
    flows : dict of str to pandas.DataFrame, optional
        (T, Z) per zone [W]: ``internal`` gains, and the 5R1C network's losses ``ventilation`` (H_ve (theta_air
        - theta_e)), ``transmission_windows`` (H_tr_w (theta_s - theta_e)), ``transmission_opaque`` (H_tr_em
        (theta_m - theta_e)) and ``radiated_out`` (the share H_tr_w / (h_ms A_t) of the radiative gains that ISO
        13790 C.2 sends straight out through the glazing).
    storage_kwh : pandas.Series, optional
        (Z,) heat stored in each zone's mass over the period [kWh] (C_m times the change of theta_m).
    shading_state : pandas.DataFrame, optional
        (T, W) bool per window: the steps its shading device was down (``building_loads(shading=...)``).
    """

    surface_gains: pd.DataFrame
    zone_solar: pd.DataFrame
    heating: pd.DataFrame
    cooling: pd.DataFrame
    temp_air: pd.DataFrame
    parts: dict = None
    flows: dict = None
    storage_kwh: pd.Series = None
    shading_state: pd.DataFrame = None

    def _dt(self):
        return (self.heating.index[1] - self.heating.index[0]).total_seconds() / 3600.0

    def summary(self):
        """Per zone and in total: annual heating/cooling/solar [kWh], peaks [W] and their times."""
        dt = self._dt()
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
        return pd.DataFrame(rows).T.infer_objects()     # numbers as floats, times as datetimes

    def balance(self):
        """The energy balance of each zone and the building over the period [kWh] (rows: zones and
        ``total``; columns :data:`BALANCE_TERMS` and ``residual``).

        ``internal + solar_transmitted + solar_opaque - sky_loss - radiated_out - ventilation -
        transmission_windows - transmission_opaque + heating - cooling - storage = residual``, zero to rounding:
        the network conserves energy exactly (tests/test_thermal_zone.py).
        """
        if self.parts is None or self.flows is None:
            raise ValueError("this LoadsResult carries no balance terms (made without building_loads)")
        dt = self._dt()
        zones = list(self.heating.columns)
        zone_of = {lab: lab.split(":")[1] for lab in self.surface_gains.columns}

        def by_zone(df):
            return df.T.groupby(lambda lab: zone_of[lab]).sum().T.reindex(columns=zones, fill_value=0.0)
        cols = {"internal": self.flows["internal"], "solar_transmitted": by_zone(self.parts["transmitted"]),
                "solar_opaque": by_zone(self.parts["opaque"]), "sky_loss": by_zone(self.parts["sky_loss"]),
                **{k: self.flows[k] for k in ("radiated_out", "ventilation", "transmission_windows",
                                              "transmission_opaque")},
                "heating": self.heating, "cooling": self.cooling}
        out = pd.DataFrame({k: v.sum() * dt / 1000.0 for k, v in cols.items()}).reindex(zones)
        out["storage"] = self.storage_kwh.reindex(zones)
        sign = {"internal": 1, "solar_transmitted": 1, "solar_opaque": 1, "heating": 1}
        out["residual"] = sum(out[k] * sign.get(k, -1) for k in BALANCE_TERMS)
        out.loc["total"] = out.sum()
        return out


def building_loads(building, constructions, times, temp_air, irradiance, temp_sky=None,
                   window_gain=None, mass_class="medium", warmup_steps=24 * 14, g_spectrum=None,
                   shading=None, internal_gains=None, setpoints=None, shading_rule="solar"):
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
    shading : array_like, optional
        (T, W) the shading device's reduction factor of each window's transmitted gain per step [1]
        (1: not deployed; ISO 13790 11.4.3 ``g_gl+sh / g_gl`` when deployed); default no shading.
    shading_rule : {"solar", "solar-not-heating"}
        ``"solar"``: the device as ``shading`` gives it, every step; ``"solar-not-heating"``: ``shading`` is where
        the device is requested, and it goes down there unless the window's zone heated in the previous step
        (:func:`~widesky.thermal.zone.simulate_5r1c`'s ``shade_request``); ``LoadsResult.shading_state`` has the
        steps it was down.
    internal_gains : array_like, optional
        (T,) internal gains per m2 of floor [W m-2] (e.g. :func:`widesky.thermal.schedules.office_gains`),
        replacing each zone's constant ``ZoneSpec.internal_gains``.
    setpoints : tuple of array_like, optional
        (heating, cooling): (T,) air set-points [degC] of every zone (e.g.
        :func:`widesky.thermal.schedules.office_setpoints`), replacing each zone's constant
        ``ZoneSpec.heating_setpoint`` and ``cooling_setpoint``.

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
    wins = [j for j, s in enumerate(surf) if s.kind == "window"]
    if window_gain is not None:
        wg = np.asarray(window_gain, float)
        if wg.shape != (T, len(wins)):
            raise ValueError(f"window_gain has shape {wg.shape}, expected ({T}, {len(wins)})")
    trans, opaque, sky = np.zeros((T, S)), np.zeros((T, S)), np.zeros((T, S))
    if shading is not None:
        shading = np.asarray(shading, float)
        if shading.shape != (T, len(wins)) or np.any(~np.isfinite(shading)) or np.any(shading < 0) \
                or np.any(shading > 1):
            raise ValueError(f"shading must be (T, W) = ({T}, {len(wins)}) factors in [0, 1], got shape "
                             f"{shading.shape}")
    tables = {}
    for j, s in enumerate(surf):
        c = _cons(constructions, s)
        glob = E["poa_direct"][:, j] + E["poa_sky_diffuse"][:, j] + E["poa_ground_diffuse"][:, j]
        if s.kind == "window":
            if c.glazing is None:
                raise ValueError(f"window {s.label!r}: construction {c.name!r} has no glazing")
            if window_gain is not None:
                trans[:, j] = wg[:, wins.index(j)] * s.area * (1 - c.frame_fraction)
            else:
                if c.name not in tables:
                    wl = (g_spectrum[0] if g_spectrum is not None
                          else np.linspace(300.0, 2500.0, 221))
                    sp = g_spectrum[1] if g_spectrum is not None else np.ones_like(wl)
                    tables[c.name] = glazing_g_table(c.glazing, wl, sp)
                ang, g, gd, _ = tables[c.name]
                trans[:, j] = window_gains(s.area, E["poa_direct"][:, j],
                                           E["poa_sky_diffuse"][:, j] + E["poa_ground_diffuse"][:, j],
                                           E["aoi"][:, j], ang, g, gd, c.frame_fraction)
            frame = s.area * c.frame_fraction
            if frame > 0:
                opaque[:, j] = opaque_gains(frame, c.frame_u, c.absorptance, glob)
            if temp_sky is not None:
                sky[:, j] = sky_losses([s.area * (1 - c.frame_fraction), frame], [c.u_value, c.frame_u],
                                       [0.84, c.emissivity], [s.tilt, s.tilt], temp_air, temp_sky).sum(1)
        elif s.kind in ("wall", "roof"):
            opaque[:, j] = opaque_gains(s.area, c.u_value, c.absorptance, glob)
            if temp_sky is not None:
                sky[:, j] = sky_losses([s.area], [c.u_value], [c.emissivity], [s.tilt], temp_air,
                                       temp_sky)[:, 0]
    if shading_rule not in SHADING_RULES:
        raise ValueError(f"shading_rule={shading_rule!r} not one of {SHADING_RULES}")
    trans_bare = trans.copy()
    requested = np.zeros((T, len(wins)), bool)
    if shading is not None:
        trans[:, wins] = trans_bare[:, wins] * shading
        requested = shading < 1.0
    gains = trans + opaque - sky
    zones = list(building.zones)
    M = np.zeros((S, len(zones)))
    for j, s in enumerate(surf):
        M[j, zones.index(s.zone)] = 1.0
    zone_solar = gains @ M
    by_state = shading is not None and shading_rule == "solar-not-heating"
    zone_of_win = [zones.index(surf[j].zone) for j in wins]
    params = zone_parameters(building, constructions, mass_class)
    spec = [building.zones[z] for z in zones]
    if internal_gains is not None:
        ig = np.asarray(internal_gains, float)
        if ig.shape != (T,) or np.any(~np.isfinite(ig)) or np.any(ig < 0):
            raise ValueError(f"internal_gains must be ({T},) finite values >= 0 W m-2, got shape {ig.shape}")
        phi_int = ig[:, None] * np.array([[z.floor_area for z in spec]])
    else:
        phi_int = np.array([[z.internal_gains for z in spec]])
    ta_out = np.asarray(temp_air, float)
    if setpoints is not None:
        sp_h, sp_c = (np.asarray(a, float) for a in setpoints)
        if sp_h.shape != (T,) or sp_c.shape != (T,) or not (np.all(np.isfinite(sp_h)) and np.all(np.isfinite(sp_c))):
            raise ValueError(f"setpoints must be (heating, cooling), each ({T},) finite values in degC, got shapes "
                             f"{sp_h.shape} and {sp_c.shape}")
        sp_h, sp_c = sp_h[:, None], sp_c[:, None]
    else:
        sp_h = np.array([[z.heating_setpoint for z in spec]])
        sp_c = np.array([[z.cooling_setpoint for z in spec]])
    extra = {}
    if by_state:
        req_zone = (requested.astype(float) @ M[wins] > 0) if wins else np.zeros((T, len(zones)), bool)
        extra = {"phi_sol_shaded": zone_solar, "shade_request": req_zone}
        zone_solar = (trans_bare + opaque - sky) @ M                  # the device up
    res = simulate_5r1c(params, ta_out, phi_int, zone_solar, sp_h, sp_c, warmup_steps=warmup_steps, **extra)
    state = requested
    if by_state:                              # the steps each window's device was down: requested, zone allowed
        state = requested & res["shaded"][:, zone_of_win]
        trans[:, wins] = trans_bare[:, wins] * np.where(state, shading, 1.0)
        gains = trans + opaque - sky
        zone_solar = gains @ M
    idx = pd.DatetimeIndex(times)

    def frame(a, cols):
        return pd.DataFrame(np.broadcast_to(a, (T, len(cols))), index=idx, columns=cols)
    # the network's flows (ISO 13790 C.2-C.3; the same closure as tests/test_thermal_zone.py)
    g = params.conductances()
    te = ta_out[:, None] if ta_out.ndim == 1 else ta_out
    h_w, a_t = g["h_tr_w"], params.total_area
    p_rad = 0.5 * phi_int + zone_solar
    flows = {"internal": phi_int, "ventilation": g["h_ve"] * (res["temp_air"] - te),
             "transmission_windows": h_w * (res["temp_surface"] - te),
             "transmission_opaque": g["h_tr_em"] * (res["temp_mass"] - te),
             "radiated_out": h_w / (H_MS * np.asarray(a_t, float)) * p_rad}
    tm_start = 2.0 * res["temp_mass"][0] - res["temp_mass_end"][0]
    storage = np.asarray(params.heat_capacity, float) * (res["temp_mass_end"][-1] - tm_start) / 3.6e6
    labels = [s.label for s in surf]
    return LoadsResult(frame(gains, labels), frame(zone_solar, zones),
                       frame(res["heating"], zones), frame(res["cooling"], zones),
                       frame(res["temp_air"], zones),
                       {"transmitted": frame(trans, labels), "opaque": frame(opaque, labels),
                        "sky_loss": frame(sky, labels)},
                       {k: frame(v, zones) for k, v in flows.items()},
                       pd.Series(storage, index=zones),
                       None if shading is None else frame(state, [labels[j] for j in wins]))
