"""``widesky gui`` (alias ``widesky explore``): the sky explorer in a browser, served on 127.0.0.1."""

from __future__ import annotations


def register(subparsers) -> None:
    """Add the ``gui`` command to the ``widesky`` parser."""
    p = subparsers.add_parser("gui", aliases=["explore"],
                              help="the sky explorer: a local web page (127.0.0.1 only) showing the sky model",
                              description=__doc__)
    p.add_argument("--dataset", action="append", default=[],
                   help="dataset file (repeatable; default the embedded dataset or $WIDESKY_DATASET)")
    p.add_argument("--dataset-dir", action="append", default=[], metavar="DIR",
                   help="folder whose *.dat dataset files the page may list and open while it runs (repeatable; "
                        "nothing outside these folders can be opened from the page)")
    p.add_argument("--output-dir", default="widesky-explorer",
                   help="folder that 'save' writes PNG/EXR files into (default ./widesky-explorer)")
    p.add_argument("--save-budget", type=float, default=2000.0, metavar="MB",
                   help="most megabytes the page may write in this session (default 2000); a save beyond it "
                        "is refused")
    p.add_argument("--response", action="append", default=[], metavar="NAME[:UNIT]=FILE",
                   help="spectral response CSV (wavelength_nm,value) to integrate the irradiance spectra against; "
                        "UNIT weight (default) or transmittance [1] -> W m-2, sr [A W-1] or qe [1] -> A m-2 "
                        "(e.g. c-Si:sr=csi.csv, low-e:transmittance=glass.csv); repeatable")
    p.add_argument("--wavelength-range", type=float, nargs=2, metavar=("LO", "HI"), default=None,
                   help="load only the channels overlapping LO-HI [nm] (part of a large dataset)")
    p.add_argument("--visibility-range", type=float, nargs=2, metavar=("LO", "HI"), default=None,
                   help="load only the visibility slabs bracketing LO-HI [km]")
    p.add_argument("--albedo-range", type=float, nargs=2, metavar=("LO", "HI"), default=None,
                   help="load only the albedo slabs bracketing LO-HI [1]")
    p.add_argument("--port", type=int, default=8765, help="TCP port on 127.0.0.1 (default 8765; 0 = any free)")
    p.add_argument("--no-browser", action="store_true", help="do not open a browser tab")
    p.add_argument("--threads", type=int, default=0, help="evaluator threads of saves (default 0: all cores)")
    p.add_argument("--view-threads", type=int, default=1,
                   help="evaluator threads of the interactive image and readouts (default 1: the fastest on a "
                        "busy 2-core machine; 0 = all cores)")
    p.set_defaults(func=_run)


UNITS = {"weight": "W m-2", "transmittance": "W m-2", "sr": "A m-2", "qe": "A m-2"}


def parse_response(item, model):
    """``NAME[:UNIT]=FILE`` -> (name, (weights (C,) per channel of ``model``, output unit))."""
    from widesky.irradiance import Response

    key, sep, path = item.partition("=")
    name, _, unit = key.partition(":")
    unit = unit or "weight"
    if not sep or not name or not path:
        raise ValueError(f"--response {item!r}: expected NAME=FILE or NAME:UNIT=FILE")
    if unit not in UNITS:
        raise ValueError(f"--response {item!r}: unit {unit!r} is not one of {', '.join(UNITS)}")
    try:
        r = Response.from_csv(path, name=name, unit=unit)
    except (OSError, ValueError) as exc:
        raise ValueError(f"--response {item!r}: {exc}") from None
    edges = model.channel_edges
    return name, (r.channel_weights(edges[:-1], edges[1:]), UNITS[unit])


def _run(args) -> int:
    from .server import Explorer, serve

    if not 0 <= args.port <= 65535:
        raise ValueError(f"--port {args.port} outside [0, 65535]")
    for opt, value in (("--threads", args.threads), ("--view-threads", args.view_threads)):
        if value < 0:
            raise ValueError(f"{opt} {value}: expected 0 (all cores) or a positive number of threads")
    if not args.save_budget >= 0:
        raise ValueError(f"--save-budget {args.save_budget}: expected megabytes >= 0")
    from pathlib import Path
    for d in args.dataset_dir:
        if not Path(d).is_dir():
            raise ValueError(f"--dataset-dir {d}: not a folder")
    if Path(args.output_dir).exists() and not Path(args.output_dir).is_dir():
        raise ValueError(f"--output-dir {args.output_dir!r} is a file: give a folder (created at the first save)")
    for opt, pair, lo, hi, unit in (("--wavelength-range", args.wavelength_range, 0.0, float("inf"), "nm"),
                                    ("--visibility-range", args.visibility_range, 0.0, float("inf"), "km"),
                                    ("--albedo-range", args.albedo_range, 0.0, 1.0, "[1]")):
        if pair is not None and not (lo <= pair[0] <= pair[1] <= hi and pair[1] < float("inf")):
            where = f"in [{lo:g}, {hi:g}]" if hi < float("inf") else f">= {lo:g}"
            raise ValueError(f"{opt} {pair[0]:g} {pair[1]:g}: expected finite LO <= HI, {where} {unit}")
    part = {k: tuple(v) for k, v in (("wavelength_range", args.wavelength_range),
                                      ("visibility", args.visibility_range), ("albedo", args.albedo_range))
            if v is not None}
    ex = Explorer(args.dataset or None, output_dir=args.output_dir, threads=args.threads, load_options=part,
                  dataset_dirs=args.dataset_dir, save_budget=int(args.save_budget * 1e6), view_threads=args.view_threads)
    for item in args.response:
        name, value = parse_response(item, ex.model(0))
        ex.responses[name] = value
    return serve(ex, args.port, open_browser=not args.no_browser, quiet=True)
