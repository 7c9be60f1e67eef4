"""Fitting sky radiance and transmittance into the Prague Sky Model's form.

Radiance of one configuration and channel (Vevoda et al. 2022, section 3.3):

    R(view) = emph(zero) * sum_r sun_r(gamma) * zen_r(alpha)

with every factor piecewise linear on its knots (``alpha`` is the altitude-corrected zenith angle
``zero`` when the sun is up, the shadow angle otherwise). We fit it by alternation:

1. with the emphasis fixed, the rank sum is a bilinear function ``phi(gamma)^T M psi(alpha)`` of a
   knot-value matrix M (nSun x nZen); M is the regularised least-squares solution on the samples (a sparse
   problem: each sample touches four entries of M; a small second-difference penalty fills knot cells no
   sample reaches), truncated to rank R by SVD;
2. with the rank sum fixed, the emphasis values are a small linear least-squares problem;

repeated a few times, then alternating least squares on the rank factors (optionally also matching the
differences between neighbouring samples: a Sobolev term). The weights can be made relative to the radiance.
Transmittance: ``sqrt(T)`` sampled on the format's (distance, altitude) grid for every (visibility, altitude,
channel) is factored by a truncated SVD into U . V.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass

import numpy as np
from scipy import linalg

__all__ = ["hat_weights", "fit_radiance", "RadianceFit", "fit_transmittance"]


def hat_weights(x, knots):
    """Piecewise-linear interpolation weights with the reference's clamping: (index, w_lo, w_hi) such
    that f(x) = w_lo * c[index] + w_hi * c[index + 1] (index <= n - 2)."""
    k = np.asarray(knots, float)
    x = np.clip(np.asarray(x, float), k[0], k[-1])
    i = np.clip(np.searchsorted(k, x, side="right") - 1, 0, len(k) - 2)
    f = (x - k[i]) / (k[i + 1] - k[i])
    return i, 1.0 - f, f


def _design(i, wl, wh, n):
    """Dense (m, n) matrix of the hat functions at the samples."""
    m = len(i)
    A = np.zeros((m, n))
    A[np.arange(m), i] = wl
    A[np.arange(m), i + 1] += wh
    return A


@functools.lru_cache(maxsize=8)
def _regulariser_banded(ns, nz, band, sun_order=1):
    """Banded upper storage of the smoothness penalty on M (row-major vec, i * nz + j): differences of order
    ``sun_order`` (1 or 2) along the sun-angle axis and second differences along the zenith axis. First
    differences keep the bandwidth at nz + 1, second differences need 2 nz."""
    N = ns * nz
    ab = np.zeros((band + 1, N))
    if sun_order == 2:
        Ds, Dz = _second_difference(ns), _second_difference(nz)
        R = np.kron(Ds.T @ Ds, np.eye(nz)) + np.kron(np.eye(ns), Dz.T @ Dz)
        for d in range(min(band, N - 1) + 1):
            ab[band - d, d:] = np.diagonal(R, d)
        ab.flags.writeable = False  # cached: shared by every fit of this shape
        return ab
    # first differences along i: (x[i+1, j] - x[i, j])^2 -> diagonal +1 / +1, off-diagonal (distance nz) -1
    diag = np.zeros(N)
    for i in range(ns - 1):
        diag[i * nz:(i + 1) * nz] += 1
        diag[(i + 1) * nz:(i + 2) * nz] += 1
        ab[band - nz, (i + 1) * nz:(i + 2) * nz] += -1.0
    # second differences along j: D^T D per row i
    Dz = _second_difference(nz)
    DtD = Dz.T @ Dz
    for d in range(min(3, nz)):
        dd = np.diagonal(DtD, d)
        for i in range(ns):
            ab[band - d, i * nz + d:(i + 1) * nz] += dd
    ab[band] += diag
    ab.flags.writeable = False  # cached: shared by every fit of this shape
    return ab


def _second_difference(n):
    D = np.zeros((max(n - 2, 0), n))
    for r in range(n - 2):
        D[r, r:r + 3] = (1.0, -2.0, 1.0)
    return D


@dataclass
class RadianceFit:
    """Fitted factors of one configuration and channel: ``sun`` (R, nSun), ``zen`` (R, nZen), ``emph``
    (nEmph,), and the fit's normalised mean absolute error on its samples [1]."""

    sun: np.ndarray
    zen: np.ndarray
    emph: np.ndarray
    nmae: float

    def evaluate(self, gamma, alpha, zero, sun_breaks, zen_breaks, emph_breaks, clamp=True):
        """The fitted radiance at angles [rad] (the reference's form, clamped at 0 unless ``clamp`` is False)."""
        ig, gl, gh = hat_weights(gamma, sun_breaks)
        ia, al, ah = hat_weights(alpha, zen_breaks)
        iz, zl, zh = hat_weights(zero, emph_breaks)
        s = self.sun[:, ig] * gl + self.sun[:, ig + 1] * gh
        z = self.zen[:, ia] * al + self.zen[:, ia + 1] * ah
        e = self.emph[iz] * zl + self.emph[iz + 1] * zh
        v = e * np.sum(s * z, axis=0)
        return np.maximum(v, 0.0) if clamp else v


