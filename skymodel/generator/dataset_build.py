"""Build a Prague-Sky-Model-format dataset from the reference solver (``widesky dataset build``).

Pipeline (docs/default-dataset.md):

1. **Solve** every (visibility, solar elevation) grid state with a black ground (albedo 0) on a product grid of
   view zeniths x relative azimuths sized for the fit (:func:`fit_directions`); one DISORT run per channel
   sub-problem (:mod:`widesky.skymodel.generator.solver`). Per visibility, one extra pair of runs (albedo 0 and 1) gives the
   atmosphere's response to a Lambertian ground, which does not depend on the sun: for a plane-parallel
   atmosphere over a Lambertian ground, per sub-problem k,

       I_k(a) = I_k(0) + a E_k(0) t_k(theta) / (pi (1 - a S_k))

   with E_k(0) the black-ground global irradiance, S_k the spherical albedo of the atmosphere and t_k(theta)
   its diffuse transmittance for isotropic illumination from below. Every albedo of the grid then costs no
   solver run (checked against direct runs in tests/test_dataset_build.py).
2. **Fit** each (visibility, albedo, elevation, channel) into the PSM form with :func:`widesky.skymodel.generator.fit.fit_radiance`
   using the evaluator's own angles (:func:`widesky.skymodel.reference_angles`).
3. **Transmittance**: sqrt(T) of straight paths through the spherical shells on the format's (distance,
   altitude) parameter grid, band-averaged with the solver's k-distribution sub-problems, factored into U . V.
4. **Write** the file and its JSON sidecar (grids, inputs, versions, the extraterrestrial spectrum).

Every solved state is cached as ``.npz`` under ``~/.cache/widesky/dataset-build/<hash>/`` (hash of the
solver-relevant settings), so an interrupted build resumes where it stopped, and changing knots or ranks
refits without solving again.

With the Monte Carlo keys of :class:`BuildConfig` (``polarisation``, ``mc_below_elevation_deg``, ...) the build also
solves polarised Monte Carlo states in spherical shells (:mod:`widesky.skymodel.generator.dataset_mc`): the polarisation
section, and the radiance of low-sun and twilight elevations.
"""

from __future__ import annotations

import hashlib
import importlib.metadata as md
import json
import time
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..channels import FINE_WAVELENGTHS_NM
from ..dataset import load_dataset
from ..evaluate import directions_from_angles, reference_angles
from ..writer import DatasetContents, write_dataset
from .cache import cache_root, ground_file, load_state, save_state, state_file, validation_states
from .dask_scheduler import pool_map
from .dataset_errors import evaluate_errors, summarise as summarise_errors
from .dataset_grid import (AZIMUTHS_DEG, direction_samples, fit_directions, fit_weights, ground_directions, knots,
                           validation_directions, with_midpoints)
from .dataset_mc import (MC_FIRST_ORDER, SPLIT_SMOOTHING, cached_rest_across_visibility, fit_grid, fit_polarisation,
                         mc_file, mc_key, mc_stokes, needs_mc_state, pol_knots, polarisation_summary, radiance_by_mc,
                         resample_radiance, solve_mc_state, split_radiance, split_state, stored_polarisation, uses_mc,
                         validation_file)
from .dataset_solve import _problems, solve_ground, solve_split_validation, solve_state
from .fit import fit_radiance, fit_transmittance
from .montecarlo import STREAM_MODES
from .smoothness import (AUREOLE_REFERENCE_READ_ON_DEG, REFERENCE_FLOOR_FRACTION, REFERENCE_REL_TOL,
                         VERTICAL_REFERENCE_HORIZON_DEG, check_dataset, reference_entries, reference_from_entries,
                         solver_turning_points, summarise)
from .smoothness_between import between_reference
from .solar import extraterrestrial_spectrum
from .solver import AtmosphereSpec, SolverConfig

__all__ = ["BuildConfig", "load_config", "fit_directions", "ground_directions", "solve_state", "solve_ground",
           "radiance_with_albedo", "state_radiance", "solve_all", "validation_states", "validation_directions",
           "knots", "with_midpoints", "refine_fill_deg", "cell_centres", "fill_grid", "fit_samples",
           "fit_state", "config_knots", "direction_samples", "fit_sky", "fit_all", "segment_path_factors",
           "transmittance_grid", "transmittance_samples", "fit_transmittance_bounded", "assemble", "build_dataset",
           "solver_reference", "smoothness_report", "cache_root"]

PLANET_RADIUS_M = 6378000.0
"""Planet radius of the format's geometry [m] (the reference's value)."""
ATMOSPHERE_TOP_M = 100000.0
"""Top of the format's atmosphere [m]."""
DIST_TO_EDGE_M = 1571524.413613
"""Ground distance of the distance parameter 1 [m] (the format's constant)."""


