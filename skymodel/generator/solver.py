"""Reference radiative-transfer solver: plane-parallel discrete ordinates (DISORT via the PyPI package disortpp).

For one sky state and every channel the solver returns the downwelling sky radiance at the ground on a set of
directions, the direct-beam band transmittance along a spherical-shell path, and the direct normal, diffuse and
global horizontal irradiances plus global irradiance on tilted planes.

Method (see docs/atmosphere-and-solver.md):

- each channel is a weighted set of sub-problems (:mod:`widesky.skymodel.generator.optics`); each is one DISORT run
  (Stamnes et al. 1988; disortpp 1.2.1) with a Lambertian ground, ``n_streams`` streams, delta-M scaling and the
  Buras-Emde intensity correction (Buras, Dowling & Emde 2011, JQSRT 112, 2028) fed with the **tabulated** Mie +
  Rayleigh phase function of every layer (``intensity_corr_buras`` with ``num_phase_func_angles > 0``). Without a
  table disortpp falls back to the Nakajima-Tanaka correction built from the Legendre moments, whose 256-term series
  of the aerosol phase function rings (Gibbs) at every scattering angle (small in the channel sums, below 0.05 % of
  the radiance at 29.2 km and 8 deg sun, but not physics; docs/atmosphere-and-solver.md, "Intensity correction");
- radiances and diffuse fluxes are weighted sums of the runs times the channel's band-mean extraterrestrial
  irradiance;
- the direct beam uses the band transmittance sum_runs w exp(-sum_l tau_l s_l / dz_l) with the geometric path
  s_l through each spherical shell (no refraction), not DISORT's plane-parallel beam;
- disortpp's pseudo-spherical mode (``use_spherical_beam``) and ``solve_spectral`` are never used: both give
  wrong radiances in 1.2.1 (tests/generator/test_disortpp_guards.py).

Angles: view zenith [deg] from the zenith (0) to the horizon (90); azimuth [deg] of the viewing direction
relative to the sun's azimuth (0 = looking toward the sun), symmetric in sign.
"""

from __future__ import annotations

import functools
import multiprocessing as mp
import os
import time
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from ..channels import CHANNEL_CENTERS_NM, N_CHANNELS, channel_index
from ..opac import HUMIDITIES
from ..visibility import aod550_from_visibility
from .aerosol import OPAC_TYPES, PHASE_MU, aerosol_layer_fractions, opac_mixture
from .atmosphere import PROFILES, slant_path_factors, standard_atmosphere
from .gases import load_kdistributions
from .optics import channel_subproblems
from .ozone import ozone_optical_depth
from .solar import SOURCES, earth_sun_distance_factor, extraterrestrial_spectrum

_trapezoid = getattr(np, "trapezoid", None) or np.trapz  # numpy < 2 has only trapz

MAX_VIEW_ZENITH_DEG = 89.95
"""Largest view zenith passed to DISORT [deg]; 90 (mu = 0) is mapped to it."""


@dataclass(frozen=True)
class AtmosphereSpec:
    """The fixed part of the clear-sky atmosphere (everything but the sky-state parameters).

    profile : AFGL climate (``'us'``, ``'t'``, ``'ms'``, ``'mw'``, ``'ss'``, ``'sw'``).
    precipitable_water : water vapour column [cm]; None = the profile's (US standard 1.42 cm).
    ozone_du : ozone column [DU]; None = the profile's (US standard 345 DU).
    aerosol_type : OPAC mixture (continental_clean, continental_average, continental_polluted, urban).
    relative_humidity : [%] for the WASO component.
    aerosol_scale_height_km : [km] of the exponential aerosol profile.
    angstrom : [1] if set, AOD(lambda) = AOD(550) (lambda/550)^-angstrom instead of the Mie spectral shape.
    et_source : extraterrestrial spectrum (``'tsis1'``, ``'g173'``, ``'e490'``, ``'kurucz'``).
    co2_ppm : [ppm] for the Rayleigh cross-section (band-model CO2 is 6S's fixed amount).
    levels_km : level altitudes [km] (None = default 31 layers).
    """

    profile: str = "us"
    precipitable_water: float | None = None
    ozone_du: float | None = None
    aerosol_type: str = "continental_average"
    relative_humidity: int = 50
    aerosol_scale_height_km: float = 1.5
    angstrom: float | None = None
    et_source: str = "tsis1"
    co2_ppm: float = 360.0
    levels_km: tuple | None = None

    def __post_init__(self):
        if self.profile not in PROFILES:
            raise ValueError(f"profile={self.profile!r}: valid AFGL profiles are {PROFILES}")
        if self.aerosol_type not in OPAC_TYPES:
            raise ValueError(f"aerosol_type={self.aerosol_type!r}: valid types are {tuple(OPAC_TYPES)}")
        if self.relative_humidity not in HUMIDITIES:
            raise ValueError(f"relative_humidity={self.relative_humidity}: valid values are {HUMIDITIES} %")
        if self.et_source not in SOURCES:
            raise ValueError(f"et_source={self.et_source!r}: valid sources are {SOURCES}")
        if not (0.1 <= self.aerosol_scale_height_km <= 20):
            raise ValueError(f"aerosol_scale_height_km={self.aerosol_scale_height_km} outside [0.1, 20] km")


