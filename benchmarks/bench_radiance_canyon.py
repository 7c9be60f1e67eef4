"""A street canyon under a measured year: widesky per face group and part (issue 39's canyon scene).

An east-west street canyon between two long blocks (street ``W`` wide, blocks ``H`` high and ``D`` deep,
``L`` long), the Denver TMY3 year (shipped), a grey ground of albedo 0.2 (the scene's, not the file's), facades
0.3, roofs 0.2. Sensor patches (analysis
groups) in the middle of the blocks, the rest of the blocks context:

* ``canyon_facing_south`` (the north block's street facade), ``canyon_facing_north`` (the south block's, in shade
  most of the day), ``open_south`` / ``open_north`` (the blocks' outer facades), ``roof`` (the north block's).

Prints the annual irradiation [kWh m-2] per group and part (direct, sky, reflected, global).
:func:`canyon_scene` is the reusable scene builder (issue 36 times this benchmark): it returns the widesky
scene and the quads (vertices, normal side, material) for another tool.

Radiance cross-check (``--radiance WORKDIR``; pyradiance 1.3.1, an optional benchmark dependency that ships the
Radiance binaries, ``pip install pyradiance==1.3.1``; skipped with that reason where it is absent): daylight
coefficients of the same sensor points over Reinhart MF 4 (rfluxmtx for the sky, rcontrib over suns at the patch
centres for the sun, 5-phase style) times gendaymtx's Perez all-weather sky and sun matrices of the same EPW
(:func:`radiance_canyon`). Pitfalls met on the way (and those the issue noted): rcontrib's ``-fd`` also sets the
*input* to binary, so ascii rays need ``-fad``; rcontrib writes coefficients per unit source radiance (no division
by the light's radiance); a glow of radius 0 is reached only by the ambient calculation, so the sky's direct view
is ``-ab 1`` and one reflection ``-ab 2``, the sun's direct ``-ab 0`` and one reflection ``-ab 1``; gendaymtx's
``-c`` comes before ``-d``/``-s``; a numpy product of the matrices replaces the single-threaded dctimestep.

Issue 36 times both codes on the same canyon refined to about ``--faces`` sensor faces (``--faces 1000`` and
``--faces 10000``), one run each: CPU time of each (widesky: this process plus its pool workers, sampled with
psutil, since the forkserver's workers are not our children; Radiance: ``resource.getrusage(RUSAGE_CHILDREN)``
around each command, plus the numpy products) and wall time, then the per-group agreement; ``--json FILE`` keeps
both codes' results, per-face annual values and timings, and ``--table FILE ...`` prints the docs' table from
such files. ``--five-phase`` gives Radiance's usual lean annual method: the sun's direct light from suns at the
patch centres (rcontrib ``-ab 0``), everything else from the sky daylight coefficients (``-ab bounces + 1``)
times the sky matrix with the sun put into its patches, minus the sun patches' direct view (``-ab 1``); without
it the sun's reflections are traced to each of the 2,305 suns (issue 39's converged reference, about 1.6 s CPU
per point at one bounce). The five-phase subtraction is what limits Radiance's per-face precision here: the
sun patches' direct view comes from two independent sample sets (measured: 10 % rms per face at ``-ad 256``,
2.0 % at 4,096, about 1 % at 16,384 and 65,536).

``--global-only``: widesky keeps what Radiance's side produces, the hourly global per face (no parts, aoi nor sun
visibility: ``OutputOptions(parts={"broadband": ("global",)}, angles=False)``, the fused product; per face equal to
the three parts' sum within float32 rounding). ``--radiance-from SAVED.json``: Radiance's results and times from
an earlier ``--json`` run of the same scene (its faces and groups are checked) instead of running it again (14 min
CPU at 10,000 faces); the JSON and the table say so. Time with ``OPENBLAS_NUM_THREADS=1``: OpenBLAS's default
threads spin-wait on this 2-core machine and add seconds of CPU to widesky's products.

Usage:  python benchmarks/bench_radiance_canyon.py [--faces 90] [--stride N] [--tolerance 0.02] [--jobs N]
        [--global-only] [--radiance WORKDIR [--bounces 5] [--ad 4096] [--five-phase] | --radiance-from SAVED.json]
        [--json FILE]
        python benchmarks/bench_radiance_canyon.py --table FILE [FILE ...]
"""

from __future__ import annotations

