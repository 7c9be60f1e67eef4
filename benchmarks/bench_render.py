"""Benchmark: the whole ``widesky sky render`` command and ``render_sky`` against their evaluation.

Embedded default dataset, the command's default sky state (sun 30 deg at azimuth 180 deg, visibility 50 km,
albedo 0.3), an up-facing 1000 x 1000 fisheye (785,456 directions in the disc) x 55 channels. Measured in
the same run, median of ``--repeat``:

  evaluation   sky_radiance on the disc's directions, float32, a fresh output array (what render_sky
               asks of the evaluator);
  render_sky   the whole render: directions, mask and image (target: at most 1.3x the evaluation);
  command      ``widesky sky render --resolution 1000 -o sky.png`` in a fresh process, PNG and spectral EXR
               written (target: at most 2x the evaluation including the first decode, measured in a
               fresh process too: import, open, decode, evaluate);
  stages       the command's steps in a fresh process, each timed (wall and CPU): imports, open, decode,
               render_sky, PNG (sRGB composite, 8-bit encoding, zlib), EXR (half rounding, RLE), rename;
  EXR          write_exr alone for each pixel type and compression (time and size; "none" and "rle" by
               widesky's own encoder, the others by the OpenEXR library).

Wall-clock and CPU (user + system) times are both reported, medians and the ratio of the best runs
(evaluation and render_sky interleaved): on a shared machine the CPU times and best runs are the steadier
ratios. The render's image holds 4/pi times as many values as the disc's evaluation (zero outside).

    python benchmarks/bench_render.py [--repeat 5] [--resolution 1000] [--json out.json] [--no-exr-table]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

STATE = dict(sun_elevation=30.0, sun_azimuth=180.0, visibility=50.0, albedo=0.3)

EVAL_CHILD = r"""
import json, sys, time
t0 = time.perf_counter(); c0 = time.process_time()
import numpy as np
from widesky import skymodel
from widesky.skymodel.render import fisheye_disc
t1 = time.perf_counter()
m = skymodel.load_dataset()
d, _ = fisheye_disc(int(sys.argv[1]))
t2 = time.perf_counter()
skymodel.sky_radiance(m, d, 30.0, 180.0, 50.0, 0.3, dtype=np.float32)  # decodes on first use
t3 = time.perf_counter()
print(json.dumps({"import_s": t1 - t0, "decode_and_eval_s": t3 - t2, "cpu_s": time.process_time() - c0}))
"""


STAGES_CHILD = r"""
import json, os, sys, time
marks = [("start", time.perf_counter(), time.process_time())]
def mark(name):
    marks.append((name, time.perf_counter(), time.process_time()))
import numpy as np
from widesky import skymodel
from widesky.core.atomic import atomic_outputs
from widesky.skymodel.render import render_sky, write_exr, write_png
mark("imports")
m = skymodel.load_dataset()
mark("open")
m.radiance_coefficients()
mark("decode")
r = render_sky(m, resolution=int(sys.argv[1]))
mark("render_sky")
png = os.path.join(sys.argv[2], "stages.png")
with atomic_outputs(png, png[:-4] + ".exr") as (tp, te):
    write_png(tp, r, composite=True)
    mark("png")
    write_exr(te, r)
    mark("exr")
