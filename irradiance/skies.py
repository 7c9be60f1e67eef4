"""Sky sources for the integrator: a small interface with analytic skies and the Prague Sky Model.

A sky source answers two questions for a series of sky states (one per time step):

* ``radiance(directions, states)`` -> (T, N, C) spectral sky radiance [W m-2 sr-1 nm-1] for
  per-step directions (T, N, 3) (ENU unit vectors above the horizon), the sun excluded;
* ``direct_normal(states)`` -> (T, C) spectral direct normal irradiance of the sun [W m-2 nm-1].

It also carries ``wavelengths`` (C,) [nm], ``channel_edges`` (C+1,) [nm] and ``min_sun_elevation``
[deg], the lowest sun elevation at which its sky radiance is defined (below it the integrator returns
zero sky light). The analytic skies here exist for furnace tests and accuracy studies;
:class:`PragueSky` wraps :mod:`widesky.skymodel`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from widesky import skymodel
from widesky.skymodel.channels import CHANNEL_EDGES_NM
from widesky.skymodel.evaluate import RadianceTables

from .patches import direction_from_angles

__all__ = ["SkyStates", "UniformSky", "AnalyticSky", "PragueSky", "default_channel_edges"]


def default_channel_edges():
    """The Prague Sky Model's 55 channels of 40 nm, 280-2480 nm: edges (56,) [nm]."""
    return CHANNEL_EDGES_NM.copy()


def _edges(wavelengths, channel_edges):
    if channel_edges is None and wavelengths is None:
        channel_edges = default_channel_edges()
    if channel_edges is None:
        w = np.asarray(wavelengths, dtype=float)
        mid = 0.5 * (w[1:] + w[:-1])
        first = w[0] - (mid[0] - w[0]) if w.size > 1 else w[0] - 20.0
        last = w[-1] + (w[-1] - mid[-1]) if w.size > 1 else w[0] + 20.0
        channel_edges = np.concatenate([[first], mid, [last]])
    e = np.asarray(channel_edges, dtype=float)
    if e.ndim != 1 or e.size < 2 or np.any(np.diff(e) <= 0):
        raise ValueError(f"channel_edges must be increasing with >= 2 values [nm], got {e!r}")
    return e


