"""Where data files are looked up (widesky.core.paths, the one resolver): the runtime data ships in the package and
is found with no folder or variable; a reference folder the user names is used or refused, never silently
replaced."""

from __future__ import annotations

import ast
import filecmp
import re
from pathlib import Path

import pytest

from widesky.core.paths import (RUNTIME_DATA_DIR, DataNotFoundError, data_dir, data_file, data_reference, has_data,
                                runtime_file, runtime_files)

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("src/widesky", "skymodel", "irradiance", "pvsim", "thermal", "cases")


def test_a_missing_named_directory_is_an_error(tmp_path, monkeypatch):
    missing = tmp_path / "nowhere"
    monkeypatch.setenv("WIDESKY_DATA_DIR", str(missing))
    with pytest.raises(DataNotFoundError, match="WIDESKY_DATA_DIR=.*nowhere.*is not a directory"):
        data_dir()
    with pytest.raises(DataNotFoundError, match="WIDESKY_DATA_DIR"):
        data_file("solar/ASTMG173.csv")
    assert not has_data()
    with pytest.raises(DataNotFoundError, match="data_dir=.*nowhere"):
        data_dir(missing)
    with pytest.raises(DataNotFoundError, match="data_dir=.*nowhere"):      # a named folder: no shipped copy instead
        runtime_file("solar/ASTMG173.csv", missing)


def test_a_named_directory_is_used(tmp_path, monkeypatch):
    (tmp_path / "solar").mkdir()
    (tmp_path / "solar" / "x.csv").write_text("1,2\n")
    monkeypatch.setenv("WIDESKY_DATA_DIR", str(tmp_path))
    assert data_dir() == tmp_path
    assert data_file("solar/x.csv") == tmp_path / "solar" / "x.csv"
    with pytest.raises(DataNotFoundError, match="'solar/ASTMG173.csv' not found"):   # not looked up elsewhere
        data_file("solar/ASTMG173.csv")
    assert runtime_file("solar/x.csv", tmp_path) == tmp_path / "solar" / "x.csv"


def test_runtime_data_needs_no_folder(tmp_path, monkeypatch):
    """The shipped files are found whatever the environment says; WIDESKY_DATA_DIR does not redirect them."""
    monkeypatch.setenv("WIDESKY_DATA_DIR", str(tmp_path / "nowhere"))
    f = runtime_file("solar/ASTMG173.csv")
    assert f == RUNTIME_DATA_DIR / "solar" / "ASTMG173.csv" and f.is_file()
    assert "CLEAR_3.DAT" in runtime_files("glazing") and runtime_files("nothing-here") == []
    assert "LICENSE-modelica-buildings.txt" not in runtime_files("weather")
    with pytest.raises(DataNotFoundError, match="'solar/none.csv' is missing from the package"):
        runtime_file("solar/none.csv")
    for bad in ("../pyproject.toml", "/etc/passwd", ""):
        with pytest.raises(ValueError, match="must be relative"):
            runtime_file(bad)


def test_data_reference(tmp_path, monkeypatch):
    """``data:<relative>``: the shipped file, else the reference folder's, else an error naming what ships."""
    monkeypatch.setenv("WIDESKY_DATA_DIR", str(tmp_path))
    denver = "weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw"
    assert data_reference(f"data:{denver}") == RUNTIME_DATA_DIR / denver
    (tmp_path / "weather").mkdir()
    (tmp_path / "weather" / "mine.epw").write_text("x")
    assert data_reference("data:weather/mine.epw") == tmp_path / "weather" / "mine.epw"
    with pytest.raises(DataNotFoundError, match=r"not shipped in the package \(shipped there: data:weather/USA_CO"):
        data_reference("data:weather/none.epw")
    with pytest.raises(ValueError, match="not a data-folder name"):
        data_reference("weather/none.epw")


def _runtime_names():
    """The file names the package's code passes to runtime_file (string literals)."""
    names = set()
    for pkg in PACKAGES:
        for f in (ROOT / pkg).rglob("*.py"):
            names |= set(re.findall(r"runtime_file\(\s*f?\"([^\"{]+)\"", f.read_text(encoding="utf-8")))
    return names


def test_every_runtime_file_ships_and_is_documented():
    """Each name the code reads with runtime_file is in widesky/data; each shipped file is in NOTICE and in
    docs/data-sources.md (source and licence), and nothing else lies in widesky/data."""
    names = _runtime_names()
    assert {"solar/ASTMG173.csv", "glazing/CLEAR_3.DAT", "gas/6S_band_gas_transmittance_USS62_55ch.csv"} <= names
    for n in names:
        assert (RUNTIME_DATA_DIR / n).is_file(), n
    notice = (ROOT / "NOTICE").read_text(encoding="utf-8")
    sources = (ROOT / "docs" / "data-sources.md").read_text(encoding="utf-8")
    shipped = sorted(p.relative_to(RUNTIME_DATA_DIR).as_posix() for p in RUNTIME_DATA_DIR.rglob("*") if p.is_file()
                     and "__pycache__" not in p.parts)
    assert shipped
    for rel in shipped:
        assert f"widesky/data/{rel}" in notice, rel
        assert f"widesky/data/{rel}" in sources, rel


@pytest.mark.reference
def test_shipped_files_are_the_reference_files():
    """Every shipped data file is byte for byte the file of the same name in the reference folder (MANIFEST.md
    gives its origin); of the licence texts, the Modelica Buildings one is there too (pvlib's and pyWinCalc's come
    from their distributions)."""
    for p in RUNTIME_DATA_DIR.rglob("*"):
        if not p.is_file() or "__pycache__" in p.parts or p.name in ("LICENSE-pvlib.txt", "LICENSE-pyWinCalc.txt"):
            continue
        rel = p.relative_to(RUNTIME_DATA_DIR).as_posix()
        ref = data_file("bestest/LICENSE-modelica-buildings.txt" if p.name == "LICENSE-modelica-buildings.txt"
                        else rel)
        assert filecmp.cmp(p, ref, shallow=False), rel


def test_core_imports_no_other_widesky_package():
    """The core layer is the lowest: its modules import only the standard library and each other."""
    for f in (ROOT / "src" / "widesky" / "core").glob("*.py"):
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            mods = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                    [node.module or ""] if isinstance(node, ast.ImportFrom) and node.level == 0 else [])
            for m in mods:
                top = m.split(".")[0]
                assert top not in PACKAGES[1:] and (top != "widesky" or m.startswith("widesky.core")), (f.name, m)
