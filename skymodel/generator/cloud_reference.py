"""Reference spectra under a homogeneous water cloud: the dataset's DISORT chain with a cloud layer.

Part of the generator (build and validation time only: it needs the ``[build]`` extra and the reference data);
the validation of the all-sky model (tests/test_cloud_reference.py, benchmarks/bench_allsky_cloud_rt.py) calls it.

An independent physical check of the all-sky parametrisation (:mod:`widesky.irradiance.allsky`, docs/all-sky.md): the
same layered clear atmosphere the dataset is built from (AFGL profile, Rayleigh, ozone, the 6S k-distribution
gas terms, OPAC aerosol; :mod:`widesky.skymodel.generator.optics`), plus a plane-parallel stratiform water cloud, solved
for the fluxes at the ground with plane-parallel DISORT (Stamnes et al. 1988; disortpp, delta-M scaling), so that
multiple scattering in the cloud, droplet absorption, the water vapour inside the cloud, Rayleigh scattering above
and below it and the multiple reflection between cloud and ground all come out of the radiative transfer itself
instead of the all-sky model's parametrisations.

The cloud:

- droplets: Mie optics of a gamma size distribution (:func:`widesky.irradiance.cloud_optics.mie_droplet_optics`):
  extinction (scaled from ``tau550``), single-scattering albedo and asymmetry parameter per wavelength;
  Henyey-Greenstein phase function with that asymmetry (DISORT's delta-M handles the forward peak for fluxes);
- geometry: from ``cloud_base_km`` up by the thickness ``H = LWP / LWC`` with ``LWP = 2 rho_w r_e tau / 3``
  (Stephens 1978, J. Atmos. Sci. 35, 2123), in three equal layers; the air in the cloud is saturated over water at
  the layer's temperature (Magnus formula, Alduchov & Eskridge 1996), which replaces the profile's vapour there.

Units: wavelength [nm], irradiance [W m-2 nm-1], altitude [km], radius [um], LWC [g m-3].
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from widesky.irradiance.allsky import AllSkyOptions, allsky_factors
from widesky.irradiance.cloud_optics import cloud_thickness_m, mie_droplet_optics, saturation_vapour_density

from ..channels import CHANNEL_CENTERS_NM, CHANNEL_EDGES_NM, N_CHANNELS, channel_index
from .aerosol import aerosol_layer_fractions, opac_mixture
from .atmosphere import AVOGADRO, DEFAULT_LEVELS_KM, H2O_MOLAR_MASS, standard_atmosphere
from .gases import load_kdistributions
from .optics import channel_subproblems
from .ozone import ozone_optical_depth
from .solar import extraterrestrial_spectrum
from .solver import AtmosphereSpec, SolverConfig, run_disort

__all__ = ["cloudy_fluxes", "CloudyFluxes", "allsky_global_horizontal"]

@dataclass
class _Layers:
    """A sub-problem's layers with the cloud added, in the form :func:`run_disort` asks of a problem."""

    dtau: np.ndarray
    ssa: np.ndarray
    mom: np.ndarray

    def disort_layers(self):
        return self.dtau[::-1].copy(), self.ssa[::-1].copy(), self.mom[::-1].copy()

    def phase_table(self):
        return None


@dataclass
class CloudyFluxes:
    """Flux spectra at the ground (C,) [W m-2 nm-1] for the channels ``channels``: ``ghi``, ``direct_horizontal``,
    ``diffuse_horizontal``; ``extraterrestrial`` (C,); ``cloud_top_km``, ``cloud_base_km`` [km];
    ``cloud_temperature_k`` [K] (mean of the cloud layers; the saturated vapour's); ``in_cloud_vapour_cm`` [cm]."""

    channels: np.ndarray
    wavelength_nm: np.ndarray
    ghi: np.ndarray
    direct_horizontal: np.ndarray
    diffuse_horizontal: np.ndarray
    extraterrestrial: np.ndarray
    tau550: float
    cloud_base_km: float
    cloud_top_km: float
    cloud_temperature_k: float
    in_cloud_vapour_cm: float