mark("rename")
print(json.dumps({b[0]: (b[1] - a[1], b[2] - a[2]) for a, b in zip(marks, marks[1:])}))
"""


def median(fn, repeat):
    wall, cpu = [], []
    for _ in range(repeat):
        c0, t0 = time.process_time(), time.perf_counter()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return float(np.median(wall)), float(np.median(cpu))


def child(cmd, env=None):
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime), out.stdout


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--resolution", type=int, default=1000)
    ap.add_argument("--json", default=None)
    ap.add_argument("--no-exr-table", action="store_true", help="skip timing write_exr for every pixel type and "
                                                                 "compression")
    args = ap.parse_args(argv)
    from widesky import skymodel
    from widesky.skymodel.render import fisheye_disc, render_sky, write_exr

    n = args.resolution
    m = skymodel.load_dataset().load()
    d, _ = fisheye_disc(n)
    res = {"resolution": n, "directions": int(d.shape[0]), "channels": m.n_channels, "cpu_count": os.cpu_count(),
           "load_average_before": os.getloadavg()[0]}
    # the command's evaluation sees every core (OpenMP); OPENBLAS_NUM_THREADS=1 only keeps BLAS from competing

    ev = lambda: skymodel.sky_radiance(m, d, **STATE, dtype=np.float32)  # noqa: E731
    rs = lambda: render_sky(m, **STATE, resolution=n)  # noqa: E731
    ev(), rs()  # warm-up
    runs = {"e": [], "r": []}
    for _ in range(2 * args.repeat):  # interleaved, so both see the same machine load
        for key, fn in (("e", ev), ("r", rs)):
            c0, t0 = time.process_time(), time.perf_counter()
            fn()
            runs[key].append((time.perf_counter() - t0, time.process_time() - c0))
    e, r = np.array(runs["e"]), np.array(runs["r"])
    res["evaluation_s"], res["evaluation_cpu_s"] = float(np.median(e[:, 0])), float(np.median(e[:, 1]))
    res["render_sky_s"], res["render_sky_cpu_s"] = float(np.median(r[:, 0])), float(np.median(r[:, 1]))
    res["render_over_evaluation"] = res["render_sky_s"] / res["evaluation_s"]
    res["render_over_evaluation_cpu"] = res["render_sky_cpu_s"] / res["evaluation_cpu_s"]
    res["render_over_evaluation_best"] = float(r[:, 0].min() / e[:, 0].min())
    res["render_over_evaluation_cpu_best"] = float(r[:, 1].min() / e[:, 1].min())

    with tempfile.TemporaryDirectory() as tmp:
        evals, cmds, fast, stages = [], [], [], []
        base = [sys.executable, "-m", "widesky.cli", "sky", "render", "--resolution", str(n)]
        for _ in range(max(3, args.repeat // 2)):
            w, c, out = child([sys.executable, "-c", EVAL_CHILD, str(n)])
            e = json.loads(out)
            evals.append((w, c, e["decode_and_eval_s"], e["import_s"]))
            w, c, _ = child(base + ["-o", str(Path(tmp) / "sky.png")])
            cmds.append((w, c))
            w, c, _ = child(base + ["--exr-compression", "none", "-o", str(Path(tmp) / "fast.png")])
            fast.append((w, c))
            stages.append(json.loads(child([sys.executable, "-c", STAGES_CHILD, str(n), tmp])[2]))
        res["stages"] = {k: [float(np.median([st[k][0] for st in stages])), float(np.median([st[k][1] for st in stages]))]
                         for k in stages[0]}
        evals, cmds, fast = np.array(evals), np.array(cmds), np.array(fast)
        res["command_none_wall_s"], res["command_none_cpu_s"] = float(np.median(fast[:, 0])), float(
            np.median(fast[:, 1]))
        res["eval_process_wall_s"], res["eval_process_cpu_s"] = float(np.median(evals[:, 0])), float(
            np.median(evals[:, 1]))
        res["decode_and_eval_s"] = float(np.median(evals[:, 2]))
        res["import_s"] = float(np.median(evals[:, 3]))
        res["command_wall_s"], res["command_cpu_s"] = float(np.median(cmds[:, 0])), float(np.median(cmds[:, 1]))
        res["command_over_decode_and_eval"] = res["command_wall_s"] / res["decode_and_eval_s"]
        res["command_over_eval_process"] = res["command_wall_s"] / res["eval_process_wall_s"]
        res["command_over_eval_process_cpu"] = res["command_cpu_s"] / res["eval_process_cpu_s"]
        res["exr_MB"] = (Path(tmp) / "sky.exr").stat().st_size / 1e6
        res["png_MB"] = (Path(tmp) / "sky.png").stat().st_size / 1e6

        r = rs()
        # the default EXR (half, RLE), one thread: widesky's encoder against the OpenEXR library's writer
        # (channel planes transposed in C, then OpenEXR's RLE), interleaved; CPU time is the steady figure
        from widesky.skymodel.render import _exr_channels, _write_exr_openexr
        names, src = _exr_channels(r)
        enc = {"widesky": [], "openexr": []}
        for _ in range(args.repeat):
            for key, fn in (("widesky", lambda: write_exr(Path(tmp) / "w.exr", r, threads=1)),
                            ("openexr", lambda: _write_exr_openexr(Path(tmp) / "o.exr", r, r.values, r._rgby, names,
                                                                   src, "auto", "rle", 1))):
                c0, t0 = time.process_time(), time.perf_counter()
                fn()
                enc[key].append((time.perf_counter() - t0, time.process_time() - c0))
        res["rle_1thread"] = {k: {"s": float(np.median(np.array(v)[:, 0])), "cpu_s": float(np.median(np.array(v)[:, 1])),
                                  "MB": (Path(tmp) / ("w.exr" if k == "widesky" else "o.exr")).stat().st_size / 1e6}
                              for k, v in enc.items()}
        exr = {}
        for pt in () if args.no_exr_table else ("half", "float"):
            for comp in ("none", "rle", "zip", "piz", "zstd"):
                p = Path(tmp) / f"{pt}_{comp}.exr"
                t, c = median(lambda: write_exr(p, r, pixel_type=pt, compression=comp), max(1, args.repeat // 2))
                exr[f"{pt}_{comp}"] = {"s": t, "MB": p.stat().st_size / 1e6}
        res["exr"] = exr

    print(f"{n}x{n} up-facing fisheye, {res['directions']} directions x {res['channels']} channels; load average "
          f"{res['load_average_before']:.2f} before the run")
    print(f"evaluation (sky_radiance, float32, fresh output): {res['evaluation_s']:.3f} s  (CPU {res['evaluation_cpu_s']:.3f} s)")
    print(f"render_sky:                                       {res['render_sky_s']:.3f} s  (CPU {res['render_sky_cpu_s']:.3f} s)"
          f"  -> {res['render_over_evaluation']:.2f}x the evaluation (CPU {res['render_over_evaluation_cpu']:.2f}x; "
          f"best runs {res['render_over_evaluation_best']:.2f}x, CPU {res['render_over_evaluation_cpu_best']:.2f}x)")
    print(f"fresh process: import {res['import_s']:.3f} s, decode + evaluation {res['decode_and_eval_s']:.3f} s, whole "
          f"process {res['eval_process_wall_s']:.3f} s (CPU {res['eval_process_cpu_s']:.3f} s)")
    print(f"command `widesky sky render --resolution {n} -o sky.png`: {res['command_wall_s']:.3f} s (CPU "
          f"{res['command_cpu_s']:.3f} s) -> {res['command_over_decode_and_eval']:.2f}x decode + evaluation, "
          f"{res['command_over_eval_process']:.2f}x the evaluation process (CPU {res['command_over_eval_process_cpu']:.2f}x); "
          f"EXR {res['exr_MB']:.1f} MB, PNG {res['png_MB']:.2f} MB")
    print(f"  with --exr-compression none: {res['command_none_wall_s']:.3f} s (CPU {res['command_none_cpu_s']:.3f} s) -> "
          f"{res['command_none_wall_s'] / res['decode_and_eval_s']:.2f}x decode + evaluation")
    w, o = res["rle_1thread"]["widesky"], res["rle_1thread"]["openexr"]
    print(f"default EXR (half, RLE), one thread: widesky's encoder {w['s']:.3f} s (CPU {w['cpu_s']:.3f} s, {w['MB']:.1f} MB), "
          f"the OpenEXR library {o['s']:.3f} s (CPU {o['cpu_s']:.3f} s, {o['MB']:.1f} MB): {o['cpu_s'] / w['cpu_s']:.1f}x "
          f"the CPU time")
    print("stages of the command in a fresh process (median wall s, CPU s): " + ", ".join(
        f"{k} {w:.3f} / {c:.3f}" for k, (w, c) in res["stages"].items()))
    for k, v in res["exr"].items():
        print(f"  write_exr {k:11s} {v['s']:.3f} s  {v['MB']:7.1f} MB")
    res["load_average_after"] = os.getloadavg()[0]
    print(f"load average after the run {res['load_average_after']:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))
    return res


if __name__ == "__main__":
    main()
