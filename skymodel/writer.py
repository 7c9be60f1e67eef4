"""Writer for Prague Sky Model dataset files (the layout of ``shared/spec/psm-dataset-format.md``).

Used for the generated default dataset, for synthetic test datasets and for subsetting files.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from widesky.core.atomic import atomic_outputs

__all__ = ["DatasetContents", "write_dataset", "encode_radiance_blocks"]

HALF_MAX = 65504.0


@dataclass
class DatasetContents:
    """Everything a dataset file holds, as float arrays (grid shape G = (nVis, nAlb, nAlt, nEle, nCh)).

    Radiance: ``sun`` G + (rank, nSun), ``zen`` G + (rank, nZen), ``emph`` G + (nEmph,), unitless
    factors whose product is radiance [W m-2 sr-1 nm-1]. Transmittance: ``trans_u``
    (nAltT, dDim, aDim, rankT) and ``trans_v`` (nVisT, nAltT, nCh, rankT), with sqrt(T) = U . V in
    [0, 1]. Polarisation (optional): ``pol_sun`` G + (rankPol, nPSun), ``pol_zen`` G + (rankPol, nPZen).
    Angles (breaks) in radians, visibilities km, altitudes m, elevations deg, wavelengths nm.
    """

    visibilities: np.ndarray
    albedos: np.ndarray
    altitudes: np.ndarray
    elevations: np.ndarray
    channel_start: float
    channel_width: float
    sun_breaks: np.ndarray
    zenith_breaks: np.ndarray
    emph_breaks: np.ndarray
    sun: np.ndarray
    zen: np.ndarray
    emph: np.ndarray
    trans_altitudes: np.ndarray
    trans_visibilities: np.ndarray
    trans_u: np.ndarray
    trans_v: np.ndarray
    pol_sun_breaks: np.ndarray | None = None
    pol_zenith_breaks: np.ndarray | None = None
    pol_sun: np.ndarray | None = None
    pol_zen: np.ndarray | None = None

    @property
    def grid_shape(self):
        return (len(self.visibilities), len(self.albedos), len(self.altitudes), len(self.elevations),
                int(self.sun.shape[4]))


def _i32(f, v):
    f.write(np.int32(v).astype("<i4").tobytes())


def _counted(f, a):
    a = np.asarray(a, dtype="<f8")
    _i32(f, a.size)
    f.write(a.tobytes())


def _balance(sun, zen, emph):
    """Move magnitudes into the zenith factor (which has a scale) so that the sun and emphasis factors
    sit near 1 where half floats are most accurate. Exact in real arithmetic."""
    sun = np.array(sun, dtype=np.float64)
    zen = np.array(zen, dtype=np.float64)
    emph = np.array(emph, dtype=np.float64)
    smax = np.max(np.abs(sun), axis=-1, keepdims=True)
    smax = np.where(smax > 0, smax, 1.0)
    sun /= smax
    zen *= smax
    emax = np.max(np.abs(emph), axis=-1, keepdims=True)
    emax = np.where(emax > 0, emax, 1.0)
    emph /= emax
    zen *= emax[..., None, :]
    return sun, zen, emph


def encode_radiance_blocks(sun, zen, emph, balance=True):
    """Encode radiance factors into the file's block layout (structured array, one block per config).

    Parameters
    ----------
    sun, zen, emph : ndarray
        Shapes (..., rank, nSun), (..., rank, nZen), (..., nEmph).
    balance : bool
        Rescale the factors so the half-float sun and emphasis vectors are near 1 (exact in real
        arithmetic). Set False to store the given values as they are.

    Returns
    -------
    numpy structured array, flattened over the leading dimensions.
    """
    if balance:
        sun, zen, emph = _balance(sun, zen, emph)
    rank, ns = sun.shape[-2:]
    nz, ne = zen.shape[-1], emph.shape[-1]
    lead = sun.shape[:-2]
    if np.max(np.abs(sun), initial=0) > HALF_MAX or np.max(np.abs(emph), initial=0) > HALF_MAX:
        raise ValueError("sun or emphasis factor exceeds the half-float range (65504); rescale into the zenith factor")
    zmax = np.max(np.abs(zen), axis=-1)
    scale = np.where(zmax > 0, 1.0 / np.where(zmax > 0, zmax, 1.0), 1.0)
    rank_dt = np.dtype([("sun", "<f2", (ns,)), ("scale", "<f8"), ("zen", "<f2", (nz,))])
    block_dt = np.dtype([("r", rank_dt, (rank,)), ("emph", "<f2", (ne,))])
    blocks = np.zeros(lead, dtype=block_dt)
    blocks["r"]["sun"] = sun.astype("<f2")
    blocks["r"]["scale"] = scale
    blocks["r"]["zen"] = (zen * scale[..., None]).astype("<f2")
    blocks["emph"] = emph.astype("<f2")
    return blocks.reshape(-1)


def write_dataset(path, c: DatasetContents, balance=True) -> Path:
    """Write ``c`` to ``path`` in the Prague Sky Model binary layout; returns the path.

    Checks shapes and the format's constraints (ascending grids, >= 2 knots, sqrt(T) within [0, 1]
    at the stored samples) before writing anything.
    """
    path = Path(path)
    G = c.grid_shape
    rank = c.sun.shape[-2]
    for name, arr, tail in (("sun", c.sun, (rank, len(c.sun_breaks))), ("zen", c.zen, (rank, len(c.zenith_breaks))),
                            ("emph", c.emph, (len(c.emph_breaks),))):
        if tuple(arr.shape) != G + tail:
            raise ValueError(f"{name} has shape {arr.shape}, expected {G + tail}")
    for name in ("visibilities", "albedos", "altitudes", "elevations", "sun_breaks", "zenith_breaks",
                 "emph_breaks", "trans_altitudes", "trans_visibilities"):
        a = np.asarray(getattr(c, name), float)
        if a.ndim != 1 or a.size < 1 or (a.size > 1 and not np.all(np.diff(a) > 0)):
            raise ValueError(f"{name} must be a non-empty strictly ascending 1-D array")
    nalt_t, ddim, adim, rank_t = c.trans_u.shape
    if c.trans_v.shape != (len(c.trans_visibilities), nalt_t, G[4], rank_t) or nalt_t != len(c.trans_altitudes):
        raise ValueError(f"trans_v shape {c.trans_v.shape} / trans_u shape {c.trans_u.shape} inconsistent")
    sqrt_t = np.einsum("ldar,vlcr->vldac", c.trans_u.astype(np.float64), c.trans_v.astype(np.float64))
    if sqrt_t.min() < -1e-6 or sqrt_t.max() > 1 + 1e-6:
        raise ValueError(f"sqrt(T) = U.V must lie in [0, 1]; got [{sqrt_t.min():.3g}, {sqrt_t.max():.3g}]")
    buf = io.BytesIO()
    for grid in (c.visibilities, c.albedos, c.altitudes, c.elevations):
        _counted(buf, grid)
    _i32(buf, G[4])
    buf.write(np.array([c.channel_start, c.channel_width], "<f8").tobytes())
    _i32(buf, rank)
    for br in (c.sun_breaks, c.zenith_breaks, c.emph_breaks):
        _counted(buf, br)
    buf.write(encode_radiance_blocks(c.sun, c.zen, c.emph, balance).tobytes())
    for v in (ddim, adim, len(c.trans_visibilities), nalt_t, rank_t):
        _i32(buf, v)
    buf.write(np.asarray(c.trans_altitudes, "<f4").tobytes())
    buf.write(np.asarray(c.trans_visibilities, "<f4").tobytes())
    buf.write(np.ascontiguousarray(c.trans_u, "<f4").tobytes())
    buf.write(np.ascontiguousarray(c.trans_v, "<f4").tobytes())
    if c.pol_sun is not None:
        rank_p = c.pol_sun.shape[-2]
        _i32(buf, rank_p)
        _counted(buf, c.pol_sun_breaks)
        _counted(buf, c.pol_zenith_breaks)
        nps, npz = len(c.pol_sun_breaks), len(c.pol_zenith_breaks)
        if c.pol_sun.shape != G + (rank_p, nps) or c.pol_zen.shape != G + (rank_p, npz):
            raise ValueError("polarisation factor shapes inconsistent with the grid and breaks")
        dt = np.dtype([("r", [("sun", "<f4", (nps,)), ("zen", "<f4", (npz,))], (rank_p,))])
        blocks = np.zeros(G, dtype=dt)
        blocks["r"]["sun"] = c.pol_sun
        blocks["r"]["zen"] = c.pol_zen
        buf.write(blocks.tobytes())
    with atomic_outputs(path) as (tmp,):
        tmp.write_bytes(buf.getvalue())
    return path