@dataclass(frozen=True)
class BuildConfig:
    """Everything that defines a generated dataset (JSON keys of the same names; see skymodel/data/default-dataset.json).

    visibilities_km [km], albedos [1], elevations_deg [deg] (ascending; values below ``min_solve_elevation_deg``
    are solved at that elevation; values above ``max_fit_elevation_deg`` hold the fit of the highest elevation
    below it, see docs/default-dataset.md), knots (sun, zenith, emphasis counts), knot_powers,
    sun_knot_midpoints_deg (optional (lo, hi) [deg]: a knot inserted at the midpoint of every sun-knot interval
    inside [lo, hi], :func:`config_knots`, and the fit samples that fill the new cells, :func:`fill_grid`; None:
    neither, the builds before it), sun_knot_refine_deg (optional (lo, hi) [deg] inside sun_knot_midpoints_deg: the
    intervals inside it halved once more, with fit samples at the centres of the new cells, :func:`refine_fill_deg`;
    None: not, the builds before it), zenith_knot_midpoints_deg (optional (lo, hi) [deg] of the altitude-corrected view
    zenith: a knot inserted at the midpoint of every zenith-knot interval inside [lo, hi], :func:`config_knots`; None:
    not, the builds before it), band_max_gamma_deg (optional [deg]: the fit also takes the elevation-interpolation
    band, :func:`band_samples`, out to this angle from the sun, with weight ``band_weight`` [1] relative to the
    smallest real sample's; None: not, the builds before it), band_min_elevation_deg (optional [deg]: the band only
    for grid elevations at or above it, :func:`has_band`; None: every grid elevation), rank,
    smoothing [1], sun_penalty_order, iterations, refine, relative_power, relative_floor, sobolev (see
    :func:`widesky.skymodel.generator.fit.fit_radiance`; :func:`fit_options`); solver settings (n_streams, n_moments);
    atmosphere (AtmosphereSpec fields);
    trans_dims (dDim, aDim), trans_rank; direction grid steps [deg]; validation (counts, seed); seed.

    Monte Carlo (:mod:`widesky.skymodel.generator.dataset_mc`; all off by default, and a configuration without these keys
    builds exactly what it built before, with the same cache keys): ``polarisation`` (bool) adds the format's
    polarisation section, fitted from a polarised Monte Carlo state per grid state, with ``pol_knots`` (gamma,
    zenith counts) and ``pol_rank``; ``mc_below_elevation_deg`` [deg]: grid elevations below it take their radiance
    from the Monte Carlo state (spherical shells, solved at their own elevation, which may be down to -10 deg; grid
    elevations below 0 need it); ``mc_samples`` paths per direction and channel batch, ``mc_channels_per_batch``
    neighbouring channels sharing paths, ``mc_ground_orders`` orders of ground reflection kept apart (all albedos
    from one run), ``mc_zenith_step_deg`` [deg] and ``mc_azimuths_deg`` [deg] (None: the default set) the
    direction grid, ``mc_seed``; ``mc_streams`` "correlated" (default: common random numbers across the directions
    of a state, a smooth error field over the sky) or "independent" (one stream per direction, the builds before
    2026-12-02; docs/atmosphere-and-solver.md, "Correlated streams"); ``mc_fit_resample`` true: the radiance fit of a
    Monte Carlo state runs on the DISORT states' direction grid, the state interpolated onto it shape-preservingly
    (:func:`widesky.skymodel.generator.dataset_mc.resample_radiance`) instead of on the state's own coarse grid;
    ``mc_single_scatter_exact`` true: the Monte Carlo radiance is scalar (DISORT's physics) and split, the singly
    scattered light computed deterministically in spherical shells on the DISORT fit grid (held-out grid for the
    validation states) and only the rest (orders >= 2 and all ground-reflected light, smooth over the sky) taken from
    the Monte Carlo grid, smoothed (:func:`widesky.skymodel.generator.dataset_mc.split_radiance`, the rest smoothed across
    visibility; skymodel/data/default-dataset.json, the default dataset's build; docs/default-dataset.md, "Low sun in
    spherical shells").
    """

    visibilities_km: tuple = (20.0, 27.4, 37.5, 51.3, 70.2, 96.2, 131.8)
    albedos: tuple = (0.0, 0.5, 1.0)
    elevations_deg: tuple = (0.0, 1.0, 2.0, 3.0, 4.5, 6.0, 8.0, 10.5, 13.5, 17.0, 21.0, 25.5, 30.5, 36.0, 42.0,
                             48.5, 55.5, 63.0, 71.0, 80.0, 90.0)
    min_solve_elevation_deg: float = 0.5
    max_fit_elevation_deg: float = 85.0
    knots: tuple = (48, 36, 24)
    knot_powers: tuple = (2.0, 1.6, 1.6)
    sun_knot_midpoints_deg: tuple | None = None
    sun_knot_refine_deg: tuple | None = None
    zenith_knot_midpoints_deg: tuple | None = None
    band_max_gamma_deg: float | None = None
    band_weight: float = 1.0
    band_min_elevation_deg: float | None = None
    rank: int = 6
    smoothing: float = 1e-6
    sun_penalty_order: int = 1
    relative_power: float = 0.0
    relative_floor: float = 0.01
    sobolev: float = 0.0
    iterations: int = 4
    refine: int = 2
    n_streams: int = 16
    n_moments: int = 128
    atmosphere: dict = field(default_factory=dict)
    zenith_step_deg: float = 2.0
    trans_dims: tuple = (128, 32)
    trans_rank: int = 40
    validation_off_grid: int = 24
    validation_on_grid: int = 12
    seed: int = 20261123
    description: str = "widesky default dataset"
    polarisation: bool = False
    mc_below_elevation_deg: float | None = None
    mc_samples: int = 1024
    mc_channels_per_batch: int = 4
    mc_ground_orders: int = 4
    mc_zenith_step_deg: float = 6.0
    mc_azimuths_deg: tuple | None = None
    mc_seed: int = 20261201
    mc_streams: str = "correlated"
    mc_fit_resample: bool = False
    mc_single_scatter_exact: bool = False
    pol_knots: tuple = (24, 16)
    pol_rank: int = 3

    def __post_init__(self):
        m = self.sun_knot_midpoints_deg
        if m is not None and not (len(tuple(m)) == 2 and 0.0 <= float(m[0]) < float(m[1]) <= 180.0):
            raise ValueError(f"sun_knot_midpoints_deg={m!r}: expected (lo, hi) [deg] with 0 <= lo < hi <= 180")
        r = self.sun_knot_refine_deg
        if r is not None and (m is None or not (len(tuple(r)) == 2 and float(m[0]) <= float(r[0]) < float(r[1])
                                                <= float(m[1]))):
            raise ValueError(f"sun_knot_refine_deg={r!r}: expected (lo, hi) [deg] inside sun_knot_midpoints_deg={m!r}")
        m = self.zenith_knot_midpoints_deg
        if m is not None and not (len(tuple(m)) == 2 and 0.0 <= float(m[0]) < float(m[1]) <= 90.0):
            raise ValueError(f"zenith_knot_midpoints_deg={m!r}: expected (lo, hi) [deg] with 0 <= lo < hi <= 90")
        if self.sun_penalty_order not in (1, 2):  # refused before any solve, not in the fit after them
            raise ValueError(f"sun_penalty_order={self.sun_penalty_order!r}: expected 1 or 2")
        if not 0.0 <= float(self.relative_power) <= 4.0:
            raise ValueError(f"relative_power={self.relative_power!r}: expected a value in [0, 4]")
        if not 0.0 < float(self.relative_floor) <= 1.0:
            raise ValueError(f"relative_floor={self.relative_floor!r}: expected a value in (0, 1]")
        g = self.band_max_gamma_deg
        if g is not None and not 0.0 < float(g) <= 90.0:
            raise ValueError(f"band_max_gamma_deg={g!r}: expected a value in (0, 90] deg, or null")
        if not 0.0 < float(self.band_weight) <= 1e4:
            raise ValueError(f"band_weight={self.band_weight!r}: expected a value in (0, 10000]")
        b0 = self.band_min_elevation_deg
        if b0 is not None and (g is None or not -10.0 <= float(b0) <= 90.0):
            raise ValueError(f"band_min_elevation_deg={b0!r}: expected a value in [-10, 90] deg with "
                             f"band_max_gamma_deg set (got {g!r}), or null")
        if not 0.0 <= float(self.sobolev) <= 1e3:
            raise ValueError(f"sobolev={self.sobolev!r}: expected a value in [0, 1000]")
        ele = np.asarray(self.elevations_deg, float)
        low = float(ele.min()) if ele.size else 0.0
        b = self.mc_below_elevation_deg
        if low < 0 and (b is None or low >= float(b)):
            raise ValueError(f"elevations_deg down to {low} deg: elevations below 0 (twilight) need "
                             f"mc_below_elevation_deg above them (got {b})")
        if low < -10.0:
            raise ValueError(f"elevations_deg: {low} deg below the Monte Carlo solver's range [-10, 90] deg")
        if self.mc_single_scatter_exact and (b is None or self.polarisation):
            raise ValueError("mc_single_scatter_exact needs mc_below_elevation_deg (the elevations it applies to) and "
                             f"no polarisation (its states are scalar); got mc_below_elevation_deg={b}, "
                             f"polarisation={self.polarisation}")
        if int(self.mc_samples) < 1 or int(self.mc_channels_per_batch) < 1:
            raise ValueError(f"mc_samples={self.mc_samples} and mc_channels_per_batch={self.mc_channels_per_batch} "
                             "must be >= 1")
        if not 1 <= int(self.mc_ground_orders) <= 16:
            raise ValueError(f"mc_ground_orders={self.mc_ground_orders} outside [1, 16]")
        if self.mc_streams not in STREAM_MODES:
            raise ValueError(f"mc_streams={self.mc_streams!r}: valid values are {STREAM_MODES}")
        if not 0.5 <= float(self.mc_zenith_step_deg) <= 30.0:
            raise ValueError(f"mc_zenith_step_deg={self.mc_zenith_step_deg} outside [0.5, 30] deg")
        if len(tuple(self.pol_knots)) != 2 or min(int(k) for k in self.pol_knots) < 2 or int(self.pol_rank) < 1:
            raise ValueError(f"pol_knots={self.pol_knots} must be two counts >= 2 and pol_rank={self.pol_rank} >= 1")

    def solver_config(self):
        return SolverConfig(n_streams=int(self.n_streams), n_moments=int(self.n_moments))

    def spec(self):
        return AtmosphereSpec(**self.atmosphere)

    def solver_key(self) -> str:
        """Hash of the settings that change solver output (not knots, ranks or grids)."""
        d = {"n_streams": self.n_streams, "n_moments": self.n_moments, "atmosphere": self.atmosphere,
             "zenith_step_deg": self.zenith_step_deg, "min_solve": self.min_solve_elevation_deg,
             "phase": "tabulated", "azimuths": AZIMUTHS_DEG.tolist(), "v": 2}
        return hashlib.sha1(json.dumps(d, sort_keys=True).encode()).hexdigest()[:12]

    def to_dict(self) -> dict:
        """The configuration as JSON-ready values; the Monte Carlo keys only where the configuration uses the Monte
        Carlo solver and ``sun_knot_midpoints_deg`` only where set (so earlier builds' sidecars are unchanged)."""
        d = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}
        if not uses_mc(self):
            for k in MC_KEYS:
                d.pop(k)
        if self.sun_knot_midpoints_deg is None:  # (absent, as in the builds before the key)
            d.pop("sun_knot_midpoints_deg")
        if self.sun_knot_refine_deg is None:  # likewise
            d.pop("sun_knot_refine_deg")
        if self.zenith_knot_midpoints_deg is None:  # likewise
            d.pop("zenith_knot_midpoints_deg")
        if self.band_max_gamma_deg is None:  # likewise
            d.pop("band_max_gamma_deg")
            d.pop("band_weight")
        if self.band_min_elevation_deg is None:  # likewise
            d.pop("band_min_elevation_deg")
        return d


MC_KEYS = ("polarisation", "mc_below_elevation_deg", "mc_samples", "mc_channels_per_batch", "mc_ground_orders",
           "mc_zenith_step_deg", "mc_azimuths_deg", "mc_seed", "mc_streams", "mc_fit_resample",
           "mc_single_scatter_exact", "pol_knots",
           "pol_rank")
"""The configuration keys of the Monte Carlo path (:mod:`widesky.skymodel.generator.dataset_mc`)."""


