"""``poa_irradiance``: per-face irradiance per response and part, in named stages.

Stages (see :mod:`widesky.irradiance.integrator` for the method):

1. **weights** (:func:`contraction_columns`): every response becomes one contraction column of the
   sky's channels (or, for an angle x wavelength optic, one per incidence-angle class node), each
   tied to the sky coefficients it multiplies (plain, or those of an optic's weight function);
2. **sky chunks** (:func:`_SkyChunks`): the sky model per chunk of steps, contracted with the
   columns, scaled by the Earth-Sun distance, the per-step (and per-channel) factors and the
   measured-weather match; evaluated ahead while the ray-casting tasks run;
3. **products** (:func:`chunk_products`): per chunk the sky, reflected and beam terms per column
   (matrix products with the coefficients of :func:`widesky.irradiance.raycast.compute_coefficients`);
4. **assembly** (:func:`assemble_parts`): columns into each response's direct, sky-diffuse and
   reflected parts with the optics applied (the beam's exactly at each step's angle of incidence),
   averaged over each face's points, written into a block of steps that a sink keeps in memory
   or streams to the HDF5 result file (bounded memory: one block at a time).
"""

from __future__ import annotations

import hashlib
import importlib.metadata as md
import os
import time
from dataclasses import asdict
from typing import NamedTuple

import numpy as np
from tqdm.auto import tqdm

from .allsky import AllSkyOptions
from .allsky_sky import AllSkyWeather, allsky_patch_radiance
from .ground import vegetation_albedo_shape
from .integrator import (IntegratorSettings, horizontal_diffuse, lazy_zeros, patch_radiance)
from .measured import measured_scale_factors
from .optics import DEFAULT_NODES, plan_optics
from .patches import cosine_weights, reinhart
from .raycast import Coefficients, start_coefficients
from .response import Response
from .result import ALL_PARTS, PARTS, FaceTable, H5Writer, POAResult, atomic_h5, chunk_shape
from .scene import Scene
from .skies import SkyStates

__all__ = ["poa_irradiance", "contraction_columns", "estimate_run", "GlobalParts"]

#: Memory for one block of output steps held before it is written [bytes].
BLOCK_BYTES = 384 << 20


def _as_responses(sky, responses):
    """[Response-like (name, weights (C,), unit, Response or None)], "broadband" first."""
    edges = np.asarray(sky.channel_edges, dtype=float)
    lo, hi = edges[:-1], edges[1:]
    C = sky.n_channels
    out = [("broadband", np.ones(C), "W m-2", None)]
    if responses is None:
        items = []
    elif isinstance(responses, dict):
        items = list(responses.items())
    else:
        items = []
        for r in responses:
            if not isinstance(r, Response):
                raise TypeError(f"responses: expected Response objects, got {type(r).__name__}")
            items.append((r.name, r))
    seen = {"broadband"}
    for name, r in items:
        name = str(name)
        if name in seen:
            raise ValueError(f"response name {name!r} given twice (\"broadband\" is always computed)"
                             if name != "broadband" else
                             "response name 'broadband' is reserved (always computed first)")
        seen.add(name)
        if isinstance(r, Response):
            out.append((name, r.channel_weights(lo, hi), r.output_unit, r))
        else:
            a = np.asarray(r, dtype=float)
            if a.shape != (C,) or not np.all(np.isfinite(a)):
                raise ValueError(f"response {name!r} must be finite with shape ({C},), got {a.shape}")
            out.append((name, a, "W m-2", None))
    return out


def contraction_columns(sky, responses, optic_nodes=DEFAULT_NODES):
    """Stage 1: contraction columns of the responses and the optics they need.

    Returns
    -------
    resp : list
        (name, weights (C,), unit, Response or None) per response.
    W : numpy.ndarray
        (C, J) contraction matrix [nm x weight unit]: sky spectral radiance -> contracted radiance.
    col_matrix : numpy.ndarray
        (J,) int: -1 for the plain sky coefficients, else the optic weight function.
    col_of : list of list of int
        Columns of each response (one, or one per class node).
    plan : irradiance.optics.OpticPlan
    """
    resp = _as_responses(sky, responses)
    plan = plan_optics([r[3] if r[3] is not None else _NoOptic for r in resp], optic_nodes)
    edges = np.asarray(sky.channel_edges, dtype=float)
    widths = np.diff(edges)
    cols, mats, col_of = [], [], []
    for i, (name, w, unit, r) in enumerate(resp):
        kind = plan.kind[i]
        if kind == "spectral":
            tab = r.angular_factor(plan.nodes, edges[:-1], edges[1:])       # (A, C)
            js = []
            for a in range(plan.nodes.size):
                js.append(len(cols))
                cols.append(w * widths * tab[a])
                mats.append(plan.index[i] + a)
            col_of.append(js)
        else:
            col_of.append([len(cols)])
            cols.append(w * widths)
            mats.append(plan.index[i] if kind == "angular" else -1)
    return resp, np.array(cols).T, np.array(mats, dtype=int), col_of, plan


class _NoOptic:
    angular = None
    spectral_angular = False
    name = "broadband"


def stored_parts(names, parts):
    """The parts kept per response: ``parts`` (dict name -> part or parts, see
    :func:`poa_irradiance`) checked against the response names; tuple of tuples, in ``names``' order."""
    if parts is None:
        parts = {}
    if not isinstance(parts, dict):
        raise TypeError(f"parts: expected a dict response name -> parts, got {type(parts).__name__}")
    unknown = sorted(set(map(str, parts)) - set(names))
    if unknown:
        raise ValueError(f"parts names response(s) {unknown} that are not computed; responses: {list(names)}")
    if "broadband" in parts:
        raise ValueError("parts: 'broadband' always keeps its three parts (poa_direct ... poa_ground_diffuse)")
    out = []
    for n in names:
        v = parts.get(n, PARTS)
        v = (v,) if isinstance(v, str) else tuple(v)
        bad = [p for p in v if p not in ALL_PARTS]
        if bad:
            raise ValueError(f"parts[{n!r}]={v!r}: each part must be one of {ALL_PARTS} (or none: "
                             "the response is then only handed to a consumer)")
        out.append(tuple(p for p in ALL_PARTS if p in v))
    return tuple(out)


