"""Angular optics in the geometry phase: incidence-angle weight functions and their coefficients.

The integrator applies a response's angular optic per incoming direction. Every optic the run
needs becomes an incidence-angle weight function ``g(theta)`` [1] tabulated on a fine grid
(:class:`AngularWeights`, 0.05 deg, linear interpolation; picklable for the ray-casting workers):

* an angle-only optic (a callable or an :class:`widesky.irradiance.response.AngularTable`) is one function;
* angle x wavelength optics (:class:`widesky.irradiance.response.SpectralAngularTable`) go through
  incidence-angle classes: piecewise-linear "hat" functions on the nodes ``optic_nodes`` [deg]
  (a partition of unity). The response's factor is taken at the nodes per channel, so the classed
  factor is its linear interpolation in angle between nodes (the classing error, measured in
  docs/irradiance-integrator.md).

For each function the workers return (:func:`optic_terms`)

* the sky coefficients ``int_patch v cos(theta) g(theta) dw`` per point and patch: each occlusion
  ray's share of the patch's exact projected solid angle times ``g`` at the ray's angle, plus the
  patch's quadrature correction (the ratio of the cos x g and cos quadratures over a ``kq x kq``
  sub-grid, 16 x 16 where the face's horizon cuts the patch, minus the rays' estimate of it) spread
  over the rays in proportion to their shares. Unobstructed, a patch gets the quadrature of
  cos x g; obstructed, the visible rays' part of it. The estimate is linear in ``g``, so optics that
  are piecewise linear on the class nodes come out the same through the classes as per ray;
* a per-point factor for reflected light: the mean of ``g`` at the angles of the rays that reached a
  reflector (ground or scene surface), weighted by each ray's share of projected solid angle. It is
  exact where the reflected radiance is uniform over the reflecting directions (the open ground of
  an unobstructed plane); elsewhere it weights the directions by solid angle, not by radiance.

The beam's factor is applied exactly in the integrator at each step's angle of incidence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["AngularWeights", "OpticPlan", "plan_optics", "optic_terms", "hat_weights",
           "DEFAULT_NODES", "GRID_STEP"]

GRID_STEP = 0.05                          # [deg] tabulation step of the weight functions
#: Default incidence-angle nodes [deg] of the angle x wavelength classes (denser where glazing
#: transmittance falls off).
DEFAULT_NODES = (0.0, 20.0, 35.0, 45.0, 52.0, 58.0, 64.0, 70.0, 75.0, 80.0, 84.0, 87.0, 90.0)


@dataclass(frozen=True, eq=False)
class AngularWeights:
    """M incidence-angle weight functions tabulated on 0..90 deg with step :data:`GRID_STEP`.

    Attributes
    ----------
    tables : numpy.ndarray
        (M, G) factors [1] at angles ``GRID_STEP * arange(G)`` [deg].
    """

    tables: np.ndarray

    @property
    def n(self) -> int:
        return int(self.tables.shape[0])

    @staticmethod
    def grid():
        """(G,) angles [deg]."""
        return np.linspace(0.0, 90.0, int(round(90.0 / GRID_STEP)) + 1)

    def index(self, theta_deg):
        """Interpolation index and fraction of angles [deg] (any shape), clipped to [0, 90]."""
        u = np.clip(np.asarray(theta_deg, dtype=float), 0.0, 90.0) / GRID_STEP
        G = self.tables.shape[1]
        i = np.minimum(u.astype(np.int64), G - 2)
        return i, u - i

    def value(self, m, index):
        """Function ``m`` at the angles of ``index`` (from :meth:`index`)."""
        i, fr = index
        t = self.tables[m]
        return t[i] * (1.0 - fr) + t[i + 1] * fr


def hat_weights(theta_deg, nodes):
    """(n, A) piecewise-linear weights of angles [deg] on ``nodes`` [deg] (rows sum to 1)."""
    th = np.clip(np.asarray(theta_deg, dtype=float).ravel(), nodes[0], nodes[-1])
    A = len(nodes)
    j = np.clip(np.searchsorted(nodes, th, side="right") - 1, 0, A - 2)
    fr = (th - nodes[j]) / (nodes[j + 1] - nodes[j])
    out = np.zeros((th.size, A))
    rows = np.arange(th.size)
    out[rows, j] = 1.0 - fr
    out[rows, j + 1] += fr
    return out


@dataclass(frozen=True, eq=False)
class OpticPlan:
    """How each response's optic maps onto the weight functions.

    Attributes
    ----------
    weights : AngularWeights or None
        The M functions (None: no response has an optic).
    kind : tuple of str
        Per response: "none", "angular" or "spectral".
    index : tuple of int
        Per response: its function (angular), the first hat function (spectral), or -1.
    nodes : numpy.ndarray or None
        (A,) class nodes [deg] when a response is spectral-angular.
    """

    weights: object
    kind: tuple
    index: tuple
    nodes: object


def plan_optics(responses, nodes=DEFAULT_NODES):
    """The :class:`OpticPlan` of a list of :class:`widesky.irradiance.Response`."""
    grid = AngularWeights.grid()
    tables, kind, index, seen = [], [], [], {}
    nodes_arr = None
    hat0 = -1
    for r in responses:
        if r.angular is None:
            kind.append("none")
            index.append(-1)
        elif r.spectral_angular:
            if nodes_arr is None:
                nodes_arr = np.asarray(nodes, dtype=float)
                if (nodes_arr.ndim != 1 or nodes_arr.size < 2 or nodes_arr[0] != 0.0
                        or nodes_arr[-1] != 90.0 or np.any(np.diff(nodes_arr) <= 0)):
                    raise ValueError(f"optic_nodes={tuple(nodes)} must ascend from 0 to 90 deg")
                hat0 = len(tables)
                eye = np.eye(nodes_arr.size)
                tables.extend(np.interp(grid, nodes_arr, eye[a]) for a in range(nodes_arr.size))
            kind.append("spectral")
            index.append(hat0)
        else:
            key = id(r.angular)
            if key not in seen:
                g = np.asarray(r.angular(grid), dtype=float).reshape(grid.shape)
                if not np.all(np.isfinite(g)) or np.any(g < 0):
                    raise ValueError(f"response {r.name!r}: its angular optic gives non-finite or "
                                     "negative factors on 0-90 deg")
                seen[key] = len(tables)
                tables.append(g)
            kind.append("angular")
            index.append(seen[key])
    w = AngularWeights(np.array(tables, dtype=np.float64)) if tables else None
    return OpticPlan(w, tuple(kind), tuple(index), nodes_arr)


def _sub_directions(patches, kq, which):
    """(p, kq*kq, 3) sub-directions and (p, kq*kq) solid angles of patches ``which`` (index into
    the P upper and P mirrored lower patches)."""
    dq, wq = patches.subsample(kq)
    dq_lo = dq.copy()
    dq_lo[..., 2] *= -1.0
    D = np.concatenate([dq, dq_lo])
    Wt = np.concatenate([wq, wq])
    return D[which], Wt[which]


def quadrature_ratio(weights, patches, normals, kq=4, kq_cut=16, block=256):
    """(M, n, 2P) ratio of the cos x g and cos quadratures over each upper and mirrored lower patch.

    ``kq x kq`` sub-directions per patch, ``kq_cut x kq_cut`` for patches cut by the face's horizon
    (where cos falls to 0 inside the patch and g changes fastest); patches wholly behind the face
    get g(90 deg).
    """
    n = normals.shape[0]
    P = patches.n_patches
    M = weights.n
    out = np.empty((M, n, 2 * P))
    out[:] = weights.tables[:, -1][:, None, None]
    cen = np.concatenate([patches.directions, patches.directions * [1.0, 1.0, -1.0]])   # (2P, 3)
    sin_r = np.sin(np.minimum(np.concatenate([patches.radius, patches.radius]), np.pi / 2))
    D, Wt = _sub_directions(patches, kq, np.arange(2 * P))
    Kq = D.shape[1]
    Dflat, Wflat = D.reshape(-1, 3), Wt.reshape(-1)
    for i0 in range(0, n, block):
        nn = normals[i0:i0 + block]
        c = np.clip(nn @ Dflat.T, 0.0, 1.0)
        wc = c * Wflat
        base = wc.reshape(nn.shape[0], 2 * P, Kq).sum(axis=2)
        idx = weights.index(np.degrees(np.arccos(c)))
        ok = base > 0
        for m in range(M):
            num = (wc * weights.value(m, idx)).reshape(nn.shape[0], 2 * P, Kq).sum(axis=2)
            out[m, i0:i0 + block][ok] = num[ok] / base[ok]
    # patches cut by the face's horizon, finer
    cc = normals @ cen.T
    fi, pi_ = np.nonzero((cc > -sin_r) & (cc < sin_r))
    if fi.size and kq_cut > kq:
        Dc, Wc = _sub_directions(patches, kq_cut, np.arange(2 * P))
        for j0 in range(0, fi.size, 4096):
            f_, p_ = fi[j0:j0 + 4096], pi_[j0:j0 + 4096]
            c = np.clip(np.einsum("nj,nkj->nk", normals[f_], Dc[p_]), 0.0, 1.0)
            wc = c * Wc[p_]
            base = wc.sum(axis=1)
            idx = weights.index(np.degrees(np.arccos(c)))
            ok = base > 0
            for m in range(M):
                num = (wc * weights.value(m, idx)).sum(axis=1)
                out[m, f_[ok], p_[ok]] = num[ok] / base[ok]
    return out


def optic_terms(weights: AngularWeights, patches, normals, exact, w3, flat_dirs, miss, r_pt, r_col,
                r_share, kq=4):
    """Sky coefficients and reflected-light factors of every weight function (one worker chunk).

    Parameters
    ----------
    weights : AngularWeights
        M functions.
    patches : SkyPatches
        P patches (their mirror images make the lower hemisphere).
    normals : numpy.ndarray
        (n, 3) point normals.
    exact : numpy.ndarray
        (n, 2P) exact projected solid angles of the upper and mirrored lower patches [sr].
    w3 : numpy.ndarray
        (n, 2P, K) ray weights (cell solid angle x cos) [sr].
    flat_dirs : numpy.ndarray
        (2P K, 3) ray directions.
    miss : numpy.ndarray
        (n, 2P, K) bool, the ray escapes (sky for the upper patches).
    r_pt, r_col : numpy.ndarray
        (h,) point and flat ray column of each ray that reached a reflector.
    r_share : numpy.ndarray
        (h,) its share of projected solid angle [sr] (no optic).
    kq : int
        Sub-grid per patch side for the quadrature ratio.

    Returns
    -------
    sky : numpy.ndarray
        (M, n, P) float32 [sr].
    reflect : numpy.ndarray
        (M, n) float32 [1].
    """
    n, P2, K = w3.shape
    P = P2 // 2
    M = weights.n
    cos_ray = np.clip((normals @ flat_dirs.T).reshape(n, P2, K), -1.0, 1.0)
    idx_ray = weights.index(np.degrees(np.arccos(np.maximum(cos_ray, 0.0))))
    ratio = quadrature_ratio(weights, patches, normals, kq)
    den_r = np.bincount(r_pt, weights=r_share, minlength=n)
    lo_exact = exact[:, P:].sum(axis=1)
    # the plain (no optic) ray shares: the patch's exact projected solid angle split over its rays
    wsum = w3.sum(axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(wsum[..., None] > 0, exact[..., None] * w3 / np.where(
            wsum > 0, wsum, 1.0)[..., None], 0.0)
        inv_exact = np.where(exact > 0, 1.0 / np.where(exact > 0, exact, 1.0), 0.0)
    has_rays = wsum > 0
    sliver = ~has_rays[:, :P] & (exact[:, :P] > 0)
    tot = share[:, :P].sum(axis=(1, 2))
    vis_plain = np.sum(share[:, :P] * miss[:, :P], axis=(1, 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        f_up = np.where(tot > 0, vis_plain / np.where(tot > 0, tot, 1.0), 1.0)
    sky = np.zeros((M, n, P), np.float32)
    refl = np.zeros((M, n), np.float32)
    g90 = weights.tables[:, -1]
    for m in range(M):
        exact_m = exact * ratio[m]
        g_ray = weights.value(m, idx_ray)                                     # (n, 2P, K)
        # a ray's share times g at its angle, plus the patch's quadrature correction spread in
        # proportion to the shares: linear in g, and exact (cos x g quadrature) where unobstructed
        delta = ratio[m] - np.sum(share * g_ray, axis=2) * inv_exact         # (n, 2P)
        share_m = share * (g_ray + delta[..., None])
        vis = np.sum(share_m[:, :P] * miss[:, :P], axis=2)
        # slivers (a positive exact weight but no ray in front): the point's mean visible fraction
        vis = vis + np.where(sliver, exact_m[:, :P] * f_up[:, None], 0.0)
        sky[m] = vis
        rs = share_m.reshape(n, -1)[r_pt, r_col]
        num_r = np.bincount(r_pt, weights=rs, minlength=n)
        with np.errstate(invalid="ignore", divide="ignore"):
            lo_ratio = np.where(lo_exact > 0, exact_m[:, P:].sum(axis=1) / np.where(
                lo_exact > 0, lo_exact, 1.0), g90[m])
            refl[m] = np.where(den_r > 0, num_r / np.where(den_r > 0, den_r, 1.0), lo_ratio)
    return sky, refl
