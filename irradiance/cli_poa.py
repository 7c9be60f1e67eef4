"""``widesky poa``: per-face plane-of-array irradiance for a mesh, a site and a period.

Examples::

    widesky poa roof.obj --context city.glb --lat 50.08 --lon 14.42 --tz Europe/Prague \\
        --start 2023-01-01 --end 2024-01-01 --step 1h --visibility 40 --albedo 0.2 -o poa.h5
    widesky poa roof.obj --weather prague.epw --response c-Si=csi_sr.csv -o poa.csv

Mesh coordinates are metres east, north, up (e.g. UTM). Without ``--weather`` the sky is the clear
sky of the dataset for every step of the period. With ``--weather`` (EPW, TMY3 or a CSV with pvlib
column names) the site, the steps, and per-step visibility (or aerosol optical depth) and albedo come
from the file, and the clear sky is scaled per step to the file's measured DNI and DHI (docs/
time-and-weather.md; ``--clear-sky`` keeps the clear sky); ``--start``/``--end`` select a part of the
file. ``--response NAME=FILE`` (repeatable, names unique) reads a spectral response
(:meth:`irradiance.Response.from_csv`: columns ``wavelength_nm,value``; ``--response-unit`` sr,
qe, transmittance or weight), band-averaged over each 40 nm channel; its parts are added.

Output by suffix: ``.h5``/``.hdf5`` the full result (:class:`irradiance.POAResult`, per face, step,
response and part; streamed to the file during the run, :meth:`POAResult.load` reads it), or
``.csv`` the area-weighted mean of every part per face group (or of one ``--group``). Outputs are
written atomically; the output folder is checked before any computation.
"""

from __future__ import annotations

import sys

import numpy as np


def add_site_options(p, spectral_model="clear", aerosol="visibility"):
    """The site, period and weather options shared by ``widesky poa`` and ``widesky pv`` (argparse
    parser ``p``); ``spectral_model`` and ``aerosol`` are the defaults of ``--spectral-model`` and
    ``--aerosol`` under a weather file."""
    p.add_argument("--weather", default=None,
                   help="weather file (EPW, TMY3, CSV): site, steps, visibility/AOD, albedo, measured DNI/DHI")
    p.add_argument("--clear-sky", action="store_true",
                   help="with --weather: do not scale the clear sky to the measured DNI/DHI")
    p.add_argument("--spectral-model", default=spectral_model, choices=("clear", "allsky"),
                   help=f"with --weather (default {spectral_model or 'allsky where the input data directory is available (WIDESKY_DATA_DIR), else clear'}): 'clear' keeps the clear sky's spectral and "
                        "angular shape, 'allsky' the all-sky model (cloud spectra, CIE overcast light, haze "
                        "below the dataset's visibility; docs/all-sky.md); the same measured DNI/DHI")
    p.add_argument("--ground-spectrum", default="vegetation", choices=("vegetation", "grey"),
                   help="with --spectral-model allsky (default vegetation): the spectrum of light the ground "
                        "reflects, green vegetation where the albedo is at most 0.3 and no snow is reported "
                        "(the weather's broadband albedo kept), or grey (docs/all-sky.md)")
    p.add_argument("--aerosol", default=aerosol, choices=("visibility", "aod"),
                   help=f"with --weather (default {aerosol}): the aerosol of each step from the file's station "
                        "visibility or its aerosol optical depth column where valid (recommended with "
                        "--spectral-model allsky, docs/all-sky.md)")
    p.add_argument("--lat", type=float, default=None, help="latitude [deg], north positive")
    p.add_argument("--lon", type=float, default=None, help="longitude [deg], east positive")
    p.add_argument("--site-altitude", type=float, default=0.0, help="site altitude [m]")
    p.add_argument("--tz", default="UTC", help="time zone: IANA name or hours east of UTC")
    p.add_argument("--start", default=None, help="period start (required without --weather)")
    p.add_argument("--end", default=None, help="period end, exclusive (required without --weather)")
    p.add_argument("--step", default="1h", help="step, e.g. 1h or 15min")