def estimate_run(n_faces, n_steps, n_responses=1, spectral=False, n_channels=55):
    """Output size of a run: (bytes of the (T, F) float32 arrays, bytes of a spectral part)."""
    per = 4 * int(n_faces) * int(n_steps)
    return per * (3 * int(n_responses) + 2), (per * int(n_channels) * 4 if spectral else 0)


def _dataset_provenance(sky):
    model = getattr(sky, "model", None)
    path = getattr(model, "path", None)
    out = {"sky": type(sky).__name__}
    if path and os.path.isfile(str(path)):
        st = os.stat(str(path))
        key = (str(path), st.st_size, st.st_mtime_ns)
        if key not in _SHA1:
            h = hashlib.sha1()
            with open(str(path), "rb") as f:
                for b in iter(lambda: f.read(1 << 22), b""):
                    h.update(b)
            _SHA1[key] = h.hexdigest()
        out.update(dataset=str(path), dataset_sha1=_SHA1[key])
    return out


_SHA1: dict = {}


def _versions():
    out = {}
    for pkg in ("widesky", "numpy", "embreex", "h5py"):
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            pass
    return out


class _Sink:
    """Where the blocks of output steps go: arrays in memory, or the HDF5 file."""

    def __init__(self, keys, T, F, C, path, resp_names, units, faces, spectral, compression=None,
                 stored=None):
        self.keys, self.T, self.F, self.C = keys, T, F, C
        self.path, self.writer, self.ctx = path, None, None
        self.spectral = spectral
        if path is None:
            self.full = {k: lazy_zeros((T, F), np.float32) for k in keys}
            self.full["aoi"] = lazy_zeros((T, F), np.float32)
            self.full["sun_visible"] = lazy_zeros((T, F), np.float32)
            if spectral:
                for p in PARTS + ("global",):
                    self.full[("spectral", p)] = lazy_zeros((T, F, C), np.float32)
        else:
            self.ctx = atomic_h5(path)
            f = self.ctx.__enter__()
            self.writer = H5Writer(f, resp_names, units, faces, T, C if spectral else None,
                                   compression, parts=stored)

    def block(self, b0, b1):
        """dict key -> (b1 - b0, F) zeroed arrays (aoi NaN) to fill for steps b0:b1."""
        n = b1 - b0
        if self.writer is None:
            out = {k: v[b0:b1] for k, v in self.full.items()}
            out["aoi"][:] = np.nan
            return out
        # one set of block buffers, reused (fresh multi-100-MB arrays per block cost seconds of
        # page faults)
        if getattr(self, "_buf", None) is None or self._buf_n < n:
            shape = {k: (n, self.F) for k in [*self.keys, "aoi", "sun_visible"]}
            if self.spectral:
                shape.update({("spectral", p): (n, self.F, self.C) for p in PARTS + ("global",)})
            self._buf = {k: lazy_zeros(v, np.float32) for k, v in shape.items()}
            self._buf_n = n
        out = {k: v[:n] for k, v in self._buf.items()}
        for k, v in out.items():
            v.fill(np.nan if k == "aoi" else 0.0)
        return out

    def flush(self, b0, block):
        if self.writer is not None:
            self.writer.write(b0, block)

    def close(self, failed, **finish):
        if self.writer is None:
            return
        if not failed:
            self.writer.finish(**finish)
        self.ctx.__exit__(RuntimeError if failed else None, None, None)


def _allsky_setup(spectral_model, measured, T, sky, options):
    """(AllSkyWeather, AllSkyOptions, dataset min visibility [km]) for spectral_model="allsky", else None."""
    if spectral_model not in ("clear", "allsky"):
        raise ValueError(f"spectral_model={spectral_model!r} is not one of ('clear', 'allsky')")
    if spectral_model == "clear":
        return None
    if measured is None:
        raise ValueError("spectral_model='allsky' needs measured=(dni, dhi) or an AllSkyWeather")
    wx = measured if isinstance(measured, AllSkyWeather) else AllSkyWeather(*tuple(measured)[:2])
    wx = AllSkyWeather(*(None if v is None else np.broadcast_to(np.asarray(v, float), (T,)) for v in wx))
    model = getattr(sky, "model", None)
    vmin = float(np.min(model.visibility_range)) if model is not None else 20.0
    return wx, options if options is not None else AllSkyOptions(), vmin


