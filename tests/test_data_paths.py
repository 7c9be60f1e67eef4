"""Where input data are looked up: a directory the user names is used or refused, never silently replaced."""

from __future__ import annotations

import pytest

from widesky.pvsim.spectra import find_data_file
from widesky.skymodel.generator.paths import DataNotFoundError, data_dir, data_file, has_data


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
    with pytest.raises(FileNotFoundError, match="nowhere"):
        find_data_file("solar/ASTMG173.csv")


def test_a_named_directory_is_used(tmp_path, monkeypatch):
    (tmp_path / "solar").mkdir()
    (tmp_path / "solar" / "x.csv").write_text("1,2\n")
    monkeypatch.setenv("WIDESKY_DATA_DIR", str(tmp_path))
    assert data_dir() == tmp_path
    assert data_file("solar/x.csv") == tmp_path / "solar" / "x.csv"
    assert find_data_file("solar/x.csv") == tmp_path / "solar" / "x.csv"
    with pytest.raises(FileNotFoundError, match="not found"):     # not looked up elsewhere either
        find_data_file("solar/ASTMG173.csv")
