"""``widesky pv``: the cell-technology library, spectral PV yield and technology comparison.

Examples::

    widesky pv list
    widesky pv plot-library docs/figures/pvsim_technologies.png
    widesky pv compare roof.obj --lat 50.08 --lon 14.42 --tz 1 --start 2023-01-01 --end 2024-01-01 -o out/
    widesky pv compare roof.obj --weather amsterdam.epw --technology perc --technology cdte --cell mine=eqe.csv -o out/
    widesky pv yield roof.obj --weather denver.epw --technology tandem_2t --two-sided -o series.csv
    widesky pv sweep roof.obj --lat 50.08 --lon 14.42 --start 2023-01-01 --end 2024-01-01 -o sweep.csv

Without ``--weather`` the sky is the dataset's clear sky for every step (an upper bound), with ``--temp-air``
and ``--wind-speed`` constant; with it, every step gets the all-sky model's spectra at the file's measured DNI
and DHI and the cell temperature uses its temp_air and wind_speed (docs/pvsim.md). The sky options and their
defaults are the ones every command shares (:data:`widesky.irradiance.SKY_DEFAULTS`).
"""

from __future__ import annotations

import sys

import numpy as np

from widesky.commands.scene_args import add_reflectance_argument, reflectances
from widesky.commands.sky_args import add_sky_arguments, check_site_arguments, simulation, sky_options
from widesky.pvsim.reference import DEFAULT_REFERENCE, REFERENCE_SPECTRA


def _site_args(p):
    p.add_argument("mesh", nargs="+", help="analysis mesh file(s) (OBJ, PLY, STL, GLB ...): one module group each")
    p.add_argument("--context", action="append", default=[], help="occluding mesh file (repeatable)")
    add_sky_arguments(p)
    p.add_argument("--temp-air", type=float, default=20.0, help="air temperature without --weather [degC]")
    p.add_argument("--wind-speed", type=float, default=1.0, help="wind speed without --weather [m s-1]")
    p.add_argument("--two-sided", action="store_true", help="analyse the rear of every face (bifacial)")
    p.add_argument("--ground-z", type=float, default=None, help="ground height [m] (default: lowest vertex)")
    add_reflectance_argument(p)
    p.add_argument("--tolerance", type=float, default=0.02, help="integrator tolerance [1] (see widesky poa)")
    p.add_argument("--cover-n", type=float, default=1.526, help="cover glass refractive index [1]")
    p.add_argument("--cover-ar", type=float, default=None, help="anti-reflection layer index [1]")
    p.add_argument("--spectral-cover", action="store_true",
                   help="wavelength-dependent cover index (Rubin soda-lime n(lambda))")
    p.add_argument("--temperature-model", choices=("faiman", "pvsyst"), default="faiman",
                   help="cell temperature model (default faiman): Faiman (IEC 61853-2) or PVsyst's U-value model")
    p.add_argument("--dc-loss", type=float, default=0.02, help="DC losses [1]")
    p.add_argument("--dc-ac-ratio", type=float, default=1.2, help="DC rating / inverter input limit [1]")
    p.add_argument("--reference", choices=REFERENCE_SPECTRA, default=DEFAULT_REFERENCE,
                   help=f"STC reference spectrum (default {DEFAULT_REFERENCE}, as in a case file): ASTM G173-03 "
                        "(shipped; --g173 names another copy) or the sky model's own AM1.5G (removes the dataset's "
                        "spectral bias)")
    p.add_argument("--g173", default=None, help="ASTM G173-03 CSV file")
    p.add_argument("--jobs", type=int, default=None, help="ray-casting processes (default: all cores)")


def _tech_args(p, default_all=True):
    p.add_argument("--technology", action="append", default=[],
                   help="preset name (repeatable; default: " + ("all presets" if default_all else "perc") + ")")
    p.add_argument("--cell", action="append", default=[], metavar="NAME[:UNIT]=FILE",
                   help="measured EQE or SR CSV (wavelength_nm,value) as an extra technology, repeatable; UNIT qe "
                        "(EQE [1], the default) or sr [A W-1], as for poa --response, e.g. mine:sr=sr.csv")


