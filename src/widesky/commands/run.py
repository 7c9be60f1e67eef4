"""``widesky run CASE``: run a case folder end to end and write its report folder."""

from __future__ import annotations

from pathlib import Path


def register(subparsers) -> None:
    """Add the ``run`` command to the ``widesky`` parser."""
    p = subparsers.add_parser("run", help="run a case (a folder with case.toml) and write its HTML report",
                              description=__doc__)
    p.add_argument("case", nargs="?", help="case folder (e.g. cases/solar_potential) or the name of a shipped case")
    p.add_argument("-o", "--output", default=None, help="report folder (default ./report-<case name>)")
    p.add_argument("--jobs", type=int, default=None, help="ray-casting processes (default: all cores)")
    p.add_argument("--list", action="store_true", help="list the shipped cases")
    p.add_argument("--schema", action="store_true", help="print the configuration keys, units and ranges")
    p.set_defaults(func=_run)


def _resolve(case):
    from widesky.cases import CASES_DIR, list_cases

    p = Path(case)
    if p.is_dir():
        return p
    if (CASES_DIR / case).is_dir() and "/" not in case:
        return CASES_DIR / case
    raise ValueError(f"case {case!r}: no such folder; shipped cases: {', '.join(list_cases())}")


def _run(args) -> int:
    from widesky.cases import SCHEMA, list_cases
    from widesky.cases.runner import run_case

    if args.list:
        import tomllib

        from widesky.cases import CASES_DIR
        names = list_cases()
        width = max(map(len, names), default=0)
        for name in names:            # each with its report's title: what it shows, not only its folder name
            try:
                title = tomllib.loads((CASES_DIR / name / "case.toml").read_text(encoding="utf-8"))["case"]["title"]
            except (OSError, KeyError, TypeError, tomllib.TOMLDecodeError):
                title = ""
            print(f"{name:{width}s}  {title}".rstrip())
        return 0
    if args.schema:
        for section, fields in SCHEMA.items():
            print(f"[{section}]")
            for key, f in fields.items():
                rng = f" [{f.lo:g}, {f.hi:g}]" if f.lo is not None else ""
                choices = f.choices
                if section == "pv" and key == "technologies":
                    from widesky.cases.config import _technology_choices
                    choices = _technology_choices()
                ch = f" one of {', '.join(choices)}" if choices else ""
                unit = f" {f.unit}" if f.unit else ""
                print(f"  {key:18s} {f.kind}{unit}{rng}{ch}: {f.help}")
        return 0
    if not args.case:
        raise ValueError("give a case folder or name (widesky run --list shows the shipped cases)")
    if args.jobs is not None and args.jobs < 1:
        raise ValueError(f"--jobs {args.jobs} must be >= 1")
    run_case(_resolve(args.case), args.output, n_jobs=args.jobs)
    return 0
