"""Every bad input to the command line is one clear error, before any work, and nothing is written (issue 34).

Each case feeds one command a wrong input a new user might give (the issue's list: silently wrong results,
tracebacks, messages that did not name the file or option, outputs found unwritable only after the computation)
and checks the contract of docs/guide/concepts.md, "The command line: errors and outputs": exit status != 0,
exactly ONE line on stderr naming the option or file, the value and what is valid, and no file or folder left
behind. The sample inputs are small files written into tmp_path.
"""

import os
import re

import numpy as np
import pandas as pd
import pytest
import trimesh

from widesky.cli import main
from widesky.core.paths import runtime_file
from widesky.irradiance.location import Site
from widesky.irradiance.weather import write_epw

DENVER = "data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw"
CLEAR_3 = runtime_file("glazing/CLEAR_3.DAT")


def _listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def refused(argv, capsys, *words, folder=None):
    """Run ``widesky argv``: it must fail with one stderr line holding every one of ``words`` and, when
    ``folder`` is given, leave it as it was. Returns the line."""
    before = _listing(folder) if folder is not None else None
    try:
        rc = main([str(a) for a in argv])
    except SystemExit as exc:          # argparse's own errors
        rc = exc.code
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc not in (0, None), f"exit status 0 for {argv}: {err}"
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}:\n{err}"
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], f"{w!r} not in {lines[0]!r}"
    if folder is not None:
        assert _listing(folder) == before, "files were written"
    return lines[0]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """A 4 m x 3 m horizontal roof and three June days of hourly weather at 48 N (2021)."""
    d = tmp_path_factory.mktemp("inputs")
    v = np.array([[0, 0, 0.0], [4, 0, 0.0], [4, 3, 0.0], [0, 3, 0.0]])
    trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False).export(d / "roof.obj")
    site = Site(48.0, 11.0, 500.0, tz=1.0, name="test")
    idx = pd.date_range("2021-06-20 01:00", periods=72, freq="1h", tz=site.tz)
    el = site.solar_position(idx, label="right", step="1h")["apparent_elevation"].to_numpy()
    s = np.clip(np.sin(np.radians(el)), 0.0, None)
    dni, dhi = 600.0 * s ** 0.3 * (s > 0), 100.0 * s ** 0.8
    data = pd.DataFrame({"ghi": dni * s + dhi, "dni": dni, "dhi": dhi, "temp_air": 20.0, "wind_speed": 2.0,
                         "visibility": 30.0, "albedo": 0.2}, index=idx)
    write_epw(d / "w.epw", data, site)
    return d


def _epw_with(src, dst, line, column, value):
    """``src`` with field ``column`` (0-based) of line ``line`` (1-based) replaced by ``value``."""
    lines = src.read_text().splitlines()
    fields = lines[line - 1].split(",")
    fields[column] = value
    lines[line - 1] = ",".join(fields)
    dst.write_text("\n".join(lines) + "\n")
    return dst


# ------------------------------------------------------------------------------------------------------------
# silently wrong results
# ------------------------------------------------------------------------------------------------------------

def _glazing_file(tmp_path, name, edit):
    rows = CLEAR_3.read_text(encoding="latin-1").splitlines()
    out = [edit(r) if re.match(r"^\s*0\.5000?\s", r) else r for r in rows]
    assert out != rows
    p = tmp_path / name
    p.write_text("\n".join(out) + "\n", encoding="latin-1")
    return p


def test_glazing_nan_is_refused(tmp_path, capsys):
    """Was: g printed from a spectrum with a NaN hole, exit 0."""
    p = _glazing_file(tmp_path, "igdb_nan.txt", lambda r: "0.500    nan    0.0470    0.0480")
    refused(["thermal", "glazing", p], capsys, "igdb_nan.txt:", "nan", "not finite", "[0, 1]")


def test_glazing_t_plus_r_above_one_names_the_file(tmp_path, capsys):
    """Was: "T0 and R0 must be >= 0 with T0 + R0 <= 1" without the file."""
    p = _glazing_file(tmp_path, "rt.txt", lambda r: "0.500    0.9000    0.3000    0.0480")
    refused(["thermal", "glazing", p], capsys, "rt.txt:", "T + Rfront = 1.2", "0.5 um", "<= 1")


