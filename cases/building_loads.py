"""The thermal part of a case: window gains per glazing unit and the building's loads (thermal's public API).

A case with a ``[thermal]`` section has a geometry whose ``build()`` returns a ``"building"``
(:class:`widesky.thermal.Building`, e.g. :func:`widesky.thermal.box_building`): every non-shading surface of it is an analysis
group named by its ``kind:zone:construction`` label, its shading surfaces are context. The integrator run carries
each glazing unit's spectral-angular g (:func:`widesky.thermal.glazing_response`), so one run gives the gain through
every window for every unit; :func:`widesky.thermal.building_loads` then runs the ISO 13790 5R1C zones once per unit.

The ``[thermal]`` section sets the use (internal gains constant or on the office profiles of
:mod:`widesky.thermal.schedules`), the window frames (frame share and U_f) and an operable shading device: in an
occupied hour (occupancy fraction >= :data:`widesky.thermal.schedules.OCCUPIED_THRESHOLD`; every hour with constant
gains) a window's device is deployed when the global irradiance on that window exceeds ``shading_threshold``
[W m-2] (with ``shading_control = "solar-not-heating"`` not while its zone heated in the previous hour), and then
multiplies its transmitted gain by ``shading_factor`` (ISO 13790 11.4.3, ``g_gl+sh / g_gl``),
and the thermostat (``thermostat = "office"``: the set-points in the hours of
:data:`widesky.thermal.schedules.OFFICE_HVAC`, ``heating_setback`` and ``cooling_setup`` otherwise).
With a rated spectrum, :func:`glazing_responses` adds each unit's rated route (AM1.5-weighted g by angle), so the
same run gives the spectral-versus-rated difference.

Units: irradiance and gains per m2 [W m-2], heat flows [W], energy [kWh], temperatures [degC], U [W m-2 K-1].
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from widesky.thermal import (Construction, ZoneSpec, building_loads, glazing_response, irradiance_by_surface,
                             rated_glazing_response, window_gain_by_surface)
from widesky.thermal.schedules import occupied_hours, office_gains, office_setpoints

__all__ = ["ThermalRun", "ORIENTATIONS", "orientation_name", "prepare_building", "glazing_responses",
           "design_day_temperature", "building_thermal", "surface_display_labels", "shading_factors"]

ORIENTATIONS = ("north", "east", "south", "west")


def orientation_name(azimuth):
    """The compass facade an azimuth [deg] (clockwise from north) faces: north, east, south or west."""
    return ORIENTATIONS[int(((float(azimuth) + 45.0) % 360.0) // 90.0)]


def _display(surface):
    if surface.kind in ("roof", "floor") or surface.tilt < 30.0 or surface.tilt > 150.0:
        return surface.kind
    return f"{surface.kind} {orientation_name(surface.azimuth)}"


def surface_display_labels(building):
    """Group label -> report label (``"window south"``, ``"wall east"``, ``"roof"``) of a building's
    non-shading surfaces."""
    return {s.label: _display(s) for s in building.surfaces if s.kind != "shading"}


def prepare_building(building, tcfg):
    """The building with every zone's use from the ``[thermal]`` section (air changes, internal gains per m2
    of floor, set-points)."""
    zones = {z: ZoneSpec(z, s.floor_area, s.volume, tcfg["air_changes"], tcfg["internal_gains"] * s.floor_area,
                         tcfg["heating_setpoint"], tcfg["cooling_setpoint"]) for z, s in building.zones.items()}
    return replace(building, zones=zones)


def glazing_responses(units, rated_spectrum=None):
    """One spectral-angular g response per unit, named ``"<unit>:spectral"`` (what
    :func:`widesky.thermal.window_gain_by_surface` reads), and with ``rated_spectrum`` (a dict with
    ``channel_edges`` (C+1,) [nm] and band-mean ``scaled`` (C,) [W m-2 nm-1], e.g. :func:`widesky.pvsim.widesky_am15g`)
    one rated-route response per unit, ``"<unit>:rated"`` (g by angle weighted by that spectrum)."""
    out = [glazing_response(u, f"{name}:spectral") for name, u in units.items()]
    if rated_spectrum is not None:
        edges = np.asarray(rated_spectrum["channel_edges"], float)
        wl = np.arange(edges[0] + 5.0, edges[-1], 10.0)
        e = np.asarray(rated_spectrum["scaled"], float)[np.clip(np.searchsorted(edges, wl) - 1, 0, len(edges) - 2)]
        out += [rated_glazing_response(u, wl, e, f"{name}:rated") for name, u in units.items()]
    return out


def shading_factors(incident, occupied, threshold, factor):
    """The shading device's state and reduction factor per window and step.

    Parameters
    ----------
    incident : array_like
        (T, W) global irradiance on each window [W m-2].
    occupied : array_like
        (T,) bool, the occupied steps.
    threshold : float
        [W m-2]: deployed when ``incident > threshold`` in an occupied step.
    factor : float
        ``g_gl+sh / g_gl`` [1] when deployed (1: no device).

    Returns
    -------
    deployed : numpy.ndarray
        (T, W) bool.
    reduction : numpy.ndarray
        (T, W) ``factor`` where deployed, else 1 [1].
    """
    inc = np.asarray(incident, float)
    occ = np.asarray(occupied, bool)
    deployed = occ[:, None] & (inc > float(threshold)) & (float(factor) < 1.0)
    return deployed, np.where(deployed, float(factor), 1.0)


def design_day_temperature(times, step_hours, mean, daily_range):
    """Air temperature (T,) [degC] of a cosine design day repeated: ``mean`` [degC], ``daily_range`` [K], warmest
    at 15:00 local time (mid-interval of steps labelled by their start)."""
    hours = np.asarray(times.hour + times.minute / 60.0, float) + 0.5 * step_hours
    return mean + 0.5 * daily_range * np.cos(2.0 * np.pi * (hours - 15.0) / 24.0)


def _constructions(tcfg, name, unit):
    return {"wall": Construction("wall", tcfg["wall_u"]), "roof": Construction("roof", tcfg["roof_u"]),
            "floor": Construction("floor", tcfg["floor_u"], b=0.5),
            "window": Construction(name, glazing=unit, frame_fraction=tcfg.get("frame_fraction", 0.0),
                                   frame_u=tcfg.get("frame_u", None))}


@dataclass
class ThermalRun:
    """What the thermal part computed.

    Attributes
    ----------
    units : dict of str to thermal.GlazingUnit
    rated : dict of str to dict
        Per unit :func:`widesky.cases.glazing.unit_summary` (U, g, solar and light transmittance) [W m-2 K-1], [1].
    windows : list of thermal.Surface
    window_area : numpy.ndarray
        (W,) glass area [m2]: the window area less its frame.
    incident : numpy.ndarray
        (T, W) global irradiance on each window [W m-2].
    window_gain : dict of str to numpy.ndarray
        Per unit (T, W) solar gain per m2 of glass [W m-2] (spectral route), after the shading device.
    bare_gain, rated_gain : dict of str to numpy.ndarray
        Per unit (T, W) gain per m2 of glass without the shading device [W m-2]: spectral route, and rated route
        (empty when the run carried no rated responses).
    deployed : dict of str to numpy.ndarray
        Per unit (T, W) bool, the shading device deployed (with ``shading_control = "solar-not-heating"`` it depends
        on the zones' heating, so on the unit).
    occupied : numpy.ndarray
        (T,) bool, the occupied steps.
    internal : dict of str to numpy.ndarray
        (T,) internal gains per m2 of floor [W m-2]: ``people``, ``lighting``, ``equipment``, ``total``
        (constant gains: all in ``total``).
    loads : dict of str to thermal.LoadsResult
    temp_air : numpy.ndarray
        (T,) [degC].
    temp_sky : numpy.ndarray or None
        (T,) [degC] (from the weather file's horizontal infrared; None: no sky loss).
    floor_area : float
        [m2].
    """

    units: dict
    rated: dict
    windows: list
    window_area: np.ndarray
    incident: np.ndarray
    window_gain: dict
    loads: dict
    temp_air: np.ndarray
    temp_sky: object
    floor_area: float
    bare_gain: dict = None
    rated_gain: dict = None
    deployed: dict = None
    occupied: np.ndarray = None
    internal: dict = None
    facade_of: dict = None

    def facade_parts(self, name):
        """For unit ``name``, per facade (``north`` ... ``west``, ``roof``): (T,) [W] ``transmitted`` solar (through
        the glass, after the shading device), ``opaque`` solar (absorbed on walls, frames, roof, reaching the zones)
        and ``sky_loss`` (long-wave loss to the sky), summed over the facade's surfaces."""
        parts = self.loads[name].parts
        out = {}
        for f in (*ORIENTATIONS, "roof"):
            cols = [lab for lab, fc in self.facade_of.items() if fc == f]
            if cols:
                out[f] = {k: parts[k][cols].sum(axis=1).to_numpy() for k in ("transmitted", "opaque", "sky_loss")}
        return out

    def orientation_of(self):
        """(W,) the compass facade of each window."""
        return [orientation_name(s.azimuth) for s in self.windows]

    def orientation_gains(self, name):
        """Per orientation with windows, for unit ``name``: (glass area [m2], solar gain (T,) [W], global
        irradiance on the glass (T,) [W]), summed over its windows."""
        return self._per_orientation(self.window_gain[name])

    def _per_orientation(self, per_m2):
        out = {}
        for o in ORIENTATIONS:
            sel = [j for j, s in enumerate(self.windows) if orientation_name(s.azimuth) == o]
            if sel:
                out[o] = (float(self.window_area[sel].sum()), per_m2[:, sel] @ self.window_area[sel],
                          self.incident[:, sel] @ self.window_area[sel])
        return out

    def route_gains(self, name):
        """Per orientation, for unit ``name`` without the shading device: (glass area [m2], spectral-route gain
        (T,) [W], rated-route gain (T,) [W]); empty without rated responses."""
        if not self.rated_gain or name not in self.rated_gain:
            return {}
        sp, ra = self._per_orientation(self.bare_gain[name]), self._per_orientation(self.rated_gain[name])
        return {o: (sp[o][0], sp[o][1], ra[o][1]) for o in sp}


def building_thermal(result, building, tcfg, units, rated, temp_air, temp_sky=None, label="left"):
    """Window gains and 5R1C loads of ``building`` for every glazing unit from one integrator result.

    Parameters
    ----------
    result : irradiance.POAResult
        With the responses of :func:`glazing_responses` and one group per non-shading surface.
    building : thermal.Building
        From :func:`prepare_building`.
    tcfg : dict
        The validated ``[thermal]`` section.
    units : dict of str to thermal.GlazingUnit
    rated : dict
        Per unit the rated values (:func:`widesky.cases.glazing.unit_summary`).
    temp_air : array_like
        (T,) [degC].
    temp_sky : array_like, optional
        (T,) [degC].
    label : {"left", "right"}
        What the result's time stamps mark (a clear-sky period: each step's start; a weather file: its end), for
        the office schedules.

    Returns
    -------
    ThermalRun
    """
    surf = [s for s in building.surfaces if s.kind != "shading"]
    labels = [s.label for s in surf]
    irr = irradiance_by_surface(result, labels)
    wins = [j for j, s in enumerate(surf) if s.kind == "window"]
    times = result.times
    step_h = (times[1] - times[0]).total_seconds() / 3600.0 if len(times) > 1 else 1.0
    incident = irr["poa_global"][:, wins]
    if tcfg.get("schedule", "constant") == "office":
        internal = office_gains(times, step_h, label=label)
        occupied = occupied_hours(times, step_h, label=label)
        series = internal["total"]
    else:
        internal = {"total": np.full(len(times), float(tcfg["internal_gains"]))}
        occupied = np.ones(len(times), bool)
        series = None
    setpoints = None
    if tcfg.get("thermostat", "constant") == "office":
        setpoints = office_setpoints(times, step_h, label, tcfg["heating_setpoint"], tcfg["cooling_setpoint"],
                                     tcfg["heating_setback"], tcfg["cooling_setup"])
    _, reduction = shading_factors(incident, occupied, tcfg.get("shading_threshold", 200.0),
                                   tcfg.get("shading_factor", 1.0))
    rule = tcfg.get("shading_control", "solar")
    names = set(result.responses)
    gains, bare, rated_g, loads, deployed = {}, {}, {}, {}, {}
    for name, unit in units.items():
        cons = _constructions(tcfg, name, unit)
        wg = window_gain_by_surface(result, labels, building, cons, "spectral")
        bare[name] = wg
        if f"{name}:rated" in names:
            rated_g[name] = window_gain_by_surface(result, labels, building, cons, "rated")
        loads[name] = building_loads(building, cons, times, temp_air, irr, temp_sky=temp_sky, window_gain=wg,
                                     mass_class=tcfg["mass"], shading=reduction, internal_gains=series,
                                     setpoints=setpoints, shading_rule=rule)
        deployed[name] = loads[name].shading_state.to_numpy()          # as the rule left it
        gains[name] = wg * np.where(deployed[name], reduction, 1.0)
    ff = float(tcfg.get("frame_fraction", 0.0))
    return ThermalRun(units, rated, [surf[j] for j in wins], np.array([surf[j].area for j in wins]) * (1.0 - ff),
                      incident, gains, loads, np.asarray(temp_air, float),
                      None if temp_sky is None else np.asarray(temp_sky, float),
                      float(sum(z.floor_area for z in building.zones.values())), bare, rated_g, deployed, occupied,
                      internal, {s.label: (s.kind if s.kind in ("roof", "floor") else orientation_name(s.azimuth))
                                 for s in surf})