@dataclass(frozen=True)
class SkyState:
    """One sky state.

    solar_elevation_deg : [deg], (0, 90]; the plane-parallel solver is not valid at or below the horizon.
    visibility_km : [km] ground meteorological range; sets AOD(550) by Koschmieder (skymodel.visibility).
    aod550 : [1] aerosol optical depth at 550 nm (alternative to visibility_km).
    aod500 : [1] aerosol optical depth at 500 nm (alternative; spectral shape from the mixture or angstrom).
    ground_albedo : [1] Lambertian albedo, a scalar or 55 values (one per channel).
    day_of_year : [1-366] scales the extraterrestrial spectrum by the Earth-Sun distance; None = 1 AU.
    """

    solar_elevation_deg: float
    visibility_km: float | None = None
    aod550: float | None = None
    aod500: float | None = None
    ground_albedo: float | tuple = 0.2
    day_of_year: int | None = None

    def __post_init__(self):
        e = float(self.solar_elevation_deg)
        if not (0.0 < e <= 90.0):
            raise ValueError(f"solar_elevation_deg={e} outside the valid range (0, 90] deg")
        given = [x is not None for x in (self.visibility_km, self.aod550, self.aod500)]
        if sum(given) != 1:
            raise ValueError("give exactly one of visibility_km [km], aod550 [1] or aod500 [1]")
        if self.visibility_km is not None and not (self.visibility_km > 0):
            raise ValueError(f"visibility_km={self.visibility_km} must be > 0 km")
        for name in ("aod550", "aod500"):
            v = getattr(self, name)
            if v is not None and not (0 <= v <= 5):
                raise ValueError(f"{name}={v} outside the valid range [0, 5]")
        a = np.asarray(self.ground_albedo, float)
        if a.shape not in ((), (N_CHANNELS,)) or np.any((a < 0) | (a > 1)):
            raise ValueError(f"ground_albedo must be a scalar or {N_CHANNELS} values in [0, 1], got {a}")

    @property
    def solar_zenith_deg(self) -> float:
        return 90.0 - float(self.solar_elevation_deg)

    def albedo(self) -> np.ndarray:
        """Ground albedo per channel [1], shape (55,)."""
        return np.broadcast_to(np.asarray(self.ground_albedo, float), (N_CHANNELS,)).copy()


@dataclass(frozen=True)
class SolverConfig:
    """Numerical settings: n_streams (even, >= 4), n_moments (Legendre moments kept, >= n_streams),
    intensity_correction (single-scattering intensity correction), tabulated_phase (feed the correction the
    tabulated phase function, Buras-Emde; False: the Nakajima-Tanaka correction from the Legendre moments, which
    rings), skip_tau (drop sub-problems whose vertical absorption optical depth exceeds this; they contribute
    < exp(-skip_tau))."""

    n_streams: int = 32
    n_moments: int = 256
    intensity_correction: bool = True
    skip_tau: float = 40.0
    tabulated_phase: bool = True

    def __post_init__(self):
        if self.n_streams < 4 or self.n_streams % 2:
            raise ValueError(f"n_streams={self.n_streams} must be even and >= 4")
        if not (self.n_streams <= self.n_moments <= 512):
            raise ValueError(f"n_moments={self.n_moments} must be in [n_streams, 512]")


