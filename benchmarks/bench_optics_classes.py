"""Benchmark: the classing error of angle x wavelength optics (issue 17).

An angle x wavelength optic (:class:`widesky.irradiance.SpectralAngularTable`) goes through incidence-angle
classes: the integrator takes the table's factor at the class nodes per channel and interpolates
linearly in angle between them (:mod:`widesky.irradiance.optics`). Its exact per-ray answer treats every
channel separately: one response per channel whose angle-only optic is that channel's column of the
table (linear interpolation on the table's own 5-degree grid), applied per ray; their sum is the
reference. Both run in the same integrator call on the same rays, so the difference is the classing
alone.

Table: the illustrative 4 mm clear glass of benchmarks/bench_poa.py (Fresnel at n = 1.52 with a
wavelength-dependent absorption). Scenes: the validation scenes (irradiance.validation_scenes: a
35-degree plane, an obstructed south facade) plus an unobstructed east wall. Sky: the embedded
default dataset; 4 clear days (21 Mar, 21 Jun, 21 Sep, 21 Dec) hourly at Prague.

Reports per node set the error of each part and of the global (sum) relative to the reference:
the annual-sum error per face and the largest hourly error (relative to the face's hourly global
above 50 W m-2). Writes docs/figures/optics_classing_error.png.

Run: python benchmarks/bench_optics_classes.py [--no-plot]
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np


def node_sets():
    return {
        "5 nodes (0,45,65,80,90)": (0.0, 45.0, 65.0, 80.0, 90.0),
        "9 nodes": (0.0, 30.0, 45.0, 55.0, 65.0, 72.0, 78.0, 84.0, 90.0),
        "13 nodes (default)": None,
        "19 nodes (5 deg)": tuple(np.arange(0.0, 90.1, 5.0)),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-plot", action="store_true")
    args = ap.parse_args(argv)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import trimesh
    from bench_poa import glazing_table
    import widesky.irradiance as ir
    from widesky.irradiance.optics import DEFAULT_NODES

    sky = ir.PragueSky()
    site = ir.Site(50.08, 14.42, 200.0, tz=1.0)
    states = []
    for day in ("2023-03-21", "2023-06-21", "2023-09-21", "2023-12-21"):
        st = ir.sky_states_for(site, day, f"{day}T23:59", "1h", visibility=40.0, albedo=0.2)
        states.append(st)
    st = ir.SkyStates.create(*(np.concatenate([getattr(s, f) for s in states])
                               for f in ("sun_elevation", "sun_azimuth", "visibility", "albedo",
                                         "altitude", "earth_sun_distance")))
    scenes = dict(ir.validation_scenes())
    wall = trimesh.Trimesh([[0, -1, 0.5], [0, 1, 0.5], [0, 1, 2.5], [0, -1, 2.5]],
                           [[0, 1, 2], [0, 2, 3]], process=False)
    wall.apply_translation((0, 0, 0))
    scenes["east_wall"] = ir.make_scene(wall, ground_z=0.0)
    table = glazing_table()
    edges = np.asarray(sky.channel_edges)
    lo, hi = edges[:-1], edges[1:]
    per_channel = table.channel_table(lo, hi)                            # (A_table, C)
    refs = [ir.Response(f"ch{c}", [lo[c], hi[c]], [1.0, 1.0], unit="transmittance",
                        angular=ir.AngularTable(table.angle_deg, per_channel[:, c]))
            for c in range(sky.n_channels)]
    glz = ir.Response("glazing", [280.0, 2480.0], [1.0, 1.0], unit="transmittance", angular=table)
    parts = ("direct", "sky_diffuse", "ground_diffuse", "global")
    rows = []
    for label, nodes in node_sets().items():
        nodes = DEFAULT_NODES if nodes is None else nodes
        for sname, scene in scenes.items():
            res = ir.poa_irradiance(scene, sky, st, responses=[glz] + refs,
                                    run=ir.RunOptions(optic_nodes=nodes, n_jobs=1))
            g_ref = sum(res.get(r.name, "global") for r in refs)
            for p in parts:
                got = res.get("glazing", p).astype(float)
                ref = sum(res.get(r.name, p).astype(float) for r in refs)
                annual = got.sum(axis=0) / np.where(ref.sum(axis=0) > 0, ref.sum(axis=0), 1) - 1
                day = g_ref > 50.0
                hourly = np.abs(got - ref)[day] / g_ref[day]
                rows.append((label, sname, p, float(np.max(np.abs(annual))),
                             float(hourly.max()) if hourly.size else 0.0))
    print(f"{'nodes':26s} {'scene':18s} {'part':15s} {'|annual| max':>13s} {'hourly max':>11s}"
          "  (hourly: |error| / hourly global of the face, global > 50 W m-2)")
    for r in rows:
        print(f"{r[0]:26s} {r[1]:18s} {r[2]:15s} {100 * r[3]:12.3f}% {100 * r[4]:10.3f}%")
    if not args.no_plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        labels = list(node_sets())
        fig, ax = plt.subplots(figsize=(7.0, 3.8))
        for sname, mk in zip(scenes, "osd"):
            for p, col in zip(parts, ("C0", "C1", "C2", "k")):
                y = [max(r[4] for r in rows if r[0] == lab and r[1] == sname and r[2] == p)
                     for lab in labels]
                ax.semilogy(range(len(labels)), np.maximum(y, 1e-7) * 100, marker=mk, color=col,
                            label=f"{sname}: {p}" if sname == "east_wall" or p == "global" else None,
                            alpha=0.8)
        ax.set_xticks(range(len(labels)))
        ax.set_xticklabels(labels, fontsize=8)
        ax.set_ylabel("largest hourly error [% of global]")
        ax.set_title("Angle x wavelength glazing through incidence-angle classes vs per ray")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs", "figures",
                           "optics_classing_error.png")
        fig.savefig(out, dpi=110)
        print("wrote", os.path.normpath(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
