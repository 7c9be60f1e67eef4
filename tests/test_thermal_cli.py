"""``widesky thermal``: outputs and one-line errors (exit 2); the facade PLY reads back."""

import numpy as np
import pandas as pd
import pytest

from widesky.cli import main
from widesky.thermal.facade import write_facade_ply

from widesky.core.paths import runtime_file

DENVER = "data:weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw"      # shipped in the package


def test_glazing_command(tmp_path, capsys):
    csv = tmp_path / "g.csv"
    rc = main(["thermal", "glazing", str(runtime_file("glazing/CLEAR5.LOF")),
               "LOW-E_5.LOF", "--gap", "12.7:argon", "--csv", str(csv)])         # a path, a shipped sample
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


def test_loads_command_weather_route(tmp_path, capsys):
    out, ply = tmp_path / "loads.csv", tmp_path / "map.ply"
    rc = main(["thermal", "loads", "--weather", DENVER, "--sky", "weather", "--route", "rated",
        "--wwr", "S=0.5,N=0.2", "--output", str(out), "--facade-map", str(ply)])
    assert rc == 0 and "4 zones, 8760 steps" in capsys.readouterr().out
    df = pd.read_csv(out, index_col=0)
    assert df["f0_south:solar_W"].sum() > df["f0_north:solar_W"].sum() > 0
    import trimesh
    m = trimesh.load(ply, process=False)
    assert len(m.faces) > 0
    assert main(["thermal", "loads", "--weather", str(out) + "x", "--output", str(out)]) == 2
    assert main(["thermal", "loads", "--weather", DENVER, "--sky", "weather", "--wwr", "Q=1",
        "--output", str(out)]) == 2


def test_facade_ply_roundtrip(tmp_path):
    import trimesh
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    p = tmp_path / "m.ply"
    write_facade_ply(p, v, f, [1.0, np.nan])               # NaN (e.g. shading faces): grey
    m = trimesh.load(p, process=False)
    assert np.asarray(m.visual.face_colors)[1, :3].tolist() == [128, 128, 128]
    write_facade_ply(p, v, f, [1.0, 2.0])
    m = trimesh.load(p, process=False)
    assert m.faces.tolist() == f.tolist()
    c = np.asarray(m.visual.face_colors)[:, :3]
    assert c[0].tolist() != c[1].tolist()
    with pytest.raises(ValueError, match="per face"):
        write_facade_ply(p, v, f, [1.0])
    assert [x.name for x in tmp_path.iterdir()] == ["m.ply"]      # no temporary left behind


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:.*clamped to the sky model's ranges:UserWarning")
def test_loads_command_context_shades(tmp_path, capsys):
    """A 15 m block 6-12 m south of the building (a mesh file, ``--context``) shades the south
    facade on the winter solstice: the south zone's solar gain falls below a tenth of the
    unshaded one (9:00-16:00 of 21 December in the Denver TMY3 year, integrator route)."""
    import trimesh
    lines = runtime_file("weather/USA_CO_Denver.Intl.AP.725650_TMY3.epw").read_text().splitlines()
    day = [r for r in lines[8:]
           if r.split(",")[1:3] == ["12", "21"] and 9 <= int(r.split(",")[3]) <= 16]
    epw = tmp_path / "dec21.epw"
    epw.write_text("\n".join(lines[:8] + day) + "\n")
    out = tmp_path / "loads.csv"
    base = ["thermal", "loads", "--weather", str(epw), "--route", "rated", "--output", str(out)]
    assert main(base) == 0
    free = pd.read_csv(out, index_col=0)
    mesh = tmp_path / "block.ply"
    trimesh.creation.box((30.0, 6.0, 15.0)).apply_translation((10.0, -9.0, 7.5)).export(mesh)
    assert main(base + ["--context", str(mesh)]) == 0
    shaded = pd.read_csv(out, index_col=0)
    capsys.readouterr()
    south = "f0_south:solar_W"
    assert len(free) == 8 and free[south].sum() > 0
    assert shaded[south].sum() < 0.1 * free[south].sum()
    assert main(base + ["--context", str(tmp_path / "none.ply")]) == 2
    assert "not found" in capsys.readouterr().err
    assert main(base + ["--sky", "weather", "--context", str(mesh)]) == 2
    assert "integrator" in capsys.readouterr().err


def test_context_box_option():
    """``--context-box X,Y,W,D,H``: a block with its south-west corner at X,Y on the ground."""
    import argparse
    from widesky.commands.thermal import _context
    m, = _context(argparse.Namespace(context=[], context_box=["-5,-12,30,6,15"]))
    assert m.bounds.tolist() == [[-5.0, -12.0, 0.0], [25.0, -6.0, 15.0]]
    for bad in ("1,2,3", "0,0,1,1,-2"):
        with pytest.raises(ValueError, match="--context-box"):
            _context(argparse.Namespace(context=[], context_box=[bad]))
