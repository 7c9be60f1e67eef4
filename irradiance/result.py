"""The integrator's result: per face, step and response the direct, sky-diffuse and reflected parts,
with the faces, times, sky states, measured-weather scaling and provenance; saved to one HDF5 file.

File layout (HDF5 through h5py; ``format = "widesky.poa"``, ``format_version = 1``)::

    /                       attrs: format, format_version, responses (JSON list, "broadband" first),
                            units (JSON dict name -> "W m-2" | "A m-2"), parts, provenance (JSON)
    /times                  (T,) int64 ns since 1970-01-01 UTC; attrs tz, label
    /faces/<field>          area (F,) [m2], centroid (F, 3) [m], normal (F, 3), tilt (F,) [deg],
                            azimuth (F,) [deg], group (F,), side (F,) 0 front / 1 back, parent (F,)
                            attrs group_names (JSON)
    /states/<field>         (T,) sun_elevation, sun_azimuth [deg], visibility [km], albedo [1],
                            altitude [m], earth_sun_distance [AU]; /states/clamped/<field> (T,) bool
    /scaling/<field>        (T,) MeasuredScaling fields (when measured weather scaled the sky)
    /poa/<response>/<part>  (T, F) float32, part in direct, sky_diffuse, ground_diffuse; attrs unit
                            (format_version 2: a response run with ``parts=`` keeps only the parts
                            named in the root attribute ``parts``, JSON dict name -> list, "global"
                            among them; version 1 files hold the three parts of every response)
    /aoi, /sun_visible      (T, F) float32 [deg] (NaN at night), [1] (absent from a run with
                            ``angles=False``: format_version 2, root attribute ``angles`` false)
    /spectral/<part>        (T, F, C) float32 [W m-2 nm-1] (spectral runs only)
    /wavelengths, /channel_edges   (C,), (C+1,) [nm]

The (T, F) datasets are chunked in blocks of steps x faces (about 1 MB), so a result larger than
memory streams to disk during the run and reads back by face group or period without reading the
rest. They are stored uncompressed by default: LZF with shuffle halves the file but cost about
13 s of CPU per GB written here (uncompressed: 1.5 s), more than the whole product phase;
``compression="lzf"`` (or "gzip") asks for it.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import json
import os
import re
from dataclasses import dataclass

import h5py
import numpy as np
import pandas as pd

from widesky.core.atomic import atomic_write

from .measured import MeasuredScaling
from .skies import SkyStates

__all__ = ["FaceTable", "POAResult", "PARTS", "FORMAT", "FORMAT_VERSION"]

PARTS = ("direct", "sky_diffuse", "ground_diffuse")
ALL_PARTS = PARTS + ("global",)
FORMAT, FORMAT_VERSION = "widesky.poa", 2


@dataclass(frozen=True, eq=False)
class FaceTable:
    """Per analysed face (side).

    Attributes
    ----------
    area : numpy.ndarray
        (F,) [m2].
    centroid : numpy.ndarray
        (F, 3) world coordinates [m] (east, north, up).
    normal : numpy.ndarray
        (F, 3) unit normal of the analysed side.
    tilt : numpy.ndarray
        (F,) surface tilt from horizontal [deg] (pvlib's surface_tilt).
    azimuth : numpy.ndarray
        (F,) surface azimuth clockwise from north [deg] (pvlib's surface_azimuth; 180 for a
        horizontal face).
    group : numpy.ndarray
        (F,) index into ``group_names``.
    group_names : tuple of str
    side : numpy.ndarray
        (F,) "front" or "back".
    parent : numpy.ndarray
        (F,) index of the mesh face (both sides of a two-sided scene share it).
    """

    area: np.ndarray
    centroid: np.ndarray
    normal: np.ndarray
    tilt: np.ndarray
    azimuth: np.ndarray
    group: np.ndarray
    group_names: tuple
    side: np.ndarray
    parent: np.ndarray

    @classmethod
    def from_scene(cls, scene):
        """The faces of an :class:`widesky.irradiance.Scene`."""
        tri = scene.triangles[scene.face_triangle]
        centroid = scene.vertices[tri].mean(axis=1) + scene.origin
        n = np.asarray(scene.face_normal, dtype=float)
        tilt, az = orientation(n)
        side = np.where(np.asarray(scene.face_side) == 1, "back", "front")
        return cls(np.asarray(scene.face_area, float), centroid, n, tilt, az,
                   np.asarray(scene.face_group), tuple(scene.group_names), side,
                   np.asarray(scene.face_triangle))

    def __len__(self):
        return int(self.area.shape[0])

    def select(self, group=None):
        """(F_sel,) face indices of a group (name or index); all faces for None."""
        if group is None:
            return np.arange(len(self))
        if isinstance(group, str):
            if group not in self.group_names:
                raise ValueError(f"group={group!r} not one of {self.group_names}")
            group = self.group_names.index(group)
        return np.nonzero(self.group == int(group))[0]


def orientation(normals):
    """(tilt, azimuth) [deg] of unit normals (F, 3): tilt from horizontal, azimuth clockwise from
    north (180 where the face is horizontal, pvlib's convention for flat surfaces)."""
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    tilt = np.degrees(np.arccos(np.clip(n[:, 2], -1.0, 1.0)))
    flat = np.hypot(n[:, 0], n[:, 1]) < 1e-9
    az = np.where(flat, 180.0, np.mod(np.degrees(np.arctan2(n[:, 0], n[:, 1])), 360.0))
    return tilt, az


class POAResult:
    """Plane-of-array irradiance per face and step (arrays (T, F), time first), per response and part.

    ``get(response, part)`` gives a response's ``direct``, ``sky_diffuse``, ``ground_diffuse`` (all
    reflected light, pvlib's name) or ``global`` part after the response's optics [``units[name]``];
    ``poa_global`` ... ``poa_ground_diffuse`` are broadband without optics [W m-2]; ``aoi`` the beam's
    angle of incidence [deg] (NaN at night, > 90 behind the face); ``sun_visible`` the fraction of a
    face's points that see the sun [1]. Arrays live in memory or in the HDF5 file (``save``/``load``;
    a run with ``output=`` streams there), read on access.

    Attributes
    ----------
    responses : tuple of str
        "broadband" first.
    units : dict of str to str
        "W m-2" or "A m-2" per response.
    faces : FaceTable
    times : pandas.DatetimeIndex or None
    states : irradiance.skies.SkyStates
        With ``earth_sun_distance`` [AU] and ``clamped`` flags.
    scaling : MeasuredScaling or None
    provenance : dict
        Dataset hash, settings, package versions, command.
    spectral : None or dict of str to numpy.ndarray
        Part -> (T, F, C) [W m-2 nm-1] (broadband, no optics) when the run was spectral.
    wavelengths, channel_edges : numpy.ndarray
        (C,), (C+1,) [nm].
    timings : dict
        Wall seconds per phase of the run (not saved).
    """

    def __init__(self, *, responses, units, data, aoi, sun_visible, faces, times, states,
                 scaling=None, provenance=None, spectral=None, wavelengths=None,
                 channel_edges=None, timings=None, source=None):
        self.responses = tuple(responses)
        self.units = dict(units)
        self._data = data                      # (response, part) -> array-like (T, F)
        self.stored_parts = {r: tuple(p for p in ALL_PARTS if (r, p) in data) for r in self.responses}
        self._aoi, self._sun_visible = aoi, sun_visible
        self.faces, self.times, self.states = faces, times, states
        self.scaling, self.provenance = scaling, dict(provenance or {})
        self.spectral = spectral
        self.wavelengths = None if wavelengths is None else np.asarray(wavelengths, float)
        self.channel_edges = None if channel_edges is None else np.asarray(channel_edges, float)
        self.timings = dict(timings or {})
        self.source = source                   # the HDF5 path when file-backed

    # -- access ----------------------------------------------------------------------------------
    def _check(self, response, part):
        if response not in self.responses:
            raise ValueError(f"response={response!r} not one of {self.responses}")
        if part not in ALL_PARTS:
            raise ValueError(f"part={part!r} not one of {ALL_PARTS}")

    def get(self, response="broadband", part="global", faces=None, steps=None):
        """(T, F) float32 part of a response [``units[response]``]; ``faces`` (indices) selects
        columns and ``steps`` (a slice) rows, read from the file without the rest. A response run
        with ``parts=`` gives only the parts it kept (else a ValueError)."""
        self._check(response, part)
        sel = slice(None) if faces is None else np.asarray(faces)
        rows = slice(None) if steps is None else steps
        have = self.stored_parts[response]
        if part not in have and not (part == "global" and set(PARTS) <= set(have)):
            raise ValueError(f"response {response!r} was kept with parts {have} only "
                             f"(poa_irradiance(output=OutputOptions(parts=...))); part={part!r} is not available")
        if part == "global" and part not in have:
            out = self._read(self._data[(response, "direct")], sel, rows).astype(np.float32,
                                                                                 copy=True)
            for p in PARTS[1:]:
                out += self._read(self._data[(response, p)], sel, rows)
            return out
        return self._read(self._data[(response, part)], sel, rows)

    @staticmethod
    def _read(a, sel, rows=slice(None)):
        if isinstance(sel, slice):
            return np.asarray(a[rows, sel])
        if sel.size == 0:
            return np.zeros((len(range(*rows.indices(a.shape[0]))), 0), np.float32)
        # h5py wants increasing indices: read the covering range, then pick (a run of consecutive
        # faces, the usual face group, is read as it is)
        lo, hi = int(sel.min()), int(sel.max()) + 1
        if sel.size == hi - lo and sel[0] == lo and np.all(np.diff(sel) == 1):
            return np.asarray(a[rows, lo:hi])
        return np.asarray(a[rows, lo:hi])[:, sel - lo]

    def parts(self, response="broadband"):
        """dict part -> (T, F) for ``direct``, ``sky_diffuse``, ``ground_diffuse``, ``global`` (those
        available: :meth:`available_parts`)."""
        return {p: self.get(response, p) for p in self.available_parts(response)}

    def available_parts(self, response):
        """Parts ``get`` gives for a response: all four, or those kept with ``parts=``."""
        have = self.stored_parts[response]
        return ALL_PARTS if set(PARTS) <= set(have) else have

    @property
    def poa_global(self):
        """(T, F) broadband global irradiance without optics [W m-2]."""
        return self.get("broadband", "global")

    @property
    def poa_direct(self):
        """(T, F) broadband beam irradiance without optics [W m-2]."""
        return self.get("broadband", "direct")

    @property
    def poa_sky_diffuse(self):
        """(T, F) broadband sky-diffuse irradiance without optics [W m-2]."""
        return self.get("broadband", "sky_diffuse")

    @property
    def poa_ground_diffuse(self):
        """(T, F) broadband reflected irradiance (ground and scene surfaces) without optics [W m-2]."""
        return self.get("broadband", "ground_diffuse")

    @property
    def weighted(self):
        """dict response -> (T, F) global irradiance weighted by each response (after its optics)
        [``units[name]``], for the responses after "broadband" (formerly ``effective_irradiance``)."""
        return {n: self.get(n, "global") for n in self.responses[1:]}

    @property
    def has_angles(self):
        """True when the result keeps ``aoi`` and ``sun_visible`` (not a run with ``angles=False``)."""
        return self._aoi is not None

    def _angles(self, name):
        a = {"aoi": self._aoi, "sun_visible": self._sun_visible}[name]
        if a is None:
            raise ValueError(f"{name} was not kept (poa_irradiance(output=OutputOptions(angles=False)))")
        return a

    @property
    def aoi(self):
        """(T, F) beam angle of incidence [deg]; NaN with the sun below the horizon."""
        return np.asarray(self._angles("aoi")[:])

    @property
    def sun_visible(self):
        """(T, F) fraction of each face's points that see the sun [1]."""
        return np.asarray(self._angles("sun_visible")[:])

    def face_columns(self, name, faces):
        """(T, len(faces)) of ``"aoi"`` [deg] or ``"sun_visible"`` [1] for some faces, reading only those
        columns from a file-backed result."""
        arrays = ("aoi", "sun_visible")
        if name not in arrays:
            raise ValueError(f"face_columns: name must be one of {sorted(arrays)}, got {name!r}")
        return self._read(self._angles(name), np.asarray(faces))

    def _shape(self):
        for a in (self._aoi, *self._data.values()):
            if a is not None:
                return tuple(a.shape[:2])
        return len(self.states), len(self.faces)

    @property
    def n_steps(self):
        return int(self._shape()[0])

    @property
    def n_faces(self):
        return int(self._shape()[1])

    # the old names of the face arrays
    @property
    def face_area(self):
        return self.faces.area

    @property
    def face_group(self):
        return self.faces.group

    @property
    def group_names(self):
        return self.faces.group_names

    QUANTITIES = ("poa_global", "poa_direct", "poa_sky_diffuse", "poa_ground_diffuse")

    def _group_matrix(self):
        G = len(self.faces.group_names)
        F = len(self.faces)
        M = np.zeros((F, G))
        M[np.arange(F), self.faces.group] = self.faces.area
        area = M.sum(axis=0)
        return M / np.where(area > 0, area, 1.0), area

    def aggregate(self):
        """Area-weighted means per face group.

        Returns
        -------
        dict
            ``"area"``: (G,) group areas [m2]; ``"<response>:<part>"`` for every response and part,
            and the broadband ``poa_global`` ... ``poa_ground_diffuse``: (T, G) area-weighted mean
            [``units[response]``] (multiply by ``area`` for power [W] or current [A]).
        """
        Mn, area = self._group_matrix()
        out = {"area": area}
        T = self.n_steps
        step = max(1, (64 << 20) // (8 * max(self.n_faces, 1)))       # blocks of steps: bounded memory
        for r in self.responses:
            for p in self.available_parts(r):
                out[f"{r}:{p}"] = np.concatenate(
                    [self.get(r, p, steps=slice(a, min(T, a + step))) @ Mn for a in range(0, T, step)]
                    or [np.zeros((0, Mn.shape[1]))])
        for q, p in zip(self.QUANTITIES, ("global", "direct", "sky_diffuse", "ground_diffuse")):
            if f"broadband:{p}" in out:            # (those kept)
                out[q] = out[f"broadband:{p}"]
        return out

    def to_pvlib(self, face=None, group=None, response="broadband"):
        """pandas DataFrame with pvlib's column names for one face or an area-weighted group.

        Columns ``poa_global``, ``poa_direct``, ``poa_sky_diffuse``, ``poa_ground_diffuse``
        [``units[response]``], ``aoi`` [deg] (the group's area-weighted mean) and ``sun_visible``
        [1]; indexed by ``times``. Give ``face`` (index) or ``group`` (name or index); with neither,
        face 0 of a one-face result.
        """
        if face is not None and group is not None:
            raise ValueError("give face or group, not both")
        if face is None and group is None:
            if self.n_faces != 1:
                raise ValueError(f"the result has {self.n_faces} faces: give face= or group=")
            face = 0
        if face is not None:
            f = int(face)
            if not 0 <= f < self.n_faces:
                raise ValueError(f"face={face} outside [0, {self.n_faces - 1}]")
            idx, w = np.array([f]), np.array([1.0])
        else:
            idx = self.faces.select(group)
            a = self.faces.area[idx]
            w = a / a.sum() if a.sum() > 0 else np.full(idx.size, 1.0 / max(idx.size, 1))
        data = {}
        for p in ("global",) + PARTS:
            data[f"poa_{p}"] = self.get(response, p, faces=idx) @ w
        if self.has_angles:
            data["aoi"] = self._read(self._aoi, idx) @ w
            data["sun_visible"] = self._read(self._sun_visible, idx) @ w
        return pd.DataFrame(data, index=self.times)

    # -- file ------------------------------------------------------------------------------------
    def save(self, path, compression=None):
        """Write the result to one HDF5 file (atomically: a temporary file, then ``os.replace``);
        ``compression`` None, "lzf" or "gzip" for the (T, F) datasets."""
        path = os.fspath(path)
        with atomic_h5(path) as f:
            w = H5Writer(f, self.responses, self.units, self.faces, self.n_steps,
                         spectral_channels=None if self.spectral is None else len(self.wavelengths),
                         compression=compression, parts=self.stored_parts, angles=self.has_angles)
            step = max(1, (64 << 20) // max(1, 4 * self.n_faces * (len(self._data) + 2)))
            for t0 in range(0, self.n_steps, step):
                t1 = min(self.n_steps, t0 + step)
                block = {k: np.asarray(v[t0:t1]) for k, v in self._data.items()}
                if self.has_angles:
                    block["aoi"] = np.asarray(self._aoi[t0:t1])
                    block["sun_visible"] = np.asarray(self._sun_visible[t0:t1])
                if self.spectral is not None:
                    for p, a in self.spectral.items():
                        block[("spectral", p)] = np.asarray(a[t0:t1])
                w.write(t0, block)
            w.finish(self.times, self.states, self.scaling, self.provenance, self.wavelengths,
                     self.channel_edges)

    @classmethod
    def load(cls, path, groups=None, start=None, end=None):
        """Read a saved result; ``groups`` (names) and ``start``/``end`` (times, end exclusive) read
        only those faces and steps. Without either, arrays stay in the file and are read on access
        (keep the returned object alive while using them)."""
        path = os.fspath(path)
        try:
            f = h5py.File(path, "r")
        except OSError as e:
            raise ValueError(f"{path}: not a readable HDF5 result ({e})") from None
        if f.attrs.get("format") != FORMAT:
            f.close()
            raise ValueError(f"{path}: not a widesky result file (format attribute "
                             f"{f.attrs.get('format')!r}, expected {FORMAT!r})")
        ver = int(f.attrs.get("format_version", -1))
        if ver > FORMAT_VERSION:
            f.close()
            raise ValueError(f"{path}: format_version {ver} is newer than this reader's "
                             f"{FORMAT_VERSION}")
        responses = tuple(json.loads(f.attrs["responses"]))
        units = json.loads(f.attrs["units"])
        faces = _read_faces(f["faces"])
        times = _read_times(f)
        states = _read_states(f["states"], times)
        scaling = _read_scaling(f["scaling"]) if "scaling" in f else None
        provenance = json.loads(f.attrs.get("provenance", "{}"))
        data = {(r, p): f["poa"][r][p] for r in responses for p in ALL_PARTS if p in f["poa"][r]}
        aoi, vis = (f["aoi"], f["sun_visible"]) if "aoi" in f else (None, None)
        spectral = ({p: f["spectral"][p] for p in f["spectral"]} if "spectral" in f else None)
        wl = f["wavelengths"][:] if "wavelengths" in f else None
        edges = f["channel_edges"][:] if "channel_edges" in f else None
        res = cls(responses=responses, units=units, data=data, aoi=aoi, sun_visible=vis,
                  faces=faces, times=times, states=states, scaling=scaling, provenance=provenance,
                  spectral=spectral, wavelengths=wl, channel_edges=edges, source=path)
        res._file = f
        if groups is None and start is None and end is None:
            return res
        return res.subset(groups=groups, start=start, end=end)

    def subset(self, groups=None, start=None, end=None):
        """An in-memory result holding only the faces of ``groups`` (names or indices) and the
        steps in [start, end) (times or anything ``pandas.Timestamp`` reads, in the result's zone)."""
        T = self.n_steps
        t0, t1 = 0, T
        if (start is not None or end is not None) and self.times is None:
            raise ValueError("start/end need a result with times")
        if start is not None:
            s = _stamp(start, self.times.tz)
            t0 = int(self.times.searchsorted(s, side="left"))
        if end is not None:
            e = _stamp(end, self.times.tz)
            t1 = int(self.times.searchsorted(e, side="left"))
        if groups is None:
            idx = np.arange(self.n_faces)
        else:
            groups = [groups] if isinstance(groups, (str, int)) else list(groups)
            idx = np.unique(np.concatenate([self.faces.select(g) for g in groups]))
        lo, hi = (int(idx.min()), int(idx.max()) + 1) if idx.size else (0, 0)

        def cut(a):
            return None if a is None else np.asarray(a[t0:t1, lo:hi])[:, idx - lo]

        data = {k: cut(v) for k, v in self._data.items()}
        fc = self.faces
        faces = FaceTable(fc.area[idx], fc.centroid[idx], fc.normal[idx], fc.tilt[idx],
                          fc.azimuth[idx], fc.group[idx], fc.group_names, fc.side[idx],
                          fc.parent[idx])
        spectral = None
        if self.spectral is not None:
            spectral = {p: np.asarray(a[t0:t1, lo:hi])[:, idx - lo] for p, a in self.spectral.items()}
        scaling = None if self.scaling is None else type(self.scaling)(
            *(np.asarray(v)[t0:t1] for v in self.scaling))
        return POAResult(responses=self.responses, units=self.units, data=data,
                         aoi=cut(self._aoi), sun_visible=cut(self._sun_visible), faces=faces,
                         times=None if self.times is None else self.times[t0:t1],
                         states=self.states.take(slice(t0, t1)), scaling=scaling,
                         provenance=self.provenance, spectral=spectral,
                         wavelengths=self.wavelengths, channel_edges=self.channel_edges,
                         timings=self.timings)

    def close(self):
        """Close the backing file (file-backed results)."""
        f = getattr(self, "_file", None)
        if f is not None:
            f.close()
            self._file = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        where = f", file {self.source!r}" if self.source else ""
        return (f"POAResult({self.n_steps} steps x {self.n_faces} faces, responses "
                f"{list(self.responses)}{where})")


def _stamp(t, tz):
    s = pd.Timestamp(t)
    return s.tz_localize(tz) if s.tzinfo is None and tz is not None else s


# -- HDF5 writing ----------------------------------------------------------------------------------
@contextlib.contextmanager
def atomic_h5(path):
    """Context manager: an h5py.File on a temporary file in the target's folder, moved onto the
    target on success and removed on failure (:func:`widesky.core.atomic.atomic_write`)."""
    with atomic_write(path) as tmp, h5py.File(tmp, "w") as f:
        yield f


def chunk_shape(T, F, C=None):
    """Chunk shape of about 1 MB for (T, F) (or (T, F, C)) float32 datasets."""
    fc = int(min(F, 4096)) or 1
    per = fc * (C or 1) * 4
    tc = int(max(1, min(T, (1 << 20) // per))) or 1
    return (tc, fc) if C is None else (tc, fc, int(C))


class H5Writer:
    """Writes a result into an open h5py.File block by block of steps (rows ``t0:t0 + n``).

    ``write(t0, block)`` takes a dict ``(response, part) -> (n, F)``, ``"aoi"``, ``"sun_visible"``
    and ``("spectral", part) -> (n, F, C)``; ``finish(...)`` writes the times, states, scaling and
    provenance.
    """

    def __init__(self, f, responses, units, faces, n_steps, spectral_channels=None,
                 compression=None, parts=None, angles=True):
        self.f = f
        T, F = int(n_steps), len(faces)
        if compression not in (None, "lzf", "gzip"):
            raise ValueError(f"compression={compression!r} is not one of (None, 'lzf', 'gzip')")
        kept = {r: tuple((parts or {}).get(r, PARTS)) for r in responses}
        full = all(v == PARTS for v in kept.values())
        f.attrs["format"] = FORMAT
        # files with every response's three parts (and the angles) stay readable by version-1 readers
        f.attrs["format_version"] = 1 if full and angles else FORMAT_VERSION
        if not angles:
            f.attrs["angles"] = False
        f.attrs["responses"] = json.dumps(list(responses))
        f.attrs["units"] = json.dumps(dict(units))
        f.attrs["parts"] = json.dumps(list(PARTS) if full else {r: list(v) for r, v in kept.items()})
        kw = dict(dtype="f4")
        if T and F:
            kw["chunks"] = chunk_shape(T, F)
            if compression is not None:
                kw.update(compression=compression, shuffle=True)
        self.ds = {}
        g = f.create_group("poa")
        for r in responses:
            gr = g.create_group(r)
            gr.attrs["unit"] = units[r]
            for p in kept[r]:
                self.ds[(r, p)] = gr.create_dataset(p, shape=(T, F), fillvalue=0.0, **kw)
        if angles:
            self.ds["aoi"] = f.create_dataset("aoi", shape=(T, F), fillvalue=np.nan, **kw)
            self.ds["aoi"].attrs["unit"] = "deg"
            self.ds["sun_visible"] = f.create_dataset("sun_visible", shape=(T, F), fillvalue=0.0, **kw)
        if spectral_channels:
            C = int(spectral_channels)
            gs = f.create_group("spectral")
            skw = dict(kw)
            if T and F:
                skw["chunks"] = chunk_shape(T, F, C)
            for p in ALL_PARTS:
                self.ds[("spectral", p)] = gs.create_dataset(p, shape=(T, F, C), fillvalue=0.0,
                                                             **skw)
        _write_faces(f.create_group("faces"), faces)

    def write(self, t0, block, f0=0):
        """Rows ``t0:t0 + n`` (of the faces ``f0:f0 + m``) from a block of (n, m) arrays."""
        for k, v in block.items():
            if k in self.ds:
                if f0 == 0 and v.shape[1] == self.ds[k].shape[1]:
                    self.ds[k][t0:t0 + v.shape[0]] = v
                else:
                    self.ds[k][t0:t0 + v.shape[0], f0:f0 + v.shape[1]] = v

    def finish(self, times, states, scaling, provenance, wavelengths, channel_edges):
        f = self.f
        if times is not None:
            ti = pd.DatetimeIndex(times)
            f.create_dataset("times", data=ti.as_unit("ns").asi8)
            f["times"].attrs["tz"] = "" if ti.tz is None else str(ti.tz)
            f["times"].attrs["unit"] = "ns since 1970-01-01 UTC"
        gs = f.create_group("states")
        for name in ("sun_elevation", "sun_azimuth", "visibility", "albedo", "altitude",
                     "earth_sun_distance"):
            gs.create_dataset(name, data=np.asarray(getattr(states, name), dtype=float))
        gc = gs.create_group("clamped")
        for k, v in states.clamped.items():
            gc.create_dataset(k, data=np.asarray(v, dtype=bool))
        if scaling is not None:
            g = f.create_group("scaling")
            for k, v in scaling._asdict().items():
                g.create_dataset(k, data=np.asarray(v))
        f.attrs["provenance"] = json.dumps(provenance or {}, default=str)
        if wavelengths is not None:
            f.create_dataset("wavelengths", data=np.asarray(wavelengths, float))
        if channel_edges is not None:
            f.create_dataset("channel_edges", data=np.asarray(channel_edges, float))


def _write_faces(g, faces):
    for name in ("area", "centroid", "normal", "tilt", "azimuth", "group", "parent"):
        g.create_dataset(name, data=np.asarray(getattr(faces, name)))
    g.create_dataset("side", data=(np.asarray(faces.side) == "back").astype(np.int8))
    g.attrs["group_names"] = json.dumps(list(faces.group_names))


def _read_faces(g):
    side = np.where(g["side"][:] == 1, "back", "front")
    return FaceTable(g["area"][:], g["centroid"][:], g["normal"][:], g["tilt"][:], g["azimuth"][:],
                     g["group"][:], tuple(json.loads(g.attrs["group_names"])), side, g["parent"][:])


def _read_times(f):
    if "times" not in f:
        return None
    tz = f["times"].attrs.get("tz", "")
    ti = pd.DatetimeIndex(pd.to_datetime(f["times"][:], unit="ns", utc=True))
    if not tz:
        return ti.tz_localize(None)
    try:
        return ti.tz_convert(tz)
    except Exception:                       # a fixed offset written as "UTC+01:00"
        m = re.match(r"UTC([+-])(\d\d):(\d\d)", tz)
        if not m:
            raise
        sign = 1 if m.group(1) == "+" else -1
        off = dt.timedelta(hours=int(m.group(2)), minutes=int(m.group(3))) * sign
        return ti.tz_convert(dt.timezone(off))


def _read_states(g, times):
    vals = {k: g[k][:] for k in SkyStates.FIELDS if k in g}
    clamped = {k: g["clamped"][k][:] for k in g["clamped"]} if "clamped" in g else {}
    return SkyStates(vals["sun_elevation"], vals["sun_azimuth"], vals["visibility"], vals["albedo"],
                     vals["altitude"], vals.get("earth_sun_distance"), clamped, times)


def _read_scaling(g):
    return MeasuredScaling(*(g[k][:] for k in MeasuredScaling._fields))
