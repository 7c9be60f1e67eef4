"""Embree ray casting of the daylight-coefficient matrix and of sun visibility (computed once).

For every analysis point the hemisphere in front of it is cut into the sky patches (upper hemisphere)
and their mirror images (lower hemisphere). ``k x k`` stratified rays per patch (equal solid angle cells)
estimate which fraction of the patch's *exact* projected solid angle (:func:`patches.cosine_weights`)
is open sky, ground or a scene surface::

    coefficient[f, p] = W_exact[f, p] * sum_s w_fs v_fs / sum_s w_fs,   w_fs = cell_solid_angle * cos

so an unobstructed face gets the exact projected solid angles (furnace-exact) and an obstructed one a
stratified estimate of the visible part. Rays down that miss the scene reach the ground plane; rays
that reach the ground or a scene surface feed one reflection (Lambertian):

* **Reflected sky.** Every reflecting point (scene hit or ground) casts one cosine-distributed
  secondary ray (its direction fixed by the ray's identity, so results do not depend on chunking).
  Where it escapes into sky patch ``q``, ``pi L_q`` is a one-sample (unbiased) estimate of the
  reflector's sky irradiance, so the hit's share times its reflectance becomes a daylight
  coefficient of patch ``q`` (``reflect_sky``, ``ground_sky``): the reflected sky keeps the sky's
  anisotropy and the reflector's own obstruction; a closed box stays dark. Where a wall's secondary
  ray reaches the ground, that ground point is lit as the scene lets it be: one cosine-distributed ray
  from it to the sky (into ``ground_sky``) and, per shading cell, one towards the sun (into ``ground_sun``),
  weighted by the wall's reflectance (``reflect_ground``, the unshaded ground's coefficient until issue 39,
  is zero).
* **Reflected sun.** The year's sun positions are grouped into shading cells (:func:`shade_cells`:
  bands of elevation split into azimuth sectors of 30-120 deg). Per cell every reflecting point traces
  one ray towards a sun-position bin of that cell, drawn (deterministically, from the ray's identity)
  with probability proportional to the bin's number of steps x a clear-sky direct normal irradiance x
  the cosine of the reflector's binned normal (42 bins); the hits that see the sun carry the reflected
  sun of that cell's steps (``reflect_sun`` per orientation bin, ``ground_sun``): an estimate of each
  cell's sunlit share of the reflectors, so the ground of a street canyon is lit when, and as rarely
  as, it is.

* **Multiple reflections** (``reflections`` = m > 1, a fixed depth; ``IntegratorSettings.reflections``,
  default 3). A secondary ray that reaches a scene surface or the ground, instead of the sky, makes that
  point the next reflection's reflecting point: it carries the path weight (the first hit's share times the
  reflectances met so far) times its own reflectance, casts its own cosine-distributed sky ray (into
  ``reflect_sky``, or ``ground_sky`` for paths that reflected off the ground) and, per shading cell, its own
  sun ray (into ``reflect_sun`` at its orientation bin, or ``ground_sun`` for a ground point), and its
  secondary ray is followed in turn, up to m reflecting points per path. The first ground reflection's
  albedo is applied by the integrator per step (those paths go to ``ground_sky`` / ``ground_sun``); a
  path's second and later ground reflections, and the sun reflected by a scene surface on a path that
  reflected off the ground (whose factors carry no albedo), take a nominal albedo (the scene's, else the
  steps' mean). Each later point's sample identity is a hash of its parent's (as for the wall-then-ground
  points of one reflection, which are the second level's ground points), so ``reflections=1`` gives
  exactly the single-reflection coefficients and each further level only adds non-negative terms. The
  series is truncated at m (no Russian roulette): the missing tail is about ``(rho F)^m`` of the
  reflected light (in the street-canyon benchmark 0.9 % and 0.4 % of the canyon facades' reflected
  light at m = 3).

Adding an occluder never adds light to these estimates: a ray's secondary direction and sampled sun
bin depend only on its identity, and an occluder can only block them or replace a reflector.

Sun visibility of the analysis points comes from one ray per point and sun-position bin
(:func:`sun_bins`: the steps' sun directions grouped into cells of about ``sun_bin`` degrees, each
traced along its members' mean direction; ``sun_bin=0`` traces every step's own direction), packed to
bits.

Embree (through embreex) is single-threaded and holds the GIL, so the work is split into independent
tasks over chunks of points that each worker process runs on its own copy of the scene (cached per
process): a local process pool by default, whose workers receive the scene once (the pool's
initializer) and tasks carry only its key, or any ``concurrent.futures.Executor`` (e.g.
``dask.distributed.Client.get_executor()``), whose tasks carry the scene's arrays.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from .patches import reinhart
from .rays import (SHADE_BANDS, SHADE_SECTORS, cast_rays, reflector_bins, shade_band, shade_cells,
                   sun_bins)
from .raystages import primary_rays, reflected_sky, reflected_sun, sun_visibility

__all__ = ["Coefficients", "compute_coefficients", "start_coefficients", "PendingCoefficients", "geometry_pool",
           "reflector_bins", "cast_rays", "sun_bins", "shade_band", "shade_cells", "SHADE_BANDS",
           "SHADE_SECTORS"]

#: The scene geometry a pool worker holds (set once by the pool's initializer, :func:`_hold_geometry`), so
#: the tasks of the default process pool carry the scene's key instead of its arrays.
_WORKER_GEOMETRY: dict = {}


@dataclass(frozen=True, eq=False)
class Coefficients:
    """Per-point geometry factors, computed once per scene and patch scheme.

    Attributes
    ----------
    sky : numpy.ndarray
        (N, P) float32 visibility-weighted projected solid angle of each sky patch [sr].
    ground_sky : numpy.ndarray
        (N, P) float32 reflected-sky coefficients of the ground: per sky patch, the projected solid
        angle of the visible ground points whose secondary ray escapes into that patch [sr]; times
        the albedo and the patch radiance it gives the ground-reflected sky light.
    reflect_sky : numpy.ndarray
        (N, P) float32 the same for scene surfaces, times their reflectance [sr].
    reflect_ground : numpy.ndarray
        (N,) projected solid angle of scene surfaces whose secondary ray reaches the ground, times
        their reflectance [sr]; times the unshaded ground radiance it gives the ground light that
        walls pass on.
    ground_sun : numpy.ndarray
        (G, N) per reflector shading cell (:func:`shade_cells`), the projected solid angle of visible
        ground times its estimated sunlit share [sr] (for the reflected sun).
    reflect_sun : numpy.ndarray
        (G, N, B) the same for scene surfaces per orientation bin, times their reflectance [sr].
    bins : numpy.ndarray
        (B, 3) bin normals.
    sun_visible : numpy.ndarray
        (N, ceil(S_b / 8)) uint8, bits (``numpy.packbits`` along axis 1) of sun visibility for each
        of the S_b sun-position bins.
    n_sun : int
        S, the number of sun directions given.
    sun_index : numpy.ndarray
        (S,) bin of each sun direction given.
    sun_band : numpy.ndarray
        (S_b,) reflector shading cell of each bin (index into the G cells, -1 below the horizon).
    sun_bin : float
        Bin size [deg] (0: one bin per direction).
    sky_optic : numpy.ndarray or None
        (M, N, P) float32 sky coefficients of the M incidence-angle weight functions [sr]
        (:mod:`widesky.irradiance.optics`).
    reflect_optic : numpy.ndarray or None
        (M, N) float32 their factors [1] on each point's reflected light.
    n_rays : int
        Rays cast.
    seconds : float
        Wall time of the ray casting [s].
    """

    sky: np.ndarray
    ground_sky: np.ndarray
    reflect_sky: np.ndarray
    reflect_ground: np.ndarray
    ground_sun: np.ndarray
    reflect_sun: np.ndarray
    bins: np.ndarray
    sun_visible: np.ndarray
    n_sun: int
    n_rays: int
    seconds: float
    sun_index: np.ndarray = None
    sun_bin: float = 0.0
    sun_band: np.ndarray = None
    sky_optic: np.ndarray = None
    reflect_optic: np.ndarray = None

    def step_band(self, sun_rank):
        """(n,) reflector shading cell of the sun directions ``sun_rank`` given (the cell of their
        bin)."""
        idx = np.asarray(sun_rank) if self.sun_index is None else self.sun_index[sun_rank]
        return self.sun_band[idx]

    @property
    def n_points(self) -> int:
        """N."""
        return int(self.sky.shape[0])

    @property
    def n_sun_bins(self) -> int:
        """S_b, the number of sun-position bins (rays per point)."""
        return self.n_sun if self.sun_index is None else int(self.sun_index.max(initial=-1)) + 1

    def sun_visibility_bins(self):
        """(S_b, N) bool sun visibility per sun-position bin (rows) and point (C-contiguous)."""
        bits = np.unpackbits(self.sun_visible, axis=1, count=self.n_sun_bins)
        return np.ascontiguousarray(bits.T).view(bool)

    def sun_visibility(self, start=0, stop=None):
        """(N, stop - start) bool sun visibility for the sun directions ``start:stop`` given."""
        stop = self.n_sun if stop is None else stop
        idx = np.arange(start, stop) if self.sun_index is None else self.sun_index[start:stop]
        return self.sun_visibility_bins()[idx].T


def _sample_directions(mf, k):
    patches = reinhart(mf)
    d, w = patches.subsample(k)                                        # (P, K, 3), (P, K)
    d_lo = d.copy()
    d_lo[..., 2] *= -1.0
    return patches, np.concatenate([d, d_lo]), np.concatenate([w, w])  # (2P, K, 3), (2P, K)


def _chunk_task(geometry, origins, normals, buried, mf, k, sun_dirs, bins, first=0, sun_count=None,
                sun_cell=None, optics=None, optic_kq=4, reflections=1, ground_albedo=0.2):
    """Coefficients for one chunk of points (runs in a worker process).

    ``sun_dirs`` (S_b, 3) are the sun-position bins' directions, ``sun_count`` (S_b,) their
    numbers of steps (the weights of the reflector shading samples) and ``sun_cell`` (S_b,) their
    reflector shading cells (default :func:`shade_cells`). ``optics`` (an
    :class:`widesky.irradiance.optics.AngularWeights`) adds the sky coefficients and reflected-light factors
    of its incidence-angle weight functions (:func:`widesky.irradiance.optics.optic_terms`). ``reflections``
    and ``ground_albedo``: see :func:`compute_coefficients`.
    """

    t0 = time.perf_counter()
    if isinstance(geometry, str):                 # a pool worker's task: the key of the scene it holds
        geometry = _WORKER_GEOMETRY[geometry]
    patches, dirs, wcell = _sample_directions(mf, k)
    P, K = patches.n_patches, dirs.shape[1]
    n = origins.shape[0]
    pr = primary_rays(geometry, origins, normals, buried, patches, dirs, wcell)
    coeffs, bounce, gsh, extra, n_bounce = reflected_sky(geometry, pr, patches, K, normals, buried, first,
                                                         optics, optic_kq, reflections, ground_albedo)
    ident = (bounce.r_pt + first) * (2 * P * K) + pr.si[bounce.ri]
    ground_sun, reflect_sun, n_sun = reflected_sun(geometry, bounce, sun_dirs, bins, sun_count, sun_cell, n,
                                                   ident, buried, gsh, extra)
    vis, n_vis = sun_visibility(geometry, origins, normals, buried, sun_dirs)
    return {"sky": coeffs["sky"].astype(np.float32), "ground_sky": coeffs["ground_sky"].astype(np.float32),
            "reflect_sky": coeffs["reflect_sky"].astype(np.float32), "reflect_ground": coeffs["reflect_ground"],
            "ground_sun": ground_sun, "reflect_sun": reflect_sun.astype(np.float32),
            "sun": np.packbits(vis, axis=1), "n_rays": pr.fi.size + n_bounce + n_sun + n_vis,
            "sky_optic": coeffs["sky_optic"], "reflect_optic": coeffs["reflect_optic"],
            "seconds": time.perf_counter() - t0}


def _hold_geometry(geometry):
    """Process-pool initializer: keep the scene's geometry in this worker (shipped once per worker); a Ctrl-C
    ends the worker at once, printing nothing (the parent, interrupted too, drops the pool and says so in one line).
    """
    from widesky._pool_signals import quiet_interrupt     # not in the parent: its import sets the handler
    signal.signal(signal.SIGINT, quiet_interrupt)
    _WORKER_GEOMETRY.clear()
    _WORKER_GEOMETRY[geometry["key"]] = geometry


def _pool_context():
    """The start method of the default pool: ``forkserver`` where the platform has it, else ``spawn``.

    Not ``fork``: a process that has cast rays itself holds Embree's TBB worker threads, and a child forked from it
    can inherit one of their locks held, so its first ray cast waits forever (seen on ``widesky run
    cases/compare_sites``, which runs several sites in one process: 2 hangs in 8 runs). The fork server is a fresh
    process that has imported this module (and Embree) but never cast a ray; workers are forked from it."""
    methods = multiprocessing.get_all_start_methods()
    if "forkserver" in methods:
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["widesky._pool_signals", __name__])   # the quiet Ctrl-C first
        return ctx
    return multiprocessing.get_context("spawn")


def _default_executor(n_jobs, geometry):
    """A local process pool whose workers each receive ``geometry`` once, at start."""
    ctx = _pool_context()
    return ProcessPoolExecutor(max_workers=n_jobs, mp_context=ctx, initializer=_hold_geometry,
                               initargs=(geometry,))


def geometry_pool(n_jobs, geometry):
    """A local process pool whose workers hold ``geometry`` (``scene.geometry()``), to pass as
    :func:`start_coefficients`'s ``executor`` for several calls on one scene (blocks of points): its tasks carry the
    scene's key, as the default pool's do, and its workers keep their Embree scene between calls. The caller shuts
    it down."""
    ex = _default_executor(int(n_jobs), geometry)
    ex.widesky_geometry_key = geometry["key"]
    return ex


def _pool_task_args(args):
    """Task arguments for the default pool: the scene's key in place of its geometry arrays."""
    return [(a[0]["key"],) + tuple(a[1:]) for a in args]