import argparse
import math
import resource
import time

import numpy as np
import trimesh

GROUPS = ("canyon_facing_south", "canyon_facing_north", "open_south", "open_north", "roof")


def _quad(p0, p1, p2, p3):
    """Two triangles of the quad p0 p1 p2 p3 (counter-clockwise seen from the side its normal points to)."""
    return trimesh.Trimesh(np.array([p0, p1, p2, p3], dtype=float), [[0, 1, 2], [0, 2, 3]], process=False)


def _grid(origin, u, v, nu, nv):
    """The parallelogram origin + [0, 1] u + [0, 1] v as nu x nv quads, normal u x v."""
    o, u, v = (np.asarray(a, dtype=float) for a in (origin, u, v))
    quads = [_quad(o + i / nu * u + j / nv * v, o + (i + 1) / nu * u + j / nv * v,
                   o + (i + 1) / nu * u + (j + 1) / nv * v, o + i / nu * u + (j + 1) / nv * v)
             for i in range(nu) for j in range(nv)]
    return trimesh.util.concatenate(quads)


def canyon_scene(street=12.0, height=12.0, depth=12.0, length=96.0, sensor=12.0, facade_rho=0.3, roof_rho=0.2,
                 ground_albedo=0.2, subdivide=3, samples_per_face=1):
    """The canyon scene.

    Parameters
    ----------
    street, height, depth, length : float
        Street width, block height, block depth, block length [m] (the street runs east-west along x).
    sensor : float
        Length [m] of the sensor patches along the blocks (centred).
    facade_rho, roof_rho, ground_albedo : float
        Diffuse reflectances [1].
    subdivide : int
        Sensor faces per side of a sensor patch (``subdivide x subdivide`` quads).

    Returns
    -------
    dict
        ``scene`` (:class:`widesky.irradiance.Scene`, groups :data:`GROUPS`), ``analysis`` and ``context``
        (lists of trimesh meshes), ``reflectance`` (per analysis mesh, per context mesh) and ``quads``
        [(trimesh, material name)] of every surface (analysis first), for another tool.
    """
    from widesky.irradiance.scene import make_scene
    W, H, D, L, S = street, height, depth, length, sensor
    x0, x1, s0, s1 = -L / 2, L / 2, -S / 2, S / 2
    ys_in, ys_out, yn_in, yn_out = -W / 2, -W / 2 - D, W / 2, W / 2 + D    # south / north block faces
    n = subdivide
    # facades facing south (normal -y): origin at the west end, u along +x, v up -> u x v = -y
    def facing_south(y, xa, xb):
        return _grid((xa, y, 0.0), (xb - xa, 0, 0), (0, 0, H), n if xb - xa == S else 1, n if xb - xa == S else 1)

    def facing_north(y, xa, xb):
        return _grid((xb, y, 0.0), (xa - xb, 0, 0), (0, 0, H), n if xb - xa == S else 1, n if xb - xa == S else 1)

    def roof(ya, yb, xa, xb):
        return _grid((xa, ya, H), (xb - xa, 0, 0), (0, yb - ya, 0), n if xb - xa == S else 1, n if xb - xa == S else 1)

    analysis = [facing_south(yn_in, s0, s1), facing_north(ys_in, s0, s1), facing_south(ys_out, s0, s1),
                facing_north(yn_out, s0, s1), roof(yn_in, yn_out, s0, s1)]
    a_rho = [facade_rho, facade_rho, facade_rho, facade_rho, roof_rho]
    context, c_rho = [], []
    for xa, xb in ((x0, s0), (s1, x1)):
        context += [facing_south(yn_in, xa, xb), facing_north(ys_in, xa, xb), facing_south(ys_out, xa, xb),
                    facing_north(yn_out, xa, xb)]
        c_rho += [facade_rho] * 4
        context += [roof(yn_in, yn_out, xa, xb), roof(ys_out, ys_in, xa, xb)]
        c_rho += [roof_rho] * 2
    context.append(roof(ys_out, ys_in, s0, s1))                        # the south block's roof, middle
    c_rho.append(roof_rho)
    for x, sgn in ((x0, -1), (x1, 1)):                                 # the blocks' end walls
        for ya, yb in ((ys_out, ys_in), (yn_in, yn_out)):
            if sgn > 0:
                context.append(_grid((x, ya, 0.0), (0, yb - ya, 0), (0, 0, H), 1, 1))
            else:
                context.append(_grid((x, yb, 0.0), (0, ya - yb, 0), (0, 0, H), 1, 1))
            c_rho.append(facade_rho)
    scene = make_scene(analysis, context, groups=list(GROUPS), analysis_reflectance=a_rho,
                       context_reflectance=c_rho, ground_z=0.0, ground_albedo=ground_albedo,
                       samples_per_face=samples_per_face)
    quads = [(m, "roof" if r == roof_rho and m is analysis[-1] else "facade") for m, r in zip(analysis, a_rho)]
    quads += [(m, "facade" if r == facade_rho else "roof") for m, r in zip(context, c_rho)]
    return {"scene": scene, "analysis": analysis, "context": context, "reflectance": (a_rho, c_rho),
            "quads": quads, "ground_albedo": ground_albedo}


