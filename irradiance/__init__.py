"""widesky.irradiance: solar position, sites, weather, sky states and per-face spectral irradiance."""
