"""Benchmark: a slider move in the sky explorer (widesky gui) -> the new 512 x 512 image.

Measured in the same run, on the embedded dataset, for a sequence of slider positions that each give a new
sky state (solar elevation 5 ... 65 deg in steps of 3.1 deg, between the grid's elevations):
  explorer  the HTTP round trip of ``GET /api/render`` through the explorer's server on 127.0.0.1
            (parameter checks, the visible channels only for the sRGB composite, display mapping, PNG encoding);
  baseline  the same image the way ``widesky sky render`` computes it: all 55 channels evaluated, then the
            same display mapping and PNG encoding (in process, no HTTP);
plus the ``/api/irradiance`` (horizontal and tilted spectra, 577 patches) and ``/api/spectrum`` round trips.
Median of the requests; the ratio is baseline / explorer.

The issue's target: a slider move shows the new 512 x 512 image in under 150 ms on 2 cores. On a shared machine
the wall time depends on the other jobs, so the script also measures the CPU time of each slider request (every
thread of this process: the server, the evaluator's threads, PNG encoding) and prints the load average. On two
dedicated cores a request's wall time lies between CPU / 2 (both cores busy throughout) and CPU (one core); the
verdict names which of the three the target meets.

    python benchmarks/bench_explorer.py [--resolution 512] [--threads 0] [--json out.json]
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
    ap.add_argument("--threads", type=int, default=0, help="evaluator threads (0: all cores)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)

    from PIL import Image

    from widesky import skymodel
    from widesky.explorer import Explorer, make_server
    from widesky.skymodel.render import _display, render_sky

    ex = Explorer(threads=args.threads)
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
    t_ex, t_eval, t_cpu = [], [], []
    load0 = os.getloadavg()[0]
    for el in elevations:
        c0 = time.process_time()
        dt, r, _ = get(f"/api/render?elevation={el:.2f}&{base}")
        t_cpu.append(time.process_time() - c0)
        t_ex.append(dt)
        t_eval.append(float(r.getheader("X-Render-Seconds")))
    t_base = []
    for el in elevations:
        t0 = time.perf_counter()
        rr = render_sky(m, sun_elevation=el, sun_azimuth=200, visibility=37, albedo=0.25,
                        resolution=args.resolution, threads=args.threads)
        buf = io.BytesIO()
        Image.fromarray(_display(rr, True, 0.0)).save(buf, format="PNG", compress_level=1)
        t_base.append(time.perf_counter() - t0)
    t_irr = [get(f"/api/irradiance?elevation={el:.2f}&{base}")[0] for el in elevations[::3]]
    t_spec = [get(f"/api/spectrum?elevation={el:.2f}&{base}&u=0.4&v=0.6")[0] for el in elevations[::3]]
    srv.shutdown()
    out = {
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
        "resolution": args.resolution, "threads": args.threads, "steps": len(elevations),
        "explorer_render_ms": 1e3 * float(np.median(t_ex)), "explorer_eval_ms": 1e3 * float(np.median(t_eval)),
        "baseline_all_channels_ms": 1e3 * float(np.median(t_base)),
        "irradiance_ms": 1e3 * float(np.median(t_irr)), "spectrum_ms": 1e3 * float(np.median(t_spec)),
        "dataset": str(m.path), "explorer_cpu_ms": 1e3 * float(np.median(t_cpu)),
        "load_average": [load0, os.getloadavg()[0]],
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
    print(f"CPU time per slider move {cpu:.0f} ms (all threads); load average {load0:.1f} -> "
          f"{out['load_average'][1]:.1f}; the 150 ms target: {out['target_150ms']}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)
    return out


if __name__ == "__main__":
    main()