def poa_irradiance(scene: Scene, sky, states: SkyStates, *, responses=None, settings=None,
                   measured=None, times=None, dni_scale=None, diffuse_scale=None, output=None,
                   spectral=False, n_jobs=None, executor=None, progress=False, coefficients=None,
                   optic_nodes=DEFAULT_NODES, provenance=None, block_steps=None, compression=None,
                   spectral_model="clear", allsky_options=None, parts=None, consumer=None):
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
    measured : tuple of array_like, optional
        (dni, dhi): (T,) measured direct normal and diffuse horizontal irradiance [W m-2] (NaN =
        missing: the clear sky is kept); the per-step factors (:func:`widesky.irradiance.measured_scale_factors`
        on the model's own DNI/DHI from the same quadrature) are kept in ``result.scaling``. Not
        together with ``dni_scale``/``diffuse_scale``.
        With ``spectral_model="allsky"`` it may be an :class:`widesky.irradiance.AllSkyWeather` (adds GHI,
        station visibility and dew point).
    spectral_model : {"clear", "allsky"}
        With ``measured``: "clear" scales the clear sky's spectral and angular shape to the measured
        DNI/DHI; "allsky" uses :mod:`widesky.irradiance.allsky` (per-step, per-channel factors and CIE
        overcast light; the same broadband DNI/DHI, docs/all-sky.md).
    allsky_options : AllSkyOptions, optional
        Switches of the all-sky model (default all parts on).
    times : pandas.DatetimeIndex, optional
        (T,) labels of the steps (default ``states.times``).
    dni_scale, diffuse_scale : array_like, optional
        (T,) or (T, C) factors [1] on the sun's direct normal irradiance and on the sky radiance
        ((T, C): per channel, applied to the spectral values before contraction); the reflected
        light follows.
    output : str or path-like, optional
        HDF5 file the result streams to during the run (written atomically; the returned result
        reads from it). None keeps the result in memory.
    spectral : bool
        Also keep the spectral parts (T, F, C) [W m-2 nm-1] (broadband, no optics; large).
    n_jobs : int, optional
        Ray-casting processes (default all cores), >= 1.
    executor : concurrent.futures.Executor, optional
        Runs the ray-casting tasks (e.g. a Dask client's executor).
    progress : bool
        Progress bars.
    coefficients : Coefficients, optional
        Precomputed for this scene, settings, these states' daylight sun directions and the
        responses' optics.
    optic_nodes : sequence of float
        Incidence-angle class nodes [deg] of angle x wavelength optics (from 0 to 90).
    provenance : dict, optional
        Extra entries (e.g. the command line) for ``result.provenance``.
    block_steps : int, optional
        Steps per output block (default: a block of about 384 MB).
    compression : {None, "lzf", "gzip"}
        Compression of the result file's (T, F) datasets (None: fastest, see
        :mod:`widesky.irradiance.result`).
    parts : dict of str to str or sequence of str, optional
        Per response (not "broadband") the parts to keep, from "direct", "sky_diffuse",
        "ground_diffuse" and "global" (default: the three parts, "global" read as their sum). A
        response kept as ``"global"`` alone is stored as one (T, F) array, the float32 sum of its
        three face-mean parts (the same numbers ``get(name, "global")`` gives from a full run), so
        many responses of which only the total is needed (PV cell currents) cost a third of the
        output; ``get`` of a part not kept is a ValueError. An empty tuple keeps nothing: the
        response is computed only for ``consumer`` (and absent from the result). Responses kept as
        "global" only (or not at all) without an angle x wavelength optic take the fused product:
        sky and reflected light through one matrix per optic, ``X @ (D + R x reflection optic)``,
        averaged over each face's points before the product (equal to the three-part sum within
        float32 rounding: tests/test_poa_parts.py).
    consumer : callable, optional
        Called once per chunk of daylight steps, when the chunk is assembled, as
        ``consumer(steps, block, rows, currents)``: ``steps`` (Tc,) step indices; ``block`` dict key
        -> (n, F) float32 arrays of the current output block (the kept parts as ``(name, part)``,
        ``"aoi"`` [deg] and ``"sun_visible"`` [1]), the chunk's values at rows ``rows`` (Tc,);
        ``currents`` dict name -> :class:`GlobalParts` of every response the fused product serves
        and of every response kept for the consumer only (the fused product's factors, so a consumer
        can use them without a copy; other kept globals are in ``block``). The
        arrays are reused afterwards: a consumer reduces them, it does not keep them (pvsim's yield
        model uses this to never write sub-cell currents).

    Returns
    -------
    POAResult
    """
    t_start = time.perf_counter()
    settings = settings or IntegratorSettings()
    if n_jobs is not None and int(n_jobs) < 1:
        raise ValueError(f"n_jobs={n_jobs} must be >= 1 (processes)")
    T, C = len(states), sky.n_channels
    times = states.times if times is None else times
    if times is not None and len(times) != T:
        raise ValueError(f"times has {len(times)} steps, the states {T}")
    resp, W, col_mat, col_of, plan = contraction_columns(sky, responses, optic_nodes)
    J = W.shape[1]
    Wall = np.concatenate([W, np.eye(C) if spectral else np.zeros((C, 0))], axis=1)
    ga = scene.ground_albedo
    spectral_ground = ga is not None and np.ndim(ga) == 1
    if spectral_ground:
        if np.shape(ga) != (C,):
            raise ValueError(f"ground_albedo has {np.shape(ga)[0]} channels, the sky {C}")
    J_all = Wall.shape[1]
    if spectral_ground:
        Wall = np.concatenate([Wall, np.asarray(ga)[:, None] * Wall], axis=1)

    # per-step factors
    scale_d, scale_s = np.ones(T), np.ones(T)
    if measured is not None:
        if dni_scale is not None or diffuse_scale is not None:
            raise ValueError("give measured=(dni, dhi) or dni_scale/diffuse_scale, not both")
        m_dni, m_dhi = (np.broadcast_to(np.asarray(a, dtype=float), (T,)) for a in tuple(measured)[:2])
        measured_scale_factors(np.ones(T), np.ones(T), m_dni, m_dhi)     # validates the inputs
        model_dni, model_dhi = np.zeros(T), np.zeros(T)
    allsky_in = _allsky_setup(spectral_model, measured, T, sky, allsky_options)
    ground_shape, ground_steps = None, None
    if allsky_in is not None and allsky_in[1].ground == "vegetation" and ga is None:
        # the all-sky ground: a vegetation shape (albedo-weighted columns) and a grey part, per step
        ground_shape = vegetation_albedo_shape(sky.wavelengths)
        ground_steps = (np.zeros(T), np.asarray(states.albedo, dtype=float).copy())
        spectral_ground = True
        Wall = np.concatenate([Wall, ground_shape[:, None] * Wall], axis=1)
    for name, v in (("dni_scale", dni_scale), ("diffuse_scale", diffuse_scale)):
        if v is not None:
            a = np.asarray(v, dtype=float)
            if a.shape not in ((T,), (T, C)) and a.ndim != 0:
                raise ValueError(f"{name} has shape {a.shape}, expected ({T},) or ({T}, {C})")
            if not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ValueError(f"{name} must be finite and >= 0")
    ch_sun = None if dni_scale is None else np.broadcast_to(
        np.asarray(dni_scale, float).reshape((T, -1) if np.ndim(dni_scale) else (1, 1)), (T, C))
    ch_sky = None if diffuse_scale is None else np.broadcast_to(
        np.asarray(diffuse_scale, float).reshape((T, -1) if np.ndim(diffuse_scale) else (1, 1)),
        (T, C))

    patches = reinhart(settings.mf)
    P = patches.n_patches
    w_horizontal = cosine_weights(patches, np.array([[0.0, 0.0, 1.0]]))[0]      # (P,) [sr]
    el = states.sun_elevation
    lit = np.nonzero(el > getattr(sky, "min_sun_elevation", 0.0))[0]
    up = el > 0
    sun_rank = np.cumsum(up) - 1
    sun_dirs = states.sun_direction[up]
    F, k, N = scene.n_faces, scene.samples_per_face, scene.n_points
    faces_tab = FaceTable.from_scene(scene)
    names = [r[0] for r in resp]
    units = {r[0]: r[2] for r in resp}
    stored = stored_parts(names, parts)
    keys = [(n, p) for n, st in zip(names, stored) for p in st]
    transient = [n for n, st in zip(names, stored) if not st]
    if transient and consumer is None:
        raise ValueError(f"parts keeps nothing of {transient} and no consumer reads them")
    kept_names = [n for n, st in zip(names, stored) if st]

    # output blocks of consecutive steps, each cut into chunks of lit steps sorted by sky state
    # (sources that share work between equal states see them together)
    n_arr = len(keys) + 2 + (4 * C if spectral else 0)
    if block_steps is None:
        block_steps = max(settings.time_chunk, BLOCK_BYTES // max(1, 4 * F * n_arr))
    block_steps = int(max(1, block_steps))
    if output is not None:
        # whole HDF5 chunks per block: a block edge inside a chunk makes HDF5 read it back
        tc = chunk_shape(max(T, 1), max(F, 1))[0]
        block_steps = max(tc, block_steps // tc * tc)
    blocks = [(b0, min(T, b0 + block_steps)) for b0 in range(0, T, block_steps)] or [(0, 0)]
    lit_mask = np.zeros(T, bool)
    lit_mask[lit] = True
    chunk_plan = []                                   # (block index, step indices)
    for bi, (b0, b1) in enumerate(blocks):
        sel = np.nonzero(lit_mask[b0:b1])[0] + b0
        key_el = np.round(el[sel], 1)
        sel = sel[np.lexsort((states.albedo[sel], states.visibility[sel], key_el))]
        for c0 in range(0, sel.size, settings.time_chunk):
            chunk_plan.append((bi, np.sort(sel[c0:c0 + settings.time_chunk])))

    pending = None
    if coefficients is None:
        pending = start_coefficients(scene, mf=settings.mf, rays_per_patch=settings.rays_per_patch,
                                     sun_directions=sun_dirs, sun_bin=settings.sun_bin,
                                     n_jobs=n_jobs, executor=executor, progress=progress,
                                     optics=plan.weights)
    t_sky = 0.0

    def sky_chunk(idx):
        """Stage 2: contracted patch radiance and direct normal irradiance of steps ``idx``."""
        nonlocal t_sky
        t0 = time.perf_counter()
        st = states.take(idx)
        if allsky_in is not None:                  # all-sky model: factors per step and channel
            Lp, dni, f, (model_dni[idx], model_dhi[idx]), g = allsky_patch_radiance(
                sky, patches, st, Wall, settings, allsky_in[0].take(idx), allsky_in[1], allsky_in[2],
                ground_shape=ground_shape)
            if g is not None:
                ground_steps[0][idx], ground_steps[1][idx] = g
            scale_d[idx], scale_s[idx] = f.scaling.sun_scale, f.scaling.sky_scale
            t_sky += time.perf_counter() - t0
            return Lp, dni
        Lp, dni, cs = patch_radiance(sky, patches, st, Wall, settings,
                                     sun_scale=None if ch_sun is None else ch_sun[idx],
                                     sky_scale=None if ch_sky is None else ch_sky[idx])
        if measured is not None:                   # column 0 is broadband: the model's DNI, DHI
            model_dni[idx] = dni[:, 0]
            model_dhi[idx] = horizontal_diffuse(Lp[..., 0], cs[:, 0], w_horizontal, st.sun_elevation)
            f = measured_scale_factors(model_dni[idx], model_dhi[idx], m_dni[idx], m_dhi[idx],
                                       missing="clear")
            scale_d[idx], scale_s[idx] = f.sun_scale, f.sky_scale
        # circumsolar light travels with the sun but is sky light: it takes the sky's scale
        dni = dni * scale_d[idx][:, None] + cs * scale_s[idx][:, None]
        Lp *= scale_s[idx][:, None, None]
        t_sky += time.perf_counter() - t0
        return Lp, dni

    # the sky of every daylight step, evaluated in chunks sorted by sky state over the whole period
    # (equal states share a sky-model call; output blocks of consecutive steps would split them),
    # while the ray-casting tasks run; kept contracted (T_lit x P x columns, float32: small)
    pos = np.full(T, -1)
    pos[lit] = np.arange(lit.size)
    Lp_all = np.zeros((lit.size, P, Wall.shape[1]), np.float32)
    dni_all = np.zeros((lit.size, Wall.shape[1]))
    order = lit[np.lexsort((states.albedo[lit], states.visibility[lit], np.round(el[lit], 1)))]
    for c0 in range(0, order.size, settings.time_chunk):
        idx = np.sort(order[c0:c0 + settings.time_chunk])
        Lp_c, dni_c = sky_chunk(idx)
        Lp_all[pos[idx]] = Lp_c
        dni_all[pos[idx]] = dni_c
    t_sky_ahead = t_sky if (pending is not None and pending.running) else 0.0
    sink = None
    failed = True
    try:
        if pending is not None:
            coefficients = pending.result()
        cf: Coefficients = coefficients
        if cf.sky.shape != (N, P) or cf.n_sun != sun_dirs.shape[0]:
            raise ValueError("coefficients do not match this scene, settings and states")
        if plan.weights is not None and (cf.sky_optic is None or
                                         cf.sky_optic.shape[0] != plan.weights.n):
            raise ValueError("coefficients lack the optics of these responses")
        t_rays = time.perf_counter()
        ctx = _ProductContext(scene, cf, states, lit, J, J_all, col_mat, spectral,
                              spectral_ground, settings.time_chunk,
                              fast_columns(resp, col_of, plan, stored), ground_steps)
        sink = _Sink(keys, T, F, C, None if output is None else os.fspath(output), kept_names,
                     {n: units[n] for n in kept_names}, faces_tab, spectral, compression,
                     stored={n: st for n, st in zip(names, stored) if st})
        t_prod = t_consumer = 0.0
        ci = 0
        bar = None
        if progress:
            bar = tqdm(total=len(chunk_plan), unit="chunk", desc="time series")
        face_nT = np.ascontiguousarray(np.asarray(scene.face_normal, dtype=np.float32).T)
        sun_dir32 = states.sun_direction.astype(np.float32)
        invalid = ~scene.face_valid
        for bi, (b0, b1) in enumerate(blocks):
            if b1 <= b0:
                continue
            block = sink.block(b0, b1)
            upb = np.nonzero(up[b0:b1])[0]
            if upb.size:                           # beam angle of incidence of every face
                cz = sun_dir32[b0 + upb] @ face_nT
                np.clip(cz, -1.0, 1.0, out=cz)
                np.arccos(cz, out=cz)
                cz *= np.float32(180.0 / np.pi)
                block["aoi"][upb] = cz
            while ci < len(chunk_plan) and chunk_plan[ci][0] == bi:
                idx = chunk_plan[ci][1]
                band = np.full(idx.size, -1)
                band[up[idx]] = cf.step_band(sun_rank[idx[up[idx]]])
                order = np.argsort(band, kind="stable")      # steps of one shading cell together
                idx, band = idx[order], band[order]
                Lp, dni = Lp_all[pos[idx]].astype(np.float64), dni_all[pos[idx]]
                t1 = time.perf_counter()
                terms = chunk_products(ctx, idx, Lp, dni, up, sun_rank, band)
                currents = assemble_parts(ctx, resp, col_of, plan, terms, block, idx - b0, names,
                                          stored)
                if consumer is not None:
                    if np.any(invalid):
                        for v in block.values():
                            v[np.ix_(idx - b0, np.nonzero(invalid)[0])] = 0
                        for gp in currents.values():
                            gp.diffuse[:, invalid] = 0
                            gp.beam[:, invalid] = 0
                    t_prod += time.perf_counter() - t1
                    t1 = time.perf_counter()
                    consumer(idx, block, idx - b0, currents)
                    t_consumer += time.perf_counter() - t1
                    t1 = time.perf_counter()
                t_prod += time.perf_counter() - t1
                ci += 1
                if bar is not None:
                    bar.update(1)
            if np.any(invalid):
                for v in block.values():
                    v[:, invalid] = 0
            sink.flush(b0, block)
        if bar is not None:
            bar.close()
        scaling = None
        if measured is not None:
            dark = ~lit_mask
            f = measured_scale_factors(model_dni, model_dhi, m_dni, m_dhi, missing="clear")
            scaling = f._replace(sun_scale=scale_d, sky_scale=scale_s,
                                 sun_guarded=f.sun_guarded & ~dark, sky_guarded=f.sky_guarded & ~dark)
        prov = {"settings": asdict(settings), "optic_nodes": list(map(float, optic_nodes)),
                "versions": _versions(), **_dataset_provenance(sky), **(provenance or {})}
        timings = {"rays": (t_rays - t_start) if pending is not None else 0.0,
                   "sky_during_rays": t_sky_ahead, "n_rays": cf.n_rays, "sun_bins": cf.n_sun_bins,
                   "sky": t_sky, "product": t_prod, "steps": T, "lit_steps": int(lit.size)}
        if consumer is not None:
            timings["consumer"] = t_consumer
        finish = dict(times=times, states=states, scaling=scaling, provenance=prov,
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
    if output is not None:
        res = POAResult.load(output)
        res.timings = timings
        return res
    full = sink.full
    spec = ({p: full[("spectral", p)] for p in PARTS + ("global",)} if spectral else None)
    return POAResult(responses=kept_names, units={n: units[n] for n in kept_names},
                     data={k: full[k] for k in keys},
                     aoi=full["aoi"], sun_visible=full["sun_visible"], faces=faces_tab, times=times,
                     states=states, scaling=scaling, provenance=prov, spectral=spec,
                     wavelengths=finish["wavelengths"], channel_edges=finish["channel_edges"],
                     timings=timings)


class GlobalParts(NamedTuple):
    """A response's global part on the faces of a chunk of steps, factored as the fused product
    gives it: ``diffuse + dni[:, None] * beam`` [the response's unit].

    Attributes
    ----------
    diffuse : numpy.ndarray
        (Tc, F) float32 sky-diffuse plus reflected light after the optics (may be a row-strided view).
    dni : numpy.ndarray
        (Tc,) float32 contracted direct normal irradiance.
    beam : numpy.ndarray
        (Tc, F) float32 face mean of ``max(0, cos aoi) x sun visibility x angular optic`` [1].
    """

    diffuse: np.ndarray
    dni: np.ndarray
    beam: np.ndarray

    def total(self, out=None):
        """(Tc, F) float32 global part."""
        out = np.multiply(self.beam, self.dni[:, None], out=out)
        out += self.diffuse
        return out


def fast_columns(resp, col_of, plan, stored):
    """[(response index, column, optic matrix)] of the responses the fused product serves: kept as
    "global" only (or not at all) with no optic or an angle-only one (matrix -1: none)."""
    out = []
    for i in range(len(resp)):
        if stored[i] in (("global",), ()) and plan.kind[i] in ("none", "angular"):
            out.append((i, col_of[i][0], -1 if plan.kind[i] == "none" else int(plan.index[i])))
    return out


class _ProductContext:
    """The coefficient matrices in the layout of the products, and reusable work buffers."""

    def __init__(self, scene, cf, states, lit, J, J_all, col_mat, spectral, spectral_ground,
                 tmax, fast=(), ground_steps=None):
        N, P = cf.sky.shape
        self.N, self.P, self.F, self.k = N, P, scene.n_faces, scene.samples_per_face
        self.J, self.J_all, self.C = J, J_all, J_all - J
        self.spectral, self.spectral_ground = spectral, spectral_ground
        self.ga = scene.ground_albedo
        # (a_shape, a_grey) (T,): per-step spectral ground = a_shape x the albedo-weighted columns'
        # shape + a_grey (the all-sky vegetated ground); None: the scene's or the states' albedo
        self.ground_steps = ground_steps
        self.col_mat = np.concatenate([col_mat, -np.ones(J_all - J, dtype=int)])
        self.cf = cf
        self.D_T = {-1: np.ascontiguousarray(cf.sky.T, dtype=np.float32)}            # (P, N)
        for m in np.unique(col_mat[col_mat >= 0]):
            self.D_T[int(m)] = np.ascontiguousarray(cf.sky_optic[m].T, dtype=np.float32)
        self.refl_factor = None if cf.reflect_optic is None else cf.reflect_optic.astype(np.float32)
        self.sun_dir = states.sun_direction                                        # (T, 3)
        self.albedo = states.albedo
        alb = states.albedo[lit]
        ga = self.ga
        if ground_steps is not None:
            fold = None
        elif ga is not None and np.ndim(ga) == 0:
            fold = float(ga)
        elif ga is None and (alb.size == 0 or np.all(alb == alb[0])):
            fold = float(alb[0]) if alb.size else 0.0
        else:
            fold = None
        if fold is not None:
            self.R_T = np.ascontiguousarray((cf.reflect_sky + fold * cf.ground_sky).T, np.float32)
            self.A_T = None
        else:
            self.R_T = np.ascontiguousarray(cf.reflect_sky.T, dtype=np.float32)
            self.A_T = np.ascontiguousarray(cf.ground_sky.T, dtype=np.float32)
        self.wall_ground = cf.reflect_ground.astype(np.float32)                     # (N,)
        self.Ksun_T = np.ascontiguousarray(np.concatenate(
            [cf.reflect_sun / np.pi, cf.ground_sun[:, :, None]], axis=2).transpose(0, 2, 1),
            dtype=np.float32)                                                       # (G, B+1, N)
        self.normals_T = np.ascontiguousarray(scene.point_normal.T.astype(np.float32))   # (3, N)
        # points that share a normal share the beam's angle of incidence: an angular optic is
        # evaluated per distinct normal (rows of modules, the walls of a building: a handful)
        un, inv = np.unique(self.normals_T.T, axis=0, return_inverse=True)
        self.normal_groups = ((np.ascontiguousarray(un.T), inv.reshape(-1))
                              if un.shape[0] <= max(1, N // 4) else None)
        self.sun_vis = cf.sun_visibility_bins()                                      # (S_b, N)
        self.sun_bin_of = np.arange(cf.n_sun) if cf.sun_index is None else cf.sun_index
        self.Hb = reinhart_vector_z(P)
        self._fused_setup(fast if fold is not None else ())
        rows = tmax * self.slow_cols.size
        self.buf_sky = lazy_zeros((rows, N), np.float32)
        self.buf_refl = lazy_zeros((rows, N), np.float32)
        self.buf_aux = lazy_zeros((rows, N), np.float32)
        self.buf_tmp = lazy_zeros((tmax, N), np.float32)
        self.buf_cos = lazy_zeros((tmax, N), np.float32)
        self.buf_vis = lazy_zeros((tmax, N), np.float32)
        self.buf_beam = lazy_zeros((tmax, N), np.float32)
        self.buf_part = [lazy_zeros((tmax, N), np.float32) for _ in range(3)]
        self.buf_fast = {m: lazy_zeros((tmax, len(c), self.F), np.float32)
                         for m, c in self.fast_cols.items()}
        self.buf_fbeam = {m: lazy_zeros((tmax, self.F), np.float32) for m in self.fast_cols if m >= 0}

    def _fused_setup(self, fast):
        """The fused product's matrices per optic: ``[faces(D + R rf); faces(wall_ground rf);
        faces(Ksun rf) of a shading cell]`` (P + 1 + B + 1, F), the last rows set per cell, and the
        cells' nonzero reflector bins. Only where the ground albedo folds into R (constant)."""
        self.fast = list(fast)
        self.fast_cols = {}
        for _i, j, m in self.fast:
            self.fast_cols.setdefault(m, []).append(j)
        fj = {j for _i, j, _m in self.fast}
        self.slow_cols = np.array([j for j in range(self.J_all) if j not in fj], dtype=int)
        self.slow_pos = np.full(self.J_all, -1)
        self.slow_pos[self.slow_cols] = np.arange(self.slow_cols.size)
        self.fast_mat = {}
        P = self.P
        for m in self.fast_cols:
            rf = None if m < 0 else self.refl_factor[m].astype(np.float64)
            top = self.D_T[m].astype(np.float64)
            top += self.R_T if rf is None else self.R_T * rf
            wg = self.wall_ground.astype(np.float64) * (1.0 if rf is None else rf)
            ks = self.Ksun_T if rf is None else self.Ksun_T * rf.astype(np.float32)
            ks = np.ascontiguousarray(self.faces(ks), dtype=np.float32)                # (G, B+1, F)
            W = np.empty((P + 1 + ks.shape[1], self.F), np.float32)
            W[:P] = self.faces(top)
            W[P] = self.faces(wg)
            nz = [np.nonzero(np.any(ks[g] != 0, axis=1))[0] for g in range(ks.shape[0])]
            self.fast_mat[m] = (W, ks, nz)

    def faces(self, a):
        """(..., N) -> (..., F): mean over each face's points."""
        k, F = self.k, self.F
        return a if k == 1 else a.reshape(a.shape[:-1] + (F, k)).mean(axis=-1)


