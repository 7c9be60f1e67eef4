"""Reader for Prague Sky Model dataset files (``.dat``), every variant.

The layout is documented in ``shared/spec/psm-dataset-format.md`` (our own words for the format of
Wilkie et al. 2021 / Vevoda et al. 2022): radiance metadata, radiance coefficients (half floats with
a per-rank zenith scale), transmittance (U, V factors of sqrt(T)) and optional polarisation.

Opening is cheap: the file is memory-mapped and only its header is parsed and validated (every count
is checked against the file size before anything is allocated). The coefficients of the selected
visibilities, albedos and channels are decoded on first use and kept as ``float32`` (what the
reference keeps in memory); :attr:`SkyModel.resident_bytes` reports their size.
"""

from __future__ import annotations

import json
import mmap
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import _core

__all__ = ["DatasetError", "SkyModel", "load_dataset", "default_dataset_path"]

DATA_DIR = Path(__file__).resolve().parent / "data"

SPECTRAL_RANGE = (280.0, 2500.0)
"""Wavelengths a dataset's channels must lie within [nm]: the wide-spectral-range model's 280-2480 nm
channels and the shipped extraterrestrial spectrum's 280-2500 nm."""
MIN_CHANNEL_WIDTH = 1.0
"""Narrowest channel accepted [nm] (the extraterrestrial spectrum is tabulated at 1 nm)."""
MIN_KNOT_STEP = 1e-6
"""Smallest spacing of two radiance or polarisation knots [rad] (0.2 arcsec; the solar disc's radius is
4.7e-3 rad): closer knots make the piecewise-polynomial table ill-conditioned."""
KNOT_TOLERANCE = 1e-6
"""Knots are angles in [0, pi] rad; values this far outside are tolerated [rad]."""
DECODE_CHUNK_BYTES = 8 << 20
"""Bytes of the file decoded at a time: the decoding's temporary memory is a few times this."""


_MADV_POPULATE_WRITE = 23
"""Linux's madvise advice (kernel 5.14 on) that faults a range in with one call; not in Python's mmap module."""