def register(subparsers) -> None:
    """Add the ``poa`` command to the ``widesky`` parser."""
    p = subparsers.add_parser("poa", help="per-face plane-of-array irradiance on a 3D mesh",
                              description=__doc__.split("\n\n")[0])
    p.add_argument("mesh", nargs="+", help="analysis mesh file(s) (OBJ, PLY, STL, GLB ...)")
    p.add_argument("--context", action="append", default=[], help="occluding mesh file (repeatable)")
    add_site_options(p, spectral_model="clear", aerosol="visibility")
    p.add_argument("--visibility", type=float, default=50.0,
                   help="visibility [km] (with --weather: where the file gives none)")
    p.add_argument("--albedo", type=float, default=0.2,
                   help="ground albedo [1] (with --weather: where the file gives none)")
    p.add_argument("--response", action="append", default=[], metavar="NAME=FILE",
                   help="spectral response CSV (wavelength_nm,value); repeatable, unique names")
    p.add_argument("--response-unit", default="sr", choices=("sr", "qe", "transmittance", "weight"),
                   help="unit of the --response values: sr [A W-1] (default), qe [1], "
                        "transmittance [1], weight [1]")
    p.add_argument("--ground-z", type=float, default=None, help="ground height [m] (default: lowest vertex)")
    p.add_argument("--dataset", default=None, help="PSM dataset file (default: embedded)")
    p.add_argument("--tolerance", type=float, default=0.02,
                   help="target relative annual error per face [1]: picks the cheapest preset measured "
                        "below it (docs/irradiance-integrator.md); 0.02 = the default settings")
    p.add_argument("--samples-per-face", type=int, default=1, help="points per face (1, 4, 9 ...)")
    p.add_argument("--two-sided", action="store_true", help="also analyse the back of every face")
    p.add_argument("--jobs", type=int, default=None, help="ray-casting processes (default: all cores)")
    p.add_argument("--group", default=None, help="with a .csv output: only this face group")
    p.add_argument("-o", "--output", required=True,
                   help="output: .h5/.hdf5 (full result per face) or .csv (per face group)")
    p.set_defaults(func=_run)


#: Longest run the CLI starts [steps] (about 10 years of 5-minute steps); split longer periods.
MAX_STEPS = 1_000_000
OUTPUT_SUFFIXES = (".h5", ".hdf5", ".csv")


def _output_kind(path):
    """"h5" or "csv" from the output's suffix; checks that its folder exists and is writable."""
    import os
    low = str(path).lower()
    kind = "h5" if low.endswith((".h5", ".hdf5")) else "csv" if low.endswith(".csv") else None
    if kind is None:
        raise ValueError(f"--output {path!r}: unknown suffix; valid: {', '.join(OUTPUT_SUFFIXES)} "
                         "(HDF5 result per face, or CSV per face group)")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ValueError(f"--output {path!r}: folder {folder!r} does not exist")
    if not os.access(folder, os.W_OK):
        raise ValueError(f"--output {path!r}: folder {folder!r} is not writable")
    return kind


def _check_args(args):
    """Bad input refused before any work, each message naming the option, value and valid range."""
    import math
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs {args.jobs}: must be >= 1 (ray-casting processes)")
    if args.spectral_model == "allsky" and (args.weather is None or args.clear_sky):
        raise ValueError("--spectral-model allsky: needs --weather (measured DNI/DHI) and no --clear-sky")
    if args.ground_z is not None and not math.isfinite(args.ground_z):
        raise ValueError(f"--ground-z {args.ground_z}: must be a finite height [m]")
    for name, v, lo, hi in (("--visibility", args.visibility, 0.0, None),
                            ("--albedo", args.albedo, 0.0, 1.0),
                            ("--site-altitude", args.site_altitude, -500.0, 9000.0),
                            ("--tolerance", args.tolerance, 0.0, None)):
        if not math.isfinite(v) or v < lo or (hi is not None and v > hi) or (
                name in ("--visibility", "--tolerance") and v <= 0):
            rng = f"[{lo:g}, {hi:g}]" if hi is not None else f"> {lo:g}"
            raise ValueError(f"{name} {v}: outside the valid range {rng}")
    if args.weather is not None:
        given = [n for n in ("lat", "lon") if getattr(args, n) is not None]
        if given:
            raise ValueError("--weather gives the site: remove " + ", ".join("--" + g for g in given))
    if args.group is not None and not str(args.output).lower().endswith(".csv"):
        raise ValueError("--group selects a face group of a .csv output")


def _responses(args):
    from .response import Response
    out, names = [], set()
    for item in args.response:
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            raise ValueError(f"--response {item!r}: expected NAME=FILE")
        if name in names or name == "broadband":
            raise ValueError(f"--response {item!r}: the name {name!r} is "
                             + ("given twice" if name in names else "reserved (always computed)"))
        names.add(name)
        out.append(Response.from_csv(path, name=name, unit=args.response_unit))
    return out


def _period_steps(args):
    """Steps of the clear-sky period, estimated before anything is allocated."""
    import pandas as pd
    try:
        step = pd.Timedelta(args.step)
        span = pd.Timestamp(args.end) - pd.Timestamp(args.start)
    except (ValueError, TypeError) as e:
        raise ValueError(f"--start/--end/--step: {e}") from None
    if step <= pd.Timedelta(0):
        raise ValueError(f"--step {args.step}: must be positive")
    return int(span / step)