def register(subparsers) -> None:
    """Add the ``pv`` command to the ``widesky`` parser."""
    p = subparsers.add_parser("pv", help="spectral PV yield and cell-technology comparison",
                              description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="pv_command", metavar="PV_COMMAND")
    sub.required = True
    s = sub.add_parser("list", help="the technology presets")
    s.set_defaults(func=_list)
    s = sub.add_parser("plot-library", help="EQE of the presets over AM1.5G (PNG)")
    s.add_argument("output", help="PNG file")
    s.add_argument("--technology", action="append", default=[], help="preset name (repeatable; default all)")
    s.set_defaults(func=_plot_library)
    for name, hlp, func in (("compare", "yield of several technologies under the same sky (tables, plots)",
                             _compare),
                            ("yield", "time series of PV yield per module group (CSV)", _yield)):
        s = sub.add_parser(name, help=hlp)
        _site_args(s)
        _tech_args(s, default_all=name == "compare")
        s.add_argument("--group", default=None,
                   help="module group to report: a mesh file's stem (default the first mesh)")
        s.add_argument("-o", "--output", required=True,
                       help="output folder" if name == "compare" else "output CSV")
        s.set_defaults(func=func)
    s = sub.add_parser("sweep", help="2T/4T tandem annual yield against the top-cell band gap (CSV)")
    _site_args(s)
    s.add_argument("--terminals", type=int, choices=(2, 4), default=2,
                   help="tandem connection (default 2): 2-terminal (series, current-matched) or 4-terminal "
                        "(independent sub-cells)")
    s.add_argument("--gaps", default="1.50:1.80:0.02", help="band gaps [eV] as start:stop:step")
    s.add_argument("--group", default=None,
                   help="module group to sweep: a mesh file's stem (default the first mesh)")
    s.add_argument("-o", "--output", required=True, help="output CSV")
    s.set_defaults(func=_sweep)


def _list(args) -> int:
    from widesky.pvsim.module import reference_currents, tandem_stc_efficiency
    from widesky.pvsim.technologies import TECHNOLOGIES, TandemTechnology
    print(f"{'name':12s} {'label':30s} {'Eg [eV]':>9s} {'eta_stc':>8s} {'gamma [%/K]':>11s} "
          f"{'rel200':>7s} {'bifac':>6s} {'Jsc AM1.5G [mA cm-2]':>22s}")
    for n, t in TECHNOLOGIES.items():
        j = reference_currents(t)                       # under the shipped ASTM G173 spectrum
        js = "/".join(f"{v / 10:.1f}" for v in j.values())
        eta = tandem_stc_efficiency(t)
        eg = (f"{t.top.bandgap_ev:.2f}/{t.bottom.bandgap_ev:.2f}" if isinstance(t, TandemTechnology)
              else f"{t.eqe.bandgap_ev:.2f}")
        print(f"{n:12s} {t.label:30s} {eg:>9s} {eta:8.3f} {100 * t.gamma_pdc:11.2f} "
              f"{t.low_irradiance_200:7.3f} {t.bifaciality:6.2f} {js:>22s}")
    return 0


def _plot_library(args) -> int:
    from widesky.core.atomic import check_output_path
    from widesky.pvsim.plots import plot_technologies
    from widesky.pvsim.technologies import get_technology
    check_output_path(args.output, "output", (".png",))
    for n in args.technology:
        try:
            get_technology(n)
        except KeyError as exc:
            raise ValueError(f"--technology {n!r}: {exc.args[0]}") from None
    print(plot_technologies(args.output, args.technology or None))
    return 0


def _technologies(args, default):
    from widesky.pvsim.curves import cell_from_csv
    from widesky.pvsim.technologies import get_technology
    names = args.technology or default
    techs = []
    for n in names:
        try:
            techs.append(get_technology(n))
        except KeyError as exc:
            raise ValueError(f"--technology {n!r}: {exc.args[0]}") from None
    for item in args.cell:
        key, sep, path = item.partition("=")
        name, _, unit = key.partition(":")
        if not sep or not name or not path:
            raise ValueError(f"--cell {item!r}: expected NAME=FILE or NAME:UNIT=FILE (UNIT qe or sr)")
        if not unit and path.endswith((":qe", ":sr")):     # the earlier NAME=FILE:UNIT form
            path, unit = path[:-3], path[-2:]
        unit = unit or "qe"
        if unit not in ("qe", "sr"):
            raise ValueError(f"--cell {item!r}: unit {unit!r} is not one of qe, sr")
        techs.append(_read_cell(item, path, unit, name))
    return techs


