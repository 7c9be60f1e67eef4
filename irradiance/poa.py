"""``poa_irradiance``: per-face irradiance per response and part, in named stages.

Stages (see :mod:`widesky.irradiance.integrator` for the method), each in a module named for it:

1. **columns** (:func:`widesky.irradiance.columns.sky_columns`): every response becomes one contraction
   column of the sky's channels (or, for an angle x wavelength optic, one per incidence-angle class node),
   each tied to the sky coefficients it multiplies (plain, or those of an optic's weight function);
2. **step scaling** (:func:`widesky.irradiance.step_scaling.step_scaling`) and **output plan**
   (:func:`widesky.irradiance.output_plan.output_plan`): how each step's sky is scaled to the weather;
   the parts kept, the output blocks of consecutive steps and their chunks of daylight steps;
3. **sky chunks** (:func:`widesky.irradiance.sky_chunks.evaluate_sky`): the sky model per chunk of steps,
   contracted with the columns, scaled by the Earth-Sun distance, the per-step (and per-channel) factors
   and the measured-weather match; evaluated while the ray-casting tasks run;
4. **products** (:func:`widesky.irradiance.products.chunk_products`): per chunk the sky, reflected and
   beam terms per column (matrix products with the coefficients of
   :func:`widesky.irradiance.raycast.compute_coefficients`);
5. **assembly** (:func:`widesky.irradiance.assembly.assemble_blocks`): columns into each response's direct,
   sky-diffuse and reflected parts with the optics applied (the beam's exactly at each step's angle of
   incidence), averaged over each face's points, written into a block of steps that a sink
   (:class:`widesky.irradiance.sink.Sink`) keeps in memory or streams to the HDF5 result file (bounded
   memory: one block at a time).

Above a working-memory budget (:data:`widesky.irradiance.output_plan.FACE_BLOCK_BYTES`) or with
``RunOptions(face_block=...)`` the ray casting and stages 4 and 5 run per block of faces, the next block's rays
cast while this block's products run, so memory does not grow with the face count; the numbers are those of one
block, bit for bit (:data:`widesky.irradiance.products.FACE_TILE`).
"""

from __future__ import annotations

import os
import time

import numpy as np

from .assembly import assemble_blocks, assemble_parts
from .columns import contraction_columns, sky_columns
from .integrator import IntegratorSettings
from .output_plan import BLOCK_BYTES, estimate_run, output_plan, stored_parts
from .poa_options import MeasuredSky, OutputOptions, RunOptions
from .products import (GlobalParts, ProductContext, check_coefficients, chunk_products, fast_columns,
                       group_normals)
from .raycast import geometry_pool, start_coefficients
from .result import FaceTable, POAResult
from .scene import Scene
from .sink import Sink, run_provenance
from .skies import SkyStates
from .sky_chunks import evaluate_sky
from .step_scaling import result_scaling, step_scaling

__all__ = ["poa_irradiance", "contraction_columns", "estimate_run", "GlobalParts", "MeasuredSky",
           "OutputOptions", "RunOptions", "BLOCK_BYTES", "stored_parts", "chunk_products", "assemble_parts"]


