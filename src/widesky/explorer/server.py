"""The sky explorer's HTTP server (standard library ``http.server``), bound to 127.0.0.1 only.

Routes (GET unless noted; parameters in the query string, see :mod:`widesky.explorer.params`)::

    /                    the page (self-contained: its script and style come from this server); it carries
                         the session token in <meta name="widesky-token">
    /app.js, /style.css
    /api/info            datasets (grids, channels, ranges), responses, output folder's name, save budget
    /api/render          PNG of the view (format=png, default), or the linear image before its display mapping
                         (format=raw: half floats divided by the exposure reference; the page applies the exposure); headers X-Render-Seconds
                         (evaluation; 0 when the sky state was cached), X-Total-Seconds
    /api/spectrum        JSON: every channel at the clicked image position (u, v in [0, 1])
    /api/irradiance      JSON: horizontal and tilted-plane spectra and their integrals
    /api/sun             JSON: solar elevation and azimuth for lat, lon, time (ISO 8601), tz (IANA name or hours)
    /api/datasets        JSON: the dataset files (*.dat) in the folders allowed with --dataset-dir
    /api/load   (POST)   opens one of those by folder index and plain name; answers its dataset index
    /api/save   (POST)   writes <name>.png and/or <name>.exr of the view (resolution up to 10000 with
                         save_resolution) into the output folder
    /files/<name>        a file written by /api/save

Safety (each item has a test in ``tests/test_explorer.py``):

* requests whose Host header is not ``127.0.0.1:<port>`` or ``localhost:<port>`` get 403 (no DNS rebinding);
* a request from another origin gets 403: an ``Origin`` header other than the server's own, or a
  ``Sec-Fetch-Site`` other than ``same-origin`` / ``none``, on every ``/api/`` and ``/files/`` route;
* every state-changing request (POST) must carry the session's token in ``X-Widesky-Token`` (a random
  256-bit value made at start-up, given only inside the page, which another origin cannot read): else 403;
* the bytes a session (one server run) may write are bounded (``save_budget``, default 2 GB): a save that
  would exceed it gets 507 and writes nothing; a save needing more memory than is available gets 413;
* ``Content-Length`` must be a plain decimal number (else 400) of at most 64 KiB (else 413); bodies are
  read with the connection's timeout, never waited for indefinitely;
* every connection has a socket timeout (``idle_timeout``, default 10 s): an idle or stalled client is
  disconnected; at most ``max_workers`` (default 32) connections are served at once, more get 503;
* no request names a file path: datasets are chosen by their index, or by a plain name listed in a folder
  allowed at start-up; saved files get a validated plain name inside the output folder; ``/files/`` serves
  only plain names found there; ``tz`` accepts IANA zone names only (or hours east of UTC);
* answers show no absolute path (folders and datasets by their names) and the ``Server`` header names no
  Python version.
"""

from __future__ import annotations

import dataclasses
import hmac
import json
import os
import re
import secrets
import select
import shutil
import socket
import sys
import threading
import time
import webbrowser
import zoneinfo
from collections import OrderedDict
from functools import lru_cache
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from urllib.parse import parse_qsl, urlsplit

import numpy as np
import pandas as pd

from widesky import skymodel
from widesky.core.atomic import atomic_write, clear_interrupted
from widesky.irradiance import Site
from widesky.skymodel.render import check_render_memory, render_sky, write_exr, write_png

from .compute import (_render_channels, direction_at, linear_payload, plane_irradiance, png_bytes, render_view,
                      sky_patches, spectrum_at)
from .params import MAX_SAVE_RESOLUTION, ParameterError, _number, channel_names, parse_pixel, parse_view

__all__ = ["Explorer", "make_server", "serve", "HTTPError"]

_STATIC = {"/": ("index.html", "text/html; charset=utf-8"),
           "/index.html": ("index.html", "text/html; charset=utf-8"),
           "/app.js": ("app.js", "text/javascript; charset=utf-8"),
           "/style.css": ("style.css", "text/css; charset=utf-8")}
_SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,120}$")
_TOKEN_SLOT = "__WIDESKY_TOKEN__"
MAX_BODY_BYTES = 1 << 16          # [bytes] the largest request body accepted (no route needs one)
DEFAULT_SAVE_BUDGET = 2_000_000_000   # [bytes] what one server run may write
_RENDER_CACHE_BYTES = 256 << 20   # [bytes] renders kept for re-use (exposure, pinned B, moving back)
_SKY_CACHE_STATES = 64            # sky states whose patch radiance is kept (a plane change re-uses it)


class HTTPError(Exception):
    """An answer other than 200: ``status`` and a one-line message."""

    def __init__(self, status, message):
        super().__init__(message)
        self.status = status


class _Gone(Exception):
    """The client closed its connection before the work started (a superseded slider state)."""


@lru_cache(maxsize=1)
def _zone_names():
    return frozenset(zoneinfo.available_timezones()) | {"UTC"}


def parse_tz(raw):
    """``tz`` of a request: an IANA zone name (as listed by :func:`zoneinfo.available_timezones`) or hours
    east of UTC in [-14, 14]; anything else (a path, a ``dateutil/...`` or ``file:`` spec) is refused."""
    raw = (raw or "UTC").strip()
    if re.fullmatch(r"[+-]?[0-9]{1,2}(\.[0-9]+)?", raw):
        h = float(raw)
        if -14.0 <= h <= 14.0:
            return h
    elif raw in _zone_names():
        return raw
    raise ParameterError(f"tz={raw!r}: expected an IANA time zone name such as Europe/Prague, "
                         "or hours east of UTC in [-14, 14]")


class _EvalLock:
    """One evaluation at a time (each already uses every core), images first: a readout (irradiance, spectrum)
    waits while an image request is waiting, so the readout a slider move triggers never delays the next image."""

    def __init__(self):
        self._cond = threading.Condition()
        self._busy = False
        self._images_waiting = 0

    def acquire(self, image=False):
        with self._cond:
            if image:
                self._images_waiting += 1
            try:
                while self._busy or (not image and self._images_waiting):
                    self._cond.wait()
            finally:
                if image:
                    self._images_waiting -= 1
            self._busy = True

    def release(self):
        with self._cond:
            self._busy = False
            self._cond.notify_all()

    def __enter__(self):                  # a readout's turn
        self.acquire(image=False)
        return self

    def __exit__(self, *exc):
        self.release()

    def image(self):
        """Context manager: an image's turn (ahead of waiting readouts)."""
        lock = self

        class _Turn:
            def __enter__(self):
                lock.acquire(image=True)

            def __exit__(self, *exc):
                lock.release()
        return _Turn()


