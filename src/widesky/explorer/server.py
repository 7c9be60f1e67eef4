"""The sky explorer's HTTP server (standard library ``http.server``), bound to 127.0.0.1 only.

Routes (GET unless noted; parameters in the query string, see :mod:`widesky.explorer.params`)::

    /                    the page (self-contained: its script and style come from this server)
    /app.js, /style.css
    /api/info            datasets (grids, channels, ranges), responses, output folder
    /api/render          PNG of the view; headers X-Render-Seconds (evaluation), X-Total-Seconds
    /api/spectrum        JSON: every channel at the clicked image position (u, v in [0, 1])
    /api/irradiance      JSON: horizontal and tilted-plane spectra and their integrals
    /api/sun             JSON: solar elevation and azimuth for lat, lon, time (ISO 8601), tz
    /api/save  (POST)    writes <name>.png and/or <name>.exr of the view into the output folder
    /files/<name>        a file written by /api/save

Safety: requests whose Host header is not ``127.0.0.1:<port>`` or ``localhost:<port>`` get 403 (a page
on another site cannot reach the server through DNS rebinding); no request names a file path: datasets
are chosen by their index among those given on the command line, saved files get a sanitised name inside
the output folder, and ``/files/`` serves only plain names found there.
"""

from __future__ import annotations

import json
import re
import threading
import time
import webbrowser
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from pathlib import Path
from urllib.parse import parse_qsl, urlsplit

import numpy as np
import pandas as pd

from widesky import skymodel
from widesky.core.atomic import atomic_write
from widesky.irradiance import Site
from widesky.skymodel.render import render_sky, write_exr, write_png

from .compute import direction_at, plane_irradiance, png_bytes, render_view, spectrum_at
from .params import ParameterError, _number, channel_names, parse_pixel, parse_view

__all__ = ["Explorer", "make_server", "serve"]

_STATIC = {"/": ("index.html", "text/html; charset=utf-8"),
           "/index.html": ("index.html", "text/html; charset=utf-8"),
           "/app.js": ("app.js", "text/javascript; charset=utf-8"),
           "/style.css": ("style.css", "text/css; charset=utf-8")}
_SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,120}$")


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
        Evaluator threads (0: all cores).
    load_options : dict, optional
        Passed to :func:`widesky.skymodel.load_dataset` for every dataset, to load part of it:
        ``wavelength_range`` (lo, hi) [nm], ``visibility`` (lo, hi) [km], ``albedo`` (lo, hi) [1].
    """

    def __init__(self, datasets=None, output_dir=".", responses=None, threads=0, load_options=None):
        self.paths = [None] if not datasets else [Path(p) for p in datasets]
        self._models = [None] * len(self.paths)
        self._lock = threading.Lock()
        # one evaluation at a time: each already uses every core, and a dataset decodes its slabs on first use
        self._eval = threading.Lock()
        self._load = skymodel.load_dataset
        self.output_dir = Path(output_dir).resolve()
        self.responses = dict(responses or {})
        self.threads = int(threads)
        self.load_options = dict(load_options or {})
        for i in range(len(self.paths)):     # open (memory-map and validate) now: a bad file fails at start-up
            self.model(i)

    def model(self, index):
        """The :class:`widesky.skymodel.SkyModel` of dataset ``index`` (opened once, decoded on first use)."""
        with self._lock:
            if self._models[index] is None:
                self._models[index] = self._load(self.paths[index], **self.load_options)
            return self._models[index]

    def view(self, query):
        return parse_view(query, self.model, len(self.paths), site_sun=site_sun)

    def info(self):
        sets = []
        for i in range(len(self.paths)):
            m = self.model(i)
            sets.append({
                "index": i, "name": Path(m.path).name,
                "visibility_km": [float(x) for x in m.visibilities], "albedo": [float(x) for x in m.albedos],
                "altitude_m": [float(x) for x in m.altitudes], "elevation_deg": [float(x) for x in m.elevations],
                "channels": channel_names(m), "wavelength_nm": m.wavelengths.tolist(),
                "polarisation": bool(m.has_polarisation), "synthetic": bool(m.is_synthetic)})
        return {"datasets": sets, "responses": ["broadband", "illuminance", *self.responses],
                "output_dir": str(self.output_dir)}

    def _responses_for(self, model):
        out = {}
        for name, (w, unit) in self.responses.items():
            w = np.asarray(w, float)
            if w.shape == (model.n_channels,):      # responses are defined on dataset 0's channels
                out[name] = (w, unit)
        return out

    def render(self, query):
        v = self.view(query)
        t0 = time.perf_counter()
        with self._eval:
            r, composite, dt = render_view(self.model(v.dataset), v, self.threads)
        png = png_bytes(r, composite, v.exposure)
        return png, dt, time.perf_counter() - t0

    def spectrum(self, query):
        v = self.view(query)
        u, w = parse_pixel(query)
        d = direction_at(v, u, w)
        if d is None:
            raise ParameterError(f"u={u:g}, v={w:g} lies outside the fisheye disc")
        with self._eval:
            out = spectrum_at(self.model(v.dataset), v, d, self.threads)
        out.update(u=u, v=w)
        return out

    def irradiance(self, query):
        v = self.view(query)
        m = self.model(v.dataset)
        with self._eval:
            out = plane_irradiance(m, v, self._responses_for(m))
        out.update(surface_tilt=v.surface_tilt, surface_azimuth=v.surface_azimuth,
                   sun_elevation=v.sun_elevation, sun_azimuth=v.sun_azimuth)
        return out

    def save(self, query):
        """Write the view as PNG and/or spectral EXR (all channels) into the output folder, atomically."""
        v = self.view(query)
        name = query.get("name", "sky")
        if not _SAFE_NAME.match(name) or ".." in name:
            raise ParameterError(f"name={name!r}: letters, digits, '.', '_' and '-' only (no folders)")
        formats = query.get("format", "png,exr").split(",")
        bad = [f for f in formats if f not in ("png", "exr")]
        if bad or not formats:
            raise ParameterError(f"format={query.get('format')!r}: expected png, exr or png,exr")
        m = self.model(v.dataset)
        self.output_dir.mkdir(parents=True, exist_ok=True)
        with self._eval:
            return self._save(m, v, name, formats)

    def _save(self, m, v, name, formats):
        written = []
        if "png" in formats:
            r, composite, _ = render_view(m, v, self.threads)
            written.append(_atomic(self.output_dir / f"{name}.png",
                                   lambda p: write_png(p, r, composite=composite, exposure=v.exposure)))
        if "exr" in formats:
            chi = None if v.channel == "rgb" else [int(np.argmin(np.abs(m.wavelengths - float(v.channel[:-2]))))]
            r = render_sky(m, sun_elevation=v.sun_elevation, sun_azimuth=v.sun_azimuth, visibility=v.visibility,
                           albedo=v.albedo, altitude=v.altitude, quantity=v.quantity, channels=chi, view=v.view,
                           view_azimuth=v.view_azimuth, resolution=v.resolution, threads=self.threads)
            written.append(_atomic(self.output_dir / f"{name}.exr", lambda p: write_exr(p, r)))
        return {"written": [p.name for p in written], "output_dir": str(self.output_dir)}

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
    time of ``tz``) and ``tz`` (IANA name or hours east of UTC), by NREL SPA."""
    lat = _number(query, "lat", 50.08, -90.0, 90.0, "deg")
    lon = _number(query, "lon", 14.42, -180.0, 180.0, "deg")
    tz = query.get("tz", "UTC") or "UTC"
    try:
        tz = float(tz)
    except ValueError:
        pass
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


