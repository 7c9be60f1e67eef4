"""Stage 3 of :func:`widesky.irradiance.poa_irradiance`: per chunk the sky, reflected and beam terms.

Matrix products of the contracted sky with the coefficients of
:func:`widesky.irradiance.raycast.compute_coefficients`, in the layout of :class:`ProductContext`;
responses kept as their global part only take the fused product (:class:`GlobalParts`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .integrator import lazy_zeros
from .patches import reinhart

__all__ = ["GlobalParts", "ProductContext", "fast_columns", "chunk_products", "check_coefficients",
           "reinhart_vector_z", "group_normals", "FACE_TILE", "tiled_matmul", "dot3"]

#: Faces per tile of the products over the face axis [faces]: each is computed in tiles of this many faces at
#: fixed offsets (a BLAS product's last bits depend on the matrices' widths), so a block of faces that starts at
#: a multiple of it (:func:`widesky.irradiance.output_plan.face_blocks`) gives the whole run's numbers bit for bit.
FACE_TILE = 4096


def tiled_matmul(a, b, out, step):
    """``out = a @ b`` [the operands' units] in tiles of ``step`` columns of ``b`` and ``out`` (views, no copies)."""
    n = b.shape[-1]
    if n <= step:
        return np.matmul(a, b, out=out)
    for c0 in range(0, n, step):
        np.matmul(a, b[..., c0:c0 + step], out=out[..., c0:c0 + step])
    return out


def dot3(s, nT):
    """(T, N) float32 dot products of (T, 3) directions and (3, N) unit vectors, element by element in a fixed
    order (no BLAS: the same bits whatever N)."""
    s = np.asarray(s, dtype=np.float32)
    out = s[:, 0:1] * nT[0]
    out += s[:, 1:2] * nT[1]
    out += s[:, 2:3] * nT[2]
    return out


def check_coefficients(cf, n_points, n_patches, n_sun, weights):
    """Refuse coefficients ``cf`` made for another scene (``n_points``), resolution (``n_patches``), set of
    daylight sun directions (``n_sun``) or set of optic weight functions (``weights``)."""
    if cf.sky.shape != (n_points, n_patches) or cf.n_sun != n_sun:
        raise ValueError("coefficients do not match this scene, settings and states")
    if weights is not None and (cf.sky_optic is None or cf.sky_optic.shape[0] != weights.n):
        raise ValueError("coefficients lack the optics of these responses")


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


class ProductContext:
    """The coefficient matrices in the layout of the products, and reusable work buffers."""

    def __init__(self, scene, cf, states, lit, J, J_all, col_mat, spectral, spectral_ground,
                 tmax, fast=(), ground_steps=None, faces=None, grouped=None):
        # faces: (f0, f1), a block of the scene's faces whose points' coefficients ``cf`` holds; grouped:
        # group_normals(scene) when known
        N, P = cf.sky.shape
        f0, f1 = (0, scene.n_faces) if faces is None else (int(faces[0]), int(faces[1]))
        self.N, self.P, self.F, self.k = N, P, f1 - f0, scene.samples_per_face
        self.tile = FACE_TILE                                                       # faces per product tile
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
        k = self.k
        self.normals_T = np.ascontiguousarray(scene.point_normal[f0 * k:f1 * k].T.astype(np.float32))   # (3, N)
        # points that share a normal share the beam's angle of incidence: an angular optic is
        # evaluated per distinct normal (rows of modules, the walls of a building: a handful); decided on the
        # whole scene's points, so that a block of faces takes the path the whole scene takes
        un, inv = np.unique(self.normals_T.T, axis=0, return_inverse=True)
        if grouped is None:
            grouped = un.shape[0] <= max(1, N // 4) if faces is None else group_normals(scene)
        self.normal_groups = (np.ascontiguousarray(un.T), inv.reshape(-1)) if grouped else None
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


def group_normals(scene):
    """True when the scene's points have at most a quarter as many distinct float32 normals as points (then an
    angular optic is evaluated per distinct normal)."""
    nt = np.asarray(scene.point_normal, dtype=np.float32)
    return bool(np.unique(nt, axis=0).shape[0] <= max(1, nt.shape[0] // 4))


def reinhart_vector_z(P):
    """(P,) vertical components of the patches' solid-angle vectors [sr] (horizontal weights)."""
    mf = int(round(np.sqrt((P - 1) / 144.0)))
    return reinhart(mf).vector[:, 2]


def chunk_products(ctx: ProductContext, idx, Lp, dni, up, sun_rank, band=None):
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
    step = ctx.tile * ctx.k                        # points per product tile
    for m in np.unique(mats):
        cols = np.nonzero(mats == m)[0]
        if cols.size == Rp:
            tiled_matmul(Xs.reshape(Tc * Rp, P), ctx.D_T[int(m)], sky_all.reshape(Tc * Rp, N), step)
        else:
            X = np.ascontiguousarray(Xs[:, cols]).reshape(Tc * cols.size, P)
            sky_all[:, cols] = tiled_matmul(X, ctx.D_T[int(m)], np.empty((X.shape[0], N), np.float32),
                                            step).reshape(Tc, cols.size, N)
    refl_all = tiled_matmul(Xs.reshape(Tc * Rp, P), ctx.R_T, ctx.buf_refl[:Tc * Rp], step).reshape(Tc, Rp, N)
    if ctx.A_T is not None:                        # the ground's albedo changes between steps
        Xa = Lp_alb if ctx.spectral_ground else alb[:, :, None] * Lp
        Xa = np.ascontiguousarray(Xa.transpose(0, 2, 1).reshape(Tc * Rp, P), dtype=np.float32)
        refl_all += tiled_matmul(Xa, ctx.A_T, ctx.buf_aux[:Tc * Rp], step).reshape(Tc, Rp, N)
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
        refl_all[rows] += tiled_matmul(Xu, ctx.Ksun_T[g], ctx.buf_aux[:rows.size * Rp], step).reshape(
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
        cos[upc] = dot3(s[upc], ctx.normals_T)
        vis[upc] = ctx.sun_vis[ctx.sun_bin_of[sun_rank[idx[upc]]]]
        if cos_u is not None:
            cos_u[upc] = dot3(s[upc], ctx.normal_groups[0])
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
            tiled_matmul(Xr[:, :P1], W[:P1], Gr, ctx.tile)
            continue
        q = nz[g]
        W[P1:P1 + q.size] = ks[g, q]
        tiled_matmul(np.concatenate([Xr[:, :P1], Xr[:, P1 + q]], axis=1), W[:P1 + q.size], Gr, ctx.tile)
    return out


