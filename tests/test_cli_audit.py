"""Defects a new user's audit of the command line found (2026-12-05), each with the case that failed before its fix.

- ``widesky thermal loads`` imported scipy (a test and build extra, not a dependency): on a plain ``pip install .``
  every run of it, with or without ``--context-box``, ended in a ModuleNotFoundError traceback.
- A command that needs an optional extra (``widesky solver fit-gases``: Py6S; ``widesky dataset build``: scipy)
  printed a traceback instead of one line naming the package and the extra.
- A Ctrl-C that Python could not propagate (raised inside a weakref callback while the report was written: "Exception
  ignored in ...") was lost: the run carried on and replaced the report; now it is recorded, every commit checks it,
  and the command exits 130 having written nothing.
- ``--step xyz`` said "unit abbreviation w/o a number", naming neither the option's value nor what is valid.
- A folder given as ``--weather`` was reported "not found".
- ``nan`` in a case's ``[scene.parameters]`` failed later as "analysis[0] mesh has non-finite vertex coordinates",
  naming neither the file nor the key.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from widesky import cli
from widesky.core import atomic

ROOT = Path(__file__).resolve().parents[1]
JUNE = ROOT / "irradiance" / "data" / "sample_golden_june.epw"      # 14 days, shipped with the package


def _without(modules, argv, cwd, timeout=300):
    """Run ``widesky argv`` in a fresh interpreter where importing any of ``modules`` fails, as on a plain install
    that lacks the optional extras."""
    code = textwrap.dedent(f"""
        import sys
        class _Absent:
            def find_spec(self, name, path=None, target=None):
                if name.split(".")[0] in {tuple(modules)!r}:
                    raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
                return None
        sys.meta_path.insert(0, _Absent())
        from widesky.cli import main
        sys.exit(main({list(argv)!r}))
    """)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd, timeout=timeout)


# ---------------------------------------------------------------------------------------------- optional packages

def test_thermal_loads_runs_without_scipy(tmp_path):
    """A plain install has no scipy: the default `thermal loads` (integrator sky) and a --context-box run all the
    same, and the overlap check still refuses a block on the building."""
    out = tmp_path / "loads.csv"
    p = _without(["scipy"], ["thermal", "loads", "--weather", str(JUNE), "--jobs", "1",
                             "--context-box", "30,0,5,5,5", "--output", str(out)], tmp_path)
    assert p.returncode == 0, p.stderr
    assert out.is_file() and "Traceback" not in p.stderr
    p = _without(["scipy"], ["thermal", "loads", "--weather", str(JUNE), "--jobs", "1",
                             "--context-box", "5,5,3,3,5", "--output", str(tmp_path / "never.csv")], tmp_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1, p.stderr
    assert "--context-box '5,5,3,3,5'" in p.stderr and "overlaps the building" in p.stderr
    assert not (tmp_path / "never.csv").exists()


def test_convex_hull_of_a_footprint():
    """The numpy hull that replaced scipy's: the corners of an L-shaped outline's points (interior and collinear
    edge points dropped), counter-clockwise; checked against the hand-drawn answer."""
    from widesky.commands.thermal import _convex_hull
    pts = np.array([[0, 0], [10, 0], [10, 4], [4, 4], [4, 8], [0, 8], [5, 0], [0, 3], [2, 2], [7, 2]], float)
    hull = _convex_hull(pts)
    assert {tuple(p) for p in hull} == {(0, 0), (10, 0), (10, 4), (4, 8), (0, 8)}
    x, y = hull[:, 0], hull[:, 1]
    assert 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) == pytest.approx(10 * 4 + 4 * 8 - 4 * 4 + 0.5 * 6 * 4)


@pytest.mark.parametrize("module,argv", [
    ("Py6S", ["solver", "fit-gases", "--output", "kdist.json"]),
    ("scipy", ["dataset", "build", str(ROOT / "skymodel" / "data" / "default-dataset.json"), "-o", "out.dat"]),
])
def test_a_missing_optional_package_is_one_line(tmp_path, module, argv):
    p = _without([module], argv, tmp_path)
    assert p.returncode == 2, p.stderr
    assert p.stderr.count("\n") == 1 and "Traceback" not in p.stderr, p.stderr
    assert f"optional package '{module}'" in p.stderr and "[build]" in p.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_missing_package_that_is_not_optional_still_raises(monkeypatch):
    """Only the extras' packages get the one-line message: a broken installation is not hidden behind it."""
    from widesky.commands import sun

    def broken(args):
        raise ModuleNotFoundError("No module named 'numpy'", name="numpy")
    monkeypatch.setattr(sun, "_position", broken)
    with pytest.raises(ModuleNotFoundError):
        cli.main(["sun", "position", "--lat", "50", "--lon", "14", "--time", "2023-06-21T12:00+00:00"])