def widesky_canyon(built, weather="data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw", tolerance=0.02, jobs=None,
                   stride=1, per_face=None, global_only=False):
    """Annual irradiation [kWh m-2] per group and part: dict group -> dict part -> value; and the run's seconds
    (dict ``wall``, ``cpu``: this process's and its descendants' CPU time, worker pools included). ``per_face``:
    a dict that receives each sensor face's annual irradiation per part [kWh m-2]. ``global_only``: keep what
    Radiance's side keeps, the hourly global per face only (``OutputOptions(parts={"broadband": ("global",)},
    angles=False)``: the fused product, no parts, aoi nor sun visibility; global within float32 rounding)."""
    from widesky.irradiance import OutputOptions, poa_irradiance
    from widesky.irradiance.integrator import IntegratorSettings
    from widesky.irradiance.simulation import Simulation
    scene = built["scene"]
    sim = Simulation(scene, weather=weather, settings=IntegratorSettings.for_tolerance(tolerance), n_jobs=jobs)
    steps = None if stride == 1 else slice(None, None, stride)
    parts = ("global",) if global_only else ("direct", "sky_diffuse", "ground_diffuse", "global")
    with _DescendantCPU() as clock:
        if global_only:
            res = poa_irradiance(scene, sim.sky_source, **sim.integrator_arguments(steps),
                                 output=OutputOptions(parts={"broadband": ("global",)}, angles=False))
        else:
            res = sim.run(steps=steps)
    secs = clock.seconds
    area = scene.face_area
    out = {}
    for g, name in enumerate(GROUPS):
        m = scene.face_group == g
        a = area[m] / area[m].sum()
        out[name] = {p: float(np.sum(getattr(res, f"poa_{p}")[:, m] @ a)) * stride / 1000.0 for p in parts}
    if per_face is not None:
        per_face.update({p: np.asarray(getattr(res, f"poa_{p}"), dtype=float).sum(0) * stride / 1000.0
                         for p in parts})
    return out, secs


def _cpu():
    """CPU seconds of this process (all threads) plus its finished, waited-for children (worker pools, Radiance)."""
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + ch.ru_utime + ch.ru_stime


class _DescendantCPU:
    """Wall and CPU seconds of a block: this process plus every descendant (a forkserver's pool workers are not
    our children, so ``RUSAGE_CHILDREN`` misses them; a thread samples their cumulative CPU every 0.1 s, the
    last sample before a worker exits counts: at most 0.1 s lost per worker)."""

    def __enter__(self):
        import threading
        import psutil
        self._me, self._seen, self._stop = psutil.Process(), {}, threading.Event()
        self._known = {p.pid for p in self._me.children(recursive=True)}
        self._t0, self._c0 = time.perf_counter(), _cpu()
        self._thread = threading.Thread(target=self._sample, daemon=True)
        self._thread.start()
        return self

    def _sample(self):
        import psutil
        while not self._stop.wait(0.1):
            for p in self._me.children(recursive=True):
                if p.pid in self._known:
                    continue
                try:
                    t = p.cpu_times()
                    self._seen[(p.pid, p.create_time())] = (t.user + t.system, p.ppid(), p)
                except psutil.Error:
                    pass

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        wall = time.perf_counter() - self._t0
        mine = _cpu() - self._c0            # this process and the children it reaped: not sampled again
        pid = self._me.pid
        others = sum(c for c, ppid, p in self._seen.values() if not (ppid == pid and not p.is_running()))
        self.seconds = {"wall": wall, "cpu": mine + others}
        return False


