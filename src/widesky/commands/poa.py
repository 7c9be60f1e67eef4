"""``widesky poa``: per-face plane-of-array irradiance for a mesh, a site and a period.

Examples::

    widesky poa roof.obj --context city.glb --lat 50.08 --lon 14.42 --tz Europe/Prague \\
        --start 2023-01-01 --end 2024-01-01 --step 1h --visibility 40 --albedo 0.2 -o poa.h5
    widesky poa roof.obj --weather prague.epw --response c-Si=csi_sr.csv -o poa.csv

Mesh coordinates are metres east, north, up (e.g. UTM). Without ``--weather`` the sky is the clear
sky of the dataset for every step of the period. With ``--weather`` (EPW, TMY3 or a CSV with pvlib
column names) the site, the steps, and per-step aerosol optical depth (or visibility) and albedo come
from the file, and every step gets the all-sky model's spectra at the file's measured DNI and DHI
(docs/all-sky.md; ``--spectral-model clear`` scales the clear sky's shape instead, ``--clear-sky`` keeps the
unscaled clear sky); ``--start``/``--end`` select a part of the file. The defaults are the ones every
command shares (:data:`widesky.irradiance.SKY_DEFAULTS`). ``--response NAME=FILE`` (repeatable, names unique) reads a spectral response
(:meth:`widesky.irradiance.Response.from_csv`: columns ``wavelength_nm,value``; ``--response-unit`` sr,
qe, transmittance or weight), band-averaged over each 40 nm channel; its parts are added.

Output by suffix: ``.h5``/``.hdf5`` the full result (:class:`widesky.irradiance.POAResult`, per face, step,
response and part; streamed to the file during the run, :meth:`POAResult.load` reads it), or
``.csv`` the area-weighted mean of every part per face group (or of one ``--group``). ``--face-sums`` (a
``.csv`` output) writes instead one row per face: its group, side, area [m2], tilt and azimuth [deg] and the
period's irradiation of every response's parts, ``<response>:<part>`` [kWh m-2] (a response in A m-2: [kAh m-2]),
from a reduce-only run that keeps no per-step arrays (:class:`widesky.irradiance.sink.FaceSums`; memory does not
grow with the period: for scenes too large for a per-step result). Outputs are written atomically; the output
folder is checked before any computation.
"""

from __future__ import annotations

import sys

import numpy as np

from widesky.commands.scene_args import (add_reflectance_argument, check_ground, check_samples, load_meshes,
                                         reflectances)
from widesky.commands.sky_args import add_sky_arguments, check_site_arguments, simulation, sky_options


def register(subparsers) -> None:
    """Add the ``poa`` command to the ``widesky`` parser."""
    p = subparsers.add_parser("poa", help="per-face plane-of-array irradiance on a 3D mesh",
                              description=__doc__.split("\n\n")[0])
    p.add_argument("mesh", nargs="+", help="analysis mesh file(s) (OBJ, PLY, STL, GLB ...)")
    p.add_argument("--context", action="append", default=[], help="occluding mesh file (repeatable)")
    add_sky_arguments(p)
    p.add_argument("--response", action="append", default=[], metavar="NAME[:UNIT]=FILE",
                   help="spectral response CSV (wavelength_nm,value); repeatable, unique names; UNIT (sr, qe, "
                        "transmittance or weight) overrides --response-unit for this one, e.g. "
                        "glass:transmittance=tvis.csv")
    p.add_argument("--response-unit", default="sr", choices=("sr", "qe", "transmittance", "weight"),
                   help="unit of the --response values: sr [A W-1] (default), qe [1], "
                        "transmittance [1], weight [1]")
    p.add_argument("--ground-z", type=float, default=None, help="ground height [m] (default: lowest vertex)")
    add_reflectance_argument(p)
    p.add_argument("--tolerance", type=float, default=0.02,
                   help="target relative annual error per face [1]: picks the cheapest preset measured "
                        "below it (docs/validation/irradiance-integrator.md); 0.02 = the default settings")
    p.add_argument("--samples-per-face", type=int, default=1, help="points per face (1, 4, 9 ...)")
    p.add_argument("--two-sided", action="store_true", help="also analyse the back of every face")
    p.add_argument("--jobs", type=int, default=None, help="ray-casting processes (default: all cores)")
    p.add_argument("--group", default=None, help="with a .csv output: only this face group")
    p.add_argument("--face-sums", action="store_true",
                   help="with a .csv output: one row per face, the period's irradiation of every part "
                        "[kWh m-2], no per-step arrays kept (for large scenes)")
    p.add_argument("-o", "--output", required=True,
                   help="output: .h5/.hdf5 (full result per face) or .csv (per face group)")
    p.set_defaults(func=_run)