# ---------------------------------------------------------------------------------------------------- Ctrl-C

def test_a_swallowed_ctrl_c_writes_nothing_and_exits_130(tmp_path, monkeypatch, capsys):
    """A Ctrl-C that some code swallows (as Python does in a weakref callback) is still an interrupt: the command's
    output is not committed, the user's file of the same name is intact, one line, status 130."""
    from widesky.commands import sun
    user = tmp_path / "states.csv"
    user.write_text("the user's own table\n")

    def swallowing(args):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(1000):           # the handler runs between bytecodes
                pass
        except KeyboardInterrupt:
            pass                            # swallowed
        with atomic.atomic_write(args.csv) as tmp:
            Path(tmp).write_text("half a result\n")
        return 0
    monkeypatch.setattr(sun, "_skystates", swallowing)
    previous = signal.getsignal(signal.SIGINT)
    code = cli.main(["sun", "skystates", str(JUNE), "--csv", str(user)])
    assert code == 130 and capsys.readouterr().err == "widesky: interrupted\n"
    assert user.read_text() == "the user's own table\n"
    assert [p.name for p in tmp_path.iterdir()] == ["states.csv"]
    assert signal.getsignal(signal.SIGINT) is previous          # the handler is put back
    with atomic.atomic_write(tmp_path / "after.csv") as tmp:    # and the record cleared: later commits work
        Path(tmp).write_text("ok\n")
    assert (tmp_path / "after.csv").read_text() == "ok\n"


def test_a_ctrl_c_swallowed_while_the_commands_import_stops_the_command(tmp_path, monkeypatch, capsys):
    """Ctrl-C in the first second (the command modules' imports), swallowed by a library's bare ``except``: the
    command does not run on to overwrite the user's file (it did: ``timeout -s INT 0.7 widesky thermal loads ...``
    wrote its CSV); one line, status 130."""
    real = cli.build_parser
    user = tmp_path / "states.csv"
    user.write_text("the user's own table\n")

    def swallowing_imports(argv):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(1000):
                pass
        except KeyboardInterrupt:
            pass                            # a bare except in some import
        return real(argv)
    monkeypatch.setattr(cli, "build_parser", swallowing_imports)
    code = cli.main(["sun", "skystates", str(JUNE), "--csv", str(user)])
    assert code == 130 and capsys.readouterr().err == "widesky: interrupted\n"
    assert user.read_text() == "the user's own table\n"


def test_ray_caster_helpers_end_quietly_on_ctrl_c():
    """The ray caster's pool helpers (and its fork server, which imports this module first) exit at once on SIGINT
    with status 130 and print nothing: no traceback per helper under the parent's one line."""
    code = ("import os, signal, time, widesky._pool_signals\n"
            "os.kill(os.getpid(), signal.SIGINT)\ntime.sleep(5)\nprint('not reached')")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 128 + signal.SIGINT and r.stdout == "" and r.stderr == ""


def test_a_recorded_interrupt_keeps_the_previous_report(tmp_path):
    """The report folder's commit checks the record too: the earlier report stays in place, the new one is gone."""
    from widesky.cases.runner import REPORT_MARKER, _atomic_folder
    dest = tmp_path / "report"
    dest.mkdir()
    (dest / REPORT_MARKER).write_text("{}")
    (dest / "index.html").write_text("the earlier report")

    def fill(tmp):
        (Path(tmp) / "index.html").write_text("the new report")
        atomic.mark_interrupted()
    try:
        with pytest.raises(KeyboardInterrupt):
            _atomic_folder(dest, fill)
    finally:
        atomic.clear_interrupted()
    assert (dest / "index.html").read_text() == "the earlier report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]


def test_ctrl_c_during_the_renames_waits_for_them():
    """A Ctrl-C between the renames of one commit is delivered after the last one: all or none, never half."""
    done = []
    try:
        with pytest.raises(KeyboardInterrupt):
            with atomic.interrupts_deferred():
                os.kill(os.getpid(), signal.SIGINT)
                for _ in range(1000):
                    pass
                done.append("renamed")
        assert done == ["renamed"]
        with pytest.raises(KeyboardInterrupt):      # recorded: a later commit of the same command refuses
            atomic.raise_if_interrupted()
    finally:
        atomic.clear_interrupted()


