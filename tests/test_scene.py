"""Scene construction (irradiance.scene): recentring, analysis points, bad geometry."""

import numpy as np
import pytest
import trimesh

from widesky.irradiance.scene import load_mesh, make_scene


def tri(offset=(0.0, 0.0, 0.0)):
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]) + np.asarray(offset)
    return trimesh.Trimesh(v, [[0, 1, 2]], process=False)


def test_recentring_keeps_precision():
    big = (654321.123, 5432109.987, 250.0)
    s = make_scene(tri(big))
    np.testing.assert_allclose(s.origin + s.vertices.mean(axis=0), np.mean(tri(big).vertices, 0))
    assert np.abs(s.vertices).max() < 1.0
    assert s.ground_z == pytest.approx(250.0 - s.origin[2])
    # offset above float32 rounding of the recentred coordinates, and tiny
    assert np.spacing(np.float32(1.0)) < s.ray_offset < 1e-3


def test_points_normals_areas_groups():
    s = make_scene([tri(), tri((5, 0, 0))], groups=["a", "b"], samples_per_face=4, two_sided=True)
    assert s.n_faces == 4 and s.n_points == 16
    np.testing.assert_allclose(s.face_area, 0.5)
    np.testing.assert_allclose(s.face_normal[:2], [[0, 0, 1]] * 2)
    np.testing.assert_allclose(s.face_normal[2:], [[0, 0, -1]] * 2)
    assert s.group_names == ("a", "b") and list(s.face_group) == [0, 1, 0, 1]
    # sub-triangle centroids average to the triangle centroid
    np.testing.assert_allclose(s.points[:4].mean(axis=0) + s.origin, [1 / 3, 1 / 3, 0], atol=1e-12)


def test_load_mesh_from_file(tmp_path):
    p = tmp_path / "t.obj"
    trimesh.creation.box().export(p)
    m = load_mesh(str(p))
    assert len(m.faces) == 12
    s = make_scene(str(p))
    assert s.n_faces == 12


def test_errors_name_the_problem():
    bad = trimesh.Trimesh(np.array([[0, 0, 0], [1, 0, np.nan], [0, 1, 0]]), [[0, 1, 2]],
                          process=False)
    with pytest.raises(ValueError, match="non-finite"):
        make_scene(bad)
    with pytest.raises(ValueError, match="groups has 1 names for 2"):
        make_scene([tri(), tri()], groups=["x"])
    with pytest.raises(ValueError, match="ground_albedo"):
        make_scene(tri(), ground_albedo=1.5)
    with pytest.raises(ValueError, match="analysis_reflectance"):
        make_scene(tri(), analysis_reflectance=-0.1)