@dataclass(frozen=True, eq=False)
class SkyStates:
    """Per-step sky states, all arrays of shape (T,); validated once where they are made.

    Attributes
    ----------
    sun_elevation : numpy.ndarray
        Apparent solar elevation [deg].
    sun_azimuth : numpy.ndarray
        Solar azimuth clockwise from north [deg].
    visibility : numpy.ndarray
        Ground-level visibility [km].
    albedo : numpy.ndarray
        Ground albedo [1] (the sky model's, also used for the Lambertian ground).
    altitude : numpy.ndarray
        Observer altitude [m].
    earth_sun_distance : numpy.ndarray
        Earth-Sun distance [AU] (NREL SPA); the integrator scales the sun and the sky by
        ``1 / r**2`` (the dataset's extraterrestrial spectrum is at 1 AU).
    clamped : dict of str to numpy.ndarray
        Field name -> (T,) bool: steps whose value was clamped to the sky model's range
        (``visibility``, ``albedo``, ``altitude``, ``sun_elevation``); empty when nothing was checked.
    times : pandas.DatetimeIndex or None
        The tz-aware steps (interval labels as given), when known.
    """

    sun_elevation: np.ndarray
    sun_azimuth: np.ndarray
    visibility: np.ndarray
    albedo: np.ndarray
    altitude: np.ndarray
    earth_sun_distance: np.ndarray = None
    clamped: dict = None
    times: object = None

    FIELDS = ("sun_elevation", "sun_azimuth", "visibility", "albedo", "altitude",
              "earth_sun_distance")

    def __post_init__(self):
        if self.earth_sun_distance is None:
            object.__setattr__(self, "earth_sun_distance", np.ones(self.sun_elevation.shape))
        if self.clamped is None:
            object.__setattr__(self, "clamped", {})

    @classmethod
    def create(cls, sun_elevation, sun_azimuth, visibility=50.0, albedo=0.2, altitude=0.0,
               earth_sun_distance=1.0, clamped=None, times=None):
        """Broadcast scalars and arrays to one length T and validate them.

        Parameters
        ----------
        sun_elevation : array_like
            [deg], within [-90, 90].
        sun_azimuth : array_like
            [deg] clockwise from north.
        visibility : array_like
            [km], > 0.
        albedo : array_like
            [1], within [0, 1].
        altitude : array_like
            [m].
        earth_sun_distance : array_like
            [AU], within [0.95, 1.05] (the Earth's orbit spans 0.983-1.017 AU).
        clamped : dict of str to array_like, optional
            (T,) bool flags per field name.
        times : pandas.DatetimeIndex, optional
            (T,) tz-aware steps.
        """
        arrs = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float)) for v in
                                     (sun_elevation, sun_azimuth, visibility, albedo, altitude,
                                      earth_sun_distance)))
        if arrs[0].ndim != 1:
            raise ValueError(f"sky states must be one-dimensional, got shape {arrs[0].shape}")
        el, az, vis, alb, alt, r = (np.array(a) for a in arrs)
        for name, v in zip(cls.FIELDS, (el, az, vis, alb, alt, r)):
            if not np.all(np.isfinite(v)):
                raise ValueError(f"{name} has non-finite values")
        if np.any(np.abs(el) > 90):
            raise ValueError(f"sun_elevation={el[np.abs(el) > 90][0]} deg outside [-90, 90]")
        if np.any(vis <= 0):
            raise ValueError(f"visibility={vis[vis <= 0][0]} km must be > 0")
        if np.any((alb < 0) | (alb > 1)):
            raise ValueError(f"albedo={alb[(alb < 0) | (alb > 1)][0]} outside [0, 1]")
        if np.any((r < 0.95) | (r > 1.05)):
            raise ValueError(f"earth_sun_distance={r[(r < 0.95) | (r > 1.05)][0]} AU outside "
                             "[0.95, 1.05]")
        T = el.shape[0]
        flags = {}
        for k, v in (clamped or {}).items():
            f = np.broadcast_to(np.asarray(v, dtype=bool), (T,)).copy()
            flags[str(k)] = f
        if times is not None and len(times) != T:
            raise ValueError(f"times has {len(times)} steps, the states {T}")
        return cls(el, az, vis, alb, alt, r, flags, times)

    def __len__(self) -> int:
        return int(self.sun_elevation.shape[0])

    def take(self, index):
        """The states at ``index`` (slice or integer array)."""
        return SkyStates(self.sun_elevation[index], self.sun_azimuth[index], self.visibility[index],
                         self.albedo[index], self.altitude[index], self.earth_sun_distance[index],
                         {k: v[index] for k, v in self.clamped.items()},
                         None if self.times is None else self.times[index])

    @property
    def sun_direction(self):
        """(T, 3) ENU unit vectors towards the sun."""
        return direction_from_angles(self.sun_elevation, self.sun_azimuth)

    @property
    def n_clamped(self):
        """dict field -> number of clamped steps (fields with at least one)."""
        return {k: int(v.sum()) for k, v in self.clamped.items() if v.any()}


class _Channels:
    """Channel bookkeeping shared by the sky sources: ``wavelengths`` (C,) [nm], ``channel_edges`` (C+1,) [nm]."""

    @property
    def n_channels(self) -> int:
        return int(self.wavelengths.shape[0])

    @property
    def channel_widths(self):
        """(C,) channel widths [nm]."""
        return np.diff(self.channel_edges)


class _SpectralSky(_Channels):
    def __init__(self, wavelengths=None, channel_edges=None):
        self.channel_edges = _edges(wavelengths, channel_edges)
        self.wavelengths = (np.asarray(wavelengths, dtype=float) if wavelengths is not None
                            else 0.5 * (self.channel_edges[1:] + self.channel_edges[:-1]))
        if self.wavelengths.shape[0] != self.channel_edges.shape[0] - 1:
            raise ValueError("wavelengths and channel_edges disagree on the channel count")

    def _spectrum(self, value, name):
        v = np.asarray(value, dtype=float)
        if v.ndim == 0:
            v = np.full(self.n_channels, float(v))
        if v.shape != (self.n_channels,):
            raise ValueError(f"{name} must be a scalar or shape ({self.n_channels},), got {v.shape}")
        return v


