"""The site, period, weather and sky options every simulating command shares (``poa``, ``pv``, ``thermal
loads``), read into one :class:`widesky.irradiance.SkyOptions` and one :class:`widesky.irradiance.Simulation`.

Their defaults are not repeated here: an option the user does not give is None and takes its value from
:data:`widesky.irradiance.SKY_DEFAULTS`, the one table every command, the case files and the API share.
"""

from __future__ import annotations

import math
import sys

from widesky.irradiance.simulation import (AEROSOL_SOURCES, GROUND_SPECTRA, SKY_DEFAULTS, SPECTRAL_MODELS,
                                           Simulation, SkyOptions)

D = SKY_DEFAULTS


def add_sky_arguments(p, *, site=True) -> None:
    """Add the weather / site / period / sky options to the argparse parser ``p``."""
    p.add_argument("--weather", default=None,
                   help="weather file (EPW, TMY3, CSV; or data:weather/<file>, a year shipped with widesky, e.g. "
                        "data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw): site, steps, aerosol, albedo, "
                        "measured DNI/DHI")
    p.add_argument("--coerce-year", type=int, default=None,
                   help="with --weather: move the file's records to this year (typical years mix years; then "
                        "--start/--end select dates of that year)")
    p.add_argument("--clear-sky", action="store_true",
                   help="with --weather: do not scale to the measured DNI/DHI (the clear sky of the file's "
                        "steps: an upper bound)")
    p.add_argument("--spectral-model", default=None, choices=SPECTRAL_MODELS,
                   help=f"with --weather (default {D.spectral_model}): 'allsky' gives each step the all-sky "
                        "model's spectra (cloud spectra, CIE overcast light, haze below the dataset's visibility; "
                        "docs/all-sky.md), 'clear' the clear sky's shape; both keep the measured DNI/DHI")
    p.add_argument("--ground-spectrum", default=None, choices=GROUND_SPECTRA,
                   help=f"with the all-sky model (default {D.ground_spectrum}): the spectrum the ground "
                        "reflects, green vegetation where the albedo is at most 0.3 and no snow is reported, "
                        "or grey")
    p.add_argument("--aerosol", default=None, choices=AEROSOL_SOURCES,
                   help=f"with --weather (default {D.aerosol}): each step's aerosol from the file's aerosol "
                        "optical depth where valid, or from its station visibility")
    p.add_argument("--visibility", type=float, default=None,
                   help=f"visibility [km] without --weather, or where the file gives none (default {D.visibility:g})")
    p.add_argument("--albedo", type=float, default=None,
                   help=f"ground albedo [1] without --weather, or where the file gives none (default {D.albedo:g})")
    if site:
        p.add_argument("--lat", type=float, default=None, help="latitude [deg], north positive")
        p.add_argument("--lon", type=float, default=None, help="longitude [deg], east positive")
        p.add_argument("--site-altitude", type=float, default=0.0, help="site altitude [m]")
        p.add_argument("--tz", default="UTC", help="time zone: IANA name or hours east of UTC")
        p.add_argument("--start", default=None, help="period start (required without --weather)")
        p.add_argument("--end", default=None, help="period end, exclusive (required without --weather)")
        p.add_argument("--step", default="1h", help="step, e.g. 1h or 15min")
    p.add_argument("--dataset", default=None, help="PSM dataset file (default: the embedded dataset)")


def sky_options(args) -> SkyOptions:
    """The command line's sky options on top of :data:`SKY_DEFAULTS` (bad values named with their range)."""
    for name, v, lo, hi in (("--visibility", args.visibility, 0.0, None), ("--albedo", args.albedo, 0.0, 1.0)):
        if v is not None and (not math.isfinite(v) or v < lo or (hi is not None and v > hi)
                              or (name == "--visibility" and v <= 0)):
            rng = f"[{lo:g}, {hi:g}]" if hi is not None else f"> {lo:g}"
            raise ValueError(f"{name} {v}: outside the valid range {rng}")
    weather = getattr(args, "weather", None)
    if args.spectral_model == "allsky" and (weather is None or args.clear_sky):
        raise ValueError("--spectral-model allsky: needs --weather (measured DNI/DHI) and no --clear-sky")
    return D.replace(spectral_model=args.spectral_model, aerosol=args.aerosol, visibility=args.visibility,
                     albedo=args.albedo, ground_spectrum=args.ground_spectrum, dataset=args.dataset,
                     use_measured=False if args.clear_sky else None)


def site(args):
    """The :class:`widesky.irradiance.Site` of ``--lat/--lon/--site-altitude/--tz`` (without ``--weather``)."""
    from widesky.irradiance.location import Site
    missing = [n for n in ("lat", "lon", "start", "end") if getattr(args, n) is None]
    if missing:
        raise ValueError("without --weather, give " + ", ".join("--" + m for m in missing))
    tz = args.tz
    try:
        tz = float(tz)
    except ValueError:
        pass
    return Site(args.lat, args.lon, args.site_altitude, tz=tz)


#: The times pandas represents (nanoseconds since 1970 in 64 bits), padded by a day for time zones.
TIME_RANGE = ("1677-09-23", "2262-04-10")


