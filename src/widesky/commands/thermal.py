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

    b = sub.add_parser("bestest", help="ASHRAE 140 Cases 600-950 and 600FF-950FF against their ranges "
                       "(exit status 1 when a figure leaves its range)")
    b.add_argument("--case", nargs="+", default=None,
                   help="cases to run (default all: 600 610 620 630 640 650 660 670 900 910 920 930 940 950 "
                        "600FF 650FF 900FF 950FF)")
    b.add_argument("--weather", default="tmy3", choices=("tmy3", "drycold"),
                   help="tmy3: Denver Intl AP TMY3 (the 140-2020 weather, default); drycold: older")
    b.add_argument("--sky", default="weather", choices=("weather", "integrator"),
                   help="weather: the file's DNI/DHI transposed (--transposition; default, seconds); integrator: "
                        "widesky's all-sky spectra at the file's DNI/DHI (ray casting: a few times longer; tmy3 only)")
    b.add_argument("--transposition", default="perez", choices=("perez", "hay-davies"),
                   help="transposition of --sky weather: Perez et al. 1990 (default) or Hay-Davies 1980")
    b.add_argument("--diffuse-optics", default="angular", choices=("angular", "hemispherical"),
                   help="how the windows take the diffuse light: angular (default): each route's own angles (the "
                        "integrator: every ray at its own angle; the weather route: Perez's circumsolar light at the "
                        "sun's, its horizon band at the band's); hemispherical: the glass's hemispherical g on all "
                        "diffuse light, the beam alone at its angle (one convention on both routes, to compare "
                        "their light)")
    b.add_argument("--exterior", default="hourly", choices=("hourly", "constant"),
                   help="outside surface coefficients of --zone-model 5r1c: hourly from wind and air temperature "
                        "(ISO 6946 Annex C, default) or ISO 13790's constant R_se = 0.04")
    b.add_argument("--zone-model", default="iso52016", choices=("5r1c", "iso52016"),
                   help="iso52016: ISO 52016-1's balance per element with the case files' layers (default); "
                        "5r1c: ISO 13790's network")
    b.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="a choice of the ISO 52016-1 run (repeatable; widesky.thermal.bestest.ISO52016_OPTIONS, "
                        "default the first of each), e.g. exterior=doe2 or lost=table: the alternatives measured in "
                        "docs/validation/thermal-bestest-cases.md")
    b.add_argument("--solar", action="store_true",
                   help="also check the light: Case 600's annual incident solar per surface, the annual transmitted "
                        "solar of Cases 600-670, and the incident and transmitted solar of the Standard's days (1 Feb, "
                        "4 May, 14 July), against the six programs' solar outputs (on the same --sky route)")
    b.add_argument("--days", action="store_true",
                   help="also check the free-floating rooms hour by hour on the Standard's days (600FF and 900FF on "
                        "1 February, 650FF and 950FF on 14 July) against the six programs' hourly range")
    b.add_argument("--monthly", action="store_true",
                   help="also check Cases 600 and 900 month by month (heating, cooling and their peaks) against the "
                        "six programs' monthly range")
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
    lo.add_argument("--floors", type=int, default=1, help="storeys (default 1), each with four perimeter zones")
    lo.add_argument("--wwr", default="0.4", help="window-to-wall ratio: one value or S=0.4,N=0.2,E=..,W=..")
    lo.add_argument("--overhang", type=float, default=0.0, help="overhang depth [m]")
    lo.add_argument("--fins", type=float, default=0.0, help="fin depth [m]")
    lo.add_argument("--rotation", type=float, default=0.0, help="clockwise rotation [deg]")
    lo.add_argument("--glazing", default="clear", choices=UNIT_NAMES,
                    help="double-glazed unit of every window (default clear; the units of thermal study)")
    lo.add_argument("--sky", default="integrator", choices=("integrator", "weather"),
                    help="integrator: widesky's spectral sky (the all-sky model at the measured DNI/DHI, as "
                         "every command) with shading (default); weather: the file transposed "
                         "(--transposition), no shading")
    lo.add_argument("--transposition", default="perez", choices=("perez", "hay-davies"),
                    help="transposition of --sky weather: Perez et al. 1990 (default) or Hay-Davies 1980")
    lo.add_argument("--route", default="spectral", choices=("spectral", "rated"),
                    help="window gains from the spectral-angular g or the rated AM1.5 g(angle)")
    lo.add_argument("--output", required=True,
                    help="hourly CSV of zone heating, cooling and solar gains [W] (the solar gains as ISO 13790 "
                         "11.3.5 counts them: net of the long-wave loss to the sky, so below zero at night)")
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
    lo.add_argument("--data-dir", default=None,
                    help="reference data folder (default WIDESKY_DATA_DIR or ../shared/data; only for data the "
                         "package does not ship)")
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
    s.add_argument("--data-dir", default=None,
                   help="reference data folder (default WIDESKY_DATA_DIR or ../shared/data; only for data the "
                        "package does not ship)")
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
    from widesky.commands.outputs import check_text_file
    from widesky.core.atomic import check_output_path
    if args.csv:
        check_output_path(args.csv, "--csv", (".csv",))
    n = len(args.layers)
    for i in args.flip:
        if not 0 <= i < n:
            raise ValueError(f"--flip {i}: no such layer; valid: 0 to {n - 1} (0-based, outside first) for "
                             f"the {n} layer(s) given")
    if args.gap and len(args.gap) != n - 1:
        raise ValueError(f"--gap given {len(args.gap)} time(s): {n} layers need {n - 1} gap(s), one per "
                         "pair of layers (or none: 12 mm of air each)")
    layers = []
    samples = [n for n in runtime_files("glazing") if n.upper().endswith((".DAT", ".LOF"))]
    for i, path in enumerate(args.layers):
        if not Path(path).is_file():
            if path not in samples:
                raise ValueError(f"layer file {path!r} not found (nor a shipped sample: {', '.join(samples)})")
            path = runtime_file(f"glazing/{path}")
        check_text_file(path, "layer", "IGDB/Optics text file (wavelength [um], T, Rfront, Rback)")
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
    from widesky.thermal.bestest import (CASES, SOURCES, case_geometry, integrator_irradiance,
                                         parse_iso52016_option, reference_results, run_case, verdicts)
    from widesky.thermal.facade import atomic_write
    if args.json:
        from widesky.core.atomic import check_output_path
        check_output_path(args.json, "--json", (".json",))
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs {args.jobs}: must be >= 1 (ray-casting processes)")
    options = {}
    for text in args.option:
        try:
            key, value = parse_iso52016_option(text)
        except ValueError as e:
            raise ValueError(f"--option {e}") from None
        options[key] = value
    for flag in ("solar", "days", "monthly"):
        if getattr(args, flag) and args.weather != "tmy3":
            raise ValueError(f"--{flag} with --weather {args.weather}: the programs' solar, hourly and monthly outputs "
                             "are for the 140-2020 weather, --weather tmy3")
    if options and args.zone_model != "iso52016":
        raise ValueError(f"--option {args.option[0]!r}: applies to --zone-model iso52016, not {args.zone_model}")
    cases = list(CASES) if args.case is None else args.case
    for c in cases:
        if c not in CASES:
            raise ValueError(f"--case {c!r} not one of {' '.join(CASES)}")
    refs = reference_results(args.data_dir)
    poas = {}
    if args.sky == "integrator":                  # one integrator run per room geometry
        for geo in dict.fromkeys(case_geometry(c) for c in cases):
            poas[geo] = integrator_irradiance(args.weather, args.data_dir, n_jobs=args.jobs,
                                              progress=sys.stderr.isatty(), geometry=geo)
    model = {"5r1c": "the ISO 13790 5R1C model", "iso52016": "the ISO 52016-1 hourly method"}[args.zone_model]
    sky = args.sky if args.sky == "integrator" else f"{args.sky} ({args.transposition})"
    chosen = "".join(f", {k}={v}" for k, v in options.items())
    chosen += f", diffuse optics {args.diffuse_optics}" if args.diffuse_optics != "angular" else ""
    ext = f", exterior {args.exterior}" if args.zone_model == "5r1c" else ""       # --exterior is 5R1C's
    print(f"ASHRAE 140 with {model}{chosen}, weather {args.weather}, sky {sky}{ext}")
    print(f"{'case':6s} {'quantity':20s} {'widesky':>16s} {'range':>18s} {'verdict':8s} source")
    saved, outside = {}, []
    for c in cases:
        r = run_case(c, args.data_dir, weather=args.weather, poa=poas.get(case_geometry(c)),
                     exterior=args.exterior, zone_model=args.zone_model, transposition=args.transposition,
                     iso52016_options=options or None, diffuse_optics=args.diffuse_optics)
        saved[c] = {k: (str(v) if hasattr(v, "isoformat") else float(v)) for k, v in r.items()
                    if k not in ("hourly", "case")}
        saved[c]["verdicts"] = {}
        for v in verdicts(c, r, refs):
            verdict = "inside" if v.inside else "OUTSIDE"
            # three decimals on loads (the programs' tables give three: a value on a rounded limit reads as
            # 2.394 against 2.054-2.388, not 2.39 against 2.05-2.39), two on temperatures
            d = 2 if v.unit == "degC" else 3
            rng = f"{v.low:.{d}f} to {v.high:.{d}f}"
            print(f"{c:6s} {v.quantity:20s} {v.value:8.{d}f} {v.unit:7s} {rng:>18s} {verdict:8s} {v.source}")
            saved[c]["verdicts"][v.quantity] = {"value": v.value, "low": v.low, "high": v.high,
                                                "unit": v.unit, "source": SOURCES[v.source],
                                                "inside": v.inside}
            if not v.inside:
                outside.append(f"{c} {v.quantity}")
    extra = []                                    # the Standard's other outputs: the light, the free-floating days
    model = {"zone_model": args.zone_model, "exterior": args.exterior, "iso52016_options": options or None,
             "diffuse_optics": args.diffuse_optics}
    if args.solar:
        from widesky.thermal.bestest_solar import solar_outputs, solar_verdicts
        extra.append(("solar", solar_verdicts(solar_outputs(args.sky, args.transposition, args.data_dir,
                                                            n_jobs=args.jobs, progress=sys.stderr.isatty(),
                                                            diffuse_optics=args.diffuse_optics)), []))
    if args.days:
        from widesky.thermal.bestest_days import day_verdicts, free_float_days
        extra.append(("days", day_verdicts(free_float_days(args.sky, args.transposition, args.data_dir,
                                                           n_jobs=args.jobs, progress=sys.stderr.isatty(),
                                                           poas=poas, **model)), []))
    if args.monthly:
        import pandas as pd
        from widesky.thermal.bestest_monthly import monthly_loads, monthly_verdicts, months_outside
        monthly = monthly_loads(args.sky, args.transposition, args.data_dir, n_jobs=args.jobs,
                                progress=sys.stderr.isatty(), poas=poas, **model)
        detail = [f"  {c} {q} {pd.Timestamp(2001, m, 1):%b}: {v:.{3 if 'peak' in q else 1}f} "
                  f"{'kW' if 'peak' in q else 'kWh'}, programs {lo:g} to {hi:g}"
                  for c, q, m, v, lo, hi in months_outside(monthly)]
        extra.append(("monthly", monthly_verdicts(monthly), ["months outside the programs' range:"] * bool(detail)
                      + detail))
    for key, found, detail in extra:
        saved[key] = {}
        for v in found:
            verdict = "inside" if v.inside else "OUTSIDE"
            d = 2 if v.unit in ("K", "%") else 1
            rng = f"{v.low:.{d}f} to {v.high:.{d}f}"
            print(f"{v.case:6s} {v.quantity:20s} {v.value:8.{d}f} {v.unit:7s} {rng:>18s} {verdict:8s} {v.source}")
            saved[key][f"{v.case} {v.quantity}"] = {"value": v.value, "low": v.low, "high": v.high, "unit": v.unit,
                                                    "source": SOURCES[v.source], "inside": v.inside}
            if not v.inside:
                outside.append(f"{v.case} {v.quantity}")
        for line in detail:
            print(line)
    hidden = {"programs_solar": not args.solar, "programs_days": not args.days, "programs_monthly": not args.monthly}
    print("sources: " + "; ".join(f"{k}: {t}" for k, t in SOURCES.items() if not hidden.get(k)))
    if args.json:
        text = json.dumps(saved, indent=1).encode()
        atomic_write(args.json, lambda fh: fh.write(text))
    if outside:
        print(f"{len(outside)} figure(s) outside their range: {', '.join(outside)}")
        return 1
    print("every figure inside its range")
    return 0


