"""The thermal part of a case: window gains per glazing unit and the building's loads (thermal's public API).

A case with a ``[thermal]`` section has a geometry whose ``build()`` returns a ``"building"``
(:class:`widesky.thermal.Building`, e.g. :func:`widesky.thermal.box_building`): every non-shading surface of it is an analysis
group named by its ``kind:zone:construction`` label, its shading surfaces are context. The integrator run carries
each glazing unit's spectral-angular g (:func:`widesky.thermal.glazing_response`), so one run gives the gain through
every window for every unit; :func:`widesky.thermal.building_loads` then runs the ISO 13790 5R1C zones once per unit.

Units: irradiance and gains per m2 [W m-2], heat flows [W], energy [kWh], temperatures [degC], U [W m-2 K-1].
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from widesky.thermal import (Construction, ZoneSpec, building_loads, glazing_response, irradiance_by_surface,
                             window_gain_by_surface)

__all__ = ["ThermalRun", "ORIENTATIONS", "orientation_name", "prepare_building", "glazing_responses",
           "design_day_temperature", "building_thermal", "surface_display_labels"]

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


def glazing_responses(units):
    """One spectral-angular g response per unit, named ``"<unit>:spectral"`` (what
    :func:`widesky.thermal.window_gain_by_surface` reads)."""
    return [glazing_response(u, f"{name}:spectral") for name, u in units.items()]


def design_day_temperature(times, step_hours, mean, daily_range):
    """Air temperature (T,) [degC] of a cosine design day repeated: ``mean`` [degC], ``daily_range`` [K], warmest
    at 15:00 local time (mid-interval of steps labelled by their start)."""
    hours = np.asarray(times.hour + times.minute / 60.0, float) + 0.5 * step_hours
    return mean + 0.5 * daily_range * np.cos(2.0 * np.pi * (hours - 15.0) / 24.0)


def _constructions(tcfg, name, unit):
    return {"wall": Construction("wall", tcfg["wall_u"]), "roof": Construction("roof", tcfg["roof_u"]),
            "floor": Construction("floor", tcfg["floor_u"], b=0.5), "window": Construction(name, glazing=unit)}


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
        (W,) glass area [m2] (frame fraction 0).
    incident : numpy.ndarray
        (T, W) global irradiance on each window [W m-2].
    window_gain : dict of str to numpy.ndarray
        Per unit (T, W) solar gain per m2 of glass [W m-2] (spectral route).
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

    def orientation_gains(self, name):
        """Per orientation with windows, for unit ``name``: (glass area [m2], solar gain (T,) [W], global
        irradiance on the glass (T,) [W]), summed over its windows."""
        out = {}
        for o in ORIENTATIONS:
            sel = [j for j, s in enumerate(self.windows) if orientation_name(s.azimuth) == o]
            if sel:
                out[o] = (float(self.window_area[sel].sum()), self.window_gain[name][:, sel] @ self.window_area[sel],
                          self.incident[:, sel] @ self.window_area[sel])
        return out


def building_thermal(result, building, tcfg, units, rated, temp_air, temp_sky=None):
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

    Returns
    -------
    ThermalRun
    """
    surf = [s for s in building.surfaces if s.kind != "shading"]
    labels = [s.label for s in surf]
    irr = irradiance_by_surface(result, labels)
    wins = [j for j, s in enumerate(surf) if s.kind == "window"]
    gains, loads = {}, {}
    times = result.times
    for name, unit in units.items():
        cons = _constructions(tcfg, name, unit)
        wg = window_gain_by_surface(result, labels, building, cons, "spectral")
        gains[name] = wg
        loads[name] = building_loads(building, cons, times, temp_air, irr, temp_sky=temp_sky, window_gain=wg,
                                     mass_class=tcfg["mass"])
    return ThermalRun(units, rated, [surf[j] for j in wins], np.array([surf[j].area for j in wins]),
                      irr["poa_global"][:, wins], gains, loads, np.asarray(temp_air, float),
                      None if temp_sky is None else np.asarray(temp_sky, float),
                      float(sum(z.floor_area for z in building.zones.values())))