def cloudy_fluxes(tau550: float, solar_elevation_deg: float, aod550: float = 0.1, ground_albedo: float = 0.2,
                  cloud_base_km: float = 1.0, radius_um: float = 10.0, lwc: float = 0.3,
                  spec: AtmosphereSpec = AtmosphereSpec(), n_streams: int = 16, channels=None,
                  droplet_absorption: bool = True, saturate: bool = True, data_dir=None) -> CloudyFluxes:
    """Global, direct and diffuse horizontal irradiance spectra at the ground under a water cloud.

    Parameters
    ----------
    tau550 : float
        Cloud optical depth at 550 nm [1], 0 (clear: the same atmosphere without the cloud) to 200.
    solar_elevation_deg : float
        [deg], (10, 90] (plane-parallel beam).
    aod550 : float
        Aerosol optical depth at 550 nm [1].
    ground_albedo : float
        Lambertian ground albedo [1].
    cloud_base_km : float
        Cloud base above the ground [km], 0.25-5.
    radius_um, lwc : float
        Droplet effective radius [um] and liquid water content [g m-3] (thickness, see the module docstring).
    spec : AtmosphereSpec
        The clear atmosphere (profile, water, ozone, aerosol type, extraterrestrial spectrum).
    n_streams : int
        DISORT streams (fluxes: 16 is ample with delta-M).
    channels : int array, optional
        Channel indices (default all 55).
    droplet_absorption, saturate : bool
        Switches for the decomposition of the cloud's spectral effect: droplets with their Mie single-scattering
        albedo (False: conservative droplets), and saturated air in the cloud (False: the profile's vapour).
    """
    if not 0.0 <= tau550 <= 200.0:
        raise ValueError(f"tau550={tau550} outside the valid range [0, 200]")
    if not 10.0 < solar_elevation_deg <= 90.0:
        raise ValueError(f"solar_elevation_deg={solar_elevation_deg} outside (10, 90] deg")
    if not 0.25 <= cloud_base_km <= 5.0:
        raise ValueError(f"cloud_base_km={cloud_base_km} outside [0.25, 5] km")
    if not 0.0 <= ground_albedo <= 1.0:
        raise ValueError(f"ground_albedo={ground_albedo} outside [0, 1]")
    if not 0.05 <= lwc <= 2.0:
        raise ValueError(f"lwc={lwc} outside [0.05, 2] g m-3")
    dd = None if data_dir is None else str(data_dir)
    H = float(cloud_thickness_m(tau550, radius_um, lwc)) / 1000.0                 # [km]
    base, top = float(cloud_base_km), float(cloud_base_km) + H
    levels = np.asarray(DEFAULT_LEVELS_KM if spec.levels_km is None else spec.levels_km, float)
    cloud_levels = np.linspace(base, top, 4) if H > 0 else np.array([base])
    levels = np.unique(np.concatenate([levels[(levels < base - 1e-6) | (levels > top + 1e-6)], cloud_levels]))
    atm = standard_atmosphere(spec.profile, spec.precipitable_water, spec.ozone_du, "DU", levels, dd)
    in_cloud = (atm.levels_km[:-1] >= base - 1e-9) & (atm.levels_km[1:] <= top + 1e-9) & (H > 0)
    h2o = atm.h2o.copy()
    dz_m = atm.thickness_km * 1000.0
    sat = saturation_vapour_density(atm.temperature_k - 273.15) * dz_m * 1e-4 / H2O_MOLAR_MASS * AVOGADRO   # [molecules cm-2]
    if saturate:
        h2o[in_cloud] = sat[in_cloud]
    atm = replace(atm, h2o=h2o)
    _, et = extraterrestrial_spectrum(spec.et_source, dd)
    o3 = ozone_optical_depth(atm, dd)
    aer = opac_mixture(spec.aerosol_type, spec.relative_humidity, dd, angstrom=spec.angstrom)
    frac = aerosol_layer_fractions(atm.levels_km, spec.aerosol_scale_height_km)
    kd = load_kdistributions()
    config = SolverConfig(n_streams, n_streams, intensity_correction=False)
    mu0 = float(np.sin(np.radians(solar_elevation_deg)))
    ch = channel_index(channels)
    et_ch = et.reshape(N_CHANNELS, 40).mean(axis=1)[ch]
    tau_layer = np.where(in_cloud, dz_m / max(H * 1000.0, 1e-9), 0.0) * tau550          # (L,) at 550 nm
    nm = config.n_moments
    ghi = np.zeros(len(ch))
    direct = np.zeros(len(ch))
    for j, c in enumerate(ch):
        for p in channel_subproblems(int(c), atm, et, o3, aer, aod550, frac, kd, nm, spec.co2_ppm, config.skip_tau):
            rel, c_c, g_c = mie_droplet_optics(p.wavelength_nm, radius_um, data_dir=data_dir)
            tc = tau_layer * float(rel)
            sca_r = p.tau_rayleigh
            sca_a = p.tau_aerosol * p.ssa_aerosol
            sca_c = tc * (1.0 - float(c_c) if droplet_absorption else 1.0)
            dtau = p.tau_rayleigh + p.tau_aerosol + p.tau_absorption + tc
            sca = sca_r + sca_a + sca_c
            ssa = np.where(dtau > 0, sca / np.maximum(dtau, 1e-300), 0.0)
            hg = float(g_c) ** np.arange(nm + 1)
            mom = (sca_r[:, None] * p.moments_rayleigh[None, : nm + 1] + sca_a[:, None] * p.moments_aerosol[None, : nm + 1]
                   + sca_c[:, None] * hg[None, :]) / np.maximum(sca, 1e-300)[:, None]
            mom[:, 0] = 1.0
            _, fd, fb = run_disort(_Layers(dtau, ssa, mom), mu0, ground_albedo, np.array([0.0]), np.array([0.0]),
                                   config, repair=False)
            ghi[j] += p.weight * (fd + fb)
            direct[j] += p.weight * fb
    ghi *= et_ch
    direct *= et_ch
    t_cloud = float(np.average(atm.temperature_k[in_cloud], weights=dz_m[in_cloud])) if in_cloud.any() else np.nan
    vap = float((atm.h2o_cm[in_cloud]).sum()) if in_cloud.any() else 0.0
    return CloudyFluxes(channels=ch, wavelength_nm=CHANNEL_CENTERS_NM[ch], ghi=ghi, direct_horizontal=direct,
                        diffuse_horizontal=ghi - direct, extraterrestrial=et_ch, tau550=float(tau550),
                        cloud_base_km=base, cloud_top_km=top, cloud_temperature_k=t_cloud, in_cloud_vapour_cm=vap)


