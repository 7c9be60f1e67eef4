"""The output plan of :func:`widesky.irradiance.poa_irradiance`: what is kept, in which blocks and chunks.

The daylight steps, the parts kept per response (:func:`stored_parts`), the blocks of faces (:func:`face_blocks`:
coefficients, products and output one block of faces at a time, so a run's working memory does not grow with
the face count), the output blocks of consecutive steps (bounded memory: one block at a time) and each block's
chunks of lit steps sorted by sky state (sources that share work between equal states see them together).
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass

import numpy as np

from .products import FACE_TILE
from .result import ALL_PARTS, PARTS, chunk_shape

__all__ = ["OutputPlan", "output_plan", "stored_parts", "estimate_run", "sky_state_order", "BLOCK_BYTES",
           "FACE_BLOCK_BYTES", "face_bytes", "face_blocks"]

#: Memory for one block of output steps held before it is written [bytes].
BLOCK_BYTES = 384 << 20

#: Working memory of one block of faces [bytes] (its points' coefficients, the products' buffers and an output
#: block, :func:`face_bytes`): a run whose faces need more works through them in blocks (:func:`face_blocks`).
FACE_BLOCK_BYTES = 1 << 30

#: Faces per block are a multiple of this: the products' tile (so a block's numbers are the whole run's bit for
#: bit) and the result file's chunk width (:func:`widesky.irradiance.result.chunk_shape`).
FACE_ALIGN = FACE_TILE


def face_bytes(points_per_face, n_patches, n_columns, n_optics, n_sun, n_arrays, time_chunk):
    """Estimated working memory per face of a run [bytes]: per point the coefficients (sky, reflected sky and
    ground, each optic's sky (float32, (P,) each, held by the coefficients and by the products' layout), the
    reflected sun per shading cell and orientation bin (41 x 43 at most, three copies) and the sun visibility
    (``n_sun`` bins, packed and unpacked)) and the products' buffers (``time_chunk`` steps x ``n_columns``);
    per face the output block (``time_chunk`` steps x ``n_arrays``) and the fused product's matrix."""
    G, B = 41, 42
    per_point = (4 * (n_patches * (6 + 2 * n_optics) + 3 * G * (B + 1) + time_chunk * (3 * n_columns + 7))
                 + (n_sun * 9) // 8)
    per_face = 4 * (time_chunk * (n_arrays + n_columns) + (n_patches + B + 2) * (1 + n_optics))
    return int(points_per_face) * per_point + per_face


def face_blocks(n_faces, face_block=None, per_face=None, budget=None):
    """[(f0, f1)] blocks of faces: ``face_block`` faces each, or (None) one block unless ``n_faces x per_face``
    [bytes] exceeds ``budget`` (default :data:`FACE_BLOCK_BYTES`), then blocks of a multiple of
    :data:`FACE_ALIGN` faces within it."""
    F = int(n_faces)
    budget = FACE_BLOCK_BYTES if budget is None else int(budget)
    if face_block is None:
        if per_face is None or F * int(per_face) <= budget:
            return [(0, F)]
        width = max(FACE_ALIGN, budget // int(per_face) // FACE_ALIGN * FACE_ALIGN)
    else:
        width = int(face_block)
    if width >= F:
        return [(0, F)]
    return [(f0, min(F, f0 + width)) for f0 in range(0, F, width)]


def takes_faces(consumer):
    """True when ``consumer`` accepts a keyword argument ``faces`` (then it is told each block's faces)."""
    if consumer is None:
        return False
    try:
        par = inspect.signature(consumer).parameters
    except (TypeError, ValueError):
        return False
    return "faces" in par or any(p.kind is inspect.Parameter.VAR_KEYWORD for p in par.values())


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



def sky_state_order(states, steps):
    """``steps`` (int array) sorted by rounded sun elevation [deg], visibility [km], albedo [1]."""
    return steps[np.lexsort((states.albedo[steps], states.visibility[steps],
                             np.round(states.sun_elevation[steps], 1)))]


@dataclass(frozen=True, eq=False)
class OutputPlan:
    """Which steps are computed, what is kept of them, and in which blocks and chunks (:func:`output_plan`).

    Attributes
    ----------
    lit : numpy.ndarray
        (T_lit,) steps with the sun above the sky source's minimum elevation.
    lit_mask, up : numpy.ndarray
        (T,) bool: lit; sun above the horizon.
    sun_rank : numpy.ndarray
        (T,) index of each step among those with the sun up.
    names : list of str
        Responses, "broadband" first.
    units : dict
        Response name -> unit.
    stored : tuple of tuple of str
        Parts kept per response.
    keys : list of tuple
        (response, part) output arrays.
    kept_names : list of str
        Responses with something kept.
    blocks : list of tuple
        (b0, b1) output blocks of consecutive steps.
    chunks : list of tuple
        (block index, step indices) chunks of lit steps, in block order.
    face_blocks : list of tuple
        (f0, f1) blocks of faces, each run end to end (coefficients, products, output) in turn.
    consumer_faces : bool
        The consumer takes ``faces=`` (the slice of faces of its block's columns).
    """

    lit: np.ndarray
    lit_mask: np.ndarray
    up: np.ndarray
    sun_rank: np.ndarray
    names: list
    units: dict
    stored: tuple
    keys: list
    kept_names: list
    blocks: list
    chunks: list
    face_blocks: list
    consumer_faces: bool = False

    @property
    def kept_units(self):
        return {n: self.units[n] for n in self.kept_names}

    @property
    def kept_parts(self):
        return {n: st for n, st in zip(self.names, self.stored) if st}


def output_plan(scene, sky, states, settings, resp, output, face_block=None, n_columns=None,
                n_optics=0) -> OutputPlan:
    """The plan of a run: ``resp`` as :attr:`widesky.irradiance.columns.Columns.resp`, ``output`` an
    :class:`~widesky.irradiance.poa_options.OutputOptions`; ``face_block`` faces per block
    (:attr:`~widesky.irradiance.poa_options.RunOptions.face_block`; None: one block unless the working memory
    estimated from ``n_columns`` contraction columns and ``n_optics`` optic weight functions exceeds
    :data:`FACE_BLOCK_BYTES`; a consumer that does not take ``faces=`` sees all faces at once)."""
    T, C, F = len(states), sky.n_channels, scene.n_faces
    el = states.sun_elevation
    lit = np.nonzero(el > getattr(sky, "min_sun_elevation", 0.0))[0]
    up = el > 0
    names = [r[0] for r in resp]
    units = {r[0]: r[2] for r in resp}
    stored = stored_parts(names, output.parts)
    keys = [(n, p) for n, st in zip(names, stored) for p in st]
    transient = [n for n, st in zip(names, stored) if not st]
    if transient and output.consumer is None:
        raise ValueError(f"parts keeps nothing of {transient} and no consumer reads them")
    kept_names = [n for n, st in zip(names, stored) if st]

    # blocks of faces, each run end to end
    n_arr = len(keys) + 2 * bool(getattr(output, "angles", True)) + (4 * C if output.spectral else 0)
    consumer_faces = takes_faces(output.consumer)
    if output.consumer is not None and not consumer_faces:
        if face_block is not None and int(face_block) < F:
            raise ValueError(f"face_block={face_block}: the consumer does not take faces= (the slice of faces of "
                             "its block's columns); add that keyword or leave face_block unset")
        face_block = F
    per_face = None
    if n_columns is not None:
        P = 144 * settings.mf ** 2 + 1
        per_face = face_bytes(scene.samples_per_face, P, n_columns, n_optics, int(np.count_nonzero(el > 0)),
                              n_arr, settings.time_chunk)
    fblocks = face_blocks(F, face_block, per_face)
    Fw = max(f1 - f0 for f0, f1 in fblocks) if F else 0

    # output blocks of consecutive steps, each cut into chunks of lit steps sorted by sky state
    block_steps = output.block_steps
    if block_steps is None:
        block_steps = max(settings.time_chunk, BLOCK_BYTES // max(1, 4 * Fw * n_arr))
    block_steps = int(max(1, block_steps))
    if output.path is not None:
        # whole HDF5 chunks per block: a block edge inside a chunk makes HDF5 read it back
        tc = chunk_shape(max(T, 1), max(F, 1))[0]
        block_steps = max(tc, block_steps // tc * tc)
    blocks = [(b0, min(T, b0 + block_steps)) for b0 in range(0, T, block_steps)] or [(0, 0)]
    lit_mask = np.zeros(T, bool)
    lit_mask[lit] = True
    chunks = []                                       # (block index, step indices)
    for bi, (b0, b1) in enumerate(blocks):
        sel = sky_state_order(states, np.nonzero(lit_mask[b0:b1])[0] + b0)
        for c0 in range(0, sel.size, settings.time_chunk):
            chunks.append((bi, np.sort(sel[c0:c0 + settings.time_chunk])))
    return OutputPlan(lit, lit_mask, up, np.cumsum(up) - 1, names, units, stored, keys, kept_names,
                      blocks, chunks, fblocks, consumer_faces)
