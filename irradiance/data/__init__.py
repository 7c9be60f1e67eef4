"""Package data of widesky.irradiance: a synthetic public-domain sample weather file."""