def load_config(path) -> BuildConfig:
    """Read a build configuration from JSON (or TOML) ``path``; unknown keys raise ValueError naming them."""
    p = Path(path)
    text = p.read_text()
    if p.suffix == ".toml":
        d = tomllib.loads(text)
    else:
        d = json.loads(text)
    valid = set(BuildConfig.__dataclass_fields__)
    bad = sorted(set(d) - valid)
    if bad:
        raise ValueError(f"unknown build-config keys {bad}; valid keys are {sorted(valid)}")
    d = {k: (tuple(v) if isinstance(v, list) else v) for k, v in d.items()}
    return BuildConfig(**d)


# --------------------------------------------------------------------------------------------- directions


FILL_AZIMUTHS_DEG = np.array([2.0, 3.25, 5.0, 7.5, 10.75])
"""Relative azimuths [deg] added to the fit samples of a configuration with ``sun_knot_midpoints_deg``
(:func:`fill_grid`): one inside each halved sun-knot cell along the sun's almucantar that :data:`AZIMUTHS_DEG` leaves
empty."""
FILL_SUN_OFFSETS_DEG = np.array([2.0, 3.25, 5.0])
"""Offsets of view zeniths around the solar zenith [deg] added likewise (the cells along the sun's vertical)."""


def refine_fill_deg(config: BuildConfig) -> np.ndarray:
    """Angles from the sun [deg] of the fit samples a configuration with ``sun_knot_refine_deg`` adds along the sun's
    almucantar (as relative azimuths) and vertical (as offsets from the solar zenith): the centre of every sun-knot
    cell inside that range (:func:`config_knots`), so each cell of the second halving holds samples (about 0.4-0.5 deg
    wide at 3.5-8.5 deg, where the solved grid has azimuths 4, 6, 9 and the fill 5, 7.5); empty when not set."""
    if config.sun_knot_refine_deg is None:
        return np.zeros(0)
    return cell_centres(np.degrees(config_knots(config)[0]), *config.sun_knot_refine_deg)


def cell_centres(breaks_deg, lo: float, hi: float) -> np.ndarray:
    """Centres [deg] of the cells of ascending knots ``breaks_deg`` [deg] that lie inside [``lo``, ``hi``] [deg].
    Pure array function."""
    b = np.asarray(breaks_deg, float)
    inside = (b[:-1] >= float(lo) - 1e-9) & (b[1:] <= float(hi) + 1e-9)
    return 0.5 * (b[:-1] + b[1:])[inside]


def fill_grid(zenith_deg, azimuth_deg, solar_elevation_deg: float, extra_deg=()):
    """The product grid ``zenith_deg`` (T,) x ``azimuth_deg`` (P,) [deg] with :data:`FILL_SUN_OFFSETS_DEG` around the
    solar zenith and :data:`FILL_AZIMUTHS_DEG` added, clipped to the grid's own range: (zenith (T2,), azimuth (P2,))
    [deg]. With the sun-knot intervals near the sun halved, some knot cells hold no sample of the build's grid and the
    fit sags there (the piecewise-linear factors follow the regulariser between samples); the fit then takes these
    directions too, the solved radiance interpolated shape-preservingly onto them
    (:func:`widesky.skymodel.generator.dataset_mc.resample_radiance`), which adds no extremum between the solved samples.
    ``extra_deg`` [deg]: more angles from the sun added both ways (:func:`refine_fill_deg`)."""
    th, ph = np.asarray(zenith_deg, float), np.asarray(azimuth_deg, float)
    zs = 90.0 - float(solar_elevation_deg)
    off = np.concatenate([FILL_SUN_OFFSETS_DEG, np.asarray(extra_deg, float)])
    t2 = np.concatenate([th, zs + off, zs - off])
    t2 = np.unique(np.round(np.clip(t2, th[0], th[-1]), 6))
    p2 = np.unique(np.round(np.clip(np.concatenate([ph, FILL_AZIMUTHS_DEG, np.asarray(extra_deg, float)]),
                                    ph[0], ph[-1]), 6))
    return t2, p2


def zenith_fill(config: BuildConfig) -> np.ndarray:
    """View zeniths [deg] of the fill rows of a configuration with ``zenith_knot_midpoints_deg`` (lo, hi): the centre of
    every zenith-knot cell inside [lo, hi] (:func:`config_knots`; at ground level the zenith factor's angle is the view
    zenith). Halved cells about 0.3-1 deg wide would otherwise hold no solved row at some elevations (rows every 2 deg
    and at 85.5, 87, 88, 89 deg, plus those around the sun) and the fit sags there, as it did along the sun's
    almucantar before :func:`fill_grid`; empty when the key is not set."""
    if config.zenith_knot_midpoints_deg is None:
        return np.zeros(0)
    return cell_centres(np.degrees(config_knots(config)[1]), *config.zenith_knot_midpoints_deg)


def fit_samples(config: BuildConfig, zenith_deg, azimuth_deg, radiance, solar_elevation_deg: float):
    """The fit's samples of one state solved on the product grid ``zenith_deg`` (T,) x ``azimuth_deg`` (P,) [deg]:
    (zenith (T2,), azimuth (P2,), radiance (T2, P2, ...)): the solved grid itself, or with ``sun_knot_midpoints_deg``
    set, :func:`fill_grid` with ``radiance`` [W m-2 sr-1 nm-1] interpolated onto it shape-preservingly
    (``radiance`` None: the grid only); with ``zenith_knot_midpoints_deg`` set also a view-zenith row at the centre of
    every zenith-knot cell inside that range (:func:`zenith_fill`), likewise interpolated."""
    zm = config.zenith_knot_midpoints_deg
    if config.sun_knot_midpoints_deg is None and zm is None:
        return np.asarray(zenith_deg, float), np.asarray(azimuth_deg, float), radiance

    if config.sun_knot_midpoints_deg is not None:
        t2, p2 = fill_grid(zenith_deg, azimuth_deg, solar_elevation_deg, refine_fill_deg(config))
    else:
        t2, p2 = np.asarray(zenith_deg, float), np.asarray(azimuth_deg, float)
    if zm is not None:
        t2 = np.unique(np.round(np.clip(np.concatenate([t2, zenith_fill(config)]), t2[0], t2[-1]), 6))
    return t2, p2, None if radiance is None else resample_radiance(zenith_deg, azimuth_deg, radiance, t2, p2)


BAND_GAMMAS_DEG = np.array([0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.25, 4.0, 5.0, 6.0, 7.0, 8.0, 9.5, 11.0,
                            12.5, 14.0, 16.0, 18.0, 20.0, 23.0, 26.0, 30.0])
"""Angles from the sun of the elevation-interpolation band's samples [deg] (:func:`band_samples`); from the grid's
smallest offset from the sun (0.25 deg) up: closer in, the interpolation along the vertical would straddle the sun."""


def band_deltas(config: BuildConfig, elevation_deg: float):
    """(up, down) [deg]: how far the grid's elevation interpolation moves the sun from grid elevation
    ``elevation_deg`` [deg] toward the neighbouring grid elevations (0 where there is none)."""
    e = np.asarray(config.elevations_deg, float)
    k = int(np.argmin(np.abs(e - float(elevation_deg))))
    return (float(e[k + 1] - e[k]) if k + 1 < len(e) else 0.0, float(e[k] - e[k - 1]) if k > 0 else 0.0)


def has_band(config: BuildConfig, elevation_deg: float) -> bool:
    """Whether the fit of grid elevation ``elevation_deg`` [deg] takes the elevation-interpolation band
    (:func:`band_samples`): ``band_max_gamma_deg`` set and the elevation at or above ``band_min_elevation_deg``
    (where set)."""
    if config.band_max_gamma_deg is None:
        return False
    lo = config.band_min_elevation_deg
    return lo is None or float(elevation_deg) >= float(lo) - 1e-9