class _Handler(BaseHTTPRequestHandler):
    server_version = "widesky-explorer"
    explorer: Explorer = None          # set on the subclass by make_server
    quiet = True

    def log_message(self, fmt, *args):  # noqa: D401  (http.server's hook)
        if not self.quiet:
            super().log_message(fmt, *args)

    def _host_ok(self):
        port = self.server.server_address[1]
        host = (self.headers.get("Host") or "").strip().lower()
        return host in (f"127.0.0.1:{port}", f"localhost:{port}")

    def _send(self, code, body, ctype, extra=None):
        self.send_response(code)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Content-Security-Policy",
                         "default-src 'self'; img-src 'self' blob: data:; style-src 'self'; script-src 'self'")
        for k, v in (extra or {}).items():
            self.send_header(k, v)
        self.end_headers()
        if self.command != "HEAD":
            try:
                self.wfile.write(body)
            except (BrokenPipeError, ConnectionResetError):
                pass                   # the page moved on (a newer slider state): nothing to deliver

    def _json(self, code, obj):
        self._send(code, json.dumps(obj).encode(), "application/json")

    def _dispatch(self, method):
        if not self._host_ok():
            return self._json(403, {"error": f"Host {self.headers.get('Host')!r} refused: use 127.0.0.1"})
        url = urlsplit(self.path)
        query = dict(parse_qsl(url.query, keep_blank_values=True))
        route = url.path
        ex = self.explorer
        try:
            if method == "GET" and route in _STATIC:
                name, ctype = _STATIC[route]
                body = resources.files(__package__).joinpath("static", name).read_bytes()
                return self._send(200, body, ctype)
            if method == "GET" and route == "/api/info":
                return self._json(200, ex.info())
            if method == "GET" and route == "/api/render":
                png, dt, total = ex.render(query)
                return self._send(200, png, "image/png", {"X-Render-Seconds": f"{dt:.4f}",
                                                          "X-Total-Seconds": f"{total:.4f}"})
            if method == "GET" and route == "/api/spectrum":
                return self._json(200, ex.spectrum(query))
            if method == "GET" and route == "/api/irradiance":
                return self._json(200, ex.irradiance(query))
            if method == "GET" and route == "/api/sun":
                el, az = site_sun(query)
                return self._json(200, {"elevation": el, "azimuth": az})
            if method == "POST" and route == "/api/save":
                return self._json(200, ex.save(query))
            if method == "GET" and route.startswith("/files/"):
                p = ex.saved_file(route[len("/files/"):])
                if p is None:
                    return self._json(404, {"error": "no such file in the output folder"})
                ctype = "image/png" if p.suffix == ".png" else "application/octet-stream"
                return self._send(200, p.read_bytes(), ctype)
        except ParameterError as exc:
            return self._json(400, {"error": str(exc)})
        except ValueError as exc:    # the evaluator's own range checks
            return self._json(400, {"error": str(exc)})
        return self._json(404, {"error": f"{method} {route}: no such resource"})

    def do_GET(self):  # noqa: N802
        self._dispatch("GET")

    def do_HEAD(self):  # noqa: N802
        self._dispatch("GET")

    def do_POST(self):  # noqa: N802
        length = int(self.headers.get("Content-Length") or 0)
        if length:
            self.rfile.read(min(length, 1 << 16))
        self._dispatch("POST")


def make_server(explorer: Explorer, port=0, quiet=True):
    """A :class:`http.server.ThreadingHTTPServer` on 127.0.0.1 (``port`` 0: a free port) serving ``explorer``;
    call ``serve_forever()`` (or :func:`serve`). ``server.server_address[1]`` is the port."""
    handler = type("ExplorerHandler", (_Handler,), {"explorer": explorer, "quiet": quiet})
    srv = ThreadingHTTPServer(("127.0.0.1", int(port)), handler)
    srv.daemon_threads = True
    return srv


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
        pass
    finally:
        srv.server_close()
    return 0
