"""Spectral plane-of-array irradiance of an unobstructed plane under all-sky factors.

The cheap path for studies of one orientation (technology comparisons, validation against measured
spectral effects): the sky is integrated with the integrator's own quadrature
(:func:`widesky.irradiance.patch_radiance` on Reinhart patches, circumsolar light traced with the sun), the
patch weights are the exact projected solid angles of :func:`widesky.irradiance.cosine_weights`, and the ground
is an infinite Lambertian plane, ``albedo GHI (1 - cos tilt) / 2``. No ray casting: nothing shades the
plane or the ground. Per-step, per-channel factors (:func:`widesky.irradiance.allsky.allsky_factors`) and the
cloud light's angular distribution (the Perez all-weather sky of :mod:`widesky.irradiance.perez_sky`, or the CIE
overcast sky of :mod:`widesky.irradiance.overcast_sky`) apply exactly as in the integrator: the cloud light is
linear in the patch radiance, so it needs only each plane's ratio of cloud light to its horizontal irradiance,
per step for the Perez sky (:func:`cloud_poa_ratio`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from tqdm.auto import tqdm

from .ground import ground_scales, step_spectral_albedo
from .integrator import IntegratorSettings, patch_radiance
from .overcast_sky import overcast_poa_ratio
from .patches import cosine_weights, direction_from_angles, reinhart
from .perez_sky import cloud_patch_shape

__all__ = ["ClearPlaneSpectra", "clear_plane_spectra", "plane_poa", "cloud_poa_ratio", "clear_patch_broadband"]


class ClearPlaneSpectra(NamedTuple):
    """Clear-sky spectra of one step series for one plane, all (T, C) [W m-2 nm-1] unless stated.

    dni : sun direct normal. dhi : sky diffuse horizontal, circumsolar included.
    circumsolar : circumsolar normal irradiance, traced with the sun (sky light: it takes the diffuse
        factor, and the integrator counts it in ``poa_direct``, as the Perez model does).
    poa_sky : sky diffuse on the plane, circumsolar excluded.
    cos_aoi : (T,) max(0, cos(angle of incidence)) [1]. sin_elevation : (T,) [1].
    overcast_ratio : () plane / horizontal sky diffuse under the CIE overcast sky [1].
    view_ground : () ground view factor ``(1 - cos tilt) / 2`` [1].
    """

    dni: np.ndarray
    dhi: np.ndarray
    circumsolar: np.ndarray
    poa_sky: np.ndarray
    cos_aoi: np.ndarray
    sin_elevation: np.ndarray
    overcast_ratio: float
    view_ground: float


def clear_plane_spectra(sky, states, surface_tilt, surface_azimuth, settings=None, chunk=64,
                        progress=False) -> ClearPlaneSpectra:
    """Clear-sky spectral irradiance components of an unobstructed plane per step.

    Parameters
    ----------
    sky : sky source
        :class:`widesky.irradiance.PragueSky` or another (:mod:`widesky.irradiance.skies`).
    states : SkyStates
        T sky states.
    surface_tilt : float
        [deg] from horizontal, in [0, 180].
    surface_azimuth : float
        [deg] clockwise from north (180 = south).
    settings : IntegratorSettings, optional
        Quadrature (``mf``, radiance samples, circumsolar disc).
    chunk : int
        Steps per sky evaluation (64: the (64, P, C) float64 spectral arrays stay in cache; 256 took twice the
        time, the same values).
    progress : bool
        tqdm progress bar.

    Returns
    -------
    ClearPlaneSpectra
    """
    if not 0.0 <= float(surface_tilt) <= 180.0:
        raise ValueError(f"surface_tilt={surface_tilt!r} deg outside the valid range [0, 180]")
    settings = settings or IntegratorSettings()
    patches = reinhart(settings.mf)
    normal = direction_from_angles(90.0 - float(surface_tilt), float(surface_azimuth)).reshape(1, 3)
    w_h = cosine_weights(patches, np.array([[0.0, 0.0, 1.0]]))[0]
    w_p = cosine_weights(patches, normal)[0]
    T, C = len(states), sky.n_channels
    dni, dhi, psky, circ = (np.zeros((T, C)) for _ in range(4))
    s = states.sun_direction
    cos_aoi = np.where(states.sun_elevation > 0, np.maximum(s @ normal[0], 0.0), 0.0)
    sin_el = np.sin(np.radians(np.maximum(states.sun_elevation, 0.0)))
    lit = np.nonzero(states.sun_elevation > getattr(sky, "min_sun_elevation", 0.0))[0]
    blocks = range(0, lit.size, max(int(chunk), 1))
    if progress:
        blocks = tqdm(blocks, unit="chunk", desc="clear-sky spectra")
    for c0 in blocks:
        idx = lit[c0:c0 + chunk]
        Lp, dn, cs = patch_radiance(sky, patches, states.take(idx), None, settings)
        dni[idx] = dn
        dhi[idx] = np.einsum("p,tpc->tc", w_h, Lp) + cs * sin_el[idx, None]
        psky[idx] = np.einsum("p,tpc->tc", w_p, Lp)
        circ[idx] = cs
    ratio = float(overcast_poa_ratio(w_p, w_h, patches.directions[:, 2]))
    view_ground = 0.5 * (1.0 - np.cos(np.radians(float(surface_tilt))))
    return ClearPlaneSpectra(dni, dhi, circ, psky, cos_aoi, sin_el, ratio, view_ground)


def clear_patch_broadband(sky, states, settings=None, chunk=256):
    """The clear sky's broadband patch radiance and circumsolar normal irradiance per step (unit scale).

    What :func:`cloud_poa_ratio` needs to share the Perez sky between clear and cloud light as the
    integrator does; one more evaluation of the sky (:func:`widesky.irradiance.patch_radiance`).

    Returns
    -------
    (radiance, circumsolar) : (T, P) [W m-2 sr-1], (T,) [W m-2]
    """
    settings = settings or IntegratorSettings()
    patches = reinhart(settings.mf)
    w = np.asarray(sky.channel_widths, dtype=float)[:, None]
    T = len(states)
    rad, circ = np.zeros((T, patches.n_patches)), np.zeros(T)
    lit = np.nonzero(states.sun_elevation > getattr(sky, "min_sun_elevation", 0.0))[0]
    for c0 in range(0, lit.size, max(int(chunk), 1)):
        idx = lit[c0:c0 + chunk]
        Lp, _dn, cs = patch_radiance(sky, patches, states.take(idx), w, settings)
        rad[idx], circ[idx] = Lp[..., 0], cs[:, 0]
    return rad, circ


def cloud_poa_ratio(factors, sun_direction, surface_tilt, surface_azimuth, settings=None, samples=4,
                    clear=None):
    """Per-step ratio of the cloud light on an unobstructed plane to its horizontal irradiance [1].

    Parameters
    ----------
    factors : AllSkyFactors
        From :func:`widesky.irradiance.allsky.allsky_factors`; where its ``sky_clearness`` is given
        (``angular="perez"``) the Perez all-weather sky of each step, elsewhere (and on steps where it is NaN)
        the CIE overcast sky.
    sun_direction : array_like
        (T, 3) unit vectors towards the sun (``SkyStates.sun_direction``).
    surface_tilt, surface_azimuth : float
        [deg] from horizontal; clockwise from north.
    settings : IntegratorSettings, optional
        The sky discretisation (``mf``).
    samples : int
        Sub-directions per patch side for the patch means.
    clear : tuple, optional
        ``(radiance, circumsolar, dhi, channel_edges)``: the clear sky's broadband patch radiance (T, P)
        [W m-2 sr-1] and circumsolar normal irradiance (T,) [W m-2] at unit scale
        (:func:`clear_patch_broadband`), its spectral diffuse horizontal irradiance (T, C) [W m-2 nm-1]
        (``ClearPlaneSpectra.dhi``) and the channel edges (C+1,) [nm]. With it the cloud light fills what
        the Perez sky has beyond the clear light (:func:`widesky.irradiance.perez_sky.cloud_patch_shape`), as
        in the integrator; without it the cloud light is the Perez sky on its own.

    Returns
    -------
    numpy.ndarray
        (T,) [1]: 1 for a horizontal plane.
    """
    settings = settings or IntegratorSettings()
    patches = reinhart(settings.mf)
    normal = direction_from_angles(90.0 - float(surface_tilt), float(surface_azimuth)).reshape(1, 3)
    w_p = cosine_weights(patches, normal)[0]
    w_h = cosine_weights(patches, np.array([[0.0, 0.0, 1.0]]))[0]
    sd = np.asarray(sun_direction, dtype=float)
    cie = float(overcast_poa_ratio(w_p, w_h, patches.directions[:, 2]))
    out = np.full(sd.shape[0], cie)
    eps = getattr(factors, "sky_clearness", None)
    if eps is None:
        return out
    ok = np.isfinite(eps)
    if not np.any(ok):
        return out
    cr = cc = None
    cloud = np.zeros(int(ok.sum()))
    if clear is not None:
        rad, circ, dhi, edges = clear
        w = np.diff(np.asarray(edges, dtype=float))
        d = np.asarray(dhi, dtype=float)[ok]
        with np.errstate(invalid="ignore", divide="ignore"):       # the clear light's broadband scale
            g = (factors.diffuse_scale[ok] * d) @ w / (d @ w)
        g = np.where(np.isfinite(g), g, 0.0)
        cr = np.asarray(rad, dtype=float)[ok] * g[:, None]
        cc = np.asarray(circ, dtype=float)[ok] * g
        cloud = factors.overcast_dhi[ok] @ w
    shape = cloud_patch_shape(patches, sd[ok], eps[ok], factors.sky_brightness[ok], cloud,
                              clear_radiance=cr, clear_circumsolar=cc, samples=samples)
    out[ok] = shape @ w_p
    return out


def plane_poa(clear: ClearPlaneSpectra, dni_scale, diffuse_scale, albedo, overcast_dhi=None,
              circumsolar_dhi=None, albedo_shape=None, channel_edges=None, vegetated=None, overcast_ratio=None):
    """Spectral plane-of-array components under per-step (and per-channel) factors.

    Parameters
    ----------
    clear : ClearPlaneSpectra
    dni_scale, diffuse_scale : array_like
        (T,) or (T, C) factors [1] on the sun spectrum and the sky radiance.
    albedo : array_like
        Ground albedo [1]: scalar or (T,) per step.
    overcast_dhi : array_like, optional
        (T, C) diffuse horizontal spectrum [W m-2 nm-1] of the cloud light (``AllSkyFactors.overcast_dhi``),
        added to the scaled clear sky: on the plane ``overcast_dhi x overcast_ratio``.
    circumsolar_dhi : array_like, optional
        (T, C) diffuse horizontal spectrum [W m-2 nm-1] of cloud light traced with the sun
        (``AllSkyFactors.circumsolar_dhi``): on the plane ``circumsolar_dhi cos(aoi) / sin(elevation)``,
        in ``poa_direct`` as the clear circumsolar light.
    albedo_shape : array_like, optional
        (C,) relative spectral shape [1] of the ground's reflectance (e.g. :func:`widesky.irradiance.ground.vegetation_albedo_shape`).
        The broadband ``albedo`` is kept (what a weather file's albedometer measures): each step's spectral
        albedo is ``albedo shape / (sum shape GHI w / sum GHI w)``, so the reflected broadband irradiance is
        unchanged and only its spectrum follows the shape (:func:`widesky.irradiance.ground.ground_scales`: a step
        whose scaled shape would exceed 1 stays grey). None: grey ground. The sky radiance keeps the grey
        albedo it was evaluated with (the sky's own dependence on the ground is a second-order term), as
        in the integrator's all-sky path (``AllSkyOptions.ground``).
    channel_edges : array_like, optional
        (C+1,) channel edges [nm], needed with ``albedo_shape`` (the broadband weighting).
    vegetated : array_like, optional
        (T,) bool: the steps whose ground follows ``albedo_shape`` (the rest grey; default all;
        :func:`widesky.irradiance.ground.vegetated_steps` gives the all-sky model's rule).
    overcast_ratio : array_like, optional
        Scalar or (T,) plane / horizontal irradiance of the cloud light [1] (:func:`cloud_poa_ratio`: the
        Perez all-weather sky of factors with ``angular="perez"``); default the CIE overcast sky's
        ``clear.overcast_ratio``.

    Returns
    -------
    dict
        ``poa_direct`` (beam and circumsolar, as the integrator), ``poa_sky_diffuse``,
        ``poa_ground_diffuse``, ``poa_global``, ``ghi``, ``dhi``, ``dni`` (the sun only): (T, C)
        [W m-2 nm-1].
    """
    T, C = clear.dni.shape
    fb = np.asarray(dni_scale, dtype=float)
    fd = np.asarray(diffuse_scale, dtype=float)
    fb = fb[:, None] if fb.ndim == 1 else fb
    fd = fd[:, None] if fd.ndim == 1 else fd
    dni = fb * clear.dni
    dhi = fd * clear.dhi
    sky = fd * clear.poa_sky
    if overcast_dhi is not None:
        ov = np.asarray(overcast_dhi, dtype=float)
        if ov.shape != (T, C) or np.any(ov < 0):
            raise ValueError(f"overcast_dhi must have shape ({T}, {C}) and be >= 0")
        ratio = clear.overcast_ratio if overcast_ratio is None else np.asarray(overcast_ratio, dtype=float)
        sky = sky + ov * (ratio[:, None] if np.ndim(ratio) == 1 else ratio)
        dhi = dhi + ov
    circ = 0.0
    if circumsolar_dhi is not None:
        cs = np.asarray(circumsolar_dhi, dtype=float)
        if cs.shape != (T, C) or np.any(cs < 0):
            raise ValueError(f"circumsolar_dhi must have shape ({T}, {C}) and be >= 0")
        se = clear.sin_elevation
        circ = np.where(se[:, None] > 0, cs / np.where(se > 0, se, 1.0)[:, None], 0.0)
        dhi = dhi + cs
    ghi = dni * clear.sin_elevation[:, None] + dhi
    alb = np.asarray(albedo, dtype=float)
    if alb.ndim == 1:
        if alb.shape != (T,):
            raise ValueError(f"albedo must be a scalar or have shape ({T},), got {alb.shape}")
        alb = alb[:, None]
    if albedo_shape is not None:
        shape = np.asarray(albedo_shape, dtype=float)
        if shape.shape != (C,) or not np.all(np.isfinite(shape)) or np.any(shape < 0) or not np.any(shape > 0):
            raise ValueError(f"albedo_shape must be ({C},) finite, >= 0 and not all zero, got shape {shape.shape}")
        if channel_edges is None or np.shape(channel_edges) != (C + 1,):
            raise ValueError(f"albedo_shape needs channel_edges of shape ({C + 1},)")
        veg = np.ones(T, bool) if vegetated is None else np.broadcast_to(np.asarray(vegetated, bool), (T,))
        a_shape, a_grey = ground_scales(shape, ghi, np.diff(np.asarray(channel_edges, dtype=float)),
                                        np.broadcast_to(alb[:, 0] if np.ndim(alb) else alb, (T,)), veg)
        alb = step_spectral_albedo(shape, a_shape, a_grey)
    ground = alb * ghi * clear.view_ground
    direct = (dni + fd * clear.circumsolar + circ) * clear.cos_aoi[:, None]
    return {"poa_direct": direct, "poa_sky_diffuse": sky, "poa_ground_diffuse": ground,
            "poa_global": direct + sky + ground, "ghi": ghi, "dhi": dhi, "dni": dni}