def band_samples(zenith_deg, azimuth_deg, radiance, solar_elevation_deg: float, deltas_deg, max_gamma_deg: float):
    """Fit samples of one grid state in its elevation-interpolation band, where the evaluator looks although no
    direction of this state's sky lies there.

    Between grid elevations the evaluator blends the bracketing states' fits at the query's own angles (gamma to the
    sun, view zenith alpha), as the reference does. A pair (gamma, alpha) with gamma < |alpha - zs| (zs: this state's
    solar zenith) is no direction of this state's sky, yet a query sun up to ``deltas_deg`` (up, down) [deg] away
    asks for it: the band ``|alpha - zs| - delta <= gamma < |alpha - zs|`` (up: alpha above the sun, down: below).
    The fit sees no sample there and its product of factors takes any value: between 17 and 21 deg the 17 deg state
    gives a ray from the sun that rises for 2 deg before the aureole falls, and the blend turns three times where
    the sky solved at 19 deg turns once (docs/default-dataset.md, "The elevation-interpolation band"). These samples
    give the band the radiance at the same angle from the sun on this state's own solar vertical, on the same side
    (view zenith zs -+ gamma, relative azimuth 0): near the sun the sky is close to symmetric about the sun, so
    each state then answers the band as its sky would with the sun moved there, and the blend of two states is the
    blend of their aureoles at the same gamma.

    Parameters
    ----------
    zenith_deg (T,), azimuth_deg (P,) [deg]: the solved product grid (it holds relative azimuth 0);
    radiance (T, P, C) [W m-2 sr-1 nm-1] on it; solar_elevation_deg [deg]; deltas_deg (up, down) [deg]
    (:func:`band_deltas`); max_gamma_deg [deg]: the band is sampled out to this angle from the sun
    (:data:`BAND_GAMMAS_DEG`, at the view zeniths of the grid).

    Returns
    -------
    dict: gamma, alpha, zero (m,) [rad] (the fit's angles), values (m, C) [W m-2 sr-1 nm-1]; m may be 0.
    """
    from scipy.interpolate import PchipInterpolator

    th = np.asarray(zenith_deg, float)
    ph = np.asarray(azimuth_deg, float)
    rad = np.asarray(radiance, float)
    zs = 90.0 - float(solar_elevation_deg)
    if ph[0] != 0.0:
        raise ValueError("band_samples: the grid's first relative azimuth must be 0 (the solar vertical)")
    column = PchipInterpolator(th, np.log(np.maximum(rad[:, 0, :], 1e-300)), axis=0, extrapolate=False)
    gam = BAND_GAMMAS_DEG[BAND_GAMMAS_DEG <= float(max_gamma_deg)]
    rows_g, rows_t = [], []
    for t in th:
        d = abs(t - zs)
        delta = deltas_deg[0] if t < zs else deltas_deg[1]
        for g in gam[(gam < d) & (gam >= d - delta)]:
            tb = zs - g if t < zs else zs + g           # the same angle from the sun on the solar vertical
            if th[0] <= tb <= th[-1]:
                rows_g.append(g)
                rows_t.append((t, tb))
    if not rows_g:
        empty = np.zeros(0)
        return {"gamma": empty, "alpha": empty, "zero": empty, "values": np.zeros((0,) + rad.shape[2:])}
    t_view = np.array([r[0] for r in rows_t])
    t_on = np.array([r[1] for r in rows_t])
    # the fit's zenith angles of the band's view zeniths (the altitude-corrected zenith, as the evaluator computes it)
    zero = reference_angles(directions_from_angles(t_view, np.full(len(t_view), 90.0)), float(solar_elevation_deg),
                            180.0)["zero"]
    values = np.exp(column(t_on))
    return {"gamma": np.radians(np.array(rows_g)), "alpha": zero, "zero": zero, "values": values}


# --------------------------------------------------------------------------------------------- solving


def radiance_with_albedo(solved: dict, ground: dict, albedo: float) -> np.ndarray:
    """Sky radiance of a black-ground solution ``solved`` (:func:`solve_state`) over a Lambertian ground of
    albedo ``albedo`` [1], from the ground response ``ground`` (:func:`solve_ground`) of the same visibility.

    Returns
    -------
    (T, P, 55) [W m-2 sr-1 nm-1]
    """
    a = float(albedo)
    out = np.array(solved["radiance"], float, copy=True)
    if a == 0.0:
        return out
    th = np.asarray(solved["zenith"], float)
    for c in range(55):
        w = np.asarray(ground["weights"][c])
        e0 = np.asarray(solved["e0"][c])
        if len(w) == 0:
            continue
        tk = np.asarray(ground["t"][c])
        t_th = np.stack([np.interp(th, ground["zenith"], tk[k]) for k in range(len(w))])  # (K, T)
        coef = w * e0 * a / (np.pi * (1.0 - a * np.asarray(ground["s"][c])))
        out[:, :, c] += (solved["et"][c] * (coef @ t_th))[:, None]
    return out


def _job_file(job) -> Path:
    kind, config, vis, ele, extra = job
    if kind == "ground":
        return ground_file(config, vis)
    if kind == "mc":
        return mc_file(config, vis, ele)
    if kind.startswith("val_"):
        return validation_file(config, kind[4:], vis, ele, extra)
    return state_file(config, vis, ele, kind, extra)


def _solve_job(job):
    kind, config, vis, ele, extra = job
    if kind == "mc":
        path = _job_file(job)
        if not path.exists():
            save_state(path, solve_mc_state(vis, ele, config))
        return kind, vis, ele, path
    if kind == "ground":
        path = ground_file(config, vis)
        if not path.exists():
            save_state(path, solve_ground(vis, config))
        return kind, vis, ele, path
    path = _job_file(job)
    if not path.exists():
        if kind.startswith("val_") and path.name.startswith("mcval_"):
            d = solve_split_validation(vis, ele, extra, config)
        elif kind == "fit":
            d = solve_state(vis, max(ele, config.min_solve_elevation_deg), config)
            d["solved_elevation"] = max(ele, config.min_solve_elevation_deg)
        else:  # validation state: its own albedo, held-out directions
            th, ph = validation_directions(ele)
            d = solve_state(vis, ele, config, th, ph, albedo=extra)
            d["solved_elevation"] = ele
            d["albedo"] = extra
        save_state(path, d)
    return kind, vis, ele, path


def state_radiance(config: BuildConfig, visibility_km: float, elevation_deg: float, albedo: float):
    """Cached solver radiance of a grid state at ``albedo`` [1]: (zenith (T,) [deg], azimuth (P,) [deg],
    radiance (T, P, 55) [W m-2 sr-1 nm-1], solved elevation [deg]); from the Monte Carlo state where the configuration
    takes that elevation's radiance from it."""
    if radiance_by_mc(config, elevation_deg):
        m = load_state(mc_file(config, visibility_km, elevation_deg))
        th, ph = fit_grid(m, config)
        if "single_fine" in m:  # split: the rest smoothed across the elevation's visibilities
            i = [float(v) for v in config.visibilities_km].index(float(visibility_km))
            rest = cached_rest_across_visibility(config, elevation_deg, albedo)[i]
            return th, ph, split_radiance(m, albedo, rest=rest), float(m["solved_elevation"])
        i = mc_stokes(m, albedo)[0][..., 0]
        if config.mc_fit_resample:
            i = resample_radiance(m["zenith"], m["azimuth"], i, th, ph)
        return th, ph, i, float(m["solved_elevation"])
    s = load_state(state_file(config, visibility_km, elevation_deg))
    g = load_state(ground_file(config, visibility_km))
    return s["zenith"], s["azimuth"], radiance_with_albedo(s, g, albedo), float(s["solved_elevation"])


def solve_all(config: BuildConfig, processes: int = 2, progress: bool = True, validation: bool = True,
              log=None):
    """Solve (or find in the cache) every grid state, ground response and validation state of ``config``; the
    Monte Carlo states (:mod:`widesky.skymodel.generator.dataset_mc`), the longest tasks, go first; the split validation
    states, which read every visibility's Monte Carlo state of their elevation, run after all of them."""
    fitted = _fitted_elevations(config)
    jobs = [("mc", config, float(v), float(e), None) for e in fitted if needs_mc_state(config, e)
            for v in config.visibilities_km]
    disort = [e for e in fitted if not radiance_by_mc(config, e)]
    if disort or validation:
        jobs += [("ground", config, float(v), 0.0, None) for v in config.visibilities_km]
    # lowest elevations first within each visibility is irrelevant; interleave for balance
    # grid elevations above max_fit_elevation_deg hold the fit of the highest one below (see assemble): not solved
    jobs += [("fit", config, float(v), float(e), None) for e in disort for v in config.visibilities_km]
    if validation:
        jobs += [("val_" + k, config, v, e, a) for k, v, e, a in validation_states(config)]
    todo = [j for j in jobs if not _job_file(j).exists()]
    todo = list({(j[0], j[2], j[3], j[4]): j for j in todo}.values())
    if log:
        log(f"solve: {len(jobs) - len(todo)} of {len(jobs)} states cached in {cache_root(config)}")
    t0 = time.perf_counter()
    # split validation states at grid points read every visibility's Monte Carlo state of their elevation
    # (rest_across_visibility): they run after the grid states have all been solved
    later = [j for j in todo if j[0].startswith("val_") and split_state(config, j[3])]
    phases = [[j for j in todo if j not in later], later]
    done = 0
    for phase in (ph for ph in phases if ph):
        for r in pool_map(_solve_job, phase, processes, progress, "solve"):
            done += 1
            if log:
                log(f"solved {r[0]} vis={r[1]} ele={r[2]} ({done}/{len(todo)}, {time.perf_counter() - t0:.0f} s)")
    return len(todo), time.perf_counter() - t0


# --------------------------------------------------------------------------------------------- fitting


