"""Stage 2's setup in :func:`widesky.irradiance.poa_irradiance`: how each step's sky is scaled to the weather.

:func:`step_scaling` checks :class:`~widesky.irradiance.poa_options.MeasuredSky` against the states and
holds the per-step factors that the sky chunks (:mod:`widesky.irradiance.sky_chunks`) fill in: measured
DNI/DHI (the clear sky's shape scaled, or the all-sky model's per-channel factors) or explicit factors;
:func:`result_scaling` gives ``result.scaling``.

Measured DNI and DHI are broadband (the whole solar spectrum) while the sky covers its channels only
(280-2480 nm for the Prague Sky Model): the sky is scaled so that its in-band DNI and DHI are the measured
values times :func:`widesky.core.spectral.in_band_share` of its range (0.99248 for 280-2480 nm), widesky's one
convention for broadband values (docs/pvsim.md, "Weather files and the 280-2480 nm band").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from widesky.core.spectral import in_band_share

from .allsky import AllSkyOptions
from .allsky_sky import AllSkyWeather
from .ground import vegetation_albedo_shape
from .measured import measured_scale_factors
from .poa_options import MeasuredSky

__all__ = ["StepScaling", "step_scaling", "result_scaling"]


@dataclass(eq=False)
class StepScaling:
    """Per-step factors of a run; the ``(T,)`` arrays are filled in per chunk of steps.

    Attributes
    ----------
    sun, sky : numpy.ndarray
        (T,) factors [1] on the sun's direct normal irradiance and on the sky radiance (measured weather).
    measured : tuple of numpy.ndarray or None
        (dni, dhi) (T,) the in-band values the sky is scaled to [W m-2]: measured (broadband) times ``share``.
    model : tuple of numpy.ndarray or None
        (dni, dhi) (T,) the model's own in-band values [W m-2] (with ``measured``).
    share : float
        :func:`widesky.core.spectral.in_band_share` of the sky's channel range [1].
    allsky : tuple or None
        (AllSkyWeather, AllSkyOptions, dataset min visibility [km]) for the all-sky model.
    ch_sun, ch_sky : numpy.ndarray or None
        (T, C) explicit factors [1] (``MeasuredSky.dni_scale``, ``diffuse_scale``).
    ground_shape : numpy.ndarray or None
        (C,) vegetation albedo shape [1] of the all-sky ground.
    ground_steps : tuple of numpy.ndarray or None
        (a_shape, a_grey) (T,) [1] per-step spectral ground of the all-sky model.
    """

    sun: np.ndarray
    sky: np.ndarray
    measured: Optional[tuple] = None
    model: Optional[tuple] = None
    allsky: Optional[tuple] = None
    ch_sun: Any = None
    ch_sky: Any = None
    ground_shape: Any = None
    ground_steps: Optional[tuple] = None
    share: float = 1.0


def _allsky_setup(spectral_model, measured, T, sky, options):
    """(AllSkyWeather, AllSkyOptions, dataset min visibility [km]) for spectral_model="allsky", else None."""
    if spectral_model == "clear":
        return None
    wx = measured if isinstance(measured, AllSkyWeather) else AllSkyWeather(*tuple(measured)[:2])
    wx = AllSkyWeather(*(None if v is None else np.broadcast_to(np.asarray(v, float), (T,)) for v in wx))
    model = getattr(sky, "model", None)
    vmin = float(np.min(model.visibility_range)) if model is not None else 20.0
    return wx, options if options is not None else AllSkyOptions(), vmin



def _channel_factors(name, v, T, C):
    """(T, C) view of explicit factors [1] (scalar, (T,) or (T, C)), checked; None stays None."""
    if v is None:
        return None
    a = np.asarray(v, dtype=float)
    if a.shape not in ((T,), (T, C)) and a.ndim != 0:
        raise ValueError(f"{name} has shape {a.shape}, expected ({T},) or ({T}, {C})")
    if not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ValueError(f"{name} must be finite and >= 0")
    return np.broadcast_to(np.asarray(v, float).reshape((T, -1) if np.ndim(v) else (1, 1)), (T, C))


def step_scaling(weather: MeasuredSky, states, sky, ground_albedo=None) -> StepScaling:
    """The per-step scaling of a run under ``weather`` (:class:`MeasuredSky`) for ``states`` (T,): measured
    DNI/DHI checked, the all-sky model's inputs, its vegetated ground where the scene sets no
    ``ground_albedo``, explicit factors as (T, C)."""
    T, C = len(states), sky.n_channels
    measured = weather.measured
    out = StepScaling(np.ones(T), np.ones(T))
    if measured is not None:
        m_dni, m_dhi = (np.broadcast_to(np.asarray(a, dtype=float), (T,)) for a in tuple(measured)[:2])
        measured_scale_factors(np.ones(T), np.ones(T), m_dni, m_dhi)     # validates the inputs
        edges = np.asarray(sky.channel_edges, dtype=float)
        out.share = in_band_share(edges[0], edges[-1])                   # broadband -> in-band [1]
        out.measured, out.model = (m_dni * out.share, m_dhi * out.share), (np.zeros(T), np.zeros(T))
    out.allsky = _allsky_setup(weather.spectral_model, measured, T, sky, weather.allsky_options)
    if out.allsky is not None and out.allsky[1].ground == "vegetation" and ground_albedo is None:
        # the all-sky ground: a vegetation shape (albedo-weighted columns) and a grey part, per step
        out.ground_shape = vegetation_albedo_shape(sky.wavelengths)
        out.ground_steps = (np.zeros(T), np.asarray(states.albedo, dtype=float).copy())
    out.ch_sun = _channel_factors("dni_scale", weather.dni_scale, T, C)
    out.ch_sky = _channel_factors("diffuse_scale", weather.diffuse_scale, T, C)
    return out


def result_scaling(scaling: StepScaling, lit_mask):
    """``result.scaling``: the measured-weather factors of the run (None without measured weather); steps
    outside ``lit_mask`` (T,) bool are not counted as guarded. The unmatched irradiance is broadband [W m-2]
    (the in-band shortfall divided by ``share``), comparable with the measured values."""
    if scaling.measured is None:
        return None
    dark = ~lit_mask
    f = measured_scale_factors(*scaling.model, *scaling.measured, missing="clear")
    return f._replace(sun_scale=scaling.sun, sky_scale=scaling.sky,
                      sun_guarded=f.sun_guarded & ~dark, sky_guarded=f.sky_guarded & ~dark,
                      unmatched_dni=f.unmatched_dni / scaling.share, unmatched_dhi=f.unmatched_dhi / scaling.share)