def reinhart_vector_z(P):
    """(P,) vertical components of the patches' solid-angle vectors [sr] (horizontal weights)."""
    mf = int(round(np.sqrt((P - 1) / 144.0)))
    return reinhart(mf).vector[:, 2]


def chunk_products(ctx: _ProductContext, idx, Lp, dni, up, sun_rank, band=None):
    """Stage 3: per column the sky, reflected and beam terms of the steps ``idx``.

    Returns a dict: ``sky`` (Tc, J', N) sky-diffuse per column (the column's own coefficients),
    ``refl`` (Tc, J', N) reflected light per column (no optic), ``beam`` (Tc, N) ``max(0, n . s)
    x sun visibility`` [1], ``cos`` (Tc, N) ``n . s`` (for the optics' angles; 0 with the sun down),
    ``dni`` (Tc, J') float32 contracted direct normal irradiance, ``vis`` (Tc, N) sun visibility;
    ``sky`` and ``refl`` hold the columns ``ctx.slow_cols`` (at ``ctx.slow_pos``); ``fast`` dict
    optic matrix -> (Tc, columns, F) face-mean sky + reflected light after the optic of the fused
    columns ``ctx.fast_cols`` (``band``, the steps' shading cells, then runs in blocks of one cell).
    """
    cf = ctx.cf
    Tc, N, P = idx.size, ctx.N, ctx.P
    s = ctx.sun_dir[idx]
    sin_el = np.maximum(s[:, 2], 0.0)
    alb_steps = ctx.albedo[idx]
    Hs = np.einsum("tpr,p->tr", Lp, ctx.Hb)                                 # (Tc, J') sky GHI
    Hd = dni * sin_el[:, None]                                              # sun GHI
    R = ctx.J_all
    if ctx.spectral_ground:                        # the last columns are albedo-weighted
        g_sky, g_sun = Hs[:, R:] / np.pi, Hd[:, R:] / np.pi
        Lp_alb = Lp[..., R:]
        if ctx.ground_steps is not None:           # per step: shape x a_shape + grey a_grey
            a1, a0 = (g[idx][:, None] for g in ctx.ground_steps)
            g_sky = a1 * g_sky + a0 * Hs[:, :R] / np.pi
            g_sun = a1 * g_sun + a0 * Hd[:, :R] / np.pi
            Lp_alb = a1[:, :, None] * Lp_alb + a0[:, :, None] * Lp[..., :R]
        Lp, dni = Lp[..., :R], dni[:, :R]
    else:
        alb = (alb_steps if ctx.ga is None else np.full(Tc, float(ctx.ga)))[:, None]
        g_sky, g_sun = alb * Hs / np.pi, alb * Hd / np.pi                  # (Tc, J')
    Lg = g_sky + g_sun                             # unshaded ground radiance
    cos_b = np.maximum(s @ cf.bins.T, 0.0)                                  # (Tc, B)
    if band is None:
        band = np.full(Tc, -1)
        band[up[idx]] = cf.step_band(sun_rank[idx[up[idx]]])
    sc = ctx.slow_cols
    Rp = sc.size
    every = Rp == Lp.shape[2]
    Xs = np.ascontiguousarray((Lp if every else Lp[..., sc]).transpose(0, 2, 1), dtype=np.float32)
    sky_all = ctx.buf_sky[:Tc * Rp].reshape(Tc, Rp, N)
    mats = ctx.col_mat[sc]
    for m in np.unique(mats):
        cols = np.nonzero(mats == m)[0]
        if cols.size == Rp:
            np.matmul(Xs.reshape(Tc * Rp, P), ctx.D_T[int(m)], out=sky_all.reshape(Tc * Rp, N))
        else:
            X = np.ascontiguousarray(Xs[:, cols]).reshape(Tc * cols.size, P)
            sky_all[:, cols] = (X @ ctx.D_T[int(m)]).reshape(Tc, cols.size, N)
    refl_all = np.matmul(Xs.reshape(Tc * Rp, P), ctx.R_T, out=ctx.buf_refl[:Tc * Rp]).reshape(
        Tc, Rp, N)
    if ctx.A_T is not None:                        # the ground's albedo changes between steps
        Xa = Lp_alb if ctx.spectral_ground else alb[:, :, None] * Lp
        Xa = np.ascontiguousarray(Xa.transpose(0, 2, 1).reshape(Tc * Rp, P), dtype=np.float32)
        refl_all += np.matmul(Xa, ctx.A_T, out=ctx.buf_aux[:Tc * Rp]).reshape(Tc, Rp, N)
    Lg32 = Lg.astype(np.float32)
    tmp = ctx.buf_tmp[:Tc]
    for r, c in enumerate(sc):                     # walls pass on the unshaded ground's light
        refl_all[:, r] += np.multiply(Lg32[:, c:c + 1], ctx.wall_ground, out=tmp)
    for g in np.unique(band[band >= 0]) if Rp else ():   # reflected sun per shading cell
        rows = np.nonzero(band == g)[0]
        Xu = np.concatenate([dni[rows][:, None, sc] * cos_b[rows, :, None], g_sun[rows][:, None, sc]],
                            axis=1)                                         # (Tg, B+1, Rp)
        Xu = np.ascontiguousarray(Xu.transpose(0, 2, 1).reshape(rows.size * Rp, -1),
                                  dtype=np.float32)
        refl_all[rows] += np.matmul(Xu, ctx.Ksun_T[g], out=ctx.buf_aux[:rows.size * Rp]).reshape(
            rows.size, Rp, N)
    fast = {m: _fused_product(ctx, m, cols, Lp, Lg, dni, cos_b, g_sun, band)
            for m, cols in ctx.fast_cols.items()}
    cos, vis, beam = ctx.buf_cos[:Tc], ctx.buf_vis[:Tc], ctx.buf_beam[:Tc]
    cos.fill(0.0)
    vis.fill(0.0)
    upc = np.nonzero(up[idx])[0]
    cos_u = None if ctx.normal_groups is None else np.zeros((Tc, ctx.normal_groups[0].shape[1]),
                                                             np.float32)
    if upc.size:
        cos[upc] = s[upc].astype(np.float32) @ ctx.normals_T
        vis[upc] = ctx.sun_vis[ctx.sun_bin_of[sun_rank[idx[upc]]]]
        if cos_u is not None:
            cos_u[upc] = s[upc].astype(np.float32) @ ctx.normal_groups[0]
    np.maximum(cos, 0.0, out=beam)
    beam *= vis
    return {"sky": sky_all, "refl": refl_all, "beam": beam, "cos": cos, "vis": vis,
            "dni": dni.astype(np.float32), "fast": fast, "cos_u": cos_u}


