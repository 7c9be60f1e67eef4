"""Where :func:`widesky.irradiance.poa_irradiance`'s blocks of output steps go, and the result's provenance.

:class:`Sink` keeps the (T, F) arrays in memory or streams each block to the HDF5 result file (written
atomically); :func:`run_provenance` records what produced a result.
"""

from __future__ import annotations

import hashlib
import importlib.metadata as md
import os
from dataclasses import asdict

import numpy as np

from .integrator import lazy_zeros
from .result import PARTS, H5Writer, POAResult, atomic_h5

__all__ = ["Sink", "run_provenance", "FaceSums"]


IN_MEMORY_BYTES = 2 << 30
"""Largest in-memory result [bytes] (its (T, F) float32 arrays, and spectral (T, F, C) ones, at their full size):
a run without an output file whose result would be larger streams it to a temporary HDF5 file instead (in
``WIDESKY_TMPDIR``, else the system's temporary folder; removed when the result is closed or garbage
collected, at once on POSIX systems), which the returned result reads on access: 1.6 GB peak resident at
20,000 faces over an hourly year (docs/benchmarks.md). Below it the arrays stay in memory, the pages of night
steps never touched (resident: about the daylight fraction of this size)."""


class Sink:
    """Where the blocks of output steps go: arrays in memory, or the HDF5 file (given, or a temporary one for a
    result larger than :data:`IN_MEMORY_BYTES`)."""

    def __init__(self, keys, T, F, C, path, resp_names, units, faces, spectral, compression=None,
                 stored=None, angles=True, arrays=True):
        # angles: keep "aoi" and "sun_visible"; arrays False: the blocks are buffers for the consumer only
        # (nothing kept, nothing written)
        self.keys, self.T, self.F, self.C = keys, T, F, C
        self.angles, self.arrays = bool(angles), bool(arrays)
        self.geo = ["aoi", "sun_visible"] if self.angles else []
        self.temporary = None
        if path is None and self.arrays:
            n_arr = len(keys) + len(self.geo) + (len(PARTS) + 1) * C * bool(spectral)
            if 4 * T * F * n_arr > IN_MEMORY_BYTES:
                import tempfile
                fd, path = tempfile.mkstemp(prefix="widesky-result-", suffix=".h5",
                                            dir=os.environ.get("WIDESKY_TMPDIR") or None)
                os.close(fd)
                self.temporary = path
        self.path, self.writer, self.ctx = path, None, None
        self.spectral = spectral
        self.resp_names, self.units, self.faces = resp_names, units, faces
        self.full = None
        if not self.arrays:
            pass
        elif path is None:
            self.full = {k: lazy_zeros((T, F), np.float32) for k in [*keys, *self.geo]}
            if spectral:
                for p in PARTS + ("global",):
                    self.full[("spectral", p)] = lazy_zeros((T, F, C), np.float32)
        else:
            self.ctx = atomic_h5(path)
            f = self.ctx.__enter__()
            self.writer = H5Writer(f, resp_names, units, faces, T, C if spectral else None,
                                   compression, parts=stored, angles=self.angles)

    def block(self, b0, b1, f0=0, f1=None):
        """dict key -> (b1 - b0, f1 - f0) zeroed arrays (aoi NaN) to fill for steps b0:b1 of the faces f0:f1
        (default all)."""
        n = b1 - b0
        f1 = self.F if f1 is None else f1
        if self.full is not None:
            out = {k: v[b0:b1, f0:f1] for k, v in self.full.items()}
            if "aoi" in out:
                out["aoi"][:] = np.nan
            return out
        # one set of block buffers, reused (fresh multi-100-MB arrays per block cost seconds of
        # page faults); contiguous (n, f1 - f0) views of them
        m = f1 - f0
        if getattr(self, "_buf", None) is None or self._buf_size < n * m:
            shape = {k: (n * m,) for k in [*self.keys, *self.geo]}
            if self.spectral:
                shape.update({("spectral", p): (n * m * self.C,) for p in PARTS + ("global",)})
            self._buf = {k: lazy_zeros(v, np.float32) for k, v in shape.items()}
            self._buf_size = n * m
        out = {}
        for k, v in self._buf.items():
            shape = (n, m, self.C) if isinstance(k, tuple) and k[0] == "spectral" else (n, m)
            out[k] = v[:int(np.prod(shape))].reshape(shape)
        for k, v in out.items():
            v.fill(np.nan if k == "aoi" else 0.0)
        return out

    def flush(self, b0, block, f0=0):
        """Write a block of steps from b0 (of the faces from f0) to the file (in memory: nothing to do)."""
        if self.writer is not None:
            self.writer.write(b0, block, f0)

    def close(self, failed, **finish):
        if self.writer is None:
            return
        if not failed:
            self.writer.finish(**finish)
        self.ctx.__exit__(RuntimeError if failed else None, None, None)
        if failed and self.temporary is not None and os.path.exists(self.temporary):
            os.unlink(self.temporary)


    def result(self, timings, times, states, scaling, provenance, wavelengths, channel_edges):
        """The run's POAResult: read back from the file, or the arrays in memory."""
        if self.path is not None:
            res = POAResult.load(self.path)
            res.timings = timings
            if self.temporary is not None:             # the open file stays readable; the name goes now
                try:
                    os.unlink(self.temporary)
                except OSError:                        # (not on Windows while open): at exit
                    import atexit
                    atexit.register(lambda p=self.temporary: os.path.exists(p) and os.unlink(p))
            return res
        full = self.full
        if full is None:                           # arrays=False: the consumer holds the reductions
            return POAResult(responses=[], units={}, data={}, aoi=None, sun_visible=None, faces=self.faces,
                             times=times, states=states, scaling=scaling, provenance=provenance,
                             wavelengths=wavelengths, channel_edges=channel_edges, timings=timings)
        spec = ({p: full[("spectral", p)] for p in PARTS + ("global",)} if self.spectral else None)
        return POAResult(responses=self.resp_names, units=self.units, data={k: full[k] for k in self.keys},
                         aoi=full.get("aoi"), sun_visible=full.get("sun_visible"), faces=self.faces, times=times,
                         states=states, scaling=scaling, provenance=provenance, spectral=spec,
                         wavelengths=wavelengths, channel_edges=channel_edges, timings=timings)