@functools.lru_cache(maxsize=8)
def _prepared(spec: AtmosphereSpec, data_dir):
    atm = standard_atmosphere(spec.profile, spec.precipitable_water, spec.ozone_du, "DU",
                              None if spec.levels_km is None else np.array(spec.levels_km), data_dir)
    _, et = extraterrestrial_spectrum(spec.et_source, data_dir)
    o3 = ozone_optical_depth(atm, data_dir)
    aer = opac_mixture(spec.aerosol_type, spec.relative_humidity, data_dir, angstrom=spec.angstrom)
    frac = aerosol_layer_fractions(atm.levels_km, spec.aerosol_scale_height_km)
    return atm, et, o3, aer, frac, load_kdistributions()


def aod550_of(state: SkyState, spec: AtmosphereSpec, data_dir=None) -> float:
    """Aerosol optical depth at 550 nm [1] of a sky state."""
    if state.aod550 is not None:
        return float(state.aod550)
    if state.visibility_km is not None:
        return float(aod550_from_visibility(state.visibility_km, spec.aerosol_scale_height_km))
    aer = _prepared(spec, None if data_dir is None else str(data_dir))[3]
    return float(state.aod500) / float(aer.at(500.0)[0][0])


def channel_problems(state: SkyState, spec: AtmosphereSpec = AtmosphereSpec(), channels=None,
                     config: SolverConfig = SolverConfig(), data_dir=None):
    """Sub-problems per channel: dict channel -> list of SubProblem, plus the channel ET [W m-2 nm-1] (55,)."""
    dd = None if data_dir is None else str(data_dir)
    atm, et, o3, aer, frac, kd = _prepared(spec, dd)
    aod = aod550_of(state, spec, dd)
    fac = 1.0 if state.day_of_year is None else float(earth_sun_distance_factor(state.day_of_year))
    et_ch = et.reshape(N_CHANNELS, 40).mean(axis=1) * fac
    out = {int(c): channel_subproblems(int(c), atm, et, o3, aer, aod, frac, kd, config.n_moments, spec.co2_ppm,
                                       config.skip_tau) for c in channel_index(channels)}
    return out, et_ch, atm


def direct_transmittance(state: SkyState, zenith_deg, spec: AtmosphereSpec = AtmosphereSpec(), channels=None,
                         spherical: bool = True, data_dir=None) -> np.ndarray:
    """Band transmittance of the direct beam along slant paths.

    Parameters
    ----------
    state : SkyState (its aerosol amount is used; its solar elevation is not).
    zenith_deg : array_like (N,)
        Zenith angles of the path at the ground [deg], 0-90.
    spherical : bool
        True: geometric path through spherical shells (Earth radius 6371 km, no refraction);
        False: plane-parallel 1/cos(zenith).

    Returns
    -------
    numpy.ndarray (N, C)
        Channel transmittance [1] (extraterrestrial-weighted band mean).
    """
    probs, _, atm = channel_problems(state, spec, channels, data_dir=data_dir)
    z = np.atleast_1d(np.asarray(zenith_deg, float))
    if spherical:
        f = slant_path_factors(atm.levels_km, z)
    else:
        if np.any(z >= 90):
            raise ValueError("plane-parallel transmittance needs zenith_deg < 90")
        f = np.repeat((1.0 / np.cos(np.radians(z)))[:, None], atm.n_layers, axis=1)
    out = np.zeros((len(z), len(probs)))
    for j, (c, plist) in enumerate(probs.items()):
        for p in plist:
            out[:, j] += p.weight * np.exp(-(f * p.tau_total[None, :]).sum(axis=1))
    return out


def default_integration_grid(solar_zenith_deg: float):
    """Direction grid used for hemispherical integrals: view zeniths (T,) [deg] and relative azimuths (P,) [deg],
    refined around the sun."""
    th = np.concatenate([np.arange(0.0, 90.0, 1.0) + 0.5, [0.0, MAX_VIEW_ZENITH_DEG],
                         solar_zenith_deg + np.array([-3, -2, -1.5, -1, -0.75, -0.5, -0.25, -0.1, 0, 0.1, 0.25,
                                                      0.5, 0.75, 1, 1.5, 2, 3])])
    th = np.unique(np.round(np.clip(th, 0.0, MAX_VIEW_ZENITH_DEG), 6))
    ph = np.unique(np.concatenate([[0, 0.1, 0.25, 0.5, 0.75, 1, 1.5, 2, 2.5, 3, 4, 5, 6, 7, 8, 10, 12.5, 15, 17.5],
                                   np.arange(20.0, 180.1, 5.0)]))
    return th, ph


