"""Extraterrestrial solar spectrum per 40 nm channel, and the Earth-Sun distance factor.

The named sources (``tsis1``, the default; ``g173``, ``e490``, ``kurucz``: :data:`widesky.skymodel.solar.SOURCES`)
are read from the data directory and averaged over the 1 nm bins 280-2480 nm by
:func:`widesky.skymodel.solar.extraterrestrial_spectrum`, widesky's one extraterrestrial-spectrum function; the
generator averages them further onto its channels here.
"""

from __future__ import annotations

import numpy as np

from ..channels import N_CHANNELS
from ..solar import SOURCES, extraterrestrial_spectrum

__all__ = ["SOURCES", "extraterrestrial_spectrum", "channel_extraterrestrial", "earth_sun_distance_factor"]


def channel_extraterrestrial(source: str = "tsis1", data_dir=None) -> np.ndarray:
    """Band-mean extraterrestrial spectral irradiance per channel [W m-2 nm-1], shape (55,), at 1 AU, of a
    named source (see :func:`widesky.skymodel.solar.extraterrestrial_spectrum`)."""
    _, e = extraterrestrial_spectrum(source, data_dir)
    return e.reshape(N_CHANNELS, 40).mean(axis=1)


def earth_sun_distance_factor(day_of_year) -> np.ndarray:
    """Eccentricity correction (r0/r)^2 [1] for a day of year [1-366], Spencer (1971) Fourier series."""
    g = 2.0 * np.pi * (np.asarray(day_of_year, float) - 1.0) / 365.0
    return (1.000110 + 0.034221 * np.cos(g) + 0.001280 * np.sin(g) + 0.000719 * np.cos(2 * g)
            + 0.000077 * np.sin(2 * g))