class UniformSky(_SpectralSky):
    """A sky of uniform radiance with a sun of constant direct normal irradiance (furnace tests).

    Parameters
    ----------
    radiance : float or array_like
        Sky radiance, scalar or (C,) [W m-2 sr-1 nm-1].
    dni : float or array_like
        Direct normal irradiance of the sun, scalar or (C,) [W m-2 nm-1]; 0 for a sky without sun.
    wavelengths, channel_edges : array_like, optional
        Channel centres (C,) and edges (C+1,) [nm]; default the PSM's 55 channels.
    min_sun_elevation : float
        Sun elevation below which the sky is dark [deg]; default -90 (always lit).
    """

    def __init__(self, radiance=1.0, dni=0.0, *, wavelengths=None, channel_edges=None,
                 min_sun_elevation=-90.0):
        super().__init__(wavelengths, channel_edges)
        self.L = self._spectrum(radiance, "radiance")
        self.dni = self._spectrum(dni, "dni")
        self.min_sun_elevation = float(min_sun_elevation)

    def radiance(self, directions, states):
        """(T, N, C) [W m-2 sr-1 nm-1] for directions (T, N, 3)."""
        d = np.asarray(directions)
        return np.broadcast_to(self.L, d.shape[:-1] + (self.n_channels,)).copy()

    def direct_normal(self, states):
        """(T, C) [W m-2 nm-1]; zero while the sun is below the horizon."""
        up = (np.asarray(states.sun_elevation) > 0)[:, None]
        return np.where(up, self.dni[None, :], 0.0)


class AnalyticSky(_SpectralSky):
    """A smooth analytic clear sky with a sharp circumsolar aureole (for accuracy studies).

    Relative radiance is the CIE general sky (CIE S 011/E:2003, type 12 "clear, low turbidity" by
    default) ``f(gamma) phi(Z) / (f(Z_s) phi(0))`` plus an aureole ``k exp(-gamma / gamma0)``, times the
    zenith radiance ``zenith * sin(elevation)**0.5`` and a spectral shape. The direct normal irradiance
    is ``dni0 * 0.7 ** (m ** 0.678)`` with the Kasten-Young air mass ``m`` (Meinel's fit).

    Parameters
    ----------
    zenith : float
        Zenith radiance for the sun at the zenith [W m-2 sr-1 nm-1], scaled by ``shape``.
    dni0 : float
        Top-of-atmosphere scale of the direct normal irradiance [W m-2 nm-1].
    shape : array_like, optional
        (C,) relative spectral shape of both; default a smooth bump peaking near 500 nm.
    a, b, c, d, e : float
        CIE gradation and indicatrix parameters [1].
    aureole : float
        Amplitude ``k`` of the extra aureole term [1].
    aureole_width : float
        ``gamma0`` [deg].
    wavelengths, channel_edges : array_like, optional
        [nm]; default the PSM's 55 channels.
    """

    def __init__(self, zenith=0.05, dni0=1.4, *, shape=None, a=-1.0, b=-0.32, c=10.0, d=-3.0, e=0.45,
                 aureole=30.0, aureole_width=2.0, wavelengths=None, channel_edges=None):
        super().__init__(wavelengths, channel_edges)
        if shape is None:
            w = self.wavelengths
            shape = np.exp(-0.5 * ((w - 500.0) / 450.0) ** 2) + 0.05
        self.shape = self._spectrum(shape, "shape")
        self.zenith, self.dni0 = float(zenith), float(dni0)
        self.p = (a, b, c, d, e)
        self.aureole, self.aureole_width = float(aureole), float(aureole_width)
        self.min_sun_elevation = 0.0

    def _indicatrix(self, chi):
        a, b, c, d, e = self.p
        return 1.0 + c * (np.exp(d * chi) - np.exp(d * np.pi / 2)) + e * np.cos(chi) ** 2

    def relative_radiance(self, directions, states):
        """(T, N) relative sky radiance [1] (the spectral scale left out)."""
        a, b, c, d, e = self.p
        dirs = np.asarray(directions, dtype=float)
        s = states.sun_direction                                          # (T, 3)
        el = np.radians(states.sun_elevation)
        zs = np.pi / 2 - el
        cosz = np.clip(dirs[..., 2], 1e-3, 1.0)
        cosg = np.clip(np.einsum("tnk,tk->tn", dirs, s), -1.0, 1.0)
        gamma = np.arccos(cosg)
        phi = 1.0 + a * np.exp(b / cosz)
        phi0 = 1.0 + a * np.exp(b)
        rel = self._indicatrix(gamma) * phi / (self._indicatrix(zs)[:, None] * phi0)
        rel = rel + self.aureole * np.exp(-np.degrees(gamma) / self.aureole_width)
        scale = np.sqrt(np.clip(np.sin(el), 0.0, 1.0))
        return rel * scale[:, None]

    def radiance(self, directions, states):
        """(T, N, C) [W m-2 sr-1 nm-1] for directions (T, N, 3); zero with the sun below the horizon."""
        rel = self.relative_radiance(directions, states)
        return (self.zenith * rel)[..., None] * self.shape

    def direct_normal(self, states):
        """(T, C) [W m-2 nm-1]."""
        el = np.asarray(states.sun_elevation, dtype=float)
        zen = 90.0 - el
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            am = 1.0 / (np.cos(np.radians(zen)) + 0.50572 * (96.07995 - zen) ** -1.6364)
            t = np.where(el > 0, 0.7 ** (np.where(el > 0, am, 1.0) ** 0.678), 0.0)
        return (self.dni0 * t)[:, None] * self.shape[None, :]