_SOLVERS: dict = {}


def _disort(num_phi: int):
    """The process's disortpp solver for runs with ``num_phi`` output azimuths. One solver per azimuth count:
    disortpp 1.2.1 keeps a solver's azimuth buffer from its first run, so a reused solver given fewer azimuths
    returns the old count's columns (tests/generator/test_disortpp_guards.py)."""
    solver = _SOLVERS.get(int(num_phi))
    if solver is None:
        import disortpp
        solver = _SOLVERS[int(num_phi)] = disortpp.DisortSolver()
    return solver


def run_disort(problem, mu0, albedo, view_zenith_deg, rel_azimuth_deg, config: SolverConfig, repair=True):
    """One plane-parallel DISORT run for a sub-problem, unit beam flux normal to the beam.

    Parameters
    ----------
    problem : SubProblem; mu0 : cosine of the solar zenith [1]; albedo : [1];
    view_zenith_deg : (T,) increasing view zeniths in [0, 89.95] [deg];
    rel_azimuth_deg : (P,) increasing relative azimuths in [0, 180] [deg].
    repair : re-solve isolated non-finite radiances (:func:`_repair_nonfinite`).

    Returns
    -------
    radiance (T, P) downwelling at the ground [sr-1 per unit normal beam flux]; diffuse_down, direct_down
    horizontal fluxes at the ground [per unit normal beam flux].
    """
    import disortpp

    dtau, ssa, mom = problem.disort_layers()
    nl = len(dtau)
    cfg = disortpp.DisortConfig(nl, config.n_streams)
    cfg.flags.use_lambertian_surface = True
    cfg.flags.use_user_mu = True
    cfg.flags.use_user_tau = True
    cfg.flags.use_spherical_beam = False
    cfg.flags.intensity_corr_buras = bool(config.intensity_correction)
    table = problem.phase_table() if (config.intensity_correction and config.tabulated_phase) else None
    if table is not None:
        cfg.flags.intensity_corr_nakajima = False
        cfg.num_phase_func_angles = len(PHASE_MU)
    cfg.num_user_tau = 1
    cfg.num_user_mu = len(view_zenith_deg)
    cfg.num_phi = len(rel_azimuth_deg)
    cfg.num_phase_func_moments = config.n_moments
    cfg.allocate()
    cfg.delta_tau = dtau.tolist()
    cfg.single_scat_albedo = ssa.tolist()
    cfg.phase_function_moments = mom[:, : config.n_moments + 1].tolist()
    if table is not None:
        cfg.mu_phase_function = PHASE_MU.tolist()
        cfg.phase_function = table.tolist()
    cfg.tau_user = [float(dtau.sum())]
    cfg.mu_user = (-np.cos(np.radians(view_zenith_deg))).tolist()
    cfg.phi_user = np.asarray(rel_azimuth_deg, float).tolist()
    cfg.bc.direct_beam_flux = 1.0
    cfg.bc.direct_beam_mu = float(mu0)
    cfg.bc.direct_beam_phi = 0.0
    cfg.bc.surface_albedo = float(albedo)
    r = _disort(len(rel_azimuth_deg)).solve(cfg)
    rad = np.asarray(r.intensity)[0]
    if repair and table is not None and not np.isfinite(rad).all():
        rad = _repair_nonfinite(rad, problem, mu0, albedo, view_zenith_deg, rel_azimuth_deg, config)
    return rad, float(r.flux_down[-1]), float(r.flux_direct_beam[-1])


NUDGE_DEG = 1e-3
"""Azimuth offset [deg] for re-solving a direction where disortpp returns NaN (:func:`_repair_nonfinite`)."""


