"""The sky, dataset and sun command lines on bad input: one line on stderr, exit code 2, nothing written.

Each case is one a user met (issue 10): a traceback, a half-written output or a wrong result before.
"""

import os
import subprocess
import sys

import numpy as np
import pytest

from widesky import skymodel
from widesky.skymodel import render as render_mod
from widesky.cli import main

SMALL = ["--resolution", "24"]


def run_cli(args, capsys):
    rc = main(args)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def assert_clean_error(rc, err, *words):
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("widesky: error:"), err
    for w in words:
        assert w in lines[0], (w, lines[0])


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    from importlib.metadata import version
    assert capsys.readouterr().out.strip() == f"widesky {version('widesky')}"


@pytest.mark.parametrize("args, words", [
    (["--exposure", "1e6"], ["--exposure", "1000000.0", "[-100, 100]"]),     # was an OverflowError
    (["--exposure", "nan"], ["--exposure", "nan"]),                           # was a black PNG
    (["--elevation", "1000"], ["--elevation", "1000.0", "[-90, 90]"]),        # was only a clamp warning
    (["--albedo", "-0.5"], ["--albedo", "[0, 1]"]),
    (["--visibility", "0"], ["--visibility", "km"]),
    (["--altitude", "inf"], ["--altitude"]),
    (["--resolution", "20001"], ["--resolution", "[1, 20000]"]),
    (["--resolution", "0"], ["--resolution"]),
    (["--channel", "5000nm"], ["--channel", "5000nm", "[280, 2480) nm"]),
    (["--channel", "99"], ["--channel", "[0, 54]"]),
])
def test_render_bad_options(tmp_path, capsys, args, words):
    rc, out, err = run_cli(["sky", "render", *SMALL, "-o", str(tmp_path / "a.png"), *args], capsys)
    assert_clean_error(rc, err, *words)
    assert os.listdir(tmp_path) == []


def test_render_bad_output_paths(tmp_path, capsys):
    # a missing folder: was a RuntimeError after the PNG had been written
    rc, _, err = run_cli(["sky", "render", *SMALL, "-o", str(tmp_path / "nodir" / "a.exr")], capsys)
    assert_clean_error(rc, err, "--output", "does not exist")
    (tmp_path / "d.png").mkdir()
    rc, _, err = run_cli(["sky", "render", *SMALL, "-o", str(tmp_path / "d.png")], capsys)
    assert_clean_error(rc, err, "--output", "is a folder")
    (tmp_path / "e.exr").mkdir()  # the .exr beside a .png is a folder: refused before any work
    rc, _, err = run_cli(["sky", "render", *SMALL, "-o", str(tmp_path / "e.png")], capsys)
    assert_clean_error(rc, err, "is a folder")
    rc, _, err = run_cli(["sky", "render", *SMALL, "-o", str(tmp_path / "p.txt")], capsys)
    assert_clean_error(rc, err, "--output", ".png or .exr")
    assert sorted(os.listdir(tmp_path)) == ["d.png", "e.exr"]


