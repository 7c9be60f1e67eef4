"""widesky.skymodel: the wide-spectral-range Prague Sky Model (reader, evaluator, renderer).

Quick start::

    from widesky import skymodel
    model = skymodel.load_dataset()                      # the embedded default dataset
    dirs = skymodel.direction_from_zenith([0, 45, 80], [0, 90, 180])   # zenith angles [deg], azimuths [deg]
    L = skymodel.sky_radiance(model, dirs, sun_elevation=30, sun_azimuth=180, visibility=40, albedo=0.2)
    # L.shape == (3, model.n_channels), [W m-2 sr-1 nm-1]
"""

from .dataset import DatasetError, SkyModel, default_dataset_path, load_dataset
from .evaluate import (SkyStateClampedWarning, channel_indices, reference_angles, direction_from_zenith,
                       directions_from_angles, polarisation,
                       sky_radiance, solar_direct_normal, sun_direction, sun_radiance, transmittance)
from .solar import SUN_RADIUS, SUN_SOLID_ANGLE, extraterrestrial_spectrum

__all__ = [
    "DatasetError", "SkyModel", "load_dataset", "default_dataset_path",
    "SkyStateClampedWarning", "reference_angles", "sky_radiance", "sun_radiance", "polarisation", "transmittance",
    "solar_direct_normal", "sun_direction", "direction_from_zenith", "directions_from_angles", "channel_indices",
    "SUN_RADIUS", "SUN_SOLID_ANGLE", "extraterrestrial_spectrum",
]