RESPONSE_UNITS = ("sr", "qe", "transmittance", "weight")

#: Longest run the CLI starts [steps] (about 10 years of 5-minute steps); split longer periods.
MAX_STEPS = 1_000_000
OUTPUT_SUFFIXES = (".h5", ".hdf5", ".csv")


def _output_kind(path):
    """"h5" or "csv" from the output's suffix; checks that it is not a folder and that its folder exists and is
    writable (:func:`widesky.core.atomic.check_output_path`)."""
    from widesky.core.atomic import check_output_path
    try:
        check_output_path(path, "--output", OUTPUT_SUFFIXES)
    except ValueError as exc:
        if "expected a file name" not in str(exc):
            raise
        raise ValueError(f"--output {path!r}: unknown suffix; valid: {', '.join(OUTPUT_SUFFIXES)} "
                         "(HDF5 result per face, or CSV per face group)") from None
    return "h5" if str(path).lower().endswith((".h5", ".hdf5")) else "csv"


def _check_args(args):
    """Bad input refused before any work, each message naming the option, value and valid range."""
    import math
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs {args.jobs}: must be >= 1 (ray-casting processes)")
    sky_options(args)
    check_site_arguments(args)
    if args.ground_z is not None and not math.isfinite(args.ground_z):
        raise ValueError(f"--ground-z {args.ground_z}: must be a finite height [m]")
    if not math.isfinite(args.tolerance) or args.tolerance <= 0:
        raise ValueError(f"--tolerance {args.tolerance}: outside the valid range > 0")
    if args.group is not None and not str(args.output).lower().endswith(".csv"):
        raise ValueError("--group selects a face group of a .csv output")
    if args.face_sums and not str(args.output).lower().endswith(".csv"):
        raise ValueError(f"--face-sums: --output {args.output!r} must be a .csv file (one row per face)")
    if args.face_sums and args.group is not None:
        raise ValueError(f"--face-sums with --group {args.group!r}: the per-face table holds every face and "
                         "its group; give one of them")


def _responses(args):
    from widesky.commands.outputs import check_text_file
    from widesky.irradiance.response import Response
    out, names = [], set()
    for item in args.response:
        key, sep, path = item.partition("=")
        name, _, unit = key.partition(":")
        unit = unit or args.response_unit
        if not sep or not name or not path:
            raise ValueError(f"--response {item!r}: expected NAME=FILE or NAME:UNIT=FILE")
        if unit not in RESPONSE_UNITS:
            raise ValueError(f"--response {item!r}: unit {unit!r} is not one of {', '.join(RESPONSE_UNITS)}")
        if name in names or name == "broadband":
            raise ValueError(f"--response {item!r}: the name {name!r} is "
                             + ("given twice" if name in names else "reserved (always computed)"))
        names.add(name)
        check_text_file(path, f"--response {item!r}", "CSV table wavelength_nm,value")
        try:
            out.append(Response.from_csv(path, name=name, unit=unit))
        except ValueError as exc:
            raise ValueError(f"--response {item!r}: {exc}") from None
    return out


def _period_steps(args):
    """Steps of the clear-sky period, estimated before anything is allocated."""
    import pandas as pd
    try:
        step = pd.Timedelta(args.step)
    except (ValueError, TypeError):
        raise ValueError(f"--step {args.step!r}: not a duration; expected a number and a unit, e.g. 1h, 15min "
                         "or 30s") from None
    try:
        span = pd.Timestamp(args.end) - pd.Timestamp(args.start)
    except (ValueError, TypeError) as e:
        raise ValueError(f"--start {args.start!r} / --end {args.end!r}: {e}") from None
    if step <= pd.Timedelta(0):
        raise ValueError(f"--step {args.step}: must be positive")
    return int(span / step)


