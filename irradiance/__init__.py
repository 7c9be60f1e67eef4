"""widesky.irradiance: solar position, sites, weather, sky states and per-face spectral irradiance."""

from .location import (LABELS, Location, Site, daytime_steps, ensure_tz_aware, fixed_offset_tz,
                       infer_step, sun_times, time_range)
from .measured import MeasuredScaling, clearness_index, measured_scale_factors
from .skystate import (DEFAULT_GROUPING, PSM_RANGES, GroupingSteps, SkyGroups, SkyRanges,
                       group_sky_states, sky_ranges, sky_states, sky_states_for)
from .solarposition import (SOLAR_CONSTANT, SpaResult, delta_t_estimate, dni_extra, julian_day,
                            solar_position, spa)
from .weather import (WEATHER_COLUMNS, WeatherData, WeatherFileError, read_epw, read_tmy3,
                      read_weather, read_weather_csv, write_epw)
from .patches import SkyPatches, cosine_weights, reinhart, tregenza
from .scene import Scene, load_mesh, make_scene
from .skies import AnalyticSky, PragueSky, SkyStates, UniformSky
from .raycast import (Coefficients, PendingCoefficients, compute_coefficients, start_coefficients,
                      sun_bins)
from .reference import ReferenceResult, reference_poa, validation_scenes
from .integrator import (PRESETS, IntegratorSettings, measured_scaling, model_irradiance,
                         patch_radiance)
from .response import AngularTable, Response, SpectralAngularTable
from .result import FaceTable, POAResult
from .poa import poa_irradiance
from .poa_options import MeasuredSky, OutputOptions, RunOptions
from .allsky import CLEAR_SHAPE, AllSkyFactors, AllSkyOptions, allsky_factors
from .allsky_sky import AllSkyWeather
from .simulation import DEFAULTS_TABLE, SKY_DEFAULTS, Simulation, SkyInput, SkyOptions, sky_input

__all__ = [
    # solar position
    "spa", "solar_position", "SpaResult", "julian_day", "delta_t_estimate", "dni_extra",
    "SOLAR_CONSTANT",
    # sites and time
    "Site", "Location", "LABELS", "ensure_tz_aware", "fixed_offset_tz", "infer_step", "sun_times",
    "time_range", "daytime_steps",
    # weather
    "WeatherData", "WeatherFileError", "read_epw", "read_tmy3", "read_weather_csv", "read_weather",
    "write_epw", "WEATHER_COLUMNS",
    # sky states
    "sky_states_for", "SkyRanges", "PSM_RANGES", "sky_ranges", "sky_states", "GroupingSteps", "DEFAULT_GROUPING",
    "SkyGroups", "group_sky_states",
    # measured weather on the clear-sky model
    "MeasuredScaling", "measured_scale_factors", "clearness_index",
    # scenes, sky patches, ray casting and per-face irradiance
    "make_scene", "Scene", "load_mesh", "reinhart", "tregenza", "SkyPatches", "cosine_weights",
    "SkyStates", "UniformSky", "AnalyticSky", "PragueSky", "compute_coefficients", "Coefficients",
    "start_coefficients", "PendingCoefficients", "sun_bins",
    "IntegratorSettings", "PRESETS", "patch_radiance", "poa_irradiance", "POAResult",
    "MeasuredSky", "OutputOptions", "RunOptions",
    "model_irradiance", "measured_scaling", "FaceTable",
    # responses and their optics
    "Response", "AngularTable", "SpectralAngularTable",
    # brute-force reference
    "reference_poa", "ReferenceResult", "validation_scenes",
    # all-sky spectra under measured weather
    "AllSkyOptions", "AllSkyFactors", "AllSkyWeather", "allsky_factors", "CLEAR_SHAPE",
    # the pipeline every front end uses
    "Simulation", "SkyOptions", "SKY_DEFAULTS", "DEFAULTS_TABLE", "SkyInput", "sky_input",
]