def fit_radiance(gamma, alpha, zero, values, sun_breaks, zen_breaks, emph_breaks, rank, *, weights=None,
                 smoothing=1e-6, iterations=2, refine=0, sun_penalty_order=1, clamp=True, relative_power=0.0,
                 relative_floor=0.01, sobolev=0.0, pairs=None):
    """Fit one configuration's radiance samples into the PSM form (see module docstring).

    Parameters
    ----------
    gamma, alpha, zero : ndarray (m,)
        Angles of the sample directions [rad]: to the sun, the zenith factor's angle, the emphasis angle.
    values : ndarray (m,)
        Radiance at the samples [W m-2 sr-1 nm-1].
    sun_breaks, zen_breaks, emph_breaks : ndarray
        Knots [rad], ascending.
    rank : int
    weights : ndarray (m,), optional
        Sample weights (e.g. solid angles [sr]); default uniform.
    smoothing : float
        Second-difference penalty on M and the emphasis relative to the data term [1].
    iterations : int
        Alternations between the rank sum and the emphasis (the iterate with the lowest weighted absolute error
        on the samples is kept).
    refine : int
        Sweeps of alternating least squares on the sun and zenith factors afterwards (0: none).
    sun_penalty_order : int
        Order of the differences penalised along the sun-angle axis of M: 1 (slopes; the first builds) or 2
        (curvature, as along the zenith axis: damps the ripple of knot-spacing period that first differences
        leave in the rank-truncated factors; docs/default-dataset.md, "Smoothness").
    clamp : bool
        The model is clamped at 0 (radiance, the default); False for a signed quantity (polarisation).
    relative_power, relative_floor : float
        Divide the weights by ``max(|y|, relative_floor * mean)^relative_power`` (:func:`relative_weights`) so that
        the fit follows the error relative to the radiance: 0 (default) keeps the weights; 1 is what the default
        dataset uses (docs/default-dataset.md, "Relative weighting and a Sobolev term"). Used by every stage.
    sobolev : float
        Weight of the differences between neighbouring samples in the ALS sweeps (``refine``): they minimise
        ``sum w r^2 + sobolev * sum_pairs w_pair (r_a - r_b)^2`` over the residual ``r`` (``w_pair`` the mean of the
        pair's weights; :func:`sobolev_matrix`). 0 (default): none.
    pairs : ndarray (k, 2) int, optional
        Indices of the neighbouring sample pairs (needed with ``sobolev``; e.g.
        :func:`widesky.skymodel.generator.dataset_build.neighbour_pairs` of a product grid).

    Returns
    -------
    RadianceFit
    """
    if sobolev < 0 or (sobolev > 0 and pairs is None):
        raise ValueError(f"sobolev={sobolev!r} must be >= 0, and a positive value needs the sample pairs")
    y = np.asarray(values, float)
    w = np.ones_like(y) if weights is None else np.asarray(weights, float)
    w = relative_weights(y, w, relative_power, relative_floor)
    ns, nz, ne = len(sun_breaks), len(zen_breaks), len(emph_breaks)
    ig, gl, gh = hat_weights(gamma, sun_breaks)
    ia, al, ah = hat_weights(alpha, zen_breaks)
    iz, zl, zh = hat_weights(zero, emph_breaks)
    E = _design(iz, zl, zh, ne)        # (m, ne)
    scale = float(np.sqrt(np.sum(w * y * y) / max(np.sum(w), 1e-300))) or 1.0
    yn = y / scale
    N = ns * nz
    if sun_penalty_order not in (1, 2):
        raise ValueError(f"sun_penalty_order must be 1 or 2, got {sun_penalty_order!r}")
    # bandwidth of the normal matrix in row-major (i * nz + j) order (the data couple i, i+1: nz + 1)
    band = nz + 1 if sun_penalty_order == 1 else 2 * nz
    lam = smoothing * np.sum(w)
    reg_ab = _regulariser_banded(ns, nz, band, sun_penalty_order)
    # the four M entries each sample touches and their bilinear weights
    cols = np.stack([ig * nz + ia, ig * nz + ia + 1, (ig + 1) * nz + ia, (ig + 1) * nz + ia + 1], axis=1)
    bil = np.stack([gl * al, gl * ah, gh * al, gh * ah], axis=1)
    lo_k, hi_k = np.triu_indices(4)  # cols are ascending within a row, so k <= l gives c_k <= c_l
    emph = np.ones(ne)
    best = None
    pos = (lambda x: np.maximum(x, 0.0)) if clamp else (lambda x: x)
    for it in range(iterations):
        e = emph[iz] * zl + emph[iz + 1] * zh
        vals = bil * e[:, None]                                   # (m, 4) nonzeros of the design rows
        # normal matrix in banded upper storage: ab[band + c_k - c_l, c_l] += w v_k v_l
        ck, cl = cols[:, lo_k], cols[:, hi_k]
        contrib = (w[:, None] * vals[:, lo_k] * vals[:, hi_k]).ravel()
        flat = ((band + ck - cl) * N + cl).ravel()
        ab = np.bincount(flat, contrib, minlength=(band + 1) * N).reshape(band + 1, N)
        ab = ab + lam * reg_ab
        ab[band] += 1e-9 * lam + 1e-300
        rhs = np.bincount(cols.ravel(), (vals * (w * yn)[:, None]).ravel(), minlength=N)
        M = linalg.solveh_banded(ab, rhs).reshape(ns, nz)
        U, S, Vt = np.linalg.svd(M, full_matrices=False)
        r = min(rank, len(S))
        sun = U[:, :r].T * np.sqrt(S[:r])[:, None]
        zen = np.sqrt(S[:r])[:, None] * Vt[:r]
        if r < rank:
            sun = np.vstack([sun, np.zeros((rank - r, ns))])
            zen = np.vstack([zen, np.zeros((rank - r, nz))])
        s_at = sun[:, ig] * gl + sun[:, ig + 1] * gh
        z_at = zen[:, ia] * al + zen[:, ia + 1] * ah
        h = np.sum(s_at * z_at, axis=0)
        pred = pos((E @ emph) * h)
        err = float(np.sum(w * np.abs(pred - yn)))
        if best is None or err < best[0]:
            best = (err, sun, zen, emph.copy())
        if it < iterations - 1:
            Xe = h[:, None] * E
            De = _second_difference(ne)
            Ae = Xe.T @ (w[:, None] * Xe) + lam * 1e-2 * (De.T @ De) + 1e-12 * np.eye(ne)
            emph_new = np.linalg.solve(Ae, Xe.T @ (w * yn))
            mean = np.mean(np.abs(emph_new))  # keep the magnitude in the rank sum
            if not np.isfinite(mean) or mean <= 0:
                break
            emph = emph_new / mean
    _, sun, zen, emph = best  # the alternation is not monotone in the absolute error: keep the best iterate
    if refine > 0:
        pw = None
        if sobolev > 0:
            pairs = np.asarray(pairs, int)
            pw = sobolev * 0.5 * (w[pairs[:, 0]] + w[pairs[:, 1]])
        sun, zen = _refine_factors(sun, zen, (ig, gl, gh), (ia, al, ah), E @ emph, yn, w, lam, refine, pos,
                                   pairs=pairs if pw is not None else None, pair_w=pw)
    s_at = sun[:, ig] * gl + sun[:, ig + 1] * gh
    z_at = zen[:, ia] * al + zen[:, ia + 1] * ah
    h = np.sum(s_at * z_at, axis=0)
    fit = pos((E @ emph) * h) * scale
    nmae = float(np.sum(w * np.abs(fit - y)) / max(np.sum(w * np.abs(y)), 1e-300))
    return RadianceFit(sun * scale, zen, emph, nmae)


