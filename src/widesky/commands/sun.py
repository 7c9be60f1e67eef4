"""``widesky sun``: solar position and per-step sky states from the command line.

Examples::

    widesky sun position --lat 39.742476 --lon -105.1786 --altitude 1830.14 \\
        --time "2003-10-17 12:30:30" --tz -7 --pressure 82000 --temperature 11 --delta-t 67
    widesky sun position --lat 52.3 --lon 4.77 --start 2021-06-21 --end 2021-06-22 --step 1h \\
        --tz Europe/Amsterdam
    widesky sun skystates path/to/weather.epw
    widesky sun skystates sample            # the shipped synthetic sample file
"""

from __future__ import annotations

import sys
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd

from widesky.commands.sky_args import check_coerce_year, check_time, local_time
from widesky.irradiance.simulation import SKY_DEFAULTS, weather_path

SAMPLE_WEATHER = Path(str(resources.files("widesky.irradiance.data") / "sample_golden_june.epw"))


def register(subparsers) -> None:
    """Add the ``sun`` command group to the ``widesky`` parser."""
    p = subparsers.add_parser("sun", help="solar position (NREL SPA) and per-step sky states",
                              description="Solar position (NREL SPA) and per-step sky states.")
    sub = p.add_subparsers(dest="sun_command", metavar="SUBCOMMAND")
    sub.required = True

    pos = sub.add_parser("position", help="solar position at given times (CSV to stdout)")
    pos.add_argument("--lat", type=float, required=True, help="latitude [deg], north positive")
    pos.add_argument("--lon", type=float, required=True, help="longitude [deg], east positive")
    pos.add_argument("--altitude", type=float, default=0.0, help="altitude above sea level [m]")
    pos.add_argument("--time", action="append", default=[],
                     help="ISO timestamp (repeatable); naive ones are taken in --tz")
    pos.add_argument("--start", help="period start (with --end and --step)")
    pos.add_argument("--end", help="period end (exclusive)")
    pos.add_argument("--step", default="1h", help="period step, e.g. 1h or 15min")
    pos.add_argument("--label", default="center", choices=("left", "right", "center"),
                     help="what period timestamps label; the sun is taken mid-interval")
    pos.add_argument("--tz", default=None,
                     help="time zone of naive times: IANA name or hours east of UTC (e.g. -7)")
    pos.add_argument("--pressure", type=float, default=None,
                     help="air pressure for refraction [Pa] (default: standard at --altitude)")
    pos.add_argument("--temperature", type=float, default=12.0, help="air temperature [degC]")
    pos.add_argument("--delta-t", type=float, default=None, help="TT - UT [s] (default: estimated)")
    pos.set_defaults(func=_position)

    sky = sub.add_parser("skystates", help="summarise the sky state of every step of a weather file")
    sky.add_argument("weather", help="EPW, TMY3 or CSV weather file, data:weather/<file> (a year shipped with "
                                     "widesky), or 'sample' for the shipped sample")
    sky.add_argument("--coerce-year", type=int, default=None, help="replace the file's years")
    sky.add_argument("--default-visibility", type=float, default=SKY_DEFAULTS.visibility,
                     help=f"visibility where the file gives none [km] (default {SKY_DEFAULTS.visibility:g})")
    sky.add_argument("--default-albedo", type=float, default=SKY_DEFAULTS.albedo,
                     help=f"albedo where the file gives none [1] (default {SKY_DEFAULTS.albedo:g})")
    sky.add_argument("--aerosol", default=SKY_DEFAULTS.aerosol, choices=("aod", "visibility"),
                     help=f"each step's aerosol from the file's aerosol optical depth where valid, or from its "
                          f"station visibility (default {SKY_DEFAULTS.aerosol}, as every command)")
    sky.add_argument("--elevation-step", type=float, default=0.25, help="grouping step [deg]")
    sky.add_argument("--azimuth-step", type=float, default=1.0,
                     help="grouping step [deg]; 0 leaves azimuth out of the key")
    sky.add_argument("--visibility-step", type=float, default=0.02, help="relative grouping step [1]")
    sky.add_argument("--albedo-step", type=float, default=0.01, help="grouping step [1]")
    sky.add_argument("--site-altitude", action="store_true",
                     help="use the site's elevation as the observer altitude (default: on the ground, 0 m)")
    sky.add_argument("--csv", default=None, help="also write the per-step states to this CSV file")
    sky.set_defaults(func=_skystates)


def _tz_arg(tz):
    if tz is None:
        return None
    try:
        return float(tz)
    except ValueError:
        return tz


MAX_POSITIONS = 10_000_000
"""Most solar positions one ``widesky sun position`` computes (about 19 years of minutes; each position
costs about 1 kB of memory while the NREL SPA runs)."""


def _check_period_size(start, end, step):
    """Refuse a period of more than MAX_POSITIONS steps before computing anything (naming the options)."""
    try:
        dt = pd.to_timedelta(step)
    except (ValueError, TypeError, OverflowError):
        raise ValueError(f"--step {step!r}: not a duration; expected a number and a unit, e.g. 1h, 15min "
                         "or 30s") from None
    try:
        t0, t1 = pd.Timestamp(start), pd.Timestamp(end)
    except (ValueError, OverflowError) as exc:
        raise ValueError(f"--start {start!r} / --end {end!r}: {exc}") from None
    if dt <= pd.Timedelta(0):
        raise ValueError(f"--step {step!r}: must be positive")
    n = (t1.tz_localize(None) if t1.tzinfo else t1) - (t0.tz_localize(None) if t0.tzinfo else t0)
    count = n / dt
    if count > MAX_POSITIONS:
        raise ValueError(f"--start {start} --end {end} --step {step}: {count:,.0f} positions, at most "
                         f"{MAX_POSITIONS:,} per command: split the period or use a longer --step")


