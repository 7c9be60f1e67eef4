"""The ``widesky`` command line."""

from __future__ import annotations

import argparse
import importlib
import os
import sys

# Packages that contribute subcommands: each module exposes ``register(subparsers)``.
# A module that does not exist (yet) is skipped; any other import error is raised.
SUBCOMMAND_MODULES = (
    "skymodel.cli_sky",
    "skymodel.cli_dataset",
    "skymodel.generator.cli",
    "irradiance.cli_sun",
    "irradiance.cli_poa",
    "pvsim.cli",
    "thermal.cli",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="widesky",
        description="Spectral solar simulation with the wide-spectral-range Prague Sky Model.")
    parser.add_argument("--version", action="version", version=f"widesky {_version()}")
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


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("widesky")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree that is not installed
        return "unknown (not installed)"


def main(argv=None) -> int:
    """Run the command line; returns the exit status (2 with a one-line message on bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except BrokenPipeError:
        # the reader of our output went away (``widesky sun position | head``): stop quietly, as cat does;
        # point stdout at /dev/null so the interpreter's final flush does not fail again
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except MemoryError:
        print("widesky: error: out of memory (reduce the problem size)", file=sys.stderr)
        return 2
    except (ValueError, OSError) as exc:
        print(f"widesky: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
