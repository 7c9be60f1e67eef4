"""All-sky spectra under measured weather: per-step, per-channel factors on the clear-sky model.

widesky's sky model is cloudless. Under a weather file, the plain measured path
(:func:`widesky.irradiance.measured_scale_factors`) scales the clear-sky sun to the measured DNI and the
clear-sky diffuse to the measured DHI, keeping the clear sky's spectral shape: under overcast the
Rayleigh-blue clear-sky diffuse is then scaled up to an overcast DHI, far too blue. This module
returns factors of shape (T, C), per step and per channel, that keep the measured broadband DNI and
DHI exactly and give the spectral shape physics argues for (docs/all-sky.md):

1. **Haze** (:mod:`widesky.irradiance.haze`): below the dataset's visibility the clear-sky state is corrected
   for the extra aerosol (reddened beam, the scattered light added to the diffuse).
2. **Cloud index** (Ernst et al. 2016, eq. 5): ``N = (rho - rho_clear) / (1 - rho_clear)`` clipped to
   [0, 1], with ``rho = DHI / GHI`` measured and ``rho_clear`` the clear model's diffuse fraction: 0 for
   a clear sky, 1 when all light is diffuse.
3. **Diffuse spectrum** (Ernst et al. 2016, eqs. 7-8): clouds scatter the whole clear-sky global
   spectrum, so the diffuse shape is ``(1 - f) D(l) / int D + f G(l) t(l) / int G t``, with ``D`` the
   clear diffuse, ``G`` the clear global horizontal spectrum, ``f`` the cloud light's share of the DHI
   (Ernst: ``f = N``; default ``partition="sky_fraction"``: the clear sky's own diffuse is kept only on
   the cloud-free share of the sky, ``(1 - f) DHI = min(DHI, (1 - N) int D)``), and ``t`` the cloud layer's spectral
   transmittance relative to a grey, non-absorbing cloud (:mod:`widesky.irradiance.cloud_optics`: the Mie
   extinction, asymmetry and absorption of the droplets per channel in a two-stream slab whose optical
   depth reproduces the measured clear-sky index ``GHI / GHI_clear``, water vapour along the in-cloud
   photon paths of transmitted light (two-stream mean path), and the blue gain of
   multiple reflection between the cloud top and the Rayleigh-scattering air above it). This is the step
   that the cloud modification factors of SEDES2 (Nann & Riordan 1991) describe empirically: overcast
   light has the global spectrum's shape (no Rayleigh excess), with deeper water bands. ``G`` is taken
   at the dataset's state, without the haze correction (haze lies below the cloud).
4. **The sun through thin cloud** (Ernst et al. 2016, eq. 6): droplets and ice crystals are large
   against the wavelength, so their extinction is spectrally flat (extinction efficiency 2 to within
   3 % over 300-1200 nm for 10 um droplets, Mie, tests/test_allsky_optics.py); the beam keeps the
   (haze-corrected) clear shape, scaled to the measured DNI.

5. **Angular distribution**: the clear part ``(1 - N)`` keeps the clear sky's radiance distribution,
   the cloud part is distributed as the CIE standard overcast sky (``overcast_dhi``;
   :mod:`widesky.irradiance.overcast_sky`) except for the share ``F1`` that the Perez all-weather model puts in the
   circumsolar region (broken and thin cloud are bright toward the sun), which is traced with the sun
   (``circumsolar_dhi``; ``circumsolar="none"`` puts it all in the CIE distribution).

The factors multiply the clear-sky model spectra the integrator evaluates:
``dni_scale * dni_clear`` and ``diffuse_scale * sky_radiance`` (circumsolar light takes the diffuse
factor, as in the integrator); :func:`widesky.irradiance.poa_irradiance` applies them with
``MeasuredSky(measured=..., spectral_model="allsky")`` (:mod:`widesky.irradiance.allsky_sky`), and with
``angular="clear"`` they are plain (T, C) ``dni_scale``/``diffuse_scale``. Every part can be
switched off (:class:`AllSkyOptions`); :data:`CLEAR_SHAPE` gives back the plain measured scaling.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .cloud_optics import (CLOUD_TOP_PRESSURE_RATIO, DEFAULT_ASYMMETRY, DEFAULT_DROPLET_RADIUS,
                           cloud_optical_depth, cloud_relative_transmittance, cloud_spectral_transmittance,
                           cloud_top_rayleigh_gain, cloud_vapour_path, droplet_coalbedo, liquid_water_k,
                           mie_droplet_optics, vapour_band_deepening)
from .haze import haze_correction
from .measured import MeasuredScaling, measured_scale_factors
from .overcast_sky import SOLAR_CONSTANT, perez_circumsolar_fraction
from .perez_sky import perez_clearness_brightness

__all__ = ["AllSkyOptions", "AllSkyFactors", "allsky_factors", "cloud_index", "CLEAR_SHAPE"]


@dataclass(frozen=True)
class AllSkyOptions:
    """Switches and parameters of the all-sky model (each part can be switched off).

    Attributes
    ----------
    cloud_spectrum : bool
        Ernst et al. (2016) diffuse shape under cloud (off: clear-sky diffuse shape).
    cloud_absorption : bool
        The droplets' own spectral optics in the cloud layer (the default droplets' Mie table ships with
        widesky; another radius or ``"adt"`` needs the OPAC water optical constants in the data directory):
        with ``droplet_optics="mie"`` their Mie extinction, asymmetry parameter and absorption per channel
        in the two-stream slab (the transport optical depth grows about 10 % from the visible to 1.5 um,
        liquid water absorbs beyond 900 nm); ``"adt"``: absorption only (anomalous diffraction),
        extinction and asymmetry grey.
    droplet_optics : {"mie", "adt"}
        See ``cloud_absorption``.
    cloud_vapour : bool
        Water-vapour absorption along the long in-cloud paths (needs the dew point and the 6S band
        table in the data directory).
    vapour_path : {"two_stream", "diffusion"}
        The in-cloud mean path of transmitted light (:func:`widesky.irradiance.cloud_optics.cloud_vapour_path`):
        the two-stream slab's by the equivalence theorem (within 5 % of DISORT), or the thick-slab
        diffusion limit (half of it at optical depth 20).
    cloud_rayleigh : bool
        Multiple reflection between the cloud top and the air above it
        (:func:`widesky.irradiance.cloud_optics.cloud_top_rayleigh_gain`): the blue shift of overcast light.
    cloud_top_pressure : float
        Pressure at the cloud top relative to sea level [1] (0.8: about 1.8 km).
    partition : {"sky_fraction", "ernst"}
        How the measured DHI splits into clear-sky light (clear shape and angular distribution) and
        cloud light (global shape, CIE overcast): ``"ernst"`` as Ernst et al. (2016, eqs. 7-8), the
        clear part ``(1 - N) DHI``; ``"sky_fraction"`` keeps the clear sky's own diffuse only on the
        cloud-free share of the sky, ``min(DHI, (1 - N) D_clear)`` [W m-2], and gives the rest of the
        DHI to the clouds (docs/all-sky.md, section 1).
    haze : {"extrapolate", "clamp"}
        Below the dataset's visibility: extend the aerosol (:mod:`widesky.irradiance.haze`) or keep the
        clamped state (flagged by :func:`widesky.irradiance.sky_states`).
    angular : {"perez", "cie_overcast", "clear"}
        Angular distribution of the cloud-scattered light (returned apart as ``overcast_dhi``, for the caller
        to distribute): ``"perez"`` the Perez, Seals & Michalsky (1993) all-weather sky of the step's measured
        sky clearness and brightness (``sky_clearness``, ``sky_brightness``; :mod:`widesky.irradiance.perez_sky`:
        horizon brightening and its own circumsolar region, so ``circumsolar`` does not apply), ``"cie_overcast"``
        the CIE overcast sky (the default until 2026-12-05), or ``"clear"`` each channel's clear-sky
        distribution (folded into ``diffuse_scale``: what (T, C) factors on the clear sky alone can express).
    circumsolar : {"perez", "none"}
        With ``angular="cie_overcast"``: the share of the cloud light that the Perez et al. (1990) all-weather
        model puts in the circumsolar region (its ``F1``, from the measured DNI and DHI) is traced with the
        sun as ``circumsolar_dhi``, the rest is CIE overcast; ``"none"``: all of it CIE overcast. Below 5 deg
        of sun elevation the share tapers with ``sin(elevation) / sin(5 deg)`` (the light stays in the sky); ``F1`` is
        capped at 1 (at low sun and large sky brightness the published fit exceeds 1).
    ground : {"vegetation", "grey"}
        The spectrum of light reflected by the ground (:mod:`widesky.irradiance.ground`): ``"vegetation"``
        reflects steps of broadband albedo up to 0.3 with no snow reported with a green-vegetation
        spectrum scaled to the weather's broadband albedo (the reflected broadband irradiance unchanged),
        the rest grey; ``"grey"``: the broadband albedo at every wavelength. Applies where the scene has
        no ``ground_albedo`` of its own.
    droplet_radius : float
        Effective droplet radius [um].
    asymmetry : float
        Droplet asymmetry parameter [1].
    fog_visibility : float
        [km], see :func:`widesky.irradiance.haze.haze_correction`.
    angstrom : float
        Angstrom exponent [1] of the extra aerosol.
    data_dir : str or None
        Reference data folder for the OPAC water optical constants (``droplet_optics="adt"`` and non-default
        droplet sizes only; default ``WIDESKY_DATA_DIR`` or ``../shared/data``); where given, the 6S band table
        is read from it too instead of the copy shipped in the package.
    """

    cloud_spectrum: bool = True
    cloud_absorption: bool = True
    droplet_optics: str = "mie"
    cloud_vapour: bool = True
    vapour_path: str = "two_stream"
    cloud_rayleigh: bool = True
    cloud_top_pressure: float = CLOUD_TOP_PRESSURE_RATIO
    partition: str = "sky_fraction"
    haze: str = "extrapolate"
    angular: str = "perez"
    circumsolar: str = "perez"
    ground: str = "vegetation"
    droplet_radius: float = DEFAULT_DROPLET_RADIUS
    asymmetry: float = DEFAULT_ASYMMETRY
    fog_visibility: float = 1.0
    angstrom: float = 1.3
    data_dir: object = None

    def __post_init__(self):
        if self.haze not in ("extrapolate", "clamp"):
            raise ValueError(f"haze={self.haze!r} is not one of ('extrapolate', 'clamp')")
        if self.angular not in ("perez", "cie_overcast", "clear"):
            raise ValueError(f"angular={self.angular!r} is not one of ('perez', 'cie_overcast', 'clear')")
        if self.circumsolar not in ("perez", "none"):
            raise ValueError(f"circumsolar={self.circumsolar!r} is not one of ('perez', 'none')")
        if self.droplet_optics not in ("mie", "adt"):
            raise ValueError(f"droplet_optics={self.droplet_optics!r} is not one of ('mie', 'adt')")
        if self.vapour_path not in ("two_stream", "diffusion"):
            raise ValueError(f"vapour_path={self.vapour_path!r} is not one of ('two_stream', 'diffusion')")
        if self.ground not in ("vegetation", "grey"):
            raise ValueError(f"ground={self.ground!r} is not one of ('vegetation', 'grey')")
        if self.partition not in ("sky_fraction", "ernst"):
            raise ValueError(f"partition={self.partition!r} is not one of ('sky_fraction', 'ernst')")
        if not 0.0 < self.cloud_top_pressure <= 1.0:
            raise ValueError(f"cloud_top_pressure={self.cloud_top_pressure!r} outside the valid range (0, 1]")


CLEAR_SHAPE = AllSkyOptions(cloud_spectrum=False, cloud_absorption=False, cloud_vapour=False,
                            cloud_rayleigh=False, haze="clamp", angular="clear", ground="grey")
"""Every part off: the clear-sky shape scaled to the measured DNI and DHI (the plain measured path)."""


class AllSkyFactors(NamedTuple):
    """Output of :func:`allsky_factors` (fields in order):

    - ``dni_scale``, ``diffuse_scale``: (T, C) factors [1] on the clear-sky sun spectrum and sky radiance;
    - ``overcast_dhi``: (T, C) diffuse horizontal spectrum [W m-2 nm-1] of the cloud-scattered light, to be
      distributed as the Perez all-weather sky of ``sky_clearness`` and ``sky_brightness`` where they are given
      (``angular="perez"``, :func:`widesky.irradiance.perez_sky.perez_patch_shape`), else as the CIE overcast
      sky (:mod:`widesky.irradiance.overcast_sky`); zero with ``angular="clear"``, where it is folded into
      ``diffuse_scale`` instead (each channel's clear-sky angular distribution);
    - ``circumsolar_dhi``: (T, C) diffuse horizontal spectrum [W m-2 nm-1] of cloud light in the circumsolar
      region, to be traced with the sun (normal irradiance ``circumsolar_dhi / sin(elevation)``); zero with
      ``circumsolar="none"`` or ``angular="clear"``;
    - ``cloud_index``: (T,) Ernst cloud index N [1] in [0, 1] (0 where nothing is measured);
    - ``cloud_tau``: (T,) cloud optical depth [1] used for the absorption (0 where none);
    - ``cloud_vapour``: (T,) extra water-vapour path in the cloud [cm];
    - ``haze``: HazeCorrection or None (the below-20 km visibility correction, when applied);
    - ``scaling``: MeasuredScaling of the broadband factors (guards, unmatched irradiance);
    - ``sky_clearness``, ``sky_brightness``: (T,) the Perez sky clearness and brightness [1] of the measured
      DHI and DNI (:func:`widesky.irradiance.perez_sky.perez_clearness_brightness`) with ``angular="perez"``,
      NaN where the sun is down or DHI is 0 (CIE overcast there); None otherwise.
    """

    dni_scale: np.ndarray
    diffuse_scale: np.ndarray
    overcast_dhi: np.ndarray
    circumsolar_dhi: np.ndarray
    cloud_index: np.ndarray
    cloud_tau: np.ndarray
    cloud_vapour: np.ndarray
    haze: object
    scaling: MeasuredScaling
    sky_clearness: object = None
    sky_brightness: object = None


def cloud_index(dhi, ghi, clear_diffuse_fraction):
    """Ernst et al. (2016) cloud index ``N = (rho - rho_clear) / (1 - rho_clear)`` [1] in [0, 1].

    Parameters
    ----------
    dhi, ghi : array_like
        Measured diffuse and global horizontal irradiance [W m-2].
    clear_diffuse_fraction : array_like
        The clear-sky model's DHI / GHI [1].

    Returns
    -------
    numpy.ndarray
        0 where ``ghi`` <= 0 or an input is NaN (no information: clear shape).
    """
    dhi = np.asarray(dhi, dtype=float)
    ghi = np.asarray(ghi, dtype=float)
    rs = np.asarray(clear_diffuse_fraction, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = dhi / ghi
        n = (rho - rs) / (1.0 - rs)
    ok = np.isfinite(n) & (ghi > 0) & (rs < 1)
    return np.where(ok, np.clip(n, 0.0, 1.0), 0.0)


def _unit(spec, w):
    """Normalise (T, C) spectra to unit integral over channels of widths w; zero rows stay zero."""
    s = spec @ w
    return np.where(s[:, None] > 0, spec / np.where(s > 0, s, 1.0)[:, None], 0.0)


def _ratio(num, den):
    with np.errstate(divide="ignore", invalid="ignore"):
        r = num / den
    return np.where((den > 0) & np.isfinite(r), r, 0.0)


def allsky_factors(channel_edges, dni_clear, dhi_clear, sun_elevation, dni, dhi, ghi=None,
                   visibility=None, temp_dew=None, min_visibility=20.0, options=AllSkyOptions(),
                   albedo=0.2, earth_sun_distance=1.0, in_band_share=1.0, **guards) -> AllSkyFactors:
    """Per-step, per-channel factors that give the all-sky spectra and keep measured DNI and DHI.

    Parameters
    ----------
    channel_edges : array_like
        (C+1,) channel edges [nm] (the sky's; the centres are their midpoints).
    dni_clear : array_like
        (T, C) the clear-sky model's sun direct normal spectrum [W m-2 nm-1].
    dhi_clear : array_like
        (T, C) the clear-sky model's diffuse horizontal spectrum, circumsolar light included
        [W m-2 nm-1].
    sun_elevation : array_like
        (T,) apparent sun elevation [deg].
    dni, dhi : array_like
        (T,) measured direct normal and diffuse horizontal irradiance [W m-2] (NaN = missing); the channels
        carry them times ``in_band_share``.
    ghi : array_like, optional
        (T,) measured global horizontal irradiance [W m-2]; default ``dni sin(elevation) + dhi``.
    visibility : array_like, optional
        (T,) measured visibility [km] for the haze extension (the sky was evaluated at
        ``max(visibility, min_visibility)``).
    temp_dew : array_like, optional
        (T,) dew point [degC] for the water vapour inside the cloud (without it that part is off).
    min_visibility : float
        The dataset's lowest visibility [km].
    options : AllSkyOptions
    albedo : array_like
        (T,) or scalar ground albedo [1] under the cloud (the sky states' albedo), for the cloud-top
        multiple reflection.
    earth_sun_distance : array_like
        (T,) or scalar Earth-Sun distance [AU], for the extraterrestrial irradiance of the Perez sky
        brightness (``circumsolar="perez"``).
    in_band_share : float
        The share [1] of ``dni``, ``dhi`` and ``ghi`` that the channels carry: 1 (default) as given; for a weather
        file's broadband values :func:`widesky.core.spectral.in_band_share` of the channels' range (0.99248 for
        280-2480 nm, as the integrator passes; docs/pvsim.md). The Perez sky clearness and brightness take the
        values as given (broadband, as the model was fitted).
    **guards
        Passed to :func:`widesky.irradiance.measured_scale_factors` (``min_model_dni``, ``min_model_dhi``,
        ``max_scale``, ``missing``; default ``missing="clear"`` as the integrator: NaN input keeps
        the clear sky, flagged).

    Returns
    -------
    AllSkyFactors
        ``sum_c dni_scale * dni_clear * width = scaling.sun_scale * sum_c dni_clear * width`` and the
        same for the diffuse: the in-band totals are those of the plain measured path (the measured
        values times the in-band share wherever its guards did not act; ``scaling``'s unmatched
        irradiance is in-band).
    """
    edges = np.asarray(channel_edges, dtype=float)
    if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0):
        raise ValueError("channel_edges must be increasing with >= 2 values [nm]")
    lam = 0.5 * (edges[1:] + edges[:-1])
    w = np.diff(edges)
    bn = np.asarray(dni_clear, dtype=float)
    dh = np.asarray(dhi_clear, dtype=float)
    el = np.asarray(sun_elevation, dtype=float)
    T, C = el.shape[0], lam.size
    if bn.shape != (T, C) or dh.shape != (T, C):
        raise ValueError(f"dni_clear and dhi_clear must have shape ({T}, {C}), got {bn.shape}, "
                         f"{dh.shape}")
    dni_bb = np.broadcast_to(np.asarray(dni, dtype=float), (T,))
    dhi_bb = np.broadcast_to(np.asarray(dhi, dtype=float), (T,))
    band_share = float(in_band_share)                    # given (broadband) -> in-band (docs/pvsim.md)
    if not 0.0 < band_share <= 1.5:
        raise ValueError(f"in_band_share={in_band_share!r} outside the valid range (0, 1.5]")
    dni, dhi = dni_bb * band_share, dhi_bb * band_share
    model_dni, model_dhi = bn @ w, dh @ w
    guards.setdefault("missing", "clear")
    scaling = measured_scale_factors(model_dni, model_dhi, dni, dhi, **guards)
    sin_el = np.sin(np.radians(np.maximum(el, 0.0)))

    haze = None
    bh, dhh = bn, dh
    if options.haze == "extrapolate" and visibility is not None:
        haze = haze_correction(lam, w, bn, dh, el, np.broadcast_to(np.asarray(visibility, float), (T,)),
                               dni=dni, min_visibility=min_visibility,
                               fog_visibility=options.fog_visibility, angstrom=options.angstrom)
        bh, dhh = haze.dni, haze.dhi

    gh = bh * sin_el[:, None] + dhh                       # clear global horizontal, hazy (T, C)
    g0 = bn * sin_el[:, None] + dh                        # the same at the dataset's state
    ghi_m = (np.nan_to_num(dni) * sin_el + np.nan_to_num(dhi)) if ghi is None else \
        np.broadcast_to(np.asarray(ghi, dtype=float), (T,)) * band_share
    n = np.zeros(T)
    tau = np.zeros(T)
    du = np.zeros(T)
    trans = np.ones((T, C))
    if options.cloud_spectrum:
        n = cloud_index(dhi, ghi_m, _ratio(dhh @ w, gh @ w))
        if options.cloud_absorption or options.cloud_vapour or options.cloud_rayleigh:
            kc = _ratio(ghi_m, gh @ w)
            tau = np.where(n > 0, cloud_optical_depth(np.where(kc > 0, kc, 1.0), options.asymmetry), 0.0)
        if options.cloud_absorption and options.droplet_optics == "mie":
            ext, co, g = mie_droplet_optics(lam, options.droplet_radius, data_dir=options.data_dir)
            trans = trans * cloud_spectral_transmittance(tau, ext, co, g, options.asymmetry)
        elif options.cloud_absorption:
            co = droplet_coalbedo(lam, liquid_water_k(lam, options.data_dir), options.droplet_radius)
            trans = trans * cloud_relative_transmittance(tau, co, options.asymmetry)
        if options.cloud_vapour and temp_dew is not None:
            du = cloud_vapour_path(tau, np.broadcast_to(np.asarray(temp_dew, float), (T,)),
                                   options.asymmetry, options.droplet_radius, path=options.vapour_path)
            trans = trans * vapour_band_deepening(edges, du, options.data_dir)
        if options.cloud_rayleigh:
            trans = trans * cloud_top_rayleigh_gain(lam, tau, np.broadcast_to(np.asarray(albedo, float), (T,)),
                                                    options.asymmetry, options.cloud_top_pressure)
    # the clear part keeps the (hazy) clear diffuse shape and angular distribution; the cloud part has
    # the shape of the global spectrum at the dataset's state (the haze lies below the cloud, where
    # the cloud's diffuse light is scattered on, not removed) times the cloud's transmittance
    keep = dh > 0                                         # channels the clear sky can carry light in
    total = scaling.sky_scale * model_dhi                 # broadband DHI reproduced [W m-2]
    share = n                                             # cloud light's share of the DHI [1]
    if options.cloud_spectrum and options.partition == "sky_fraction":
        clear_light = np.minimum(total, (1.0 - n) * (dhh @ w))
        share = np.where(total > 0, 1.0 - _ratio(clear_light, total), 0.0)
    clear_part = (1.0 - share)[:, None] * _unit(np.where(keep, dhh, 0.0), w)
    cloud_part = share[:, None] * _unit(np.where(keep, g0 * trans, 0.0), w)
    eps = dlt = None
    r = np.broadcast_to(np.asarray(earth_sun_distance, dtype=float), (T,))
    if options.angular != "clear":
        diffuse_scale = scaling.sky_scale[:, None] * _ratio(clear_part * model_dhi[:, None], dh)
        overcast_dhi = total[:, None] * cloud_part
        circumsolar_dhi = np.zeros((T, C))
        if options.angular == "perez":
            eps, dlt, ok = perez_clearness_brightness(dhi_bb, dni_bb, el, SOLAR_CONSTANT / r ** 2)
            eps, dlt = np.where(ok, eps, np.nan), np.where(ok, dlt, np.nan)
        elif options.circumsolar == "perez" and options.cloud_spectrum:
            f1 = perez_circumsolar_fraction(dhi_bb, dni_bb, el, SOLAR_CONSTANT / r ** 2)
            f1 = np.minimum(f1, 1.0) * np.minimum(1.0, sin_el / np.sin(np.radians(5.0)))
            circumsolar_dhi = f1[:, None] * overcast_dhi
            overcast_dhi = overcast_dhi - circumsolar_dhi
    else:
        diffuse_scale = scaling.sky_scale[:, None] * _ratio((clear_part + cloud_part) * model_dhi[:, None], dh)
        overcast_dhi = np.zeros((T, C))
        circumsolar_dhi = np.zeros((T, C))
    beam = _unit(np.where(bn > 0, bh, 0.0), w)
    dni_scale = scaling.sun_scale[:, None] * _ratio(beam * model_dni[:, None], bn)
    # rows with nothing to shape (night, zero model) keep the broadband factor on every channel
    for f, s, m in ((dni_scale, scaling.sun_scale, model_dni), (diffuse_scale, scaling.sky_scale, model_dhi)):
        empty = ~(m > 0)
        f[empty] = np.asarray(s)[empty, None]
    return AllSkyFactors(dni_scale, diffuse_scale, overcast_dhi, circumsolar_dhi, n, tau, du, haze, scaling,
                         eps, dlt)
