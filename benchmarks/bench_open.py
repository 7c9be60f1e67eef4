"""Benchmark: opening a SWIR-sized (about 550 MB) dataset and loading only what a run needs.

Writes (once, into a cache directory, with the project's own synthetic writer) a file with the layout of
a large dataset: 10 visibilities x 3 albedos x 45 elevations x 55 channels, radiance rank 12 with
90/90/60 knots, polarisation rank 8 with 45/45 knots. Then measures, each in a fresh process so
resident memory is attributable:
  read      read the whole file into memory (what the reference's loader must at least do: it reads
            every block with fread before converting it)
  refconv   baseline for the decoding time: read the whole file and convert as many of its halves as
            the full decode keeps float32 values, each on its own (``_core.reference_halves``: a scalar
            decoder of the sign, exponent and mantissa fields, one thread, as the reference's initialize
            converts each value; the reference itself is not installed here). A lower bound of the
            reference's load: it skips the block parsing and the zenith scale division, and its output
            array takes as many fresh pages as the decoded arrays
  open      load_dataset(path): memory-map and validate the header
  state     load_dataset(path, visibility=50, albedo=0.3, elevation=33).load(): one sky state's selection
  one vis   load_dataset(path, visibility=50).load(): the two bracketing visibility slabs
  all       load_dataset(path).load(): decode everything
the time (best of 3; wall clock and CPU time, the steadier figure on a shared machine), the growth of
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
elif mode == "refconv":  # read + as many halves converted on their own into float32 as the decode keeps
    from widesky.skymodel import _core
    data = open(path, "rb").read()
    raw = np.frombuffer(data, np.uint16, count=min(len(data) // 2, int(sys.argv[3])))
    out = np.empty(raw.size, np.float32)
    _core.reference_halves(raw, out)
    resident = out.nbytes
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
if mode not in ("read", "refconv"):
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

    def child(mode, n_values=0):
        out = subprocess.run([sys.executable, "-c", CHILD, str(path), mode, str(n_values)], capture_output=True,
                             text=True, check=True)
        return json.loads(out.stdout)

    n_values = int(round(child("all")["resident_MB"] * 1e6 / 4))
    modes = ("read", "open", "state", "onevis", "all", "refconv")
    runs = {m: [] for m in modes}
    for _ in range(args.repeat):  # rounds over every mode, so the decode and its baseline see the same load
        for mode in modes:
            runs[mode].append(child(mode, n_values))
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
    res["all_over_refconv_time"] = res["all"]["seconds"] / res["refconv"]["seconds"]
    res["all_over_refconv_cpu"] = res["all"]["cpu_seconds"] / res["refconv"]["cpu_seconds"]
    res["all_over_refconv_median_time"] = res["all"]["median_seconds"] / res["refconv"]["median_seconds"]
    print(f"decoding everything takes {res['all_over_refconv_time']:.2f}x the time of the baseline (read + as many "
          f"halves converted on their own, one thread; medians {res['all_over_refconv_median_time']:.2f}x; CPU time "
          f"{res['all_over_refconv_cpu']:.2f}x)")
    res["all_over_read_time"] = res["all"]["seconds"] / res["read"]["seconds"]
    res["all_over_read_cpu"] = res["all"]["cpu_seconds"] / res["read"]["cpu_seconds"]
    print(f"decoding everything takes {res['all_over_read_time']:.2f}x the time of reading the file (CPU time "
          f"{res['all_over_read_cpu']:.2f}x); peak "
          f"{res['all']['peak_growth_MB'] - res['all']['resident_MB']:.1f} MB above the decoded size")
    return res


if __name__ == "__main__":
    main()
