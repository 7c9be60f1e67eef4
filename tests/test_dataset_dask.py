"""Dataset build on a Dask distributed cluster (skymodel.generator.dask_scheduler): a local cluster of two worker
processes on 127.0.0.1 writes a file byte-identical to the process-pool build of the same tiny configuration
(4 DISORT streams, the grid of tests/test_dataset_build.py), each with its own empty state cache; bad scheduler
addresses fail with a one-line error naming the parameter.

``dask[distributed]`` is a test dependency; without it (or without the input data) the test is skipped.
"""

import json
import os
import subprocess
import sys
import warnings

import pytest


TINY = {"visibilities_km": [20.0, 131.8], "albedos": [0.0, 1.0], "elevations_deg": [10.0, 60.0],
        "knots": [16, 12, 8], "rank": 3, "n_streams": 4, "n_moments": 8, "zenith_step_deg": 15.0,
        "trans_dims": [128, 32], "trans_rank": 24, "validation_off_grid": 1, "validation_on_grid": 1, "seed": 3,
        "iterations": 3, "refine": 1, "description": "tiny test dataset"}


def _fresh_cache(tmp, name, monkeypatch, mie_cache):
    """An empty state cache that shares the (content-keyed) Mie tables of ``mie_cache``."""
    root = tmp / f"cache_{name}"
    root.mkdir()
    (root / "build").symlink_to(mie_cache, target_is_directory=True)
    monkeypatch.setenv("WIDESKY_CACHE_DIR", str(root))
    return root


def _build(tmp, name, monkeypatch, processes):
    from widesky.skymodel.generator.dataset_build import build_dataset, load_config

    (tmp / "tiny.json").write_text(json.dumps(TINY))
    out = tmp / f"{name}.dat"
    build_dataset(load_config(tmp / "tiny.json"), out, processes=processes, progress=False, validation=False)
    return out.read_bytes()


@pytest.mark.slow
@pytest.mark.reference
def test_dask_local_cluster_build_is_byte_identical_to_process_pool(tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")
    from widesky.skymodel.generator.dask_scheduler import SCHEDULER_ENV

    from widesky.skymodel.generator.paths import cache_dir
    from widesky.skymodel.generator.solver import AtmosphereSpec, channel_problems, SkyState

    monkeypatch.delenv(SCHEDULER_ENV, raising=False)
    channel_problems(SkyState(30.0, aod550=0.1), AtmosphereSpec(), [5])  # Mie tables in the user cache
    mie = cache_dir()
    _fresh_cache(tmp_path, "pool", monkeypatch, mie)
    pool = _build(tmp_path, "pool", monkeypatch, processes=2)
    dask_cache = _fresh_cache(tmp_path, "dask", monkeypatch, mie)
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # distributed's own deprecation and port warnings
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                      dashboard_address=None) as cluster:
            monkeypatch.setenv(SCHEDULER_ENV, cluster.scheduler_address)
            dask = _build(tmp_path, "dask", monkeypatch, processes=2)
            monkeypatch.delenv(SCHEDULER_ENV)
    assert any((dask_cache / "dataset-build").rglob("*.npz"))  # the workers filled their own cache
    assert dask == pool


def test_bad_scheduler_address_is_a_one_line_error(tmp_path):
    from widesky.skymodel.generator.dask_scheduler import check_address

    with pytest.raises(ValueError, match="scheduler='not an address'"):
        check_address("not an address")
    assert check_address("tcp://127.0.0.1:8786") == "tcp://127.0.0.1:8786"
    cfg = tmp_path / "c.json"
    cfg.write_text(json.dumps(TINY))
    r = subprocess.run([sys.executable, "-m", "widesky.cli", "dataset", "build", str(cfg), "-o",
                        str(tmp_path / "x.dat"), "--scheduler", "nowhere"], capture_output=True, text=True,
                       env={**os.environ, "WIDESKY_CACHE_DIR": str(tmp_path / "cache")})
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "scheduler='nowhere'" in r.stderr
