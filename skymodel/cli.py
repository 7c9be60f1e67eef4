"""The ``widesky`` command line."""

from __future__ import annotations

import argparse
import importlib
import sys

# Packages that contribute subcommands: each module exposes ``register(subparsers)``.
# A module that does not exist (yet) is skipped; any other import error is raised.
SUBCOMMAND_MODULES = (
    "skymodel.cli_sky",
    "skymodel.cli_dataset",
    "skymodel.generator.cli",
    "irradiance.cli_sun",
    "irradiance.cli_poa",
    "skymodel.explorer.cli", "cases.cli",
    "pvsim.cli",
    "thermal.cli",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="widesky",
        description="Spectral solar simulation with the wide-spectral-range Prague Sky Model.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in SUBCOMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name is not None and name.startswith(exc.name):
                continue
            raise
        module.register(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (ValueError, OSError) as exc:
        print(f"widesky: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
