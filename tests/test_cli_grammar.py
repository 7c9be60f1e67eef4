"""One command-line grammar (issue 34): every subcommand has a description, every option a help text without
documentation markup (double backticks), and the flags the simulating commands share mean the same and have the
same default everywhere."""

import argparse

import pytest

from widesky.cli import build_parser


def _walk(parser, path=("widesky",)):
    """(command path, parser) for ``parser`` and every subcommand below it."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _walk(sub, path + (name,))


PARSERS = list(_walk(build_parser()))


def test_every_command_is_found():
    names = {" ".join(p) for p, _ in PARSERS}
    for cmd in ("widesky sky render", "widesky dataset build", "widesky solver solve", "widesky poa",
                "widesky pv sweep", "widesky thermal loads", "widesky run", "widesky sun skystates"):
        assert cmd in names


@pytest.mark.parametrize("path,parser", PARSERS, ids=[" ".join(p) for p, _ in PARSERS])
def test_help_text(path, parser):
    assert parser.description and parser.description.strip(), f"{' '.join(path)}: no description"
    assert "``" not in parser.description, f"{' '.join(path)}: double backticks in the description"
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                assert choice.help and "``" not in choice.help, f"{' '.join(path)} {choice.dest}: subcommand help"
            continue
        if action.help == argparse.SUPPRESS:
            continue
        name = "/".join(action.option_strings) or action.dest
        assert action.help and action.help.strip(), f"{' '.join(path)} {name}: no help text"
        assert "``" not in action.help, f"{' '.join(path)} {name}: double backticks in the help"
    text = parser.format_help()
    assert "``" not in text


def _option(path, flag):
    parser = dict((" ".join(p), q) for p, q in PARSERS)[path]
    for a in parser._actions:
        if flag in a.option_strings:
            return a
    return None


SHARED = {
    "--jobs": ("widesky poa", "widesky pv compare", "widesky pv yield", "widesky pv sweep", "widesky run",
               "widesky thermal loads", "widesky thermal study", "widesky thermal bestest"),
    "--spectral-model": ("widesky poa", "widesky pv compare", "widesky pv yield", "widesky pv sweep"),
    "--aerosol": ("widesky poa", "widesky pv compare", "widesky pv yield", "widesky pv sweep",
                  "widesky sun skystates"),
    "--reference": ("widesky pv compare", "widesky pv yield", "widesky pv sweep"),
}


@pytest.mark.parametrize("flag", sorted(SHARED))
def test_shared_flags_mean_the_same(flag):
    from widesky.irradiance.simulation import SKY_DEFAULTS
    actions = [(cmd, _option(cmd, flag)) for cmd in SHARED[flag]]
    missing = [cmd for cmd, a in actions if a is None]
    assert not missing, f"{flag} missing in {missing}"
    kinds = {(a.type, tuple(a.choices or ())) for _, a in actions}
    assert len(kinds) == 1, f"{flag}: types/choices differ: {kinds}"
    defaults = {a.default for _, a in actions}
    if flag in ("--spectral-model",):
        # None in the parser: the value comes from SKY_DEFAULTS, as in a case file
        assert defaults == {None} and SKY_DEFAULTS.spectral_model
    elif flag == "--aerosol":
        assert defaults <= {None, SKY_DEFAULTS.aerosol}
    else:
        assert len(defaults) == 1, f"{flag}: defaults differ: {defaults}"
