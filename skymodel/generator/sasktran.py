"""Deterministic spherical vector solver backend on SASKTRAN2 (PyPI ``sasktran2``, optional, ``[build]`` extra).

Same atmosphere as the DISORT chain and the Monte Carlo solver: the sub-problems of
:func:`widesky.skymodel.generator.solver.channel_problems` (spectral groups x H2O terms x mixed-gas terms: Rayleigh
optical depths, ozone, k-distribution gas absorption, OPAC aerosol, Lambertian ground), turned into the
*components* of :func:`widesky.skymodel.generator.montecarlo.channel_components` (per-layer extinction, Rayleigh and
aerosol scattering coefficients [km-1], depolarisation ratio, the aerosol's full scattering matrix). Every component
of a request is one "wavelength" of one SASKTRAN2 calculation (one engine, one atmosphere: the engine and its
geometry are reused across all sub-problems of the channels asked for).

Method (docs/atmosphere-and-solver.md, "SASKTRAN2 backend"):

- geometry: spherical shells (Earth radius 6371 km, no refraction), observer at the ground looking up
  (``SolarAnglesObserverLocation``), the sun given by its zenith angle at the observer (above 90 deg: twilight);
- layers: the generator's homogeneous layers, each split into sub-layers of at most ``fine_step_km`` below
  ``fine_top_km`` and ``upper_step_km`` above; the optical properties are held constant inside each generator layer
  (``InterpolationMethod.LowerInterpolation``: the value of a level holds up to the next level), so the optical
  depths are exactly those of the DISORT chain and of the Monte Carlo shells. The split matters: SASKTRAN2 interpolates
  the source function linearly between levels along the line of sight, and a 10 km single layer of optical depth 0.5
  overestimates the singly scattered radiance by 62 % at mu0 = 0.2 (measured); linear interpolation of the
  properties between levels changes the layer optical depths (the 1-10 % errors of the feasibility test);
- scattering: Greek coefficients (a1, a2, a3, b1) per layer, mixed by scattering optical depth. Rayleigh with
  depolarisation rho (Hansen & Travis 1974): Delta = (1 - rho) / (1 + rho / 2), a1 = (1, 0, Delta / 2),
  a2_2 = 3 Delta, b1_2 = +sqrt(6) Delta / 2 (SASKTRAN2's own sign, read back from its Rayleigh constituent in the
  tests). Aerosol: the OPAC mixture's Mie matrix (P11, P12, P33, P34 of :mod:`.montecarlo_mie`, P22 = P11,
  P44 = P33 for spheres) projected with ``sasktran2.legendre.compute_greek_coefficients``; that projection returns
  b1_2 = -sqrt(6)/2 for the Rayleigh matrix in widesky's convention (P12 < 0: polarised perpendicular to the
  scattering plane), so b1 is negated before use (test: the projected Rayleigh matrix equals the analytic Rayleigh
  coefficients in SASKTRAN2's sign);
- multiple scattering: SASKTRAN2's discrete ordinates (``n_streams``, delta-M, pseudo-spherical with ``num_sza``
  solar zeniths along the line of sight) integrated along the spherical line of sight;
- single scattering (``exact_single_scatter``, the default): not SASKTRAN2's (a truncated Legendre series, which
  rings in the aureole) but widesky's own deterministic quadrature along the view ray through the shells with the
  tabulated Mie matrix (the Monte Carlo kernel run with ``max_order = 1``: its first order is a quadrature, no random
  numbers, standard error 0): I = I_ms(SASKTRAN2, single-scatter source off) + I_ss(widesky). The two parts add
  exactly in SASKTRAN2 (total = single-scatter-only + multiple-scatter-only to 1e-15, checked);
- Stokes frame and signs: the Monte Carlo solver's (:mod:`.montecarlo`): Q > 0 polarised in the vertical plane
  through the view direction, azimuth 0 = looking toward the sun; SASKTRAN2's Q and U are converted
  (``Q_SIGN``, ``U_SIGN``, checked against the Monte Carlo in the tests). Exactly vertical views are moved to
  ``MIN_VIEW_ZENITH_DEG`` (SASKTRAN2's frame at the zenith ignores the azimuth).

``OPENBLAS_NUM_THREADS=1`` is set before SASKTRAN2 is imported (its LAPACK calls would otherwise start a thread per
core in every worker) and SASKTRAN2's own threads are set by ``threads`` (default 1: parallelism is over sky states).
Tested with :data:`SASKTRAN2_VERSION`.
"""

from __future__ import annotations

import functools
import os
import time
from dataclasses import dataclass, field

import numpy as np

