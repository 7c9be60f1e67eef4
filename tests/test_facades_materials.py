"""Surface materials on the command line (issue 39): ``widesky poa --reflectance GROUP=VALUE``.

A 4 m wide floor strip (group ``floor.obj``) in front of a 4 m high wall (group ``wall.obj``): the wall's
reflected light reaching the floor scales with the wall's reflectance (the floor's part from the wall is
linear in it to first order: the floor's reflected light at reflectance r is ``ground + r x wall`` plus the
later reflections' r**2 ... terms, so three runs give 0, 1 and 2 times the wall's part within 1 %); bad values
give exit status 2 and one line naming the option, the value and what is valid.
"""

import numpy as np
import pandas as pd
import pytest
import trimesh

from widesky.cli import main

CLEAR = ["--lat", "48", "--lon", "11", "--tz", "Europe/Berlin", "--start", "2021-06-21T06:00",
         "--end", "2021-06-21T20:00", "--jobs", "1"]


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    d = tmp_path_factory.mktemp("materials")
    floor = np.array([[0, 0, 0.01], [4, 0, 0.01], [4, 4, 0.01], [0, 4, 0.01]], dtype=float)
    wall = np.array([[0, 4.2, 0], [4, 4.2, 0], [4, 4.2, 4], [0, 4.2, 4]], dtype=float)   # facing south (-y)
    trimesh.Trimesh(floor, [[0, 1, 2], [0, 2, 3]], process=False).export(d / "floor.obj")
    trimesh.Trimesh(wall, [[0, 2, 1], [0, 3, 2]], process=False).export(d / "wall.obj")
    return d / "floor.obj", d / "wall.obj"


def _run(meshes, tmp_path, *extra):
    floor, wall = meshes
    out = tmp_path / f"r{len(list(tmp_path.iterdir()))}.csv"
    assert main(["poa", str(floor), str(wall), *CLEAR, *extra, "--ground-z", "0", "-o", str(out)]) == 0
    df = pd.read_csv(out, index_col=0)
    return df[[c for c in df.columns if str(floor) in c and "ground_diffuse" in c]].to_numpy().sum()


def test_wall_reflectance_moves_the_floor_light(meshes, tmp_path):
    floor, wall = meshes
    r0 = _run(meshes, tmp_path, "--reflectance", f"{wall}=0")
    r1 = _run(meshes, tmp_path, "--reflectance", f"{wall}=0.3")
    r2 = _run(meshes, tmp_path, "--reflectance", f"{wall}=0.6")
    assert r1 > r0 * 1.05
    # linear to first order: the later reflections (IntegratorSettings.reflections, default 3) add the
    # wall -> floor -> wall paths, measured +0.2 % and +0.4 % on the slope at 0.3 and 0.6 against 0.1
    np.testing.assert_allclose(r2 - r0, 2 * (r1 - r0), rtol=1e-2)
    default = _run(meshes, tmp_path)                                   # 0.1 for analysis meshes
    np.testing.assert_allclose(default - r0, (r1 - r0) / 3, rtol=1e-2)
    # the floor's own reflectance reaches it through those paths (measured +48 % with 0.9)
    assert _run(meshes, tmp_path, "--reflectance", f"{wall}=0.6", "--reflectance", f"{floor}=0.9") > 1.2 * r2


@pytest.mark.parametrize("item, msg", [("x.obj=0.3", "no analysis mesh 'x.obj'"), ("{wall}=1.5", "in [0, 1]"),
                                       ("{wall}=refl.csv", "spectral reflectance file is not supported"),
                                       ("0.3", "expected GROUP=VALUE")])
def test_bad_reflectance_is_one_line(meshes, tmp_path, capsys, item, msg):
    floor, wall = meshes
    out = tmp_path / "x.csv"
    assert main(["poa", str(floor), str(wall), *CLEAR, "--reflectance", item.format(wall=wall),
                 "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--reflectance" in err and msg in err and err.count("\n") == 1
    assert not out.exists()


def _pv_floor_ground(meshes, tmp_path, *extra):
    floor, wall = meshes
    out = tmp_path / f"pv{len(list(tmp_path.iterdir()))}.csv"
    assert main(["pv", "yield", str(floor), str(wall), *CLEAR, "--ground-z", "0", "--group", "floor", *extra,
                 "-o", str(out)]) == 0
    return pd.read_csv(out, index_col=0)["poa_ground_diffuse"].sum()


def test_pv_takes_the_same_reflectance(meshes, tmp_path):
    """``widesky pv`` passes ``--reflectance`` to the scene as ``poa`` does (groups are the meshes' stems): the
    floor's reflected light grows with the wall's reflectance, by the same amount as through ``poa``."""
    r0 = _pv_floor_ground(meshes, tmp_path, "--reflectance", "wall=0")
    r1 = _pv_floor_ground(meshes, tmp_path, "--reflectance", "wall=0.3")
    assert r1 > r0 * 1.05


def test_pv_bad_reflectance_is_one_line(meshes, tmp_path, capsys):
    floor, wall = meshes
    out = tmp_path / "y.csv"
    assert main(["pv", "yield", str(floor), str(wall), *CLEAR, "--reflectance", "wal=0.3", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no analysis mesh 'wal'" in err and "floor, wall, CONTEXT" in err and err.count("\n") == 1
    assert not out.exists()


def test_reflections_option(meshes, tmp_path, capsys):
    """``--reflections N`` reaches the integrator: with reflective wall and floor (0.8 each) the floor's reflected
    light grows from one bounce to three (the wall -> floor -> wall -> floor paths); 0 is refused in one line."""
    floor, wall = meshes
    mats = ["--reflectance", f"{wall}=0.8", "--reflectance", f"{floor}=0.8"]
    one = _run(meshes, tmp_path, *mats, "--reflections", "1")
    three = _run(meshes, tmp_path, *mats, "--reflections", "3")
    assert three > one * 1.1
    out = tmp_path / "z.csv"
    assert main(["poa", str(floor), str(wall), *CLEAR, "--reflections", "0", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--reflections 0" in err and "[1, 20]" in err and err.count("\n") == 1
    assert not out.exists()