def compute_coefficients(scene, *, mf=1, rays_per_patch=2, sun_directions=None, sun_bin=0.0,
                         n_jobs=None, chunk_size=None, executor=None, progress=False, optics=None,
                         optic_kq=4, reflections=1, ground_albedo=None, points=None):
    """Daylight coefficients, ground and reflection factors and sun visibility of every point.

    Parameters
    ----------
    scene : Scene
        The scene.
    mf : int
        Reinhart subdivision of the sky (1 = 145 patches).
    rays_per_patch : int
        ``k``: k x k rays per patch and hemisphere.
    sun_directions : array_like, optional
        (S, 3) ENU unit vectors towards the sun (one per daylight step).
    sun_bin : float
        Size of the sun-position bins [deg] (:func:`sun_bins`); 0 casts one ray per direction given.
    n_jobs : int, optional
        Worker processes (default: all cores); 1 runs in this process.
    chunk_size : int, optional
        Points per task; default bounds a task's working memory to a few hundred MB.
    executor : concurrent.futures.Executor, optional
        Runs the tasks instead of a local process pool.
    progress : bool
        Show a progress bar.
    optics : irradiance.optics.AngularWeights, optional
        Incidence-angle weight functions whose coefficients to add (``sky_optic``,
        ``reflect_optic``).
    optic_kq : int
        Sub-grid per patch side of their quadrature.
    reflections : int
        Reflecting points per light path (>= 1): 1 is one reflection (plus the ground light a wall passes
        on), ``m`` follows each secondary ray that reaches a surface to ``m`` reflections (fixed depth; see
        the module's description).
    ground_albedo : float, optional
        Nominal ground albedo [1] of the reflections the integrator cannot apply the step's albedo to (a
        path's second and later ground reflections, the sun a scene surface reflects on a path that
        reflected off the ground; ``reflections`` > 1 only); default the scene's ground albedo (mean over
        channels), else 0.2.
    points : tuple of int, optional
        (start, stop): only the points ``start:stop`` (face-major; the coefficients of a block of faces, equal
        to those rows of the whole scene's: each ray's identity is its point's index in the scene).

    Returns
    -------
    Coefficients
    """
    return start_coefficients(scene, mf=mf, rays_per_patch=rays_per_patch,
                              sun_directions=sun_directions, sun_bin=sun_bin, n_jobs=n_jobs,
                              chunk_size=chunk_size, executor=executor, progress=progress,
                              optics=optics, optic_kq=optic_kq, reflections=reflections,
                              ground_albedo=ground_albedo, points=points).result()


