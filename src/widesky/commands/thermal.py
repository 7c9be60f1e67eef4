"""``widesky thermal``: glazing properties, building loads, ASHRAE 140 validation, the glazing study."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

UNIT_NAMES = ("clear", "low-e", "low-e #2", "solar-control")


def register(subparsers) -> None:
    p = subparsers.add_parser("thermal", help="facade solar gains, glazing and hourly zone loads",
                              description="Facade solar gains, glazing optics and hourly zone loads "
                                          "(ISO 13790 5R1C).")
    sub = p.add_subparsers(dest="thermal_command", metavar="SUBCOMMAND")
    sub.required = True

    g = sub.add_parser("glazing", help="U-value, solar transmittance and g of a glazing unit")
    g.add_argument("layers", nargs="+", help="IGDB/Optics layer files, outside first, or the names of the "
                   "samples shipped with widesky (CLEAR_3.DAT, CLEAR_6.DAT, CLEAR5.LOF, LOW-E_5.LOF)")
    g.add_argument("--gap", action="append", default=[], metavar="MM[:GAS]",
                   help="gap between consecutive layers (e.g. 12:argon); once per gap, default 12:air")
    g.add_argument("--flip", action="append", type=int, default=[], metavar="I",
                   help="mount layer I (0-based) the other way round (coating facing inside)")
    g.add_argument("--csv", help="write g, T and absorbed per layer by angle [deg] (AM1.5) here")
    g.set_defaults(func=_glazing)

    b = sub.add_parser("bestest", help="ASHRAE 140 Cases 600/660/670/900 against the reference programs")
    b.add_argument("--case", nargs="+", default=["600", "660", "670", "900"])
    b.add_argument("--weather", default="tmy3", choices=("tmy3", "drycold"),
                   help="tmy3: Denver Intl AP TMY3 (the 140-2020 weather, default); drycold: older")
    b.add_argument("--sky", default="weather", choices=("weather", "integrator"),
                   help="weather: Hay-Davies from the file (default, seconds); integrator: widesky's "
                        "all-sky spectra at the file's DNI/DHI (minutes; tmy3 only)")
    b.add_argument("--exterior", default="hourly", choices=("hourly", "constant"),
                   help="outside surface coefficients: hourly from wind and air temperature "
                        "(ISO 6946 Annex C, default) or ISO 13790's constant R_se = 0.04")
    b.add_argument("--json", help="also write the results here (for python -m widesky.thermal.figures)")
    b.add_argument("--jobs", type=int, default=None, help="ray-casting processes (default: all cores, as every command)")
    b.add_argument("--data-dir", default=None,
                   help="data directory (default WIDESKY_DATA_DIR or ../shared/data)")
    b.set_defaults(func=_bestest)

    lo = sub.add_parser("loads", help="hourly gains and loads of a box building for a weather file")
    lo.add_argument("--weather", required=True,
                    help="EPW or TMY3 file, or data:weather/<file> for a year shipped with widesky "
                         "(data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw)")
    lo.add_argument("--width", type=float, default=20.0, help="[m] along x (east)")
    lo.add_argument("--depth", type=float, default=12.0, help="[m] along y (north)")
    lo.add_argument("--floor-height", type=float, default=3.5, help="[m]")
    lo.add_argument("--floors", type=int, default=1)
    lo.add_argument("--wwr", default="0.4", help="window-to-wall ratio: one value or S=0.4,N=0.2,E=..,W=..")
    lo.add_argument("--overhang", type=float, default=0.0, help="overhang depth [m]")
    lo.add_argument("--fins", type=float, default=0.0, help="fin depth [m]")
    lo.add_argument("--rotation", type=float, default=0.0, help="clockwise rotation [deg]")
    lo.add_argument("--glazing", default="clear", choices=UNIT_NAMES)
    lo.add_argument("--sky", default="integrator", choices=("integrator", "weather"),
                    help="integrator: widesky's spectral sky (the all-sky model at the measured DNI/DHI, as "
                         "every command) with shading (default); weather: Hay-Davies from the file, no shading")
    lo.add_argument("--route", default="spectral", choices=("spectral", "rated"),
                    help="window gains from the spectral-angular g or the rated AM1.5 g(angle)")
    lo.add_argument("--output", required=True, help="hourly CSV of zone heating, cooling and solar [W]")
    lo.add_argument("--facade-map", help="PLY coloured by the annual incident shortwave per face "
                                         "[kWh m-2], with a per-face CSV beside it")
    lo.add_argument("--context", action="append", default=[], metavar="MESH",
                    help="neighbouring buildings or terrain that shade and reflect: a mesh file "
                         "(anything trimesh loads; x east, y north, z up [m], the building's "
                         "south-west corner at 0,0 before --rotation; repeatable; integrator sky)")
    lo.add_argument("--context-box", action="append", default=[], metavar="X,Y,W,D,H",
                    help="a neighbouring block on the ground: south-west corner X,Y, width W "
                         "(east), depth D (north), height H [m] (repeatable; integrator sky)")
    lo.add_argument("--jobs", type=int, default=None, help="ray-casting processes (default: all cores, as every command)")
    lo.add_argument("--data-dir", default=None)
    lo.set_defaults(func=_loads)

    s = sub.add_parser("study", help="spectral vs rated glazing: effective g per orientation and "
                                     "month, annual gains and loads")
    s.add_argument("--weather", required=True,
                   help="EPW or TMY3 file, or data:weather/<file> for a year shipped with widesky "
                        "(data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw)")
    s.add_argument("--output", required=True, help="folder for effective_g.csv and annual.csv")
    s.add_argument("--jobs", type=int, default=None, help="ray-casting processes (default: all cores, as every command)")
    s.add_argument("--solar-control", action="store_true",
                   help="add the double-silver solar-control unit (thermal.thinfilm) to the three")
    s.add_argument("--data-dir", default=None)
    s.set_defaults(func=_study)


def _parse_gap(text):
    from widesky.thermal.glazing import Gap
    mm, _, gas = text.partition(":")
    try:
        return Gap(float(mm), gas or "air")
    except ValueError as exc:
        raise ValueError(f"--gap {text!r}: {exc}") from None


def _weather_file(text):
    """``--weather``: a file, or ``data:weather/<file>`` (shipped with widesky, else in the reference data folder)."""
    from widesky.irradiance.simulation import weather_path
    try:
        return weather_path(text)
    except FileNotFoundError as exc:
        raise ValueError(f"--weather: {exc}") from None


def _glazing(args) -> int:
    from widesky.core.paths import runtime_file, runtime_files
    from widesky.thermal.glazing import GlazingUnit, read_igdb, read_solar_spectrum
    layers = []
    samples = [n for n in runtime_files("glazing") if n.upper().endswith((".DAT", ".LOF"))]
    for i, path in enumerate(args.layers):
        if not Path(path).is_file():
            if path not in samples:
                raise ValueError(f"layer file {path!r} not found (nor a shipped sample: {', '.join(samples)})")
            path = runtime_file(f"glazing/{path}")
        layer = read_igdb(path)
        layers.append(layer.flipped() if i in args.flip else layer)
    gaps = [_parse_gap(t) for t in args.gap]
    if not gaps and len(layers) > 1:
        gaps = [_parse_gap("12")] * (len(layers) - 1)
    unit = GlazingUnit("unit", layers, gaps)
    sw, se = read_solar_spectrum()
    r = unit.rated(sw, se)
    print(f"U = {unit.u_value():.3f} W m-2 K-1 (EN 673)   T_sol = {r['transmittance']:.3f}   "
          f"g = {r['shgc']:.3f}   (AM1.5 global, normal incidence)")
    for layer, a, n in zip(layers, r["absorbed"], unit.inward_fractions()):
        kind = "coated" if layer.coated else "uncoated"
        print(f"  {layer.name[:40]:40s} {kind:8s} absorbed {a:.3f}  inward fraction {n:.3f}")
    if args.csv:
        import pandas as pd
        from widesky.thermal.facade import write_face_csv
        from widesky.thermal.glazing import ANGLES
        rows = [{"aoi_deg": a, **{k: v for k, v in unit.rated(sw, se, a).items() if k != "absorbed"},
                 **{f"absorbed_{j}": v for j, v in enumerate(unit.rated(sw, se, a)["absorbed"])}}
                for a in ANGLES]
        write_face_csv(args.csv, pd.DataFrame(rows).set_index("aoi_deg"))
    return 0


def _bestest(args) -> int:
    import json
    from widesky.thermal.bestest import CASES, integrator_irradiance, reference_results, run_case
    from widesky.thermal.facade import atomic_write
    for c in args.case:
        if c not in CASES:
            raise ValueError(f"--case {c!r} not one of {CASES}")
    refs = reference_results(args.data_dir)
    poa = None
    if args.sky == "integrator":
        poa = integrator_irradiance(args.weather, args.data_dir, n_jobs=args.jobs,
                                    progress=sys.stderr.isatty())
    print(f"ASHRAE 140 with the ISO 13790 5R1C model, weather {args.weather}, sky {args.sky}, "
          f"exterior {args.exterior}")
    print(f"{'case':5s} {'quantity':15s} {'widesky':>9s} {'limits':>15s} {'programs':>15s}")
    saved = {}
    for c in args.case:
        r = run_case(c, args.data_dir, weather=args.weather, poa=poa, exterior=args.exterior)
        saved[c] = {k: (str(v) if hasattr(v, "isoformat") else float(v)) for k, v in r.items()
                    if k not in ("hourly", "case")}
        for q, unit, scale in (("annual_heating", "MWh", 1e-3), ("annual_cooling", "MWh", 1e-3),
                               ("peak_heating", "kW", 1e-3), ("peak_cooling", "kW", 1e-3)):
            ref = refs[c][q]
            lim = ref.get("limits")
            prog = list(ref["programs"].values())
            lim_s = f"{lim[0] * scale:.2f}-{lim[1] * scale:.2f}" if lim else "-"
            print(f"{c:5s} {q:15s} {r[q] * scale:7.2f} {unit:3s} {lim_s:>13s} "
                  f"{min(prog) * scale:6.2f}-{max(prog) * scale:.2f}")
    if args.json:
        text = json.dumps(saved, indent=1).encode()
        atomic_write(args.json, lambda fh: fh.write(text))
    return 0


def _context(args):
    """Context meshes from ``--context`` files and ``--context-box`` blocks."""
    if not (args.context or args.context_box):
        return []
    import trimesh
    from widesky.irradiance.scene import load_mesh
    meshes = []
    for p in args.context:
        if not Path(p).is_file():
            raise ValueError(f"--context {p!r} not found")
        meshes.append(load_mesh(p))
    for text in args.context_box:
        try:
            x, y, w, d, h = (float(v) for v in text.split(","))
        except ValueError:
            raise ValueError(f"--context-box {text!r}: expected X,Y,W,D,H in m") from None
        if not (w > 0 and d > 0 and h > 0):
            raise ValueError(f"--context-box {text!r}: W, D and H must be > 0 m")
        meshes.append(trimesh.creation.box((w, d, h)).apply_translation((x + w / 2, y + d / 2,
                                                                         h / 2)))
    return meshes


def _wwr(text):
    key = {"S": "south", "N": "north", "E": "east", "W": "west"}
    try:
        return float(text)
    except ValueError:
        pass
    out = {}
    for item in text.split(","):
        k, sep, v = item.partition("=")
        if not sep or k.strip().upper() not in key:
            raise ValueError(f"--wwr {text!r}: expected a number or S=0.4,N=0.2,E=..,W=..")
        out[key[k.strip().upper()]] = float(v)
    return out


def _loads(args) -> int:
    import pandas as pd
    from widesky.irradiance import read_weather
    from widesky.thermal.building import ZoneSpec, box_building
    from widesky.thermal.facade import write_face_csv, write_facade_ply
    from widesky.thermal.loads import building_loads
    from widesky.thermal.study import _constructions, standard_units
    from widesky.thermal.surface import sky_temperature, surface_irradiance

    args.weather = _weather_file(args.weather)
    context = _context(args)
    if context and args.sky != "integrator":
        raise ValueError("--context and --context-box need --sky integrator (the weather route "
                         "has no shading)")
    w = read_weather(args.weather)
    units = standard_units(args.data_dir, solar_control=True)
    unit = units[args.glazing]
    b = box_building(args.width, args.depth, args.floor_height, args.floors, _wwr(args.wwr),
                     overhang=args.overhang, fins=args.fins, rotation=args.rotation,
                     zone_use=ZoneSpec("use", air_changes=0.7, internal_gains=10.0 * args.width
                                       * args.depth / 4, cooling_setpoint=26.0))
    cons = _constructions(args.glazing, unit)
    data = w.data
    surf = [s for s in b.surfaces if s.kind != "shading"]
    window_gain = None
    if args.sky == "weather":
        from widesky.irradiance import dni_extra
        sp = w.site.solar_position(data.index, w.label, w.step)
        irr = surface_irradiance([s.tilt for s in surf], [s.azimuth for s in surf],
                                 sp["zenith"].to_numpy(), sp["azimuth"].to_numpy(),
                                 data["dni"].fillna(0).to_numpy(), data["dhi"].fillna(0).to_numpy(),
                                 data["ghi"].fillna(0).to_numpy(),
                                 dni_extra(sp["earth_sun_distance"].to_numpy()))
        if args.route == "spectral":
            raise ValueError("--route spectral needs --sky integrator (the weather file has no spectra)")
    else:
        from widesky.irradiance import Simulation
        from widesky.thermal.gains import (building_scene, front_faces, glazing_response, irradiance_by_surface,
                                           rated_glazing_response, window_gain_by_surface)
        from widesky.thermal.glazing import read_solar_spectrum
        scene, labels = building_scene(b, context)
        sim = Simulation(scene, weather=w, n_jobs=args.jobs, progress=sys.stderr.isatty())
        for msg in sim.warnings:
            print(f"widesky: warning: {msg}", file=sys.stderr)
        resp = (glazing_response(unit, f"{args.glazing}:spectral") if args.route == "spectral"
                else rated_glazing_response(unit, *read_solar_spectrum(args.data_dir),
                                            f"{args.glazing}:rated"))
        res = sim.run([resp])
        irr = irradiance_by_surface(res, labels)
        window_gain = window_gain_by_surface(res, labels, b, cons, args.route)
    t_sky = (sky_temperature(np.maximum(data["ghi_infrared"].fillna(300).to_numpy(), 1.0))
             if "ghi_infrared" in data else None)
    lr = building_loads(b, cons, data.index, data["temp_air"].to_numpy(), irr, temp_sky=t_sky,
                        window_gain=window_gain)
    out = pd.concat({"heating_W": lr.heating, "cooling_W": lr.cooling, "solar_W": lr.zone_solar},
                    axis=1)
    out.columns = [f"{z}:{q}" for q, z in out.columns]
    write_face_csv(args.output, out)
    if args.facade_map:
        # annual incident global per mesh face [kWh m-2] (per result face on the integrator route,
        # so shading shows within a surface), and each surface's annual gain per m2
        order = np.concatenate([s.faces for s in surf])
        incident = np.full(len(b.faces), np.nan)
        if window_gain is None:
            for j, s in enumerate(surf):
                incident[s.faces] = irr["poa_global"][:, j].sum() / 1000.0
        else:
            front = front_faces(res)
            annual = res.get("broadband", "global").sum(axis=0) / 1000.0
            incident[order[np.asarray(res.faces.parent)[front]]] = annual[front]
        gain = lr.surface_gains.sum().to_numpy() / 1000.0 / np.array([s.area for s in surf])
        per_face_gain = np.full(len(b.faces), np.nan)
        for j, s in enumerate(surf):
            per_face_gain[s.faces] = gain[j]
        write_facade_ply(args.facade_map, b.vertices, b.faces, incident)
        write_face_csv(Path(args.facade_map).with_suffix(".csv"),
                       pd.DataFrame({"surface": [b.surfaces[i].label for i in b.face_surface],
                                     "incident_kWh_m2": incident,
                                     "surface_gain_kWh_m2": per_face_gain}))
    s = lr.summary().loc["total"]
    print(f"{len(b.zones)} zones, {len(data)} steps ({args.sky}, {args.route}): heating "
          f"{s['heating_kWh']:.0f} kWh, cooling {s['cooling_kWh']:.0f} kWh, solar "
          f"{s['solar_kWh']:.0f} kWh, peak cooling {s['peak_cooling_W'] / 1000:.1f} kW at "
          f"{s['peak_cooling_time']} -> {args.output}")
    return 0


def _study(args) -> int:
    from widesky.thermal.facade import write_face_csv
    from widesky.thermal.study import glazing_study
    args.weather = _weather_file(args.weather)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    from widesky.thermal.study import standard_units
    units = standard_units(args.data_dir, solar_control=args.solar_control)
    r = glazing_study(args.weather, units, n_jobs=args.jobs, progress=sys.stderr.isatty(),
                      data_dir=args.data_dir)
    write_face_csv(out / "effective_g.csv", r["effective_g"])
    write_face_csv(out / "annual.csv", r["annual"])
    print(r["annual"].round(1).to_string())
    return 0
