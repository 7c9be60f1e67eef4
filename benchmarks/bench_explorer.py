"""Benchmark: a slider move in the sky explorer (widesky gui) -> the new 512 x 512 image.

Measured in the same run, on the embedded dataset, for a sequence of slider positions that each give a new
sky state (solar elevation 5 ... 65 deg in steps of 3.1 deg, between the grid's elevations):
  explorer  the HTTP round trip of ``GET /api/render`` through the explorer's server on 127.0.0.1
            (parameter checks, the visible channels only for the sRGB composite, display mapping, PNG encoding);
  raw       the route the page uses since issue 36, ``GET /api/render?format=raw``: the same evaluation, the
            linear image as float32 (no display mapping, no PNG: the page maps it and applies the exposure);
  baseline  the same image the way ``widesky sky render`` computes it: all 55 channels evaluated, then the
            same display mapping and PNG encoding (in process, no HTTP);
plus the ``/api/irradiance`` (horizontal and tilted spectra, 577 patches) and ``/api/spectrum`` round trips.
Median of the requests; the ratio is baseline / explorer.

The issue's target: a slider move shows the new 512 x 512 image in under 150 ms on 2 cores. On a shared machine
the wall time depends on the other jobs, so the script also measures the CPU time of each slider request (every
thread of this process: the server, the evaluator's threads, PNG encoding) and prints the load average. On two
dedicated cores a request's wall time lies between CPU / 2 (both cores busy throughout) and CPU (one core); the
verdict names which of the three the target meets.

With ``--browser`` (Playwright and a Chromium executable: ``chromium`` on the PATH or ``WIDESKY_CHROMIUM``) it
also measures what the issue asks for, in headless Chromium: from the slider's ``input`` event to the new image
painted on the page, for the same elevation sequence (one move at a time: each waits for its image), for an
exposure move and for a tilted-plane move (the latter two need no new sky image).

    python benchmarks/bench_explorer.py [--resolution 512] [--threads 0] [--browser] [--json out.json]
        [--screenshot docs/_static/screenshots/explorer.png] [--legacy-page 36fa688]

``--screenshot PATH`` (with ``--browser``) also writes the page's picture used in docs/guide/explorer.md;
``--legacy-page REV`` also times the explorer of git revision REV (server and page; 36fa688 is the one before
issue 36) in the same browser and run, its moves interleaved with today's: the before / after comparison.
"""

from __future__ import annotations