def test_glazing_flip_out_of_range(tmp_path, capsys):
    refused(["thermal", "glazing", "CLEAR_3.DAT", "CLEAR_3.DAT", "--flip", "5"], capsys,
            "--flip 5", "valid: 0 to 1", folder=tmp_path)


def test_glazing_gap_count(capsys):
    refused(["thermal", "glazing", "CLEAR_3.DAT", "CLEAR_3.DAT", "--gap", "12", "--gap", "16"], capsys,
            "--gap", "2 layers need 1 gap")


@pytest.mark.parametrize("args,words", [
    (["--wwr", "S=0.4,S=0.2"], ["--wwr 'S=0.4,S=0.2'", "S is given twice", "S=0.4,N=0.2"]),
    (["--wwr", "Q=0.4"], ["--wwr 'Q=0.4'", "S, N, E, W"]),
    (["--wwr", "1.5"], ["--wwr '1.5'", "[0, 0.95]"]),
    (["--overhang=-1"], ["--overhang -1", "[0, 20] m"]),
    (["--fins", "nan"], ["--fins nan", "[0, 20] m"]),
    (["--rotation", "nan"], ["--rotation nan", "[-360, 360] deg"]),
    (["--floors", "0"], ["--floors 0", "[1, 200]"]),
    (["--context-box", "2,2,3,3,3"], ["--context-box '2,2,3,3,3'", "overlaps the building", "x 0.0 to 20.0 m"]),
    (["--context-box", "2,2,3"], ["--context-box '2,2,3'", "X,Y,W,D,H"]),
    (["--facade-map", "map.txt"], ["--facade-map 'map.txt'", ".ply"]),
    (["--output", "nodir/x.csv"], ["--output 'nodir/x.csv'", "'nodir' does not exist"]),
    (["--output", "."], ["--output '.'", "expected a file name ending in .csv"]),
])
def test_thermal_loads_options(args, words, tmp_path, capsys, monkeypatch):
    """Each was accepted (a repeated key, a block inside the building, a negative overhang, a binary PLY written
    into map.txt) or found only after the whole computation (the output folder, 9 s in)."""
    monkeypatch.chdir(tmp_path)
    argv = ["thermal", "loads", "--weather", DENVER, "--output", "loads.csv", *args]
    refused(argv, capsys, *words, folder=tmp_path)


def test_case_weather_malformed_record(tmp_path, inputs, capsys):
    """A negative DNI in a case's weather file: one line naming the file, its line and the field's range."""
    folder = tmp_path / "case"
    folder.mkdir()
    _epw_with(inputs / "w.epw", folder / "bad.epw", 20, 14, "-50")
    (folder / "geometry.py").write_text("def build(p):\n    return {'analysis': {'roof': %r}}\n"
                                        % str(inputs / "roof.obj"))
    (folder / "case.toml").write_text(CASE.format(weather='weather = "bad.epw"', start="2021-06-20",
                                                  end="2021-06-23", sky_time="2021-06-21T12:30"))
    line = refused(["run", folder, "-o", tmp_path / "report"], capsys, "bad.epw:20", "'dni'", "-50", "[0, 2000]",
                   folder=tmp_path)
    assert "sky.weather" in line


def test_sun_skystates_negative_dni(tmp_path, inputs, capsys):
    bad = _epw_with(inputs / "w.epw", tmp_path / "neg.epw", 14, 14, "-5")
    refused(["sun", "skystates", bad], capsys, "neg.epw:14", "'dni'", "-5", "[0, 2000]")


def test_tmy3_negative_dni(tmp_path, capsys):
    """The same physical ranges in a TMY3 file (minimal columns; DNI -20 on the record of 13:00)."""
    header = "Date (MM/DD/YYYY),Time (HH:MM),GHI (W/m^2),DNI (W/m^2),DHI (W/m^2),Dry-bulb (C)"
    rows = [f"06/21/1988,{h:02d}:00,{300 if 6 < h < 20 else 0},{-20 if h == 13 else 0},{100 if 6 < h < 20 else 0},20"
            for h in range(1, 25)]
    p = tmp_path / "neg_tmy3.csv"
    p.write_text('723650,"ALBUQUERQUE INTL ARPT",NM,-7.0,35.050,-106.617,1619\n' + header + "\n"
                 + "\n".join(rows) + "\n")
    refused(["sun", "skystates", p], capsys, "neg_tmy3.csv:15", "'dni'", "-20", "[0, 2000]")