def allsky_global_horizontal(clear: CloudyFluxes, cloudy: CloudyFluxes, solar_elevation_deg: float, options=None,
                             albedo: float = 0.2):
    """The all-sky model's global horizontal spectrum (C,) [W m-2 nm-1] for a cloudy reference case.

    The reference's broadband direct and diffuse horizontal irradiance are the "measured" weather, its
    cloud-free solve the clear sky (so only the cloud parametrisation is compared), the cloud layer's
    temperature the dew point (the model's in-cloud vapour is saturated at the surface dew point, the
    reference's at the layer's temperature). ``options``: :class:`widesky.irradiance.allsky.AllSkyOptions`."""
    options = AllSkyOptions() if options is None else options
    edges = CHANNEL_EDGES_NM[np.r_[clear.channels, clear.channels[-1] + 1]]
    if not np.array_equal(np.diff(clear.channels), np.ones(len(clear.channels) - 1)):
        raise ValueError("allsky_global_horizontal needs contiguous channels")
    w = np.diff(edges)
    s = np.sin(np.radians(solar_elevation_deg))
    dni_c = clear.direct_horizontal / s
    dni = float((cloudy.direct_horizontal @ w) / s)
    dhi = float(cloudy.diffuse_horizontal @ w)
    td = cloudy.cloud_temperature_k - 273.15 if np.isfinite(cloudy.cloud_temperature_k) else np.nan
    f = allsky_factors(edges, dni_c[None], clear.diffuse_horizontal[None], np.array([solar_elevation_deg]),
                       np.array([dni]), np.array([dhi]), temp_dew=np.array([td]), albedo=albedo, options=options)
    return (f.dni_scale[0] * dni_c * s + f.diffuse_scale[0] * clear.diffuse_horizontal + f.overcast_dhi[0]
            + f.circumsolar_dhi[0])