class PragueSky(_Channels):
    """The Prague Sky Model (:mod:`widesky.skymodel`) as a sky source.

    Parameters
    ----------
    model : skymodel.SkyModel or str or None
        A loaded model, a dataset path, or None for the embedded default dataset.
    channels : array_like of int, optional
        Channel subset passed to the sky model.
    elevation_quantum : float
        Sun elevations are rounded to this step [deg] to share sky-model evaluations between steps
        (error at most half a step of elevation); 0 evaluates every distinct state exactly.
    threads : int
        OpenMP threads per sky-model call; default 1, since the integrator evaluates the sky while
        its worker processes cast rays (measured on 2 busy cores: 2 threads were slower than 1);
        0 uses all cores.
    """

    def __init__(self, model=None, *, channels=None, elevation_quantum=0.2, threads=1):
        self._sm = skymodel
        if model is None or isinstance(model, (str, bytes)) or hasattr(model, "__fspath__"):
            model = skymodel.load_dataset(model)
        self.model = model
        self.channels = None if channels is None else np.asarray(channels, dtype=int)
        edges = np.asarray(model.channel_edges, dtype=float)
        wl = np.asarray(model.wavelengths, dtype=float)
        if self.channels is not None:
            wl = wl[self.channels]
            edges = np.stack([edges[self.channels], edges[self.channels + 1]], axis=1)
            if not np.allclose(edges[1:, 0], edges[:-1, 1]):
                raise ValueError("a channel subset for the integrator must be contiguous")
            edges = np.concatenate([edges[:, 0], edges[-1:, 1]])
        self.wavelengths, self.channel_edges = wl, edges
        self.min_sun_elevation = float(np.min(model.elevation_range))
        if not elevation_quantum >= 0:
            raise ValueError(f"elevation_quantum={elevation_quantum} deg must be >= 0")
        self.elevation_quantum = float(elevation_quantum)
        if int(threads) < 0:
            raise ValueError(f"threads={threads} must be >= 0 (0: all cores)")
        self.threads = int(threads)

    def check_states(self, states):
        """Raise ValueError naming the parameter when a state lies outside the dataset's ranges."""
        for name, rng in (("visibility", self.model.visibility_range),
                          ("albedo", self.model.albedo_range),
                          ("altitude", self.model.altitude_range)):
            v = getattr(states, name)
            lo, hi = float(np.min(rng)), float(np.max(rng))
            bad = (v < lo - 1e-9) | (v > hi + 1e-9)
            if np.any(bad):
                raise ValueError(f"{name}={v[bad][0]} outside the dataset's range [{lo}, {hi}]")

    def _tables(self):
        """The per-configuration tables of this sky's dataset and channels
        (:class:`widesky.skymodel.evaluate.RadianceTables`), made on first use and kept with the loaded dataset, so
        a time series, and every sky object on the same dataset (the explorer makes one per view), builds each
        configuration's table once."""
        rt = getattr(self, "_radiance_tables", None)
        if rt is None:
            shared = self.model.__dict__.setdefault("_radiance_tables", {})
            key = None if self.channels is None else tuple(int(c) for c in self.channels)
            rt = shared.get(key)
            if rt is None:
                rt = shared[key] = RadianceTables(self.model, self.channels)
            self._radiance_tables = rt
        rt.threads = self.threads
        return rt

    def __getstate__(self):                      # the kept tables are a cache: not pickled
        state = dict(self.__dict__)
        state.pop("_radiance_tables", None)
        return state

    def state_order(self, states, steps):
        """``steps`` (int array) in an order that lets neighbouring steps share the sky model's corner
        configurations (visibility cell, albedo cell, altitude, elevation): the integrator evaluates the
        sky in chunks of this order."""
        st = states.take(steps)
        return np.asarray(steps)[self._tables().order_key(st.sun_elevation, st.visibility, st.albedo,
                                                          st.altitude)]

    def radiance(self, directions, states):
        """(T, N, C) [W m-2 sr-1 nm-1] for directions (T, N, 3).

        Sun elevations are rounded to ``elevation_quantum``. Each step is the weighted sum of its
        corner configurations' tables, each table built once per loaded dataset and kept
        (:class:`widesky.skymodel.evaluate.RadianceTables`): the values of
        :func:`widesky.skymodel.sky_radiance` to float32 rounding (relative below 1e-6). Above
        :attr:`PER_STATE_DIRECTIONS` directions per step (images), one merged table per distinct state.
        """
        d = np.asarray(directions, dtype=float)
        q = self.elevation_quantum
        el = np.round(states.sun_elevation / q) * q if q > 0 else states.sun_elevation
        if d.shape[1] > self.PER_STATE_DIRECTIONS:          # images: one merged table per state is cheaper
            return self._radiance_per_state(d, el, states)
        return self._tables().radiance(d, el, states.sun_azimuth, states.visibility, states.albedo,
                                       states.altitude)

    PER_STATE_DIRECTIONS = 20000
    """Above this many directions per step :meth:`radiance` evaluates each distinct state with its own merged
    table (:func:`widesky.skymodel.sky_radiance`), which costs one table precompute (about 5 ms) but a
    sixth to an eighth of the per-direction work of the corner tables."""

    def _radiance_per_state(self, d, el, states):
        """(T, N, C): one sky-model call per distinct (elevation, visibility, albedo, altitude); steps that differ
        only in sun azimuth share it, their directions rotated about the zenith."""
        T, N = d.shape[0], d.shape[1]
        out = np.empty((T, N, self.n_channels))
        key = np.stack([el, states.visibility, states.albedo, states.altitude], axis=1)
        _, inverse = np.unique(key, axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        for g in range(inverse.max() + 1 if T else 0):
            members = np.nonzero(inverse == g)[0]
            ref = members[0]
            delta = np.radians(states.sun_azimuth[ref] - states.sun_azimuth[members])    # (m,)
            cd, sd = np.cos(delta)[:, None], np.sin(delta)[:, None]
            dm = d[members]
            rot = np.stack([dm[..., 0] * cd + dm[..., 1] * sd, -dm[..., 0] * sd + dm[..., 1] * cd,
                            dm[..., 2]], axis=-1)
            vals = self._sm.sky_radiance(
                self.model, rot.reshape(-1, 3), float(el[ref]), float(states.sun_azimuth[ref]),
                float(states.visibility[ref]), float(states.albedo[ref]),
                float(states.altitude[ref]), channels=self.channels, threads=self.threads)
            out[members] = np.asarray(vals).reshape(members.size, N, self.n_channels)
        return out

    def radiance_means(self, directions, rows, weights, states):
        """(T, rows.max() + 1, C) [W m-2 sr-1 nm-1]: per step the sums over the fixed directions (N, 3) of
        ``weights`` (N,) [1] x radiance, by ``rows`` (N,) (patch means of stratified samples), without the
        (T, N, C) samples (as :meth:`radiance`, elevations rounded to ``elevation_quantum``)."""
        q = self.elevation_quantum
        el = np.round(states.sun_elevation / q) * q if q > 0 else states.sun_elevation
        return self._tables().radiance(directions, el, states.sun_azimuth, states.visibility, states.albedo,
                                       states.altitude, rows=rows, weights=weights)

    def direct_normal(self, states):
        """(T, C) [W m-2 nm-1]; zero with the sun below the horizon."""
        if len(states) == 0:
            return np.zeros((0, self.n_channels))
        dni = self._tables().direct_normal(states.sun_elevation, states.sun_azimuth, states.visibility,
                                           states.altitude)          # solar_direct_normal, step by step
        return np.where((states.sun_elevation > 0)[:, None], dni, 0.0)
