"""Benchmark: opening a SWIR-sized (about 550 MB) dataset and loading only what a run needs.

Writes (once, into a cache directory, with the project's own synthetic writer) a file with the layout of
a large dataset: 10 visibilities x 3 albedos x 45 elevations x 55 channels, radiance rank 12 with
90/90/60 knots, polarisation rank 8 with 45/45 knots. Then measures, each in a fresh process so
resident memory is attributable:
  read      read the whole file into memory (what any loader must at least do)
  ref       the baseline: the project's C port of the reference loader (``_core.reference_load``: the loop
            of the public reference C++ ``PragueSkyModel::initialize`` ported to C: stdio fread segment
            by segment, each half converted on its own through a double into zero-filled float32
            vectors, one thread; the reference binary itself is not installed here)
  open      load_dataset(path): memory-map and validate the header
  state     load_dataset(path, visibility=50, albedo=0.3, elevation=33).load(): one sky state's selection
  one vis   load_dataset(path, visibility=50).load(): the two bracketing visibility slabs
  all1      load_dataset(path).load() on one thread (OMP_NUM_THREADS=1): decode everything
  all       the same with the default threads (every core)
the time (best of the rounds, every step once per round so the decode and its baseline see the same load;
wall clock and CPU time, the steadier figure on a shared machine), the growth of
the resident set (VmRSS) and its peak (VmHWM) over the start, against the decoded size (target: peak at
most 1.1x the decoded size plus a fixed margin).

    python benchmarks/bench_open.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

CHILD = r"""
import sys, time, json
import numpy as np
def status(key):
    for line in open("/proc/self/status"):
        if line.startswith(key + ":"):
            return int(line.split()[1]) * 1024
from widesky import skymodel
path, mode = sys.argv[1], sys.argv[2]
before = status("VmRSS")
open("/proc/self/clear_refs", "w").write("5")  # reset VmHWM to the current RSS
t0 = time.perf_counter()
c0 = time.process_time()
resident = 0
if mode == "read":
    data = open(path, "rb").read()
    resident = len(data)
elif mode == "ref":  # the project's C port of the reference loader (one thread)
    from widesky.skymodel import _core
    vectors = _core.reference_load(path)
    resident = sum(len(v) for v in vectors if v is not None)
elif mode == "open":
    m = skymodel.load_dataset(path)
elif mode == "state":
    m = skymodel.load_dataset(path, visibility=50.0, albedo=0.3, elevation=33.0).load()
elif mode == "onevis":
    m = skymodel.load_dataset(path, visibility=50.0).load()
else:
    m = skymodel.load_dataset(path).load()
dt = time.perf_counter() - t0
cpu = time.process_time() - c0
if mode not in ("read", "ref"):
    resident = m.resident_bytes
print(json.dumps({"seconds": dt, "cpu_seconds": cpu, "rss_growth_MB": (status("VmRSS") - before) / 1e6,
                  "peak_growth_MB": (status("VmHWM") - before) / 1e6, "resident_MB": resident / 1e6}))