def _repair_nonfinite(rad, problem, mu0, albedo, view_zenith_deg, rel_azimuth_deg, config):
    """disortpp 1.2.1's Buras-Emde correction with a tabulated phase function returns NaN at isolated directions
    (seen once in the default build: 300 nm, one sub-problem, view zenith 63.75 deg, relative azimuth 0.125 deg, sun
    at 24.606 deg; the neighbours 0.025 deg away are finite and smooth). Those entries are solved again with the
    azimuth moved by :data:`NUDGE_DEG` (a radiance change below 1e-6 relative there), and only if that is not
    finite either with the Legendre-series (Nakajima-Tanaka) correction; anything still not finite is an error."""
    rad = np.array(rad, float)
    th = np.asarray(view_zenith_deg, float)
    ph = np.asarray(rel_azimuth_deg, float)
    for i, j in np.argwhere(~np.isfinite(rad)):
        a = ph[j] + NUDGE_DEG if ph[j] + NUDGE_DEG <= 180.0 else ph[j] - NUDGE_DEG
        v = run_disort(problem, mu0, albedo, th[i:i + 1], np.array([a]), config, repair=False)[0][0, 0]
        if not np.isfinite(v):
            nt = SolverConfig(config.n_streams, config.n_moments, config.intensity_correction, config.skip_tau,
                              tabulated_phase=False)
            v = run_disort(problem, mu0, albedo, th[i:i + 1], ph[j:j + 1], nt, repair=False)[0][0, 0]
        if not np.isfinite(v):
            raise RuntimeError(f"DISORT returned a non-finite radiance at view zenith {th[i]} deg, relative "
                               f"azimuth {ph[j]} deg (mu0 {mu0}, albedo {albedo}) that re-solving did not repair")
        rad[i, j] = v
    return rad


def _worker_init():
    # one OpenMP thread per worker process: disortpp's own threads would oversubscribe the cores
    os.environ["OMP_NUM_THREADS"] = "1"


def _solve_channel(job):
    channel, problems, mu0, albedo, th, ph, config = job
    rad = np.zeros((len(th), len(ph)))
    dif = dirh = 0.0
    for p in problems:
        r, fd, fb = run_disort(p, mu0, albedo, th, ph, config)
        rad += p.weight * r
        dif += p.weight * fd
        dirh += p.weight * fb
    return channel, rad, dif, dirh, len(problems)


@dataclass
class SkyResult:
    """Solver output for one sky state (channels C, requested directions N).

    Attributes
    ----------
    channels (C,) channel indices; wavelength_nm (C,) channel centres [nm];
    extraterrestrial (C,) band-mean ET [W m-2 nm-1];
    radiance (N, C) sky radiance on the requested directions [W m-2 sr-1 nm-1];
    view_zenith_deg, relative_azimuth_deg (N,) the requested directions [deg];
    grid_zenith_deg (T,), grid_azimuth_deg (P,), grid_radiance (T, P, C) radiance on the integration grid;
    direct_transmittance (C,) spherical-shell slant path [1]; direct_transmittance_pp (C,) plane-parallel [1];
    dni, dhi, ghi (C,) [W m-2 nm-1] (dni from the spherical path; dhi from DISORT's diffuse flux);
    dhi_integrated (C,) [W m-2 nm-1] the grid radiance integrated over the sky (flux closure);
    n_runs (C,) solver runs per channel; state, spec, config: the inputs; seconds: wall time [s].
    """

    channels: np.ndarray
    wavelength_nm: np.ndarray
    extraterrestrial: np.ndarray
    radiance: np.ndarray
    view_zenith_deg: np.ndarray
    relative_azimuth_deg: np.ndarray
    grid_zenith_deg: np.ndarray
    grid_azimuth_deg: np.ndarray
    grid_radiance: np.ndarray
    direct_transmittance: np.ndarray
    direct_transmittance_pp: np.ndarray
    dni: np.ndarray
    dhi: np.ndarray
    ghi: np.ndarray
    dhi_integrated: np.ndarray
    n_runs: np.ndarray
    state: SkyState
    spec: AtmosphereSpec
    config: SolverConfig
    seconds: float = 0.0
    meta: dict = field(default_factory=dict)

    def poa_global(self, surface_tilt, surface_azimuth_rel=0.0):
        """Global irradiance on a tilted plane [W m-2 nm-1], shape (C,).

        Parameters
        ----------
        surface_tilt : float
            Tilt from horizontal [deg], 0-180.
        surface_azimuth_rel : float
            Azimuth of the plane's normal relative to the sun's azimuth [deg] (0 = facing the sun).

        Returns
        -------
        dict with poa_global, poa_direct, poa_sky_diffuse, poa_ground_diffuse (C,) [W m-2 nm-1]
        (ground: isotropic Lambertian reflection of ghi, view factor (1 - cos tilt) / 2).
        """
        b = np.radians(float(surface_tilt))
        pa = np.radians(float(surface_azimuth_rel))
        n = np.array([np.sin(b) * np.cos(pa), np.sin(b) * np.sin(pa), np.cos(b)])
        zs = np.radians(self.state.solar_zenith_deg)
        cos_aoi = max(0.0, n @ np.array([np.sin(zs), 0.0, np.cos(zs)]))
        th = np.radians(self.grid_zenith_deg)
        # full azimuth circle from the symmetric half
        ph = np.radians(np.concatenate([self.grid_azimuth_deg, 360.0 - self.grid_azimuth_deg[::-1][1:]]))
        rad = np.concatenate([self.grid_radiance, self.grid_radiance[:, ::-1][:, 1:]], axis=1)
        d = np.stack([np.sin(th)[:, None] * np.cos(ph)[None, :], np.sin(th)[:, None] * np.sin(ph)[None, :],
                      np.cos(th)[:, None] * np.ones_like(ph)[None, :]], axis=-1)
        cosi = np.maximum(d @ n, 0.0) * np.sin(th)[:, None]
        sky = _trapz2(rad * cosi[:, :, None], th, ph)
        ground = self.state.albedo()[self.channels] * self.ghi * (1.0 - np.cos(b)) / 2.0
        direct = self.dni * cos_aoi
        return {"poa_global": direct + sky + ground, "poa_direct": direct, "poa_sky_diffuse": sky,
                "poa_ground_diffuse": ground}