class Explorer:
    """State shared by the requests: the datasets (opened lazily, once), responses and output folder.

    Parameters
    ----------
    datasets : list of str or Path, optional
        Dataset files; default the embedded dataset (or ``WIDESKY_DATASET``).
    output_dir : str or Path
        Folder that ``/api/save`` writes into (created if missing).
    responses : dict of str to (ndarray, str), optional
        Extra spectral responses: name -> (weights per channel of dataset 0, output unit), e.g. a cell SR
        [A W-1] -> "A m-2" or a glazing transmittance [1] -> "W m-2"; the irradiance spectra are
        integrated against them (see :func:`widesky.explorer.cli.parse_response`).
    threads : int
        Evaluator threads of saves (0: all cores).
    view_threads : int
        Evaluator threads of what a slider move asks for (the interactive image, the clicked spectrum, the
        plane's sky patches); default 1: on the shared 2-core development machine one thread was never slower
        than two for a 512 x 512 image (28-32 ms wall / 12 ms CPU against 88-94 ms / 33-38 ms in one
        process at load average 6.1; equal in ``benchmarks/bench_explorer.py``'s loop), and at 1024 pixels it
        used less CPU (43 ms against 61-75 ms). 0: all cores.
    load_options : dict, optional
        Passed to :func:`widesky.skymodel.load_dataset` for every dataset, to load part of it:
        ``wavelength_range`` (lo, hi) [nm], ``visibility`` (lo, hi) [km], ``albedo`` (lo, hi) [1].
    dataset_dirs : list of str or Path, optional
        Folders whose ``*.dat`` files the page may list and open at run time (``/api/datasets``,
        ``/api/load``); nothing else on disk can be opened by a request.
    save_budget : int
        Bytes that saves may write in this session (one server run) [bytes]; a save that would pass it
        is refused (HTTP 507).
    max_datasets : int
        Most datasets open at once (each maps its file and decodes slabs on use).
    """

    def __init__(self, datasets=None, output_dir=".", responses=None, threads=0, load_options=None,
                 dataset_dirs=None, save_budget=DEFAULT_SAVE_BUDGET, max_datasets=16, view_threads=1):
        self.paths = [None] if not datasets else [Path(p) for p in datasets]
        self._models = [None] * len(self.paths)
        self._lock = threading.Lock()
        # one evaluation at a time: each already uses every core, and a dataset decodes its slabs on first use;
        # images go before readouts
        self._eval = _EvalLock()
        self._load = skymodel.load_dataset
        self.output_dir = Path(output_dir).resolve()
        self.responses = dict(responses or {})
        # explicit counts: the evaluator's 0 ("all cores") keeps the count of the process's previous call (OpenMP's
        # omp_set_num_threads is global), so after a one-thread view render a 0 would mean one thread
        self.threads = int(threads) or (os.cpu_count() or 1)
        self.view_threads = int(view_threads) or (os.cpu_count() or 1)
        self.load_options = dict(load_options or {})
        self.dataset_dirs = [Path(d).resolve() for d in (dataset_dirs or [])]
        for d in self.dataset_dirs:
            if not d.is_dir():
                raise ValueError(f"--dataset-dir {d}: not a folder")
        self.save_budget = int(save_budget)
        self.saved_bytes = 0
        self.max_datasets = int(max_datasets)
        self.token = secrets.token_urlsafe(32)          # this session's: only the page carries it
        self._renders = OrderedDict()                    # image key -> Render (least recently used first)
        self._skies = OrderedDict()                      # sky key -> patch radiance
        for i in range(len(self.paths)):     # open (memory-map and validate) now: a bad file fails at start-up
            self.model(i)

    # --- datasets ------------------------------------------------------------------------------------
    def model(self, index):
        """The :class:`widesky.skymodel.SkyModel` of dataset ``index`` (opened once, decoded on first use)."""
        with self._lock:
            if self._models[index] is None:
                self._models[index] = self._load(self.paths[index], **self.load_options)
            return self._models[index]

    def view(self, query):
        return parse_view(query, self.model, len(self.paths), site_sun=site_sun)

    def _dataset_info(self, i):
        m = self.model(i)
        return {"index": i, "name": Path(m.path).name,
                "visibility_km": [float(x) for x in m.visibilities], "albedo": [float(x) for x in m.albedos],
                "altitude_m": [float(x) for x in m.altitudes], "elevation_deg": [float(x) for x in m.elevations],
                "channels": channel_names(m), "wavelength_nm": m.wavelengths.tolist(),
                "polarisation": bool(m.has_polarisation), "synthetic": bool(m.is_synthetic)}

    def info(self):
        return {"datasets": [self._dataset_info(i) for i in range(len(self.paths))],
                "responses": ["broadband", "illuminance", *self.responses],
                "output_dir": self.output_dir.name, "dataset_dirs": [d.name for d in self.dataset_dirs],
                "save_budget_bytes": self.save_budget, "saved_bytes": self.saved_bytes,
                "max_save_resolution": MAX_SAVE_RESOLUTION}

    def available_datasets(self):
        """The ``*.dat`` files of the allowed folders: ``folder`` (index), ``name``, ``bytes``, ``loaded``
        (the dataset index if open, else None)."""
        opened = {str(p.resolve()): i for i, p in enumerate(self.paths) if p is not None}
        out = []
        for k, d in enumerate(self.dataset_dirs):
            try:
                entries = sorted(os.scandir(d), key=lambda e: e.name)
            except OSError:
                continue
            for e in entries:
                if e.name.endswith(".dat") and _SAFE_NAME.match(e.name) and e.is_file():
                    out.append({"folder": k, "name": e.name, "bytes": e.stat().st_size,
                                "loaded": opened.get(str(Path(e.path).resolve()))})
        return {"folders": [d.name for d in self.dataset_dirs], "files": out}

    def load(self, query):
        """Open the dataset ``name`` of allowed folder ``folder`` (a plain name listed there); returns its
        dataset index and description."""
        if not self.dataset_dirs:
            raise HTTPError(403, "no dataset folder was allowed at start-up (widesky gui --dataset-dir DIR)")
        k = _number(query, "folder", 0, 0, len(self.dataset_dirs) - 1, "", integer=True)
        name = query.get("name", "")
        listed = {f["name"]: f for f in self.available_datasets()["files"] if f["folder"] == k}
        if name not in listed:
            raise ParameterError(f"name={name!r}: not a dataset file of folder {self.dataset_dirs[k].name!r} "
                                 f"(choose one of {', '.join(sorted(listed)) or 'none'})")
        if listed[name]["loaded"] is not None:
            i = listed[name]["loaded"]
            return self._dataset_info(i)
        path = self.dataset_dirs[k] / name
        with self._lock:
            if len(self.paths) >= self.max_datasets:
                raise HTTPError(507, f"{len(self.paths)} datasets are open, the most this session allows")
        try:
            m = self._load(path, **self.load_options)
        except (OSError, ValueError) as exc:
            msg = str(exc).replace(str(path), name).replace(str(self.dataset_dirs[k]), self.dataset_dirs[k].name)
            raise ParameterError(f"dataset {name!r}: {msg}") from None
        with self._lock:
            self.paths.append(path)
            self._models.append(m)
            i = len(self.paths) - 1
        return self._dataset_info(i)

    # --- renders ----------------------------------------------------------------------------------------
    @staticmethod
    def _image_key(v):
        return dataclasses.astuple(dataclasses.replace(v, exposure=0.0, surface_tilt=0.0, surface_azimuth=0.0))

    def _render(self, v, alive=None):
        """(Render, composite, seconds of evaluation) of a view, from the cache when this image was made."""
        key = self._image_key(v)
        with self._lock:
            hit = self._renders.get(key)
            if hit is not None:
                self._renders.move_to_end(key)
                return hit[0], hit[1], 0.0
        with self._eval.image():
            if alive is not None and not alive():
                raise _Gone()
            with self._lock:
                hit = self._renders.get(key)
            if hit is not None:
                return hit[0], hit[1], 0.0
            r, composite, dt = render_view(self.model(v.dataset), v, self.view_threads)
        with self._lock:
            self._renders[key] = (r, composite)
            size = lambda e: e[0].values.nbytes * 2     # noqa: E731  (values and their sRGB + Y image)
            while len(self._renders) > 1 and sum(size(e) for e in self._renders.values()) > _RENDER_CACHE_BYTES:
                self._renders.popitem(last=False)
        return r, composite, dt

    def render(self, query, alive=None):
        """PNG bytes of the view, seconds of evaluation, seconds in all."""
        v = self.view(query)
        t0 = time.perf_counter()
        r, composite, dt = self._render(v, alive)
        return png_bytes(r, composite, v.exposure), dt, time.perf_counter() - t0

    def render_linear(self, query, alive=None):
        """The view before its display mapping (:func:`widesky.explorer.compute.linear_payload`): (bytes, headers)."""
        v = self.view(query)
        t0 = time.perf_counter()
        r, composite, dt = self._render(v, alive)
        kind, ref, data = linear_payload(r, composite)
        n = r.mask.shape[0]
        return data, {"X-Image-Kind": kind, "X-Image-Size": str(n), "X-Reference": repr(float(ref)),
                      "X-Render-Seconds": f"{dt:.4f}", "X-Total-Seconds": f"{time.perf_counter() - t0:.4f}"}

    def spectrum(self, query):
        v = self.view(query)
        u, w = parse_pixel(query)
        d = direction_at(v, u, w)
        if d is None:
            raise ParameterError(f"u={u:g}, v={w:g} lies outside the fisheye disc")
        with self._eval:
            out = spectrum_at(self.model(v.dataset), v, d, self.view_threads)
        out.update(u=u, v=w)
        return out

    def _responses_for(self, model):
        out = {}
        for name, (w, unit) in self.responses.items():
            w = np.asarray(w, float)
            if w.shape == (model.n_channels,):      # responses are defined on dataset 0's channels
                out[name] = (w, unit)
        return out

    def irradiance(self, query):
        v = self.view(query)
        m = self.model(v.dataset)
        key = (v.dataset, v.sun_elevation, v.sun_azimuth, v.visibility, v.albedo, v.altitude)
        with self._lock:
            sky = self._skies.get(key)
        if sky is None:
            with self._eval:
                sky = sky_patches(m, v, threads=self.view_threads)
            with self._lock:
                self._skies[key] = sky
                while len(self._skies) > _SKY_CACHE_STATES:
                    self._skies.popitem(last=False)
        out = plane_irradiance(m, v, self._responses_for(m), sky=sky)
        out.update(surface_tilt=v.surface_tilt, surface_azimuth=v.surface_azimuth,
                   sun_elevation=v.sun_elevation, sun_azimuth=v.sun_azimuth)
        return out

    # --- saving ---------------------------------------------------------------------------------------
    def save(self, query):
        """Write the view as PNG and/or spectral EXR (all channels) into the output folder, atomically.

        ``name``: a plain file name (letters, digits, '.', '_', '-'; a trailing .png / .exr is dropped);
        ``format``: png, exr or png,exr; ``save_resolution``: 16 to 10000 pixels (default the view's);
        ``overwrite=1`` replaces an existing file of that name (otherwise 409).
        """
        v = self.view(query)
        name = query.get("name", "sky")
        if not _SAFE_NAME.match(name) or ".." in name:
            raise ParameterError(f"name={name!r}: letters, digits, '.', '_' and '-' only, not starting with '.' "
                                 "(a file name inside the output folder, no folders)")
        name = re.sub(r"\.(png|exr)$", "", name, flags=re.IGNORECASE) or "sky"
        formats = query.get("format", "png,exr").split(",")
        bad = [f for f in formats if f not in ("png", "exr")]
        if bad or not formats:
            raise ParameterError(f"format={query.get('format')!r}: expected png, exr or png,exr")
        res = _number(query, "save_resolution", v.resolution, 16, MAX_SAVE_RESOLUTION, "pixels", integer=True)
        v = dataclasses.replace(v, resolution=res)
        overwrite = query.get("overwrite", "0") == "1"
        targets = [self.output_dir / f"{name}.{f}" for f in formats]
        if not overwrite:
            there = [p.name for p in targets if p.exists()]
            if there:
                raise HTTPError(409, f"{', '.join(there)} already in the output folder: choose another name "
                                     "or tick 'overwrite'")
        m = self.model(v.dataset)
        chi_n = len(_render_channels(m, v)[0])
        n_exr = m.n_channels if v.channel == "rgb" else 1
        need = 0
        for f in formats:          # estimated file sizes: 8-bit RGB; EXR float32 per channel + RGB preview
            need += res * res * 3 + 65536 if f == "png" else res * res * (n_exr + 3) * 4 + 65536
            try:
                check_render_memory(res, chi_n if f == "png" else n_exr, exr=(f == "exr"), option="save_resolution")
            except ValueError as exc:
                raise HTTPError(413, str(exc)) from None
        with self._lock:
            left = self.save_budget - self.saved_bytes
            if need > left:
                raise HTTPError(507, f"this save needs about {need / 1e6:.0f} MB; {max(left, 0) / 1e6:.0f} MB "
                                     f"of this session's {self.save_budget / 1e6:.0f} MB save budget are left "
                                     "(widesky gui --save-budget MB)")
            self.saved_bytes += need                      # reserved now; corrected to the real sizes below
        try:
            self.output_dir.mkdir(parents=True, exist_ok=True)
            free = shutil.disk_usage(self.output_dir).free
            if need > free:
                raise HTTPError(507, f"this save needs about {need / 1e6:.0f} MB; the output folder's disk has "
                                     f"{free / 1e6:.0f} MB free")
            with self._eval:
                written = self._save(m, v, name, formats)
        except BaseException:
            with self._lock:
                self.saved_bytes -= need
            raise
        real = sum(p.stat().st_size for p in written)
        with self._lock:
            self.saved_bytes += real - need
        return {"written": [p.name for p in written], "output_dir": self.output_dir.name, "bytes": real,
                "resolution": res, "saved_bytes": self.saved_bytes, "save_budget_bytes": self.save_budget}

    def _save(self, m, v, name, formats):
        written = []
        if "png" in formats:
            r, composite, _ = render_view(m, v, self.threads)
            written.append(_atomic(self.output_dir / f"{name}.png",
                                   lambda p: write_png(p, r, composite=composite, exposure=v.exposure)))
            del r
        if "exr" in formats:
            chi = None if v.channel == "rgb" else [int(np.argmin(np.abs(m.wavelengths - float(v.channel[:-2]))))]
            r = render_sky(m, sun_elevation=v.sun_elevation, sun_azimuth=v.sun_azimuth, visibility=v.visibility,
                           albedo=v.albedo, altitude=v.altitude, quantity=v.quantity, channels=chi, view=v.view,
                           view_azimuth=v.view_azimuth, resolution=v.resolution, threads=self.threads)
            written.append(_atomic(self.output_dir / f"{name}.exr", lambda p: write_exr(p, r)))
        return written

    def saved_file(self, name):
        """Path of a saved file by plain name, or None (never a path outside the output folder)."""
        if not _SAFE_NAME.match(name) or ".." in name:
            return None
        p = (self.output_dir / name).resolve()
        if p.parent != self.output_dir or not p.is_file():
            return None
        return p