def _read_cell(item, path, unit, name):
    """``--cell`` read with :func:`widesky.pvsim.curves.cell_from_csv`; a file that is missing, binary or not a
    two-column table is one line naming the option and the file."""
    from widesky.commands.outputs import check_text_file
    from widesky.pvsim.curves import cell_from_csv
    check_text_file(path, f"--cell {item!r}", "CSV table wavelength_nm,value")
    try:
        return cell_from_csv(path, unit=unit, name=name)
    except (ValueError, UnicodeDecodeError, IndexError, KeyError, TypeError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if "C error:" in msg:          # pandas' tokenizer: say what it means
            msg = (f"cannot read curve file {path!r}: not a table of two comma-separated columns (wavelength_nm,value)"
                   f" ({msg.split('C error:', 1)[1].strip()})")
        if path in msg:
            raise ValueError(f"--cell {item!r}: {msg}") from None
        raise ValueError(f"--cell {item!r}: file {path!r} is not a response table (expected text columns "
                         f"wavelength_nm,value with EQE in [0, 1] or SR in A W-1): {msg}") from None


#: Valid ranges of the numeric options every pv subcommand shares: (lo, hi, unit, lo included).
PV_RANGES = {"cover_n": (1.0, 3.0, "", False), "dc_ac_ratio": (0.1, 10.0, "", True),
             "temp_air": (-90.0, 70.0, "degC", True), "wind_speed": (0.0, 100.0, "m s-1", True),
             "tolerance": (0.0, 1.0, "", False)}


def _groups(args):
    """The module group of each mesh: its file's stem, or the path where two stems are the same."""
    from pathlib import Path
    stems = [Path(m).stem for m in args.mesh]
    return stems if len(set(stems)) == len(stems) else [str(m) for m in args.mesh]


def check_pv_args(args, output_kind):
    """Every option and the output checked before the scene is built or anything computed: each message names
    the option, its value and the valid range. ``output_kind`` is "folder" (pv compare) or "csv"."""
    import math

    from widesky.commands.outputs import check_output_folder
    from widesky.core.atomic import check_output_path
    for name, (lo, hi, unit, closed) in PV_RANGES.items():
        v = getattr(args, name)
        if not (math.isfinite(v) and (lo <= v if closed else lo < v) and v <= hi):
            u = f" {unit}" if unit else ""
            raise ValueError(f"--{name.replace('_', '-')} {v:g}: outside the valid range "
                             f"{'[' if closed else '('}{lo:g}, {hi:g}]{u}")
    if not (math.isfinite(args.dc_loss) and 0.0 <= args.dc_loss < 1.0):
        raise ValueError(f"--dc-loss {args.dc_loss:g}: outside the valid range [0, 1)")
    if args.cover_ar is not None and not (math.isfinite(args.cover_ar) and 1.0 <= args.cover_ar <= args.cover_n):
        raise ValueError(f"--cover-ar {args.cover_ar:g}: outside the valid range [1, --cover-n {args.cover_n:g}]")
    if args.ground_z is not None and not math.isfinite(args.ground_z):
        raise ValueError(f"--ground-z {args.ground_z}: must be a finite height [m]")
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs {args.jobs}: must be >= 1 (ray-casting processes)")
    groups = _groups(args)
    reflectances(args.reflectance, groups)
    if args.group is not None and args.group not in groups:
        raise ValueError(f"--group {args.group!r}: not a module group; valid: {', '.join(groups)} (a mesh "
                         "file's stem)")
    if output_kind == "folder":
        check_output_folder(args.output, "--output")
    else:
        check_output_path(args.output, "--output", (".csv",))
    check_site_arguments(args)
    sky_options(args)


def _setup(args):
    from widesky.commands.scene_args import integrator_settings
    from widesky.irradiance.scene import make_scene
    from widesky.pvsim.system import CoverOptics, SystemSpec
    cover = CoverOptics(n=args.cover_n, n_ar=args.cover_ar, spectral=args.spectral_cover)
    system = SystemSpec(temperature_model=args.temperature_model, dc_loss=args.dc_loss,
                        dc_ac_ratio=args.dc_ac_ratio)
    from widesky.commands.scene_args import check_ground, load_meshes
    groups = _groups(args)
    refl, ctx_refl = reflectances(args.reflectance, groups)
    scene = make_scene(load_meshes(args.mesh, "mesh"), load_meshes(args.context, "--context"), groups=groups,
                       analysis_reflectance=refl, context_reflectance=ctx_refl, ground_z=args.ground_z,
                       two_sided=args.two_sided)
    check_ground(scene, args.ground_z)
    sim = simulation(args, scene, integrator_settings(args))
    return dict(sim=sim, note=sim.description, cover=cover, system=system,
                temp_air=sim.weather_series("temp_air", args.temp_air),
                wind_speed=np.maximum(sim.weather_series("wind_speed", args.wind_speed), 0.0))


def _run_yield(args, techs):
    from widesky.pvsim.stream import simulate
    c = _setup(args)
    sim = c["sim"]
    res, y = simulate(sim.scene, sim.sky_source, technologies=techs, temp_air=c["temp_air"],
                      wind_speed=c["wind_speed"], cover=c["cover"], system=c["system"],
                      reference=None if args.reference == "g173" else "widesky", reference_path=args.g173,
                      keep_currents=False, **sim.integrator_arguments())
    return res, y, c["note"] + ("" if args.reference == "g173" else ", reference: widesky AM1.5G"), sim.input.label


def _compare(args) -> int:
    from widesky.pvsim.compare import summary_text, write_comparison
    from widesky.pvsim.technologies import TECHNOLOGIES
    check_pv_args(args, "folder")
    techs = _technologies(args, list(TECHNOLOGIES))
    res, y, note, label = _run_yield(args, techs)
    paths = write_comparison(y, args.output, args.group, note, label)
    sys.stdout.write(summary_text(y, args.group, note, label))
    print(f"wrote {', '.join(str(p) for p in paths)}")
    return 0


def _yield(args) -> int:
    import pandas as pd
    from widesky.pvsim.compare import _write_text, summary_table
    check_pv_args(args, "csv")
    techs = _technologies(args, ["perc"])
    res, y, note, _ = _run_yield(args, techs)
    g = args.group or y.groups[0]
    if g not in y.groups:
        raise ValueError(f"--group {g!r} not one of {y.groups}")
    frames = {n: ty.series[g] for n, ty in y.technologies.items()}
    df = pd.concat(frames, axis=1) if len(frames) > 1 else next(iter(frames.values()))
    if df.columns.nlevels == 1:                        # one technology: a named first column, not an empty header
        df.index.name = df.index.name or "time"
    _write_text(args.output, df.to_csv(float_format="%.6g"))
    t = summary_table(y, g)
    for n, r in t.iterrows():
        print(f"{r['label']}: {r['ac_kwh']:.1f} kWh AC, {r['specific_yield']:.0f} kWh/kWp, "
              f"PR {r['performance_ratio']:.3f} ({note})")
    print(f"wrote {args.output}")
    return 0


def _sweep(args) -> int:
    from widesky.pvsim.compare import _write_text, bandgap_sweep
    try:
        a, b, st = (float(x) for x in args.gaps.split(":"))
    except ValueError:
        raise ValueError(f"--gaps {args.gaps!r}: expected start:stop:step in eV") from None
    if not (1.5 <= a <= b <= 1.8 and st > 0):
        raise ValueError(f"--gaps {args.gaps!r}: band gaps must lie in [1.5, 1.8] eV with a step > 0")
    gaps = np.round(np.arange(a, b + 1e-9, st), 4)
    check_pv_args(args, "csv")
    c = _setup(args)
    sim = c["sim"]
    df = bandgap_sweep(sim.scene, sim.sky_source, gaps_ev=gaps, terminals=args.terminals, group=args.group,
                       cover=c["cover"], temp_air=c["temp_air"], wind_speed=c["wind_speed"],
                       **sim.integrator_arguments())
    _write_text(args.output, df.to_csv(float_format="%.6g"))
    best = df["dc_kwh_per_m2"].idxmax()
    print(f"{args.terminals}T tandem: annual DC yield peaks at a top gap of {best:.2f} eV "
          f"({df.loc[best, 'dc_kwh_per_m2']:.1f} kWh m-2; STC optimum "
          f"{df['eta_stc'].idxmax():.2f} eV) -> {args.output}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    from widesky.cli import main
    sys.exit(main(["pv", *sys.argv[1:]]))
