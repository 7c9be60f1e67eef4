"""widesky.skymodel.generator: physical clear-sky atmosphere (280-2480 nm) and a reference radiative-transfer solver.

The generator side of widesky (optional extra ``[build]``): AFGL atmosphere, Bodhaine Rayleigh, Bogumil ozone,
6S-fitted exponential sums for H2O and the mixed gases, OPAC aerosols by Mie theory, an extraterrestrial spectrum,
and plane-parallel DISORT (disortpp) for sky radiance, direct-beam transmittance and irradiances per channel.
See docs/atmosphere-and-solver.md.
"""

from .aerosol import OPAC_TYPES, AerosolOptics, aerosol_layer_fractions, component_optics, opac_mixture
from .atmosphere import DEFAULT_LEVELS_KM, PROFILES, Atmosphere, slant_path_factors, standard_atmosphere
from ..channels import CHANNEL_CENTERS_NM, CHANNEL_EDGES_NM, N_CHANNELS
from .gases import ExpSum, GasKDistribution, fit_exponential_sum, fit_gas_kdistributions, load_kdistributions
from .ozone import ozone_cross_section, ozone_optical_depth
from .paths import DataNotFoundError, cache_dir, data_dir, has_data
from widesky.core.rayleigh import (depolarization_ratio, king_factor, rayleigh_cross_section, rayleigh_extinction_sea_level_km,
                       rayleigh_moments, rayleigh_phase_function)
from .solar import channel_extraterrestrial, earth_sun_distance_factor, extraterrestrial_spectrum
from .solver import (AtmosphereSpec, SkyResult, SkyState, SkyTask, SolverConfig, aod550_of, channel_problems,
                     direct_transmittance, run_sky_task, solve_sky)

__all__ = [
    "OPAC_TYPES", "AerosolOptics", "aerosol_layer_fractions", "component_optics", "opac_mixture",
    "DEFAULT_LEVELS_KM", "PROFILES", "Atmosphere", "slant_path_factors", "standard_atmosphere",
    "CHANNEL_CENTERS_NM", "CHANNEL_EDGES_NM", "N_CHANNELS",
    "ExpSum", "GasKDistribution", "fit_exponential_sum", "fit_gas_kdistributions", "load_kdistributions",
    "ozone_cross_section", "ozone_optical_depth",
    "DataNotFoundError", "cache_dir", "data_dir", "has_data",
    "depolarization_ratio", "king_factor", "rayleigh_cross_section", "rayleigh_extinction_sea_level_km",
    "rayleigh_moments", "rayleigh_phase_function",
    "channel_extraterrestrial", "earth_sun_distance_factor", "extraterrestrial_spectrum",
    "AtmosphereSpec", "SkyResult", "SkyState", "SkyTask", "SolverConfig", "aod550_of", "channel_problems",
    "direct_transmittance", "run_sky_task", "solve_sky",
]