def poa_irradiance(scene: Scene, sky, states: SkyStates, *, responses=None, settings=None, weather=None,
                   output=None, run=None, times=None) -> POAResult:
    """Plane-of-array irradiance per face, step and response: direct, sky-diffuse and reflected parts.

    Parameters
    ----------
    scene : Scene
        From :func:`widesky.irradiance.make_scene`.
    sky : sky source
        :class:`widesky.irradiance.PragueSky`, :class:`~irradiance.UniformSky` ...
    states : SkyStates
        T sky states (e.g. from :func:`widesky.irradiance.sky_states_for`); the sun and sky are scaled by
        ``1 / earth_sun_distance**2``.
    responses : list of Response, or dict of str to Response or array_like, optional
        Spectral responses with optional angular optics (:class:`widesky.irradiance.Response`); arrays (C,)
        are channel weights [1] without optics. "broadband" (unit weight, no optics) is always
        computed first.
    settings : IntegratorSettings, optional
        Resolution; default ``IntegratorSettings()``.
    weather : MeasuredSky, optional
        How the sky is scaled to the weather (measured DNI/DHI [W m-2] and the spectral model, or explicit
        factors [1]); default the clear sky as modelled.
    output : OutputOptions, optional
        What is kept and where (memory or an HDF5 file, spectral parts, parts per response, a consumer per
        chunk); default the three parts of every response in memory.
    run : RunOptions, optional
        How it runs (processes, executor, progress, precomputed coefficients, optic nodes [deg]).
    times : pandas.DatetimeIndex, optional
        (T,) labels of the steps (default ``states.times``).

    Returns
    -------
    POAResult
    """
    t_start = time.perf_counter()
    settings = settings or IntegratorSettings()
    weather = MeasuredSky() if weather is None else weather
    output = OutputOptions() if output is None else output
    run = RunOptions() if run is None else run
    T = len(states)
    times = states.times if times is None else times
    if times is not None and len(times) != T:
        raise ValueError(f"times has {len(times)} steps, the states {T}")
    cols = sky_columns(scene, sky, responses, output.spectral, run.optic_nodes)
    scaling = step_scaling(weather, states, sky, scene.ground_albedo)
    if scaling.ground_shape is not None:
        cols = cols.with_ground_shape(scaling.ground_shape)
    n_optics = 0 if cols.plan.weights is None else int(cols.plan.weights.n)
    plan = output_plan(scene, sky, states, settings, cols.resp, output,
                       face_block=scene.n_faces if run.coefficients is not None else run.face_block,
                       n_columns=cols.J_all, n_optics=n_optics)
    fblocks = plan.face_blocks
    whole = [tuple(b) for b in fblocks] == [(0, scene.n_faces)]      # one block: the whole scene
    k = scene.samples_per_face
    sun_dirs = states.sun_direction[plan.up]

    pool = None
    if not whole and run.coefficients is None and run.executor is None and (run.n_jobs or os.cpu_count() or 1) > 1:
        # one pool for every block of faces: its workers keep the scene (and their Embree scene) between blocks
        pool = geometry_pool(run.n_jobs or os.cpu_count() or 1, scene.geometry())

    def start(i):                                  # the ray casting of the i-th block of faces
        f0, f1 = fblocks[i]
        return start_coefficients(scene, mf=settings.mf, rays_per_patch=settings.rays_per_patch,
                                  sun_directions=sun_dirs, sun_bin=settings.sun_bin, n_jobs=run.n_jobs,
                                  executor=run.executor if pool is None else pool, progress=run.progress,
                                  optics=cols.plan.weights,
                                  reflections=settings.reflections,
                                  ground_albedo=(float(np.mean(states.albedo[plan.lit])) if scene.ground_albedo
                                                 is None and plan.lit.size else None),
                                  points=None if whole else (f0 * k, f1 * k))

    pending = sink = None
    failed = True
    try:
        pending = start(0) if run.coefficients is None else None
        sky_terms = evaluate_sky(sky, states, settings, cols.Wall, scaling, plan.lit)
        t_sky_ahead = sky_terms.seconds if (pending is not None and pending.running) else 0.0
        sink = Sink(plan.keys, T, scene.n_faces, sky.n_channels,
                    None if output.path is None else os.fspath(output.path), plan.kept_names, plan.kept_units,
                    FaceTable.from_scene(scene), output.spectral, output.compression, stored=plan.kept_parts,
                    angles=output.angles, arrays=output.arrays)
        grouped = None if whole else group_normals(scene)
        t_prod = t_consumer = t_wait = t_cast = 0.0
        n_rays = n_bins = 0
        for i, (f0, f1) in enumerate(fblocks):
            t_w = time.perf_counter()
            cf = pending.result() if pending is not None else run.coefficients
            t_wait += time.perf_counter() - t_w
            if i == 0:
                t_rays = time.perf_counter()
            check_coefficients(cf, (f1 - f0) * k, sky_terms.n_patches, sun_dirs.shape[0], cols.plan.weights)
            n_rays, n_bins = n_rays + cf.n_rays, cf.n_sun_bins
            t_cast += cf.seconds if pending is not None else 0.0
            # the next block's rays are cast (in the workers) while this process does this block's products
            pending = start(i + 1) if run.coefficients is None and i + 1 < len(fblocks) else None
            ctx = ProductContext(scene, cf, states, plan.lit, cols.J, cols.J_all, cols.col_mat, output.spectral,
                                 cols.spectral_ground, settings.time_chunk,
                                 fast_columns(cols.resp, cols.col_of, cols.plan, plan.stored), scaling.ground_steps,
                                 faces=None if whole else (f0, f1), grouped=grouped)
            del cf
            tp, tc = assemble_blocks(ctx, cols, plan, sink, scene, states, sky_terms, output.consumer,
                                     run.progress, faces=None if whole else (f0, f1))
            del ctx
            t_prod, t_consumer = t_prod + tp, t_consumer + tc
        cast = run.coefficients is None
        timings = {"rays": ((t_rays - t_start) if whole else t_cast) if cast else 0.0,
                   "sky_during_rays": t_sky_ahead, "n_rays": n_rays, "sun_bins": n_bins,
                   "sky": sky_terms.seconds, "product": t_prod, "steps": T, "lit_steps": int(plan.lit.size),
                   "face_blocks": len(fblocks), "rays_wait": t_wait if cast else 0.0}
        if output.consumer is not None:
            timings["consumer"] = t_consumer
        finish = dict(times=times, states=states, scaling=result_scaling(scaling, plan.lit_mask),
                      provenance=run_provenance(settings, run.optic_nodes, sky, output.provenance),
                      wavelengths=np.asarray(sky.wavelengths, dtype=float),
                      channel_edges=np.asarray(sky.channel_edges, dtype=float))
        sink.close(False, **finish)
        failed = False
    finally:
        if failed and sink is not None:
            sink.close(True)
        if failed and pending is not None:
            pending.cancel()
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    timings["total"] = time.perf_counter() - t_start
    return sink.result(timings, **finish)