def test_single_year_weather_in_another_year(tmp_path, inputs, capsys):
    """poa: a 2021 file for a 2024 period is an error suggesting --coerce-year; a case (whose design moves the
    records to the period's year) says so in a warning."""
    refused(["poa", inputs / "roof.obj", "--weather", inputs / "w.epw", "--start", "2024-06-20", "--end",
             "2024-06-22", "-o", tmp_path / "p.csv"], capsys, "records are of 2021", "--coerce-year",
            folder=tmp_path)
    import widesky.irradiance as ir
    from widesky.cases.config import load_config
    from widesky.cases.runner import simulation
    folder = tmp_path / "case"
    folder.mkdir()
    (folder / "w.epw").write_bytes((inputs / "w.epw").read_bytes())
    (folder / "geometry.py").write_text("def build(p):\n    return {}\n")
    (folder / "case.toml").write_text(CASE.format(weather='weather = "w.epw"', start="2024-06-20",
                                                  end="2024-06-23", sky_time="2024-06-21T12:30"))
    sim = simulation(load_config(folder), None, ir.IntegratorSettings())
    assert any("records are of 2021" in w and "moved to 2024" in w and "period" in w for w in sim.warnings)


def test_sky_render_elevation_outside_dataset(tmp_path, capsys):
    """Was: clamped to the dataset's lowest elevation with a warning, exit 0, a picture of another sky."""
    refused(["sky", "render", "--elevation", "-90", "--resolution", "16", "-o", tmp_path / "s.png"], capsys,
            "--elevation -90", "outside the dataset's range [0, 90] deg", folder=tmp_path)


def test_poa_ground_above_scene(tmp_path, inputs, capsys):
    """Was: every face 0 W m-2, no warning."""
    refused(["poa", inputs / "roof.obj", "--weather", inputs / "w.epw", "--ground-z", "100", "-o",
             tmp_path / "p.csv"], capsys, "--ground-z 100", "at most 0.00 m", folder=tmp_path)


def test_poa_samples_per_face_bounded(tmp_path, inputs, capsys):
    """Was: unbounded (past 2 minutes); now estimated and refused, with the bound and how to lower it."""
    line = refused(["poa", inputs / "roof.obj", "--weather", inputs / "w.epw", "--samples-per-face", "1000000",
                    "-o", tmp_path / "p.csv"], capsys, "--samples-per-face 1000000", "2,000,000 analysis points",
                   "10,000 per face", "1,000,000 points", "lower --samples-per-face", folder=tmp_path)
    assert "GB of memory" in line
    refused(["poa", inputs / "roof.obj", "--weather", inputs / "w.epw", "--samples-per-face", "3", "-o",
             tmp_path / "p.csv"], capsys, "--samples-per-face 3", "square number")


# ------------------------------------------------------------------------------------------------------------
# tracebacks
# ------------------------------------------------------------------------------------------------------------

CASE = """
[case]
title = "bad input"
[site]
latitude = 48.0
longitude = 11.0
tz = "Europe/Berlin"
[period]
start = "{start}"
end = "{end}"
step = "1h"
[sky]
{weather}
[scene]
geometry = "geometry.py"
[report]
sky_time = "{sky_time}"
views = ["south-west"]
render_size = 128
"""


@pytest.mark.parametrize("script,words", [
    ("def build(p):\n    return {'analysis': {\n\n  x = (\n", ["geometry.py:", "syntax error"]),
    ("import numpy as np\n\ndef build(p):\n    return {'analysis': {'a': np.zeros(3)[5]}}\n",
     ["geometry.py:4", "build(parameters)", "IndexError"]),
])
def test_case_geometry_script_errors(script, words, tmp_path, capsys):
    """Was: a Python traceback from inside the runner."""
    folder = tmp_path / "case"
    folder.mkdir()
    (folder / "geometry.py").write_text(script)
    (folder / "case.toml").write_text(CASE.format(weather="", start="2024-06-21", end="2024-06-22",
                                                  sky_time="2024-06-21T12:30"))
    refused(["run", folder, "-o", tmp_path / "report"], capsys, *words, folder=tmp_path)