def _fused_product(ctx, m, cols, Lp, Lg, dni, cos_b, g_sun, band):
    """(Tc, len(cols), F) face-mean sky + reflected light after optic ``m`` of columns ``cols``: per
    run of steps in one shading cell one product ``[L_patches | L_ground | DNI cos_bins | G_sun]
    @ [D + R rf; wall rf; Ksun rf]`` (only the cell's nonzero reflector bins)."""
    W, ks, nz = ctx.fast_mat[m]
    Tc, P, nc = Lp.shape[0], ctx.P, len(cols)
    P1 = P + 1
    X = np.empty((Tc, nc, W.shape[0]), np.float32)
    X[:, :, :P] = Lp[..., cols].transpose(0, 2, 1)
    X[:, :, P] = Lg[:, cols]
    X[:, :, P1:-1] = dni[:, cols][:, :, None] * cos_b[:, None, :]
    X[:, :, -1] = g_sun[:, cols]
    out = ctx.buf_fast[m][:Tc]
    starts = np.flatnonzero(np.r_[True, band[1:] != band[:-1]])
    for a, b in zip(starts, np.r_[starts[1:], Tc]):
        g = int(band[a])
        Gr = out[a:b].reshape((b - a) * nc, ctx.F)
        Xr = X[a:b].reshape((b - a) * nc, -1)
        if g < 0 or nz[g].size == 0:               # sun down, or no sunlit reflector in view
            np.matmul(Xr[:, :P1], W[:P1], out=Gr)
            continue
        q = nz[g]
        W[P1:P1 + q.size] = ks[g, q]
        np.matmul(np.concatenate([Xr[:, :P1], Xr[:, P1 + q]], axis=1), W[:P1 + q.size], out=Gr)
    return out