def config_knots(config: BuildConfig):
    """(sun_breaks, zenith_breaks, emph_breaks) [rad] of ``config``: gamma knots dense near the sun, zenith and
    emphasis knots (altitude-corrected view zenith ``zero``) dense near the horizon, up to pi/2; with
    ``sun_knot_midpoints_deg`` (lo, hi) [deg] the sun-knot intervals inside it are halved (:func:`with_midpoints`:
    the aureole of a low sun, where the product form's piecewise-linear factors otherwise scallop along the rays from
    the sun; docs/default-dataset.md, "Sun knots near a low sun"), and with ``zenith_knot_midpoints_deg`` (lo, hi)
    [deg] likewise the zenith-knot intervals inside it (the last degrees above the horizon, where the low-sun sky's
    aureole, horizon band and Earth's shadow share the zenith factors; "Zenith knots above the horizon")."""
    ns, nz, ne = (int(x) for x in config.knots)
    ps, pz, pe = (float(x) for x in config.knot_powers)
    sb = knots(ns, 0.0, np.pi, ps, "lo")
    if config.sun_knot_midpoints_deg is not None:
        sb = with_midpoints(sb, *np.radians(np.asarray(config.sun_knot_midpoints_deg, float)))
    if config.sun_knot_refine_deg is not None:  # a second halving inside the first
        sb = with_midpoints(sb, *np.radians(np.asarray(config.sun_knot_refine_deg, float)))
    zb = knots(nz, 0.0, 0.5 * np.pi, pz, "hi")
    if config.zenith_knot_midpoints_deg is not None:
        zb = with_midpoints(zb, *np.radians(np.asarray(config.zenith_knot_midpoints_deg, float)))
    return (sb, zb, knots(ne, 0.0, 0.5 * np.pi, pe, "hi"))


def neighbour_pairs(n_zenith: int, n_azimuth: int) -> np.ndarray:
    """Index pairs (k, 2) of neighbouring samples of a (zenith x azimuth) product grid flattened row-major: along each
    almucantar (azimuth neighbours), then along each vertical (zenith neighbours)."""
    idx = np.arange(n_zenith * n_azimuth).reshape(n_zenith, n_azimuth)
    return np.concatenate([np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1),
                           np.stack([idx[:-1].ravel(), idx[1:].ravel()], 1)])


def fit_sky(radiance, samples, breaks, rank, smoothing=1e-6, iterations=4, refine=2, sun_penalty_order=1, band=None,
            band_weight=1.0, **fit_kw):
    """Fit every channel of one configuration.

    Parameters
    ----------
    radiance : (T, P, C) [W m-2 sr-1 nm-1] on the grid of ``samples`` (:func:`direction_samples`).
    breaks : (sun, zenith, emph) knots [rad]; rank : int.
    band : optional :func:`band_samples` dict, fitted too, each with ``band_weight`` times the smallest fit weight of
        the grid's samples (not counted in ``nmae``).
    fit_kw : further keyword arguments of :func:`widesky.skymodel.generator.fit.fit_radiance` (:func:`fit_options`); with
        ``sobolev`` the neighbour pairs of the (T, P) grid (:func:`neighbour_pairs`) are added.

    Returns
    -------
    sun (C, rank, nSun), zen (C, rank, nZen), emph (C, nEmph), nmae (C,) [1] on the samples (solid-angle weighted).
    """
    y = np.asarray(radiance, float).reshape(-1, radiance.shape[-1])
    C = y.shape[1]
    sb, zb, eb = breaks
    w = fit_weights(samples["weights"])
    sun = np.zeros((C, rank, len(sb)))
    zen = np.zeros((C, rank, len(zb)))
    emph = np.ones((C, len(eb)))
    nmae = np.zeros(C)
    if fit_kw.get("sobolev", 0) > 0 and "pairs" not in fit_kw:
        if np.ndim(radiance) != 3:
            raise ValueError(f"sobolev needs the radiance on its (zenith, azimuth) grid, got shape "
                             f"{np.shape(radiance)}")
        fit_kw = dict(fit_kw, pairs=neighbour_pairs(*radiance.shape[:2]))
    alpha = samples.get("alpha", samples["zero"])
    gam, alp, zer, wall = samples["gamma"], alpha, samples["zero"], w
    yb = np.zeros((0, C))
    if band is not None and len(band["gamma"]):
        gam, alp, zer = (np.concatenate([a, band[k]]) for a, k in ((gam, "gamma"), (alp, "alpha"), (zer, "zero")))
        wall = np.concatenate([w, np.full(len(band["gamma"]), float(band_weight) * w.min())])
        yb = np.asarray(band["values"], float).reshape(len(band["gamma"]), C)
    for c in range(C):
        if not np.any(y[:, c] > 0):
            continue
        f = fit_radiance(gam, alp, zer, np.concatenate([y[:, c], yb[:, c]]), sb, zb, eb, rank,
                         weights=wall, smoothing=smoothing, iterations=iterations, refine=refine,
                         sun_penalty_order=sun_penalty_order, **fit_kw)
        sun[c], zen[c], emph[c] = f.sun, f.zen, f.emph
        pred = f.evaluate(samples["gamma"], alpha, samples["zero"], sb, zb, eb)
        sw = samples["weights"]
        nmae[c] = np.sum(sw * np.abs(pred - y[:, c])) / max(np.sum(sw * np.abs(y[:, c])), 1e-300)
    return sun, zen, emph, nmae


def fit_state(config: BuildConfig, zenith_deg, azimuth_deg, radiance, solar_elevation_deg: float, breaks=None,
              grid_elevation_deg=None):
    """:func:`fit_sky` of one state's radiance (T, P, C) [W m-2 sr-1 nm-1], solved on the product grid ``zenith_deg``
    (T,) x ``azimuth_deg`` (P,) [deg] at ``solar_elevation_deg`` [deg], with the settings of ``config``: its knots (or
    ``breaks``), rank, penalties and fit terms, on its fit samples (:func:`fit_samples`) and, with
    ``band_max_gamma_deg`` set, the elevation-interpolation band (:func:`band_samples`) toward the neighbours of grid
    elevation ``grid_elevation_deg`` [deg] (default ``solar_elevation_deg``). Returns fit_sky's (sun, zen, emph,
    nmae)."""
    t2, p2, rad = fit_samples(config, zenith_deg, azimuth_deg, radiance, solar_elevation_deg)
    br = config_knots(config) if breaks is None else breaks
    band = None
    e = solar_elevation_deg if grid_elevation_deg is None else grid_elevation_deg
    if has_band(config, e):
        band = band_samples(zenith_deg, azimuth_deg, radiance, solar_elevation_deg, band_deltas(config, e),
                            float(config.band_max_gamma_deg))
    return fit_sky(rad, direction_samples(t2, p2, solar_elevation_deg), br, config.rank, config.smoothing,
                   config.iterations, config.refine, config.sun_penalty_order, band=band,
                   band_weight=float(config.band_weight), **fit_options(config))


def fit_options(config: BuildConfig) -> dict:
    """The fit's optional terms that ``config`` sets (keyword arguments of :func:`fit_sky`; empty for a configuration
    without them, which fits as the builds before them did): relative weighting (``relative_power``,
    ``relative_floor``) and the Sobolev term (``sobolev``)."""
    d = {}
    if float(config.relative_power) != 0.0:
        d.update(relative_power=float(config.relative_power), relative_floor=float(config.relative_floor))
    if float(config.sobolev) != 0.0:
        d["sobolev"] = float(config.sobolev)
    return d


def fit_file(config: BuildConfig, visibility_km: float, elevation_deg: float) -> Path:
    """Cache file of one grid state's fitted factors (depends on knots, rank and albedos too)."""
    d = {"knots": list(config.knots), "powers": list(config.knot_powers), "rank": config.rank,
         "smoothing": config.smoothing, "iterations": config.iterations, "refine": config.refine,
         "albedos": list(config.albedos), "v": 1}
    if config.sun_penalty_order != 1:  # (absent for first-order builds: their cached fits keep their names)
        d["sun_penalty_order"] = config.sun_penalty_order
    if config.sun_knot_midpoints_deg is not None:  # likewise
        d["sun_knot_midpoints_deg"] = [float(x) for x in config.sun_knot_midpoints_deg]
    if config.sun_knot_refine_deg is not None:  # likewise
        d["sun_knot_refine_deg"] = [float(x) for x in config.sun_knot_refine_deg]
    if config.zenith_knot_midpoints_deg is not None:  # likewise
        d["zenith_knot_midpoints_deg"] = [float(x) for x in config.zenith_knot_midpoints_deg]
        d["zenith_fill"] = 1  # the fit samples of zenith_fill (a trial without them is not this fit)
    if has_band(config, elevation_deg):  # likewise (and a state without the band keeps its band-free name)
        d["band"] = [float(config.band_max_gamma_deg), float(config.band_weight), BAND_GAMMAS_DEG.tolist(),
                     list(config.elevations_deg)]
    d.update(fit_options(config))  # likewise: only the options a configuration sets

    # only where the state uses the Monte Carlo solver: a scalar configuration keeps its fit-cache names, and so do the
    # DISORT states of a build whose low sun alone comes from the Monte Carlo (every state of a polarised build has one)
    if uses_mc(config) and needs_mc_state(config, elevation_deg):
        d["mc"] = {"key": mc_key(config), "below": config.mc_below_elevation_deg,
                   "polarisation": bool(config.polarisation), "pol_knots": list(config.pol_knots),
                   "pol_rank": int(config.pol_rank)}
        if config.mc_fit_resample:  # (absent otherwise: the earlier polarised fits keep their names)
            d["mc"]["resample"] = True
        if config.mc_single_scatter_exact:
            d["mc"]["split"] = SPLIT_SMOOTHING
    key = hashlib.sha1(json.dumps(d, sort_keys=True).encode()).hexdigest()[:10]
    return cache_root(config) / f"fitted_{key}_v{visibility_km:.4f}_e{elevation_deg:.4f}.npz"


