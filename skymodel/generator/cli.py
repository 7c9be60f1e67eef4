"""``widesky solver ...``: solve a sky state, run the validations, refit the gas band model (the reference
solver's tools; ``widesky dataset build`` builds a dataset with it)."""

from __future__ import annotations

import json

import numpy as np

from . import report
from .gases import SHIPPED_FILE, fit_gas_kdistributions
from .solver import AtmosphereSpec, SkyState, SolverConfig, solve_sky


def register(subparsers):
    """Add the ``solver`` command group to the ``widesky`` parser."""
    p = subparsers.add_parser("solver", help="the reference solver behind the datasets: solve a sky state, "
                                             "validate, refit the gas model",
                              description="The physical atmosphere and reference radiative-transfer solver that "
                                          "datasets are built from: solve one sky state, run the validation cases, "
                                          "refit the gas band model. To build a dataset: widesky dataset build.")
    sub = p.add_subparsers(dest="build_command", metavar="SUBCOMMAND")
    sub.required = True

    s = sub.add_parser("solve", help="solve one sky state for all channels and print irradiances")
    s.add_argument("--elevation", type=float, required=True, help="solar elevation [deg]")
    g = s.add_mutually_exclusive_group(required=True)
    g.add_argument("--visibility", type=float, help="visibility [km]")
    g.add_argument("--aod550", type=float, help="aerosol optical depth at 550 nm [1]")
    g.add_argument("--aod500", type=float, help="aerosol optical depth at 500 nm [1]")
    s.add_argument("--albedo", type=float, default=0.2, help="ground albedo [1]")
    s.add_argument("--profile", default="us", help="AFGL profile (us, t, ms, mw, ss, sw)")
    s.add_argument("--water", type=float, default=None, help="precipitable water [cm]")
    s.add_argument("--ozone", type=float, default=None, help="ozone column [DU]")
    s.add_argument("--aerosol", default="continental_average", help="OPAC aerosol type")
    s.add_argument("--et", default="tsis1", help="extraterrestrial spectrum (tsis1, g173, e490, kurucz)")
    s.add_argument("--streams", type=int, default=32, help="DISORT streams")
    s.add_argument("--processes", type=int, default=None, help="worker processes (default: all cores)")
    s.add_argument("--data-dir", default=None, help="input data directory (default WIDESKY_DATA_DIR or ../shared/data)")
    s.add_argument("--output", default=None, help="write the result to this .npz")
    s.set_defaults(func=_solve)

    v = sub.add_parser("validate", help="run the validation cases and print their figures")
    v.add_argument("--which", default="rayleigh,lowsun,g173,spctrl2,6s,lowtran",
                   help="comma list of rayleigh, lowsun, g173, spctrl2, 6s")
    v.add_argument("--figures", default=None, help="directory for build_*.png figures")
    v.add_argument("--json", default=None, help="write the figures as JSON here")
    v.add_argument("--data-dir", default=None, help="input data directory")
    v.set_defaults(func=_validate)

    f = sub.add_parser("fit-gases", help="rerun 6S and refit the per-channel exponential sums")
    f.add_argument("--output", default=None, help="JSON output (default: the package's kdist_6s.json)")
    f.add_argument("--tolerance", type=float, default=1e-3, help="max transmittance error of a fit [1]")
    f.set_defaults(func=_fit)


def _solve(args):
    state = SkyState(solar_elevation_deg=args.elevation, visibility_km=args.visibility, aod550=args.aod550,
                     aod500=args.aod500, ground_albedo=args.albedo)
    spec = AtmosphereSpec(profile=args.profile, precipitable_water=args.water, ozone_du=args.ozone,
                          aerosol_type=args.aerosol, et_source=args.et)
    r = solve_sky(state, spec, config=SolverConfig(n_streams=args.streams), processes=args.processes,
                  progress=True, data_dir=args.data_dir)
    print(f"{r.n_runs.sum()} solver runs over {len(r.channels)} channels in {r.seconds:.1f} s "
          f"({r.meta['processes']} processes); AOD550 = {r.meta['aod550']:.4f}")
    print("integrated 280-2480 nm [W m-2]: DNI %.1f  DHI %.1f  GHI %.1f" % (40 * r.dni.sum(), 40 * r.dhi.sum(),
                                                                          40 * r.ghi.sum()))
    if args.output:
        np.savez(args.output, wavelength_nm=r.wavelength_nm, extraterrestrial=r.extraterrestrial, dni=r.dni,
                 dhi=r.dhi, ghi=r.ghi, direct_transmittance=r.direct_transmittance,
                 grid_zenith_deg=r.grid_zenith_deg, grid_azimuth_deg=r.grid_azimuth_deg,
                 grid_radiance=r.grid_radiance)
    return 0


def _validate(args):
    res = report.run(args.which.split(","), figures=args.figures, data_dir=args.data_dir)
    print(json.dumps(res, indent=1))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


def _fit(args):
    out = fit_gas_kdistributions(args.tolerance, output=args.output or SHIPPED_FILE)
    print(f"fitted {len(out['channels'])} channels -> {args.output or SHIPPED_FILE}")
    return 0