from .atmosphere import EARTH_RADIUS_KM

SASKTRAN2_VERSION = "2026.10.1"
"""The SASKTRAN2 version this backend is validated with (pinned in the ``[build]`` extra)."""

MIN_VIEW_ZENITH_DEG = 1e-3
"""Smallest view zenith passed to SASKTRAN2 [deg]; an exactly vertical view takes its Stokes frame from the sun's
plane whatever its azimuth (DoLP frame off by up to 0.2 in the feasibility test)."""

Q_SIGN = 1.0
"""SASKTRAN2's Q for an up-looking observer times this = widesky's Q (Q > 0 in the view's vertical plane)."""
U_SIGN = -1.0
"""SASKTRAN2's U times this = widesky's U (the Monte Carlo's sign, :mod:`.montecarlo`)."""


def _sasktran2():
    # sasktran2 bundles its own OpenBLAS (sasktran2.libs), which reads this when it is first loaded; numpy's
    # OpenBLAS is already loaded: set the variable before numpy in a build process (benchmarks/bench_sasktran.py),
    # otherwise its idle threads spin and inflate the CPU time on a loaded machine (measured 4-5x at twilight)
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    import sasktran2

    return sasktran2


def available() -> bool:
    """True when the optional package ``sasktran2`` can be imported."""
    try:
        _sasktran2()
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class SasktranConfig:
    """Numerical settings of the SASKTRAN2 backend.

    n_streams : discrete-ordinates streams (even, >= 4); 16 meets the benchmark tolerances.
    polarised : solve I, Q, U (3 Stokes components) or I only (scalar, about 7x cheaper).
    num_sza : solar zeniths of the pseudo-spherical multiple-scattering source along the line of sight; None = by
        solar elevation: 1 at >= 15 deg, 5 at 0-15 deg, 33 below the horizon.
    fine_step_km : [km] largest sub-layer below ``fine_top_km``; upper_step_km : [km] largest sub-layer above.
    fine_top_km : [km].
    delta_m : delta-M scaling of the multiple-scattering problem.
    exact_single_scatter : replace SASKTRAN2's single scattering with widesky's tabulated-matrix quadrature.
    quadrature_step_km : [km] longest sub-interval of that quadrature.
    threads : SASKTRAN2 threads (over components).
    """

    n_streams: int = 16
    polarised: bool = True
    num_sza: int | None = None
    fine_step_km: float = 0.25
    fine_top_km: float = 20.0
    upper_step_km: float = 2.0
    delta_m: bool = True
    exact_single_scatter: bool = True
    quadrature_step_km: float = 0.25
    threads: int = 1

    def __post_init__(self):
        if self.n_streams < 4 or self.n_streams % 2:
            raise ValueError(f"n_streams={self.n_streams} must be even and >= 4")
        if self.num_sza is not None and self.num_sza < 1:
            raise ValueError(f"num_sza={self.num_sza} must be >= 1")
        for name in ("fine_step_km", "upper_step_km"):
            if not (getattr(self, name) > 0):
                raise ValueError(f"{name}={getattr(self, name)} must be > 0 km")

    def sza_count(self, solar_elevation_deg: float) -> int:
        """Pseudo-spherical solar zeniths for a solar elevation [deg]."""
        if self.num_sza is not None:
            return int(self.num_sza)
        e = float(solar_elevation_deg)
        return 1 if e >= 15.0 else (5 if e >= 0.0 else 33)


def fine_levels(levels_km, config: SasktranConfig = SasktranConfig()):
    """Sub-divide homogeneous layers: returns the fine level altitudes (F+1,) [km] and, for each fine level, the index
    of the generator layer whose properties it carries (F+1,) (the top level repeats the top layer)."""
    lv = np.asarray(levels_km, float)
    out, parent = [], []
    for i in range(len(lv) - 1):
        step = config.fine_step_km if lv[i] < config.fine_top_km - 1e-9 else config.upper_step_km
        n = max(1, int(np.ceil((lv[i + 1] - lv[i]) / step - 1e-9)))
        z = np.linspace(lv[i], lv[i + 1], n + 1)[:-1]
        out.append(z)
        parent.append(np.full(n, i))
    out.append([lv[-1]])
    parent.append([len(lv) - 2])
    return np.concatenate(out), np.concatenate(parent).astype(int)