def _trapz2(f, th, ph):
    """Integral of f(theta, phi, ...) over theta (rad) then phi (rad) by the trapezoid rule."""
    g = _trapezoid(f, ph, axis=1)
    return _trapezoid(g, th, axis=0)


def solve_sky(state: SkyState, spec: AtmosphereSpec = AtmosphereSpec(), view_zenith_deg=None,
              relative_azimuth_deg=None, channels=None, config: SolverConfig = SolverConfig(),
              processes: int | None = None, progress: bool = False, data_dir=None) -> SkyResult:
    """Solve one sky state for the requested channels.

    Parameters
    ----------
    state : SkyState
    spec : AtmosphereSpec
    view_zenith_deg, relative_azimuth_deg : array_like (N,), optional
        Viewing directions [deg]: zenith 0-90 (90 is evaluated at 89.95), azimuth relative to the sun, any sign
        (0 = toward the sun). Default: none (the integration grid is always solved).
        Cost grows with (unique zeniths) x (unique |azimuths|): prefer product grids.
    channels : int array, optional
        Channel indices 0..54 (default all 55).
    config : SolverConfig
    processes : int, optional
        Worker processes over channels (default: all cores, at most 2 x channels); 1 = in this process.
    progress : bool
        Show a tqdm progress bar over channels.

    Returns
    -------
    SkyResult
    """
    t0 = time.perf_counter()
    ch = channel_index(channels)
    probs, et_ch, atm = channel_problems(state, spec, ch, config, data_dir)
    zs = state.solar_zenith_deg
    mu0 = np.cos(np.radians(zs))
    th_g, ph_g = default_integration_grid(zs)
    if view_zenith_deg is None:
        vz = np.zeros(0)
        va = np.zeros(0)
    else:
        vz = np.atleast_1d(np.asarray(view_zenith_deg, float))
        va = np.atleast_1d(np.asarray(relative_azimuth_deg, float))
        if vz.shape != va.shape:
            raise ValueError(f"view_zenith_deg {vz.shape} and relative_azimuth_deg {va.shape} differ in shape")
        if np.any((vz < 0) | (vz > 90)):
            raise ValueError(f"view_zenith_deg outside [0, 90] deg: {vz[(vz < 0) | (vz > 90)][:3]}")
    va_f = np.abs(((va + 180.0) % 360.0) - 180.0)
    vz_c = np.minimum(vz, MAX_VIEW_ZENITH_DEG)
    th = np.unique(np.concatenate([th_g, np.round(vz_c, 9)]))
    ph = np.unique(np.concatenate([ph_g, np.round(va_f, 9)]))
    alb = state.albedo()
    jobs = [(int(c), probs[int(c)], mu0, alb[int(c)], th, ph, config) for c in ch]
    order = sorted(range(len(jobs)), key=lambda i: -len(jobs[i][1]))
    nproc = min(os.cpu_count() or 1, len(jobs)) if processes is None else max(1, int(processes))
    results = {}
    if nproc > 1 and len(jobs) > 1:
        with mp.get_context("spawn").Pool(nproc, initializer=_worker_init) as pool:
            it = pool.imap_unordered(_solve_channel, [jobs[i] for i in order])
            for r in _bar(it, len(jobs), progress):
                results[r[0]] = r
    else:
        for i in _bar(order, len(jobs), progress):
            r = _solve_channel(jobs[i])
            results[r[0]] = r
    grid = np.stack([results[int(c)][1] for c in ch], axis=-1) * et_ch[ch][None, None, :]
    dif = np.array([results[int(c)][2] for c in ch]) * et_ch[ch]
    nruns = np.array([results[int(c)][4] for c in ch])
    it_th = np.searchsorted(th, np.round(vz_c, 9))
    it_ph = np.searchsorted(ph, np.round(va_f, 9))
    rad = grid[it_th, it_ph, :] if len(vz) else np.zeros((0, len(ch)))
    sel_th = np.isin(th, th_g)
    sel_ph = np.isin(ph, ph_g)
    th_i, ph_i, grid_i = th[sel_th], ph[sel_ph], grid[sel_th][:, sel_ph]
    thr, phr = np.radians(th_i), np.radians(ph_i)
    integ = 2.0 * _trapz2(grid_i * (np.cos(thr) * np.sin(thr))[:, None, None], thr, phr)
    # add the sliver between 89.95 deg and the horizon (radiance held constant)
    integ += 2.0 * np.pi * grid_i[-1].mean(axis=0) * 0.5 * np.cos(np.radians(MAX_VIEW_ZENITH_DEG)) ** 2
    tdir = np.zeros(len(ch))
    tdir_pp = np.zeros(len(ch))
    f_sph = slant_path_factors(atm.levels_km, [zs])[0]
    for j, c in enumerate(ch):
        for p in probs[int(c)]:
            tdir[j] += p.weight * np.exp(-(p.tau_total * f_sph).sum())
            tdir_pp[j] += p.weight * np.exp(-p.tau_total.sum() / mu0)
    dni = et_ch[ch] * tdir
    return SkyResult(channels=ch, wavelength_nm=CHANNEL_CENTERS_NM[ch], extraterrestrial=et_ch[ch], radiance=rad,
                     view_zenith_deg=vz, relative_azimuth_deg=va, grid_zenith_deg=th, grid_azimuth_deg=ph,
                     grid_radiance=grid, direct_transmittance=tdir, direct_transmittance_pp=tdir_pp, dni=dni,
                     dhi=dif, ghi=dni * mu0 + dif, dhi_integrated=integ, n_runs=nruns, state=state, spec=spec,
                     config=config, seconds=time.perf_counter() - t0,
                     meta={"aod550": aod550_of(state, spec, data_dir), "processes": nproc})


def _bar(it, total, enabled):
    if not enabled:
        return it
    return tqdm(it, total=total, desc="channels", leave=False)


@dataclass(frozen=True)
class SkyTask:
    """A picklable unit of work for a process pool (or Dask): one sky state, its directions and channels."""

    state: SkyState
    spec: AtmosphereSpec = AtmosphereSpec()
    view_zenith_deg: tuple = ()
    relative_azimuth_deg: tuple = ()
    channels: tuple | None = None
    config: SolverConfig = SolverConfig()
    data_dir: str | None = None


def run_sky_task(task: SkyTask) -> SkyResult:
    """Run a :class:`SkyTask` in this process (processes=1), for use as the function of a process pool map."""
    vz = np.asarray(task.view_zenith_deg, float) if len(task.view_zenith_deg) else None
    va = np.asarray(task.relative_azimuth_deg, float) if len(task.relative_azimuth_deg) else None
    return solve_sky(task.state, task.spec, vz, va, None if task.channels is None else list(task.channels),
                     task.config, processes=1, progress=False, data_dir=task.data_dir)
