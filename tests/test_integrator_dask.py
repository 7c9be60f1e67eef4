"""The ray-casting tasks on a Dask distributed cluster (ARCHITECTURE section 8): a local cluster of two
worker processes on 127.0.0.1, reached through ``Client.get_executor()`` (a
``concurrent.futures.Executor``), gives exactly the coefficients and irradiance of one process.

``dask[distributed]`` is an optional test-time dependency: without it the test is skipped.
"""

import warnings

import numpy as np
import pytest
import trimesh

from widesky.irradiance.poa import RunOptions, poa_irradiance
from widesky.irradiance.patches import direction_from_angles
from widesky.irradiance.raycast import compute_coefficients
from widesky.irradiance.scene import make_scene
from widesky.irradiance.skies import AnalyticSky, SkyStates

distributed = pytest.importorskip("distributed")

STATES = SkyStates.create([10.0, 35.0, 60.0], [100.0, 170.0, 250.0], 40.0, 0.3)


def quad(tilt, azimuth, centre):
    v = np.array([[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, 0.5, 0.0], [-0.5, 0.5, 0.0]])
    rot = trimesh.geometry.align_vectors([0, 0, 1], direction_from_angles(90.0 - tilt, azimuth))
    return trimesh.Trimesh(v @ rot[:3, :3].T + np.asarray(centre), [[0, 1, 2], [0, 2, 3]],
                           process=False)


@pytest.mark.slow
def test_dask_local_cluster_matches_serial():
    rows = [quad(25.0, 180.0, (0.0, 2.0 * i, 0.5)) for i in range(8)]
    box = trimesh.creation.box(extents=(3, 3, 6))
    box.apply_translation((5, 5, 3))
    scene = make_scene(rows, context=box, ground_z=0.0)
    sun = STATES.sun_direction
    serial = compute_coefficients(scene, sun_directions=sun, n_jobs=1)
    ref = poa_irradiance(scene, AnalyticSky(), STATES, run=RunOptions(n_jobs=1))
    with warnings.catch_warnings():
        # the cluster's own start-up and shutdown chatter is not under test
        warnings.simplefilter("ignore")
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           host="127.0.0.1", dashboard_address=None,
                                           silence_logs=50)
        client = distributed.Client(cluster)
        try:
            ex = client.get_executor()
            dist = compute_coefficients(scene, sun_directions=sun, executor=ex, chunk_size=4)
            res = poa_irradiance(scene, AnalyticSky(), STATES, run=RunOptions(executor=ex))
            workers = client.run(lambda: 1)
        finally:
            client.close()
            cluster.close()
    assert len(workers) == 2
    for name in ("sky", "ground_sky", "reflect_sky", "reflect_ground", "ground_sun", "reflect_sun", "sun_visible"):
        np.testing.assert_array_equal(getattr(dist, name), getattr(serial, name), err_msg=name)
    for q in ref.QUANTITIES:
        np.testing.assert_array_equal(getattr(res, q), getattr(ref, q), err_msg=q)