def _atomic(path, write):
    """Run ``write(tmp)`` on a temporary file beside ``path``, then rename it into place
    (:func:`widesky.core.atomic.atomic_write`)."""
    with atomic_write(path) as tmp:
        write(tmp)
    return path


def site_sun(query):
    """(apparent elevation, azimuth) [deg] of the sun for ``lat``, ``lon`` [deg], ``time`` (ISO 8601, local
    time of ``tz``) and ``tz`` (IANA name or hours east of UTC, :func:`parse_tz`), by NREL SPA."""
    lat = _number(query, "lat", 50.08, -90.0, 90.0, "deg")
    lon = _number(query, "lon", 14.42, -180.0, 180.0, "deg")
    tz = parse_tz(query.get("tz"))
    raw = query.get("time", "")
    try:
        t = pd.Timestamp(raw)
    except (ValueError, TypeError):
        raise ParameterError(f"time={raw!r}: expected an ISO 8601 date-time such as 2024-06-21T12:00") from None
    if t is pd.NaT:
        raise ParameterError(f"time={raw!r}: expected an ISO 8601 date-time such as 2024-06-21T12:00")
    try:
        site = Site(lat, lon, tz=tz)
        sp = site.solar_position(pd.DatetimeIndex([t]), label="center", step="1h")
    except ValueError as exc:
        raise ParameterError(f"tz={query.get('tz')!r} / time={raw!r}: {exc}") from None
    return float(sp["apparent_elevation"].iloc[0]), float(sp["azimuth"].iloc[0])