def check_time(option, text):
    """``text`` as a Timestamp inside :data:`TIME_RANGE`, or one line naming ``option``, the value and the range."""
    import pandas as pd
    lo, hi = (pd.Timestamp(v) for v in TIME_RANGE)
    valid = f"an ISO time from {lo.date()} to {hi.date()}, e.g. 2021-06-21 12:00 or 2021-06-21T12:00+02:00"
    try:
        t = pd.Timestamp(text)
    except (ValueError, OverflowError, TypeError):
        raise ValueError(f"{option} {text!r}: not a time; expected {valid}") from None
    if t is pd.NaT:
        raise ValueError(f"{option} {text!r}: not a time; expected {valid}")
    naive = t.tz_convert(None) if t.tzinfo is not None else t
    if not lo <= naive <= hi:
        raise ValueError(f"{option} {text!r}: outside the supported years; expected {valid}")
    return t.as_unit("ns")


def local_time(option, t, site):
    """The naive time ``t`` in the site's zone; a time skipped or repeated by a daylight-saving change is one
    line naming ``option`` and the time."""
    import pandas as pd
    try:
        return t.tz_localize(site.tz, nonexistent="raise", ambiguous="raise")
    except Exception as exc:  # noqa: BLE001 - pytz / zoneinfo raise their own NonExistent / Ambiguous errors
        kind = ("does not exist there (the clocks jump over it at the daylight-saving change)"
                if "nonexistent" in type(exc).__name__.lower() or "nonexistent" in str(exc).lower()
                else "occurs twice there (the clocks go back at the daylight-saving change)")
        # the zone's UTC offset just before the change, for the example
        before = t - pd.Timedelta(hours=3)
        off = before.tz_localize(site.tz, ambiguous=True, nonexistent="shift_forward").strftime("%z")
        raise ValueError(f"{option} {str(t)!r} in --tz {site.tz}: this local time {kind}; give it with its UTC "
                         f"offset (e.g. {t.strftime('%Y-%m-%dT%H:%M')}{off[:3]}:{off[3:]}) or a fixed --tz in "
                         "hours") from None


def check_coerce_year(year) -> None:
    """``--coerce-year`` inside the years pandas represents (whole years of :data:`TIME_RANGE`)."""
    if year is not None and not 1678 <= year <= 2261:
        raise ValueError(f"--coerce-year {year}: outside the valid range [1678, 2261]")


def check_period(args) -> None:
    """``--start``/``--end`` as times inside :data:`TIME_RANGE` that exist in ``--tz`` (naive ones)."""
    for option in ("start", "end"):
        text = getattr(args, option, None)
        if text is None:
            continue
        t = check_time(f"--{option}", text)
        if t.tzinfo is None and getattr(args, "weather", None) is None:
            local_time(f"--{option}", t, site(args))
    check_coerce_year(getattr(args, "coerce_year", None))


def check_site_arguments(args) -> None:
    """A weather file gives the site: refuse ``--lat``/``--lon`` beside it."""
    if args.weather is not None:
        given = [n for n in ("lat", "lon") if getattr(args, n, None) is not None]
        if given:
            raise ValueError("--weather gives the site: remove " + ", ".join("--" + g for g in given))
    if not math.isfinite(args.site_altitude) or not -500.0 <= args.site_altitude <= 9000.0:
        raise ValueError(f"--site-altitude {args.site_altitude}: outside the valid range [-500, 9000]")
    check_period(args)


def simulation(args, scene, settings, sky_source=None) -> Simulation:
    """The :class:`widesky.irradiance.Simulation` of the command line's scene, site or weather, and sky; its
    warnings (clamped steps) printed to stderr."""
    options = sky_options(args)
    kw = dict(sky=options, settings=settings, n_jobs=args.jobs, progress=sys.stderr.isatty(),
              sky_source=sky_source)
    if args.weather is None:
        sim = Simulation(scene, site=site(args), start=args.start, end=args.end, step=args.step, **kw)
    else:
        sim = Simulation(scene, weather=args.weather, start=args.start, end=args.end,
                         coerce_year=args.coerce_year, **kw)
    for w in sim.warnings:
        print(f"widesky: warning: {w}", file=sys.stderr)
    if args.weather is not None and not args.clear_sky:
        warn_if_unmeasured(sim, args.weather, "; --clear-sky says so on purpose")
    return sim


def warn_if_unmeasured(sim, weather, hint=""):
    """Warn on stderr where a weather file lacks the DNI or DHI column, so that ``sim`` runs on the unscaled clear
    sky (a CSV with a misspelt column did so silently), naming the missing columns and those widesky does not
    know."""
    rows = sim.input.weather
    missing = [c for c in ("dni", "dhi") if rows is not None and c not in rows.columns]
    if sim.input.measured is None and missing:
        from widesky.irradiance.weather import WEATHER_COLUMNS
        others = [str(c) for c in rows.columns if str(c) not in WEATHER_COLUMNS]
        print(f"widesky: warning: weather file {str(weather)!r} gives no {' and no '.join(missing)} column: "
              f"the clear sky of its steps is used, not scaled to measurements (an upper bound{hint})"
              + (f"; columns widesky does not know: {', '.join(others)}" if others else ""),
              file=sys.stderr)
