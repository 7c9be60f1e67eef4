"""``widesky gui`` (alias ``widesky explore``): the sky explorer in a browser, served on 127.0.0.1."""

from __future__ import annotations


def register(subparsers) -> None:
    """Add the ``gui`` command to the ``widesky`` parser."""
    p = subparsers.add_parser("gui", aliases=["explore"],
                              help="the sky explorer: a local web page (127.0.0.1 only) showing the sky model",
                              description=__doc__)
    p.add_argument("--dataset", action="append", default=[],
                   help="dataset file (repeatable; default the embedded dataset or $WIDESKY_DATASET)")
    p.add_argument("--output-dir", default="widesky-explorer",
                   help="folder that 'save' writes PNG/EXR files into (default ./widesky-explorer)")
    p.add_argument("--response", action="append", default=[], metavar="NAME=FILE",
                   help="spectral response CSV (wavelength [nm], response [1]) to integrate the irradiance "
                        "spectra against, e.g. a cell SR or a glazing transmittance; repeatable")
    p.add_argument("--port", type=int, default=8765, help="TCP port on 127.0.0.1 (default 8765; 0 = any free)")
    p.add_argument("--no-browser", action="store_true", help="do not open a browser tab")
    p.add_argument("--threads", type=int, default=0, help="evaluator threads (default 0: all cores)")
    p.set_defaults(func=_run)


def _run(args) -> int:
    from irradiance.cli_poa import read_response

    from .server import Explorer, serve

    if not 0 <= args.port <= 65535:
        raise ValueError(f"--port {args.port} outside [0, 65535]")
    ex = Explorer(args.dataset or None, output_dir=args.output_dir, threads=args.threads)
    for item in args.response:
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            raise ValueError(f"--response {item!r}: expected NAME=FILE")
        ex.responses[name] = read_response(path, ex.model(0).wavelengths)
    return serve(ex, args.port, open_browser=not args.no_browser, quiet=True)
