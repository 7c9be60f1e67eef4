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
    p.add_argument("--tolerance", type=float, default=0.02, help="integrator tolerance [1] (see widesky poa)")
    p.add_argument("--cover-n", type=float, default=1.526, help="cover glass refractive index [1]")
    p.add_argument("--cover-ar", type=float, default=None, help="anti-reflection layer index [1]")
    p.add_argument("--spectral-cover", action="store_true",
                   help="wavelength-dependent cover index (Rubin soda-lime n(lambda))")
    p.add_argument("--temperature-model", choices=("faiman", "pvsyst"), default="faiman")
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
    p.add_argument("--cell", action="append", default=[], metavar="NAME=FILE[:qe|sr]",
                   help="measured EQE (default) or SR [A W-1] CSV as an extra technology (repeatable)")


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
    s.add_argument("--terminals", type=int, choices=(2, 4), default=2)
    s.add_argument("--gaps", default="1.50:1.80:0.02", help="band gaps [eV] as start:stop:step")
    s.add_argument("--group", default=None)
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
    from widesky.pvsim.plots import plot_technologies
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
            raise ValueError(str(exc.args[0])) from None
    for item in args.cell:
        name, sep, rest = item.partition("=")
        if not sep or not name or not rest:
            raise ValueError(f"--cell {item!r}: expected NAME=FILE[:qe|sr]")
        path, unit = rest, "qe"
        if rest.endswith((":qe", ":sr")):
            path, unit = rest[:-3], rest[-2:]
        techs.append(cell_from_csv(path, unit=unit, name=name))
    return techs


def _setup(args):
    from widesky.irradiance.integrator import IntegratorSettings
    from widesky.irradiance.scene import make_scene
    from widesky.pvsim.system import CoverOptics, SystemSpec
    check_site_arguments(args)
    sky_options(args)
    if args.cover_ar is not None and not 1.0 <= args.cover_ar <= args.cover_n:
        raise ValueError(f"--cover-ar={args.cover_ar} outside the valid range [1, --cover-n={args.cover_n}]")
    cover = CoverOptics(n=args.cover_n, n_ar=args.cover_ar, spectral=args.spectral_cover)
    system = SystemSpec(temperature_model=args.temperature_model, dc_loss=args.dc_loss,
                        dc_ac_ratio=args.dc_ac_ratio)
    from pathlib import Path
    stems = [Path(m).stem for m in args.mesh]
    groups = stems if len(set(stems)) == len(stems) else [str(m) for m in args.mesh]
    scene = make_scene(args.mesh, args.context, groups=groups, ground_z=args.ground_z, two_sided=args.two_sided)
    sim = simulation(args, scene, IntegratorSettings.for_tolerance(args.tolerance))
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
    return res, y, c["note"] + ("" if args.reference == "g173" else ", reference: widesky AM1.5G")


def _compare(args) -> int:
    from widesky.pvsim.compare import summary_text, write_comparison
    from widesky.pvsim.technologies import TECHNOLOGIES
    techs = _technologies(args, list(TECHNOLOGIES))
    res, y, note = _run_yield(args, techs)
    paths = write_comparison(y, args.output, args.group, note)
    sys.stdout.write(summary_text(y, args.group, note))
    print(f"wrote {', '.join(str(p) for p in paths)}")
    return 0


def _yield(args) -> int:
    import pandas as pd
    from widesky.pvsim.compare import _write_text, summary_table
    techs = _technologies(args, ["perc"])
    res, y, note = _run_yield(args, techs)
    g = args.group or y.groups[0]
    if g not in y.groups:
        raise ValueError(f"--group {g!r} not one of {y.groups}")
    frames = {n: ty.series[g] for n, ty in y.technologies.items()}
    df = pd.concat(frames, axis=1) if len(frames) > 1 else next(iter(frames.values()))
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