class FaceSums:
    """A consumer (:class:`~widesky.irradiance.poa_options.OutputOptions`) that sums every kept part of every
    response per face over the period: the irradiation [kWh m-2] (a response in A m-2: [kAh m-2]), with no
    (T, F) output (``OutputOptions(consumer=FaceSums(...), arrays=False)``: a reduce-only run).

    Per chunk it adds ``sum_t w_t x E[t, f] / 1000`` (float32 within a chunk, float64 across chunks) for each
    ``(response, part)`` of the block
    (a response kept with its three parts also gets their sum as "global") and the global part of each
    response handed over in ``currents`` only (kept as ``()`` or served by the fused product and not in the
    block: ``w . diffuse + (w dni) . beam``, no (Tc, F) temporary). It takes ``faces=``, so runs in blocks of
    faces (``RunOptions(face_block=...)``) fill the faces' columns block by block.

    Parameters
    ----------
    n_faces : int
        Faces of the scene.
    step_hours : float or array_like
        Duration of each step [h]: a number, or (T,) per step (default 1: hourly steps).

    Attributes
    ----------
    sums : dict
        ``(response, part)`` -> (F,) float64 period sum [kWh m-2] (or [kAh m-2]).
    """

    def __init__(self, n_faces, step_hours=1.0):
        self.n_faces = int(n_faces)
        if self.n_faces < 0:
            raise ValueError(f"n_faces={n_faces} must be >= 0")
        w = np.asarray(step_hours, dtype=float)
        if w.ndim > 1 or not np.all(np.isfinite(w)) or np.any(w < 0):
            raise ValueError(f"step_hours={step_hours!r}: expected a finite number >= 0 [h] or (T,) of them")
        self.step_hours = w
        self.sums = {}

    def _add(self, key, faces, value):
        if key not in self.sums:
            self.sums[key] = np.zeros(self.n_faces)
        self.sums[key][faces] += value

    def __call__(self, steps, block, rows, currents, faces=None):
        faces = slice(0, self.n_faces) if faces is None else faces
        steps = np.asarray(steps)
        if self.step_hours.ndim == 1 and steps.size and int(steps.max()) >= self.step_hours.size:
            raise ValueError(f"FaceSums: step_hours has {self.step_hours.size} steps, the run at least "
                             f"{int(steps.max()) + 1}")
        # float32 products over a chunk's steps (a few hundred at most), accumulated over chunks in float64
        w = ((np.full(steps.size, float(self.step_hours)) if self.step_hours.ndim == 0
              else self.step_hours[steps]) / 1000.0).astype(np.float32)
        per = {}
        for k, v in block.items():
            if isinstance(k, tuple) and k[0] != "spectral":
                s = (w @ v[rows]).astype(np.float64)
                self._add(k, faces, s)
                per.setdefault(k[0], {})[k[1]] = s
        for name, got in per.items():
            if "global" not in got and set(PARTS) <= set(got):
                self._add((name, "global"), faces, sum(got[p] for p in PARTS))
        for name, gp in currents.items():
            if name not in per:
                s = (w @ gp.diffuse).astype(np.float64)
                s += w * gp.dni @ gp.beam
                self._add((name, "global"), faces, s)

    def table(self, faces=None):
        """pandas DataFrame, one row per face, one column ``"<response>:<part>"`` per sum [kWh m-2]; with
        ``faces`` (:class:`widesky.irradiance.result.FaceTable`) its group, side, area [m2], tilt and azimuth
        [deg] first."""
        import pandas as pd
        cols = {}
        if faces is not None:
            cols.update(group=np.asarray(faces.group_names, dtype=object)[faces.group], side=faces.side,
                        area_m2=faces.area, tilt_deg=faces.tilt, azimuth_deg=faces.azimuth)
        for (r, p), v in self.sums.items():
            cols[f"{r}:{p}"] = v
        return pd.DataFrame(cols, index=pd.RangeIndex(self.n_faces, name="face"))


def run_provenance(settings, optic_nodes, sky, extra=None):
    """``result.provenance``: the settings, the optic nodes [deg], package versions, the sky source and its
    dataset file (with its SHA-1), and ``extra`` entries."""
    return {"settings": asdict(settings), "optic_nodes": list(map(float, optic_nodes)),
            "versions": _versions(), **_dataset_provenance(sky), **(extra or {})}


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