def _fit_job(job):
    config, vis, ele = job
    path = fit_file(config, vis, ele)
    if path.exists():
        return vis, ele, path

    breaks = config_knots(config)
    m = load_state(mc_file(config, vis, ele)) if needs_mc_state(config, ele) else None
    if radiance_by_mc(config, ele):
        (zen_deg, az_deg), solved = fit_grid(m, config), float(m["solved_elevation"])

        def radiance(a):
            return state_radiance(config, vis, ele, a)[2]
    else:
        s = load_state(state_file(config, vis, ele))
        g = load_state(ground_file(config, vis))
        zen_deg, az_deg, solved = s["zenith"], s["azimuth"], float(s["solved_elevation"])

        def radiance(a):
            return radiance_with_albedo(s, g, a)
    out = {k: [] for k in ("sun", "zen", "emph", "nmae")}
    for a in config.albedos:
        fitted = fit_state(config, zen_deg, az_deg, radiance(a), solved, breaks, grid_elevation_deg=ele)
        for k, v in zip(("sun", "zen", "emph", "nmae"), fitted):
            out[k].append(v)
    if config.polarisation:
        out.update(_fit_polarisation_state(config, m))
    save_state(path, {k: np.stack(v) for k, v in out.items()})
    return vis, ele, path


def _fit_polarisation_state(config, m) -> dict:
    """Polarisation factors of one Monte Carlo state for every albedo of the grid, with the fit's error and the
    state's noise and polarisation figures (lists over albedos, each (C, ...))."""
    samples = direction_samples(m["zenith"], m["azimuth"], float(m["solved_elevation"]))
    out = {k: [] for k in ("psun", "pzen", "pmae", "pse", "dolp", "abs_qs", "docp")}
    for a in config.albedos:
        p, _ = stored_polarisation(m, a)
        psun, pzen, mae = fit_polarisation(p, samples, pol_knots(config), int(config.pol_rank))
        summ = polarisation_summary(m, a)
        for k, v in (("psun", psun), ("pzen", pzen), ("pmae", mae), ("pse", summ["se_p"]), ("dolp", summ["dolp"]),
                     ("abs_qs", summ["abs_qs"]), ("docp", summ["docp"])):
            out[k].append(np.asarray(v))
    return out


def _fitted_elevations(config: BuildConfig) -> list:
    """Grid elevations [deg] that are solved and fitted (those up to ``max_fit_elevation_deg``; at least the lowest)."""
    ele = [float(e) for e in config.elevations_deg]
    ok = [e for e in ele if e <= config.max_fit_elevation_deg]
    return ok or ele[:1]


FIT_KEYS = ("sun", "zen", "emph", "nmae", "psun", "pzen", "pmae", "pse", "dolp", "abs_qs", "docp")
"""Arrays of a fitted state: radiance factors and error, then (polarised builds) the polarisation factors, their
fit error, noise and figures (:func:`_fit_polarisation_state`)."""


def fit_all(config: BuildConfig, processes=2, progress=True, log=None):
    """Fit every grid state (cached); returns sun, zen, emph arrays of grid shape G + (...) and nmae G. Elevations above
    ``max_fit_elevation_deg`` take the fit of the highest fitted elevation (:func:`assemble` explains why)."""
    fitted_ele = _fitted_elevations(config)
    jobs = [(config, float(v), float(e)) for v in config.visibilities_km for e in fitted_ele]
    todo = [j for j in jobs if not fit_file(config, j[1], j[2]).exists()]
    t0 = time.perf_counter()
    for i, r in enumerate(pool_map(_fit_job, todo, processes, progress, "fit")):
        if log and (i % 10 == 0 or i == len(todo) - 1):
            log(f"fitted vis={r[0]} ele={r[1]} ({i + 1}/{len(todo)}, {time.perf_counter() - t0:.0f} s)")
    nv, na, ne = len(config.visibilities_km), len(config.albedos), len(config.elevations_deg)
    res = {}
    for iv, v in enumerate(config.visibilities_km):
        for ie, e in enumerate(config.elevations_deg):
            e_fit = max([x for x in fitted_ele if x <= float(e)] or fitted_ele[:1])
            d = load_state(fit_file(config, float(v), e_fit))
            for k in [k for k in FIT_KEYS if k in d]:
                x = d[k]  # (nAlb, C, ...)
                if k not in res:
                    res[k] = np.zeros((nv, na, 1, ne) + x.shape[1:])
                res[k][iv, :, 0, ie] = x
    return res


# --------------------------------------------------------------------------------------------- transmittance

def segment_path_factors(levels_km, observer_altitude_m, target_altitude_m, ground_distance_m,
                         earth_radius_m: float = PLANET_RADIUS_M) -> np.ndarray:
    """Geometric length of the straight segment from an observer to a target point inside each spherical shell,
    divided by the shell's thickness (no refraction).

    Parameters
    ----------
    levels_km : (L+1,) level altitudes [km], ground first.
    observer_altitude_m : float [m].
    target_altitude_m, ground_distance_m : array_like (N,) altitude [m] and great-circle ground distance [m] of
        the target from the observer.
    earth_radius_m : [m].

    Returns
    -------
    (N, L) [1]. Parts of a segment below the ground (targets below the observer's horizon, which no ray
    reaches) count as the lowest layer, so the table stays continuous there. Nothing above the top level counts.
    """
    r_lev = earth_radius_m + 1000.0 * np.asarray(levels_km, float)
    ha = np.atleast_1d(np.asarray(target_altitude_m, float))
    gd = np.atleast_1d(np.asarray(ground_distance_m, float))
    ro = earth_radius_m + float(observer_altitude_m)
    ang = gd / earth_radius_m
    rt = earth_radius_m + ha
    O = np.stack([np.zeros_like(ang), np.full_like(ang, ro)], axis=-1)
    Pt = np.stack([rt * np.sin(ang), rt * np.cos(ang)], axis=-1)
    dvec = Pt - O
    length = np.linalg.norm(dvec, axis=-1)
    u = dvec / np.maximum(length, 1e-9)[:, None]
    t0 = -np.einsum("ij,ij->i", O, u)           # parameter of the closest approach to the centre
    b2 = np.maximum(ro * ro - t0 * t0, 0.0)     # squared impact parameter

    def inside(r):  # length of the segment [0, length] with radius < r, shape (N, len(r))
        q = np.sqrt(np.maximum(r[None, :] ** 2 - b2[:, None], 0.0))
        lo = np.maximum(0.0, t0[:, None] - q)
        hi = np.minimum(length[:, None], t0[:, None] + q)
        return np.maximum(hi - lo, 0.0)

    cum = inside(r_lev)
    cum[:, 0] = 0.0  # below the ground counts as the lowest layer
    seg = np.diff(cum, axis=1)
    return seg / np.diff(r_lev)[None, :]


def transmittance_grid(d_dim: int, a_dim: int):
    """Target points of the format's transmittance samples: altitude (aDim,) [m] and ground distance (dDim,) [m].

    Sample i of n sits at parameter i / n (altitude = a^3 x 100 km, distance = d^4 x 1 571 524.4 m), except the last
    altitude sample, which sits at the top of the atmosphere (a = 1): the evaluator uses that sample, with factor 0,
    for every point above ((n - 1) / n)^3 x 100 km, in particular for the top-of-atmosphere end of every infinite
    path (the sun's direct beam)."""
    a = np.arange(a_dim) / a_dim
    a[-1] = 1.0
    d = np.arange(d_dim) / d_dim
    return a ** 3 * ATMOSPHERE_TOP_M, d ** 4 * DIST_TO_EDGE_M


