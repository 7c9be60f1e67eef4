"""``widesky poa``: per-face plane-of-array irradiance for a mesh, a site and a period.

Examples::

    widesky poa roof.obj --context city.glb --lat 50.08 --lon 14.42 --tz Europe/Prague \\
        --start 2023-01-01 --end 2024-01-01 --step 1h --visibility 40 --albedo 0.2 -o poa.npz
    widesky poa roof.obj --weather prague.epw --response c-Si=csi_sr.csv -o poa.csv

Mesh coordinates are metres east, north, up (e.g. UTM). Without ``--weather`` the sky is the clear
sky of the dataset for every step of the period. With ``--weather`` (EPW, TMY3 or a CSV with pvlib
column names) the site, the steps, and per-step visibility (or aerosol optical depth) and albedo come
from the file, and the clear sky is scaled per step to the file's measured DNI and DHI (docs/
time-and-weather.md; ``--clear-sky`` keeps the clear sky); ``--start``/``--end`` select a part of the
file. ``--response NAME=FILE`` (repeatable) reads a spectral response (CSV: wavelength [nm],
response [1]; interpolated to the channel centres, 0 outside) and adds its effective irradiance.

Writes an ``.npz`` with the (T, F) arrays ``poa_global``, ``poa_direct``, ``poa_sky_diffuse``,
``poa_ground_diffuse`` and ``effective_irradiance_<name>`` [W m-2], ``times``, ``face_area`` [m2],
``face_group`` and ``group_names``; or, for ``.csv``, the area-weighted mean per face group.
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
    p.add_argument("--weather", default=None,
                   help="weather file (EPW, TMY3, CSV): site, steps, visibility/AOD, albedo, measured DNI/DHI")
    p.add_argument("--clear-sky", action="store_true",
                   help="with --weather: do not scale the clear sky to the measured DNI/DHI")
    p.add_argument("--lat", type=float, default=None, help="latitude [deg], north positive")
    p.add_argument("--lon", type=float, default=None, help="longitude [deg], east positive")
    p.add_argument("--site-altitude", type=float, default=0.0, help="site altitude [m]")
    p.add_argument("--tz", default="UTC", help="time zone: IANA name or hours east of UTC")
    p.add_argument("--start", default=None, help="period start (required without --weather)")
    p.add_argument("--end", default=None, help="period end, exclusive (required without --weather)")
    p.add_argument("--step", default="1h", help="step, e.g. 1h or 15min")
    p.add_argument("--visibility", type=float, default=50.0,
                   help="visibility [km] (with --weather: where the file gives none)")
    p.add_argument("--albedo", type=float, default=0.2,
                   help="ground albedo [1] (with --weather: where the file gives none)")
    p.add_argument("--response", action="append", default=[], metavar="NAME=FILE",
                   help="spectral response CSV (wavelength [nm], response [1]); repeatable")
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


def read_response(path, wavelengths):
    """A spectral response from a CSV file (first column wavelength [nm], second the response [1];
    ``#`` comments and one header line allowed), interpolated linearly to ``wavelengths`` [nm], 0
    outside its range."""
    rows = []
    try:
        with open(path, encoding="utf-8-sig") as f:
            lines = f.read().splitlines()
    except OSError as e:
        raise ValueError(f"response file {path}: {e.strerror}") from None
    header_seen = False
    for n, line in enumerate(lines, 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = [x.strip() for x in line.replace(";", ",").split(",")]
        try:
            rows.append((float(parts[0]), float(parts[1])))
        except (ValueError, IndexError):
            if rows or header_seen:
                raise ValueError(f"response file {path}, line {n}: expected 'wavelength [nm], "
                                 f"response [1]', got {line[:60]!r}") from None
            header_seen = True
    a = np.array(rows, dtype=float).reshape(-1, 2)
    a = a[np.all(np.isfinite(a), axis=1)]
    if a.shape[0] < 2:
        raise ValueError(f"response file {path}: fewer than two valid rows")
    a = a[np.argsort(a[:, 0])]
    return np.interp(wavelengths, a[:, 0], a[:, 1], left=0.0, right=0.0)


def _steps(args, sky):
    """(times, SkyStates, measured (dni, dhi) or None, note) for the period or the weather file."""
    from .location import Site, time_range
    from .skies import SkyStates
    from .skystate import sky_states
    from .weather import read_weather

    if args.weather is None:
        missing = [n for n in ("lat", "lon", "start", "end") if getattr(args, n) is None]
        if missing:
            raise ValueError("without --weather, give " + ", ".join("--" + m for m in missing))
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
        return times, states, None, "clear sky"
    wd = read_weather(args.weather)
    data = wd.data
    if args.start is not None or args.end is not None:
        lo = data.index[0] if args.start is None else wd.site.localize([args.start])[0]
        hi = None if args.end is None else wd.site.localize([args.end])[0]
        keep = (data.index >= lo) & (True if hi is None else data.index < hi)
        data = data[keep]
        if data.empty:
            raise ValueError(f"no steps of {args.weather} in the period {args.start} .. {args.end}")
    sp = wd.site.solar_position(data.index, wd.label, wd.step)
    st = sky_states(sp, data, model=sky.model, default_visibility=args.visibility,
                    default_albedo=args.albedo)
    states = SkyStates.create(st["solar_elevation"].to_numpy(), st["azimuth"].to_numpy(),
                              st["visibility"].to_numpy(), st["albedo"].to_numpy())
    note = f"weather {args.weather} ({wd.site.latitude:.3f}, {wd.site.longitude:.3f})"
    if args.clear_sky or not {"dni", "dhi"} <= set(data.columns):
        return data.index, states, None, note + ", clear sky"
    return (data.index, states, (data["dni"].to_numpy(), data["dhi"].to_numpy()),
            note + ", scaled to measured DNI/DHI")


def _run(args) -> int:
    from .integrator import IntegratorSettings, poa_irradiance
    from .scene import make_scene
    from .skies import PragueSky

    sky = PragueSky(args.dataset)
    responses = {}
    for item in args.response:
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            raise ValueError(f"--response {item!r}: expected NAME=FILE")
        responses[name] = read_response(path, sky.wavelengths)
    times, states, measured, note = _steps(args, sky)
    sky.check_states(states)
    scene = make_scene(args.mesh, args.context, groups=[str(m) for m in args.mesh],
                       ground_z=args.ground_z, samples_per_face=args.samples_per_face,
                       two_sided=args.two_sided)
    res = poa_irradiance(scene, sky, states, responses=responses,
                         settings=IntegratorSettings.for_tolerance(args.tolerance),
                         measured=measured,
                         times=times, n_jobs=args.jobs, progress=sys.stderr.isatty())
    if args.output.endswith(".csv"):
        import pandas as pd
        agg = res.aggregate()
        cols = {}
        for q in [*res.QUANTITIES, *(f"effective_irradiance:{n}" for n in res.effective_irradiance)]:
            for g, name in enumerate(res.group_names):
                cols[f"{name}:{q}"] = agg[q][:, g]
        pd.DataFrame(cols, index=times).to_csv(args.output)
    else:
        np.savez_compressed(args.output, times=np.asarray(times.astype(str), dtype=str),
                            face_area=res.face_area, face_group=res.face_group,
                            group_names=np.array(res.group_names),
                            **{q: getattr(res, q) for q in res.QUANTITIES},
                            **{f"effective_irradiance_{n}": v
                               for n, v in res.effective_irradiance.items()})
    if res.scaling is not None:
        lit = states.sun_elevation > 0
        n_g = int(np.sum(res.scaling.sun_guarded | res.scaling.sky_guarded))
        note += f" ({n_g} of {int(lit.sum())} daylight steps guarded or missing)"
    tm = res.timings
    print(f"{scene.n_faces} faces x {len(times)} steps ({note}): rays {tm['rays']:.1f} s "
          f"({tm['n_rays'] / 1e6:.1f} M), sky {tm['sky']:.1f} s, products {tm['product']:.1f} s "
          f"-> {args.output}")
    return 0