def _parse_context_boxes(args):
    """``--context-box X,Y,W,D,H`` values, checked: five finite numbers [m], W, D, H > 0."""
    import math
    args.context_boxes = []
    for text in args.context_box:
        try:
            vals = tuple(float(v) for v in text.split(","))
        except ValueError:
            vals = ()
        if len(vals) != 5 or not all(math.isfinite(v) for v in vals):
            raise ValueError(f"--context-box {text!r}: expected X,Y,W,D,H, five numbers in m")
        if not min(vals[2:]) > 0:
            raise ValueError(f"--context-box {text!r}: W, D and H must be > 0 m")
        args.context_boxes.append(vals)


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
    _parse_context_boxes(args)
    for x, y, w, d, h in args.context_boxes:
        meshes.append(trimesh.creation.box((w, d, h)).apply_translation((x + w / 2, y + d / 2, h / 2)))
    return meshes


def _wwr(text):
    """``--wwr``: one ratio for every facade, or one per orientation (each key at most once), in [0, 0.95]."""
    key = {"S": "south", "N": "north", "E": "east", "W": "west"}
    valid = "one number in [0, 0.95] or S=0.4,N=0.2,E=..,W=.. (each of S, N, E, W at most once)"
    try:
        out = float(text)
    except ValueError:
        out = {}
        for item in text.split(","):
            k, sep, v = item.partition("=")
            k = k.strip().upper()
            if not sep or k not in key:
                raise ValueError(f"--wwr {text!r}: {item!r} is not KEY=VALUE with KEY one of S, N, E, W; "
                                 f"expected {valid}") from None
            if key[k] in out:
                raise ValueError(f"--wwr {text!r}: {k} is given twice; expected {valid}") from None
            try:
                out[key[k]] = float(v)
            except ValueError:
                raise ValueError(f"--wwr {text!r}: {k}={v!r} is not a number; expected {valid}") from None
    for v in (out.values() if isinstance(out, dict) else [out]):
        if not 0.0 <= v <= 0.95:
            raise ValueError(f"--wwr {text!r}: {v!r} outside the valid range [0, 0.95]")
    return out


