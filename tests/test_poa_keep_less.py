"""Keeping only what was asked for (issue 36): broadband's parts, aoi and sun visibility optional, and a
reduce-only run with per-face period sums (``OutputOptions(parts=..., angles=..., arrays=...)``,
:class:`widesky.irradiance.sink.FaceSums`).

Reference: the default run (every response's three parts, aoi and sun visibility, in memory, one block of faces).
A run keeping less gives exactly (``assert_array_equal``) the default's numbers for what it keeps, in memory and
streamed to HDF5, in blocks of faces (product tiles of 8 faces, so that a 24-face scene runs in 3 blocks); a
response kept as "global" alone (or not at all) takes the fused product, equal to the three parts' float32 sum
within float32 rounding (rtol 1e-5, as tests/test_poa_parts.py), and the other responses' products, one column
fewer, then round their last bits differently: such runs are compared to float32 rounding (rtol 1e-5). Per-face sums: the sum over steps of the default run's arrays x
the step's hours / 1000 [kWh m-2], to float32 tolerance (rtol 1e-5 of the largest face's sum).
"""

import numpy as np
import pytest
import trimesh

import widesky.irradiance.output_plan as output_plan
import widesky.irradiance.products as products
from widesky.irradiance import (OutputOptions, Response, RunOptions, SkyStates, make_scene, poa_irradiance)
from widesky.irradiance.result import PARTS, POAResult
from widesky.irradiance.sink import FaceSums
from widesky.irradiance.skies import UniformSky

SKY = UniformSky(radiance=0.05, dni=0.9)
STATES = SkyStates.create([8.0, 30.0, 55.0, 20.0, -5.0, 65.0], [100.0, 150.0, 190.0, 250.0, 300.0, 175.0],
                          40.0, 0.25)


def _box(extents, rot, xyz):
    m = trimesh.creation.box(extents=extents)
    m.apply_transform(trimesh.transformations.rotation_matrix(np.radians(rot), [1, 0, 0]))
    m.apply_translation(xyz)
    return m


def _scene():
    """Two tilted module rows (24 analysed faces, both sides), a vertical panel and a wall as context."""
    rows = [_box((6.0, 2.0, 0.02), 30.0, (0.0, y, 1.5)) for y in (0.0, -4.0)]
    return make_scene(rows, [_box((6.0, 2.0, 0.02), 90.0, (0.0, 6.0, 1.5)), _box((8.0, 1.0, 5.0), 0.0, (0, 10, 2.5))],
                      ground_z=0.0)


def _responses():
    wl = np.linspace(280.0, 2480.0, 12)
    return [Response("a", wl, 0.6 * np.clip((wl - 300) / 800, 0, 1), unit="sr"),
            Response("b", wl, np.exp(-((wl - 700) / 300) ** 2), unit="qe",
                     angular=lambda aoi: np.maximum(np.cos(np.radians(np.clip(aoi, 0, 90))), 0.0) ** 0.2)]


