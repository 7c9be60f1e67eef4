"""Monte Carlo reference solver: polarised backward path tracing in spherical shells (kernel: skymodel._montecarlo).

Same atmosphere as the DISORT chain (:mod:`widesky.skymodel.generator.solver`): the layers, Rayleigh optical depths,
ozone, k-distribution gas terms and OPAC aerosol of :func:`widesky.skymodel.generator.solver.channel_problems`, each
sub-problem (spectral group x water term x mixed-gas term) one spectral *component* of the tracer. Differences
from DISORT, on purpose: the layers are homogeneous spherical shells (Earth radius 6371 km, no refraction) or, for
validation, plane-parallel slabs; light is a Stokes vector (I, Q, U, V); Rayleigh scattering uses the matrix with
depolarisation (Hansen & Travis 1974 eq. 2.15, Delta from :func:`widesky.core.rayleigh.depolarization_ratio`)
and aerosol the exact Mie matrix (:mod:`widesky.skymodel.generator.montecarlo_mie`, no delta-M truncation); the sun may be
below the horizon (twilight).

Method (kernel comments give the details):

- paths start at the observer and run backward along the view direction; free paths are sampled with the total
  extinction of one *hero* component per sample (sample i uses component i mod K); a ray that would escape to space
  is forced to collide (weight 1 - exp(-tau)); a ray that reaches the ground reflects (Lambertian, depolarising);
- at every scattering and ground vertex the sun is connected by next-event estimation (its slant transmittance
  through the shells, zero when the planet is in the way);
- all K components of a batch (the sub-problems of one or several channels) share every path: each gets the
  one-sample multiple-importance weight f_k / (1/K sum_j p_j) (balance heuristic over the path densities), so the
  estimate is unbiased for every component and stays bounded in the saturated gas terms;
- Stokes vectors are carried as the 4x4 product of rotated scattering matrices from the observer; the observer's
  frame is the local meridian plane: Q > 0 is polarisation in the vertical plane through the view direction,
  U > 0 at +45 deg from it toward increasing azimuth (the convention of Coulson, Dave & Sekera 1960 and Natraj et
  al. 2009 up to the sign of U, checked in tests/generator/test_montecarlo_validation.py); V > 0 is circular
  polarisation whose electric vector turns counterclockwise as seen by the observer looking at the sky (toward the
  source), i.e. V = i (E x E*) . k for Bohren & Huffman's fields (time factor exp(-i omega t)): checked against an
  independent Jones-calculus quadrature of second-order scattering in tests/generator/test_montecarlo_circular.py;
- Russian roulette below a path weight of 0.05 after the second order; ``max_order`` caps the scattering order;
- variance reduction (``first_order="quadrature"``, the default; unbiased, checked against the original estimator
  and a closed form in tests/generator/test_montecarlo_estimators.py): the singly scattered light of a view ray
  that escapes to space is integrated deterministically along the ray through the shells (sub-intervals of at most
  ``quadrature_step_km``, split at the edge of the Earth's shadow, the exponential of the optical depths to the
  observer and to the sun integrated exactly for their linear interpolation), so paths carry only orders >= 2;
  their first vertex is drawn from a mixture of the components' forced free paths (3/4) and their
  single-scattering integrands along the ray (1/4: the sunlit part at twilight); every later free path along a ray
  that crosses the Earth's shadow (widened by 6 km) is drawn half from the forced free path and half from it
  conditioned on the part outside the shadow. The densities of the mixtures enter the weights (hero balance
  heuristic over every component's mixture density).

Random streams (``streams``), reproducible and independent of the number of threads in both modes:
``"independent"`` (the default): each view direction has its own stream (seed, direction index), so the errors of
two directions are independent; ``"correlated"`` (common random numbers): path i of every direction starts from
the same random numbers (one stream per path and scattering order, the same for all directions) and every sampled
direction takes its azimuth in a frame that moves continuously with the view direction (around the view: the frame
parallel-transported from the zenith, :func:`sampling_frames`; later: the current polarisation reference, and
around the ground normal a frame that is continuous near the observer), so the estimate is a piecewise-continuous
function of the view direction: the same error per direction, but an error field that is smooth across directions
(the sky has no direction-to-direction speckle, at the price that averages over directions, e.g. the hemispherical
integral, no longer average the noise down; docs/atmosphere-and-solver.md, "Correlated streams"). Angles as in :mod:`widesky.skymodel.generator.solver`: view zenith [deg] 0-90, azimuth [deg]
relative to the sun's (0 = toward the sun).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from .. import _montecarlo
from ..channels import CHANNEL_CENTERS_NM
from ..opac import HUMIDITIES
from .aerosol import OPAC_TYPES
from .atmosphere import EARTH_RADIUS_KM
from .montecarlo_mie import matrix_mu_grid, mixture_matrix
from .solver import AtmosphereSpec, channel_problems
from widesky.core.rayleigh import depolarization_ratio

MIN_SOLAR_ELEVATION_DEG = -10.0
FIRST_ORDER_METHODS = ("quadrature", "sampled")
STREAM_MODES = ("independent", "correlated")


@dataclass(frozen=True)
class MonteCarloConfig:
    """Numerical settings of the Monte Carlo solver.

    samples : paths per view direction (rounded up to a multiple of the number of components of a batch).
    seed : base seed (uint64); results are a deterministic function of it.
    polarised : trace Stokes vectors (True) or scalar radiance with P11 only (False, DISORT's physics).
    planet_radius_km : [km] radius of the ground sphere; ``None`` = plane-parallel slabs.
    max_order : [1] largest scattering order traced.
    channels_per_batch : consecutive channels of the request whose components share paths (hero wavelengths), >= 1;
        4 neighbouring channels are 3-7x more efficient than 1 (`benchmarks/bench_montecarlo.py hero`).
    threads : OpenMP threads of the kernel (0 = the OpenMP default).
    first_order : "quadrature" (default): the singly scattered light of a view ray that escapes to space (every
        upward view) is integrated deterministically along the ray and the sampled paths carry only orders >= 2,
        their first vertex drawn toward the sunlit, scattering part of the ray (unbiased; at -2 deg 3.5-250x less
        variance per path, with the sun at 36 deg about the same, but 2x more at 1900 nm: docs/atmosphere-and-solver.md
        "Variance reduction"); "sampled": every order sampled (the
        first vertex by the hero's forced free path, next-event estimation at it), as before. Downward views that
        end on the ground are always sampled.
    quadrature_step_km : [km] longest sub-interval of that quadrature (also split at layer boundaries and at the edge
        of the Earth's shadow), > 0.
    streams : "independent" (default: one random stream per view direction) or "correlated" (common random numbers
        across directions: a smooth error field over the sky; module docstring).
    ground_orders : 0 (default): the ground reflects with the components' albedo. B >= 1: every path is traced over
        a white ground (albedo 1) and its contributions are split by the number n of ground reflections before they
        reach the observer (n = 0 .. B - 2 exactly, the last order holding n >= B - 1), so that one run gives the
        sky over any Lambertian albedo a as sum_n a^n X_n (:func:`stokes_at_albedo`).
    """

    samples: int = 4096
    seed: int = 1
    polarised: bool = True
    planet_radius_km: float | None = EARTH_RADIUS_KM
    max_order: int = 500
    channels_per_batch: int = 4
    threads: int = 1
    ground_orders: int = 0
    first_order: str = "quadrature"
    quadrature_step_km: float = 2.0
    streams: str = "independent"

    def __post_init__(self):
        if int(self.samples) < 1:
            raise ValueError(f"samples={self.samples} must be >= 1")
        if not (0 <= int(self.seed) < 2 ** 64):
            raise ValueError(f"seed={self.seed} must be in [0, 2**64)")
        if self.planet_radius_km is not None and not (100.0 <= self.planet_radius_km <= 1e9):
            raise ValueError(f"planet_radius_km={self.planet_radius_km} outside [100, 1e9] km (None = plane-parallel)")
        if not (1 <= int(self.max_order) <= 100000):
            raise ValueError(f"max_order={self.max_order} outside [1, 100000]")
        if int(self.channels_per_batch) < 1:
            raise ValueError(f"channels_per_batch={self.channels_per_batch} must be >= 1")
        if int(self.threads) < 0:
            raise ValueError(f"threads={self.threads} must be >= 0")
        if not (0 <= int(self.ground_orders) <= 16):
            raise ValueError(f"ground_orders={self.ground_orders} outside [0, 16]")
        if self.first_order not in FIRST_ORDER_METHODS:
            raise ValueError(f"first_order={self.first_order!r}: valid values are {FIRST_ORDER_METHODS}")
        if self.streams not in STREAM_MODES:
            raise ValueError(f"streams={self.streams!r}: valid values are {STREAM_MODES}")
        if not (0.01 <= float(self.quadrature_step_km) <= 1000.0):
            raise ValueError(f"quadrature_step_km={self.quadrature_step_km} outside [0.01, 1000] km")


@dataclass(frozen=True)
class Components:
    """Layer optics of K spectral components (layers ground first, L layers).

    levels_km (L+1,) level altitudes [km]; extinction, rayleigh, aerosol (L, K) extinction and scattering
    coefficients [km-1]; depolarisation (K,) Rayleigh depolarisation ratio [1]; aerosol_table (K,) index into
    aerosol_matrices (G, M, 4) (P11, P12, P33, P34 on :func:`matrix_mu_grid`); albedo (K,) [1];
    channel (K,) output index; weight (K,) weight of the component in its output [1].
    """

    levels_km: np.ndarray
    extinction: np.ndarray
    rayleigh: np.ndarray
    aerosol: np.ndarray
    depolarisation: np.ndarray
    aerosol_table: np.ndarray
    aerosol_matrices: np.ndarray
    albedo: np.ndarray
    channel: np.ndarray
    weight: np.ndarray

    @property
    def n_components(self) -> int:
        return self.extinction.shape[1]


def rayleigh_slab(tau: float, albedo: float = 0.0, depolarisation: float = 0.0, thickness_km: float = 10.0,
                  n_layers: int = 1) -> Components:
    """One conservative Rayleigh layer of optical depth ``tau`` [1] over a Lambertian ground (the atmosphere of
    Coulson et al. 1960), ``n_layers`` equal sublayers of total thickness ``thickness_km`` [km]."""
    if not (tau > 0):
        raise ValueError(f"tau={tau} must be > 0")
    lv = np.linspace(0.0, thickness_km, n_layers + 1)
    e = np.full((n_layers, 1), tau / thickness_km)
    return Components(levels_km=lv, extinction=e, rayleigh=e.copy(), aerosol=np.zeros_like(e),
                      depolarisation=np.array([float(depolarisation)]), aerosol_table=np.zeros(1, np.int32),
                      aerosol_matrices=_isotropic_table(), albedo=np.array([float(albedo)]),
                      channel=np.zeros(1, np.int32), weight=np.ones(1))


def _isotropic_table():
    mu = matrix_mu_grid()
    t = np.zeros((1, len(mu), 4))
    t[0, :, 0] = 1.0
    return t


def channel_components(problems: dict, atmosphere, albedo, aerosol_type: str, relative_humidity: int,
                       co2_ppm: float = 360.0, data_dir=None) -> Components:
    """Components of the channels in ``problems`` (dict channel -> list of SubProblem, as returned by
    :func:`widesky.skymodel.generator.solver.channel_problems`); output index = position of the channel in the dict.
    albedo : (55,) ground albedo per channel [1]."""
    if aerosol_type not in OPAC_TYPES:
        raise ValueError(f"aerosol_type={aerosol_type!r}: valid types are {tuple(OPAC_TYPES)}")
    if relative_humidity not in HUMIDITIES:
        raise ValueError(f"relative_humidity={relative_humidity}: valid values are {HUMIDITIES} %")
    dz = np.diff(atmosphere.levels_km)
    cols = {"ext": [], "ray": [], "aer": [], "rho": [], "tab": [], "alb": [], "ch": [], "w": []}
    lams = []
    for j, (c, plist) in enumerate(problems.items()):
        for p in plist:
            cols["ext"].append(p.tau_total / dz)
            cols["ray"].append(p.tau_rayleigh / dz)
            cols["aer"].append(p.tau_aerosol * p.ssa_aerosol / dz)
            cols["rho"].append(float(depolarization_ratio(p.wavelength_nm, co2_ppm)))
            lam = round(float(p.wavelength_nm), 6)
            if lam not in lams:
                lams.append(lam)
            cols["tab"].append(lams.index(lam))
            cols["alb"].append(float(albedo[int(c)]))
            cols["ch"].append(j)
            cols["w"].append(p.weight)
    if not cols["w"]:
        raise ValueError("no sub-problems: every term of these channels is beyond skip_tau")
    mats = np.stack([mixture_matrix(aerosol_type, relative_humidity, lam, data_dir) for lam in lams])
    return Components(levels_km=np.asarray(atmosphere.levels_km, float), extinction=np.array(cols["ext"]).T.copy(),
                      rayleigh=np.array(cols["ray"]).T.copy(), aerosol=np.array(cols["aer"]).T.copy(),
                      depolarisation=np.array(cols["rho"]), aerosol_table=np.array(cols["tab"], np.int32),
                      aerosol_matrices=mats, albedo=np.array(cols["alb"]), channel=np.array(cols["ch"], np.int32),
                      weight=np.array(cols["w"]))


def _unit_views(view_zenith_deg, relative_azimuth_deg, downward: bool):
    th = np.radians(np.asarray(view_zenith_deg, float))
    ph = np.radians(np.asarray(relative_azimuth_deg, float))
    sz = -1.0 if downward else 1.0
    v = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), sz * np.cos(th)], axis=1)
    # frame of the light arriving at the observer (propagation -v): unit vector in the meridian plane
    a = np.stack([np.cos(th) * np.cos(ph), np.cos(th) * np.sin(ph), -sz * np.sin(th)], axis=1)
    return np.ascontiguousarray(v), np.ascontiguousarray(a)


def sampling_frames(views, downward: bool = False):
    """Azimuth references of the correlated streams (N, 3): for each unit view vector (N, 3) the x axis carried to it
    from the pole of its hemisphere (the zenith, or the nadir for ``downward``) by the rotation about pole x view, a
    unit vector perpendicular to the view that is continuous over the whole hemisphere, the pole and the horizon
    included (unlike the meridian frame, undefined at the pole)."""
    v = np.asarray(views, float)
    pz = -1.0 if downward else 1.0
    dz = pz * v[:, 2]
    f = v[:, 0] / (1.0 + dz)  # R(e_x) = e_x - (v_x / (1 + pole . v)) (pole + v)
    u = np.stack([1.0 - f * v[:, 0], -f * v[:, 1], -f * (pz + v[:, 2])], axis=1)
    u -= np.einsum("ij,ij->i", u, v)[:, None] * v
    return np.ascontiguousarray(u / np.linalg.norm(u, axis=1)[:, None])


@dataclass
class StokesResult:
    """Monte Carlo output (N directions, C outputs).

    stokes (N, C, 4) mean (I, Q, U, V) [per unit solar irradiance normal to the beam, sr-1, unless scaled], or
    (N, C, B, 4) per order of ground reflection when traced with ``ground_orders`` B >= 1;
    stderr: standard error of the mean, same shape and unit; samples: paths per direction; seconds: wall time [s].
    """

    stokes: np.ndarray
    stderr: np.ndarray
    samples: int
    seconds: float
    meta: dict = field(default_factory=dict)

    def degree_of_polarisation(self) -> np.ndarray:
        """Degree of linear polarisation sqrt(Q^2 + U^2) / I [1], shape (N, C)."""
        s = self.stokes
        return np.hypot(s[..., 1], s[..., 2]) / s[..., 0]


def trace(components: Components, solar_zenith_deg: float, view_zenith_deg, relative_azimuth_deg,
          config: MonteCarloConfig = MonteCarloConfig(), observer_altitude_km: float = 0.0,
          downward: bool = False) -> StokesResult:
    """Trace the Stokes radiance seen by an observer (array in, array out).

    Parameters
    ----------
    components : Components (K components, C = max(channel) + 1 outputs).
    solar_zenith_deg : [deg] at the observer, 0 to 100 (above 90: sun below the horizon, spherical shells only).
    view_zenith_deg, relative_azimuth_deg : (N,) [deg]; zenith 0-90 measured from the zenith (``downward=False``)
        or from the nadir (``downward=True``); azimuth relative to the sun's (0 = the view direction's horizontal
        part points toward the sun).
    observer_altitude_km : [km] inside [0, top of the atmosphere].
    downward : look down (an observer at the top of a slab, e.g. reflected light of Coulson et al.).

    Returns
    -------
    StokesResult with radiance per unit solar irradiance normal to the beam [sr-1]; with ``config.ground_orders``
    B >= 1 its arrays have an extra axis of the B orders of ground reflection (N, C, B, 4).
    """
    cp = components
    lv = np.asarray(cp.levels_km, float)
    sza = float(solar_zenith_deg)
    if not (0.0 <= sza <= 90.0 - MIN_SOLAR_ELEVATION_DEG):
        raise ValueError(f"solar_zenith_deg={sza} outside [0, {90 - MIN_SOLAR_ELEVATION_DEG}] deg")
    if sza >= 90.0 and config.planet_radius_km is None:
        raise ValueError(f"solar_zenith_deg={sza}: a sun at or below the horizon needs spherical shells "
                         "(planet_radius_km not None)")
    vz = np.atleast_1d(np.asarray(view_zenith_deg, float))
    va = np.broadcast_to(np.atleast_1d(np.asarray(relative_azimuth_deg, float)), vz.shape)
    if np.any((vz < 0) | (vz > 90)):
        raise ValueError(f"view_zenith_deg must be in [0, 90] deg, got {vz.min()}..{vz.max()}")
    alt = float(observer_altitude_km)
    if not (lv[0] <= alt <= lv[-1]):
        raise ValueError(f"observer_altitude_km={alt} outside [{lv[0]}, {lv[-1]}] km")
    L, K = cp.extinction.shape
    C = int(cp.channel.max()) + 1
    B = int(config.ground_orders)
    albedo = np.ones(K) if B else cp.albedo
    cch = np.asarray(cp.channel, np.int32) * max(B, 1)
    planar = config.planet_radius_km is None
    R = 0.0 if planar else float(config.planet_radius_km)
    radii = np.ascontiguousarray(lv + R)
    layer = int(np.clip(np.searchsorted(lv, alt, side="right") - 1, 0, L - 1))
    if downward and alt > lv[0] and layer > 0 and alt == lv[layer]:
        layer -= 1  # on a level, looking down: start in the layer below
    mu = matrix_mu_grid()
    mats = np.asarray(cp.aerosol_matrices, float)
    cdf = np.concatenate([np.zeros((mats.shape[0], 1)),
                          np.cumsum(0.5 * (mats[:, 1:, 0] + mats[:, :-1, 0]) * np.diff(mu)[None, :], axis=1)], axis=1)
    rho = np.asarray(cp.depolarisation, float)
    delta = (1 - rho) / (1 + rho / 2)
    delta_p = (1 - 2 * rho) / (1 - rho)
    z = np.radians(sza)
    sun = np.array([np.sin(z), 0.0, np.cos(z)])
    views, frames = _unit_views(vz, va, downward)
    n = int(np.ceil(int(config.samples) / K) * K)
    s = np.zeros((len(vz), C * max(B, 1), 4))
    s2 = np.zeros_like(s)
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    t0 = time.perf_counter()
    _montecarlo.trace(L, K, mats.shape[0], len(mu), int(planar), radii, C * max(B, 1), f64(cp.extinction), f64(cp.rayleigh),
                      f64(cp.aerosol), f64(np.stack([delta, delta_p], axis=1)), f64(mu), f64(mats), f64(cdf),
                      np.ascontiguousarray(cp.aerosol_table, np.int32), f64(albedo),
                      np.ascontiguousarray(cch, np.int32), f64(cp.weight), len(vz), f64(sun), alt + R, layer,
                      views, frames, n, int(config.seed), int(config.max_order), int(bool(config.polarised)),
                      int(config.threads), s, s2, max(B, 1), int(config.first_order == "quadrature"),
                      float(config.quadrature_step_km),
                      sampling_frames(views, downward) if config.streams == "correlated" else None)
    mean = s / n
    var = np.maximum(s2 / n - mean ** 2, 0.0)
    se = np.sqrt(var / n)
    if B:
        mean, se = mean.reshape(len(vz), C, B, 4), se.reshape(len(vz), C, B, 4)
    return StokesResult(stokes=mean, stderr=se, samples=n, seconds=time.perf_counter() - t0,
                        meta={"components": K, "ground_orders": B, "streams": config.streams})


def stokes_at_albedo(orders, albedo, stderr=None):
    """Stokes vectors over a Lambertian ground of albedo ``albedo`` [1] in [0, 1] from a run with ``ground_orders``
    B >= 1 (:class:`MonteCarloConfig`).

    Parameters
    ----------
    orders : (..., C, B, 4) contributions X_n by the number n of ground reflections (the last holds n >= B - 1).
    albedo : float [1], or (C,) per channel.
    stderr : optional (..., C, B, 4) their standard errors.

    Returns
    -------
    (..., C, 4) = sum_{n < B-1} a^n X_n + a^(B-1) X_rest (1 - q) / (1 - a q), where the tail beyond B - 2 reflections
    is taken as geometric with the ratio q of the intensities of the last two exact orders (per channel, summed over
    the leading axes, within [0, 0.9]; exact at a = 0 and a = 1 for any q). With ``stderr``: (value, bound), the
    bound sum_n a^n se_n on the standard error (the orders share paths, so their errors may correlate).
    """
    x = np.asarray(orders, float)
    B = x.shape[-2]
    a = np.asarray(albedo, float)
    if np.any((a < 0) | (a > 1)):
        raise ValueError(f"albedo={albedo} outside [0, 1]")
    a = np.broadcast_to(a, x.shape[-3:-2])[:, None]  # (C, 1)
    pw = a ** np.arange(B)[None, :]                   # (C, B)
    if B >= 3:
        lead = tuple(range(x.ndim - 3))
        i_last, i_prev = x[..., B - 2, 0].sum(axis=lead), x[..., B - 3, 0].sum(axis=lead)
        q = np.clip(np.divide(i_last, i_prev, out=np.zeros_like(i_last), where=i_prev > 0), 0.0, 0.9)[:, None]
        pw = pw.copy()
        pw[:, -1:] *= (1.0 - q) / (1.0 - a * q)
    val = np.einsum("...cbs,cb->...cs", x, pw)
    if stderr is None:
        return val
    return val, np.einsum("...cbs,cb->...cs", np.asarray(stderr, float), pw)


def hemisphere_directions(n: int, seed: int = 0):
    """Cosine-weighted directions over the upper hemisphere by Latin hypercube sampling (n strata in sin^2 of the
    zenith angle, n in azimuth, paired by a random permutation): view zenith, azimuth [deg], (n,) each.
    The mean of a radiance over them estimates the diffuse horizontal irradiance divided by pi, without bias."""
    if int(n) < 1:
        raise ValueError(f"n={n} must be >= 1")
    rng = np.random.default_rng(seed)
    n = int(n)
    u1 = (rng.permutation(n) + rng.random(n)) / n
    u2 = (np.arange(n) + rng.random(n)) / n
    return np.degrees(np.arcsin(np.sqrt(u1))), 360.0 * u2 - 180.0


@dataclass
class MonteCarloSky:
    """Monte Carlo sky radiance of one sky state (N directions, C channels).

    channels (C,); wavelength_nm (C,) [nm]; extraterrestrial (C,) band-mean ET [W m-2 nm-1];
    stokes (N, C, 4) (I, Q, U, V) [W m-2 sr-1 nm-1], or (N, C, B, 4) by order of ground reflection when solved with
    ``ground_orders`` B >= 1 (:func:`stokes_at_albedo`); stderr: its standard error, same shape and unit;
    view_zenith_deg, relative_azimuth_deg (N,) [deg]; solar_elevation_deg [deg]; samples per direction;
    seconds [s] wall time.
    """

    channels: np.ndarray
    wavelength_nm: np.ndarray
    extraterrestrial: np.ndarray
    stokes: np.ndarray
    stderr: np.ndarray
    view_zenith_deg: np.ndarray
    relative_azimuth_deg: np.ndarray
    solar_elevation_deg: float
    samples: int
    seconds: float

    @property
    def radiance(self) -> np.ndarray:
        """Sky radiance I [W m-2 sr-1 nm-1], shape (N, C) (N, C, B with ground orders)."""
        return self.stokes[..., 0]


def solve_sky_mc(state, spec=None, view_zenith_deg=(0.0,), relative_azimuth_deg=(0.0,), channels=None,
                 config: MonteCarloConfig = MonteCarloConfig(), solar_elevation_deg: float | None = None,
                 data_dir=None, progress: bool = False) -> MonteCarloSky:
    """Monte Carlo sky radiance for a sky state of the DISORT chain.

    Parameters
    ----------
    state : skymodel.generator.solver.SkyState (aerosol amount, albedo, day of year; its solar elevation unless
        ``solar_elevation_deg`` is given).
    spec : AtmosphereSpec (default: the default atmosphere).
    view_zenith_deg, relative_azimuth_deg : (N,) [deg], see :func:`trace`.
    channels : channel indices 0..54 (default all).
    config : MonteCarloConfig; its ``channels_per_batch`` neighbouring channels share paths.
    solar_elevation_deg : [deg] in [-10, 90]: overrides the state's (the sun may be below the horizon).
    progress : tqdm bar over channel batches.
    """
    spec = AtmosphereSpec() if spec is None else spec
    el = float(state.solar_elevation_deg if solar_elevation_deg is None else solar_elevation_deg)
    if not (MIN_SOLAR_ELEVATION_DEG <= el <= 90.0):
        raise ValueError(f"solar_elevation_deg={el} outside [{MIN_SOLAR_ELEVATION_DEG}, 90] deg")
    probs, et_ch, atm = channel_problems(state, spec, channels, data_dir=data_dir)
    ch = np.array(list(probs), int)
    vz = np.atleast_1d(np.asarray(view_zenith_deg, float))
    va = np.broadcast_to(np.atleast_1d(np.asarray(relative_azimuth_deg, float)), vz.shape).copy()
    nb = int(config.channels_per_batch)
    batches = [ch[i:i + nb] for i in range(0, len(ch), nb)]
    B = int(config.ground_orders)
    out = np.zeros((len(vz), len(ch)) + ((B,) if B else ()) + (4,))
    err = np.zeros_like(out)
    t0 = time.perf_counter()
    samples = 0
    it = batches
    if progress:
        it = tqdm(batches, desc="Monte Carlo channel batches", leave=False)
    alb = state.albedo()
    for bi, b in enumerate(it):
        comps = channel_components({int(c): probs[int(c)] for c in b}, atm, alb, spec.aerosol_type,
                                   spec.relative_humidity, spec.co2_ppm, data_dir)
        cfg = MonteCarloConfig(**{**config.__dict__, "seed": (int(config.seed) + 7919 * int(b[0])) % 2 ** 64})
        r = trace(comps, 90.0 - el, vz, va, cfg)
        j = np.searchsorted(ch, b)
        et_b = et_ch[b].reshape((1, -1) + (1,) * (out.ndim - 2))
        out[:, j] = r.stokes * et_b
        err[:, j] = r.stderr * et_b
        samples = max(samples, r.samples)
    return MonteCarloSky(channels=ch, wavelength_nm=CHANNEL_CENTERS_NM[ch], extraterrestrial=et_ch[ch], stokes=out,
                         stderr=err, view_zenith_deg=vz, relative_azimuth_deg=va, solar_elevation_deg=el,
                         samples=samples, seconds=time.perf_counter() - t0)
