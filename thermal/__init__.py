"""widesky.thermal: facade solar gains with spectral-angular glazing, and hourly zone loads.

Glazing optics per wavelength and angle (:mod:`widesky.thermal.optics`, :mod:`widesky.thermal.glazing`), opaque
surfaces and weather-driven surface irradiance (:mod:`widesky.thermal.surface`), the ISO 13790 5R1C zone
model (:mod:`widesky.thermal.zone`) with hourly outside surface coefficients (:mod:`widesky.thermal.exterior`),
building input (:mod:`widesky.thermal.building`), gains and loads
(:mod:`widesky.thermal.loads`), the integrator wiring (:mod:`widesky.thermal.gains`), ASHRAE 140 validation
(:mod:`widesky.thermal.bestest`) and the spectral-vs-rated glazing study (:mod:`widesky.thermal.study`).
See docs/thermal.md.
"""

from .optics import coated_angular, equivalent_slab, fresnel_interface, hemispherical, invert_slab, slab
from .glazing import (ANGLES, GAS_PROPERTIES, WAVELENGTHS, Gap, GlazingLayer, GlazingUnit,
                      combine_layers, gap_conductance, inward_fractions, layer_from_broadband,
                      layer_from_nk, read_igdb, read_nk_yml, read_solar_spectrum, solar_weighted)
from .surface import absorbed_solar, aoi, sky_temperature, sol_air_temperature, surface_irradiance
from .zone import ZoneParameters, simulate_5r1c
from .exterior import exterior_coefficients, hourly_u_value, wind_at_height
from .building import Building, Surface, ZoneSpec, box_building, building_from_meshes, parse_label
from .loads import (MASS_CLASSES, Construction, LoadsResult, building_loads, glazing_g_table,
                    opaque_gains, sky_losses, window_gains, zone_parameters)
from .gains import (building_scene, glazing_response, irradiance_by_surface, rated_glazing_response,
                    window_gain_by_surface)
from .facade import write_face_csv, write_facade_ply
from .thinfilm import Film, coated_layer_from_stack, drude_index, solar_control_layer, stack_optics

__all__ = [
    # glazing optics
    "slab", "fresnel_interface", "invert_slab", "coated_angular", "equivalent_slab", "hemispherical",
    "GlazingLayer", "Gap", "GlazingUnit", "combine_layers", "inward_fractions", "gap_conductance",
    "read_igdb", "read_nk_yml", "layer_from_nk", "layer_from_broadband", "read_solar_spectrum",
    "solar_weighted", "ANGLES", "WAVELENGTHS", "GAS_PROPERTIES",
    "Film", "stack_optics", "drude_index", "coated_layer_from_stack", "solar_control_layer",
    # surfaces
    "aoi", "surface_irradiance", "absorbed_solar", "sol_air_temperature", "sky_temperature",
    # zone model
    "ZoneParameters", "simulate_5r1c", "exterior_coefficients", "hourly_u_value", "wind_at_height",
    # buildings, gains and loads
    "Building", "Surface", "ZoneSpec", "parse_label", "building_from_meshes", "box_building",
    "Construction", "MASS_CLASSES", "window_gains", "opaque_gains", "sky_losses", "zone_parameters",
    "building_loads", "LoadsResult", "glazing_g_table",
    # the integrator route
    "glazing_response", "rated_glazing_response", "building_scene", "irradiance_by_surface",
    "window_gain_by_surface",
    # outputs
    "write_facade_ply", "write_face_csv",
]
