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

__all__ = ["Sink", "run_provenance"]


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
                 stored=None):
        self.keys, self.T, self.F, self.C = keys, T, F, C
        self.temporary = None
        if path is None:
            n_arr = len(keys) + 2 + (len(PARTS) + 1) * C * bool(spectral)
            if 4 * T * F * n_arr > IN_MEMORY_BYTES:
                import tempfile
                fd, path = tempfile.mkstemp(prefix="widesky-result-", suffix=".h5",
                                            dir=os.environ.get("WIDESKY_TMPDIR") or None)
                os.close(fd)
                self.temporary = path
        self.path, self.writer, self.ctx = path, None, None
        self.spectral = spectral
        self.resp_names, self.units, self.faces = resp_names, units, faces
        if path is None:
            self.full = {k: lazy_zeros((T, F), np.float32) for k in keys}
            self.full["aoi"] = lazy_zeros((T, F), np.float32)
            self.full["sun_visible"] = lazy_zeros((T, F), np.float32)
            if spectral:
                for p in PARTS + ("global",):
                    self.full[("spectral", p)] = lazy_zeros((T, F, C), np.float32)
        else:
            self.ctx = atomic_h5(path)
            f = self.ctx.__enter__()
            self.writer = H5Writer(f, resp_names, units, faces, T, C if spectral else None,
                                   compression, parts=stored)

    def block(self, b0, b1, f0=0, f1=None):
        """dict key -> (b1 - b0, f1 - f0) zeroed arrays (aoi NaN) to fill for steps b0:b1 of the faces f0:f1
        (default all)."""
        n = b1 - b0
        f1 = self.F if f1 is None else f1
        if self.writer is None:
            out = {k: v[b0:b1, f0:f1] for k, v in self.full.items()}
            out["aoi"][:] = np.nan
            return out
        # one set of block buffers, reused (fresh multi-100-MB arrays per block cost seconds of
        # page faults); contiguous (n, f1 - f0) views of them
        m = f1 - f0
        if getattr(self, "_buf", None) is None or self._buf_size < n * m:
            shape = {k: (n * m,) for k in [*self.keys, "aoi", "sun_visible"]}
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
        spec = ({p: full[("spectral", p)] for p in PARTS + ("global",)} if self.spectral else None)
        return POAResult(responses=self.resp_names, units=self.units, data={k: full[k] for k in self.keys},
                         aoi=full["aoi"], sun_visible=full["sun_visible"], faces=self.faces, times=times,
                         states=states, scaling=scaling, provenance=provenance, spectral=spec,
                         wavelengths=wavelengths, channel_edges=channel_edges, timings=timings)


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


