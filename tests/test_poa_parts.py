"""``poa_irradiance(parts=...)``: responses kept as their global part only (the fast path for many
PV cell currents) give the same numbers as the full run's ``get(name, "global")``.

Reference: the full per-response run on the same scene, sky and states. With a ground albedo that
changes between steps the global-only path stores the float32 sum of the three face-mean parts that
``POAResult.get`` would form from a full run, so the comparison is exact (bitwise), in memory and
streamed to HDF5; angle-only optics shared by several responses are evaluated once per chunk (counted
here), with no change to the numbers. With a constant albedo (it folds into the reflected-sky matrix)
global-only responses take the fused product, one matrix per optic: compared within float32 rounding
(the last tests), with a consumer that receives them chunk by chunk.
"""

import h5py
import numpy as np
import pytest
import trimesh

from widesky.irradiance import (OutputOptions, POAResult, Response, RunOptions, SkyStates, SpectralAngularTable,
                                make_scene, poa_irradiance)
from widesky.irradiance.optics import DEFAULT_NODES
from widesky.irradiance.skies import UniformSky

STATES = SkyStates.create([8.0, 30.0, 55.0, 20.0, -5.0], [100.0, 150.0, 190.0, 250.0, 300.0],
                          40.0, [0.2, 0.2, 0.3, 0.3, 0.2])


def _fresnel(aoi):
    th = np.radians(np.clip(aoi, 0.0, 89.9))
    tr = np.arcsin(np.sin(th) / 1.5)
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = np.where(th > 1e-6, (np.sin(tr - th) / np.sin(tr + th)) ** 2, 0.04)
        rp = np.where(th > 1e-6, (np.tan(tr - th) / np.tan(tr + th)) ** 2, 0.04)
    return (1 - 0.5 * (rs + rp)) / 0.96


class Counting:
    """An angle-only optic that counts its calls."""

    def __init__(self):
        self.calls = 0

    def __call__(self, aoi):
        self.calls += 1
        return _fresnel(aoi)


def _panel(tilt, y):
    """A 6 m x 2 m module tilted by ``tilt`` [deg] about the east-west axis, 1.5 m up, at ``y`` [m]."""
    m = trimesh.creation.box(extents=(6.0, 2.0, 0.02))
    m.apply_transform(trimesh.transformations.rotation_matrix(np.radians(tilt), [1, 0, 0]))
    m.apply_translation((0.0, y, 1.5))
    return m


def _wall(y):
    wall = trimesh.creation.box(extents=(8.0, 1.0, 5.0))
    wall.apply_translation((0.0, y, 2.5))
    return wall


def _scene():
    rows = [_panel(t, y) for t, y in ((30.0, 0.0), (30.0, -4.0), (90.0, 6.0))]
    return make_scene(rows[:2], [rows[2], _wall(10.0)], ground_z=0.0)


def _responses(optic):
    wl = np.linspace(280.0, 2480.0, 12)
    nodes = np.asarray(DEFAULT_NODES)
    table = SpectralAngularTable(nodes, [280.0, 2480.0],
                                 np.stack([_fresnel(nodes), 0.8 * _fresnel(nodes)], 1))
    return [Response("a", wl, 0.6 * np.clip((wl - 300) / 800, 0, 1), unit="sr", angular=optic),
            Response("b", wl, np.exp(-((wl - 700) / 300) ** 2), unit="qe", angular=optic),
            Response("c", wl, np.full(wl.size, 0.7), unit="weight"),
            Response("d", [280.0, 2480.0], [1.0, 1.0], unit="transmittance", angular=table),
            Response("e", wl, np.linspace(0.2, 1.0, wl.size), unit="weight", angular=optic)]


PARTS = {"a": "global", "b": ["global"], "c": "global", "d": "global", "e": ("direct", "global")}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    scene = _scene()
    sky = UniformSky(radiance=0.05, dni=0.9)
    full = poa_irradiance(scene, sky, STATES, responses=_responses(_fresnel), run=RunOptions(n_jobs=1))
    opt = Counting()
    fast = poa_irradiance(scene, sky, STATES, responses=_responses(opt),
                          run=RunOptions(n_jobs=1, coefficients=None),
                          output=OutputOptions(parts=PARTS))
    path = tmp_path_factory.mktemp("parts") / "fast.h5"
    streamed = poa_irradiance(scene, sky, STATES, responses=_responses(_fresnel), run=RunOptions(n_jobs=1),
                              output=OutputOptions(parts=PARTS, path=path))
    return full, fast, streamed, opt, path


def test_global_only_equals_full_run(runs):
    full, fast, streamed, _, _ = runs
    for res in (fast, streamed):
        for name in "abcde":
            np.testing.assert_array_equal(res.get(name, "global"), full.get(name, "global"), err_msg=name)
        np.testing.assert_array_equal(res.get("e", "direct"), full.get("e", "direct"))
        for part in ("direct", "sky_diffuse", "ground_diffuse", "global"):
            np.testing.assert_array_equal(res.get("broadband", part), full.get("broadband", part))
        np.testing.assert_array_equal(res.aoi, full.aoi)
        assert res.weighted.keys() == full.weighted.keys()
    assert full.get("a", "global").max() > 0 and full.get("d", "ground_diffuse").max() > 0


def test_parts_not_kept_are_a_clear_error(runs):
    _, fast, streamed, _, _ = runs
    for res in (fast, streamed):
        with pytest.raises(ValueError, match=r"response 'a' was kept with parts \('global',\)"):
            res.get("a", "direct")
        with pytest.raises(ValueError, match="sky_diffuse"):
            res.get("e", "sky_diffuse")
        with pytest.raises(ValueError, match="not available"):
            res.to_pvlib(group=0, response="c")
        assert res.available_parts("e") == ("direct", "global")
        assert res.available_parts("broadband") == ("direct", "sky_diffuse", "ground_diffuse", "global")
        agg = res.aggregate()
        assert "a:global" in agg and "a:direct" not in agg and "broadband:sky_diffuse" in agg


