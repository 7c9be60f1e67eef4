"""The ``widesky`` command line."""

from __future__ import annotations

import argparse
import importlib
import os
import sys

# The front ends that contribute subcommands (the app layer: they sit above the packages they drive); each
# module exposes ``register(subparsers)``. A module that does not exist is skipped; any other import error is
# raised.
SUBCOMMAND_MODULES = (
    "widesky.commands.sky",
    "widesky.commands.dataset",
    "widesky.skymodel.generator.cli",
    "widesky.commands.sun",
    "widesky.commands.poa",
    "widesky.explorer.cli", "widesky.commands.run",
    "widesky.commands.pv",
    "widesky.commands.thermal",
)


# The module that registers each known command, so that a command imports only its own module (the others
# pull in pandas, trimesh, ...: seconds of start-up for nothing). Anything else (no command, --help, an
# unknown name) registers every module.
COMMAND_MODULES = {
    "sky": "widesky.commands.sky",
    "dataset": "widesky.commands.dataset",
    "solver": "widesky.skymodel.generator.cli",
    "sun": "widesky.commands.sun",
    "poa": "widesky.commands.poa",
}


def _command(argv):
    """The first non-option argument (the command), or None."""
    for a in argv:
        if not a.startswith("-"):
            return a
        if a in ("-h", "--help", "--version"):
            return None
    return None


def build_parser(argv=None) -> argparse.ArgumentParser:
    """The ``widesky`` parser; with ``argv`` naming a known command, only that command's module is imported."""
    cmd = _command(argv) if argv is not None else None
    if argv and argv[0] == "--version":
        modules = ()
    else:
        modules = (COMMAND_MODULES[cmd],) if cmd in COMMAND_MODULES else SUBCOMMAND_MODULES
    parser = argparse.ArgumentParser(
        prog="widesky",
        description="Spectral solar simulation with the wide-spectral-range Prague Sky Model.")
    parser.add_argument("--version", action=_VersionAction)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in modules:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name is not None and name.startswith(exc.name):
                continue
            raise
        module.register(sub)
    _tidy(parser)
    return parser


def _plain(text):
    """``text`` without reStructuredText literal markup (double backticks, ``:func:`` roles): --help is plain text."""
    import re
    if not text:
        return text
    text = re.sub(r":(?:func|class|meth|data|mod|attr):`~?([^`]+)`", r"\1", text)
    return text.replace("``", "")


def _tidy(parser):
    """Every subcommand gets a description (its one-line help, where it has none) and every help text is plain
    text (no documentation markup): one grammar, whoever registered the command."""
    parser.description = _plain(parser.description)
    for action in parser._actions:
        if action.help not in (None, argparse.SUPPRESS):
            action.help = _plain(action.help)
        if isinstance(action, argparse._SubParsersAction):
            helps = {c.dest: c.help for c in action._choices_actions}
            for name, sub in action.choices.items():
                if not sub.description and helps.get(name):
                    h = _plain(helps[name])
                    sub.description = h[0].upper() + h[1:] + ("" if h.endswith(".") else ".")
                _tidy(sub)


class _VersionAction(argparse.Action):
    """``--version``: the installed version, looked up only when asked (importlib.metadata costs tens of
    milliseconds of start-up)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help="show the program's version number and exit"):
        super().__init__(option_strings=option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"widesky {_version()}")
        parser.exit()


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("widesky")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree that is not installed
        return "unknown (not installed)"


def main(argv=None) -> int:
    """Run the command line; returns the exit status (2 with a one-line message on bad input)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if _command(argv) == "build":
        print("widesky: error: 'widesky build' is now 'widesky solver' (the reference solver's tools: solve, "
              "validate, fit-gases); to build a dataset: widesky dataset build", file=sys.stderr)
        return 2
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except BrokenPipeError:
        # the reader of our output went away (``widesky sun position | head``): stop quietly, as cat does;
        # point stdout at /dev/null so the interpreter's final flush does not fail again
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        # Ctrl-C: outputs are written atomically, so nothing half-written is left; one line, the shell's status
        print("widesky: interrupted", file=sys.stderr)
        return 130
    except MemoryError:
        print("widesky: error: out of memory (reduce the problem size)", file=sys.stderr)
        return 2
    except (ValueError, OSError) as exc:
        print(f"widesky: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
