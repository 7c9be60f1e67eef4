"""widesky.pvsim: cell spectral responses, module model and spectral PV yield.

The cell-technology library (parametric EQE presets and tandems), user EQE/SR curves, cover optics,
cell temperature, the module model on channel-contracted irradiance, and the system layer on the
integrator (yield per module group, loss waterfall, technology comparison). See docs/pvsim.md.
"""

from .spectra import (HC_EV_NM, am15g, am15g_channels, band_average, channel_edges, photon_flux,
                      qe_to_sr, read_astm_g173, sr_to_qe)
from .eqe import EQEParameters, absorptance_edge, parametric_eqe, transmittance_below_gap
from .technologies import (PEROVSKITE_BANDGAP_RANGE, TECHNOLOGIES, CellTechnology, TandemTechnology,
                           get_technology, perovskite, perovskite_silicon_tandem, technology_names)
from .curves import TabulatedEQE, cell_from_csv, read_curve_csv, validate_curve
from .optics import (cover_iam, cover_transmittance, extinction_to_absorption, fresnel_interface,
                     rubin_soda_lime_index, spectral_cover_iam)
from .temperature import TEMPERATURE_MODEL_PARAMETERS, faiman, pvsyst_cell, temperature_model_parameters
from .module import (G_STC, T_STC, bifacial_effective_irradiance, channel_sr, current_mismatch_loss,
                     dc_power, effective_irradiance, low_irradiance_factor, pvwatts_inverter,
                     reference_currents, short_circuit_current, spectral_mismatch, stack_power,
                     tandem_stc_efficiency, temperature_factor)
from .system import (COVER_RESPONSE, WATERFALL_STAGES, CoverOptics, SystemSpec, TechnologyYield, YieldResult,
                     pv_yield, technology_parts, technology_responses)
from .stream import simulate
from .compare import (bandgap_sweep, hourly_spectral_factors, monthly_spectral_factor, plot_comparison,
                      summary_table, summary_text, visibility_spectral_factor, waterfall_table,
                      write_comparison)
from .reference import DEFAULT_REFERENCE, REFERENCE_SPECTRA, widesky_am15g
from .plots import plot_technologies
from . import compare, system

__all__ = [
    "DEFAULT_REFERENCE", "REFERENCE_SPECTRA",
    "HC_EV_NM", "am15g", "am15g_channels", "band_average", "channel_edges", "photon_flux", "qe_to_sr",
    "read_astm_g173", "sr_to_qe",
    "EQEParameters", "absorptance_edge", "parametric_eqe", "transmittance_below_gap",
    "PEROVSKITE_BANDGAP_RANGE", "TECHNOLOGIES", "CellTechnology", "TandemTechnology", "get_technology",
    "perovskite", "perovskite_silicon_tandem", "technology_names",
    "TabulatedEQE", "cell_from_csv", "read_curve_csv", "validate_curve",
    "cover_iam", "cover_transmittance", "extinction_to_absorption", "fresnel_interface",
    "rubin_soda_lime_index", "spectral_cover_iam",
    "TEMPERATURE_MODEL_PARAMETERS", "faiman", "pvsyst_cell", "temperature_model_parameters",
    "G_STC", "T_STC", "bifacial_effective_irradiance", "channel_sr", "current_mismatch_loss", "dc_power",
    "effective_irradiance", "low_irradiance_factor", "pvwatts_inverter", "reference_currents",
    "short_circuit_current", "spectral_mismatch", "stack_power", "tandem_stc_efficiency",
    "temperature_factor",
    "COVER_RESPONSE", "WATERFALL_STAGES", "CoverOptics", "SystemSpec", "TechnologyYield", "YieldResult",
    "pv_yield", "simulate", "technology_parts", "technology_responses",
    "bandgap_sweep", "hourly_spectral_factors", "monthly_spectral_factor", "plot_comparison", "summary_table",
    "summary_text", "visibility_spectral_factor", "waterfall_table", "write_comparison",
    "widesky_am15g", "plot_technologies",
]