_SAME_ORIGIN_FETCH = ("same-origin", "none")    # Sec-Fetch-Site values of the page itself / a typed address


class _Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"      # keep-alive: the page's requests reuse their connections
    server_version = "widesky-explorer"
    sys_version = ""
    explorer: Explorer = None          # set on the subclass by make_server
    quiet = True
    timeout = 10.0                     # [s] socket timeout of every connection (StreamRequestHandler applies it)

    def version_string(self):
        return self.server_version     # no Python version in the Server header

    def log_message(self, fmt, *args):  # noqa: D401  (http.server's hook)
        if not self.quiet:
            super().log_message(fmt, *args)

    def _origins(self):
        port = self.server.server_address[1]
        return (f"127.0.0.1:{port}", f"localhost:{port}")

    def _host_ok(self):
        host = (self.headers.get("Host") or "").strip().lower()
        return host in self._origins()

    def _cross_origin(self):
        """Why this request comes from another origin, or None."""
        origin = self.headers.get("Origin")
        if origin is not None and origin.strip().lower() not in tuple("http://" + o for o in self._origins()):
            return f"Origin {origin!r}"
        site = self.headers.get("Sec-Fetch-Site")
        if site is not None and site.strip().lower() not in _SAME_ORIGIN_FETCH:
            return f"Sec-Fetch-Site {site!r}"
        return None

    def _send(self, code, body, ctype, extra=None):
        try:
            self.send_response(code)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.send_header("X-Content-Type-Options", "nosniff")
            self.send_header("Cross-Origin-Resource-Policy", "same-origin")
            self.send_header("Content-Security-Policy",
                             "default-src 'self'; img-src 'self' blob: data:; style-src 'self'; script-src 'self'")
            if code >= 400:
                self.send_header("Connection", "close")
                self.close_connection = True
            for k, v in (extra or {}).items():
                self.send_header(k, v)
            self.end_headers()
            if self.command != "HEAD":
                self.wfile.write(body)
        except (BrokenPipeError, ConnectionResetError, TimeoutError):
            self.close_connection = True   # the page moved on (a newer slider state): nothing to deliver

    def _json(self, code, obj):
        self._send(code, json.dumps(obj).encode(), "application/json")

    def _alive(self):
        """False once the client has closed the connection (an aborted fetch)."""
        try:
            readable, _, _ = select.select([self.connection], [], [], 0)
            if not readable:
                return True
            return self.connection.recv(1, socket.MSG_PEEK) != b""
        except OSError:
            return False

    def _read_body(self):
        """Read the request body: ``Content-Length`` a plain decimal number of at most MAX_BODY_BYTES."""
        if self.headers.get("Transfer-Encoding") is not None:
            raise HTTPError(400, "Transfer-Encoding is not accepted: send a Content-Length")
        values = self.headers.get_all("Content-Length") or []
        if not values:
            return b""
        raw = values[0].strip()
        if len(set(v.strip() for v in values)) != 1 or not re.fullmatch(r"[0-9]{1,19}", raw):
            raise HTTPError(400, f"Content-Length {values[0][:40]!r}: expected one non-negative whole number")
        n = int(raw)
        if n > MAX_BODY_BYTES:
            raise HTTPError(413, f"Content-Length {n}: at most {MAX_BODY_BYTES} bytes")
        body = self.rfile.read(n) if n else b""       # under the socket timeout: a stalled client is dropped
        if len(body) != n:
            raise HTTPError(400, f"Content-Length {n}: the body ended after {len(body)} bytes")
        return body

    def _page(self):
        html = resources.files(__package__).joinpath("static", "index.html").read_text(encoding="utf-8")
        return html.replace(_TOKEN_SLOT, self.explorer.token).encode()

    def _dispatch(self, method):
        try:
            if not self._host_ok():
                raise HTTPError(403, f"Host {self.headers.get('Host')!r} refused: use 127.0.0.1")
            self._read_body()
            url = urlsplit(self.path)
            query = dict(parse_qsl(url.query, keep_blank_values=True))
            route = url.path
            if route.startswith(("/api/", "/files/")):
                why = self._cross_origin()
                if why is not None:
                    raise HTTPError(403, f"{why} refused: the explorer answers its own page only")
            if method == "POST":
                token = self.headers.get("X-Widesky-Token") or ""
                if not hmac.compare_digest(token.encode(), self.explorer.token.encode()):
                    raise HTTPError(403, "missing or wrong X-Widesky-Token: state-changing requests come from "
                                         "the explorer's own page")
            return self._route(method, route, query)
        except _Gone:
            self.close_connection = True
        except HTTPError as exc:
            self._json(exc.status, {"error": str(exc)})
        except ParameterError as exc:
            self._json(400, {"error": str(exc)})
        except ValueError as exc:    # the evaluator's own range checks
            self._json(400, {"error": str(exc)})
        except TimeoutError:
            self.close_connection = True
        except Exception as exc:     # noqa: BLE001  (one line to the page, the traceback to the terminal)
            if not self.quiet:
                import traceback
                traceback.print_exc(file=sys.stderr)
            self._json(500, {"error": f"internal error: {type(exc).__name__}"})

    def _route(self, method, route, query):
        ex = self.explorer
        if method == "GET" and route in _STATIC:
            name, ctype = _STATIC[route]
            if name == "index.html":
                return self._send(200, self._page(), ctype)
            body = resources.files(__package__).joinpath("static", name).read_bytes()
            return self._send(200, body, ctype)
        if method == "GET" and route == "/api/info":
            return self._json(200, ex.info())
        if method == "GET" and route == "/api/render":
            fmt = query.get("format", "png")
            if fmt == "raw":
                data, headers = ex.render_linear(query, alive=self._alive)
                return self._send(200, data, "application/octet-stream", headers)
            if fmt != "png":
                raise ParameterError(f"format={fmt!r}: expected png or raw")
            png, dt, total = ex.render(query, alive=self._alive)
            return self._send(200, png, "image/png", {"X-Render-Seconds": f"{dt:.4f}",
                                                      "X-Total-Seconds": f"{total:.4f}"})
        if method == "GET" and route == "/api/spectrum":
            return self._json(200, ex.spectrum(query))
        if method == "GET" and route == "/api/irradiance":
            return self._json(200, ex.irradiance(query))
        if method == "GET" and route == "/api/sun":
            el, az = site_sun(query)
            return self._json(200, {"elevation": el, "azimuth": az})
        if method == "GET" and route == "/api/datasets":
            return self._json(200, ex.available_datasets())
        if method == "POST" and route == "/api/load":
            return self._json(200, ex.load(query))
        if method == "POST" and route == "/api/save":
            return self._json(200, ex.save(query))
        if method == "GET" and route.startswith("/files/"):
            p = ex.saved_file(route[len("/files/"):])
            if p is None:
                return self._json(404, {"error": "no such file in the output folder"})
            ctype = "image/png" if p.suffix == ".png" else "application/octet-stream"
            return self._send(200, p.read_bytes(), ctype)
        return self._json(404, {"error": f"{method} {route}: no such resource"})

    def do_GET(self):  # noqa: N802
        self._dispatch("GET")

    def do_HEAD(self):  # noqa: N802
        self._dispatch("GET")

    def do_POST(self):  # noqa: N802
        self._dispatch("POST")


