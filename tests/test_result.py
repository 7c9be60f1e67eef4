"""POAResult: save/load round trip (HDF5), streaming equals in memory, reads by group and period,
to_pvlib and parts; references are the in-memory result itself (exact float32 equality)."""

import numpy as np
import pandas as pd
import pytest
import trimesh

from widesky.irradiance import (AngularTable, OutputOptions, POAResult, Response, RunOptions, SkyStates, make_scene,
                                poa_irradiance)
from widesky.irradiance.skies import AnalyticSky


def quad(tilt, azimuth, centre=(0.0, 0.0, 0.0)):
    t, a = np.radians(tilt), np.radians(azimuth)
    n = np.array([np.sin(t) * np.sin(a), np.sin(t) * np.cos(a), np.cos(t)])
    u = np.cross([0, 0, 1.0], n) if abs(n[2]) < 0.999 else np.array([1.0, 0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    c = np.asarray(centre, float)
    pts = [c - u / 2 - v / 2, c + u / 2 - v / 2, c + u / 2 + v / 2, c - u / 2 + v / 2]
    return trimesh.Trimesh(pts, [[0, 1, 2], [0, 2, 3]], process=False)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    times = pd.date_range("2021-06-21 04:00", periods=12, freq="2h", tz="Europe/Prague")
    el = np.array([-10, 5, 20, 40, 55, 62, 55, 40, 20, 5, -3, -20.0])
    az = np.linspace(60, 300, 12)
    st = SkyStates.create(el, az, 40.0, 0.2, earth_sun_distance=1.0163,
                          clamped={"visibility": np.arange(12) % 5 == 0}, times=times)
    scene = make_scene([quad(30, 180), quad(90, 90, (3, 0, 0.5))], groups=["roof", "wall"],
                       ground_z=-2.0)
    iam = AngularTable([0, 60, 80, 90], [1.0, 0.95, 0.6, 0.0])
    resp = [Response("cell", [280, 1200], [0.2, 0.7], unit="sr", angular=iam)]
    mem = poa_irradiance(scene, AnalyticSky(), st, responses=resp, run=RunOptions(n_jobs=1))
    path = tmp_path_factory.mktemp("res") / "r.h5"
    streamed = poa_irradiance(scene, AnalyticSky(), st, responses=resp, run=RunOptions(n_jobs=1),
                              output=OutputOptions(path=path, block_steps=5))
    return mem, streamed, path


def test_streamed_equals_in_memory_and_round_trips(run, tmp_path):
    mem, streamed, path = run
    assert streamed.source == str(path) and streamed.responses == ("broadband", "cell")
    assert streamed.units == {"broadband": "W m-2", "cell": "A m-2"}
    for r in mem.responses:
        for p in ("direct", "sky_diffuse", "ground_diffuse", "global"):
            np.testing.assert_array_equal(streamed.get(r, p), mem.get(r, p), err_msg=f"{r} {p}")
    np.testing.assert_array_equal(streamed.aoi, mem.aoi)
    np.testing.assert_array_equal(streamed.sun_visible, mem.sun_visible)
    assert streamed.times.equals(mem.times) and str(streamed.times.tz) == "Europe/Prague"
    np.testing.assert_array_equal(streamed.states.earth_sun_distance, 1.0163)
    np.testing.assert_array_equal(streamed.states.clamped["visibility"],
                                  mem.states.clamped["visibility"])
    np.testing.assert_array_equal(streamed.faces.tilt, mem.faces.tilt)
    assert streamed.faces.group_names == ("roof", "wall")
    assert "settings" in streamed.provenance and "versions" in streamed.provenance
    # save of the in-memory result gives the same file content
    p2 = tmp_path / "again.h5"
    mem.save(p2)
    with POAResult.load(p2) as back:
        np.testing.assert_array_equal(back.get("cell", "global"), mem.get("cell", "global"))
        np.testing.assert_array_equal(back.aoi, mem.aoi)
    assert not list(tmp_path.glob(".tmp-*"))


def test_night_and_orientation(run):
    mem = run[0]
    night = mem.states.sun_elevation <= 0
    assert np.all(np.isnan(mem.aoi[night])) and not np.any(np.isnan(mem.aoi[~night]))
    assert np.all(mem.poa_direct[night] == 0)
    np.testing.assert_allclose(mem.faces.tilt, [30, 30, 90, 90], atol=1e-9)
    np.testing.assert_allclose(mem.faces.azimuth, [180, 180, 90, 90], atol=1e-9)
    # the optic only removes light, and the beam's factor is the table at the face's aoi
    day = ~night
    r = mem.get("cell", "direct")[day] / np.where(mem.poa_direct[day] > 0, mem.poa_direct[day], 1)
    assert np.all(mem.get("cell", "global") <= mem.poa_global)
    g = np.interp(mem.aoi[day], [0, 60, 80, 90], [1.0, 0.95, 0.6, 0.0])
    lit = mem.poa_direct[day] > 1.0
    ratio0 = r[lit] / g[lit]
    assert np.ptp(ratio0) < 1e-5 * ratio0.mean()         # one spectral weight, times the exact IAM


def test_load_by_group_and_period(run):
    mem, _, path = run
    part = POAResult.load(path, groups=["wall"], start="2021-06-21 08:00", end="2021-06-21 14:00")
    assert part.n_faces == 2 and part.n_steps == 3
    np.testing.assert_array_equal(part.poa_global, mem.poa_global[2:5, 2:4])
    assert list(part.faces.group) == [1, 1]
    with pytest.raises(ValueError, match="group"):
        POAResult.load(path, groups=["nope"])


def test_to_pvlib_group_is_area_weighted(run):
    mem = run[0]
    df = mem.to_pvlib(group="roof", response="cell")
    np.testing.assert_allclose(df["poa_global"], mem.get("cell", "global")[:, :2].mean(axis=1),
                               rtol=1e-6)
    assert list(df.columns) == ["poa_global", "poa_direct", "poa_sky_diffuse",
                                "poa_ground_diffuse", "aoi", "sun_visible"]
    with pytest.raises(ValueError, match="faces"):
        mem.to_pvlib()


def test_load_refuses_other_files(tmp_path):
    p = tmp_path / "x.h5"
    p.write_bytes(b"not hdf5")
    with pytest.raises(ValueError, match="HDF5"):
        POAResult.load(p)