class PendingCoefficients:
    """Ray-casting tasks under way (from :func:`start_coefficients`); ``result()`` collects them.

    With a process pool or an executor the tasks run while the caller does other work (the
    integrator evaluates the sky meanwhile); in serial mode they run inside ``result()``.
    """

    def __init__(self, t0, args, bounds, bins, sun, sun_index, sun_bin, sun_band, n_jobs, executor,
                 progress):
        self._t0, self._args, self._bounds = t0, args, bounds
        self._bins, self._sun, self._sun_index, self._sun_bin = bins, sun, sun_index, sun_bin
        self._sun_band = sun_band
        self._futs, self._own, self._value = None, None, None
        self._bar = None
        if progress:
            self._bar = tqdm(total=bounds[-1][1] - bounds[0][0] if bounds else 0, unit="point",
                             desc="ray casting")
        if executor is not None or (n_jobs > 1 and len(args) > 1):
            ex = executor if executor is not None else _default_executor(n_jobs, args[0][0])
            self._own = ex if executor is None else None
            # the default pool's workers hold the scene (initializer), and so do a geometry_pool's; a user's
            # executor gets it per task
            holds = bool(args) and getattr(executor, "widesky_geometry_key", None) == args[0][0]["key"]
            tasks = args if executor is not None and not holds else _pool_task_args(args)
            try:
                self._futs = {ex.submit(_chunk_task, *a): i for i, a in enumerate(tasks)}
            except BaseException:
                self._close()
                raise

    @property
    def running(self) -> bool:
        """True when the tasks run elsewhere (a pool or an executor) while the caller works."""
        return self._futs is not None

    def cancel(self):
        """Stop the pool this object started (pending tasks are dropped) and close the progress bar."""
        self._close()

    def _close(self):
        if self._own is not None:
            self._own.shutdown(cancel_futures=True)
            self._own = None
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def result(self):
        """The :class:`Coefficients` (waits for the tasks; runs them here in serial mode)."""
        if self._value is not None:
            return self._value
        args, bounds = self._args, self._bounds
        results = [None] * len(args)
        try:
            if self._futs is None:
                for i, a in enumerate(args):
                    results[i] = _chunk_task(*a)
                    if self._bar is not None:
                        self._bar.update(bounds[i][1] - bounds[i][0])
            else:
                for f in as_completed(self._futs):
                    i = self._futs[f]
                    results[i] = f.result()
                    if self._bar is not None:
                        self._bar.update(bounds[i][1] - bounds[i][0])
        finally:
            self._close()
        self._value = Coefficients(
            sky=np.concatenate([r["sky"] for r in results]),
            ground_sky=np.concatenate([r["ground_sky"] for r in results]),
            reflect_sky=np.concatenate([r["reflect_sky"] for r in results]),
            reflect_ground=np.concatenate([r["reflect_ground"] for r in results]),
            ground_sun=np.concatenate([r["ground_sun"] for r in results], axis=1),
            reflect_sun=np.concatenate([r["reflect_sun"] for r in results], axis=1),
            bins=self._bins, sun_visible=np.concatenate([r["sun"] for r in results]),
            n_sun=int(self._sun.shape[0]), n_rays=int(sum(r["n_rays"] for r in results)),
            seconds=time.perf_counter() - self._t0, sun_index=self._sun_index,
            sun_bin=float(self._sun_bin), sun_band=self._sun_band,
            sky_optic=(None if results[0]["sky_optic"] is None else
                       np.concatenate([r["sky_optic"] for r in results], axis=1)),
            reflect_optic=(None if results[0]["reflect_optic"] is None else
                           np.concatenate([r["reflect_optic"] for r in results], axis=1)))
        return self._value


