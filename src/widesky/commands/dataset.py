"""``widesky dataset ...``: build the default dataset from the reference solver, compress channels, write synthetic
datasets."""

from __future__ import annotations

import numpy as np


def register(sub):
    ds = sub.add_parser("dataset", help="build, compress and synthesise sky-model datasets",
                        description="Sky-model datasets: build one from the reference solver (widesky dataset build), "
                                    "choose the channels to keep (compress), or write a synthetic one for tests "
                                    "(synthetic).")
    dsub = ds.add_subparsers(dest="dataset_command", metavar="SUBCOMMAND")
    dsub.required = True
    s = dsub.add_parser("synthetic", help="write a synthetic dataset (for tests and benchmarks; not a physical sky)")
    s.add_argument("output", help="dataset file to write, .dat (its folder must exist)")
    s.add_argument("--visibilities", default="20,60,131.8", help="comma-separated [km]")
    s.add_argument("--albedos", default="0,0.5,1", help="comma-separated [1]")
    s.add_argument("--altitudes", default="0", help="comma-separated [m]")
    s.add_argument("--elevations", type=int, default=12, help="number of solar elevations (-4.2..90 deg), >= 3")
    s.add_argument("--channels", type=int, default=55, help="40 nm channels from 280 nm (1..55)")
    s.add_argument("--rank", type=int, default=4, help="radiance rank (1..64)")
    s.add_argument("--knots", default="24,24,16", help="sun,zenith,emphasis knot counts")
    s.add_argument("--polarisation", action="store_true", help="also write polarisation sections")
    s.add_argument("--seed", type=int, default=0, help="random seed of the synthetic coefficients (default 0)")
    s.set_defaults(func=_synthetic)

    b = dsub.add_parser("build", help="build a PSM-format dataset from the reference solver (resumable; needs the "
                                      "[build] extra and the input data directory)")
    b.add_argument("config", help="build configuration (JSON or TOML), e.g. skymodel/data/default-dataset.json")
    b.add_argument("-o", "--output", required=True, help="dataset file to write, .dat (+ <file>.json sidecar)")
    b.add_argument("--processes", type=int, default=2, help="worker processes over sky states (default 2)")
    b.add_argument("--solve-only", action="store_true", help="only solve (and cache) the sky states")
    b.add_argument("--no-validation", action="store_true", help="skip the held-out error report")
    b.add_argument("--data-dir", default=None, help="input data directory (default: see docs/atmosphere-and-solver.md)")
    b.add_argument("--quiet", action="store_true", help="no progress bars")
    b.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the sky states on this Dask scheduler (e.g. tcp://127.0.0.1:8786) instead of processes")
    b.set_defaults(func=_build)

    c = dsub.add_parser("compress", help="greedy channel omission: write the list of channels to keep")
    c.add_argument("dataset", help="dataset file")
    c.add_argument("--max-error", type=float, default=0.15,
                   help="largest relative error of an interpolated channel [1] (default 0.15)")
    c.add_argument("--keep-first", type=int, default=12, help="channels always kept (default 12: 280-760 nm)")
    c.add_argument("--quantile", type=float, default=1.0,
                   help="error statistic over samples: 1 = maximum (default), 0.99 = 99th percentile")
    c.add_argument("--directions", type=int, default=400, help="random sky directions per configuration (default 400)")
    c.add_argument("--seed", type=int, default=0, help="random seed of the sampled directions (default 0)")
    c.add_argument("-o", "--output", default=None, help="channel list, .json; default <dataset>.channels.json")
    c.set_defaults(func=_compress)


def _floats(text, option, lo=-np.inf, hi=np.inf, unit=""):
    """A comma-separated, strictly ascending list of numbers in [lo, hi] for ``option``."""
    try:
        vals = tuple(float(x) for x in str(text).split(",") if x.strip())
    except ValueError:
        raise ValueError(f"{option} {text!r}: expected comma-separated numbers") from None
    u = f" {unit}" if unit else ""
    if not vals:
        raise ValueError(f"{option} {text!r}: expected at least one value")
    bad = [v for v in vals if not lo <= v <= hi]
    if bad:
        raise ValueError(f"{option} {text!r}: {bad[0]!r}{u} outside the valid range [{lo:g}, {hi:g}]{u}")
    if any(b <= a for a, b in zip(vals, vals[1:])):
        raise ValueError(f"{option} {text!r}: values must be strictly ascending")
    return vals


def _count(value, option, lo, hi):
    if not lo <= value <= hi:
        raise ValueError(f"{option} {value}: outside the valid range [{lo}, {hi}]")
    return int(value)


def _synthetic(args):
    from widesky.skymodel.dataset import SPECTRAL_RANGE, load_dataset
    from widesky.core.atomic import check_output_path
    from widesky.skymodel.synthetic import write_synthetic_dataset

    # every option is checked before anything is written
    vis = _floats(args.visibilities, "--visibilities", 1e-3, 1e4, "km")
    alb = _floats(args.albedos, "--albedos", 0.0, 1.0)
    alt = _floats(args.altitudes, "--altitudes", 0.0, 1e5, "m")
    n = _count(args.elevations, "--elevations", 3, 1000)
    max_ch = int((SPECTRAL_RANGE[1] - 280.0) // 40.0)
    _count(args.channels, "--channels", 1, max_ch)
    _count(args.rank, "--rank", 1, 64)
    try:
        ns, nz, ne = (int(x) for x in args.knots.split(","))
    except ValueError:
        raise ValueError(f"--knots {args.knots!r}: expected three integers sun,zenith,emphasis") from None
    for k in (ns, nz, ne):
        _count(k, "--knots (each)", 2, 4096)
    check_output_path(args.output, "output", (".dat",))
    elev = np.concatenate([[-4.2, 0.0], np.geomspace(1.0, 90.0, n - 2)])
    path = write_synthetic_dataset(args.output, visibilities=vis, albedos=alb, altitudes=alt,
                                   elevations=tuple(elev), n_channels=args.channels, rank=args.rank, n_sun=ns,
                                   n_zen=nz, n_emph=ne, polarisation=args.polarisation, seed=args.seed)
    print(load_dataset(path).describe())
    return 0


def _build(args):
    import os
    import time

    from widesky.skymodel.generator.dataset_build import build_dataset, load_config, solve_all

    def log(msg):
        print(time.strftime("%H:%M:%S"), msg, flush=True)

    from widesky.core.atomic import check_output_path

    if not args.solve_only:
        check_output_path(args.output, "--output", (".dat",))      # before hours of solving, not after
    if args.processes < 1:
        raise ValueError(f"--processes {args.processes}: must be >= 1")
    cfg = load_config(args.config)
    if args.scheduler is not None:
        from widesky.skymodel.generator.dask_scheduler import SCHEDULER_ENV, check_address

        os.environ[SCHEDULER_ENV] = check_address(args.scheduler)
    if args.solve_only:
        n, secs = solve_all(cfg, args.processes, not args.quiet, not args.no_validation, log)
        log(f"solved {n} states in {secs:.0f} s")
        return 0
    meta = build_dataset(cfg, args.output, args.processes, not args.quiet, not args.no_validation, log,
                         args.data_dir)
    log(f"wrote {args.output} ({meta['file_bytes'] / 1e6:.1f} MB) in {meta['build_seconds']:.0f} s")
    if "errors" in meta and "all" in meta["errors"]:
        e = meta["errors"]["all"]
        log(f"held-out NMAE, mean over channels and states: {100 * e['nmae_channel_mean']:.2f} %; "
            f"targets: {e['targets']}")
    return 0


def _compress(args):
    from widesky.skymodel.compress import greedy_omission, omission_errors, radiance_samples, write_channel_list
    from widesky.skymodel.dataset import load_dataset

    from widesky.core.atomic import check_output_path

    out = args.output or str(args.dataset) + ".channels.json"
    check_output_path(out, "--output", (".json",))
    if not 0.0 < args.max_error < 10.0:
        raise ValueError(f"--max-error {args.max_error!r}: outside the valid range (0, 10)")
    if not 0.0 < args.quantile <= 1.0:
        raise ValueError(f"--quantile {args.quantile!r}: outside the valid range (0, 1]")
    if args.directions < 10:
        raise ValueError(f"--directions {args.directions}: at least 10")
    model = load_dataset(args.dataset)
    if not 0 <= args.keep_first <= model.n_channels:
        raise ValueError(f"--keep-first {args.keep_first}: outside the valid range [0, {model.n_channels}]")
    y = radiance_samples(model, args.directions, args.seed)
    kept = greedy_omission(y, model.wavelengths, args.max_error, args.keep_first, quantile=args.quantile)
    err = omission_errors(y, model.wavelengths, kept, quantile=args.quantile)
    write_channel_list(out, kept, model.wavelengths, args.max_error, args.dataset, args.quantile)
    saved = 1.0 - kept.size / model.n_channels
    print(f"kept {kept.size} of {model.n_channels} channels (radiance data {100 * saved:.0f} % smaller); "
          f"largest interpolation error {100 * err.max():.1f} %; wrote {out}")
    print("kept centres [nm]: " + " ".join(f"{w:g}" for w in model.wavelengths[kept]))
    return 0