def rayleigh_greek(depolarisation: float, n_moments: int) -> np.ndarray:
    """Greek coefficients (n_moments, 4) = (a1, a2, a3, b1) per moment [1] of Rayleigh scattering with
    depolarisation ratio ``depolarisation`` [1], in SASKTRAN2's sign convention (b1_2 > 0)."""
    rho = float(depolarisation)
    d = (1.0 - rho) / (1.0 + rho / 2.0)
    g = np.zeros((n_moments, 4))
    g[0, 0] = 1.0
    g[2, 0] = d / 2.0
    g[2, 1] = 3.0 * d
    g[2, 3] = np.sqrt(6.0) / 2.0 * d
    return g


def matrix_greek(matrix, n_moments: int) -> np.ndarray:
    """Greek coefficients (n_moments, 4) = (a1, a2, a3, b1) [1] of a scattering matrix of spheres tabulated on
    :func:`widesky.skymodel.generator.montecarlo_mie.matrix_mu_grid` as (P11, P12, P33, P34) (M, 4) in widesky's
    convention (P12 < 0: perpendicular polarisation), normalised to a1_0 = 1, b1 in SASKTRAN2's sign."""
    from sasktran2.legendre import compute_greek_coefficients

    from .montecarlo_mie import matrix_mu_grid

    m = np.asarray(matrix, float)
    mu = matrix_mu_grid()
    ang = np.degrees(np.arccos(np.clip(mu, -1, 1)))[::-1]  # increasing 0..180
    p = [np.atleast_2d(m[::-1, j]) for j in range(4)]
    a1, a2, a3, _a4, b1, _b2 = compute_greek_coefficients(p[0], p[1], p[0], p[2], p[3], p[2], ang,
                                                          max(int(n_moments), 2))
    g = np.stack([a1[0], a2[0], a3[0], -b1[0]], axis=1)[:n_moments]
    return g / g[0, 0]


@functools.lru_cache(maxsize=64)
def _matrix_greek_cached(key, n_moments):
    return matrix_greek(np.frombuffer(key[0]).reshape(key[1]), n_moments)


@dataclass
class SasktranStokes:
    """Output of :func:`trace_stokes` (N directions, C outputs): stokes (N, C, 3) (I, Q, U) per unit solar irradiance
    normal to the beam [sr-1]; single (N, C, 3) widesky's exact single scattering (zero without
    ``exact_single_scatter``); multiple (N, C, 3) SASKTRAN2's part (everything without ``exact_single_scatter``);
    seconds [s] wall, cpu_seconds [s] process CPU; meta: levels, components, num_sza."""

    stokes: np.ndarray
    single: np.ndarray
    multiple: np.ndarray
    seconds: float
    cpu_seconds: float
    meta: dict = field(default_factory=dict)

    def degree_of_polarisation(self) -> np.ndarray:
        """sqrt(Q^2 + U^2) / I [1], shape (N, C)."""
        s = self.stokes
        return np.hypot(s[..., 1], s[..., 2]) / s[..., 0]


def _greek_layers(comps, n_moments, polarised):
    """Per layer and component Greek coefficients (L, K, n, 4) (or (L, K, n, 1) scalar) and SSA (L, K)."""
    ray = np.asarray(comps.rayleigh, float)
    aer = np.asarray(comps.aerosol, float)
    ext = np.asarray(comps.extinction, float)
    sca = ray + aer
    ssa = np.where(ext > 0, sca / np.maximum(ext, 1e-300), 0.0)
    mats = np.asarray(comps.aerosol_matrices, float)
    g_a = []
    for t in range(mats.shape[0]):
        m = np.ascontiguousarray(mats[t])
        g_a.append(_matrix_greek_cached((m.tobytes(), m.shape), n_moments))
    g_a = np.stack(g_a)  # (T, n, 4)
    g_r = np.stack([rayleigh_greek(r, n_moments) for r in comps.depolarisation])  # (K, n, 4)
    g_ak = g_a[np.asarray(comps.aerosol_table, int)]  # (K, n, 4)
    w = np.where(sca > 0, 1.0 / np.maximum(sca, 1e-300), 0.0)
    g = (ray * w)[:, :, None, None] * g_r[None] + (aer * w)[:, :, None, None] * g_ak[None]
    g[:, :, 0, 0] = 1.0
    if not polarised:
        g = g[..., :1]
    return g, np.clip(ssa, 0.0, 1.0)