def start_coefficients(scene, *, mf=1, rays_per_patch=2, sun_directions=None, sun_bin=0.0,
                       n_jobs=None, chunk_size=None, executor=None, progress=False, optics=None,
                       optic_kq=4, reflections=1, ground_albedo=None, points=None):
    """Submit the ray-casting tasks of :func:`compute_coefficients` and return at once.

    Same parameters; returns a :class:`PendingCoefficients` whose ``result()`` gives the
    :class:`Coefficients`.
    """
    t0 = time.perf_counter()
    if not (float(reflections) == int(reflections) and 1 <= int(reflections) <= 20):
        raise ValueError(f"reflections={reflections} must be an integer in [1, 20] (reflections per light path)")
    reflections = int(reflections)
    if ground_albedo is None:
        ga = getattr(scene, "ground_albedo", None)
        ground_albedo = 0.2 if ga is None else float(np.mean(ga))
    if not 0.0 <= float(ground_albedo) <= 1.0:
        raise ValueError(f"ground_albedo={ground_albedo} must be in [0, 1]")
    sun = np.zeros((0, 3)) if sun_directions is None else np.asarray(sun_directions, float)
    sun = sun.reshape(-1, 3)
    if not np.all(np.isfinite(sun)):
        raise ValueError("sun_directions has non-finite values")
    sun_rep, sun_index = sun_bins(sun, sun_bin)
    bins = reflector_bins()
    geom = scene.geometry()
    origins, normals, buried = scene.ray_origins, scene.point_normal, scene.point_buried
    lo, hi = (0, scene.n_points) if points is None else (int(points[0]), int(points[1]))
    if not 0 <= lo <= hi <= scene.n_points:
        raise ValueError(f"points={points} outside the scene's 0:{scene.n_points}")
    n = hi - lo
    n_jobs = (os.cpu_count() or 1) if n_jobs is None else int(n_jobs)
    if n_jobs < 1:
        raise ValueError(f"n_jobs={n_jobs} must be >= 1 (processes)")
    if chunk_size is None:
        n_dirs = 2 * (144 * mf * mf + 1) * rays_per_patch ** 2
        chunk_size = int(max(32, min(2000, 4_000_000 // n_dirs)))
        if n_jobs != 1 or executor is not None:       # at least two tasks per worker for balance
            workers = n_jobs if executor is None else max(n_jobs, 2)
            chunk_size = int(max(32, min(chunk_size, -(-n // (2 * workers)))))
    bounds = [(i, min(i + int(chunk_size), hi)) for i in range(lo, hi, int(chunk_size))]
    sun_count = np.bincount(sun_index, minlength=sun_rep.shape[0]).astype(float)
    sun_band, _ = shade_cells(sun_rep)
    args = [(geom, origins[a:b], normals[a:b], buried[a:b], mf, rays_per_patch, sun_rep, bins, a,
             sun_count, sun_band, optics, optic_kq, reflections, float(ground_albedo)) for a, b in bounds]
    return PendingCoefficients(t0, args, bounds, bins, sun, sun_index, sun_bin, sun_band, n_jobs,
                               executor, progress)