class _Server(ThreadingHTTPServer):
    """A threading HTTP server with at most ``max_workers`` connections served at once (more get 503 at once)."""

    daemon_threads = True

    def __init__(self, address, handler, max_workers):
        super().__init__(address, handler)
        self.max_workers = int(max_workers)
        self._slots = threading.BoundedSemaphore(self.max_workers)

    def process_request(self, request, client_address):
        if not self._slots.acquire(blocking=False):
            body = b'{"error": "the explorer is busy: too many connections at once"}'
            try:
                request.settimeout(1.0)
                request.sendall(b"HTTP/1.0 503 Service Unavailable\r\nServer: widesky-explorer\r\n"
                                b"Content-Type: application/json\r\nRetry-After: 1\r\nConnection: close\r\n"
                                b"Content-Length: " + str(len(body)).encode() + b"\r\n\r\n" + body)
            except OSError:
                pass
            self.shutdown_request(request)
            return
        threading.Thread(target=self._work, args=(request, client_address), daemon=True).start()

    def _work(self, request, client_address):
        try:
            self.process_request_thread(request, client_address)
        finally:
            self._slots.release()


def make_server(explorer: Explorer, port=0, quiet=True, idle_timeout=10.0, max_workers=32):
    """An HTTP server on 127.0.0.1 (``port`` 0: a free port) serving ``explorer``; call ``serve_forever()``
    (or :func:`serve`). ``server.server_address[1]`` is the port. ``idle_timeout`` [s]: a connection that
    sends or reads nothing for that long is closed; ``max_workers``: connections served at once."""
    if not idle_timeout > 0:
        raise ValueError(f"idle_timeout={idle_timeout}: expected a positive number of seconds")
    handler = type("ExplorerHandler", (_Handler,), {"explorer": explorer, "quiet": quiet,
                                                    "timeout": float(idle_timeout)})
    return _Server(("127.0.0.1", int(port)), handler, max_workers)


def serve(explorer: Explorer, port=8765, open_browser=True, quiet=True):
    """Serve until interrupted (Ctrl-C); prints the address and optionally opens a browser tab."""
    srv = make_server(explorer, port, quiet)
    url = f"http://127.0.0.1:{srv.server_address[1]}/"
    print(f"widesky sky explorer on {url} (Ctrl-C stops it); saving into {explorer.output_dir}", flush=True)
    if open_browser:
        webbrowser.open(url)
    try:
        srv.serve_forever()
    except KeyboardInterrupt:
        clear_interrupted()     # Ctrl-C is how the explorer stops: a normal end (exit status 0), not an interrupt
    finally:
        srv.server_close()
    return 0