import argparse
import http.client
import io
import json
import os
import platform
import threading
import time

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--resolution", type=int, default=512)
    ap.add_argument("--threads", type=int, default=0, help="evaluator threads of saves and the baseline (0: all cores)")
    ap.add_argument("--view-threads", type=int, default=1,
                    help="evaluator threads of the explorer's interactive image (the server's default 1)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--browser", action="store_true", help="also time slider moves in headless Chromium")
    ap.add_argument("--screenshot", default=None, help="with --browser: write a PNG picture of the page here")
    ap.add_argument("--legacy-page", default=None, metavar="REV",
                    help="with --browser: also time the explorer (server and page) of git revision REV (e.g. "
                         "36fa688, before issue 36) in the same run, its moves interleaved with today's")
    args = ap.parse_args(argv)

    from PIL import Image

    from widesky import skymodel
    from widesky.explorer import Explorer, make_server
    from widesky.skymodel.render import _display, render_sky

    ex = Explorer(threads=args.threads, view_threads=args.view_threads)
    m = ex.model(0)
    srv = make_server(ex, port=0)
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    port = srv.server_address[1]
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=120)

    def get(path):
        t0 = time.perf_counter()
        conn.request("GET", path, headers={"Host": f"127.0.0.1:{port}"})
        r = conn.getresponse()
        body = r.read()
        assert r.status == 200, body[:200]
        return time.perf_counter() - t0, r, body

    elevations = np.arange(5.0, 66.0, 3.1)
    base = f"azimuth=200&visibility=37&albedo=0.25&resolution={args.resolution}"
    get(f"/api/render?elevation=30&{base}")                 # warm-up: first decode of the dataset slabs
    t_ex, t_eval, t_cpu, t_raw, t_raw_cpu = [], [], [], [], []
    load0 = os.getloadavg()[0]
    for el in elevations:       # interleaved; each request a new sky state (the server keeps recent renders)
        c0 = time.process_time()
        dt, r, _ = get(f"/api/render?elevation={el:.2f}&{base}")
        t_cpu.append(time.process_time() - c0)
        t_ex.append(dt)
        t_eval.append(float(r.getheader("X-Render-Seconds")))
        c0 = time.process_time()
        dt, r, _ = get(f"/api/render?elevation={el + 0.05:.2f}&{base}&format=raw")
        t_raw_cpu.append(time.process_time() - c0)
        t_raw.append(dt)
    t_base = []
    for el in elevations:
        t0 = time.perf_counter()
        rr = render_sky(m, sun_elevation=el, sun_azimuth=200, visibility=37, albedo=0.25,
                        resolution=args.resolution, threads=args.threads or (os.cpu_count() or 1))
        buf = io.BytesIO()
        Image.fromarray(_display(rr, True, 0.0)).save(buf, format="PNG", compress_level=1)
        t_base.append(time.perf_counter() - t0)
    # the interactive image's evaluator threads: one against all cores, interleaved, in process, new states
    from widesky.explorer.compute import render_view
    ncpu = os.cpu_count() or 1        # explicit: the evaluator's 0 keeps the previous call's count (OpenMP)
    per_threads = {1: ([], []), ncpu: ([], [])}
    for el in elevations:
        for th, off in ((1, 0.11), (ncpu, 0.17)):
            v = ex.view({"elevation": f"{el + off:.2f}", "azimuth": "200", "visibility": "37", "albedo": "0.25",
                         "resolution": str(args.resolution)})
            c0, t0 = time.process_time(), time.perf_counter()
            render_view(m, v, th)
            per_threads[th][0].append(time.perf_counter() - t0)
            per_threads[th][1].append(time.process_time() - c0)
    t_irr = [get(f"/api/irradiance?elevation={el:.2f}&{base}")[0] for el in elevations[::3]]
    t_spec = [get(f"/api/spectrum?elevation={el:.2f}&{base}&u=0.4&v=0.6")[0] for el in elevations[::3]]
    browser = None
    if args.browser:
        pages = {"page": f"http://127.0.0.1:{port}/"}
        old = legacy_server(args.legacy_page, args.threads) if args.legacy_page else None
        if old is not None:
            pages[f"explorer of {args.legacy_page}"] = f"http://127.0.0.1:{old.server_address[1]}/"
        browser = browser_moves(pages, elevations, args.screenshot)
        if old is not None:
            old.shutdown()
    srv.shutdown()
    out = {
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
        "resolution": args.resolution, "threads": args.threads, "steps": len(elevations),
        "explorer_render_ms": 1e3 * float(np.median(t_ex)), "explorer_eval_ms": 1e3 * float(np.median(t_eval)),
        "explorer_raw_ms": 1e3 * float(np.median(t_raw)), "explorer_raw_cpu_ms": 1e3 * float(np.median(t_raw_cpu)),
        "baseline_all_channels_ms": 1e3 * float(np.median(t_base)),
        "irradiance_ms": 1e3 * float(np.median(t_irr)), "spectrum_ms": 1e3 * float(np.median(t_spec)),
        "dataset": str(m.path), "explorer_cpu_ms": 1e3 * float(np.median(t_cpu)),
        "load_average": [load0, os.getloadavg()[0]],
        "view_threads": args.view_threads,
        "evaluation_by_threads": {(f"{th} thread" + ("s" if th > 1 else "")): {
            "wall_ms": 1e3 * float(np.median(w)), "cpu_ms": 1e3 * float(np.median(c))}
            for th, (w, c) in per_threads.items()},
    }
    target = 150.0
    cpu = out["explorer_cpu_ms"]
    out["target_150ms"] = ("met (wall time)" if out["explorer_render_ms"] < target else
                           "met on 2 dedicated cores (CPU time below it)" if cpu < target else
                           "met on 2 dedicated cores only if both stay busy (CPU / 2 below it)" if cpu / 2 < target
                           else "not met")
    out["ratio"] = out["baseline_all_channels_ms"] / out["explorer_render_ms"]
    print(f"slider move -> {args.resolution}x{args.resolution} image: {out['explorer_render_ms']:.0f} ms round trip "
          f"(sky evaluation {out['explorer_eval_ms']:.0f} ms); baseline (all 55 channels, widesky sky render's path) "
          f"{out['baseline_all_channels_ms']:.0f} ms: {out['ratio']:.1f}x")
    print(f"irradiance readout {out['irradiance_ms']:.0f} ms, clicked spectrum {out['spectrum_ms']:.1f} ms "
          f"({out['machine']}, threads={args.threads}, median of {len(elevations)} / {len(t_irr)} requests)")
    print(f"the page's route (format=raw: half-float image, exposure and sRGB mapping in the browser): "
          f"{out['explorer_raw_ms']:.0f} ms round trip, {out['explorer_raw_cpu_ms']:.0f} ms CPU")
    print("the image's sky evaluation in process (median wall / CPU): " + "; ".join(
        f"{k} {v['wall_ms']:.0f} / {v['cpu_ms']:.0f} ms" for k, v in out["evaluation_by_threads"].items()))
    print(f"CPU time per slider move {cpu:.0f} ms (all threads); load average {load0:.1f} -> "
          f"{out['load_average'][1]:.1f}; the 150 ms target: {out['target_150ms']}")
    if browser:
        out["browser"] = browser
        for label, res in browser.items():
            print(f"{label} in headless Chromium, input event -> new image drawn (median / max ms): " + "; ".join(
                f"{k} {v['median_ms']:.0f} / {v['max_ms']:.0f}" for k, v in res.items()))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)
    return out


