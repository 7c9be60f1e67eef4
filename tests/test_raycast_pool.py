"""The default process pool ships the scene to each worker once: its tasks carry the scene's key."""

import pickle

import numpy as np
import trimesh

from widesky.irradiance import make_scene
from widesky.irradiance.raycast import _pool_task_args, compute_coefficients, start_coefficients


def test_pool_tasks_carry_the_key_not_the_scene():
    box = trimesh.creation.box(extents=(3, 3, 6))
    big = trimesh.creation.icosphere(subdivisions=4)          # 5120 faces of context geometry
    big.apply_translation((10, 0, 2))
    scene = make_scene(box, context=big, ground_z=0.0)
    sun = np.array([[0.3, -0.5, 0.81]])
    pending = start_coefficients(scene, sun_directions=sun, n_jobs=1, chunk_size=8)
    args = pending._args
    tasks = _pool_task_args(args)
    assert len(tasks) == len(args) > 1
    assert all(t[0] == scene.key for t in tasks)
    geo_bytes = len(pickle.dumps(args[0][0]))
    assert all(len(pickle.dumps(t)) < len(pickle.dumps(a)) - 0.9 * geo_bytes for t, a in zip(tasks, args))
    # and the pool's workers, holding the scene from their initializer, give the serial result
    serial = pending.result()
    pooled = compute_coefficients(scene, sun_directions=sun, n_jobs=2, chunk_size=8)
    for name in ("sky", "ground_sky", "reflect_sky", "reflect_ground", "ground_sun", "reflect_sun",
                 "sun_visible"):
        np.testing.assert_array_equal(getattr(serial, name), getattr(pooled, name))