def _refuse_huge(n_steps, n_faces, n_responses, what):
    from .poa import estimate_run
    if n_steps <= MAX_STEPS:
        return
    out_bytes, _ = estimate_run(n_faces, n_steps, n_responses)
    # measured on the 20,000-face benchmark (docs/irradiance-integrator.md): about 26 s for
    # 20,000 faces x 4,444 daylight steps x 3 responses on 2 quiet cores, i.e. 1e-7 s per face,
    # daylight step and response; half the steps are daylight
    secs = 1e-7 * n_faces * n_steps * 0.5 * (n_responses + 1)
    raise ValueError(f"{what}: {n_steps:,} steps x {n_faces:,} faces would write about "
                     f"{out_bytes / 1e9:,.0f} GB and take about {secs / 3600:,.1f} h; the CLI "
                     f"runs at most {MAX_STEPS:,} steps: split the period")


def _steps(args, sky):
    """(SkyStates, measured (dni, dhi) or None, note) for the period or the weather file."""
    from .location import Site
    from .skystate import sky_states_for
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
        states = sky_states_for(site, args.start, args.end, args.step, model=sky.model,
                                visibility=args.visibility, albedo=args.albedo, label="left")
        return states, None, "clear sky"
    wd = read_weather(args.weather)
    states = sky_states_for(wd, args.start, args.end, model=sky.model,
                            visibility=args.visibility, albedo=args.albedo, prefer=args.aerosol)
    note = f"weather {args.weather} ({wd.site.latitude:.3f}, {wd.site.longitude:.3f})"
    from .allsky_sky import weather_measurements
    measured, how = weather_measurements(wd.data.loc[states.times], args.spectral_model, args.aerosol,
                                         args.clear_sky)
    return states, measured, f"{note}, {how}"


def _write_csv(res, path, group=None):
    """Area-weighted mean of every response's parts per face group, written atomically."""
    import os
    import tempfile

    import pandas as pd

    from skymodel.outputs import plain_mode
    agg = res.aggregate()
    groups = list(enumerate(res.group_names))
    if group is not None:
        if group not in res.group_names:
            raise ValueError(f"--group {group!r}: not one of {res.group_names}")
        groups = [(res.group_names.index(group), group)]
    cols = {}
    for r in res.responses:
        for p in ("global", "direct", "sky_diffuse", "ground_diffuse"):
            for g, name in groups:
                cols[f"{name}:{r}:poa_{p}"] = agg[f"{r}:{p}"][:, g]
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".csv", dir=folder)
    os.close(fd)
    plain_mode(tmp)
    try:
        pd.DataFrame(cols, index=res.times).to_csv(tmp)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def _run(args) -> int:
    import warnings

    from .allsky import AllSkyOptions
    from .integrator import IntegratorSettings
    from .poa import poa_irradiance
    from .scene import make_scene
    from .skies import PragueSky

    _check_args(args)
    kind = _output_kind(args.output)
    responses = _responses(args)
    if args.weather is None and args.start is not None and args.end is not None:
        _refuse_huge(_period_steps(args), 1, len(responses), f"--start {args.start} --end "
                     f"{args.end} --step {args.step}")
    sky = PragueSky(args.dataset)
    scene = make_scene(args.mesh, args.context, groups=[str(m) for m in args.mesh],
                       ground_z=args.ground_z, samples_per_face=args.samples_per_face,
                       two_sided=args.two_sided)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        states, measured, note = _steps(args, sky)
    for w in caught:
        print(f"widesky: warning: {w.message}", file=sys.stderr)
    _refuse_huge(len(states), scene.n_faces, len(responses), "the run")
    res = poa_irradiance(scene, sky, states, responses=responses,
                         settings=IntegratorSettings.for_tolerance(args.tolerance),
                         measured=measured, n_jobs=args.jobs, progress=sys.stderr.isatty(),
                         spectral_model=args.spectral_model if measured is not None else "clear",
                         allsky_options=AllSkyOptions(ground=args.ground_spectrum),
                         output=args.output if kind == "h5" else None,
                         provenance={"command": "widesky poa " + " ".join(sys.argv[2:])})
    if kind == "csv":
        _write_csv(res, args.output, args.group)
    if res.scaling is not None:
        lit = states.sun_elevation > 0
        n_g = int(np.sum(res.scaling.sun_guarded | res.scaling.sky_guarded))
        note += f" ({n_g} of {int(lit.sum())} daylight steps guarded or missing)"
    n_c = states.n_clamped
    if n_c:
        note += ", clamped: " + ", ".join(f"{k} {v}" for k, v in n_c.items())
    tm = res.timings
    print(f"{scene.n_faces} faces x {len(states)} steps ({note}): rays {tm['rays']:.1f} s "
          f"({tm['n_rays'] / 1e6:.1f} M), sky {tm['sky']:.1f} s, products {tm['product']:.1f} s "
          f"-> {args.output}")
    res.close()
    return 0