def trace_stokes(components, solar_zenith_deg: float, view_zenith_deg, relative_azimuth_deg,
                 config: SasktranConfig = SasktranConfig(), downward: bool = False,
                 plane_parallel: bool = False) -> SasktranStokes:
    """I, Q, U seen by an observer at the ground looking up, per unit solar irradiance normal to the beam [sr-1].

    Parameters
    ----------
    components : :class:`widesky.skymodel.generator.montecarlo.Components` (the Monte Carlo solver's atmosphere:
        K spectral components, C = max(channel) + 1 outputs, each output the weighted sum of its components).
    solar_zenith_deg : [deg] at the observer, 0 to 100 (above 90: sun below the horizon).
    view_zenith_deg, relative_azimuth_deg : (N,) [deg]; view zenith 0-90 from the zenith, azimuth relative to the
        sun's (0 = looking toward the sun).
    config : SasktranConfig.
    downward, plane_parallel : validation only: an observer above the top of the atmosphere looking down (view
        zenith measured from the nadir) in a plane-parallel atmosphere (SASKTRAN2 solves only upwelling radiance
        there), with SASKTRAN2's own single scattering (``exact_single_scatter`` must be False).

    Returns
    -------
    SasktranStokes (stokes, single, multiple: (N, C, 3) [sr-1]; I only in column 0 when not polarised).
    """
    sk = _sasktran2()
    from .montecarlo import MonteCarloConfig, trace

    sza = float(solar_zenith_deg)
    if not (0.0 <= sza <= 100.0):
        raise ValueError(f"solar_zenith_deg={sza} outside [0, 100] deg")
    vz = np.atleast_1d(np.asarray(view_zenith_deg, float))
    va = np.broadcast_to(np.atleast_1d(np.asarray(relative_azimuth_deg, float)), vz.shape)
    if np.any((vz < 0) | (vz > 90)):
        raise ValueError(f"view_zenith_deg must be in [0, 90] deg, got {vz.min()}..{vz.max()}")
    if downward != plane_parallel:
        raise ValueError("downward and plane_parallel go together (SASKTRAN2 solves only upwelling radiance in "
                         "plane-parallel mode; the sky backend is spherical and looks up)")
    if downward and config.exact_single_scatter:
        raise ValueError("downward=True needs config.exact_single_scatter=False")
    t0, c0 = time.perf_counter(), time.process_time()
    cp = components
    L, K = cp.extinction.shape
    C = int(cp.channel.max()) + 1
    nst = 3 if config.polarised else 1
    nmom = config.n_streams + 1 if config.delta_m else config.n_streams
    lv_f, parent = fine_levels(cp.levels_km, config)
    g, ssa = _greek_layers(cp, nmom, config.polarised)
    cfg = sk.Config()
    cfg.num_stokes = nst
    cfg.num_streams = int(config.n_streams)
    cfg.num_singlescatter_moments = nmom
    cfg.num_threads = int(config.threads)
    cfg.delta_m_scaling = bool(config.delta_m)
    cfg.num_sza = config.sza_count(90.0 - sza)
    cfg.multiple_scatter_source = sk.MultipleScatterSource.DiscreteOrdinates
    cfg.single_scatter_source = (sk.SingleScatterSource.NoSource if config.exact_single_scatter
                                 else sk.SingleScatterSource.Exact)
    mu0 = float(np.cos(np.radians(sza)))
    geo = sk.Geometry1D(mu0, 0.0, EARTH_RADIUS_KM * 1e3, lv_f * 1e3, sk.InterpolationMethod.LowerInterpolation,
                        sk.GeometryType.PlaneParallel if plane_parallel else sk.GeometryType.Spherical)
    vg = sk.ViewingGeometry()
    vzc = np.maximum(vz, MIN_VIEW_ZENITH_DEG)
    for z, a in zip(vzc, va):
        if downward:
            vg.add_ray(sk.GroundViewingSolar(mu0, float(np.radians(a)), float(np.cos(np.radians(z))),
                                             float(lv_f[-1] * 1e3 + 1e5)))
        else:
            vg.add_ray(sk.SolarAnglesObserverLocation(mu0, float(np.radians(a)), float(np.cos(np.radians(z))), 0.0))
    atmo = sk.Atmosphere(geo, cfg, numwavel=K, calculate_derivatives=False)
    atmo.storage.total_extinction[:] = cp.extinction[parent] * 1e-3  # km-1 -> m-1
    atmo.storage.ssa[:] = ssa[parent]
    lc = atmo.storage.leg_coeff
    lc[:] = 0.0
    gp = g[parent]  # (F+1, K, n, nst')
    lc[:] = np.transpose(gp, (2, 3, 0, 1)).reshape(lc.shape)
    atmo.surface.albedo[:] = np.asarray(cp.albedo, float)
    eng = sk.Engine(cfg, geo, vg)
    rad = np.asarray(eng.calculate_radiance(atmo)["radiance"].values)  # (K, N, nst)
    per = np.zeros((len(vz), C, 3))
    w = np.asarray(cp.weight, float)
    for k in range(K):
        per[:, int(cp.channel[k]), :nst] += w[k] * rad[k]
    per[:, :, 1] *= Q_SIGN
    per[:, :, 2] *= U_SIGN
    single = np.zeros_like(per)
    if config.exact_single_scatter:
        r1 = trace(cp, sza, vz, va, MonteCarloConfig(samples=K, seed=1, polarised=config.polarised, max_order=1,
                                                     quadrature_step_km=config.quadrature_step_km))
        single[:, :, :nst] = r1.stokes[:, :, :nst]
    stokes = single + per
    return SasktranStokes(stokes=stokes, single=single, multiple=per, seconds=time.perf_counter() - t0,
                          cpu_seconds=time.process_time() - c0,
                          meta={"levels": len(lv_f), "components": K, "num_sza": cfg.num_sza,
                                "n_streams": config.n_streams, "nstokes": nst})