def relative_weights(y, w, power, floor):
    """Weights ``w / max(y, floor * typ)^power`` rescaled to the sum of ``w`` (``typ``: the ``w``-weighted mean of
    ``|y|``), so that a least-squares fit with them minimises the error relative to the data rather than the absolute
    one (``power`` 2: squared relative error; 0: ``w`` itself)."""
    if power == 0:
        return w
    if not (0 < power <= 4 and floor > 0):
        raise ValueError(f"relative_power={power!r} must be in [0, 4] and relative_floor={floor!r} > 0")
    typ = float(np.sum(w * np.abs(y)) / max(np.sum(w), 1e-300)) or 1.0
    r = w / np.maximum(np.abs(y) / typ, floor) ** power
    return r * (np.sum(w) / np.sum(r))


def sobolev_matrix(w, pairs, pair_w):
    """Sparse (m, m) matrix of a weighted least-squares fit that also matches the differences between sample pairs:
    ``diag(w) + sum_p pair_w[p] (e_a - e_b)(e_a - e_b)^T`` for ``pairs[p] = (a, b)``, so that
    ``r^T Q r = sum w r^2 + sum pair_w (r_a - r_b)^2`` for the residual ``r``."""
    from scipy import sparse

    m = len(w)
    a, b = np.asarray(pairs[:, 0]), np.asarray(pairs[:, 1])
    rows = np.concatenate([np.arange(m), a, b, a, b])
    cols = np.concatenate([np.arange(m), a, b, b, a])
    vals = np.concatenate([w, pair_w, pair_w, -pair_w, -pair_w])
    return sparse.csr_matrix((vals, (rows, cols)), shape=(m, m))