def subdivision_for(faces):
    """``canyon_scene``'s ``subdivide`` for about ``faces`` sensor faces (5 patches x n x n quads x 2 triangles)."""
    return max(1, round(math.sqrt(faces / 10.0)))


def _radiance_env():
    """PATH and RAYPATH for the Radiance binaries pyradiance ships; None where pyradiance is absent."""
    import os
    try:
        import pyradiance
    except ImportError:
        return None
    root = os.path.dirname(pyradiance.__file__)
    env = dict(os.environ)
    env["PATH"] = os.path.join(root, "bin") + os.pathsep + env.get("PATH", "")
    env["RAYPATH"] = os.pathsep.join([".", os.path.join(root, "lib")])
    return env


def _read_matrix(data):
    """A Radiance matrix (header, then binary doubles) as (NROWS, NCOLS, NCOMP)."""
    head, _, body = data.partition(b"\n\n")
    info = dict(line.split("=", 1) for line in head.decode(errors="replace").splitlines() if "=" in line)
    rows, cols, comp = (int(info[k].strip()) for k in ("NROWS", "NCOLS", "NCOMP"))
    return np.frombuffer(body, dtype="<f8", count=rows * cols * comp).reshape(rows, cols, comp)


def radiance_canyon(built, epw, workdir, mf=4, bounces=5, ad=4096, lw=1e-4, five_phase=False, per_face=None):
    """Radiance daylight coefficients of the same scene and weather: annual [kWh m-2] per group and part.

    Sky: rfluxmtx (Reinhart MF ``mf`` + ground glow) x gendaymtx's Perez all-weather sky (``-O1`` broadband
    radiance, ground glow 0: the ground is a 10 km polygon of the scene's albedo). Sun: rcontrib over suns at the
    Reinhart patch centres (radius 0.533 deg, 5-phase style) x gendaymtx ``-5 0.533 -d``. ``direct + sky`` from
    the runs without reflections (sun ``-ab 0``, sky ``-ab 1``: a glow with radius 0 is seen through the ambient
    calculation only), reflected light = converged (``bounces`` more) minus those. ``five_phase``: the sun's
    reflections from the sky coefficients (``-ab bounces + 1`` minus ``-ab 1``) times gendaymtx's sun-only patch
    matrix (``-d``) instead of rcontrib ``-ab bounces`` over the 2,305 suns.

    Returns the dict group -> part -> value and the timings: a list of (step, wall [s], CPU [s]) per Radiance
    command and matrix product. ``per_face``: a dict that receives each sensor face's annual global (``global``).
    """
    import subprocess
    from pathlib import Path
    env = _radiance_env()
    if env is None:
        raise RuntimeError("pyradiance is not installed (pip install pyradiance==1.3.1)")
    wd = Path(workdir)
    wd.mkdir(parents=True, exist_ok=True)

    timings = []

    def run(cmd, stdin=None, out=None, label=None):
        t0, c0 = time.perf_counter(), _cpu()
        r = subprocess.run(cmd, input=stdin, capture_output=True, env=env, cwd=wd, check=False)
        timings.append((label or cmd[0], time.perf_counter() - t0, _cpu() - c0))
        if r.returncode != 0:
            raise RuntimeError(f"{cmd[0]} failed: {r.stderr.decode(errors='replace')[-400:]}")
        if out is not None:
            (wd / out).write_bytes(r.stdout)
        return r.stdout

    a_rho, c_rho = built["reflectance"]
    lines = [f"void plastic mat_{i} 0 0 5 {r:g} {r:g} {r:g} 0 0" for i, r in enumerate(list(a_rho) + list(c_rho))]
    for i, m in enumerate(list(built["analysis"]) + list(built["context"])):
        for j, t in enumerate(m.vertices[m.faces]):
            lines.append(f"mat_{i} polygon s{i}_{j} 0 0 9 " + " ".join(f"{x:.6f}" for x in t.ravel()))
    g, R = built["ground_albedo"], 5000.0
    lines.append(f"void plastic ground_mat 0 0 5 {g:g} {g:g} {g:g} 0 0")
    lines.append(f"ground_mat polygon ground 0 0 12 {-R} {-R} 0 {R} {-R} 0 {R} {R} 0 {-R} {R} 0")
    (wd / "scene.rad").write_text("\n".join(lines) + "\n")
    (wd / "sky.rad").write_text("#@rfluxmtx h=u u=Y\nvoid glow groundglow 0 0 4 1 1 1 0\n"
                                "groundglow source ground 0 0 4 0 0 -1 180\n"
                                f"#@rfluxmtx h=r{mf} u=Y\nvoid glow skyglow 0 0 4 1 1 1 0\n"
                                "skyglow source skydome 0 0 4 0 0 1 180\n")
    sc = built["scene"]
    pts = sc.points + sc.origin + 0.01 * sc.point_normal
    rays = "".join(f"{p[0]:.5f} {p[1]:.5f} {p[2]:.5f} {n[0]:.6f} {n[1]:.6f} {n[2]:.6f}\n"
                   for p, n in zip(pts, sc.point_normal)).encode()
    N = pts.shape[0]
    run(["oconv", "scene.rad"], out="scene.oct")
    n_sun = int(run(["rcalc", "-n", "-e", f"MF:{mf}", "-f", "reinsrc.cal", "-e", "$1=Rmax"]).split()[0])
    suns = run(["rcalc", "-e", f"MF:{mf}", "-f", "reinsrc.cal", "-e", "Rbin=recno",
                "-o", "solar source sun 0 0 4 ${Dx} ${Dy} ${Dz} 0.533"], stdin=b"\n".join([b"1"] * n_sun) + b"\n")
    (wd / "suns.rad").write_bytes(b"void light solar 0 0 3 1e6 1e6 1e6\n" + suns)
    run(["oconv", "scene.rad", "suns.rad"], out="sun.oct")
    common = ["-ad", str(ad), "-lw", str(lw), "-aa", "0"]
    dc = {}
    for ab in (1, bounces + 1):
        out = run(["rfluxmtx", "-I+", "-y", str(N), "-ab", str(ab), *common, "-fad", "-", "sky.rad", "-i",
                   "scene.oct"], stdin=rays, label=f"rfluxmtx sky -ab {ab}")
        dc[("sky", ab)] = _read_matrix(out)[..., 0]
    for ab in (0,) if five_phase else (0, bounces):
        out = run(["rcontrib", "-I+", "-y", str(N), "-ab", str(ab), *common, "-dc", "1", "-dt", "0", "-dj", "0", "-st", "1",
                   "-ss", "0", "-e", f"MF:{mf}", "-f", "reinhart.cal", "-b", "rbin", "-bn", "Nrbins",
                   "-m", "solar", "-fad", "sun.oct"], stdin=rays, label=f"rcontrib suns -ab {ab}")
        dc[("sun", ab)] = _read_matrix(out)[..., 0]              # coefficients: per unit source radiance
    run(["epw2wea", str(epw), "year.wea"])
    sky = _read_matrix(run(["gendaymtx", "-O1", "-m", str(mf), "-g", "0", "0", "0", "-c", "1", "1", "1", "-s",
                            "-od", "year.wea"], label="gendaymtx sky"))[..., 0]
    sun = _read_matrix(run(["gendaymtx", "-O1", "-m", str(mf), "-5", "0.533", "-c", "1", "1", "1", "-d",
                            "-od", "year.wea"], label="gendaymtx suns"))[..., 0]
    if five_phase:                                               # the sun in its patches, ground glow 0
        sun_patch = _read_matrix(run(["gendaymtx", "-O1", "-m", str(mf), "-g", "0", "0", "0", "-c", "1", "1", "1",
                                      "-d", "-od", "year.wea"], label="gendaymtx sun patches"))[..., 0]
    t0, c0 = time.perf_counter(), _cpu()
    direct_sky = dc[("sun", 0)] @ sun + dc[("sky", 1)] @ sky                           # (N, T) [W m-2]
    if five_phase:
        total = direct_sky + (dc[("sky", bounces + 1)] - dc[("sky", 1)]) @ (sky + sun_patch)
    else:
        total = dc[("sun", bounces)] @ sun + dc[("sky", bounces + 1)] @ sky
    timings.append(("matrix products (numpy)", time.perf_counter() - t0, _cpu() - c0))
    face = {"direct_sky": direct_sky.sum(1) / 1000.0, "reflected": (total - direct_sky).sum(1) / 1000.0,
            "global": total.sum(1) / 1000.0}
    k = sc.samples_per_face
    if per_face is not None:
        per_face.update({p: v.reshape(-1, k).mean(1) for p, v in face.items()})
    out = {}
    for gi, name in enumerate(GROUPS):
        m = sc.face_group == gi
        a = sc.face_area[m] / sc.face_area[m].sum()
        out[name] = {p: float(v.reshape(-1, k).mean(1)[m] @ a) for p, v in face.items()}
    return out, timings