@dataclass
class SasktranSky:
    """SASKTRAN2 sky of one sky state (N directions, C channels): channels (C,); wavelength_nm (C,) [nm];
    extraterrestrial (C,) band-mean ET [W m-2 nm-1]; stokes (N, C, 3) (I, Q, U) [W m-2 sr-1 nm-1];
    view_zenith_deg, relative_azimuth_deg (N,) [deg]; solar_elevation_deg [deg]; components (runs) per request;
    seconds [s] wall; cpu_seconds [s]."""

    channels: np.ndarray
    wavelength_nm: np.ndarray
    extraterrestrial: np.ndarray
    stokes: np.ndarray
    view_zenith_deg: np.ndarray
    relative_azimuth_deg: np.ndarray
    solar_elevation_deg: float
    components: int
    seconds: float
    cpu_seconds: float

    @property
    def radiance(self) -> np.ndarray:
        """Sky radiance I [W m-2 sr-1 nm-1], shape (N, C)."""
        return self.stokes[..., 0]

    def degree_of_polarisation(self) -> np.ndarray:
        """Degree of linear polarisation [1], shape (N, C)."""
        return np.hypot(self.stokes[..., 1], self.stokes[..., 2]) / self.stokes[..., 0]


def solve_sky_sasktran(state, spec=None, view_zenith_deg=(0.0,), relative_azimuth_deg=(0.0,), channels=None,
                       config: SasktranConfig = SasktranConfig(), solar_elevation_deg: float | None = None,
                       data_dir=None) -> SasktranSky:
    """SASKTRAN2 sky radiance and polarisation for a sky state of the DISORT chain (its sub-problems, all channels
    asked for in one SASKTRAN2 call).

    Parameters
    ----------
    state : :class:`widesky.skymodel.generator.solver.SkyState` (aerosol amount, albedo, day of year; its solar
        elevation unless ``solar_elevation_deg`` is given).
    spec : AtmosphereSpec (default: the default atmosphere).
    view_zenith_deg, relative_azimuth_deg : (N,) [deg].
    channels : channel indices 0..54 (default all).
    solar_elevation_deg : [deg] in [-10, 90]: overrides the state's (the sun may be below the horizon).
    """
    from ..channels import CHANNEL_CENTERS_NM
    from .montecarlo import MIN_SOLAR_ELEVATION_DEG, channel_components
    from .solver import AtmosphereSpec, channel_problems

    spec = AtmosphereSpec() if spec is None else spec
    el = float(state.solar_elevation_deg if solar_elevation_deg is None else solar_elevation_deg)
    if not (MIN_SOLAR_ELEVATION_DEG <= el <= 90.0):
        raise ValueError(f"solar_elevation_deg={el} outside [{MIN_SOLAR_ELEVATION_DEG}, 90] deg")
    probs, et_ch, atm = channel_problems(state, spec, channels, data_dir=data_dir)
    ch = np.array(list(probs), int)
    comps = channel_components(probs, atm, state.albedo(), spec.aerosol_type, spec.relative_humidity, spec.co2_ppm,
                               data_dir)
    vz = np.atleast_1d(np.asarray(view_zenith_deg, float))
    va = np.broadcast_to(np.atleast_1d(np.asarray(relative_azimuth_deg, float)), vz.shape).copy()
    r = trace_stokes(comps, 90.0 - el, vz, va, config)
    return SasktranSky(channels=ch, wavelength_nm=CHANNEL_CENTERS_NM[ch], extraterrestrial=et_ch[ch],
                       stokes=r.stokes * et_ch[ch][None, :, None], view_zenith_deg=vz, relative_azimuth_deg=va,
                       solar_elevation_deg=el, components=comps.n_components, seconds=r.seconds,
                       cpu_seconds=r.cpu_seconds)