def _position(args) -> int:
    from widesky.irradiance.location import Site, time_range

    try:
        site = Site(args.lat, args.lon, args.altitude, tz=_tz_arg(args.tz) or "UTC")
    except ValueError as exc:  # name the options, not only the parameters
        raise ValueError(f"--lat/--lon/--altitude/--tz: {exc}") from None
    if args.time and args.start:
        raise ValueError("give either --time or --start/--end, not both")
    if args.time:
        stamps = [check_time("--time", t) for t in args.time]
        if len({t.tzinfo is None for t in stamps}) > 1:
            raise ValueError("--time: give every time with a UTC offset, or none with one (then --tz applies)")
        label = "center"
        if stamps[0].tzinfo is None:
            if args.tz is None:
                raise ValueError("--time values are naive: give --tz (e.g. --tz -7 or --tz Europe/Paris)")
            stamps = [local_time("--time", t, site) for t in stamps]
        times = pd.DatetimeIndex(stamps)
    elif args.start and args.end:
        for option in ("start", "end"):
            t = check_time(f"--{option}", getattr(args, option))
            if t.tzinfo is None:
                local_time(f"--{option}", t, site)
        _check_period_size(args.start, args.end, args.step)
        times = time_range(args.start, args.end, args.step, site.tz, args.label)
        label = args.label
    else:
        raise ValueError("give --time, or --start and --end")
    for option, value in (("--pressure", args.pressure), ("--temperature", args.temperature),
                          ("--delta-t", args.delta_t)):
        if value is not None and not np.isfinite(value):
            raise ValueError(f"{option} {value!r}: must be a finite number")
    try:
        sp = site.solar_position(times, label=label, step=args.step if label != "center" else None,
                                 pressure=args.pressure, temperature=args.temperature,
                                 delta_t=args.delta_t)
    except ValueError as exc:           # the times are checked above: name the refraction option at fault
        named = [o for o, k in (("--pressure", "pressure"), ("--temperature", "temperature"), ("--delta-t", "delta"))
                 if k in str(exc)]
        raise ValueError(f"{'/'.join(named) or 'solar position'}: {exc}") from None
    sp.index.name = "time"
    sp.to_csv(sys.stdout, float_format="%.6f")
    return 0


def _skystates(args) -> int:
    from widesky.irradiance.skystate import GroupingSteps, group_sky_states, sky_states
    from widesky.irradiance.weather import read_weather

    if args.csv:
        from widesky.core.atomic import check_output_path

        check_output_path(args.csv, "--csv", (".csv",))
    for name in ("elevation_step", "visibility_step", "albedo_step"):
        if not getattr(args, name) > 0:
            raise ValueError(f"--{name.replace('_', '-')} {getattr(args, name)!r}: must be > 0")
    if not args.azimuth_step >= 0:
        raise ValueError(f"--azimuth-step {args.azimuth_step!r}: must be >= 0 (0 leaves azimuth out)")
    if not 0 < args.default_visibility <= 1e4:
        raise ValueError(f"--default-visibility {args.default_visibility!r} km outside the valid range (0, 10000] km")
    if not 0 <= args.default_albedo <= 1:
        raise ValueError(f"--default-albedo {args.default_albedo!r} outside the valid range [0, 1]")
    check_coerce_year(args.coerce_year)
    path = SAMPLE_WEATHER if args.weather == "sample" else weather_path(args.weather)
    kwargs = {} if args.coerce_year is None else {"coerce_year": args.coerce_year}
    w = read_weather(path, **kwargs)
    sp = w.solar_position()
    altitude = w.site.altitude if args.site_altitude else 0.0
    states = sky_states(sp, w, altitude=altitude, default_visibility=args.default_visibility,
                        default_albedo=args.default_albedo, prefer=args.aerosol)
    steps = GroupingSteps(elevation=args.elevation_step,
                          azimuth=args.azimuth_step if args.azimuth_step > 0 else None,
                          visibility=args.visibility_step, albedo=args.albedo_step)
    g = group_sky_states(states, steps)
    print(w.summary())
    n = len(states)
    print(f"steps: {n}; sky evaluated (sun above the model's minimum elevation): {g.n_evaluated}; "
          f"with beam: {int(states['has_beam'].sum())}")
    src = states.loc[~states["below_min"], "visibility_source"].value_counts()
    print("visibility source (evaluated steps): " + ", ".join(f"{k}={v}" for k, v in src.items()))
    flags = [c for c in states.columns if c.endswith("_clamped")]
    ev = ~states["below_min"]
    print("clamped to the model's range (evaluated steps): "
          + ", ".join(f"{c[:-8]}={int(states.loc[ev, c].sum())}" for c in flags))
    print(f"grouping {steps}: {g.n_groups} distinct skies for {g.n_evaluated} steps "
          f"(reduction {g.reduction:.2f}x)")
    if args.csv:
        from widesky.core.atomic import atomic_outputs

        with atomic_outputs(args.csv) as (tmp,):
            states.to_csv(tmp, index_label="time")
        print(f"wrote {args.csv}")
    return 0