# ---------------------------------------------------------------------------------------------- messages

@pytest.mark.parametrize("argv", [
    ["poa", str(ROOT / "docs" / "example-data" / "roof.obj"), "--lat", "50", "--lon", "14", "--start", "2023-06-01",
     "--end", "2023-06-02", "--step", "xyz", "-o", "never.h5"],
    ["sun", "position", "--lat", "50", "--lon", "14", "--tz", "0", "--start", "2023-06-01", "--end", "2023-06-02",
     "--step", "xyz"],
])
def test_a_bad_step_names_the_option_its_value_and_the_form(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--step 'xyz': not a duration" in err and "15min" in err
    assert list(tmp_path.iterdir()) == []


def test_a_folder_as_weather_file_says_so(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "site").mkdir()
    assert cli.main(["sun", "skystates", "site"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'site' is a folder" in err and "EPW" in err


def test_nan_in_scene_parameters_names_the_key(tmp_path):
    """The shipped pv_plant case with its table tilt set to nan (TOML's literal): refused naming the file and key,
    before the geometry script runs; and nan inside a list names the item."""
    import shutil

    from widesky.cases.config import ConfigError, load_config
    case = tmp_path / "pv_plant"
    shutil.copytree(ROOT / "cases" / "pv_plant", case)
    text = (case / "case.toml").read_text()
    assert "\ntilt = 25.0\n" in text
    (case / "case.toml").write_text(text.replace("\ntilt = 25.0\n", "\ntilt = nan\n"))
    with pytest.raises(ConfigError, match=r"case\.toml: scene\.parameters\.tilt = nan: expected a finite number"):
        load_config(case)
    (case / "case.toml").write_text(text.replace("\ntilt = 25.0\n", "\ntilt = 25.0\nextra = [1.0, -inf]\n"))
    with pytest.raises(ConfigError, match=r"scene\.parameters\.extra\[1\] = -inf: expected a finite number"):
        load_config(case)


# ---------------------------------------------------------------------------------- outputs: suffixes and headers

@pytest.mark.parametrize("argv,option,suffix", [
    (["dataset", "synthetic", "notes.txt"], "output", ".dat"),
    (["dataset", "compress", str(ROOT / "skymodel" / "data" / "polarised.dat"), "-o", "notes.txt"], "--output",
     ".json"),
])
def test_dataset_outputs_need_their_suffix(argv, option, suffix, tmp_path, monkeypatch, capsys):
    """`dataset synthetic notes.txt` wrote a binary dataset over the user's text file, `dataset compress -o notes.txt`
    a JSON list: both are refused now, the file intact."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("the user's notes\n")
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{option} 'notes.txt': expected a file name ending in {suffix}" in err
    assert (tmp_path / "notes.txt").read_text() == "the user's notes\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


@pytest.mark.parametrize("extra,words", [
    (["--output-dir", "notes.txt"], "--output-dir 'notes.txt' is a file"),
    (["--wavelength-range", "800", "300"], "--wavelength-range 800 300: expected finite LO <= HI, >= 0 nm"),
    (["--albedo-range", "-1", "5"], "--albedo-range -1 5: expected finite LO <= HI, in [0, 1]"),
    (["--visibility-range", "nan", "60"], "--visibility-range nan 60"),
])
def test_gui_refuses_bad_options_before_serving(extra, words, tmp_path, monkeypatch, capsys):
    """These started the server (a file as --output-dir failed only at the first save; reversed or impossible
    ranges were taken as given)."""
    from widesky.explorer import server
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("the user's notes\n")
    monkeypatch.setattr(server, "serve", lambda *a, **k: pytest.fail("the server started"))
    assert cli.main(["gui", "--no-browser", "--port", "0", *extra]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_time_series_csvs_name_their_first_column(tmp_path, monkeypatch, capsys):
    """poa's, sun skystates', thermal loads' and pv yield's CSVs had an empty first header cell (pandas reads it as
    'Unnamed: 0'); each now says 'time'."""
    import pandas as pd
    monkeypatch.chdir(tmp_path)
    roof = str(ROOT / "docs" / "example-data" / "roof.obj")
    runs = {
        "poa.csv": ["poa", roof, "--lat", "50", "--lon", "14", "--start", "2023-06-21", "--end", "2023-06-22",
                    "--jobs", "1", "-o", "poa.csv"],
        "states.csv": ["sun", "skystates", str(JUNE), "--csv", "states.csv"],
        "loads.csv": ["thermal", "loads", "--weather", str(JUNE), "--sky", "weather", "--route", "rated",
                      "--output", "loads.csv"],
        "yield.csv": ["pv", "yield", roof, "--lat", "50", "--lon", "14", "--start", "2023-06-21", "--end",
                      "2023-06-22", "--jobs", "1", "-o", "yield.csv"],
    }
    for name, argv in runs.items():
        assert cli.main(argv) == 0, (name, capsys.readouterr().err)
        assert (tmp_path / name).read_text().split(",", 1)[0] == "time", name
        t = pd.read_csv(tmp_path / name, index_col="time")
        assert len(t) > 0 and pd.to_datetime(t.index, utc=True).notna().all(), name


def test_the_top_view_says_north_is_up(monkeypatch):
    """A report's plan view had no orientation: its title now says north is up (the camera looks from the south, so
    a south-facing wall shows as a strip along the bottom edge)."""
    from matplotlib.figure import Figure

    from widesky.cases.render3d import render_scene
    texts = []
    original = Figure.text

    def spy(self, x, y, s, *args, **kwargs):
        texts.append(s)
        return original(self, x, y, s, *args, **kwargs)
    monkeypatch.setattr(Figure, "text", spy)
    v = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]], float)
    t = np.array([[0, 1, 2], [0, 2, 3]])
    render_scene(v, t, np.array([1.0, 2.0]), vmin=0, vmax=2, view="top", size=120)
    render_scene(v, t, np.array([1.0, 2.0]), vmin=0, vmax=2, view="south-west", size=120)
    assert texts == ["view from the top (north up)", "view from the south-west"]


def test_pv_compare_interrupted_while_plotting_leaves_nothing(tmp_path, monkeypatch, capsys):
    """Ctrl-C while `pv compare` drew compare.png left the five tables without it (each file was atomic, the set was
    not); now the six are renamed together: a new folder is not left behind, an earlier comparison stays whole."""
    from widesky.pvsim import compare

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(compare, "plot_comparison", interrupted)
    roof = str(ROOT / "docs" / "example-data" / "roof.obj")
    argv = ["pv", "compare", roof, "--lat", "50", "--lon", "14", "--start", "2023-06-21", "--end", "2023-06-22",
            "--technology", "perc", "--technology", "cdte", "--jobs", "1", "-o"]
    assert cli.main([*argv, str(tmp_path / "new" / "cmp")]) == 130
    assert capsys.readouterr().err.endswith("widesky: interrupted\n")
    assert list(tmp_path.iterdir()) == []
    old = tmp_path / "old"
    old.mkdir()
    for name in ("summary.csv", "compare.png", "notes.txt"):
        (old / name).write_text(f"earlier {name}\n")
    assert cli.main([*argv, str(old)]) == 130
    assert {p.name: p.read_text() for p in old.iterdir()} == {n: f"earlier {n}\n" for n in
                                                               ("summary.csv", "compare.png", "notes.txt")}


def test_every_option_with_a_default_says_it():
    """`--help` left many defaults unsaid (thermal loads' building size [m], sun position's --step and --label,
    poa's --tz and --step, dataset synthetic's grids ...): every valued option now states its default."""
    import argparse

    def walk(parser, path=("widesky",)):
        yield path, parser
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    yield from walk(sub, path + (name,))
    silent, parsers = [], dict(walk(cli.build_parser()))
    for path, parser in parsers.items():
        for a in parser._actions:
            if (a.option_strings and type(a) is argparse._StoreAction and a.default not in (None, [])
                    and "default" not in (a.help or "")):
                silent.append(f"{' '.join(path)} {a.option_strings[-1]}")
    assert not silent, silent
    loads = " ".join(parsers[("widesky", "thermal", "loads")].format_help().split())
    assert "--width WIDTH [m] along x (east) (default 20.0)" in loads


@pytest.mark.parametrize("argv,words", [
    (["sky", "render", "--quantity", "foo"], "argument --quantity: invalid choice: 'foo'"),
    (["sun", "position"], "the following arguments are required: --lat, --lon"),
    (["pv", "sweep", "roof.obj", "--terminals", "3", "-o", "s.csv"], "argument --terminals: invalid choice: 3"),
    (["poa", "roof.obj", "-o", "p.h5", "--bogus"], "unrecognized arguments: --bogus"),
    (["nosuch"], "invalid choice: 'nosuch'"),
])
def test_argparse_errors_are_one_line(argv, words, capsys):
    """argparse printed its usage summary (up to 21 lines) above its error: now the one line, pointing to --help."""
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.count("\n") == 1 and words in err and "--help lists the options" in err, err


def test_run_list_gives_each_case_its_title(capsys):
    """`widesky run --list` printed bare folder names: now each with its report's title."""
    import tomllib

    from widesky.cases import CASES_DIR, list_cases
    assert cli.main(["run", "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [ln.split()[0] for ln in lines] == list_cases()
    for name, line in zip(list_cases(), lines):
        title = tomllib.loads((CASES_DIR / name / "case.toml").read_text())["case"]["title"]
        assert line.endswith(title), line


@pytest.mark.parametrize("argv,option", [(["sky", "info", "PragueSkyModelSWIR.dat", "--load"], "dataset"),
                                         (["sky", "render", "--dataset", "PragueSkyModelSWIR.dat", "-o", "x.png"],
                                          "--dataset")])
def test_a_missing_dataset_says_what_a_dataset_is(argv, option, tmp_path, monkeypatch, capsys):
    """README's `sky info PragueSkyModelSWIR.dat` without the file said only "no such file"."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{option} 'PragueSkyModelSWIR.dat': no such file" in err
    assert "Prague Sky Model dataset (.dat)" in err and "embedded" in err and list(tmp_path.iterdir()) == []


def test_a_weather_csv_without_dhi_warns_of_the_clear_sky(tmp_path, monkeypatch, capsys):
    """A CSV whose diffuse column was misspelt (dhi_wrong) ran on the unscaled clear sky with nothing on stderr:
    the upper bound in place of the measured year. Now a warning names the missing column and the unknown one."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "w.csv").write_text("# latitude: 50\n# longitude: 14\ntime,ghi,dni,dhi_wrong,temp_air\n"
                                    "2023-06-01 12:00+00:00,800,700,100,20\n2023-06-01 13:00+00:00,790,690,100,20\n")
    roof = str(ROOT / "docs" / "example-data" / "roof.obj")
    assert cli.main(["poa", roof, "--weather", "w.csv", "--jobs", "1", "-o", "p.csv"]) == 0
    err = capsys.readouterr().err
    assert err.startswith("widesky: warning: weather file 'w.csv' gives no dhi column") and "dhi_wrong" in err
    assert cli.main(["poa", roof, "--weather", "w.csv", "--clear-sky", "--jobs", "1", "-o", "p.csv"]) == 0
    assert capsys.readouterr().err == ""                    # asked for: no warning


@pytest.mark.parametrize("argv,words", [
    (["thermal", "loads", "--weather", "w.csv", "--sky", "weather", "--route", "rated", "--output", "l.csv"],
     "--weather 'w.csv': the file gives no dhi column; thermal loads needs temp_air [degC], and dni, dhi and ghi"),
    (["thermal", "loads", "--weather", "t.csv", "--output", "l.csv"],
     "--weather 't.csv': the file gives no temp_air column; thermal loads needs temp_air [degC]"),
    (["thermal", "study", "--weather", "t.csv", "--output", "study"],
     "--weather 't.csv': the file gives no temp_air column; thermal study needs temp_air [degC]"),
])
def test_thermal_commands_name_a_missing_weather_column(argv, words, tmp_path, monkeypatch, capsys):
    """A CSV weather file without dhi (--sky weather) or without temp_air ended in KeyError tracebacks."""
    monkeypatch.chdir(tmp_path)
    head = "# latitude: 50\n# longitude: 14\n"
    (tmp_path / "w.csv").write_text(head + "time,ghi,dni,dhi_wrong,temp_air\n2023-06-01 12:00+00:00,800,700,100,20\n"
                                    "2023-06-01 13:00+00:00,790,690,100,20\n")
    (tmp_path / "t.csv").write_text(head + "time,ghi,dni,dhi\n2023-06-01 12:00+00:00,800,700,100\n"
                                    "2023-06-01 13:00+00:00,790,690,100\n")
    before = sorted(p.name for p in tmp_path.iterdir())
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == before