#: The box building's options and their valid ranges (lo, hi, unit, lo included).
LOADS_RANGES = {"width": (0.0, 1000.0, "m", False), "depth": (0.0, 1000.0, "m", False),
                "floor_height": (2.0, 20.0, "m", True), "floors": (1, 200, "", True),
                "overhang": (0.0, 20.0, "m", True), "fins": (0.0, 20.0, "m", True),
                "rotation": (-360.0, 360.0, "deg", True)}


def _check_loads_args(args):
    """Every ``thermal loads`` option checked before any work, each message naming option, value and range."""
    import math
    for name, (lo, hi, unit, closed) in LOADS_RANGES.items():
        v = getattr(args, name)
        if not (math.isfinite(v) and (lo <= v if closed else lo < v) and v <= hi):
            u = f" {unit}" if unit else ""
            raise ValueError(f"--{name.replace('_', '-')} {v!r}: outside the valid range "
                             f"{'[' if closed else '('}{lo:g}, {hi:g}]{u}")
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs {args.jobs}: must be >= 1 (ray-casting processes)")


def _overlap(a, b):
    """True when the convex polygons ``a`` and ``b`` ((N, 2) vertices in order) share interior area (more than
    1 mm of overlap along every axis: blocks that touch do not overlap); separating-axis test."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        for nx, ny in np.column_stack([-edges[:, 1], edges[:, 0]]):
            n = np.hypot(nx, ny)
            if n == 0:
                continue
            pa, pb = a @ np.array([nx, ny]) / n, b @ np.array([nx, ny]) / n
            if min(pa.max(), pb.max()) - max(pa.min(), pb.min()) <= 1e-3:
                return False
    return True


def _convex_hull(pts):
    """The convex hull of 2-D points ``pts`` ((N, 2) [m]) as its vertices in counter-clockwise order (Andrew's
    monotone chain; collinear points dropped). numpy only: scipy is a test and build extra, not installed for users."""
    pts = np.unique(np.asarray(pts, dtype=float), axis=0)  # sorted by x, then y
    if len(pts) < 3:
        return pts

    def chain(points):
        out = []
        for p in points:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(p)
        return out

    lower, upper = chain(pts), chain(pts[::-1])
    return np.array(lower[:-1] + upper[:-1])


def _check_context_boxes(args, building):
    """Refuse a ``--context-box`` that overlaps the building's footprint (after ``--rotation``)."""
    if not args.context_box:
        return
    xy = np.asarray(building.vertices)[:, :2]
    walls = np.unique(np.concatenate([s.faces for s in building.surfaces if s.kind != "shading"]))
    pts = xy[np.unique(np.asarray(building.faces)[walls])]
    foot = _convex_hull(pts)
    for text, (x, y, w, d, _h) in zip(args.context_box, args.context_boxes):
        box = np.array([[x, y], [x + w, y], [x + w, y + d], [x, y + d]])
        if _overlap(box, foot):
            lo, hi = foot.min(axis=0), foot.max(axis=0)
            raise ValueError(f"--context-box {text!r}: the block overlaps the building (its footprint spans x "
                             f"{lo[0]:.1f} to {hi[0]:.1f} m, y {lo[1]:.1f} to {hi[1]:.1f} m): a neighbour must "
                             "stand outside it")