def _table(runs):
    """The issue-36 markdown table from the ``--json`` records of several runs (one line per run)."""
    lines = ["| sensor faces | Radiance | widesky CPU (wall) | Radiance CPU (wall) | **CPU ratio** | "
             "annual global per group, widesky / Radiance - 1 |", "|---|---|---|---|---|---|"]
    for r in runs:
        w, q, st = r["widesky_seconds"], r["radiance_seconds"], r["settings"]
        diffs = [r["widesky"][g]["global"] / r["radiance"][g]["global"] - 1 for g in GROUPS]
        method = "five-phase" if st["five_phase"] else "suns traced"
        method += ", saved run" if r.get("radiance_from") else ""
        keep = "; widesky hourly global only, as Radiance" if st.get("global_only") else ""
        lines.append(f"| {r['faces']:,} | {method}, `-ab {st['bounces'] + 1} -ad {st['ad']}`{keep} | "
                     f"{w['cpu']:.1f} s ({w['wall']:.0f} s) | {q['cpu']:.0f} s ({q['wall']:.0f} s) | "
                     f"**{q['cpu'] / w['cpu']:.1f}x** | {min(diffs):+.1%} to {max(diffs):+.1%} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faces", type=int, default=90,
                    help="about this many sensor faces (the sensor patches refined; default 90)")
    ap.add_argument("--stride", type=int, default=1)
    ap.add_argument("--tolerance", type=float, default=0.02)
    ap.add_argument("--jobs", type=int, default=None)
    ap.add_argument("--radiance", default=None, metavar="WORKDIR",
                    help="also run the Radiance cross-check (pyradiance) in this folder")
    ap.add_argument("--bounces", type=int, default=5)
    ap.add_argument("--ad", type=int, default=4096)
    ap.add_argument("--five-phase", action="store_true",
                    help="Radiance's sun reflections from the sky coefficients (the usual lean annual method)")
    ap.add_argument("--global-only", action="store_true",
                    help="widesky keeps the hourly global per face only, as Radiance's side (no parts, no angles)")
    ap.add_argument("--radiance-from", default=None, metavar="JSON",
                    help="take Radiance's results and times from this earlier --json run of the same scene "
                         "(checked: faces and groups) instead of running Radiance again")
    ap.add_argument("--json", default=None, metavar="FILE", help="write both codes' results and timings here")
    ap.add_argument("--table", nargs="+", default=None, metavar="JSON",
                    help="print the issue-36 table of earlier --json runs and exit")
    a = ap.parse_args(argv)
    if a.table:
        import json
        print(_table([json.load(open(f)) for f in a.table]))
        return
    if a.faces < 10:
        raise SystemExit(f"--faces {a.faces}: must be at least 10 (5 sensor patches of 2 triangles)")
    built = canyon_scene(subdivide=subdivision_for(a.faces))
    n_faces = built["scene"].n_faces
    w_face, r_face = {}, {}
    saved = None
    if a.radiance_from:
        import json
        saved = json.load(open(a.radiance_from))
        if saved["faces"] != n_faces or saved["face_group"] != built["scene"].face_group.tolist():
            raise SystemExit(f"--radiance-from {a.radiance_from}: its scene ({saved['faces']} faces) is not this "
                             f"one ({n_faces} faces at --faces {a.faces}); give the --json of a run at these --faces")
        if saved["settings"]["stride"] != a.stride:
            raise SystemExit(f"--radiance-from {a.radiance_from}: its run used --stride {saved['settings']['stride']}, "
                             f"not --stride {a.stride}; give the same --stride")
    res, secs = widesky_canyon(built, tolerance=a.tolerance, jobs=a.jobs, stride=a.stride, per_face=w_face,
                               global_only=a.global_only)
    print(f"widesky, Denver TMY3, {n_faces} faces, {secs['wall']:.1f} s wall, {secs['cpu']:.1f} s CPU"
          + (", hourly global per face only" if a.global_only else ""))
    print("| group | direct | sky | reflected | global | [kWh m-2 a-1] |")
    print("|---|---|---|---|---|---|")
    for g, r in res.items():
        print(f"| {g} | " + " | ".join(f"{r[p]:.1f}" if p in r else "-" for p in
                                       ("direct", "sky_diffuse", "ground_diffuse", "global")) + " | |")
    if saved is not None:
        rad, rsecs, timings = (saved[k] for k in ("radiance", "radiance_seconds", "radiance_steps"))
        r_face = saved["per_face"]["radiance"]
        print(f"Radiance from {a.radiance_from} (an earlier run of this scene): {rsecs['cpu']:.1f} s CPU")
        print(f"CPU ratio Radiance / widesky {rsecs['cpu'] / secs['cpu']:.1f}x")
        for g, r in res.items():
            print(f"| {g} | global diff {r['global'] / rad[g]['global'] - 1:+.1%} |")
    elif a.radiance is None:
        return
    elif _radiance_env() is None:
        print("Radiance cross-check skipped: pyradiance is not installed (an optional benchmark dependency: "
              "pip install pyradiance==1.3.1)")
        return
    else:
        rad, rsecs, timings = _run_radiance(built, a, r_face)
        _print_radiance(a, res, secs, rad, rsecs, timings)
    if a.json:
        import json
        st = saved["settings"] if saved is not None else {"bounces": a.bounces, "ad": a.ad, "five_phase": a.five_phase}
        with open(a.json, "w") as f:
            json.dump({"faces": n_faces, "widesky": res, "widesky_seconds": secs, "radiance": rad,
                       "radiance_seconds": rsecs, "radiance_steps": timings, "radiance_from": a.radiance_from,
                       "per_face": {"widesky": {p: v.tolist() for p, v in w_face.items()},
                                    "radiance": {p: np.asarray(v).tolist() for p, v in r_face.items()}},
                       "face_group": built["scene"].face_group.tolist(),
                       "settings": {"bounces": st["bounces"], "ad": st["ad"], "five_phase": st["five_phase"],
                                    "tolerance": a.tolerance, "jobs": a.jobs, "stride": a.stride,
                                    "global_only": a.global_only}}, f, indent=1)


