"""``widesky poa``: per-face plane-of-array irradiance for a mesh, a site and a period.

Example::

    widesky poa roof.obj --context city.glb --lat 50.08 --lon 14.42 --tz Europe/Prague \\
        --start 2023-01-01 --end 2024-01-01 --step 1h --visibility 40 --albedo 0.2 -o poa.npz

Mesh coordinates are metres east, north, up (e.g. UTM). Writes an ``.npz`` with the (T, F) arrays
``poa_global``, ``poa_direct``, ``poa_sky_diffuse``, ``poa_ground_diffuse`` [W m-2], ``times``,
``face_area`` [m2] and ``face_group``; or, for ``.csv``, the area-weighted mean per face group.
"""

from __future__ import annotations

import sys

import numpy as np


def register(subparsers) -> None:
    """Add the ``poa`` command to the ``widesky`` parser."""
    p = subparsers.add_parser("poa", help="per-face plane-of-array irradiance on a 3D mesh",
                              description=__doc__.split("\n\n")[0])
    p.add_argument("mesh", nargs="+", help="analysis mesh file(s) (OBJ, PLY, STL, GLB ...)")
    p.add_argument("--context", action="append", default=[], help="occluding mesh file (repeatable)")
    p.add_argument("--lat", type=float, required=True, help="latitude [deg], north positive")
    p.add_argument("--lon", type=float, required=True, help="longitude [deg], east positive")
    p.add_argument("--site-altitude", type=float, default=0.0, help="site altitude [m]")
    p.add_argument("--tz", default="UTC", help="time zone: IANA name or hours east of UTC")
    p.add_argument("--start", required=True, help="period start")
    p.add_argument("--end", required=True, help="period end (exclusive)")
    p.add_argument("--step", default="1h", help="step, e.g. 1h or 15min")
    p.add_argument("--visibility", type=float, default=50.0, help="visibility [km]")
    p.add_argument("--albedo", type=float, default=0.2, help="ground albedo [1]")
    p.add_argument("--ground-z", type=float, default=None, help="ground height [m] (default: lowest vertex)")
    p.add_argument("--dataset", default=None, help="PSM dataset file (default: embedded)")
    p.add_argument("--tolerance", type=float, default=0.02,
                   help="target relative annual error per face [1]: picks the cheapest preset measured "
                        "below it (docs/irradiance-integrator.md); 0.02 = the default settings")
    p.add_argument("--samples-per-face", type=int, default=1, help="points per face (1, 4, 9 ...)")
    p.add_argument("--two-sided", action="store_true", help="also analyse the back of every face")
    p.add_argument("--jobs", type=int, default=None, help="ray-casting processes (default: all cores)")
    p.add_argument("-o", "--output", required=True, help="output .npz (per face) or .csv (per group)")
    p.set_defaults(func=_run)


def _run(args) -> int:
    from .integrator import IntegratorSettings, poa_irradiance
    from .location import Site, time_range
    from .scene import make_scene
    from .skies import PragueSky, SkyStates

    tz = args.tz
    try:
        tz = float(tz)
    except ValueError:
        pass
    site = Site(args.lat, args.lon, args.site_altitude, tz=tz)
    times = time_range(args.start, args.end, args.step, tz=site.tz, label="left")
    sp = site.solar_position(times, label="left")
    states = SkyStates.create(sp["apparent_elevation"].to_numpy(), sp["azimuth"].to_numpy(),
                              args.visibility, args.albedo)
    sky = PragueSky(args.dataset)
    sky.check_states(states)
    scene = make_scene(args.mesh, args.context, groups=[str(m) for m in args.mesh],
                       ground_z=args.ground_z, samples_per_face=args.samples_per_face,
                       two_sided=args.two_sided)
    res = poa_irradiance(scene, sky, states, settings=IntegratorSettings.for_tolerance(args.tolerance),
                         times=times, n_jobs=args.jobs, progress=sys.stderr.isatty())
    if args.output.endswith(".csv"):
        import pandas as pd
        agg = res.aggregate()
        cols = {}
        for q in res.QUANTITIES:
            for g, name in enumerate(res.group_names):
                cols[f"{name}:{q}"] = agg[q][:, g]
        pd.DataFrame(cols, index=times).to_csv(args.output)
    else:
        np.savez_compressed(args.output, times=times.astype(str).to_numpy(),
                            face_area=res.face_area, face_group=res.face_group,
                            group_names=np.array(res.group_names),
                            **{q: getattr(res, q) for q in res.QUANTITIES})
    tm = res.timings
    print(f"{scene.n_faces} faces x {len(times)} steps: rays {tm['rays']:.1f} s "
          f"({tm['n_rays'] / 1e6:.1f} M), sky {tm['sky']:.1f} s, products {tm['product']:.1f} s "
          f"-> {args.output}")
    return 0