def _refine_factors(sun, zen, hs, hz, e, y, w, lam, sweeps, pos=lambda x: np.maximum(x, 0.0), pairs=None,
                    pair_w=None):
    """Alternating weighted least squares on the rank factors with the emphasis ``e`` (per sample) fixed:
    sun given zen, then zen given sun (each a small dense problem with a second-difference penalty); keeps
    the result only if it lowers the weighted absolute error."""
    R, ns = sun.shape
    nz = zen.shape[1]
    Q = None
    if pairs is not None:
        Q = sobolev_matrix(w, pairs, pair_w)

    def err(s_, z_):
        h = np.sum((s_[:, hs[0]] * hs[1] + s_[:, hs[0] + 1] * hs[2]) * (z_[:, hz[0]] * hz[1] + z_[:, hz[0] + 1] * hz[2]), 0)
        return float(np.sum(w * np.abs(pos(e * h) - y)))

    def solve(other, h_other, h_self, n_self):
        # each design row has 2R non-zeros: assemble the normal matrix from them (sparse outer products)
        idx, lo, hi = h_self
        oat = other[:, h_other[0]] * h_other[1] + other[:, h_other[0] + 1] * h_other[2]  # (R, m)
        K = R * n_self
        offs = (np.arange(R) * n_self)[None, :]
        cols = np.concatenate([idx[:, None] + offs, idx[:, None] + 1 + offs], axis=1)      # (m, 2R)
        c = (e[None, :] * oat).T                                                             # (m, R)
        vals = np.concatenate([lo[:, None] * c, hi[:, None] * c], axis=1)                  # (m, 2R)
        if Q is not None:  # data and Sobolev terms together: A^T Q A x = A^T Q y (A dense, m x K)
            A = np.zeros((len(y), K))
            np.put_along_axis(A, cols, vals, axis=1)
            QA = Q @ A
            N = A.T @ QA
            rhs = QA.T @ y
        else:
            flat = (cols[:, :, None] * K + cols[:, None, :]).ravel()
            N = np.bincount(flat, (w[:, None, None] * vals[:, :, None] * vals[:, None, :]).ravel(),
                            minlength=K * K).reshape(K, K)
            rhs = np.bincount(cols.ravel(), (vals * (w * y)[:, None]).ravel(), minlength=K)
        D = _second_difference(n_self)
        N += lam * np.kron(np.eye(R), D.T @ D) + 1e-10 * lam * np.eye(K)
        x = linalg.solve(N, rhs, assume_a="pos")
        return x.reshape(R, n_self)

    best = (err(sun, zen), sun, zen)
    for _ in range(sweeps):
        try:
            with warnings.catch_warnings():
                # near-singular when a rank's factor is ~0; the regulariser keeps it solvable and the result is
                # kept only if it lowers the error
                warnings.simplefilter("ignore", linalg.LinAlgWarning)
                sun = solve(zen, hz, hs, ns)
                zen = solve(sun, hs, hz, nz)
        except (np.linalg.LinAlgError, ValueError):
            break
        ek = err(sun, zen)
        if ek < best[0]:
            best = (ek, sun, zen)
    return best[1], best[2]


def fit_transmittance(sqrt_t, rank):
    """Factor ``sqrt(T)`` samples into the format's U . V.

    Parameters
    ----------
    sqrt_t : ndarray (nVisT, nAltT, nCh, dDim, aDim)
        Square root of transmittance [1] on the format's distance x altitude parameter grid.
    rank : int

    Returns
    -------
    U : ndarray (nAltT, dDim, aDim, rank) float32
    V : ndarray (nVisT, nAltT, nCh, rank) float32
    max_abs_error : float  largest |U.V - sqrt(T)| after clipping to [0, 1] [1]
    """
    x = np.asarray(sqrt_t, float)
    nv, na, nc, dd, ad = x.shape
    U = np.zeros((na, dd, ad, rank))
    V = np.zeros((nv, na, nc, rank))
    err = 0.0
    for a in range(na):
        X = x[:, a].reshape(nv * nc, dd * ad).T  # (grid, vis*ch)
        u, s, vt = np.linalg.svd(X, full_matrices=False)
        r = min(rank, len(s))
        U[a, ..., :r] = (u[:, :r] * s[:r]).reshape(dd, ad, r)
        V[:, a, :, :r] = vt[:r].T.reshape(nv, nc, r)
        rec = np.clip(np.einsum("dar,vcr->vcda", U[a], V[:, a]), 0, 1)
        err = max(err, float(np.abs(rec - x[:, a]).max()))
    return U.astype(np.float32), V.astype(np.float32), err
