"""``widesky thermal``: outputs and one-line errors (exit 2); the facade PLY reads back."""

import numpy as np
import pandas as pd
import pytest

from skymodel.cli import main
from thermal.facade import write_facade_ply

try:
    from skymodel.generator.paths import data_file
    data_file("glazing/CLEAR5.LOF")
    data_file("weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw")
    HAVE_DATA = True
except Exception:                     # noqa: BLE001
    HAVE_DATA = False
needs_data = pytest.mark.skipif(not HAVE_DATA, reason="../shared/data not available")


@needs_data
@pytest.mark.reference
def test_glazing_command(tmp_path, capsys):
    csv = tmp_path / "g.csv"
    rc = main(["thermal", "glazing", str(data_file("glazing/CLEAR5.LOF")),
               str(data_file("glazing/LOW-E_5.LOF")), "--gap", "12.7:argon", "--csv", str(csv)])
    out = capsys.readouterr().out
    assert rc == 0 and "U = 1.5" in out and "inward fraction" in out
    t = pd.read_csv(csv, index_col=0)
    assert t["shgc"].iloc[0] > t["shgc"].iloc[-1] and t.index[-1] == 90


def test_errors_are_one_line(capsys, tmp_path):
    assert main(["thermal", "glazing", str(tmp_path / "none.dat")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not found" in err
    assert main(["thermal", "bestest", "--case", "123"]) == 2
    assert "case" in capsys.readouterr().err


@needs_data
@pytest.mark.reference
def test_loads_command_weather_route(tmp_path, capsys):
    out, ply = tmp_path / "loads.csv", tmp_path / "map.ply"
    rc = main(["thermal", "loads", "--weather", str(data_file(
        "weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw")), "--sky", "weather", "--route", "rated",
        "--wwr", "S=0.5,N=0.2", "--output", str(out), "--facade-map", str(ply)])
    assert rc == 0 and "4 zones, 8760 steps" in capsys.readouterr().out
    df = pd.read_csv(out, index_col=0)
    assert df["f0_south:solar_W"].sum() > df["f0_north:solar_W"].sum() > 0
    import trimesh
    m = trimesh.load(ply, process=False)
    assert len(m.faces) > 0
    assert main(["thermal", "loads", "--weather", str(out) + "x", "--output", str(out)]) == 2
    assert main(["thermal", "loads", "--weather", str(data_file(
        "weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw")), "--sky", "weather", "--wwr", "Q=1",
        "--output", str(out)]) == 2


def test_facade_ply_roundtrip(tmp_path):
    import trimesh
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    p = tmp_path / "m.ply"
    write_facade_ply(p, v, f, [1.0, 2.0])
    m = trimesh.load(p, process=False)
    assert m.faces.tolist() == f.tolist()
    c = np.asarray(m.visual.face_colors)[:, :3]
    assert c[0].tolist() != c[1].tolist()
    with pytest.raises(ValueError, match="per face"):
        write_facade_ply(p, v, f, [1.0])
    assert [x.name for x in tmp_path.iterdir()] == ["m.ply"]      # no temporary left behind