def transmittance_samples(visibility_km: float, config: BuildConfig, observer_altitude_m: float = 0.0,
                          data_dir=None) -> np.ndarray:
    """sqrt of the band transmittance [1] on the format's grid for one visibility: shape (55, dDim, aDim).

    Band transmittance per channel: sum over the solver's sub-problems of weight x exp(-optical path) (the
    solver's direct-beam rule), along straight segments (:func:`segment_path_factors`)."""
    probs, _, atm = _problems(visibility_km, config, data_dir)
    d_dim, a_dim = (int(x) for x in config.trans_dims)
    alt, dist = transmittance_grid(d_dim, a_dim)
    D, A = np.meshgrid(dist, alt, indexing="ij")
    f = segment_path_factors(atm.levels_km, observer_altitude_m, A.ravel(), D.ravel())  # (N, L)
    out = np.zeros((55, d_dim * a_dim))
    for c in range(55):
        for p in probs[c]:
            out[c] += p.weight * np.exp(-(f @ p.tau_total))
    return np.sqrt(np.clip(out, 0.0, 1.0)).reshape(55, d_dim, a_dim)


def fit_transmittance_bounded(sqrt_t, rank):
    """:func:`widesky.skymodel.generator.fit.fit_transmittance` plus one constant basis column and a per-(visibility, channel)
    rescale that keep U . V inside [0, 1] at every sample (the format's requirement).

    Returns U (nAltT, dDim, aDim, rank + 1), V (nVisT, nAltT, nCh, rank + 1) float32 and the largest
    |U . V - sqrt(T)| [1]."""
    x = np.asarray(sqrt_t, float)
    U, V, _ = fit_transmittance(x, rank)
    U = np.concatenate([U.astype(np.float64), np.ones(U.shape[:-1] + (1,))], axis=-1)
    V = np.concatenate([V.astype(np.float64), np.zeros(V.shape[:-1] + (1,))], axis=-1)
    for _ in range(3):
        rec = np.einsum("ldar,vlcr->vlcda", U, V)
        lo = rec.min(axis=(-2, -1))
        V[..., -1] += np.maximum(-lo, 0.0) + 2e-7 * (lo < 0)
        rec = np.einsum("ldar,vlcr->vlcda", U, V)
        hi = rec.max(axis=(-2, -1))
        V *= np.where(hi > 1.0 - 1e-7, (1.0 - 1e-7) / np.maximum(hi, 1e-300), 1.0)[..., None]
        U32, V32 = U.astype(np.float32), V.astype(np.float32)
        rec32 = np.einsum("ldar,vlcr->vlcda", U32.astype(np.float64), V32.astype(np.float64))
        if rec32.min() >= -1e-7 and rec32.max() <= 1.0 + 1e-7:
            break
    err = float(np.abs(rec32 - x).max())
    return U32, V32, err


# --------------------------------------------------------------------------------------------- assembly

def _versions() -> dict:
    out = {}
    for name in ("widesky", "numpy", "scipy", "disortpp", "miepython", "Py6S"):
        try:
            out[name] = md.version(name)
        except md.PackageNotFoundError:
            out[name] = None
    return out


def extraterrestrial_table(config: BuildConfig, data_dir=None):
    """The solver's extraterrestrial spectrum at 1 nm for the sidecar: wavelength (2202,) [nm] (bin centres
    280.5-2479.5 plus the edges 280 and 2480, holding the end bins' values) and irradiance [W m-2 nm-1]."""
    _, et = extraterrestrial_spectrum(config.spec().et_source, data_dir)
    wl = np.concatenate([[280.0], FINE_WAVELENGTHS_NM, [2480.0]])
    e = np.concatenate([[et[0]], et, [et[-1]]])
    return wl, e


def _low_sun_note(config: BuildConfig) -> str:
    if config.mc_below_elevation_deg is not None and config.mc_single_scatter_exact:
        return (f"grid elevations below {config.mc_below_elevation_deg} deg take their sky radiance from spherical "
                "shells, solved at their own elevation: single scattering exact (deterministic quadrature) on the fit "
                "grid, higher orders and ground-reflected light from the scalar Monte Carlo solver, smoothed "
                "(the plane-parallel sky-diffuse irradiance is 0.3-0.8x the spherical one below 3 deg: "
                "docs/default-dataset.md, 'Low sun in spherical shells')")
    if config.mc_below_elevation_deg is not None:
        return (f"grid elevations below {config.mc_below_elevation_deg} deg take their sky radiance from the Monte "
                "Carlo solver in spherical shells, solved at their own elevation (twilight included)")
    return (f"grid elevations below {config.min_solve_elevation_deg} deg hold the sky solved at "
            f"{config.min_solve_elevation_deg} deg; plane-parallel diffuse is unreliable below "
            "about 3 deg (docs/default-dataset.md)")


def assemble(config: BuildConfig, output, processes=2, progress=True, log=None, data_dir=None) -> dict:
    """Fit (cached) and write the dataset file ``output`` and its sidecar ``<output>.json``; the grid states must
    be solved already (:func:`solve_all`). Returns the sidecar dict."""
    t0 = time.perf_counter()
    fitted = fit_all(config, processes, progress, log)
    ele = np.asarray(config.elevations_deg, float)
    src = np.nonzero(ele <= config.max_fit_elevation_deg)[0]
    if len(src) and src[-1] < len(ele) - 1:
        # near the zenith sun gamma ~ zero: the two factors are not separately determined there, and interpolating
        # toward such a configuration fails off the diagonal (measured: 50 % NMAE at 86.9 deg). Those grid
        # elevations hold the factors fitted at the highest elevation below the limit (about 1 % NMAE on the
        # zenith-sun sky, measured).
        for k in [k for k in ("sun", "zen", "emph", "psun", "pzen") if k in fitted]:
            fitted[k][:, :, :, src[-1] + 1:] = fitted[k][:, :, :, src[-1]: src[-1] + 1]
        if log:
            log(f"elevations {ele[src[-1] + 1:].tolist()} deg hold the fit at {ele[src[-1]]} deg")
    sb, zb, eb = config_knots(config)
    # transmittance
    sq = np.stack([transmittance_samples(v, config, 0.0, data_dir) for v in config.visibilities_km])[:, None]
    U, V, terr = fit_transmittance_bounded(sq, int(config.trans_rank))
    if log:
        log(f"transmittance: rank {config.trans_rank}+1, max |sqrt(T) error| {terr:.2e}")
    sun = fitted["sun"]
    pol = {}
    if config.polarisation:
        psb, pzb = pol_knots(config)
        pol = dict(pol_sun_breaks=psb, pol_zenith_breaks=pzb, pol_sun=fitted["psun"], pol_zen=fitted["pzen"])
    c = DatasetContents(np.asarray(config.visibilities_km, float), np.asarray(config.albedos, float),
                        np.array([0.0]), np.asarray(config.elevations_deg, float), 280.0, 40.0, sb, zb, eb,
                        sun, fitted["zen"], fitted["emph"], np.array([0.0], np.float32),
                        np.asarray(config.visibilities_km, np.float32), U, V, **pol)
    output = Path(output)
    write_dataset(output, c)
    wl, et = extraterrestrial_table(config, data_dir)
    nm = fitted["nmae"]  # (nVis, nAlb, 1, nEle, C)
    meta = {
        "synthetic": False,
        "description": config.description,
        "generator": "widesky.skymodel.generator.dataset_build (widesky dataset build)",
        "config": config.to_dict(),
        "versions": _versions(),
        "solver": {"method": "plane-parallel DISORT (disortpp), Buras-Emde intensity correction with the tabulated "
                             "phase function",
                   "n_streams": config.n_streams, "n_moments": config.n_moments,
                   "atmosphere": {k: (list(v) if isinstance(v, tuple) else v)
                                  for k, v in asdict(config.spec()).items()},
                   "low_sun": _low_sun_note(config)},
        "grids": {"visibilities_km": list(config.visibilities_km), "albedos": list(config.albedos),
                  "altitudes_m": [0.0], "elevations_deg": list(config.elevations_deg),
                  "sun_breaks_rad": sb.tolist(), "zenith_breaks_rad": zb.tolist(), "emph_breaks_rad": eb.tolist(),
                  "rank": config.rank, "trans_dims": list(config.trans_dims), "trans_rank": config.trans_rank + 1},
        "fit_on_samples": {"nmae_mean": float(nm.mean()), "nmae_median_per_channel":
                           np.median(nm.reshape(-1, nm.shape[-1]), axis=0).round(5).tolist(),
                           "transmittance_max_abs_sqrt_error": terr},
        "extraterrestrial": {"source": config.spec().et_source, "wavelength": wl.round(2).tolist(),
                             "irradiance": [float(f"{x:.6g}") for x in et]},
        "file_bytes": output.stat().st_size,
        "assemble_seconds": round(time.perf_counter() - t0, 1),
    }

    if uses_mc(config):
        meta["monte_carlo"] = _mc_meta(config, fitted)
    output.with_name(output.name + ".json").write_text(json.dumps(meta, indent=1))
    return meta


