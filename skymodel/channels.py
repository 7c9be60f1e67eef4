"""The 55 spectral channels of the wide-spectral-range Prague Sky Model: 40 nm wide, 280-2480 nm."""

from __future__ import annotations

import numpy as np

CHANNEL_WIDTH_NM = 40.0
CHANNEL_EDGES_NM = 280.0 + CHANNEL_WIDTH_NM * np.arange(56)
"""Channel edges [nm], shape (56,): 280, 320, ..., 2480."""
CHANNEL_CENTERS_NM = 0.5 * (CHANNEL_EDGES_NM[:-1] + CHANNEL_EDGES_NM[1:])
"""Channel centres [nm], shape (55,): 300, 340, ..., 2460."""
N_CHANNELS = 55
FINE_WAVELENGTHS_NM = np.arange(280.5, 2480.0, 1.0)
"""1 nm grid used for band averaging [nm]: bin centres 280.5 ... 2479.5, shape (2200,)."""


def channel_index(channels) -> np.ndarray:
    """Validate channel indices (0..54) and return them as an int array."""
    if channels is None:
        return np.arange(N_CHANNELS)
    idx = np.atleast_1d(np.asarray(channels))
    if idx.dtype.kind not in "iu" or np.any((idx < 0) | (idx >= N_CHANNELS)):
        raise ValueError(f"channels={channels!r}: indices must be integers in [0, {N_CHANNELS - 1}]")
    return idx.astype(int)


def fine_slice(channel: int) -> slice:
    """Slice of :data:`FINE_WAVELENGTHS_NM` inside channel ``channel`` (40 values)."""
    return slice(40 * channel, 40 * channel + 40)
