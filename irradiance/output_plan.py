"""The output plan of :func:`widesky.irradiance.poa_irradiance`: what is kept, in which blocks and chunks.

The daylight steps, the parts kept per response (:func:`stored_parts`), the output blocks of consecutive
steps (bounded memory: one block at a time) and each block's chunks of lit steps sorted by sky state
(sources that share work between equal states see them together).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .result import ALL_PARTS, PARTS, chunk_shape

__all__ = ["OutputPlan", "output_plan", "stored_parts", "estimate_run", "sky_state_order", "BLOCK_BYTES"]

#: Memory for one block of output steps held before it is written [bytes].
BLOCK_BYTES = 384 << 20


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

    @property
    def kept_units(self):
        return {n: self.units[n] for n in self.kept_names}

    @property
    def kept_parts(self):
        return {n: st for n, st in zip(self.names, self.stored) if st}


def output_plan(scene, sky, states, settings, resp, output) -> OutputPlan:
    """The plan of a run: ``resp`` as :attr:`widesky.irradiance.columns.Columns.resp`, ``output`` an
    :class:`~widesky.irradiance.poa_options.OutputOptions`."""
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

    # output blocks of consecutive steps, each cut into chunks of lit steps sorted by sky state
    n_arr = len(keys) + 2 + (4 * C if output.spectral else 0)
    block_steps = output.block_steps
    if block_steps is None:
        block_steps = max(settings.time_chunk, BLOCK_BYTES // max(1, 4 * F * n_arr))
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
                      blocks, chunks)
