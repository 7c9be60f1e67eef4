"""Sky discretisation: Tregenza / Reinhart patches of the upper (sky) and lower (ground) hemisphere.

The Tregenza sky (Tregenza 1987, "Subdivision of the sky hemisphere for luminance measurements",
Lighting Res. Technol. 19(1)) has 7 rings of 12 deg with 30, 30, 24, 24, 18, 12, 6 patches and a zenith
cap: 145 patches. Reinhart's subdivision (Reinhart & Walkenhorst 2001; Bourgeois, Reinhart & Ward 2008)
splits every ring into ``mf`` rings and every patch of a ring into ``mf`` azimuth sectors, with the ring
height ``90 / (7 mf + 0.5)`` deg and one cap of half a ring height: ``144 mf**2 + 1`` patches
(mf = 1, 2, 4: 145, 577, 2305).

Coordinates: local east-north-up, x east, y north, z up; altitude above the horizon [deg] and azimuth
clockwise from north [deg]. Patch edges in azimuth start at 0 (north) in every ring.

Everything here is exact geometry: patch solid angles sum to 2 pi sr, the vector integrals ``int w dw``
give the cosine weight ``n . int w dw`` of a patch that lies wholly above a face's horizon, and
:func:`cosine_weights` handles the patches a face's horizon cuts with a fine quadrature.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["SkyPatches", "reinhart", "tregenza", "cosine_weights", "direction_from_angles",
           "angles_from_direction"]

_TREGENZA_COUNTS = (30, 30, 24, 24, 18, 12, 6)


def direction_from_angles(altitude, azimuth):
    """Unit vectors (..., 3) east-north-up from altitude [deg] and azimuth clockwise from north [deg]."""
    a = np.radians(np.asarray(altitude, dtype=float))
    p = np.radians(np.asarray(azimuth, dtype=float))
    ca = np.cos(a)
    return np.stack(np.broadcast_arrays(ca * np.sin(p), ca * np.cos(p), np.sin(a)), axis=-1)


def orthonormal_frame(axes):
    """(n, 3) unit vectors u, v completing the unit vectors ``axes`` (n, 3) to right-handed frames
    (u, v, axis); dimensionless."""
    axes = np.asarray(axes, dtype=float)
    ref = np.where(np.abs(axes[:, 2:3]) < 0.9, np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]]))
    u = np.cross(ref, axes)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(axes, u)


def angles_from_direction(directions):
    """Altitude [deg] and azimuth clockwise from north in [0, 360) [deg] of ENU vectors (..., 3)."""
    d = np.asarray(directions, dtype=float)
    alt = np.degrees(np.arcsin(np.clip(d[..., 2] / np.linalg.norm(d, axis=-1), -1.0, 1.0)))
    az = np.degrees(np.arctan2(d[..., 0], d[..., 1])) % 360.0
    return alt, az


def _vector_integral(a1, a2, p1, p2):
    """int w dw over the altitude band [a1, a2] x azimuth [p1, p2] [rad]; returns (..., 3) [sr]."""
    i2 = 0.5 * (a2 - a1) + 0.25 * (np.sin(2 * a2) - np.sin(2 * a1))
    vx = i2 * (np.cos(p1) - np.cos(p2))
    vy = i2 * (np.sin(p2) - np.sin(p1))
    vz = 0.5 * (np.sin(a2) ** 2 - np.sin(a1) ** 2) * (p2 - p1)
    return np.stack([vx, vy, vz], axis=-1)


@dataclass(frozen=True, eq=False)
class SkyPatches:
    """A discretisation of the upper hemisphere into altitude rings of equal-width azimuth sectors.

    Attributes
    ----------
    name : str
        Scheme name, e.g. ``"reinhart-2"``.
    mf : int
        Reinhart subdivision factor (1 = Tregenza 145).
    ring_edges : numpy.ndarray
        Altitude edges of the rings, (n_rings + 1,) [deg]; the last ring is the zenith cap.
    ring_counts : numpy.ndarray
        Number of azimuth sectors per ring, (n_rings,).
    altitude_bounds, azimuth_bounds : numpy.ndarray
        Per patch (P, 2) [deg].
    ring : numpy.ndarray
        Ring index per patch (P,).
    solid_angle : numpy.ndarray
        (P,) [sr], summing to 2 pi.
    vector : numpy.ndarray
        (P, 3) exact ``int w dw`` [sr]; its z component is the horizontal cosine weight (sum pi).
    directions : numpy.ndarray
        (P, 3) unit vectors along ``vector`` (the patch's mean direction).
    radius : numpy.ndarray
        (P,) angular radius [rad]: the largest angle from ``directions`` to the patch boundary.
    """

    name: str
    mf: int
    ring_edges: np.ndarray
    ring_counts: np.ndarray
    altitude_bounds: np.ndarray
    azimuth_bounds: np.ndarray
    ring: np.ndarray
    solid_angle: np.ndarray
    vector: np.ndarray
    directions: np.ndarray
    radius: np.ndarray
    _ring_start: np.ndarray = field(repr=False)

    @property
    def n_patches(self) -> int:
        """Number of patches P."""
        return int(self.solid_angle.shape[0])

    def __len__(self) -> int:
        return self.n_patches

    def index(self, directions):
        """Patch index (...,) of ENU unit vectors (..., 3); -1 for directions at or below the horizon."""
        d = np.asarray(directions, dtype=float)
        alt, az = angles_from_direction(d)
        ring = np.searchsorted(self.ring_edges, alt, side="right") - 1
        ring = np.clip(ring, 0, len(self.ring_counts) - 1)
        counts = self.ring_counts[ring]
        col = np.minimum((az / 360.0 * counts).astype(np.int64), counts - 1)
        out = self._ring_start[ring] + col
        return np.where(d[..., 2] > 0.0, out, -1)

    def subsample(self, k: int):
        """Stratified sub-directions: ``k x k`` equal-solid-angle cells per patch (``k`` in sin(alt), az).

        Returns
        -------
        directions : numpy.ndarray
            (P, k*k, 3) unit vectors at the cell centres (in sin(altitude) and azimuth).
        weights : numpy.ndarray
            (P, k*k) cell solid angles [sr]; each row sums to the patch's solid angle.
        """
        k = int(k)
        if k < 1:
            raise ValueError(f"k={k} sub-samples per patch side must be >= 1")
        u = (np.arange(k) + 0.5) / k
        s1 = np.sin(np.radians(self.altitude_bounds[:, :1]))
        s2 = np.sin(np.radians(self.altitude_bounds[:, 1:]))
        s = s1 + (s2 - s1) * u[None, :]                                  # (P, k)
        p = self.azimuth_bounds[:, :1] + (self.azimuth_bounds[:, 1:] - self.azimuth_bounds[:, :1]) * u
        alt = np.degrees(np.arcsin(np.clip(s, -1, 1)))
        alt_g = np.repeat(alt, k, axis=1)                                # (P, k*k): alt major
        az_g = np.tile(p, (1, k))
        dirs = direction_from_angles(alt_g, az_g)
        w = np.repeat(self.solid_angle[:, None] / (k * k), k * k, axis=1)
        return dirs, w


def reinhart(mf: int = 1) -> SkyPatches:
    """Reinhart subdivision of the Tregenza sky: ``144 mf**2 + 1`` patches.

    Parameters
    ----------
    mf : int
        Subdivision factor >= 1 (1 = Tregenza's 145 patches, 2 = 577, 4 = 2305).
    """
    mf = int(mf)
    if mf < 1:
        raise ValueError(f"mf={mf} must be a positive integer (1 = Tregenza 145 patches)")
    h = 90.0 / (7 * mf + 0.5)
    n_rows = 7 * mf
    counts = [mf * _TREGENZA_COUNTS[r // mf] for r in range(n_rows)] + [1]
    edges = np.array([r * h for r in range(n_rows + 1)] + [90.0])
    counts = np.array(counts, dtype=np.int64)
    alt_b, az_b, ring = [], [], []
    for r, n in enumerate(counts):
        for c in range(n):
            alt_b.append((edges[r], edges[r + 1]))
            az_b.append((360.0 * c / n, 360.0 * (c + 1) / n))
            ring.append(r)
    alt_b = np.array(alt_b)
    az_b = np.array(az_b)
    a1, a2 = np.radians(alt_b[:, 0]), np.radians(alt_b[:, 1])
    p1, p2 = np.radians(az_b[:, 0]), np.radians(az_b[:, 1])
    omega = (p2 - p1) * (np.sin(a2) - np.sin(a1))
    vec = _vector_integral(a1, a2, p1, p2)
    dirs = vec / np.linalg.norm(vec, axis=1, keepdims=True)
    # angular radius: the farthest boundary point from the mean direction (dense boundary sampling)
    t = np.linspace(0.0, 1.0, 33)
    bd_alt = np.concatenate([np.broadcast_to(alt_b[:, :1], (len(alt_b), 33)),
                             np.broadcast_to(alt_b[:, 1:], (len(alt_b), 33)),
                             alt_b[:, :1] + (alt_b[:, 1:] - alt_b[:, :1]) * t,
                             alt_b[:, :1] + (alt_b[:, 1:] - alt_b[:, :1]) * t], axis=1)
    bd_az = np.concatenate([az_b[:, :1] + (az_b[:, 1:] - az_b[:, :1]) * t,
                            az_b[:, :1] + (az_b[:, 1:] - az_b[:, :1]) * t,
                            np.broadcast_to(az_b[:, :1], (len(az_b), 33)),
                            np.broadcast_to(az_b[:, 1:], (len(az_b), 33))], axis=1)
    bd = direction_from_angles(bd_alt, bd_az)
    cosang = np.einsum("pk,pbk->pb", dirs, bd)
    radius = np.arccos(np.clip(cosang.min(axis=1), -1.0, 1.0)) + 1e-9
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    name = "tregenza" if mf == 1 else f"reinhart-{mf}"
    return SkyPatches(name=name, mf=mf, ring_edges=edges, ring_counts=counts, altitude_bounds=alt_b,
                      azimuth_bounds=az_b, ring=np.array(ring), solid_angle=omega, vector=vec,
                      directions=dirs, radius=radius, _ring_start=start)


def tregenza() -> SkyPatches:
    """The Tregenza (1987) sky of 145 patches (``reinhart(1)``)."""
    return reinhart(1)


def _mirror(v):
    v = np.array(v, dtype=float, copy=True)
    v[..., 2] *= -1.0
    return v


def _cut_weights(n, a1, a2, p1, p2, nodes=10):
    """Clipped integral int max(0, n . w) dw over altitude [a1, a2] x azimuth [p1, p2] [rad].

    Closed form in azimuth (the positive part of ``A + B cos(phi - phi0)``) and Gauss-Legendre in
    altitude. All arguments are (m,) arrays, ``n`` is (m, 3); returns (m,) [sr].
    """
    x, gw = np.polynomial.legendre.leggauss(nodes)
    half = 0.5 * (a2 - a1)
    a = 0.5 * (a1 + a2)[:, None] + half[:, None] * x[None, :]            # (m, q)
    bh = np.hypot(n[:, 0], n[:, 1])
    phi0 = np.arctan2(n[:, 0], n[:, 1])
    A = n[:, 2:3] * np.sin(a)
    B = bh[:, None] * np.cos(a)
    ratio = np.clip(-A / np.maximum(B, 1e-300), -1.0, 1.0)
    psic = np.arccos(ratio)
    psic = np.where(B > 0, psic, np.where(A > 0, np.pi, 0.0))
    u1 = np.mod(p1 - phi0 + np.pi, 2 * np.pi) - np.pi
    u2 = u1 + (p2 - p1)
    u1, u2 = u1[:, None], u2[:, None]
    inner = np.zeros_like(a)
    for k in (0, 1):
        lo = np.maximum(u1, -psic + 2 * np.pi * k)
        hi = np.minimum(u2, psic + 2 * np.pi * k)
        ok = hi > lo
        inner += np.where(ok, A * (hi - lo) + B * (np.sin(hi) - np.sin(lo)), 0.0)
    return np.sum(inner * np.cos(a) * gw[None, :], axis=1) * half


def cosine_weights(patches: SkyPatches, normals, *, lower: bool = False, chunk: int = 4096):
    """Exact projected solid angle ``int_patch max(0, n . w) dw`` of every patch for every normal.

    Patches wholly above the face's horizon use the closed form ``n . int w dw``; patches wholly
    below give 0; patches cut by the face's horizon are integrated in closed form in azimuth and by
    10-point Gauss-Legendre in altitude (measured: the weights of any normal sum to pi within 1e-4 sr).

    Parameters
    ----------
    patches : SkyPatches
        The discretisation.
    normals : array_like
        (F, 3) unit face normals (ENU).
    lower : bool
        If True, weights of the mirror-image patches of the lower (ground) hemisphere.
    chunk : int
        Faces per block (bounds memory).

    Returns
    -------
    numpy.ndarray
        (F, P) [sr]; for any normal the upper plus lower weights sum to pi.
    """
    n = np.atleast_2d(np.asarray(normals, dtype=float))
    if lower:
        n = _mirror(n)                        # mirror the face instead of the patches
    vec, cen, rad = patches.vector, patches.directions, patches.radius
    sin_r = np.sin(np.minimum(rad, np.pi / 2))
    a_b = np.radians(patches.altitude_bounds)
    p_b = np.radians(patches.azimuth_bounds)
    out = np.empty((n.shape[0], patches.n_patches))
    for i0 in range(0, n.shape[0], chunk):
        nn = n[i0:i0 + chunk]
        w = nn @ vec.T
        c = nn @ cen.T
        below = c <= -sin_r
        cut = ~below & (c < sin_r)
        w[below] = 0.0
        fi, pi = np.nonzero(cut)
        for j0 in range(0, fi.size, 50000):
            f_, p_ = fi[j0:j0 + 50000], pi[j0:j0 + 50000]
            w[f_, p_] = _cut_weights(nn[f_], a_b[p_, 0], a_b[p_, 1], p_b[p_, 0], p_b[p_, 1])
        out[i0:i0 + chunk] = w
    return np.maximum(out, 0.0)