def _mc_meta(config: BuildConfig, fitted: dict) -> dict:
    """Sidecar section of a build that uses the Monte Carlo solver: its settings, which elevations it solved, and
    (polarised builds) the polarisation fit's error and the Monte Carlo noise per channel."""
    ele = [float(e) for e in config.elevations_deg]

    split = bool(config.mc_single_scatter_exact)
    d = {"method": ("scalar" if split else "polarised")
         + " backward Monte Carlo in spherical shells (skymodel.generator.montecarlo), "
                   "next-event estimation, hero-wavelength batches; all albedos from one run by order of ground "
                   f"reflection; estimator: first order {MC_FIRST_ORDER['radiance']} (with sunlit-importance "
                   "paths) where the Monte Carlo gives the radiance, first order "
                   f"{MC_FIRST_ORDER['polarisation']} where it gives only the polarisation; "
                   f"{config.mc_streams} random streams"
                   + (" (common random numbers across the directions of a state)"
                      if config.mc_streams == "correlated" else " (one per direction)")
                   + ("; radiance fitted on the DISORT fit grid after a monotone piecewise-cubic interpolation of "
                      "each state" if config.mc_fit_resample else "; radiance fitted on each state's own grid")
                   + ("; split: single scattering exact (the first-order quadrature, deterministic) on the DISORT "
                      "fit grid, the rest (orders >= 2, ground-reflected light) from the Monte Carlo grid, smoothed "
                      f"({SPLIT_SMOOTHING}: cosine series to order 2 in azimuth, each term sin^m(zenith) times an "
                      "even smoothing spline in zenith, regular at the zenith; then a cubic in log visibility across "
                      "the elevation's states)"
                      if split else ""),
         "streams": config.mc_streams, "fit_resample": bool(config.mc_fit_resample), "single_scatter_exact": split,
         "key": mc_key(config), "samples_per_direction_and_batch": int(config.mc_samples),
         "channels_per_batch": int(config.mc_channels_per_batch), "ground_orders": int(config.mc_ground_orders),
         "zenith_step_deg": float(config.mc_zenith_step_deg), "seed": int(config.mc_seed),
         "radiance_elevations_deg": [e for e in ele if radiance_by_mc(config, e)],
         "disort_elevations_deg": [e for e in ele if not radiance_by_mc(config, e)]}
    if config.polarisation:
        psb, pzb = pol_knots(config)
        per_ch = lambda k: np.median(fitted[k].reshape(-1, fitted[k].shape[-1]), axis=0).round(5).tolist()  # noqa
        d["polarisation"] = {
            "stored": "P = Q_s / I with Q_s referred to the scattering plane; readers return -P, the signed degree of "
                      "linear polarisation (docs/atmosphere-and-solver.md)",
            "rank": int(config.pol_rank), "sun_breaks_rad": psb.tolist(), "zenith_breaks_rad": pzb.tolist(),
            "fit_mae_mean": float(fitted["pmae"].mean()), "fit_mae_median_per_channel": per_ch("pmae"),
            "mc_se_mean": float(fitted["pse"].mean()), "mc_se_median_per_channel": per_ch("pse"),
            "dolp_mean_per_channel": per_ch("dolp"), "abs_qs_over_i_mean_per_channel": per_ch("abs_qs"),
            "docp_mean_per_channel": per_ch("docp")}
    return d


def solver_reference(config: BuildConfig, progress: bool = False, rel_tol: float | None = None,
                     floor_fraction: float | None = None) -> list:
    """The solver's own turning points along the smoothness check's profiles at every grid state, where they exceed
    the check's limits (:func:`widesky.skymodel.generator.smoothness.reference_entries` rows; from the cached solves). Only
    grid states that hold the sky solved at their own elevation count: the 0 deg states of a DISORT build (a sky
    solved at ``min_solve_elevation_deg``), those above ``max_fit_elevation_deg`` (the highest fit) and those whose
    radiance comes from the Monte Carlo solution (its noise is not the sky's shape) get no allowance, except the split
    Monte Carlo states (:func:`widesky.skymodel.generator.dataset_mc.split_radiance`: their structure is the exact single
    scattering, the noise only in the smooth rest), which are solved at their own elevation. The solver's turning
    points are counted with the guard band (:data:`widesky.skymodel.generator.smoothness.REFERENCE_REL_TOL` and
    ``REFERENCE_FLOOR_FRACTION``) unless ``rel_tol`` / ``floor_fraction`` [1] say otherwise."""
    tol = REFERENCE_REL_TOL if rel_tol is None else rel_tol
    floor = REFERENCE_FLOOR_FRACTION if floor_fraction is None else floor_fraction
    fitted = _fitted_elevations(config)
    ref = {}
    jobs = [(float(v), float(e)) for v in config.visibilities_km for e in config.elevations_deg]
    for v, e in tqdm(jobs, desc="solver reference", disable=not progress):
        e_fit = max([x for x in fitted if x <= e] or fitted[:1])
        own = split_state(config, e) if radiance_by_mc(config, e) else e >= config.min_solve_elevation_deg
        if e_fit != e or not own:
            continue
        for a in config.albedos:
            zen, az, rad, solved = state_radiance(config, v, e, float(a))
            ref[(v, e, float(a))] = solver_turning_points(zen, az, rad, solved, tol, floor)
    return reference_entries(ref)


def smoothness_report(dataset_path, reference_rows=None, between=None) -> dict:
    """The smoothness check (:mod:`widesky.skymodel.generator.smoothness`) of a written dataset over its grid and between grid
    points, summarised for the sidecar; with ``reference_rows`` (:func:`solver_reference`) a profile fails only beyond
    the solver's own turning points there, and with ``between``
    (:func:`widesky.skymodel.generator.smoothness_between.between_reference`) the pairs between grid points solved at their
    own state are judged against that solve."""
    model = load_dataset(dataset_path)
    ref = None
    if reference_rows is not None:
        ref = reference_from_entries(reference_rows, (model.visibilities, model.elevations, model.albedos), between)
    out = summarise(check_dataset(model, reference=ref), model.wavelengths)
    if between is not None and "between" in out:
        out["between"]["pairs_solved_at_their_state"] = len(between["examined"])
    return out


def build_dataset(config: BuildConfig, output, processes: int = 2, progress: bool = True, validation: bool = True,
                  log=None, data_dir=None) -> dict:
    """Solve (resumable), fit and write a dataset (see module docstring); returns the sidecar dict, with the
    held-out error report (:func:`widesky.skymodel.generator.dataset_errors.evaluate_errors`) when ``validation``."""
    t0 = time.perf_counter()
    n, secs = solve_all(config, processes, progress, validation, log)
    meta = assemble(config, output, processes, progress, log, data_dir)
    meta["solve"] = {"states_solved_now": n, "solve_seconds_now": round(secs, 1)}
    if validation:
        errs = evaluate_errors(config, output)
        meta["errors"] = summarise_errors(errs)

    rows = solver_reference(config, progress)
    meta["smoothness_reference"] = {
        "description": "profiles of the smoothness check where the solver's own sky (interpolated from its grid) has "
                       "more turning points than the limit: [visibility km, elevation deg, albedo, channel index, "
                       "profile kind, profile index, turning points]; the check allows these counts there; grid states "
                       "that hold a sky solved at another elevation (0 deg) have none (docs/default-dataset.md, "
                       "'Smoothness'); counted with the guard band's hysteresis 'rel_tol' and floor 'floor_fraction', "
                       "the verticals read on to the view zeniths 'vertical_read_on_deg' and the aureole rays to "
                       "'aureole_read_on_deg' from the sun (an extremum in the checked part whose reversal completes "
                       "past it counts)",
        "rel_tol": REFERENCE_REL_TOL, "floor_fraction": REFERENCE_FLOOR_FRACTION,
        "vertical_read_on_deg": list(VERTICAL_REFERENCE_HORIZON_DEG), "aureole_read_on_deg": AUREOLE_REFERENCE_READ_ON_DEG,
        "rows": rows}

    model = load_dataset(output)
    between = between_reference(config, model, reference_from_entries(
        rows, (model.visibilities, model.elevations, model.albedos)), processes, progress)
    meta["smoothness_between_reference"] = {
        "description": "(state, channel) pairs between grid points that fail the check by the bracketing grid states' "
                       "allowance, solved at their own state ('examined': [visibility km, elevation deg, albedo, "
                       "channel index]) and the profiles where that solve has more turning points than the limit "
                       "('rows', as smoothness_reference); the check judges those pairs against their own solve "
                       "(skymodel.generator.smoothness_between; docs/default-dataset.md, 'The check')", **between}
    meta["smoothness"] = smoothness_report(output, rows, between)
    meta["build_seconds"] = round(time.perf_counter() - t0, 1)
    Path(output).with_name(Path(output).name + ".json").write_text(json.dumps(meta, indent=1))
    return meta