"""


def big_dataset(cache: Path) -> Path:
    """Write one visibility slab of a synthetic model, then assemble the 10-visibility file by repeating
    its sections (visibility is the outermost index of every section)."""
    path = cache / "bench_swir_sized.dat"
    if path.exists():
        return path
    from widesky import skymodel
    from widesky.skymodel.synthetic import synthetic_contents
    from widesky.skymodel.writer import write_dataset

    nvis = 10
    vis = np.linspace(20, 131.8, nvis)
    elev = np.concatenate([[-4.2, -2.0, 0.0], np.geomspace(0.5, 90.0, 42)])
    c = synthetic_contents(visibilities=vis[:1], albedos=(0, 0.5, 1), elevations=elev, n_channels=55, rank=12,
                           n_sun=90, n_zen=90, n_emph=60, polarisation=True, pol_rank=8, n_pol_sun=45,
                           n_pol_zen=45, seed=7)
    small = cache / "bench_swir_one_vis.dat"
    write_dataset(small, c)
    m = skymodel.load_dataset(small)
    lay = m._layout
    b = small.read_bytes()
    v_off, u_off = m._trans_v_off, m._trans_u_off
    with open(path, "wb") as f:
        f.write(np.int32(nvis).tobytes() + np.asarray(vis, "<f8").tobytes())
        f.write(b[12:lay.rad_offset])                        # the rest of the radiance metadata
        f.write(b[lay.rad_offset:lay.trans_offset] * nvis)   # radiance blocks
        t = b[lay.trans_offset:]
        f.write(t[:8] + np.int32(nvis).tobytes() + t[12:20])  # dDim, aDim, nVisT, nAltT, rankT
        f.write(b[lay.trans_offset + 20:lay.trans_offset + 20 + 4 * m._n_alt_t])
        f.write(np.asarray(vis, "<f4").tobytes())
        f.write(b[u_off:v_off])                              # U
        f.write(b[v_off:lay.pol_offset] * nvis)              # V
        hdr_end = m._pol_blocks_offset
        f.write(b[lay.pol_offset:hdr_end])
        f.write(b[hdr_end:] * nvis)                          # polarisation blocks
    del m
    small.unlink()
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    cache = Path(os.environ.get("WIDESKY_BENCH_CACHE", tempfile.gettempdir()))
    t0 = time.perf_counter()
    path = big_dataset(cache)
    print(f"dataset {path} ({path.stat().st_size / 1e6:.0f} MB, written/reused in {time.perf_counter() - t0:.1f} s)")
    res = {"file_MB": path.stat().st_size / 1e6, "load_average_before": os.getloadavg()[0]}

    def child(mode):
        env = dict(os.environ, OMP_NUM_THREADS="1") if mode in ("all1", "ref") else None
        out = subprocess.run([sys.executable, "-c", CHILD, str(path), mode], capture_output=True, text=True,
                             check=True, env=env)
        return json.loads(out.stdout)

    modes = ("read", "open", "state", "onevis", "ref", "all1", "all")
    runs = {m: [] for m in modes}
    for _ in range(args.repeat):  # rounds over every mode, so the decode and its baseline see the same load
        for mode in modes:
            runs[mode].append(child(mode))
    for mode in modes:
        best = dict(min(runs[mode], key=lambda r: r["seconds"]))
        best["cpu_seconds"] = min(r["cpu_seconds"] for r in runs[mode])
        best["median_seconds"] = float(np.median([r["seconds"] for r in runs[mode]]))
        best["median_cpu_seconds"] = float(np.median([r["cpu_seconds"] for r in runs[mode]]))
        res[mode] = best
        ratio = best["peak_growth_MB"] / best["resident_MB"] if best["resident_MB"] else float("nan")
        print(f"{mode:7s} {best['seconds'] * 1e3:9.1f} ms (CPU {best['cpu_seconds'] * 1e3:7.1f} ms; medians "
              f"{best['median_seconds'] * 1e3:.0f} / {best['median_cpu_seconds'] * 1e3:.0f} ms)   RSS growth "
              f"{best['rss_growth_MB']:7.1f} MB   peak growth {best['peak_growth_MB']:7.1f} MB   decoded "
              f"{best['resident_MB']:7.1f} MB   peak/decoded {ratio:5.2f}")
    for mode, what in (("all1", "one thread"), ("all", "default threads")):
        r = {k: res[mode][k] / res["ref"][k] for k in ("seconds", "cpu_seconds", "median_seconds",
                                                          "median_cpu_seconds")}
        res[f"{mode}_over_ref"] = r
        print(f"decoding everything ({what}) against the project's C port of the reference loader: "
              f"{r['cpu_seconds']:.2f}x its CPU time (medians {r['median_cpu_seconds']:.2f}x), {r['seconds']:.2f}x "
              f"its wall time (medians {r['median_seconds']:.2f}x)")
    res["all_peak_over_ref_peak"] = res["all"]["peak_growth_MB"] / res["ref"]["peak_growth_MB"]
    res["load_average_after"] = os.getloadavg()[0]
    res["all_over_read_time"] = res["all"]["seconds"] / res["read"]["seconds"]
    res["all_over_read_cpu"] = res["all"]["cpu_seconds"] / res["read"]["cpu_seconds"]
    print(f"decoding everything takes {res['all_over_read_time']:.2f}x the time of reading the file (CPU time "
          f"{res['all_over_read_cpu']:.2f}x); peak "
          f"{res['all']['peak_growth_MB'] - res['all']['resident_MB']:.1f} MB above the decoded size, "
          f"{res['all_peak_over_ref_peak']:.2f}x the reference port's peak")
    print(f"load average {res['load_average_before']:.2f} before, {res['load_average_after']:.2f} after")
    return res


if __name__ == "__main__":
    main()