def test_plot_library_unknown_technology(tmp_path, capsys):
    """Was: KeyError traceback."""
    refused(["pv", "plot-library", "--technology", "foo", tmp_path / "x.png"], capsys, "--technology 'foo'",
            "valid: perc, topcon", folder=tmp_path)


# ------------------------------------------------------------------------------------------------------------
# messages that did not name the file or the option
# ------------------------------------------------------------------------------------------------------------

def test_garbage_and_binary_weather(tmp_path, inputs, capsys):
    (tmp_path / "bin.epw").write_bytes(bytes(range(256)) * 8)
    refused(["sun", "skystates", tmp_path / "bin.epw"], capsys, "bin.epw", "binary", "EPW")
    (tmp_path / "text.epw").write_text("hello world\nfoo,bar\n")
    refused(["sun", "skystates", tmp_path / "text.epw"], capsys, "text.epw", "LOCATION", "TMY3")
    (tmp_path / "w.csv").write_text("time,ghi\n2021-01-01T00:00,0\n")
    refused(["poa", inputs / "roof.obj", "--weather", tmp_path / "w.csv", "-o", tmp_path / "p.csv"], capsys,
            "w.csv", "latitude", "EPW")


@pytest.mark.parametrize("name,content,words", [
    ("empty.obj", "", ["empty.obj", "no triangles"]),
    ("tri.xyz", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", ["tri.xyz", ".xyz", "valid:", ".obj", ".ply"]),
    ("none.obj", None, ["none.obj", "not found"]),
])
def test_mesh_messages_name_the_file(name, content, words, tmp_path, inputs, capsys):
    if content is not None:
        (tmp_path / name).write_text(content)
    refused(["poa", tmp_path / name, "--weather", inputs / "w.epw", "-o", tmp_path / "p.csv"], capsys, *words)
    refused(["poa", inputs / "roof.obj", "--context", tmp_path / name, "--weather", inputs / "w.epw", "-o",
             tmp_path / "p.csv"], capsys, "--context", *words)


def test_response_files_named(tmp_path, inputs, capsys):
    (tmp_path / "bad.csv").write_text('wavelength_nm,value\n300,0.5\n400,"0.7\n500,0.8,3,4\n')
    (tmp_path / "bin.csv").write_bytes(b"\x7fELF\x02\x01\x01" + bytes(range(256)) * 4)
    common = [inputs / "roof.obj", "--weather", inputs / "w.epw"]
    refused(["poa", *common, "--response", f"a={tmp_path / 'bad.csv'}", "-o", tmp_path / "p.csv"], capsys,
            "--response", "bad.csv", "line 3", "wavelength_nm,value", folder=tmp_path)
    refused(["poa", *common, "--response", f"a={tmp_path / 'bin.csv'}", "-o", tmp_path / "p.csv"], capsys,
            "--response", "bin.csv", "not a text file", folder=tmp_path)
    refused(["pv", "yield", *common, "--cell", f"a={tmp_path / 'bad.csv'}", "-o", tmp_path / "y.csv"], capsys,
            "--cell", "bad.csv", folder=tmp_path)
    refused(["pv", "yield", *common, "--cell", f"a={tmp_path / 'bin.csv'}", "-o", tmp_path / "y.csv"], capsys,
            "--cell", "bin.csv", "not a text file", folder=tmp_path)


@pytest.mark.parametrize("args,words", [
    (["--cover-n", "0.5"], ["--cover-n 0.5", "(1, 3]"]),
    (["--dc-loss", "1"], ["--dc-loss 1", "[0, 1)"]),
    (["--temp-air", "nan"], ["--temp-air nan", "degC"]),
    (["--cover-ar", "2"], ["--cover-ar 2", "--cover-n 1.526"]),
])
def test_pv_numbers_named(args, words, tmp_path, inputs, capsys):
    """Was: "n=np.float64(0.5) must be finite and > 1"."""
    line = refused(["pv", "yield", inputs / "roof.obj", "--weather", inputs / "w.epw", *args, "-o",
                    tmp_path / "y.csv"], capsys, *words, folder=tmp_path)
    assert "np.float64" not in line


@pytest.mark.parametrize("args,words", [
    (["--tz", "Europe/Prague", "--time", "2021-03-28 02:30"], ["--time '2021-03-28 02:30:00'", "does not exist",
                                                               "daylight-saving", "UTC offset"]),
    (["--tz", "Europe/Prague", "--time", "2021-10-31 02:30"], ["--time", "occurs twice"]),
    (["--tz", "UTC", "--time", "2300-01-01 12:00"], ["--time '2300-01-01 12:00'", "1677-09-23 to 2262-04-10"]),
    (["--tz", "UTC", "--start", "1600-01-01", "--end", "1600-01-02"], ["--start '1600-01-01'", "1677-09-23"]),
])
def test_sun_position_times(args, words, capsys):
    """Was: blamed on --pressure/--temperature/--delta-t, or "Out of bounds nanosecond timestamp"."""
    line = refused(["sun", "position", "--lat", "50", "--lon", "14", *args], capsys, *words)
    assert "--pressure" not in line and "nanosecond" not in line


def test_poa_period_times(tmp_path, inputs, capsys):
    base = ["poa", inputs / "roof.obj", "-o", tmp_path / "p.csv"]
    refused([*base, "--lat", "50", "--lon", "14", "--tz", "Europe/Prague", "--start", "2021-03-28 02:30", "--end",
             "2021-03-29"], capsys, "--start", "does not exist", folder=tmp_path)
    refused([*base, "--lat", "50", "--lon", "14", "--start", "2300-01-01", "--end", "2300-01-02"], capsys,
            "--start '2300-01-01'", "2262-04-10", folder=tmp_path)
    refused([*base, "--weather", inputs / "w.epw", "--coerce-year", "3000"], capsys, "--coerce-year 3000",
            "[1678, 2261]", folder=tmp_path)


# ------------------------------------------------------------------------------------------------------------
# outputs checked before the computation; no empty folders left
# ------------------------------------------------------------------------------------------------------------

def test_output_paths_checked_first(tmp_path, inputs, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "dir.h5").mkdir()
    common = [inputs / "roof.obj", "--weather", inputs / "w.epw"]
    refused(["poa", *common, "-o", "dir.h5"], capsys, "--output 'dir.h5'", "is a folder", folder=tmp_path)
    refused(["pv", "sweep", *common, "-o", "nodir/s.csv"], capsys, "--output 'nodir/s.csv'", "does not exist",
            folder=tmp_path)
    refused(["pv", "yield", *common, "-o", "y.txt"], capsys, "--output 'y.txt'", ".csv", folder=tmp_path)
    refused(["thermal", "glazing", "CLEAR_3.DAT", "--csv", "nodir/g.csv"], capsys, "--csv 'nodir/g.csv'",
            "does not exist", folder=tmp_path)
    refused(["pv", "plot-library", "lib.txt"], capsys, "'lib.txt'", ".png", folder=tmp_path)


def test_no_empty_folders(tmp_path, inputs, capsys, monkeypatch):
    """pv compare --group nothere and a thermal study that fails used to leave their (empty) output folders."""
    monkeypatch.chdir(tmp_path)
    refused(["pv", "compare", inputs / "roof.obj", "--weather", inputs / "w.epw", "--group", "nothere", "-o",
             "cmp"], capsys, "--group 'nothere'", "valid: roof", folder=tmp_path)
    (tmp_path / "bad.epw").write_text("LOCATION,x\n")
    before = _listing(tmp_path)
    rc = main(["thermal", "study", "--weather", "bad.epw", "--output", "study/out"])
    assert rc == 2 and _listing(tmp_path) == before
    capsys.readouterr()
    (tmp_path / "afile").write_text("x")
    refused(["thermal", "study", "--weather", DENVER, "--output", "afile"], capsys, "--output 'afile'",
            "is a file", folder=tmp_path)


def test_old_build_command_points_to_the_new_names(capsys):
    refused(["build", "solve"], capsys, "widesky solver", "widesky dataset build")


def test_report_folder_parents_not_created_before_the_run(tmp_path, capsys):
    """widesky run: a failing case leaves no parent folders of its report behind."""
    folder = tmp_path / "case"
    folder.mkdir()
    (folder / "geometry.py").write_text("def build(p):\n    return {'analysis': {\n")
    (folder / "case.toml").write_text(CASE.format(weather="", start="2024-06-21", end="2024-06-22",
                                                  sky_time="2024-06-21T12:30"))
    refused(["run", folder, "-o", tmp_path / "a" / "b" / "report"], capsys, "syntax error", folder=tmp_path)
    assert not os.path.exists(tmp_path / "a")
