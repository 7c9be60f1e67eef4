"""The all-sky model inside the integrator: one chunk of steps, from the clear sky to contracted all-sky light.

:func:`widesky.irradiance.poa_irradiance` with ``MeasuredSky(measured=..., spectral_model="allsky")`` calls
:func:`allsky_patch_radiance` for each chunk of lit steps instead of scaling the contracted clear sky
by broadband factors. The clear sky is evaluated once, contracted with a broadband column and the
identity (so the model's spectral DNI and DHI of the step are known from the integrator's own
quadrature), the per-step per-channel factors of :func:`widesky.irradiance.allsky.allsky_factors` are applied
per channel, and the result is contracted with the integrator's columns; the cloud-scattered light
is added as patch radiance of the Perez all-weather sky of the step (:mod:`widesky.irradiance.perez_sky`;
``AllSkyOptions(angular="cie_overcast")``: the CIE overcast sky, :mod:`widesky.irradiance.overcast_sky`), which
then goes through the same occlusion, optics and reflection coefficients as any sky light.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from widesky.core.spectral import in_band_share

from .allsky import AllSkyOptions, allsky_factors
from .ground import ground_scales, vegetated_steps
from .integrator import patch_radiance
from .overcast_sky import cie_overcast_relative
from .perez_sky import cloud_patch_shape

__all__ = ["AllSkyWeather", "allsky_patch_radiance"]


class AllSkyWeather(NamedTuple):
    """Measured weather for the all-sky model, each (T,) (``None``: not available).

    dni, dhi, ghi : [W m-2] (``ghi`` default ``dni sin(elevation) + dhi``).
    visibility : [km] station visibility (the haze extension below the dataset's range).
    temp_dew : [degC] dew point (water vapour in the cloud).
    snow_depth : [cm] snow depth (a snow-covered ground is not vegetated, :mod:`widesky.irradiance.ground`).
    """

    dni: np.ndarray
    dhi: np.ndarray
    ghi: object = None
    visibility: object = None
    temp_dew: object = None
    snow_depth: object = None

    def take(self, idx):
        """The steps ``idx``."""
        return AllSkyWeather(*(None if v is None else np.asarray(v, dtype=float)[idx] for v in self))


def weather_measurements(data, spectral_model="clear", aerosol="visibility", clear_sky=False):
    """What the integrator's ``MeasuredSky(measured=...)`` takes from a weather file's rows, and how to describe it.

    Parameters
    ----------
    data : pandas.DataFrame
        The weather rows of the steps (columns ``dni``, ``dhi`` [W m-2]; ``ghi`` [W m-2], ``visibility``
        [km], ``temp_dew`` [degC], ``snow_depth`` [cm] where present).
    spectral_model : {"clear", "allsky"}
        Clear-sky spectra scaled to the measured DNI/DHI, or the all-sky spectra (docs/all-sky.md).
    aerosol : {"visibility", "aod"}
        Where the steps' aerosol came from; with "aod" the haze extension (which works from station
        visibility) is not applied.
    clear_sky : bool
        Ignore the measurements (the unscaled clear sky).

    Returns
    -------
    (measured, description)
        ``measured``: None, (dni, dhi) (T,) arrays, or an :class:`AllSkyWeather`; ``description``: a phrase
        for reports, e.g. "scaled to measured DNI/DHI".
    """
    if clear_sky or not {"dni", "dhi"} <= set(data.columns):
        return None, "clear sky"
    measured = (data["dni"].to_numpy(), data["dhi"].to_numpy())
    if spectral_model == "allsky":
        col = {c: data[c].to_numpy() if c in data else None
               for c in ("ghi", "visibility", "temp_dew", "snow_depth")}
        if aerosol == "aod":
            col["visibility"] = None
        return AllSkyWeather(*measured, **col), "all-sky spectra scaled to measured DNI/DHI"
    if spectral_model != "clear":
        raise ValueError(f"spectral_model={spectral_model!r} is not one of ('clear', 'allsky')")
    return measured, "scaled to measured DNI/DHI"


def allsky_patch_radiance(sky, patches, states, weights, settings, weather: AllSkyWeather,
                          options=AllSkyOptions(), min_visibility=20.0, ground_shape=None):
    """All-sky patch radiance and beam of one chunk of steps, contracted with ``weights``.

    The chunk is evaluated in blocks of steps whose spectral arrays stay in cache (about 4 MB; each step's values
    do not depend on the block).

    Parameters
    ----------
    sky, patches, states, settings
        As :func:`widesky.irradiance.patch_radiance` (``states``: the chunk's T states).
    weights : array_like
        (C, R) contraction matrix of the integrator.
    weather : AllSkyWeather
        The chunk's measured weather.
    options : AllSkyOptions
    min_visibility : float
        The dataset's lowest visibility [km].
    ground_shape : array_like, optional
        (C,) relative spectral reflectance [1] of a vegetated ground (:mod:`widesky.irradiance.ground`): with it
        the per-step factors of the shape and of a grey ground are returned (``ground``).

    Returns
    -------
    radiance : numpy.ndarray
        (T, P, R) all-sky patch radiance, contracted.
    direct_normal : numpy.ndarray
        (T, R) sun plus circumsolar normal irradiance, contracted (the circumsolar light takes the
        diffuse factor, as in the integrator's measured path).
    factors : AllSkyFactors
    model : tuple
        (model_dni, model_dhi) (T,) [W m-2], the clear model's broadband values.
    ground : tuple or None
        With ``ground_shape``: (a_shape, a_grey) (T,) [1] of :func:`widesky.irradiance.ground.ground_scales`
        from the step's all-sky global horizontal spectrum (vegetated steps by
        :func:`widesky.irradiance.ground.vegetated_steps` from the states' albedo and ``weather.snow_depth``).
    """
    W = np.asarray(weights, dtype=float)
    T = len(states)
    # blocks of steps whose spectral arrays stay in cache ((block, P, C + 1) float64 of about 4 MB): the whole chunk's
    # 56-column arrays made every pass, the sky tables' lookups included, run from memory (about twice the time)
    block = max(16, _BLOCK_BYTES // (8 * patches.n_patches * (sky.n_channels + 1)))
    if T <= block:
        return _allsky_block(sky, patches, states, W, settings, weather, options, min_visibility, ground_shape)
    parts = []
    for a in range(0, T, block):
        idx = np.arange(a, min(a + block, T))
        wx = AllSkyWeather(*(v if v is None or np.ndim(v) == 0 else np.asarray(v)[idx] for v in weather))
        parts.append(_allsky_block(sky, patches, states.take(idx), W, settings, wx, options, min_visibility,
                                   ground_shape))
    return _stack(parts)


_BLOCK_BYTES = 4 << 20


def _stack(parts):
    """Per-step results of consecutive blocks joined along the steps (named tuples field by field; None stays)."""
    first = parts[0]
    if first is None:
        return None
    if isinstance(first, tuple):
        joined = [_stack([p[i] for p in parts]) for i in range(len(first))]
        return type(first)(*joined) if hasattr(first, "_fields") else tuple(joined)
    if isinstance(first, np.ndarray) and first.ndim >= 1:
        return np.concatenate(parts)
    return first


def _allsky_block(sky, patches, states, W, settings, weather, options, min_visibility, ground_shape):
    """:func:`allsky_patch_radiance` of one block of steps."""
    C = sky.n_channels
    R = W.shape[1]
    widths = np.asarray(sky.channel_widths, dtype=float)
    # the spectral clear sky, uncontracted (the circumsolar nodes' solid angles from its broadband radial profile)
    Lp, dn, cs = patch_radiance(sky, patches, states, None, settings, profile=widths)   # (T, P, C), (T, C), (T, C)
    w_h = patches.vector[:, 2]                                    # exact horizontal weights [sr]
    sin_el = np.sin(np.radians(np.maximum(states.sun_elevation, 0.0)))
    h_clear = np.matmul(w_h, Lp)                                  # (T, C) patches' horizontal irradiance
    dhi_clear = h_clear + cs * sin_el[:, None]
    f = allsky_factors(sky.channel_edges, dn, dhi_clear, states.sun_elevation, weather.dni,
                       weather.dhi, ghi=weather.ghi, visibility=weather.visibility,
                       temp_dew=weather.temp_dew, min_visibility=min_visibility, options=options,
                       albedo=states.albedo, earth_sun_distance=states.earth_sun_distance,
                       in_band_share=in_band_share(sky.channel_edges[0], sky.channel_edges[-1]))   # broadband weather
    ds = f.diffuse_scale                                          # (T, C)
    # one pass over the spectral patch radiance: per step the (C, R + 1) matrix of the diffuse factors times the
    # integrator's columns and the channel widths (the clear light's broadband radiance for the Perez sky)
    Wt = np.empty((len(states), C, R + 1))
    np.multiply(ds[:, :, None], W[None], out=Wt[..., :R])
    np.multiply(ds, widths, out=Wt[..., R])
    LW = np.matmul(Lp, Wt)                                        # (T, P, R + 1)
    L = LW[..., :R]
    dni_c = dn * f.dni_scale + cs * ds                            # (T, C) beam + circumsolar
    if np.any(f.circumsolar_dhi > 0):                              # cloud light traced with the sun
        up = sin_el > 0
        dni_c[up] += f.circumsolar_dhi[up] / sin_el[up, None]
    dni = dni_c @ W
    if np.any(f.overcast_dhi > 0):
        shape = cie_overcast_relative(patches.directions[:, 2])
        shape = np.broadcast_to(shape / (shape * w_h).sum(), (len(states), w_h.size)).copy()   # [sr-1]
        if f.sky_clearness is not None:        # clear + cloud light together the step's Perez all-weather sky
            ok = np.isfinite(f.sky_clearness)
            if np.any(ok):
                k = max(4, getattr(settings, "radiance_samples", 2))
                shape[ok] = cloud_patch_shape(patches, states.sun_direction[ok], f.sky_clearness[ok],
                                              f.sky_brightness[ok], f.overcast_dhi[ok] @ widths,
                                              clear_radiance=LW[ok, :, R],
                                              clear_circumsolar=np.einsum("tc,tc->t", cs[ok], ds[ok] * widths),
                                              samples=k)
        L += shape[:, :, None] * (f.overcast_dhi @ W)[:, None, :]
    L = np.ascontiguousarray(L)
    ground = None
    if ground_shape is not None:                                   # the all-sky GHI spectrum of each step
        ghi_c = h_clear * ds + f.overcast_dhi + dni_c * sin_el[:, None]
        veg = vegetated_steps(states.albedo, weather.snow_depth)
        ground = ground_scales(ground_shape, ghi_c, widths, states.albedo, veg)
    return L, dni, f, (dn @ widths, dhi_clear @ widths), ground