def _loads(args) -> int:
    import pandas as pd
    from widesky.irradiance import read_weather
    from widesky.irradiance.skystate import interval_text
    from widesky.thermal.building import ZoneSpec, box_building
    from widesky.thermal.facade import write_face_csv, write_facade_ply
    from widesky.thermal.loads import building_loads
    from widesky.thermal.study import _constructions, standard_units
    from widesky.thermal.surface import sky_temperature, surface_irradiance

    from widesky.core.atomic import check_output_path
    # every option and output path checked before the weather is read or anything computed
    _check_loads_args(args)
    wwr = _wwr(args.wwr)
    _parse_context_boxes(args)
    if (args.context or args.context_box) and args.sky != "integrator":
        raise ValueError("--context and --context-box need --sky integrator (the weather route "
                         "has no shading)")
    if args.route == "spectral" and args.sky == "weather":
        raise ValueError("--route spectral needs --sky integrator (the weather file has no spectra); "
                         "with --sky weather give --route rated")
    check_output_path(args.output, "--output", (".csv",))
    if args.facade_map:
        check_output_path(args.facade_map, "--facade-map", (".ply",))
        check_output_path(Path(args.facade_map).with_suffix(".csv"), "--facade-map (its .csv beside it)")
    args.weather = _weather_file(args.weather)
    b = box_building(args.width, args.depth, args.floor_height, args.floors, wwr,
                     overhang=args.overhang, fins=args.fins, rotation=args.rotation,
                     zone_use=ZoneSpec("use", air_changes=0.7, internal_gains=10.0 * args.width
                                       * args.depth / 4, cooling_setpoint=26.0))
    _check_context_boxes(args, b)
    context = _context(args)
    w = read_weather(args.weather)
    data = w.data
    lacking = [c for c in ("temp_air", *(("dni", "dhi", "ghi") if args.sky == "weather" else ()))
               if c not in data.columns]
    if lacking:
        raise ValueError(f"--weather {str(args.weather)!r}: the file gives no {', '.join(lacking)} column; "
                         "thermal loads needs temp_air [degC]" + (", and dni, dhi and ghi [W m-2] with --sky weather"
                                                                 if args.sky == "weather" else ""))
    units = standard_units(args.data_dir, solar_control=True)
    unit = units[args.glazing]
    cons = _constructions(args.glazing, unit)
    surf = [s for s in b.surfaces if s.kind != "shading"]
    window_gain = None
    if args.sky == "weather":
        from widesky.irradiance import dni_extra
        sp = w.site.solar_position(data.index, w.label, w.step)
        irr = surface_irradiance([s.tilt for s in surf], [s.azimuth for s in surf],
                                 sp["zenith"].to_numpy(), sp["azimuth"].to_numpy(),
                                 data["dni"].fillna(0).to_numpy(), data["dhi"].fillna(0).to_numpy(),
                                 data["ghi"].fillna(0).to_numpy(),
                                 dni_extra(sp["earth_sun_distance"].to_numpy()), transposition=args.transposition)
    else:
        from widesky.irradiance import Simulation
        from widesky.thermal.gains import (building_scene, front_faces, glazing_response, irradiance_by_surface,
                                           rated_glazing_response, result_in_band_share, window_gain_by_surface)
        from widesky.thermal.glazing import read_solar_spectrum
        scene, labels = building_scene(b, context)
        sim = Simulation(scene, weather=w, n_jobs=args.jobs, progress=sys.stderr.isatty())
        for msg in sim.warnings:
            print(f"widesky: warning: {msg}", file=sys.stderr)
        from widesky.commands.sky_args import warn_if_unmeasured
        warn_if_unmeasured(sim, args.weather)
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
    out.index.name = out.index.name or "time"         # a named first column, not an empty header
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
            annual = res.get("broadband", "global").sum(axis=0) / 1000.0 / result_in_band_share(res)   # broadband
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
          f"{s['solar_kWh']:.0f} kWh, peak cooling {s['peak_cooling_W'] / 1000:.1f} kW in "
          f"{interval_text(s['peak_cooling_time'], w.label, w.step, '%Y-%m-%d %H:%M')} -> {args.output}")
    return 0


def _study(args) -> int:
    from widesky.thermal.facade import write_face_csv
    from widesky.thermal.study import glazing_study
    from widesky.commands.outputs import check_output_folder
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs {args.jobs}: must be >= 1 (ray-casting processes)")
    out = check_output_folder(args.output, "--output")    # created only once the results are ready
    args.weather = _weather_file(args.weather)
    from widesky.irradiance import read_weather
    if "temp_air" not in read_weather(args.weather).data.columns:   # before minutes of ray casting, not after
        raise ValueError(f"--weather {str(args.weather)!r}: the file gives no temp_air column; thermal study needs "
                         "temp_air [degC]")
    from widesky.thermal.study import standard_units
    units = standard_units(args.data_dir, solar_control=args.solar_control)
    r = glazing_study(args.weather, units, n_jobs=args.jobs, progress=sys.stderr.isatty(),
                      data_dir=args.data_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_face_csv(out / "effective_g.csv", r["effective_g"])
    write_face_csv(out / "annual.csv", r["annual"])
    print(r["annual"].round(1).to_string())
    return 0
