"""Runs in blocks of faces (``RunOptions(face_block=...)``, issue 36): the rays, products and output of one block of
faces at a time give the whole run's numbers bit for bit.

Reference: the same run in one block (the whole scene). Each ray's identity is its point's index in the scene, so a
block's coefficients are the whole scene's rows; every product over the face axis runs in tiles of
``products.FACE_TILE`` faces at fixed offsets, so a block that starts at a multiple of the tile makes the same BLAS
calls on the same numbers (the tile is set to 8 faces here, to exercise it on a 24-face scene; the library's is
4,096, and its automatic blocks are multiples of it). Compared exactly (``assert_array_equal``) for every response
and part, aoi and sun visibility: in memory, streamed to HDF5 (a process pool casting the next block's rays during
this block's products), with angle-only and angle x wavelength optics, a ground albedo that changes between steps,
spectral parts, four points per face with the fused global-only product and a consumer, and the automatic split
above the working-memory budget.
"""

import numpy as np
import pytest

import widesky.irradiance.output_plan as output_plan
import widesky.irradiance.products as products
import trimesh

from widesky.irradiance import (IntegratorSettings, OutputOptions, Response, RunOptions, SkyStates,
                                SpectralAngularTable, make_scene, poa_irradiance)
from widesky.irradiance.optics import DEFAULT_NODES
from widesky.irradiance.raycast import compute_coefficients
from widesky.irradiance.skies import UniformSky

SKY = UniformSky(radiance=0.05, dni=0.9)
STATES = SkyStates.create([8.0, 30.0, 55.0, 20.0, -5.0], [100.0, 150.0, 190.0, 250.0, 300.0],
                          40.0, [0.2, 0.2, 0.3, 0.3, 0.2])
STATES_FOLD = SkyStates.create([8.0, 30.0, 55.0, 20.0, -2.0, 65.0], [100.0, 150.0, 190.0, 250.0, 300.0, 175.0],
                               40.0, 0.25)


def _fresnel(aoi):
    """Glass (n = 1.5) transmittance relative to normal incidence [1] at ``aoi`` [deg]."""
    th = np.radians(np.clip(aoi, 0.0, 89.9))
    tr = np.arcsin(np.sin(th) / 1.5)
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = np.where(th > 1e-6, (np.sin(tr - th) / np.sin(tr + th)) ** 2, 0.04)
        rp = np.where(th > 1e-6, (np.tan(tr - th) / np.tan(tr + th)) ** 2, 0.04)
    return (1 - 0.5 * (rs + rp)) / 0.96


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
    """No optic, angle-only optics and an angle x wavelength table."""
    wl = np.linspace(280.0, 2480.0, 12)
    nodes = np.asarray(DEFAULT_NODES)
    table = SpectralAngularTable(nodes, [280.0, 2480.0], np.stack([_fresnel(nodes), 0.8 * _fresnel(nodes)], 1))
    return [Response("a", wl, 0.6 * np.clip((wl - 300) / 800, 0, 1), unit="sr", angular=optic),
            Response("b", wl, np.exp(-((wl - 700) / 300) ** 2), unit="qe", angular=optic),
            Response("c", wl, np.full(wl.size, 0.7), unit="weight"),
            Response("d", [280.0, 2480.0], [1.0, 1.0], unit="transmittance", angular=table),
            Response("e", wl, np.linspace(0.2, 1.0, wl.size), unit="weight", angular=optic)]


@pytest.fixture
def tile8(monkeypatch):
    """Product tiles (and automatic blocks) of 8 faces."""
    monkeypatch.setattr(products, "FACE_TILE", 8)
    monkeypatch.setattr(output_plan, "FACE_ALIGN", 8)