# in the page: move one slider, then resolve with the milliseconds until the image of that state is painted
# (the page records it in window.wideskyShown; a page without that hook: the <img> holding that state has loaded)
_MOVE = """async ([name, value]) => {
  const el = document.querySelector(`[name=${name}]`) || document.getElementById(name);
  el.value = value;
  const needle = `${name}=${el.value}`;                     // the value the slider snapped to
  const shown = () => {
    const s = window.wideskyShown && window.wideskyShown.A;
    if (s) return ('&' + s.state + '&').includes('&' + needle + '&') ? s.time : null;
    const img = document.getElementById('imgA');
    return img.complete && (img.dataset.state || '').includes(needle) ? performance.now() : null;
  };
  const t0 = performance.now();
  el.dispatchEvent(new Event("input", {bubbles: true}));
  for (;;) {
    const t = shown();
    if (t !== null) return t - t0;
    if (performance.now() - t0 > 10000) return NaN;
    await new Promise((r) => requestAnimationFrame(r));
  }
}"""

_MOVE_READOUT = """async ([name, value]) => {
  const el = document.querySelector(`[name=${name}]`);
  const cell = () => document.querySelector('#readout tbody').rows[0].cells[2].textContent;
  const before = cell(), t0 = performance.now();
  el.value = value; el.dispatchEvent(new Event('input', {bubbles: true}));
  for (;;) {
    if (cell() !== before) return performance.now() - t0;
    if (performance.now() - t0 > 30000) return NaN;
    await new Promise((r) => requestAnimationFrame(r));
  }
}"""