@pytest.fixture(scope="module")
def tile8():
    """Product tiles (and automatic blocks) of 8 faces, for the reference run too (a tile's width sets the BLAS
    calls, hence the last bits)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(products, "FACE_TILE", 8)
        mp.setattr(output_plan, "FACE_ALIGN", 8)
        yield


@pytest.fixture(scope="module")
def full(tile8):
    return poa_irradiance(_scene(), SKY, STATES, responses=_responses(), run=RunOptions(n_jobs=1))


class Nop:
    def __call__(self, steps, block, rows, currents, faces):
        pass


def _fuses(parts):
    """True when ``parts`` moves a response to the fused product ("global" alone, or nothing)."""
    return any(((v,) if isinstance(v, str) else tuple(v)) in (("global",), ()) for v in parts.values())


def _check_kept(full, res, parts, angles):
    # a response moved to the fused product leaves fewer columns in the other responses' matrix products,
    # whose BLAS calls then round their last bits differently: those runs agree to float32 rounding
    exact = not _fuses(parts)
    names = [n for n in full.responses if parts.get(n, PARTS) != ()]
    assert list(res.responses) == names
    for n in names:
        want = parts.get(n, PARTS)
        want = (want,) if isinstance(want, str) else tuple(want)
        assert set(res.stored_parts[n]) == set(want)
        for p in res.available_parts(n):
            if not exact:                              # the fused product: the three parts' sum within rounding
                np.testing.assert_allclose(res.get(n, p), full.get(n, p), rtol=1e-5,
                                           atol=1e-5 * float(full.get(n, p).max()), err_msg=f"{n} {p}")
            else:
                np.testing.assert_array_equal(res.get(n, p), full.get(n, p), err_msg=f"{n} {p}")
        for p in set(("direct", "sky_diffuse", "ground_diffuse", "global")) - set(res.available_parts(n)):
            with pytest.raises(ValueError, match="was kept with parts"):
                res.get(n, p)
    if angles:
        np.testing.assert_array_equal(res.aoi, full.aoi)
        np.testing.assert_array_equal(res.sun_visible, full.sun_visible)
    else:
        assert not res.has_angles
        for name in ("aoi", "sun_visible"):
            with pytest.raises(ValueError, match=f"{name} was not kept"):
                getattr(res, name)
    assert (res.n_steps, res.n_faces) == (full.n_steps, full.n_faces)


COMBOS = [({"broadband": ("direct", "ground_diffuse")}, False),
          ({"broadband": "sky_diffuse", "a": ("direct",)}, True),
          ({}, False),
          ({"broadband": ("global",), "b": "global"}, False),
          ({"broadband": ()}, True),
          ({"broadband": (), "a": ()}, False)]


@pytest.mark.parametrize("parts,angles", COMBOS)
def test_keeping_less_gives_the_same_numbers(full, tile8, tmp_path, parts, angles):
    scene, r = _scene(), _responses()
    consumer = Nop() if () in parts.values() else None
    for face_block, path in ((None, None), (8, None), (16, tmp_path / "r.h5")):
        res = poa_irradiance(scene, SKY, STATES, responses=r,
                             run=RunOptions(n_jobs=1, face_block=face_block),
                             output=OutputOptions(parts=parts, angles=angles, consumer=consumer, path=path))
        assert res.timings["face_blocks"] == {None: 1, 8: 3, 16: 2}[face_block]
        _check_kept(full, res, parts, angles)
        if path is not None:                           # the file reads back the same, and saves again
            res.save(tmp_path / "again.h5")
            with POAResult.load(tmp_path / "again.h5") as again:
                _check_kept(full, again, parts, angles)
            res.close()


def _sums_of(full, hours):
    out = {}
    w = np.asarray(hours, float) * np.ones(full.n_steps) / 1000.0
    for n in full.responses:
        for p in full.available_parts(n):
            out[(n, p)] = w @ full.get(n, p).astype(np.float64)
    return out


@pytest.mark.parametrize("face_block", [None, 8])
def test_face_sums_reduce_only(full, tile8, face_block):
    hours = np.array([1.0, 0.5, 1.0, 2.0, 1.0, 0.25])
    sums = FaceSums(full.n_faces, step_hours=hours)
    res = poa_irradiance(_scene(), SKY, STATES, responses=_responses(),
                         run=RunOptions(n_jobs=1, face_block=face_block),
                         output=OutputOptions(parts={"broadband": (), "a": "global"}, angles=False, arrays=False,
                                              consumer=sums))
    assert res.responses == () and not res.has_angles and (res.n_steps, res.n_faces) == (6, 24)
    ref = _sums_of(full, hours)
    want = {("broadband", "global"), ("a", "global")} | {("b", p) for p in PARTS + ("global",)}
    assert set(sums.sums) == want
    for k in want:
        np.testing.assert_allclose(sums.sums[k], ref[k], rtol=1e-5, atol=1e-5 * ref[k].max(), err_msg=str(k))
    assert ref[("broadband", "global")].max() > 0 and ref[("b", "ground_diffuse")].max() > 0
    tab = sums.table(res.faces)
    assert len(tab) == 24 and "broadband:global" in tab and tab["area_m2"].gt(0).all()


def test_face_sums_beside_a_streamed_run(full, tile8, tmp_path):
    sums = FaceSums(full.n_faces)                     # hourly: step_hours 1
    with poa_irradiance(_scene(), SKY, STATES, responses=_responses(), run=RunOptions(n_jobs=1, face_block=8),
                        output=OutputOptions(path=tmp_path / "s.h5", consumer=sums)) as res:
        _check_kept(full, res, {}, True)
    ref = _sums_of(full, 1.0)
    assert set(sums.sums) == set(ref)
    for k, v in ref.items():
        np.testing.assert_allclose(sums.sums[k], v, rtol=1e-5, atol=1e-5 * v.max(), err_msg=str(k))


def test_bad_combinations():
    scene, r = _scene(), _responses()
    for kw, err, msg in (({"arrays": False}, ValueError, "give a consumer"),
                         ({"arrays": False, "consumer": Nop(), "path": "x.h5"}, ValueError, "arrays=False writes"),
                         ({"arrays": False, "consumer": Nop(), "spectral": True}, ValueError, "spectral"),
                         ({"angles": "no"}, TypeError, "angles: expected True or False"),
                         ({"arrays": 0}, TypeError, "arrays: expected True or False")):
        with pytest.raises(err, match=msg):
            OutputOptions(**kw)
    with pytest.raises(ValueError, match="no consumer reads them"):
        poa_irradiance(scene, SKY, STATES.take([1]), responses=r, run=RunOptions(n_jobs=1),
                       output=OutputOptions(parts={"broadband": ()}))
    with pytest.raises(ValueError, match="each part must be one of"):
        poa_irradiance(scene, SKY, STATES.take([1]), responses=r, run=RunOptions(n_jobs=1),
                       output=OutputOptions(parts={"broadband": "total"}))
    for bad in (-1.0, [[1.0]], np.nan):
        with pytest.raises(ValueError, match="step_hours"):
            FaceSums(3, step_hours=bad)
    with pytest.raises(ValueError, match="step_hours has 2 steps"):
        poa_irradiance(scene, SKY, STATES, responses=r, run=RunOptions(n_jobs=1),
                       output=OutputOptions(consumer=FaceSums(scene.n_faces, [1.0, 1.0]), arrays=False))


# --- widesky poa --face-sums --------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def roof(tmp_path_factory):
    """A 4 m x 3 m horizontal roof (2 faces) and a 2 m wall south of it facing north."""
    d = tmp_path_factory.mktemp("sums_cli")
    v = np.array([[0, 0, 0.0], [4, 0, 0.0], [4, 3, 0.0], [0, 3, 0.0]])
    trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False).export(d / "roof.obj")
    return d / "roof.obj"


CLEAR = ["--lat", "48", "--lon", "11", "--tz", "Europe/Berlin", "--start", "2021-06-21", "--end", "2021-06-22",
         "--step", "30min", "--jobs", "1"]


def test_cli_face_sums_equal_the_full_result(roof, tmp_path):
    import pandas as pd
    from widesky.cli import main
    assert main(["poa", str(roof), *CLEAR, "-o", str(tmp_path / "full.h5")]) == 0
    assert main(["poa", str(roof), *CLEAR, "--face-sums", "-o", str(tmp_path / "sums.csv")]) == 0
    tab = pd.read_csv(tmp_path / "sums.csv", index_col=0)
    assert len(tab) == 2 and list(tab["area_m2"]) == [6.0, 6.0]
    with POAResult.load(tmp_path / "full.h5") as z:
        for p in ("global", "direct", "sky_diffuse", "ground_diffuse"):
            want = z.get("broadband", p).astype(np.float64).sum(axis=0) * 0.5 / 1000.0      # 30-min steps
            np.testing.assert_allclose(tab[f"broadband:{p}"], want, rtol=1e-5, err_msg=p)
    # a clear June day at 48 N on a horizontal roof: about 8 kWh m-2 (global horizontal irradiation)
    assert 6.0 < tab["broadband:global"].iloc[0] < 9.5


@pytest.mark.parametrize("extra, out, msg", [
    (["--face-sums"], "x.h5", "--face-sums: --output"),
    (["--face-sums", "--group", "roof"], "x.csv", "--face-sums with --group"),
])
def test_cli_face_sums_bad_input(roof, tmp_path, capsys, extra, out, msg):
    from widesky.cli import main
    assert main(["poa", str(roof), *CLEAR, *extra, "-o", str(tmp_path / out)]) == 2
    err = capsys.readouterr().err
    assert msg in err and err.count("\n") == 1 and "Traceback" not in err
    assert not any(tmp_path.iterdir())


def test_step_hours_of_a_typical_year():
    """A TMY3/EPW year joins months of different years: its times step backwards (and years ahead) at month
    boundaries, so each step's length is the series' median interval (1 h), not the time to the next record.
    (The shipped Denver TMY3 file made `widesky poa --face-sums` refuse its own step lengths before.)"""
    import pandas as pd
    from widesky.commands.poa import step_hours
    jan = pd.date_range("1995-01-01 01:00", periods=744, freq="h", tz="Etc/GMT+7")
    feb = pd.date_range("1991-02-01 01:00", periods=672, freq="h", tz="Etc/GMT+7")
    mar = pd.date_range("2003-03-01 01:00", periods=744, freq="h", tz="Etc/GMT+7")
    w = step_hours(jan.append(feb).append(mar))
    assert w.shape == (2160,) and np.all(w == 1.0)
    half = pd.date_range("2021-06-21", periods=5, freq="30min", tz="UTC")
    assert np.all(step_hours(half) == 0.5) and step_hours(half[:1]).tolist() == [1.0]