def _same(a, b):
    assert a.responses == b.responses
    for r in a.responses:
        assert a.available_parts(r) == b.available_parts(r)
        for p in a.available_parts(r):
            np.testing.assert_array_equal(b.get(r, p), a.get(r, p), err_msg=f"{r} {p}")
    np.testing.assert_array_equal(b.aoi, a.aoi)
    np.testing.assert_array_equal(b.sun_visible, a.sun_visible)
    if a.spectral is not None:
        for p in a.spectral:
            np.testing.assert_array_equal(np.asarray(b.spectral[p][:]), np.asarray(a.spectral[p][:]), err_msg=p)


def test_blocks_equal_whole_run(tile8, tmp_path):
    scene = _scene()                                    # 24 faces; STATES' albedo changes between steps
    assert scene.n_faces == 24
    r = _responses(_fresnel)
    whole = poa_irradiance(scene, SKY, STATES, responses=r, run=RunOptions(n_jobs=1))
    assert whole.timings["face_blocks"] == 1
    blocked = poa_irradiance(scene, SKY, STATES, responses=r, run=RunOptions(n_jobs=1, face_block=8))
    assert blocked.timings["face_blocks"] == 3
    _same(whole, blocked)
    # streamed to a file, the last block partial, the rays in a pool of two processes
    with poa_irradiance(scene, SKY, STATES, responses=r, run=RunOptions(n_jobs=2, face_block=16),
                        output=OutputOptions(path=tmp_path / "blocked.h5")) as streamed:
        assert streamed.timings["face_blocks"] == 2
        _same(whole, streamed)
    assert whole.get("d", "ground_diffuse").max() > 0 and whole.get("a", "direct").max() > 0
    # the spectral parts
    ws = poa_irradiance(scene, SKY, STATES, run=RunOptions(n_jobs=1), output=OutputOptions(spectral=True))
    bs = poa_irradiance(scene, SKY, STATES, run=RunOptions(n_jobs=1, face_block=8),
                        output=OutputOptions(spectral=True))
    _same(ws, bs)


class FaceCollect:
    """A consumer that takes ``faces=`` and keeps copies of the global parts and aoi it is handed."""

    def __init__(self, T, F):
        self.T, self.F = T, F
        self.got, self.calls = {}, []

    def __call__(self, steps, block, rows, currents, faces):
        self.calls.append((faces.start, faces.stop, tuple(steps)))
        for name, gp in currents.items():
            assert gp.diffuse.shape[1] == faces.stop - faces.start
            self.got.setdefault(name, np.full((self.T, self.F), np.nan, np.float32))[steps, faces] = gp.total()
        a = self.got.setdefault("aoi", np.full((self.T, self.F), np.nan, np.float32))
        a[steps, faces] = block["aoi"][rows]


def test_fused_product_and_consumer_in_blocks(tile8):
    """A constant albedo (the fused global-only product), four points per face, a wall that reflects the sun."""
    scene = make_scene([_panel(30.0, 0.0), _panel(30.0, -4.0)], [_wall(4.0)], ground_z=0.0, samples_per_face=4)
    F, T = scene.n_faces, len(STATES_FOLD)
    parts = {"a": "global", "b": (), "c": "global", "d": "global"}
    runs = []
    for fb in (None, 8):
        col = FaceCollect(T, F)
        res = poa_irradiance(scene, SKY, STATES_FOLD, responses=_responses(_fresnel),
                             run=RunOptions(n_jobs=1, face_block=fb), output=OutputOptions(parts=parts, consumer=col))
        runs.append((res, col))
    (whole, cw), (blocked, cb) = runs
    _same(whole, blocked)
    assert blocked.timings["face_blocks"] == 3
    for key in cw.got:
        np.testing.assert_array_equal(cb.got[key], cw.got[key], err_msg=key)
    assert {(a, b) for a, b, _ in cw.calls} == {(0, F)}
    assert sorted({(a, b) for a, b, _ in cb.calls}) == [(0, 8), (8, 16), (16, 24)]
    assert np.nanmax(cw.got["b"]) > 0


class PlainCollect:
    def __call__(self, steps, block, rows, currents):
        pass


