"""Benchmark: per-face POA irradiance for a 20,000-face scene over an hourly year (issue 6).

Scene: rows of PV modules (analysis), a building whose facades and roof are analysed, neighbouring
buildings and trees as context. Sky: the Prague Sky Model (embedded default dataset, or a synthetic
PSM-format dataset written to a temporary file when none is installed), 55 channels contracted to three
responses (broadband, a c-Si-like cell response, a glazing-like transmittance). Hourly clear-sky year
at 50 N, 14.4 E (Prague), solar positions by irradiance.solarposition (NREL SPA).

Baseline, same run: ray casting the sky anew for every hour (what per-hour ray tracers do) on a few
daylight hours, scaled to the year's daylight hours; the ratio is reported.

Run: python benchmarks/bench_poa.py [--faces 20000] [--jobs 2] [--baseline-hours 3]
     [--mf M --rays-per-patch K --radiance-samples K]  (default: IntegratorSettings())
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
        rot = trimesh.transformations.rotation_matrix(np.radians(-25.0), [1, 0, 0])  # tilt to south
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
    import skymodel
    from irradiance.skies import PragueSky
    if path:
        m = skymodel.load_dataset(path)
        return PragueSky(m), f"dataset {path}{' (synthetic)' if m.is_synthetic else ''}"
    try:
        m = skymodel.load_dataset()
        return PragueSky(m), f"default dataset{' (synthetic)' if m.is_synthetic else ''}"
    except Exception:
        from skymodel.synthetic import write_synthetic_dataset
        path = os.path.join(tempfile.mkdtemp(), "synthetic.dat")
        write_synthetic_dataset(path)
        return PragueSky(skymodel.load_dataset(path)), "synthetic dataset"


def responses(wl):
    """Three responses: broadband (implicit), c-Si-like SR and a glazing-like transmittance."""
    csi = np.clip((wl - 300.0) / 800.0, 0, 1) * (wl < 1180)
    glazing = 0.85 * np.exp(-0.5 * ((wl - 650.0) / 600.0) ** 2)
    return {"c-Si": csi, "glazing": glazing}


def year_states(year=2023, lat=50.08, lon=14.42, visibility=40.0, albedo=0.2):
    from irradiance.skies import SkyStates
    from irradiance.solarposition import solar_position
    times = pd.date_range(f"{year}-01-01 00:30", f"{year}-12-31 23:30", freq="1h", tz="Etc/GMT-1")
    sp = solar_position(times, lat, lon)
    st = SkyStates.create(sp["apparent_elevation"].to_numpy(), sp["azimuth"].to_numpy(),
                          visibility, albedo)
    return times, st


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faces", type=int, default=20000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--baseline-hours", type=int, default=3)
    ap.add_argument("--dataset", default=None, help="PSM dataset file (default: the embedded one)")
    ap.add_argument("--mf", type=int, default=None, help="override IntegratorSettings.mf")
    ap.add_argument("--rays-per-patch", type=int, default=None, help="override rays_per_patch")
    ap.add_argument("--radiance-samples", type=int, default=None, help="override radiance_samples")
    args = ap.parse_args(argv)
    from irradiance.integrator import IntegratorSettings, poa_irradiance
    from irradiance.scene import make_scene

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
    t0 = time.perf_counter()
    res = poa_irradiance(scene, sky, states, responses=resp, settings=settings, times=times,
                         n_jobs=args.jobs, progress=sys.stderr.isatty())
    t_total = time.perf_counter() - t0
    tm = res.timings
    n_lit = tm["lit_steps"]
    print(f"end to end: {t_total:.1f} s (+ {t_setup:.1f} s building the scene and solar positions)")
    print(f"  ray casting: {tm['rays']:.1f} s wall, {tm['n_rays'] / 1e6:.1f} M rays "
          f"({tm['sun_bins']} sun-position bins), {tm['n_rays'] / tm['rays'] / 1e6:.2f} M rays/s on "
          f"{args.jobs} processes (this process evaluated the sky meanwhile)")
    print(f"  sky patch radiance: {tm['sky']:.1f} s for {n_lit} lit steps "
          f"({1e3 * tm['sky'] / max(n_lit, 1):.2f} ms/step), {tm['sky_during_rays']:.1f} s of it "
          f"during the ray casting")
    print(f"  products: {tm['product']:.1f} s "
          f"({scene.n_faces * n_lit / max(tm['product'], 1e-9) / 1e6:.1f} M face-steps/s)")
    agg = res.aggregate()
    kwh = agg["poa_global"].sum(axis=0) / 1000.0
    print("  annual POA global per group [kWh m-2]: " +
          ", ".join(f"{g} {v:.0f}" for g, v in zip(res.group_names, kwh)))

    # baseline: the sky ray-cast anew for every hour, a few daylight hours, scaled
    lit = np.nonzero(states.sun_elevation > 5)[0]
    pick = lit[np.linspace(0, lit.size - 1, args.baseline_hours).astype(int)]
    t0 = time.perf_counter()
    for t in pick:
        poa_irradiance(scene, sky, states.take([t]), responses=resp, settings=settings,
                       n_jobs=args.jobs)
    t_hour = (time.perf_counter() - t0) / pick.size
    t_base = t_hour * n_lit
    print(f"baseline (sky ray-cast anew per hour): {t_hour:.2f} s/hour x {n_lit} lit hours = "
          f"{t_base:.0f} s; ratio baseline / daylight-coefficient method = {t_base / t_total:.1f}x")
    print(f"load average after: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
