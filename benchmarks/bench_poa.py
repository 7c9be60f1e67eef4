"""Benchmark: per-face POA irradiance for a 20,000-face scene over an hourly year (issue 6).

Scene: rows of PV modules (analysis), a building whose facades and roof are analysed, neighbouring
buildings and trees as context. Sky: the Prague Sky Model (embedded default dataset, or a synthetic
PSM-format dataset written to a temporary file when none is installed), 55 channels contracted to three
responses (broadband, a c-Si-like cell response, a glazing-like transmittance). Hourly clear-sky year
at 50 N, 14.4 E (Prague), solar positions by irradiance.solarposition (NREL SPA).

Baseline, same run: ray casting the sky anew for every hour (what per-hour ray tracers do) on a few
daylight hours, scaled to the year's daylight hours; the ratio is reported.

Run: python benchmarks/bench_poa.py [--faces 20000] [--jobs 2] [--baseline-hours 3] [--dask N]
     [--mf M --rays-per-patch K --radiance-samples K]  (default: IntegratorSettings())

The headline figure is faces x hours per second (the period's hours, daylight or not, per second of wall time,
end to end); ``--dask N`` casts the rays on a local Dask cluster of N worker processes through
``RunOptions(executor=client.get_executor())`` (no other change; the check sum is printed to compare).

Faces x hours per second and memory against the face count (issue 36)::

     python benchmarks/bench_poa.py --scaling 20000,100000,200000,1000000 [--pieces 2] [--max-file-gb 9] [--reduce]

runs each size in its own process (peak resident memory of that process: ``ru_maxrss``), streamed to an HDF5 file
(``WIDESKY_TMPDIR`` or the system's temporary folder, removed after), in blocks of faces
(``RunOptions(face_block=...)``, default the automatic blocks); a size whose whole file would exceed
``--max-file-gb`` runs only its first ``--pieces`` blocks of faces (the whole scene built and ray-cast against, the
rest of the faces not computed: "in pieces"), and its time is extrapolated per face, said so. Prints faces x hours
per second, CPU per face (the main process; the ray casting: its descendants'), peak RSS, and the
exponent of CPU against faces fitted over the sizes; see :func:`scaling`. ``--reduce`` runs each size reduce-only
(``OutputOptions(arrays=False, angles=False, consumer=FaceSums(...))``: per-face annual sums of the three
responses' three parts and global [kWh m-2], no (T, F) output; "in pieces" by the same file-size rule).

The per-step sky cost (issue 36): ``--sky-steps [--repeat 2] [--baseline-core PATH]`` times the sky stage alone
against a per-state baseline (see :func:`sky_steps`).

Memory and time against today's code path (issue 17):

     python benchmarks/bench_poa.py --compare [--baseline-commit 46f5284] [--repeat 1]

runs, each in its own process (so that peak resident memory is the process's own: ru_maxrss of
the main process; the ray-casting workers are separate processes, reported apart), alternating:
``today`` (the integrator at ``--baseline-commit``, extracted with ``git archive``: totals and the
weighted responses held in memory), ``streamed`` (this code: 3 responses x 3 parts + aoi + sun
visibility streamed to an HDF5 file) and ``optics`` (the same with a Fresnel cover IAM on the c-Si
response and an angle x wavelength glazing table). Time is reported as the ratio to ``today`` in
the same run.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np
import pandas as pd
import trimesh

from widesky.irradiance.integrator import IntegratorSettings


def grid_plane(nx, ny, size_x, size_y):
    """A rectangle of nx x ny quads (2 nx ny triangles), normal +z, centred at the origin."""
    xs, ys = np.linspace(-size_x / 2, size_x / 2, nx + 1), np.linspace(-size_y / 2, size_y / 2, ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    v = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    idx = np.arange(v.shape[0]).reshape(nx + 1, ny + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    f = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return trimesh.Trimesh(v, f, process=False)


def gridded_cube(size, per_side):
    """A cube standing on z=0 whose roof and four facades are gridded (outward normals), no floor."""
    parts = []
    for normal in ((0, 0, 1), (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0)):
        m = grid_plane(per_side, per_side, size, size)
        rot = trimesh.geometry.align_vectors([0, 0, 1], normal)
        m.apply_transform(rot)
        m.apply_translation(np.asarray(normal, dtype=float) * size / 2)
        parts.append(m)
    cube = trimesh.util.concatenate(parts)
    cube.apply_translation((0, 0, size / 2))
    return cube


def benchmark_scene(n_faces=20000):
    """(analysis meshes, group names, context meshes) with about ``n_faces`` analysis triangles."""
    n_rows = 8
    building_faces = n_faces // 5                          # 5 gridded faces of the building
    per_side = max(2, int(np.sqrt(building_faces / 10)))   # 5 faces x per_side^2 x 2 triangles
    module_faces = n_faces - 10 * per_side ** 2
    cells = module_faces // (2 * n_rows)
    ny = 4
    nx = max(1, cells // ny)
    rows = []
    for i in range(n_rows):
        m = grid_plane(nx, ny, 60.0, 4.0)
        # tilt 25 deg to the south: a positive rotation about +x (east) turns the normal +z towards -y
        # (south); before 2026-12-01 the sign was negative and the rows faced north (azimuth 0)
        rot = trimesh.transformations.rotation_matrix(np.radians(25.0), [1, 0, 0])
        m.apply_transform(rot)
        m.apply_translation((0.0, -40.0 - 9.0 * i, 1.9))
        rows.append(m)
    building = gridded_cube(16.0, per_side)
    building.apply_translation((0.0, 20.0, 0.0))
    context = []
    rng = np.random.default_rng(1)
    for j in range(6):
        b = trimesh.creation.box(extents=(15.0, 15.0, rng.uniform(8, 25)))
        b.apply_translation((rng.uniform(-120, 120), rng.uniform(40, 120), b.extents[2] / 2))
        context.append(b)
    for j in range(12):
        t = trimesh.creation.icosphere(subdivisions=2, radius=rng.uniform(2, 4))
        t.apply_translation((rng.uniform(-60, 60), rng.uniform(-5, 10), 6.0))
        context.append(t)
    analysis = [trimesh.util.concatenate(rows), building]
    return analysis, ["pv_rows", "building"], [trimesh.util.concatenate(context)]


def sky_source(path=None):
    """The PSM (a dataset file, the default dataset, else a synthetic dataset in a temporary file)."""
    from widesky import skymodel
    from widesky.irradiance.skies import PragueSky
    if path:
        m = skymodel.load_dataset(path)
        return PragueSky(m), f"dataset {path}{' (synthetic)' if m.is_synthetic else ''}"
    try:
        m = skymodel.load_dataset()
        return PragueSky(m), f"default dataset{' (synthetic)' if m.is_synthetic else ''}"
    except Exception:
        from widesky.skymodel.synthetic import write_synthetic_dataset
        path = os.path.join(tempfile.mkdtemp(), "synthetic.dat")
        write_synthetic_dataset(path)
        return PragueSky(skymodel.load_dataset(path)), "synthetic dataset"


def responses(wl):
    """Three responses: broadband (implicit), c-Si-like SR [A W-1] (below q lambda / (h c) everywhere) and a
    glazing-like transmittance [1]."""
    csi = 0.65 * np.clip((wl - 300.0) / 800.0, 0, 1) * (wl < 1180)
    glazing = 0.85 * np.exp(-0.5 * ((wl - 650.0) / 600.0) ** 2)
    return {"c-Si": csi, "glazing": glazing}


def fresnel_cover(aoi, n=1.526, K=4.0, L=0.002):
    """Transmittance of a glass cover relative to normal incidence [1] at ``aoi`` [deg]: Fresnel
    reflection of unpolarised light at both polarisations and Beer absorption along the refracted
    path (De Soto et al. 2006's cover model, written from the physics)."""
    th = np.radians(np.clip(np.asarray(aoi, dtype=float), 0.0, 89.999))

    def tau(t):
        tr = np.arcsin(np.sin(t) / n)
        with np.errstate(invalid="ignore", divide="ignore"):
            rs = (np.sin(tr - t) / np.sin(tr + t)) ** 2
            rp = (np.tan(tr - t) / np.tan(tr + t)) ** 2
        r0 = ((n - 1) / (n + 1)) ** 2
        rs = np.where(t < 1e-9, r0, rs)
        rp = np.where(t < 1e-9, r0, rp)
        return np.exp(-K * L / np.cos(tr)) * (1 - 0.5 * (rs + rp))

    out = tau(th) / tau(np.zeros(1))
    return np.where(np.asarray(aoi) >= 90.0, 0.0, out)


def glazing_table():
    """An angle x wavelength transmittance of 4 mm clear glass [1]: Fresnel at n = 1.52 with a
    wavelength-dependent absorption coefficient (an iron-oxide-like band near 1000 nm and the UV
    edge), 0-90 deg by 5 deg, 280-2480 nm by 20 nm (an illustrative table, not a product's)."""
    from widesky.irradiance import SpectralAngularTable
    ang = np.arange(0.0, 90.1, 5.0)
    wl = np.arange(280.0, 2480.1, 20.0)
    K = 20.0 + 120.0 * np.exp(-0.5 * ((wl - 1000.0) / 250.0) ** 2) + 4000.0 * np.exp(-(wl - 280.0) / 25.0)
    tab = np.stack([fresnel_cover(ang, n=1.52, K=k, L=0.004) * np.exp(-k * 0.004) for k in K], 1)
    return SpectralAngularTable(ang, wl, tab)


def response_objects(wl, optics):
    """The two responses of :func:`responses` as Response objects; with ``optics`` a Fresnel cover
    on c-Si and the angle x wavelength glazing table."""
    from widesky.irradiance import Response
    r = responses(wl)
    return [Response("c-Si", wl, r["c-Si"], unit="sr", angular=fresnel_cover if optics else None),
            Response("glazing", wl, r["glazing"] if not optics else np.ones_like(wl),
                     unit="transmittance", angular=glazing_table() if optics else None)]


def year_states(year=2023, lat=50.08, lon=14.42, visibility=40.0, albedo=0.2, states_type=None):
    from widesky.irradiance.skies import SkyStates
    from widesky.irradiance.solarposition import solar_position
    SkyStates = states_type or SkyStates
    times = pd.date_range(f"{year}-01-01 00:30", f"{year}-12-31 23:30", freq="1h", tz="Etc/GMT-1")
    sp = solar_position(times, lat, lon)
    st = SkyStates.create(sp["apparent_elevation"].to_numpy(), sp["azimuth"].to_numpy(),
                          visibility, albedo)
    return times, st


def _worker(mode, faces, jobs, output):
    """One timed run in this process; prints a JSON line (seconds, peak RSS)."""
    import json
    import resource
    import importlib
    base = os.environ.get("BENCH_POA_BASELINE")
    if base:                  # the baseline package, under its own name (the editable install
        sys.path.insert(0, base)          # resolves "irradiance.*" to this worktree)
    pkg = "irradiance_baseline" if base else "irradiance"
    make_scene = importlib.import_module(pkg + ".scene").make_scene
    skies = importlib.import_module(pkg + ".skies")
    if base and not skies.__file__.startswith(base):
        raise SystemExit(f"baseline not loaded: {skies.__file__}")
    analysis, groups, context = benchmark_scene(faces)
    scene = make_scene(analysis, context, groups=groups, ground_z=0.0)
    times, states = year_states(states_type=skies.SkyStates)
    from widesky import skymodel
    sky = skies.PragueSky(skymodel.load_dataset())
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    ru0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.perf_counter()
    if mode == "today":
        poa_irradiance = importlib.import_module(pkg + ".integrator").poa_irradiance
        res = poa_irradiance(scene, sky, states, responses=responses(sky.wavelengths),
                             times=times, n_jobs=jobs)    # the baseline commit's keywords
    else:
        from widesky.irradiance import OutputOptions, RunOptions, poa_irradiance
        res = poa_irradiance(scene, sky, states, responses=response_objects(sky.wavelengths, mode == "optics"),
                             times=times, run=RunOptions(n_jobs=jobs), output=OutputOptions(path=output))
    sec = time.perf_counter() - t0
    ru1 = resource.getrusage(resource.RUSAGE_SELF)
    if mode == "today":
        total = float(res.poa_global.sum(dtype=np.float64))
    else:                                    # the check sum after the timing, by blocks of steps
        total = float(sum(res.get("broadband", "global", steps=slice(a, a + 512)).sum(
            dtype=np.float64) for a in range(0, res.n_steps, 512)))
    ruc = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_main = (ru1.ru_utime + ru1.ru_stime) - (ru0.ru_utime + ru0.ru_stime)
    cpu_workers = ruc.ru_utime + ruc.ru_stime
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    size = os.path.getsize(output) if output and os.path.exists(output) else 0
    print("RESULT " + json.dumps({"mode": mode, "seconds": sec, "cpu_main": cpu_main,
                                  "cpu_workers": cpu_workers, "peak_rss_mb": rss / 1024,
                                  "rss_before_run_mb": rss0 / 1024, "worker_peak_rss_mb": kids / 1024,
                                  "file_mb": size / 2 ** 20, "sum_poa_global": total,
                                  "timings": {k: v for k, v in res.timings.items()
                                              if isinstance(v, (int, float))}}))
    return 0


class _DescendantCPU:
    """CPU time [s] of this process's descendants (the ray-casting pool's workers are the fork server's children,
    which this process never reaps, so ``RUSAGE_CHILDREN`` misses them): polled every 0.5 s with psutil, the
    last value seen per process (up to 0.5 s of a worker's last moments can be missed)."""

    def __init__(self):
        import threading
        import psutil
        self.me, self.seen = psutil.Process(), {}
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while not self.stop.wait(0.5):
            self.poll()

    def poll(self):
        import psutil
        for c in self.me.children(recursive=True):
            try:
                t = c.cpu_times()
                self.seen[c.pid] = t.user + t.system
            except psutil.Error:
                pass

    def total(self):
        self.poll()
        self.stop.set()
        self.thread.join()
        return float(sum(self.seen.values()))


def _scale_worker(faces, jobs, output, pieces, face_block, reduce=False):
    """One size of ``--scaling`` in this process: prints a JSON line. ``reduce``: a reduce-only run (per-face
    annual sums of every response's parts, :class:`widesky.irradiance.sink.FaceSums`; no (T, F) output)."""
    import dataclasses
    import json
    import resource
    from widesky.irradiance import OutputOptions, RunOptions, poa_irradiance
    from widesky.irradiance import poa as poamod
    from widesky.irradiance.scene import make_scene
    t_a = time.perf_counter()
    analysis, groups, context = benchmark_scene(faces)
    scene = make_scene(analysis, context, groups=groups, ground_z=0.0)
    times, states = year_states()
    sky, _ = sky_source(None)
    resp = responses(sky.wavelengths)
    t_setup = time.perf_counter() - t_a
    plans = []
    real_plan = poamod.output_plan

    def first_pieces(*a, **kw):              # only the first `pieces` blocks of faces (the rest not computed)
        plan = real_plan(*a, **kw)
        plans.append(plan)
        if pieces and len(plan.face_blocks) > pieces:
            plan = dataclasses.replace(plan, face_blocks=plan.face_blocks[:pieces])
        return plan

    poamod.output_plan = first_pieces
    real_sky, sky_cpu = poamod.evaluate_sky, []

    def timed_sky(*a, **kw):                 # the sky stage's CPU time (this process, all its threads)
        c = time.process_time()
        out = real_sky(*a, **kw)
        sky_cpu.append(time.process_time() - c)
        return out

    poamod.evaluate_sky = timed_sky
    from widesky.irradiance import sink as sinkmod
    real_flush, flush_cpu = sinkmod.Sink.flush, [0.0]

    def timed_flush(self, *a, **kw):         # writing the output blocks to the file (CPU of this process)
        c = time.process_time()
        real_flush(self, *a, **kw)
        flush_cpu[0] += time.process_time() - c

    sinkmod.Sink.flush = timed_flush
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    ru0 = resource.getrusage(resource.RUSAGE_SELF)
    load0 = os.getloadavg()[0]
    kids = _DescendantCPU()
    t0 = time.perf_counter()
    if reduce:
        from widesky.irradiance.sink import FaceSums
        sums = FaceSums(scene.n_faces)                     # hourly steps
        out_opt = OutputOptions(angles=False, arrays=False, consumer=sums)
    else:
        out_opt = OutputOptions(path=output)
    res = poa_irradiance(scene, sky, states, responses=resp, times=times,
                         run=RunOptions(n_jobs=jobs, face_block=face_block), output=out_opt)
    sec = time.perf_counter() - t0
    ru1 = resource.getrusage(resource.RUSAGE_SELF)
    cpu_rays = kids.total()
    blocks = plans[0].face_blocks
    done = sum(b - a for a, b in blocks[:pieces or None])
    tm = res.timings
    size = os.path.getsize(output) if os.path.exists(output) else 0
    res.close()
    print("RESULT " + json.dumps({
        "faces": scene.n_faces, "faces_done": done, "blocks": len(blocks),
        "blocks_done": len(blocks[:pieces or None]), "block_faces": blocks[0][1] - blocks[0][0],
        "hours": len(states), "lit": tm["lit_steps"], "seconds": sec, "setup_s": t_setup,
        "cpu_main": (ru1.ru_utime + ru1.ru_stime) - (ru0.ru_utime + ru0.ru_stime), "cpu_rays": cpu_rays,
        "peak_rss_mb": ru1.ru_maxrss / 1024, "rss_before_run_mb": rss0 / 1024, "file_gb": size / 1e9,
        "sky_s": tm["sky"], "sky_cpu": sky_cpu[0], "write_cpu": flush_cpu[0], "product_s": tm["product"],
        "rays_s": tm["rays"], "rays_wait_s": tm["rays_wait"], "n_rays": tm["n_rays"], "load_before": load0,
        "reduce": bool(reduce), "consumer_s": tm.get("consumer", 0.0),
        "load_after": os.getloadavg()[0]}), flush=True)
    return 0


def scaling(args):
    """Faces x hours per second, CPU per face and peak memory from 20k to 1M faces (issue 36), each size in its own
    process; sizes too large for the disk in pieces (see the module docstring). CPU of the ray casting: that of
    the process's descendants (its pools' workers and their fork server, :class:`_DescendantCPU`). Projection to
    ``--cores`` cores: the ray casting's CPU spread over cores - 1 worker processes, the main process's products
    and file writing as measured (one process), the larger of the two plus the sky stage."""
    import json
    import subprocess
    sizes = [int(x) for x in args.scaling.split(",")]
    work = tempfile.mkdtemp(prefix="bench_poa_scaling_", dir=os.environ.get("WIDESKY_TMPDIR") or None)
    print(f"load average before: {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores; {args.jobs} "
          f"ray-casting processes; output streamed to {work}")
    rows = []
    for F in sizes:
        per_face_file = 8760 * 4 * 11                      # 3 responses x 3 parts + aoi + sun visibility, float32
        pieces = 0 if F * per_face_file <= args.max_file_gb * 1e9 else args.pieces
        out = os.path.join(work, f"f{F}.h5")
        cmd = [sys.executable, os.path.abspath(__file__), "--scale-worker", "--faces", str(F), "--jobs",
               str(args.jobs), "--worker-output", out, "--pieces", str(pieces)]
        if args.face_block:
            cmd += ["--face-block", str(args.face_block)]
        if args.reduce:
            cmd += ["--reduce"]
        env = dict(os.environ, OPENBLAS_NUM_THREADS=str(args.blas_threads))
        p = subprocess.run(cmd, capture_output=True, text=True, cwd=work, env=env)
        if os.path.exists(out):
            os.unlink(out)
        line = [x for x in p.stdout.splitlines() if x.startswith("RESULT ")]
        if p.returncode or not line:
            print(p.stdout[-2000:], p.stderr[-4000:])
            raise SystemExit(f"{F} faces: run failed")
        r = json.loads(line[-1][7:])
        rows.append(r)
        print("  " + json.dumps({k: (round(v, 3) if isinstance(v, float) else v) for k, v in r.items()}), flush=True)
    print()
    print("| faces | computed | blocks of faces | wall | **faces x hours / s** | CPU per face: rays / products / "
          "file | sky CPU | peak RSS (before the run) | load |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        F, d = r["faces"], r["faces_done"]
        fhs = d * r["hours"] / r["seconds"]
        part = "all" if d == F else f"first {r['blocks_done']} of {r['blocks']} ({d:,})"
        print(f"| {F:,} | {part} | {r['blocks']} x {r['block_faces']:,} | {r['seconds']:.1f} s | "
              f"**{fhs / 1e6:.2f} M** | {1e3 * r['cpu_rays'] / d:.2f} / "
              f"{1e3 * (r['cpu_main'] - r['sky_cpu'] - r['write_cpu']) / d:.2f} / {1e3 * r['write_cpu'] / d:.2f} ms | "
              f"{r['sky_cpu']:.1f} s | "
              f"{r['peak_rss_mb']:,.0f} MB ({r['rss_before_run_mb']:,.0f}) | "
              f"{r['load_before']:.1f}-{r['load_after']:.1f} |")
    if len(rows) > 1:
        x = np.log([r["faces"] for r in rows])
        for key, v in (("ray casting", lambda r: r["cpu_rays"]),
                       ("products", lambda r: r["cpu_main"] - r["sky_cpu"] - r["write_cpu"]),
                       *(() if rows[-1].get("reduce") else (("file writing", lambda r: r["write_cpu"]),)),
                       ("all", lambda r: r["cpu_rays"] + r["cpu_main"] - r["sky_cpu"])):
            y = np.log([v(r) / r["faces_done"] * r["faces"] for r in rows])
            print(f"exponent of the {key} CPU (whole scene: per-face CPU x faces) against faces: "
                  f"{np.polyfit(x, y, 1)[0]:.2f}")
    big = rows[-1]
    F, d, n = big["faces"], big["faces_done"], args.cores
    rays = big["cpu_rays"] / d * F
    write = big["write_cpu"] / d * F
    main_f = (big["cpu_main"] - big["sky_cpu"]) / d * F
    for label, m in ((("reduce-only: per-face annual sums, no (T, F) output (OutputOptions(arrays=False, "
                       "angles=False, consumer=FaceSums))", main_f),) if big.get("reduce") else
                     (("with the file", main_f), ("without the file writing (a projection only)", main_f - write))):
        wall = max(rays / max(n - 1, 1), m) + big["sky_cpu"]
        print(f"projection, {F:,} faces x {big['hours']} h on {n} cores, {label}: rays {rays:,.0f} s CPU -> "
              f"{rays / (n - 1):,.0f} s on {n - 1} worker processes; main process {m:,.0f} s CPU beside them; sky "
              f"{big['sky_cpu']:.1f} s CPU: about {wall / 60:.1f} min ({F * big['hours'] / wall / 1e6:.1f} M faces x "
              f"hours / s)")
    print(f"load average after: {os.getloadavg()[0]:.1f}")
    os.rmdir(work)
    return 0


def compare(args):
    """Run today / streamed / optics in separate processes, alternating; print RSS and time ratios."""
    import json
    import subprocess
    here = os.path.dirname(os.path.abspath(__file__))
    repo = os.path.dirname(here)
    work = tempfile.mkdtemp(prefix="bench_poa_")
    base = os.path.join(work, "baseline")
    os.makedirs(base)
    arch = subprocess.run(["git", "-C", repo, "archive", args.baseline_commit, "irradiance"],
                          check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", base], input=arch, check=True)
    os.rename(os.path.join(base, "irradiance"), os.path.join(base, "irradiance_baseline"))
    runs = []
    for rep in range(args.repeat):
        for mode in args.modes.split(","):
            env = dict(os.environ)
            env.pop("BENCH_POA_BASELINE", None)
            if mode == "today":
                env["BENCH_POA_BASELINE"] = base
            out = os.path.join(work, f"{mode}.h5")
            cmd = [sys.executable, os.path.abspath(__file__), "--worker", mode, "--faces",
                   str(args.faces), "--jobs", str(args.jobs), "--worker-output", out]
            load = os.getloadavg()[0]
            p = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=work)
            line = [x for x in p.stdout.splitlines() if x.startswith("RESULT ")]
            if p.returncode or not line:
                print(p.stdout[-2000:], p.stderr[-4000:])
                raise SystemExit(f"{mode} run failed")
            r = json.loads(line[-1][7:])
            r["load"] = load
            runs.append(r)
            cpu = (f", CPU main {r['cpu_main']:.1f} s + workers {r['cpu_workers']:.1f} s"
                   if "cpu_main" in r else "")
            print(f"  {mode:9s} {r['seconds']:7.1f} s wall{cpu}, peak RSS main {r['peak_rss_mb']:7.0f} MB "
                  f"(before the run {r['rss_before_run_mb']:.0f} MB), workers {r['worker_peak_rss_mb']:.0f} MB, "
                  f"file {r['file_mb']:.0f} MB, load {load:.1f}", flush=True)
            if os.path.exists(out):
                os.unlink(out)
    modes = [m for m in ("today", "streamed", "optics") if any(r["mode"] == m for r in runs)]
    t = {m: [r["seconds"] for r in runs if r["mode"] == m] for m in modes}
    if "today" not in t:
        return 0
    t.setdefault("streamed", t["today"])
    t.setdefault("optics", t["today"])
    m = {k: max([r["peak_rss_mb"] for r in runs if r["mode"] == k] or [np.nan]) for k in t}
    sums = {k: ([r["sum_poa_global"] for r in runs if r["mode"] == k] or [np.nan])[0] for k in t}
    print(f"wall-time ratio streamed / today = {np.median(t['streamed']) / np.median(t['today']):.2f} "
          f"(medians of {args.repeat}), optics / today = "
          f"{np.median(t['optics']) / np.median(t['today']):.2f}")
    c = {m: [r["cpu_main"] + r["cpu_workers"] for r in runs if r["mode"] == m] or [np.nan]
         for m in t}
    cm = {m: [r["cpu_main"] for r in runs if r["mode"] == m] or [np.nan] for m in t}
    print(f"main-process CPU ratio streamed / today = "
          f"{np.median(cm['streamed']) / np.median(cm['today']):.2f}")
    print(f"CPU-time ratio (main + workers; robust on a shared machine) streamed / today = "
          f"{np.median(c['streamed']) / np.median(c['today']):.2f}, optics / today = "
          f"{np.median(c['optics']) / np.median(c['today']):.2f}")
    print(f"peak RSS of the main process [MB]: today {m['today']:.0f}, streamed {m['streamed']:.0f}, "
          f"optics {m['optics']:.0f}")
    print(f"broadband poa_global sums agree: streamed / today - 1 = "
          f"{sums['streamed'] / sums['today'] - 1:.2e} (the new runs scale by 1/r^2 of the "
          f"Earth-Sun distance, today's do not: the annual mean of 1/r^2 is about 1.0001)")
    return 0


class PerStateSky:
    """Baseline sky source for ``--sky-steps``: the Prague Sky Model evaluated as before issue 36, one
    ``skymodel.sky_radiance`` call per distinct sky state (elevation rounded as PragueSky rounds it, visibility,
    albedo, altitude; steps that differ only in sun azimuth share a call, their directions rotated about the
    zenith), i.e. a per-state table precompute of about 5-7 ms, then every sample direction; the sun's
    spectrum by one ``solar_direct_normal`` call per step. Same values as :class:`PragueSky` (to float32
    rounding), none of its per-configuration tables."""

    def __init__(self, sky):
        self.sky = sky

    def __getattr__(self, name):          # everything else from the wrapped PragueSky, but not its new paths
        if name in ("radiance_means", "state_order", "sky") or name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.sky, name)

    def radiance(self, directions, states):
        d = np.asarray(directions, dtype=float)
        q = self.elevation_quantum
        el = np.round(states.sun_elevation / q) * q if q > 0 else states.sun_elevation
        return self.sky._radiance_per_state(d, el, states)       # PragueSky's per-state path (images use it)

    def direct_normal(self, states):
        from widesky import skymodel
        dni = skymodel.solar_direct_normal(self.model, states.sun_elevation, states.sun_azimuth, states.visibility,
                                           states.albedo, states.altitude, channels=self.channels,
                                           threads=self.threads)
        dni = np.asarray(dni, dtype=float).reshape(len(states), self.n_channels)
        return np.where((states.sun_elevation > 0)[:, None], dni, 0.0)


def sky_steps(args):
    """The per-step sky cost (issue 36): the sky stage of ``poa_irradiance`` alone (the sky of every daylight hour
    of a year, contracted to the benchmark's responses) with :class:`PerStateSky` (baseline) and ``PragueSky``,
    interleaved, CPU time; for the clear-sky year of this benchmark and the Denver TMY3 year under the all-sky
    model (the default weather path), and the largest difference of the contracted patch radiance. The baseline
    evaluates each all-sky chunk (256 steps) whole, as before issue 36; the candidate in cache-sized blocks.

    The baseline's per-state calls run on today's C kernels, which other work makes faster too. ``--baseline-core
    PATH`` runs them on another build of ``skymodel/_core.c`` instead (a ``_core*.so`` built from the commit before
    issue 36, e.g. ``git show 36fa688:skymodel/_core.c``; functions it lacks come from today's), so that the ratio
    is against the per-step cost as it was."""
    from widesky.irradiance import poa as poamod
    from widesky.irradiance.scene import make_scene
    from widesky.irradiance.simulation import SKY_DEFAULTS, Simulation
    from widesky.irradiance import allsky_sky
    from widesky.irradiance.sky_chunks import evaluate_sky
    block_bytes = allsky_sky._BLOCK_BYTES
    analysis, groups, context = benchmark_scene(200)
    scene = make_scene(analysis, context, groups=groups, ground_z=0.0)
    cases = []
    times, states = year_states()
    sky, which = sky_source(args.dataset)
    cases.append(("clear-sky year (Prague, this benchmark's states)", sky, states, None))
    for model in ("allsky", "clear"):
        sim = Simulation(scene, weather="data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw",
                         sky=SKY_DEFAULTS.replace(spectral_model=model, dataset=args.dataset), n_jobs=1)
        a = sim.integrator_arguments()
        name = ("Denver TMY3, all-sky model (the default weather path)" if model == "allsky" else
                "Denver TMY3, clear-sky spectra scaled to measured DNI/DHI")
        cases.append((name, sim.sky_source, a["states"], a["weather"]))
    from widesky.skymodel import evaluate as sm_eval
    today_core = base_core = sm_eval._core
    if getattr(args, "baseline_core", None):
        import importlib.machinery
        import importlib.util
        loader = importlib.machinery.ExtensionFileLoader("_core", args.baseline_core)
        other = importlib.util.module_from_spec(importlib.util.spec_from_loader("_core", loader))
        loader.exec_module(other)

        class _Core:                                  # the other build's kernels, today's where it has none
            def __getattr__(self, name):
                return getattr(other, name) if hasattr(other, name) else getattr(today_core, name)
        base_core = _Core()
    print(f"load average before: {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores; CPU time of this "
          f"process (one thread), {args.repeat} interleaved rounds, best round; baseline's C kernels: "
          f"{getattr(args, 'baseline_core', None) or 'today'}")
    print("| sky stage | baseline: per-state precompute [ms/step] | per-configuration tables [ms/step] | "
          "ratio | largest difference |")
    print("|---|---|---|---|---|")
    for name, sky, st, weather in cases:
        sky.model.radiance_coefficients()
        base = PerStateSky(sky)
        resp = responses(sky.wavelengths)
        cols = poamod.sky_columns(scene, sky, resp, False, None)
        best, terms = {}, {}
        for rep in range(args.repeat):
            for label, src in (("base", base), ("new", sky)):
                if label == "new":
                    sky._radiance_tables = None          # each round builds its tables anew
                    sky.model.__dict__.pop("_radiance_tables", None)
                scaling = poamod.step_scaling(weather or poamod.MeasuredSky(), st, src, scene.ground_albedo)
                W = cols.Wall if scaling.ground_shape is None else cols.with_ground_shape(scaling.ground_shape).Wall
                plan = poamod.output_plan(scene, src, st, IntegratorSettings(), cols.resp, poamod.OutputOptions())
                # the baseline evaluates each all-sky chunk whole, as before (issue 36: in cache-sized blocks)
                allsky_sky._BLOCK_BYTES = 1 << 40 if label == "base" else block_bytes
                sm_eval._core = base_core if label == "base" else today_core
                c0 = time.process_time()
                terms[label] = evaluate_sky(src, st, IntegratorSettings(), W, scaling, plan.lit)
                c = time.process_time() - c0
                sm_eval._core = today_core
                allsky_sky._BLOCK_BYTES = block_bytes
                best[label] = min(best.get(label, np.inf), c / plan.lit.size)
        a, b = terms["base"].Lp.astype(float), terms["new"].Lp.astype(float)
        diff = (np.abs(a - b) / np.maximum(np.abs(a).max(axis=1, keepdims=True), 1e-30)).max()
        print(f"| {name}, {plan.lit.size} daylight hours | {1e3 * best['base']:.2f} | {1e3 * best['new']:.3f} | "
              f"**{best['base'] / best['new']:.1f}x** | {diff:.1e} of the step's largest patch radiance |",
              flush=True)
    print(f"load average after: {os.getloadavg()[0]:.1f}")
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compare", action="store_true",
                    help="memory and time against today's code path (see the module docstring)")
    ap.add_argument("--baseline-commit", default="46f5284")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--modes", default="today,streamed,optics",
                    help="comma-separated subset of today, streamed, optics")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--worker-output", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--faces", type=int, default=20000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--baseline-hours", type=int, default=3)
    ap.add_argument("--dataset", default=None, help="PSM dataset file (default: the embedded one)")
    ap.add_argument("--dask", type=int, default=0,
                    help="cast the rays on a local Dask cluster of this many worker processes (RunOptions(executor=...))")
    ap.add_argument("--scaling", default=None,
                    help="comma-separated face counts: faces x hours per second and memory against faces (see scaling)")
    ap.add_argument("--pieces", type=int, default=2, help="blocks of faces computed where the whole file is too large")
    ap.add_argument("--max-file-gb", type=float, default=9.0, help="largest result file written whole [GB]")
    ap.add_argument("--face-block", type=int, default=None, help="RunOptions(face_block=...) (default automatic)")
    ap.add_argument("--cores", type=int, default=16, help="cores of the node the scaling run is projected to")
    ap.add_argument("--blas-threads", type=int, default=1,
                    help="OPENBLAS_NUM_THREADS of the --scaling runs (1: the cores are busy casting rays)")
    ap.add_argument("--scale-worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--reduce", action="store_true",
                    help="--scaling: reduce-only runs (per-face annual sums of every part, no (T, F) output)")
    ap.add_argument("--sky-steps", action="store_true",
                    help="the per-step sky cost against the per-state baseline (see sky_steps)")
    ap.add_argument("--baseline-core", default=None,
                    help="--sky-steps: a _core*.so built from another commit for the baseline's kernels")
    ap.add_argument("--mf", type=int, default=None, help="override IntegratorSettings.mf")
    ap.add_argument("--rays-per-patch", type=int, default=None, help="override rays_per_patch")
    ap.add_argument("--radiance-samples", type=int, default=None, help="override radiance_samples")
    args = ap.parse_args(argv)
    if args.worker:
        return _worker(args.worker, args.faces, args.jobs, args.worker_output)
    if args.scale_worker:
        return _scale_worker(args.faces, args.jobs, args.worker_output, args.pieces, args.face_block, args.reduce)
    if args.scaling:
        return scaling(args)
    if args.compare:
        return compare(args)
    if args.sky_steps:
        return sky_steps(args)
    from widesky.irradiance.integrator import IntegratorSettings
    from widesky.irradiance.poa import RunOptions, poa_irradiance
    from widesky.irradiance.scene import make_scene

    t0 = time.perf_counter()
    analysis, groups, context = benchmark_scene(args.faces)
    scene = make_scene(analysis, context, groups=groups, ground_z=0.0)
    times, states = year_states()
    sky, which = sky_source(args.dataset)
    resp = responses(sky.wavelengths)
    over = {k: v for k, v in (("mf", args.mf), ("rays_per_patch", args.rays_per_patch),
                               ("radiance_samples", args.radiance_samples)) if v is not None}
    settings = IntegratorSettings(**over)
    t_setup = time.perf_counter() - t0
    print(f"scene: {scene.n_faces} analysis faces, {scene.triangles.shape[0]} triangles; "
          f"{len(states)} hourly steps; sky: PSM {which}, {sky.n_channels} channels -> "
          f"{1 + len(resp)} responses; settings {settings}")
    print(f"load average before the run: {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores")
    import resource
    cluster = client = None
    run = RunOptions(n_jobs=args.jobs, progress=sys.stderr.isatty())
    if args.dask:                 # the same run on a local multi-process Dask cluster: no code change
        import distributed
        cluster = distributed.LocalCluster(n_workers=args.dask, threads_per_worker=1, processes=True,
                                           host="127.0.0.1", dashboard_address=None, silence_logs=50)
        client = distributed.Client(cluster)
        run = RunOptions(executor=client.get_executor(), progress=sys.stderr.isatty())
    ru0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.perf_counter()
    res = poa_irradiance(scene, sky, states, responses=resp, settings=settings, times=times, run=run)
    t_total = time.perf_counter() - t0
    ru1 = resource.getrusage(resource.RUSAGE_SELF)
    if client is not None:
        client.close()
        cluster.close()
    tm = res.timings
    n_lit = tm["lit_steps"]
    cpu_main = (ru1.ru_utime + ru1.ru_stime) - (ru0.ru_utime + ru0.ru_stime)
    print(f"end to end: {t_total:.1f} s (+ {t_setup:.1f} s building the scene and solar positions); "
          f"CPU of this process {cpu_main:.1f} s; peak RSS of this process {ru1.ru_maxrss / 1024:.0f} MB"
          f"{'; ray casting on a local Dask cluster of %d worker processes' % args.dask if args.dask else ''}")
    print(f"**headline: {scene.n_faces * len(states) / t_total / 1e6:.2f} M faces x hours per second** "
          f"({scene.n_faces} faces x {len(states)} hours of the period in {t_total:.1f} s wall; "
          f"{scene.n_faces * n_lit / t_total / 1e6:.2f} M faces x daylight hours per second)")
    print(f"  check sum of broadband poa_global: {float(sum(res.get('broadband', 'global', steps=slice(a, a + 512)).sum(dtype=np.float64) for a in range(0, res.n_steps, 512))):.6e} W m-2")
    print(f"  ray casting: {tm['rays']:.1f} s wall, {tm['n_rays'] / 1e6:.1f} M rays "
          f"({tm['sun_bins']} sun-position bins), {tm['n_rays'] / tm['rays'] / 1e6:.2f} M rays/s on "
          f"{args.jobs} processes (this process evaluated the sky meanwhile)")
    print(f"  sky patch radiance: {tm['sky']:.1f} s for {n_lit} lit steps "
          f"({1e3 * tm['sky'] / max(n_lit, 1):.2f} ms/step), {tm['sky_during_rays']:.1f} s of it "
          f"during the ray casting")
    print(f"  products: {tm['product']:.1f} s "
          f"({scene.n_faces * n_lit / max(tm['product'], 1e-9) / 1e6:.1f} M face-steps/s)")
    agg = res.aggregate()
    kwh = agg["poa_global"].sum(axis=0) / 1000.0   # hourly steps: W m-2 x 1 h
    print("  annual POA global per group [kWh m-2]: " +
          ", ".join(f"{g} {v:.0f}" for g, v in zip(res.group_names, kwh)))

    if args.baseline_hours <= 0:
        print(f"load average after: {os.getloadavg()[0]:.1f}")
        return 0
    # baseline: the sky ray-cast anew for every hour, a few daylight hours, scaled
    lit = np.nonzero(states.sun_elevation > 5)[0]
    pick = lit[np.linspace(0, lit.size - 1, args.baseline_hours).astype(int)]
    t0 = time.perf_counter()
    for t in pick:
        poa_irradiance(scene, sky, states.take([t]), responses=resp, settings=settings,
                       run=RunOptions(n_jobs=args.jobs))
    t_hour = (time.perf_counter() - t0) / pick.size
    t_base = t_hour * n_lit
    print(f"baseline (sky ray-cast anew per hour): {t_hour:.2f} s/hour x {n_lit} lit hours = "
          f"{t_base:.0f} s; ratio baseline / daylight-coefficient method = {t_base / t_total:.1f}x")
    print(f"load average after: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