def test_consumer_without_faces_is_not_split(monkeypatch):
    scene = _scene()
    with pytest.raises(ValueError, match=r"face_block=8: the consumer does not take faces="):
        poa_irradiance(scene, SKY, STATES.take([1]), run=RunOptions(n_jobs=1, face_block=8),
                       output=OutputOptions(consumer=PlainCollect()))
    monkeypatch.setattr(output_plan, "FACE_BLOCK_BYTES", 1)        # would split, but the consumer sees all faces
    monkeypatch.setattr(output_plan, "FACE_ALIGN", 8)
    res = poa_irradiance(scene, SKY, STATES.take([1]), run=RunOptions(n_jobs=1),
                         output=OutputOptions(consumer=PlainCollect()))
    assert res.timings["face_blocks"] == 1


def test_automatic_split_above_the_budget(tile8, monkeypatch):
    scene = _scene()
    whole = poa_irradiance(scene, SKY, STATES, responses=_responses(_fresnel), run=RunOptions(n_jobs=1))
    plan = output_plan.output_plan(scene, SKY, STATES, IntegratorSettings(), [("broadband", None, "W m-2", None)],
                                   OutputOptions(), n_columns=1)
    assert plan.face_blocks == [(0, 24)]
    monkeypatch.setattr(output_plan, "FACE_BLOCK_BYTES", 1)        # the estimate of any face exceeds it
    auto = poa_irradiance(scene, SKY, STATES, responses=_responses(_fresnel), run=RunOptions(n_jobs=1))
    assert auto.timings["face_blocks"] == 3                        # blocks of FACE_ALIGN (8) faces
    _same(whole, auto)


def test_face_block_rule():
    per = output_plan.face_bytes(1, 145, 3, 0, 4444, 11, 256)
    assert 20_000 < per < 80_000                                   # bytes per face of the benchmark's run
    fit = output_plan.FACE_BLOCK_BYTES // per                     # faces within the budget: one block
    assert output_plan.face_blocks(fit, None, per) == [(0, fit)]
    assert len(output_plan.face_blocks(fit + 1, None, per)) == 2
    fb = output_plan.face_blocks(1_000_000, None, per)
    widths = {b - a for a, b in fb[:-1]}
    assert len(widths) == 1 and widths.pop() % 4096 == 0
    assert (fb[0][1] - fb[0][0]) * per <= output_plan.FACE_BLOCK_BYTES
    assert fb[0][0] == 0 and fb[-1][1] == 1_000_000 and all(a[1] == b[0] for a, b in zip(fb, fb[1:]))
    assert output_plan.face_blocks(10, 4) == [(0, 4), (4, 8), (8, 10)]
    assert output_plan.face_blocks(10, 10) == [(0, 10)]
    assert output_plan.FACE_ALIGN == products.FACE_TILE


def test_bad_face_block():
    with pytest.raises(ValueError, match=r"face_block=0 must be >= 1 \(faces\)"):
        RunOptions(face_block=0)
    with pytest.raises(ValueError, match="points=.* outside the scene's 0:24"):
        compute_coefficients(_scene(), n_jobs=1, points=(20, 30))


def test_each_block_holds_only_its_faces(tile8, monkeypatch):
    """The coefficients, the products' matrices and buffers and the output block are the block's size (what keeps a
    run's memory independent of the face count)."""
    import widesky.irradiance.poa as poa
    seen = []
    real = poa.ProductContext

    class Recording(real):
        def __init__(self, *a, **kw):
            super().__init__(*a, **kw)
            seen.append((self.F, self.cf.sky.shape[0], self.D_T[-1].shape[1], self.buf_sky.shape[1]))

    monkeypatch.setattr(poa, "ProductContext", Recording)
    scene = _scene()
    poa_irradiance(scene, SKY, STATES, run=RunOptions(n_jobs=1, face_block=8))
    assert seen == [(8, 8, 8, 8)] * 3