def test_file_layout_and_round_trip(runs, tmp_path):
    full, fast, _, _, path = runs
    with h5py.File(path, "r") as f:
        assert f.attrs["format_version"] == 2
        assert sorted(f["poa"]["a"]) == ["global"]
        assert sorted(f["poa"]["broadband"]) == ["direct", "ground_diffuse", "sky_diffuse"]
    p2 = tmp_path / "saved.h5"
    fast.save(p2)
    with POAResult.load(p2) as back:
        np.testing.assert_array_equal(back.get("b", "global"), full.get("b", "global"))
        assert back.stored_parts["e"] == ("direct", "global")
    p1 = tmp_path / "full.h5"
    full.save(p1)
    with h5py.File(p1, "r") as f:                  # full runs keep the version-1 layout
        assert f.attrs["format_version"] == 1
    sub = fast.subset(groups=[0])
    np.testing.assert_array_equal(sub.get("a", "global"), full.get("a", "global")[:, sub.faces.select(0)])


def test_shared_optic_evaluated_once_per_chunk(runs):
    # three responses share the callable: one call per chunk of steps (one chunk here), not three
    _, _, _, opt, _ = runs
    assert opt.calls == 1 + 1        # the optic table (plan_optics) and one chunk


def test_bad_parts():
    scene = _scene()
    sky = UniformSky(radiance=0.05, dni=0.9)
    r = _responses(_fresnel)
    for parts, msg in (({"zz": "global"}, "not computed"), ({"broadband": "total"}, "each part must be one of"),
                       ({"a": "total"}, "each part must be one of"), ({"a": []}, "no consumer reads them"),
                       ("global", "expected a dict")):
        with pytest.raises((ValueError, TypeError), match=msg):
            poa_irradiance(scene, sky, STATES.take([1]), responses=r, run=RunOptions(n_jobs=1),
                           output=OutputOptions(parts=parts))


# --- the fused product (one matrix per optic for global-only responses) ----------------------------

STATES_FOLD = SkyStates.create([8.0, 30.0, 55.0, 20.0, -2.0, 65.0], [100.0, 150.0, 190.0, 250.0, 300.0, 175.0],
                               40.0, 0.25)


class Collect:
    """A consumer that keeps copies of what it is handed."""

    def __init__(self, T, F):
        self.T, self.F = T, F
        self.got = {}

    def __call__(self, steps, block, rows, currents):
        for name, gp in currents.items():
            self.got.setdefault(name, np.full((self.T, self.F), np.nan, np.float32))[steps] = gp.total()
        a = self.got.setdefault("aoi", np.full((self.T, self.F), np.nan, np.float32))
        a[steps] = block["aoi"][rows]


@pytest.fixture(scope="module")
def fused_runs():
    """A constant ground albedo (it folds into the reflected-sky matrix), four points per face, a wall
    that reflects the sun onto the modules."""
    rows = [_panel(30.0, 0.0), _panel(30.0, -4.0)]
    scene = make_scene(rows, [_wall(4.0)], ground_z=0.0, samples_per_face=4)
    sky = UniformSky(radiance=0.05, dni=0.9)
    full = poa_irradiance(scene, sky, STATES_FOLD, responses=_responses(_fresnel), run=RunOptions(n_jobs=1))
    col = Collect(len(STATES_FOLD), scene.n_faces)
    fused = poa_irradiance(scene, sky, STATES_FOLD, responses=_responses(_fresnel), run=RunOptions(n_jobs=1),
                           output=OutputOptions(parts={"a": "global", "b": (), "c": "global", "d": "global"},
                                                consumer=col))
    return full, fused, col


def test_fused_product_matches_the_three_parts(fused_runs):
    """Responses kept as global only (no optic, or an angle-only one) take one product per optic with
    X @ faces(D + R rf) instead of the three parts' products: the same numbers within float32
    rounding of sums of about 200 terms (rtol 2e-6 with an absolute floor of 2e-6 of the maximum; the
    per-part path is what the full run gives)."""
    full, fused, col = fused_runs
    for name in "acd":
        ref = full.get(name, "global")
        np.testing.assert_allclose(fused.get(name, "global"), ref, rtol=2e-6, atol=2e-6 * ref.max(),
                                   err_msg=name)
    ref = full.get("b", "global")
    lit = np.isfinite(col.got["b"][:, 0])
    np.testing.assert_allclose(col.got["b"][lit], ref[lit], rtol=2e-6, atol=2e-6 * ref.max())
    assert np.all(ref[~lit] == 0)
    # the consumer sees the stored numbers, and "b" (kept for the consumer only) is not in the result
    np.testing.assert_array_equal(col.got["a"][lit], fused.get("a", "global")[lit])
    np.testing.assert_array_equal(col.got["aoi"][lit], full.aoi[lit])
    assert "b" not in fused.responses and "d" not in col.got      # d has a spectral optic
    # "e" takes the per-part path in both runs, but its product shares a matrix with other columns in one run and not
    # the other, and the BLAS kernel's blocking (chosen by the CPU) need not round the two alike: float32 rounding
    # (measured on one machine: equal; on another: 3e-7 relative)
    for part in ("direct", "sky_diffuse", "ground_diffuse"):
        ref_e = full.get("e", part)
        np.testing.assert_allclose(fused.get("e", part), ref_e, rtol=2e-6, atol=2e-6 * max(ref_e.max(), 1e-30),
                                   err_msg=part)
    assert ref.max() > 0 and full.get("a", "ground_diffuse").max() > 0