def test_render_memory_is_estimated_first(tmp_path, capsys, monkeypatch):
    """--resolution 4000 under memory pressure was a MemoryError while writing the EXR: the CLI now
    estimates the memory first and refuses, naming the option and the largest resolution that fits."""
    need = render_mod.render_memory_bytes(4000, 55)
    assert need > 4000 ** 2 * 55 * 4  # at least the float32 image itself
    monkeypatch.setattr(render_mod, "available_memory_bytes", lambda: need // 2)
    rc, _, err = run_cli(["sky", "render", "--resolution", "4000", "-o", str(tmp_path / "a.png")], capsys)
    assert_clean_error(rc, err, "--resolution 4000", "GB")
    most = int(err.split("at most ")[1].split()[0])
    assert 2000 < most < 4000 and render_mod.render_memory_bytes(most, 55) <= need // 2
    assert os.listdir(tmp_path) == []


def test_render_outputs_are_all_or_nothing(tmp_path, capsys, monkeypatch):
    """A failure writing the EXR leaves neither the PNG nor a temporary file behind."""
    def fail(*a, **k):
        raise OSError("disk full (simulated)")
    monkeypatch.setattr(render_mod, "write_exr", fail)
    rc, _, err = run_cli(["sky", "render", *SMALL, "-o", str(tmp_path / "a.png")], capsys)
    assert_clean_error(rc, err, "disk full")
    assert os.listdir(tmp_path) == []


def test_render_clamp_policy(tmp_path, capsys):
    """One policy: a physically valid value outside the dataset's grid is clamped to the dataset's range
    with a warning (exit 0); a physically impossible one is an error (above). The sun elevation is the exception
    (issue 34): below the dataset's lowest elevation it is an error naming the range, since a clamped sun would
    be drawn where it is not."""
    model = skymodel.load_dataset()
    below = model.elevation_range[0] - 2.0
    rc, out, err = run_cli(["sky", "render", *SMALL, "--visibility", "300", "-o", str(tmp_path / "a.png")], capsys)
    assert rc == 0 and "warning:" in err and "clamped" in err and "visibility=300" in err
    assert sorted(os.listdir(tmp_path)) == ["a.exr", "a.png"]
    rc, out, err = run_cli(["sky", "render", *SMALL, "--elevation", str(below), "-o", str(tmp_path / "b.png")],
                           capsys)
    assert rc == 2 and "--elevation" in err and "outside the dataset's range" in err
    assert sorted(os.listdir(tmp_path)) == ["a.exr", "a.png"]


def test_render_files_are_complete(tmp_path, capsys):
    rc, out, _ = run_cli(["sky", "render", *SMALL, "-o", str(tmp_path / "a.png")], capsys)
    assert rc == 0 and f"wrote {tmp_path / 'a.png'}" in out
    assert sorted(os.listdir(tmp_path)) == ["a.exr", "a.png"]  # no temporary left
    mode = os.stat(tmp_path / "a.png").st_mode & 0o777
    umask = os.umask(0)
    os.umask(umask)
    assert mode == 0o666 & ~umask


@pytest.mark.parametrize("args, words", [
    (["--rank", "0"], ["--rank 0"]),                                  # was an IndexError
    (["--visibilities", "0,20"], ["--visibilities", "0.0 km"]),       # left an invalid file behind
    (["--visibilities", "60,20"], ["--visibilities", "ascending"]),
    (["--visibilities", "x"], ["--visibilities", "numbers"]),
    (["--albedos", "0,2"], ["--albedos", "[0, 1]"]),
    (["--channels", "56"], ["--channels 56", "[1, 55]"]),
    (["--knots", "1,8,8"], ["--knots"]),
    (["--elevations", "2"], ["--elevations 2"]),
])
def test_dataset_synthetic_bad_options(tmp_path, capsys, args, words):
    rc, _, err = run_cli(["dataset", "synthetic", str(tmp_path / "s.dat"), *args], capsys)
    assert_clean_error(rc, err, *words)
    assert os.listdir(tmp_path) == []


def test_dataset_synthetic_writes_a_valid_file(tmp_path, capsys):
    rc, out, _ = run_cli(["dataset", "synthetic", str(tmp_path / "s.dat"), "--channels", "3", "--rank", "1",
                          "--knots", "4,4,3", "--elevations", "4"], capsys)
    assert rc == 0 and "synthetic" in out
    assert sorted(os.listdir(tmp_path)) == ["s.dat", "s.dat.json"]
    m = skymodel.load_dataset(tmp_path / "s.dat")
    assert np.isfinite(skymodel.sky_radiance(m, [[0, 0, 1.0]], 30, 180, 50, 0.5)).all()


def test_sun_position_into_a_closed_pipe():
    """``widesky sun position | head -2`` was 'Broken pipe', exit 2: now a quiet exit 0."""
    cmd = [sys.executable, "-c", "import sys; from widesky.cli import main; sys.exit(main())", "sun", "position",
           "--lat", "52.3", "--lon", "4.77", "--start", "2021-06-21", "--end", "2021-07-21", "--step", "1min",
           "--tz", "Europe/Amsterdam"]
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE) as p:
        first = p.stdout.readline()
        p.stdout.close()  # the reader goes away, as head does
        err = p.stderr.read().decode()
        assert p.wait(timeout=120) == 0, err
    assert first.startswith(b"time,") and err == ""


@pytest.mark.parametrize("args, words", [
    (["position", "--lat", "52", "--lon", "4", "--start", "2000-01-01", "--end", "2200-01-01", "--step", "1min",
      "--tz", "0"], ["--start", "positions, at most 10,000,000"]),        # ran 106 s, then MemoryError
    (["position", "--lat", "52", "--lon", "4", "--start", "2000-01-01", "--end", "2000-01-02", "--step", "0h",
      "--tz", "0"], ["--step", "positive"]),
    (["position", "--lat", "100", "--lon", "4", "--time", "2021-01-01T00:00", "--tz", "0"], ["--lat", "latitude=100"]),
    (["position", "--lat", "10", "--lon", "4", "--time", "2021-01-01T00:00", "--tz", "0", "--pressure", "-5"],
     ["--pressure", "pressure=-5"]),
    (["position", "--lat", "10", "--lon", "4", "--time", "2021-01-01T00:00", "--tz", "0", "--temperature", "nan"],
     ["--temperature", "finite"]),
    (["skystates", "sample", "--elevation-step", "0"], ["--elevation-step", "> 0"]),
    (["skystates", "sample", "--default-albedo", "2"], ["--default-albedo", "[0, 1]"]),
])
def test_sun_bad_options(tmp_path, capsys, args, words):
    rc, _, err = run_cli(["sun", *args], capsys)
    assert_clean_error(rc, err, *words)


def test_sun_skystates_csv_checked_first_and_written_whole(tmp_path, capsys):
    rc, _, err = run_cli(["sun", "skystates", "sample", "--csv", str(tmp_path / "no" / "s.csv")], capsys)
    assert_clean_error(rc, err, "--csv", "does not exist")
    rc, out, _ = run_cli(["sun", "skystates", "sample", "--csv", str(tmp_path / "s.csv")], capsys)
    assert rc == 0 and os.listdir(tmp_path) == ["s.csv"]
    assert (tmp_path / "s.csv").read_text().count("\n") > 300
