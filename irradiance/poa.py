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
from .products import GlobalParts, ProductContext, check_coefficients, chunk_products, fast_columns
from .raycast import start_coefficients
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
    plan = output_plan(scene, sky, states, settings, cols.resp, output)
    sun_dirs = states.sun_direction[plan.up]
    pending = None
    if run.coefficients is None:
        pending = start_coefficients(scene, mf=settings.mf, rays_per_patch=settings.rays_per_patch,
                                     sun_directions=sun_dirs, sun_bin=settings.sun_bin, n_jobs=run.n_jobs,
                                     executor=run.executor, progress=run.progress, optics=cols.plan.weights,
                                     reflections=settings.reflections,
                                     ground_albedo=(float(np.mean(states.albedo[plan.lit])) if scene.ground_albedo
                                                    is None and plan.lit.size else None))
    sky_terms = evaluate_sky(sky, states, settings, cols.Wall, scaling, plan.lit)
    t_sky_ahead = sky_terms.seconds if (pending is not None and pending.running) else 0.0
    sink = None
    failed = True
    try:
        cf = pending.result() if pending is not None else run.coefficients
        check_coefficients(cf, scene.n_points, sky_terms.n_patches, sun_dirs.shape[0], cols.plan.weights)
        t_rays = time.perf_counter()
        ctx = ProductContext(scene, cf, states, plan.lit, cols.J, cols.J_all, cols.col_mat, output.spectral,
                             cols.spectral_ground, settings.time_chunk,
                             fast_columns(cols.resp, cols.col_of, cols.plan, plan.stored), scaling.ground_steps)
        sink = Sink(plan.keys, T, scene.n_faces, sky.n_channels,
                    None if output.path is None else os.fspath(output.path), plan.kept_names, plan.kept_units,
                    FaceTable.from_scene(scene), output.spectral, output.compression, stored=plan.kept_parts)
        t_prod, t_consumer = assemble_blocks(ctx, cols, plan, sink, scene, states, sky_terms,
                                             output.consumer, run.progress)
        timings = {"rays": (t_rays - t_start) if pending is not None else 0.0,
                   "sky_during_rays": t_sky_ahead, "n_rays": cf.n_rays, "sun_bins": cf.n_sun_bins,
                   "sky": sky_terms.seconds, "product": t_prod, "steps": T, "lit_steps": int(plan.lit.size)}
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
    timings["total"] = time.perf_counter() - t_start
    return sink.result(timings, **finish)