def browser_moves(pages, elevations, screenshot=None, settle=0.5):
    """Median and max milliseconds from a slider's input event to the new image (or readout), per page
    (``pages``: label -> URL); the pages' moves are interleaved, each page's sky states new to the server,
    each move ``settle`` seconds after the previous one's image."""
    import shutil

    from playwright.sync_api import sync_playwright

    exe = os.environ.get("WIDESKY_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    stats = lambda t: {"median_ms": float(np.median(t)), "max_ms": float(np.max(t)), "n": len(t)}  # noqa: E731
    out = {}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        tabs = {}
        for k, (label, url) in enumerate(pages.items()):
            page = browser.new_page(viewport={"width": 1400, "height": 1100}, bypass_csp=True)
            page.goto(url)
            page.wait_for_function("document.querySelector('#readout tbody').rows.length > 0", timeout=60000)
            page.evaluate(_MOVE, ["elevation", f"{29.3 + 0.3 * k:.1f}"])          # warm-up
            tabs[label] = (page, 0.3 * (k + 1))        # each page its own sky states, all new to the server
        times = {label: {"elevation": [], "exposure": [], "tilt_readout": []} for label in tabs}

        def move(label, kind, script, args):
            # one slider move after the pages have come to rest (what a move sets off later, the irradiance and
            # spectrum once the slider rests, has finished), as a person moving a slider and looking
            time.sleep(settle)
            times[label][kind].append(tabs[label][0].evaluate(script, args))

        for el in elevations:
            for label, (page, off) in tabs.items():
                move(label, "elevation", _MOVE, ["elevation", f"{el + off:.1f}"])
        for ev in (1, 2, 3, -1, -2, 0.5, 4, 0):
            for label in tabs:
                move(label, "exposure", _MOVE, ["exposure", f"{ev:g}"])
        for a in (10, 20, 30, 40, 50, 60, 70, 80):
            for label in tabs:
                move(label, "tilt_readout", _MOVE_READOUT, ["surface_tilt", str(a)])
        for label in tabs:
            out[label] = {k: stats(v) for k, v in times[label].items()}
        page = next(iter(tabs.values()))[0]
        if screenshot:
            page.evaluate(_MOVE, ["elevation", "18"])
            page.evaluate(_MOVE_READOUT, ["surface_tilt", "35"])
            box = page.locator("#viewA").bounding_box()
            page.mouse.click(box["x"] + box["width"] * 0.62, box["y"] + box["height"] * 0.7)
            page.wait_for_function("document.getElementById('dirinfo').textContent.includes('zenith')")
            page.screenshot(path=screenshot, full_page=True)
        browser.close()
    return out


def legacy_server(rev, threads):
    """The explorer as it was at git revision ``rev`` (e.g. 36fa688, before issue 36: PNG images with the
    exposure applied on the server, a new render for every move, the irradiance recomputed for every move): its
    server module and its page, script and style, on a port of its own, with an explorer of its own (its own
    dataset copy, no shared caches). The old server module runs against today's compute and params modules (the
    same evaluation calls; their signatures are unchanged)."""
    import subprocess
    import types
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]

    def show(path):
        return subprocess.run(["git", "show", f"{rev}:{path}"], cwd=root, capture_output=True, check=True).stdout

    files = {name: show(f"src/widesky/explorer/static/{name}") for name in ("index.html", "app.js", "style.css")}
    types_ = {"index.html": "text/html; charset=utf-8", "app.js": "text/javascript; charset=utf-8",
              "style.css": "text/css; charset=utf-8"}
    mod = types.ModuleType("widesky.explorer._legacy_server")
    mod.__package__ = "widesky.explorer"
    exec(compile(show("src/widesky/explorer/server.py"), f"{rev}:server.py", "exec"), mod.__dict__)
    srv = mod.make_server(mod.Explorer(threads=threads), port=0)
    base = srv.RequestHandlerClass

    class LegacyPage(base):
        def do_GET(self):  # noqa: N802
            name = {"/": "index.html", "/index.html": "index.html", "/app.js": "app.js",
                    "/style.css": "style.css"}.get(self.path)
            if name:
                return self._send(200, files[name], types_[name])
            return super().do_GET()

    srv.RequestHandlerClass = LegacyPage
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    return srv


if __name__ == "__main__":
    main()