def _refuse_huge(n_steps, n_faces, n_responses, what):
    from widesky.irradiance.poa import estimate_run
    if n_steps <= MAX_STEPS:
        return
    out_bytes, _ = estimate_run(n_faces, n_steps, n_responses)
    # measured on the 20,000-face benchmark (docs/validation/irradiance-integrator.md): about 26 s for
    # 20,000 faces x 4,444 daylight steps x 3 responses on 2 quiet cores, i.e. 1e-7 s per face,
    # daylight step and response; half the steps are daylight
    secs = 1e-7 * n_faces * n_steps * 0.5 * (n_responses + 1)
    raise ValueError(f"{what}: {n_steps:,} steps x {n_faces:,} faces would write about "
                     f"{out_bytes / 1e9:,.0f} GB and take about {secs / 3600:,.1f} h; the CLI "
                     f"runs at most {MAX_STEPS:,} steps: split the period")


def _write_csv(res, path, group=None):
    """Area-weighted mean of every response's parts per face group, written atomically."""
    import pandas as pd

    from widesky.core.atomic import atomic_write
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
    with atomic_write(path) as tmp:
        pd.DataFrame(cols, index=res.times).to_csv(tmp, index_label="time")


def step_hours(times):
    """(T,) duration of each step [h]: the series' median interval between consecutive times (one step: 1 h),
    the rule pvsim uses. Not the time to the next step: a typical-year file (TMY3, EPW) joins months of
    different years, so its times step backwards or years ahead at month boundaries."""
    t = np.asarray(times.as_unit("ns").asi8 if hasattr(times, "as_unit") else times, dtype=np.int64)
    if t.size < 2:
        return np.ones(t.size)
    d = np.diff(t) / 3.6e12
    d = d[d > 0]
    return np.full(t.size, float(np.median(d)) if d.size else 1.0)


def _face_sums(sim, responses, path, provenance):
    """A reduce-only run: per face the period's sum of every part [kWh m-2], written to ``path`` (CSV, atomic)."""
    from widesky.core.atomic import atomic_write
    from widesky.irradiance.poa import OutputOptions, poa_irradiance
    from widesky.irradiance.sink import FaceSums
    kw = sim.integrator_arguments(None)
    sums = FaceSums(sim.scene.n_faces, step_hours=step_hours(kw["times"]))
    out = OutputOptions(angles=False, arrays=False, consumer=sums,
                        provenance={"sky": sim.description, **provenance})
    res = poa_irradiance(sim.scene, sim.sky_source, responses=responses, output=out, **kw)
    with atomic_write(path) as tmp:
        sums.table(res.faces).to_csv(tmp)
    return res


def _run(args) -> int:
    from widesky.commands.scene_args import integrator_settings
    from widesky.irradiance.scene import make_scene

    _check_args(args)
    kind = _output_kind(args.output)
    responses = _responses(args)
    if args.weather is None and args.start is not None and args.end is not None:
        _refuse_huge(_period_steps(args), 1, len(responses), f"--start {args.start} --end "
                     f"{args.end} --step {args.step}")
    meshes = load_meshes(args.mesh, "mesh")
    context = load_meshes(args.context, "--context")
    check_samples(args.samples_per_face, sum(len(m.faces) for m in meshes), args.two_sided)
    groups = [str(m) for m in args.mesh]
    refl, ctx_refl = reflectances(args.reflectance, groups)
    scene = make_scene(meshes, context, groups=groups, analysis_reflectance=refl, context_reflectance=ctx_refl,
                       ground_z=args.ground_z, samples_per_face=args.samples_per_face,
                       two_sided=args.two_sided)
    check_ground(scene, args.ground_z)
    sim = simulation(args, scene, integrator_settings(args))
    states, note = sim.states, sim.description
    _refuse_huge(len(states), scene.n_faces, len(responses), "the run")
    prov = {"command": "widesky poa " + " ".join(sys.argv[2:])}
    if args.face_sums:
        res = _face_sums(sim, responses, args.output, prov)
    else:
        res = sim.run(responses, output=args.output if kind == "h5" else None, provenance=prov)
    if kind == "csv" and not args.face_sums:
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