def _run_radiance(built, a, r_face):
    """Radiance's run for ``main``: (results per group, seconds, per-step timings)."""
    from widesky.core.paths import data_reference
    t0, c0 = time.perf_counter(), _cpu()
    rad, timings = radiance_canyon(built, data_reference("data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw"),
                                   a.radiance, bounces=a.bounces, ad=a.ad, five_phase=a.five_phase, per_face=r_face)
    return rad, {"wall": time.perf_counter() - t0, "cpu": _cpu() - c0}, timings


def _print_radiance(a, res, secs, rad, rsecs, timings):
    """Radiance's times and the per-group agreement (parts where widesky kept them)."""
    print(f"Radiance (pyradiance), {rsecs['wall']:.1f} s wall, {rsecs['cpu']:.1f} s CPU (children included); "
          f"{'five-phase' if a.five_phase else 'suns traced'}, -ab {a.bounces} (sky {a.bounces + 1}), -ad {a.ad}:")
    for label, wall, cpu in timings:
        print(f"  {label}: {wall:.1f} s wall, {cpu:.1f} s CPU")
    print(f"CPU ratio Radiance / widesky {rsecs['cpu'] / secs['cpu']:.1f}x, wall {rsecs['wall'] / secs['wall']:.1f}x")
    print("| group | widesky direct + sky | Radiance | diff | widesky reflected | Radiance | diff | global diff |")
    print("|---|---|---|---|---|---|---|---|")
    for g, r in res.items():
        q = rad[g]
        if "direct" not in r:                                    # --global-only
            print(f"| {g} | - | {q['direct_sky']:.1f} | | - | {q['reflected']:.1f} | | "
                  f"{r['global'] / q['global'] - 1:+.1%} |")
            continue
        ds = r["direct"] + r["sky_diffuse"]
        print(f"| {g} | {ds:.1f} | {q['direct_sky']:.1f} | {ds / q['direct_sky'] - 1:+.1%} | "
              f"{r['ground_diffuse']:.1f} | {q['reflected']:.1f} | "
              f"{r['ground_diffuse'] / max(q['reflected'], 1e-9) - 1:+.1%} | {r['global'] / q['global'] - 1:+.1%} |")


if __name__ == "__main__":
    main()