def _fresh_float32(shapes):
    """Uninitialised float32 arrays of the given shapes, carved from ONE fresh private anonymous memory
    mapping (each 64-byte aligned), for the decoder to fill.

    Where the OS allows it (Linux), the mapping declines transparent huge pages and is faulted in by one
    madvise call instead of one page fault per 4 KiB page as the decoder first writes it. Measured with
    benchmarks/bench_open.py on the project's 2-core virtual machine: numpy's default huge-page advice for
    large arrays made decoding everything take about 3x the CPU time (the kernel zeroed its 2 MiB pages
    at under 1 GB/s there), and faulting the mapping in up front saved about 15 % more."""
    sizes = [int(np.prod(sh, dtype=np.int64)) * 4 for sh in shapes]
    offsets = np.concatenate([[0], np.cumsum([(n + 63) // 64 * 64 for n in sizes])])
    total = int(offsets[-1])
    if total == 0:
        return [np.empty(sh, np.float32) for sh in shapes]
    private = getattr(mmap, "MAP_PRIVATE", None)  # Unix; elsewhere (Windows) plain anonymous memory
    try:
        block = mmap.mmap(-1, total) if private is None else mmap.mmap(-1, total, flags=private)
    except OSError as exc:  # out of address space or memory: what numpy's allocation would raise
        raise MemoryError(f"cannot allocate {total / 1e6:.1f} MB for the decoded coefficients: {exc}") from None
    if sys.platform.startswith("linux"):
        for advice in (getattr(mmap, "MADV_NOHUGEPAGE", None), _MADV_POPULATE_WRITE):
            try:
                if advice is not None:
                    block.madvise(advice)
            except OSError:  # no transparent huge pages, or a kernel older than 5.14: the pages fault in as written
                pass
    return [np.frombuffer(block, np.float32, n // 4, int(off)).reshape(sh) if n else np.empty(sh, np.float32)
            for sh, n, off in zip(shapes, sizes, offsets[:-1])]


def default_dataset_path() -> Path:
    """Path of the embedded default dataset shipped inside the package."""
    return DATA_DIR / "default.dat"


class DatasetError(ValueError):
    """A dataset file is missing, truncated, corrupted or inconsistent.

    Attributes
    ----------
    path : str
        The file.
    field : str or None
        The field being read or checked (names as in the format description).
    offset : int or None
        Byte offset of that field in the file [bytes].
    """

    def __init__(self, path, field, offset, problem):
        self.path, self.field, self.offset, self.problem = str(path), field, offset, problem
        where = f" field '{field}'" if field else ""
        at = f" at byte offset {offset}" if offset is not None else ""
        super().__init__(f"{path}:{where}{at}: {problem}" if where or at else f"{path}: {problem}")


class _Cursor:
    """Sequential little-endian reader over a memory map with bounds checks."""

    def __init__(self, buf, path):
        self.buf, self.path, self.pos, self.size = buf, path, 0, len(buf)

    def error(self, field, problem, offset=None):
        return DatasetError(self.path, field, self.pos if offset is None else offset, problem)

    def need(self, field, nbytes):
        if nbytes > self.size - self.pos:
            raise self.error(field, f"file truncated: needs {nbytes} bytes, {self.size - self.pos} left "
                                    f"(file size {self.size})")

    def i32(self, field, minimum=None):
        self.need(field, 4)
        v = int(np.frombuffer(self.buf, "<i4", 1, self.pos)[0])
        if minimum is not None and v < minimum:
            raise self.error(field, f"value {v} must be >= {minimum}")
        self.pos += 4
        return v

    def array(self, field, dtype, count, ascending=False, min_step=None, valid=None):
        """Read ``count`` values; ``ascending``: strictly ascending with steps of at least ``min_step``
        (default 1e-9 of the largest magnitude, at least 1e-9); ``valid``: (lo, hi) range of every value."""
        dt = np.dtype(dtype)
        self.need(field, count * dt.itemsize)
        with np.errstate(invalid="ignore"):  # a float32 signalling NaN flags "invalid" when widened: rejected below
            a = np.frombuffer(self.buf, dt, count, self.pos).astype(np.float64)
        if not np.all(np.isfinite(a)):
            raise self.error(field, "non-finite value")
        if valid is not None and count and (a.min() < valid[0] or a.max() > valid[1]):
            bad = a[(a < valid[0]) | (a > valid[1])][0]
            raise self.error(field, f"value {bad!r} outside the valid range [{valid[0]:g}, {valid[1]:g}]")
        if ascending and count > 1:
            step = np.diff(a)
            if not np.all(step > 0):
                raise self.error(field, f"values must be strictly ascending, got {a[:8]}...")
            tiny = min_step if min_step is not None else 1e-9 * max(1.0, float(np.abs(a).max()))
            if step.min() < tiny:
                i = int(np.argmin(step))
                raise self.error(field, f"knots {i} and {i + 1} ({a[i]!r}, {a[i + 1]!r}) are {step[i]:.3g} apart: "
                                        f"ascending values must differ by at least {tiny:.3g}")
        self.pos += count * dt.itemsize
        return a

    def counted(self, field, dtype="<f8", minimum=1, ascending=True, **kw):
        start = self.pos
        n = self.i32(f"n({field})", minimum)
        itemsize = np.dtype(dtype).itemsize
        if n > (self.size - self.pos) // itemsize:
            raise self.error(f"n({field})", f"count {n} exceeds what the file can hold", start)
        return self.array(field, dtype, n, ascending, **kw)


def _bracket(grid, query, what):
    """Grid indices needed to evaluate ``query`` (a value or a (lo, hi) range) by interpolation."""
    grid = np.asarray(grid)
    if query is None:
        return np.arange(len(grid))
    lo, hi = (query, query) if np.ndim(query) == 0 else (min(query), max(query))
    lo, hi = float(lo), float(hi)
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise ValueError(f"{what}={query!r} must be finite")
    i0 = int(np.clip(np.searchsorted(grid, lo, side="right") - 1, 0, len(grid) - 1))
    i1 = int(np.clip(np.searchsorted(grid, hi, side="left"), 0, len(grid) - 1))
    return np.arange(i0, max(i0, i1) + 1)


def _read_sidecar(sidecar: Path, channel_range):
    """The dataset's JSON sidecar, validated: an object; its ``extraterrestrial`` spectrum (if any) two
    equally long lists, wavelengths [nm] strictly ascending and covering the channels ``channel_range``
    [nm], irradiances [W m-2 nm-1] finite, >= 0 and not all zero."""
    try:
        meta = json.loads(sidecar.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DatasetError(sidecar, None, None, f"unreadable JSON sidecar: {exc}") from None
    if not isinstance(meta, dict):
        raise DatasetError(sidecar, None, None, f"the sidecar must hold a JSON object, got {type(meta).__name__}")
    et = meta.get("extraterrestrial")
    if et is None:
        return meta
    if not isinstance(et, dict) or "wavelength" not in et or "irradiance" not in et:
        raise DatasetError(sidecar, "extraterrestrial", None,
                           "expected an object with lists 'wavelength' [nm] and 'irradiance' [W m-2 nm-1]")
    arrays = {}
    for key in ("wavelength", "irradiance"):
        try:
            a = np.asarray(et[key], dtype=np.float64)
        except (TypeError, ValueError):
            raise DatasetError(sidecar, f"extraterrestrial.{key}", None, "expected a list of numbers") from None
        if a.ndim != 1 or a.size < 2:
            raise DatasetError(sidecar, f"extraterrestrial.{key}", None,
                               f"expected a list of at least 2 numbers, got shape {a.shape}")
        if not np.isfinite(a).all():
            raise DatasetError(sidecar, f"extraterrestrial.{key}", None, "non-finite value")
        arrays[key] = a
    wl, e = arrays["wavelength"], arrays["irradiance"]
    if wl.size != e.size:
        raise DatasetError(sidecar, "extraterrestrial", None, f"{wl.size} wavelengths but {e.size} irradiances")
    if not np.all(np.diff(wl) > 0):
        raise DatasetError(sidecar, "extraterrestrial.wavelength", None, "wavelengths must be strictly ascending")
    if wl[0] > channel_range[0] or wl[-1] < channel_range[1]:
        raise DatasetError(sidecar, "extraterrestrial.wavelength", None,
                           f"spectrum [{wl[0]:g}, {wl[-1]:g}] nm does not cover the dataset's channels "
                           f"[{channel_range[0]:g}, {channel_range[1]:g}] nm")
    if e.min() < 0 or not e.max() > 0:
        raise DatasetError(sidecar, "extraterrestrial.irradiance", None,
                           f"irradiances must be >= 0 and not all 0 W m-2 nm-1, got [{e.min():g}, {e.max():g}]")
    return meta


@dataclass(frozen=True)
class _Layout:
    rad_offset: int
    block_dtype: np.dtype
    trans_offset: int
    pol_offset: int | None
    pol_block_dtype: np.dtype | None


class SkyModel:
    """A loaded (memory-mapped) Prague Sky Model dataset and the selection of it a run uses.

    Use :func:`load_dataset` to create one. Grid attributes describe the *selected* part:

    Attributes
    ----------
    path : pathlib.Path
    visibilities : ndarray  [km]
    albedos : ndarray  [1]
    altitudes : ndarray  [m]
    elevations : ndarray  [deg] solar elevation grid
    wavelengths : ndarray  [nm] centres of the selected channels
    channel_edges : ndarray  [nm] lower edges of the selected channels plus the upper edge of the last
    channel_index : ndarray  indices of the selected channels in the file
    channel_start, channel_width : float  [nm] the file's channel grid
    rank : int  radiance rank
    sun_breaks, zenith_breaks, emph_breaks : ndarray  [rad] knots of the radiance factors
    has_polarisation : bool
    metadata : dict  the JSON sidecar (``<file>.json``) if present, else {}
    """

    def __init__(self, path, *, visibility=None, albedo=None, channels=None, wavelength_range=None,
                 polarisation=True, elevation=None):
        path = Path(path)
        self.path = path
        if not path.exists():
            raise DatasetError(path, None, None, "no such file")
        if path.is_dir():
            raise DatasetError(path, None, None, "is a directory, not a dataset file")
        size = path.stat().st_size
        if size == 0:
            raise DatasetError(path, "nVis", 0, "file is empty")
        self.file_size = size
        self._mm = np.memmap(path, dtype=np.uint8, mode="r")
        self._parse(self._mm, path, polarisation)
        self._select(visibility, albedo, channels, wavelength_range, elevation)
        self._decoded = {}
        sidecar = path.with_suffix(path.suffix + ".json")
        if not sidecar.exists():
            sidecar = path.with_suffix(".json")
        self.metadata = _read_sidecar(sidecar, self.wavelength_range) if sidecar.exists() else {}

    # ------------------------------------------------------------------ parsing
    def _parse(self, buf, path, want_pol):
        c = _Cursor(buf, path)
        self.file_visibilities = c.counted("visibilities")
        self.file_albedos = c.counted("albedos")
        self.file_altitudes = c.counted("altitudes")
        self.file_elevations = c.counted("elevations")
        if np.any(self.file_visibilities <= 0):
            raise c.error("visibilities", "visibilities must be > 0 km", 4)
        self.n_channels_file = c.i32("channels", 1)
        self.channel_start = float(c.array("channelStart", "<f8", 1)[0])
        self.channel_width = float(c.array("channelWidth", "<f8", 1)[0])
        lo, hi = SPECTRAL_RANGE
        if not lo <= self.channel_start < hi:
            raise c.error("channelStart", f"{self.channel_start!r} nm outside the model's spectral range "
                                          f"[{lo:g}, {hi:g}) nm", c.pos - 16)
        if not MIN_CHANNEL_WIDTH <= self.channel_width <= hi - lo:
            raise c.error("channelWidth", f"{self.channel_width!r} nm outside [{MIN_CHANNEL_WIDTH:g}, {hi - lo:g}] nm",
                          c.pos - 8)
        top = self.channel_start + self.n_channels_file * self.channel_width
        if top > hi + 1e-6:
            raise c.error("channels", f"{self.n_channels_file} channels of {self.channel_width:g} nm from "
                                      f"{self.channel_start:g} nm end at {top:g} nm, beyond the model's spectral "
                                      f"range [{lo:g}, {hi:g}] nm", c.pos - 20)
        self.rank = c.i32("rankRad", 1)
        knot = dict(minimum=2, min_step=MIN_KNOT_STEP, valid=(-KNOT_TOLERANCE, np.pi + KNOT_TOLERANCE))
        self.sun_breaks = c.counted("sunBreaks", **knot)
        self.zenith_breaks = c.counted("zenithBreaks", **knot)
        self.emph_breaks = c.counted("emphBreaks", **knot)
        ns, nz, ne, rank = len(self.sun_breaks), len(self.zenith_breaks), len(self.emph_breaks), self.rank
        block_bytes = rank * (2 * ns + 8 + 2 * nz) + 2 * ne
        n_cfg = (len(self.file_visibilities) * len(self.file_albedos) * len(self.file_altitudes)
                 * len(self.file_elevations) * self.n_channels_file)
        c.need("radiance coefficients", n_cfg * block_bytes)
        rank_dt = np.dtype([("sun", "<f2", (ns,)), ("scale", "<f8"), ("zen", "<f2", (nz,))])
        block_dt = np.dtype([("r", rank_dt, (rank,)), ("emph", "<f2", (ne,))])
        assert block_dt.itemsize == block_bytes
        rad_offset = c.pos
        c.pos += n_cfg * block_bytes
        trans_offset = c.pos
        self.trans_d_dim = c.i32("dDim", 1)
        self.trans_a_dim = c.i32("aDim", 1)
        n_vis_t = c.i32("nVisT", 1)
        n_alt_t = c.i32("nAltT", 1)
        self.trans_rank = c.i32("rankT", 1)
        self.trans_altitudes = c.array("altitudesT", "<f4", n_alt_t, ascending=True)
        self.trans_visibilities = c.array("visibilitiesT", "<f4", n_vis_t, ascending=True)
        nu = n_alt_t * self.trans_d_dim * self.trans_a_dim * self.trans_rank
        nv = n_vis_t * n_alt_t * self.n_channels_file * self.trans_rank
        c.need("U", 4 * nu)
        u_off = c.pos
        c.pos += 4 * nu
        c.need("V", 4 * nv)
        v_off = c.pos
        c.pos += 4 * nv
        self._trans_u_off, self._trans_v_off, self._n_alt_t, self._n_vis_t = u_off, v_off, n_alt_t, n_vis_t
        pol_offset = pol_dt = None
        self.has_polarisation = False
        remaining = c.size - c.pos
        if remaining:
            pol_offset = c.pos
            self.pol_rank = c.i32("rankPol", 1)
            pknot = {**knot, "minimum": 1}
            self.pol_sun_breaks = c.counted("polSunBreaks", **pknot)
            self.pol_zenith_breaks = c.counted("polZenithBreaks", **pknot)
            nps, npz = len(self.pol_sun_breaks), len(self.pol_zenith_breaks)
            c.need("polarisation coefficients", n_cfg * self.pol_rank * 4 * (nps + npz))
            pol_dt = np.dtype([("r", [("sun", "<f4", (nps,)), ("zen", "<f4", (npz,))], (self.pol_rank,))])
            self._pol_blocks_offset = c.pos
            c.pos += n_cfg * pol_dt.itemsize
            if c.pos != c.size:
                raise c.error("end of file", f"{c.size - c.pos} unexpected trailing bytes after the "
                                             "polarisation section")
            self.has_polarisation = bool(want_pol)
        self._layout = _Layout(rad_offset, block_dt, trans_offset, pol_offset, pol_dt)

    # ------------------------------------------------------------------ selection
    def _select(self, visibility, albedo, channels, wavelength_range, elevation=None):
        self._vis_idx = _bracket(self.file_visibilities, visibility, "visibility")
        self._alb_idx = _bracket(self.file_albedos, albedo, "albedo")
        self._ele_idx = _bracket(self.file_elevations, elevation, "elevation")
        nch = self.n_channels_file
        lower = self.channel_start + self.channel_width * np.arange(nch)
        if channels is not None and wavelength_range is not None:
            raise ValueError("give either channels or wavelength_range, not both")
        if channels is not None:
            idx = np.unique(np.asarray(channels, dtype=np.int64).ravel())
            if idx.size == 0 or idx.min() < 0 or idx.max() >= nch:
                raise ValueError(f"channels={channels!r} outside the dataset's channel indices [0, {nch - 1}]")
        elif wavelength_range is not None:
            lo, hi = float(min(wavelength_range)), float(max(wavelength_range))
            idx = np.nonzero((lower + self.channel_width > lo) & (lower <= hi))[0]
            if idx.size == 0:
                raise ValueError(f"wavelength_range={wavelength_range!r} nm selects no channel of the dataset "
                                 f"[{lower[0]}, {lower[-1] + self.channel_width}) nm")
        else:
            idx = np.arange(nch)
        self.channel_index = idx.astype(np.int64)
        self.visibilities = self.file_visibilities[self._vis_idx]
        self.albedos = self.file_albedos[self._alb_idx]
        self.altitudes = self.file_altitudes
        self.elevations = self.file_elevations[self._ele_idx]
        self.channel_lower = lower[idx]
        self.wavelengths = self.channel_lower + 0.5 * self.channel_width
        self.channel_edges = np.append(self.channel_lower, self.channel_lower[-1] + self.channel_width)

    # ------------------------------------------------------------------ public properties
    @property
    def n_channels(self) -> int:
        """Number of selected channels."""
        return int(self.channel_index.size)

    @property
    def visibility_range(self):
        """(min, max) of the selected visibility grid [km]."""
        return float(self.visibilities[0]), float(self.visibilities[-1])

    @property
    def albedo_range(self):
        """(min, max) of the selected albedo grid [1]."""
        return float(self.albedos[0]), float(self.albedos[-1])

    @property
    def elevation_range(self):
        """(min, max) of the solar elevation grid [deg]."""
        return float(self.elevations[0]), float(self.elevations[-1])

    @property
    def altitude_range(self):
        """(min, max) of the observer altitude grid [m]."""
        return float(self.altitudes[0]), float(self.altitudes[-1])

    @property
    def wavelength_range(self):
        """(lower edge, upper edge) of the file's channels [nm]."""
        return self.channel_start, self.channel_start + self.n_channels_file * self.channel_width

    @property
    def is_synthetic(self) -> bool:
        """True when the sidecar marks the dataset as synthetic (not a physical sky)."""
        return bool(self.metadata.get("synthetic", False))

    @property
    def resident_bytes(self) -> int:
        """Bytes of decoded coefficients held in memory now [bytes]."""
        return int(sum(a.nbytes for a in self._decoded.values()))

    def selection_bytes(self) -> int:
        """Bytes the decoded coefficients of the current selection occupy once loaded [bytes]."""
        n_cfg = len(self._vis_idx) * len(self._alb_idx) * len(self.altitudes) * len(self.elevations) * self.n_channels
        ns, nz, ne = len(self.sun_breaks), len(self.zenith_breaks), len(self.emph_breaks)
        total = n_cfg * 4 * (self.rank * (ns + nz) + ne)
        total += 4 * (self._n_alt_t * self.trans_d_dim * self.trans_a_dim * self.trans_rank
                      + self._n_vis_t * self._n_alt_t * self.n_channels * self.trans_rank)
        if self.has_polarisation:
            total += n_cfg * 4 * self.pol_rank * (len(self.pol_sun_breaks) + len(self.pol_zenith_breaks))
        return int(total)

    # ------------------------------------------------------------------ decoding
    def _slab_rows(self, dtype, offset):
        """Yield ((i, j, row0, n), file_offset, n) for every run of whole configurations the selection
        needs: per selected (visibility, albedo) pair and altitude, the selected elevations' rows in chunks
        of at most DECODE_CHUNK_BYTES, each row holding every channel of the file; row0 counts the rows
        of the selection's (altitude, elevation) plane."""
        nalb, nalt, nele, nch = (len(self.file_albedos), len(self.file_altitudes), len(self.file_elevations),
                                 self.n_channels_file)
        e0, nsel = int(self._ele_idx[0]), len(self._ele_idx)
        row_bytes = nch * dtype.itemsize
        step = max(1, DECODE_CHUNK_BYTES // row_bytes)
        for i, v in enumerate(self._vis_idx):
            for j, a in enumerate(self._alb_idx):
                for h in range(nalt):
                    first = ((int(v) * nalb + int(a)) * nalt + h) * nele + e0
                    for r0 in range(0, nsel, step):
                        n = min(step, nsel - r0)
                        yield (i, j, h * nsel + r0, n), offset + (first + r0) * row_bytes, n

    def _decode(self, dtype, offset, targets, convert, raw=False):
        """Decode the selection's blocks chunk by chunk straight into preallocated float32 ``targets``
        (name -> array of shape (nVisSel, nAlbSel, nAlt * nEle, nChSel, ...)). ``convert(chunk, out_views,
        file_offset)`` fills the views from a chunk of structured blocks (rows, nChSel), or with ``raw``
        from the chunk's bytes (rows x every channel of the file)."""
        ch = self.channel_index
        all_ch = ch.size == self.n_channels_file
        buf = bytearray()
        with open(self.path, "rb") as f, np.errstate(all="ignore"):
            for (i, j, r0, n), off, nrows in self._slab_rows(dtype, offset):
                need = nrows * self.n_channels_file * dtype.itemsize
                if len(buf) < need:
                    buf = bytearray(need)
                f.seek(off)
                view = memoryview(buf)[:need]
                if f.readinto(view) != need:
                    raise DatasetError(self.path, "radiance coefficients", off, "file changed while reading")
                views = {k: t[i, j, r0:r0 + n] for k, t in targets.items()}
                if raw:
                    convert(view, views, off)
                    continue
                blk = np.frombuffer(view, dtype).reshape(nrows, self.n_channels_file)
                if not all_ch:
                    blk = blk[:, ch]
                convert(blk, views, off)

    def _chunk_error(self, field, bad, file_offset, itemsize, problem):
        """DatasetError at the first True of ``bad`` (rows, nChSel) of a chunk starting at ``file_offset``."""
        r, k = (int(x) for x in np.argwhere(bad)[0][:2])
        off = file_offset + (r * self.n_channels_file + int(self.channel_index[k])) * itemsize
        return DatasetError(self.path, field, int(off), problem)

    def _selection_shape(self):
        return (len(self._vis_idx), len(self._alb_idx), len(self.file_altitudes) * len(self._ele_idx),
                self.n_channels)

    def radiance_coefficients(self):
        """Decoded radiance factors of the selection, as the reference keeps them (float32).

        Decoded in bounded chunks straight into the float32 arrays (the temporary memory is a few times
        ``DECODE_CHUNK_BYTES``, independent of the dataset's size).

        Returns
        -------
        sun : ndarray, shape (nVis, nAlb, nAlt, nEle, nCh, rank, nSun)
        zen : ndarray, shape (nVis, nAlb, nAlt, nEle, nCh, rank, nZen)  (already divided by zenithScale)
        emph : ndarray, shape (nVis, nAlb, nAlt, nEle, nCh, nEmph)
        """
        if "sun" not in self._decoded:
            dt = self._layout.block_dtype
            rank, ns, nz, ne = self.rank, len(self.sun_breaks), len(self.zenith_breaks), len(self.emph_breaks)
            lead = self._selection_shape()
            shapes = [lead + (rank, ns), lead + (rank, nz), lead + (ne,)]
            out = dict(zip(("sun", "zen", "emph"), _fresh_float32(shapes)))

            names = {1: ("zenithScale", "zero or non-finite zenith scale"),
                     2: ("sunStored", "non-finite radiance coefficient (inf or NaN half float)"),
                     3: ("zenStored", "non-finite radiance coefficient (overflow dividing by zenithScale)"),
                     4: ("emphStored", "non-finite radiance coefficient (inf or NaN half float)")}

            def convert(raw, o, off):
                bad = _core.decode_radiance(raw, self.n_channels_file, self.channel_index, rank, ns, nz, ne,
                                            o["sun"], o["zen"], o["emph"])
                if bad is not None:
                    code, row, k = bad
                    field, problem = names[code]
                    pos = np.zeros((row + 1, self.n_channels), bool)
                    pos[row, k] = True
                    raise self._chunk_error(field, pos, off, dt.itemsize, problem)

            self._decode(dt, self._layout.rad_offset, out, convert, raw=True)
            full = self._blocks_shape()
            self._decoded.update({k: v.reshape(full + v.shape[4:]) for k, v in out.items()})
        return self._decoded["sun"], self._decoded["zen"], self._decoded["emph"]

    def _blocks_shape(self):
        return (len(self._vis_idx), len(self._alb_idx), len(self.file_altitudes), len(self._ele_idx),
                self.n_channels)

    def _block_offset(self, sel_index):
        """File byte offset of the radiance block at a position of the selection."""
        iv, ia, ialt, ie, ich = (int(x) for x in sel_index)
        cfg = ((((self._vis_idx[iv] * len(self.file_albedos) + self._alb_idx[ia]) * len(self.file_altitudes)
                 + ialt) * len(self.file_elevations) + self._ele_idx[ie]) * self.n_channels_file
               + self.channel_index[ich])
        return int(self._layout.rad_offset + cfg * self._layout.block_dtype.itemsize)

    def transmittance_coefficients(self):
        """Transmittance factors (float32).

        Returns
        -------
        U : ndarray, shape (nAltT, dDim, aDim, rankT)
        V : ndarray, shape (nVisT, nAltT, nCh_selected, rankT)
        """
        if "U" not in self._decoded:
            d, a, r = self.trans_d_dim, self.trans_a_dim, self.trans_rank
            U = np.frombuffer(self._mm, "<f4", self._n_alt_t * d * a * r, self._trans_u_off)
            V = np.frombuffer(self._mm, "<f4", self._n_vis_t * self._n_alt_t * self.n_channels_file * r,
                              self._trans_v_off)
            U = np.array(U, dtype=np.float32).reshape(self._n_alt_t, d, a, r)
            V = V.reshape(self._n_vis_t, self._n_alt_t, self.n_channels_file, r)
            V = np.ascontiguousarray(V[:, :, self.channel_index], dtype=np.float32)
            for name, arr, off in (("U", U, self._trans_u_off), ("V", V, self._trans_v_off)):
                if not np.isfinite(arr).all():
                    raise DatasetError(self.path, name, off, "non-finite transmittance coefficient")
            self._decoded.update(U=U, V=V)
        return self._decoded["U"], self._decoded["V"]

    def polarisation_coefficients(self):
        """Polarisation factors (float32): psun (..., rankPol, nPSun), pzen (..., rankPol, nPZen).

        Raises
        ------
        ValueError
            If the dataset has no polarisation section (e.g. the ground-level dataset).
        """
        if not self.has_polarisation:
            raise ValueError(f"{self.path.name} has no polarisation data (no polarisation section in the file)")
        if len(self.pol_sun_breaks) < 2 or len(self.pol_zenith_breaks) < 2:
            raise DatasetError(self.path, "polSunBreaks", self._layout.pol_offset,
                               "polarisation needs at least 2 knots per factor to evaluate")
        if "psun" not in self._decoded:
            dt = self._layout.pol_block_dtype
            lead = self._selection_shape()
            rank, nps, npz = self.pol_rank, len(self.pol_sun_breaks), len(self.pol_zenith_breaks)
            out = dict(zip(("psun", "pzen"), _fresh_float32([lead + (rank, nps), lead + (rank, npz)])))

            def convert(raw, o, off):
                bad = _core.decode_polarisation(raw, self.n_channels_file, self.channel_index, rank, nps, npz,
                                                o["psun"], o["pzen"])
                if bad is not None:
                    pos = np.zeros((bad[0] + 1, self.n_channels), bool)
                    pos[bad] = True
                    raise self._chunk_error("polarisation coefficients", pos, off, dt.itemsize, "non-finite value")

            self._decode(dt, self._pol_blocks_offset, out, convert, raw=True)
            full = self._blocks_shape()
            self._decoded.update({k: v.reshape(full + v.shape[4:]) for k, v in out.items()})
        return self._decoded["psun"], self._decoded["pzen"]

    def load(self):
        """Decode everything the selection needs now (instead of on first evaluation); returns self."""
        self.radiance_coefficients()
        self.transmittance_coefficients()
        if self.has_polarisation:
            self.polarisation_coefficients()
        return self

    def describe(self) -> str:
        """Human-readable summary: grids, channels, sections and sizes."""
        def rng(a, unit):
            return f"{len(a)} values {a[0]:g} .. {a[-1]:g} {unit}" if len(a) > 1 else f"{a[0]:g} {unit}"
        lines = [
            f"dataset        {self.path}",
            f"file size      {self.file_size / 1e6:.1f} MB",
        ]
        if self.is_synthetic:
            lines.append("NOTE           synthetic dataset (not a physical sky): for testing and demos only")
        if self.metadata.get("description"):
            lines.append(f"description    {self.metadata['description']}")
        lines += [
            f"visibility     {rng(self.file_visibilities, 'km')}",
            f"albedo         {rng(self.file_albedos, '')}",
            f"altitude       {rng(self.file_altitudes, 'm')}",
            f"solar elev.    {rng(self.file_elevations, 'deg')}",
            f"channels       {self.n_channels_file} x {self.channel_width:g} nm from {self.channel_start:g} nm "
            f"({self.wavelength_range[0]:g}-{self.wavelength_range[1]:g} nm)",
            f"radiance       rank {self.rank}, knots sun {len(self.sun_breaks)} / zenith {len(self.zenith_breaks)}"
            f" / emphasis {len(self.emph_breaks)}",
            f"transmittance  rank {self.trans_rank}, {self.trans_d_dim} distance x {self.trans_a_dim} altitude "
            f"samples, {self._n_vis_t} visibilities, {self._n_alt_t} altitudes",
            "polarisation   " + (f"rank {self.pol_rank}, knots sun {len(self.pol_sun_breaks)} / zenith "
                                 f"{len(self.pol_zenith_breaks)}" if self._layout.pol_offset is not None else "none"),
            f"selection      {len(self.visibilities)} visibilities, {len(self.albedos)} albedos, "
            f"{len(self.elevations)} elevations, {self.n_channels} channels: {self.selection_bytes() / 1e6:.1f} MB when decoded",
            f"resident       {self.resident_bytes / 1e6:.1f} MB decoded now",
        ]
        return "\n".join(lines)

    def __repr__(self):
        return (f"SkyModel({str(self.path)!r}, visibilities={len(self.visibilities)}, albedos={len(self.albedos)}, "
                f"channels={self.n_channels}, polarisation={self.has_polarisation})")


def load_dataset(path=None, *, visibility=None, albedo=None, channels=None, wavelength_range=None,
                 polarisation=True, elevation=None) -> SkyModel:
    """Open a Prague Sky Model dataset (memory-mapped; decoded on first use).

    Parameters
    ----------
    path : str or Path, optional
        Dataset file (official full / ground-level / SWIR files or one written by widesky). Default:
        the environment variable ``WIDESKY_DATASET`` if set, else the embedded default dataset.
    visibility : float or (float, float), optional
        Load only the visibility slabs needed for this visibility [km] or range of visibilities [km]
        (the bracketing grid points). Default: all.
    albedo : float or (float, float), optional
        Same for the ground albedo [1].
    elevation : float or (float, float), optional
        Same for the solar elevation [deg] (the model's grid is in elevation at the view point, which
        equals the solar elevation for an observer on the ground). With all three given, a single sky
        state decodes only the (at most) 8 configurations per channel it interpolates between.
    channels : sequence of int, optional
        Indices of the file's channels to load.
    wavelength_range : (float, float), optional
        Load the channels overlapping this range [nm].
    polarisation : bool
        Set False to ignore the polarisation section.

    Returns
    -------
    SkyModel

    Raises
    ------
    DatasetError
        Missing, truncated, corrupted or inconsistent file (names the field and byte offset).
    """
    if path is None:
        path = os.environ.get("WIDESKY_DATASET") or default_dataset_path()
    return SkyModel(path, visibility=visibility, albedo=albedo, channels=channels,
                    wavelength_range=wavelength_range, polarisation=polarisation, elevation=elevation)
