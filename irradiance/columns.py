"""Stage 1 of :func:`widesky.irradiance.poa_irradiance`: the contraction columns.

Every response becomes one contraction column of the sky's channels (or, for an angle x wavelength optic,
one per incidence-angle class node), each tied to the sky coefficients it multiplies (plain, or those of an
optic's weight function); :func:`sky_columns` appends the spectral parts' and the ground's columns.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .optics import DEFAULT_NODES, OpticPlan, plan_optics
from .response import Response

__all__ = ["Columns", "contraction_columns", "sky_columns"]


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



@dataclass(frozen=True, eq=False)
class Columns:
    """The columns the sky is contracted with (:func:`sky_columns`).

    Attributes
    ----------
    resp : list
        (name, weights (C,), unit, Response or None) per response, "broadband" first.
    col_mat : numpy.ndarray
        (J,) int: -1 for the plain sky coefficients, else the optic weight function.
    col_of : list of list of int
        Columns of each response.
    plan : OpticPlan
    J : int
        Response columns.
    J_all : int
        Response columns and the spectral parts' identity columns (C with ``spectral``).
    Wall : numpy.ndarray
        (C, J_all or 2 J_all) contraction matrix [nm x weight unit]; with a spectral ground the second
        half is the first weighted by the ground's albedo (shape).
    spectral_ground : bool
        Whether ``Wall`` holds the albedo-weighted columns.
    """

    resp: list
    col_mat: np.ndarray
    col_of: list
    plan: OpticPlan
    J: int
    J_all: int
    Wall: np.ndarray
    spectral_ground: bool

    @property
    def names(self):
        return [r[0] for r in self.resp]

    def with_ground_shape(self, shape):
        """These columns and the same weighted by a ground albedo shape (C,) [1] (the all-sky vegetated
        ground)."""
        return replace(self, Wall=np.concatenate([self.Wall, shape[:, None] * self.Wall], axis=1),
                       spectral_ground=True)


def sky_columns(scene, sky, responses, spectral=False, optic_nodes=DEFAULT_NODES) -> Columns:
    """Stage 1: the responses' columns (:func:`contraction_columns`), with ``spectral`` the identity
    columns of the spectral parts, and with a spectral ground albedo (C,) [1] of the scene the columns
    weighted by it."""
    C = sky.n_channels
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
    return Columns(resp, col_mat, col_of, plan, J, J_all, Wall, spectral_ground)