def assemble_parts(ctx: _ProductContext, resp, col_of, plan, terms, block, rows, names, stored=None):
    """Stage 4: each response's direct, sky-diffuse and reflected parts from its columns, the
    optics applied, averaged over each face's points, into ``block`` at ``rows``.

    ``stored`` (per response, from :func:`stored_parts`; default the three parts) names the parts
    kept; "global" is the float32 sum ``direct + sky_diffuse + ground_diffuse`` of the face means
    (what ``POAResult.get(name, "global")`` sums from the three), or for the fused columns their
    :class:`GlobalParts` total. An angle-only optic is evaluated once per chunk for all the
    responses that share it. Returns dict name -> :class:`GlobalParts` of the responses kept as
    "global" only or not at all.
    """
    sky_all, refl_all, beam, dni = terms["sky"], terms["refl"], terms["beam"], terms["dni"]
    Tc = beam.shape[0]
    aoi_pt = None
    f = ctx.faces
    b_dir, b_sky, b_ref = (b[:Tc] for b in ctx.buf_part)
    optic_at_aoi = {}                              # id(angular callable) -> (Tc, N) factor
    sp = ctx.slow_pos
    fast = {i: (j, m) for i, j, m in ctx.fast}
    fast_beam = {}
    currents = {}
    for i, (name, _w, _unit, r) in enumerate(resp):
        kind = plan.kind[i]
        js = col_of[i]
        if kind == "spectral" and aoi_pt is None:
            aoi_pt = np.degrees(np.arccos(np.clip(terms["cos"], 0.0, 1.0)))
        if kind == "angular":
            key = id(r.angular)
            if key not in optic_at_aoi:            # it multiplies the beam: only where that arrives
                optic_at_aoi[key] = _optic_on_beam(ctx, r.angular, terms)
        keep = PARTS if stored is None else stored[i]
        if i in fast:
            j, m = fast[i]
            if m not in fast_beam:                 # face mean of beam x optic, shared by the columns
                fast_beam[m] = f(beam) if m < 0 else f(np.multiply(
                    beam, optic_at_aoi[id(r.angular)], out=ctx.buf_fbeam[m][:Tc] if ctx.k == 1 else None))
            gp = GlobalParts(terms["fast"][m][:, ctx.fast_cols[m].index(j)], dni[:, j], fast_beam[m])
            currents[name] = gp
            if keep:
                block[(name, "global")][rows] = gp.total(out=b_dir[:, :ctx.F])
            continue
        if kind == "none":
            j = sp[js[0]]
            direct = np.multiply(dni[:, js[0]:js[0] + 1], beam, out=b_dir)
            skyd = sky_all[:, j]
            refl = refl_all[:, j]
        elif kind == "angular":
            j = sp[js[0]]
            g = optic_at_aoi[id(r.angular)]
            direct = np.multiply(dni[:, js[0]:js[0] + 1], beam, out=b_dir)
            direct *= g
            skyd = sky_all[:, j]
            refl = np.multiply(refl_all[:, j], ctx.refl_factor[plan.index[i]][None, :], out=b_ref)
        else:
            direct, skyd, refl = b_dir, b_sky, b_ref
            for b in (direct, skyd, refl):
                b.fill(0.0)
            eye = np.eye(plan.nodes.size)
            for a, j in enumerate(js):
                hat = np.interp(aoi_pt, plan.nodes, eye[a]).astype(np.float32)
                hat *= beam
                hat *= dni[:, j:j + 1]
                direct += hat
                skyd += sky_all[:, sp[j]]
                refl += refl_all[:, sp[j]] * ctx.refl_factor[plan.index[i] + a][None, :]
        if keep == PARTS:
            block[(name, "direct")][rows] = f(direct)
            block[(name, "sky_diffuse")][rows] = f(skyd)
            block[(name, "ground_diffuse")][rows] = f(refl)
            continue
        means = {"direct": f(direct), "sky_diffuse": f(skyd), "ground_diffuse": f(refl)}
        tot = None
        if "global" in keep or not keep:
            tot = np.array(means["direct"], dtype=np.float32)
            tot += means["sky_diffuse"]
            tot += means["ground_diffuse"]
        if not keep:                               # for the consumer only
            currents[name] = GlobalParts(tot, np.zeros(Tc, np.float32), np.zeros_like(tot))
        for p in keep:
            block[(name, p)][rows] = tot if p == "global" else means[p]
    block["sun_visible"][rows] = f(terms["vis"])
    if ctx.spectral:
        J, C = ctx.J, ctx.C
        s0 = sp[J]
        sd = sky_all[:, s0:s0 + C].transpose(0, 2, 1)
        rd = refl_all[:, s0:s0 + C].transpose(0, 2, 1)
        dd = beam[:, :, None] * dni[:, None, J:J + C]
        for p, v in (("direct", dd), ("sky_diffuse", sd), ("ground_diffuse", rd)):
            block[("spectral", p)][rows] = _face_mean_spectral(ctx, v)
        block[("spectral", "global")][rows] = sum(block[("spectral", p)][rows] for p in PARTS)
    return currents


def _optic_on_beam(ctx, angular, terms):
    """(Tc, N) float32 angular optic at each point's beam angle of incidence [1]: per distinct
    normal (``ctx.normal_groups``) then spread, else where the beam arrives (0 elsewhere)."""
    if ctx.normal_groups is not None:
        aoi = np.degrees(np.arccos(np.clip(terms["cos_u"], 0.0, 1.0)))
        return np.asarray(angular(aoi), dtype=np.float32)[:, ctx.normal_groups[1]]
    beam = terms["beam"]
    lit = beam > 0
    g = np.zeros(beam.shape, np.float32)
    if lit.any():
        g[lit] = np.asarray(angular(np.degrees(np.arccos(np.clip(terms["cos"][lit], 0.0, 1.0)))),
                            dtype=np.float32)
    return g


def _face_mean_spectral(ctx, v):
    """(Tc, N, C) -> (Tc, F, C)."""
    k = ctx.k
    return v if k == 1 else v.reshape(v.shape[0], ctx.F, k, v.shape[2]).mean(axis=2)
