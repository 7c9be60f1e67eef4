"""Sky-state tasks of a dataset build on an existing Dask distributed cluster.

The solve and fit tasks of :mod:`widesky.skymodel.generator.dataset_build` are independent and write their results into
the state cache (:mod:`widesky.skymodel.generator.cache`), so they can run anywhere that sees the same cache folder and
the same package: on the local spawn process pool by default, or on the workers of a Dask scheduler when one is
named, by ``widesky dataset build ... --scheduler ADDRESS`` or the environment variable ``WIDESKY_DASK_SCHEDULER``
(for example ``tcp://127.0.0.1:8786``). Results are collected in submission order; the build only reads them back
from the cache in grid order, so the written dataset does not depend on where or in which order tasks ran.
Workers should run one thread each (``dask worker ADDRESS --nthreads 1``) with ``OMP_NUM_THREADS=1``, and share
``WIDESKY_CACHE_DIR`` with the client. A stopped build resumes from the cache with either executor.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import re

from tqdm import tqdm

SCHEDULER_ENV = "WIDESKY_DASK_SCHEDULER"
_ADDRESS = re.compile(r"^(tcp|tls|inproc|ucx|ws|wss)://[^\s/]+$|^[A-Za-z0-9_.\-\[\]:]+:\d+$")


def check_address(address: str) -> str:
    """Validate a scheduler address (``tcp://host:port`` or ``host:port``); returns it unchanged."""
    if not isinstance(address, str) or not _ADDRESS.match(address):
        raise ValueError(f"scheduler={address!r}: expected a Dask scheduler address such as tcp://127.0.0.1:8786")
    return address


def scheduler_address():
    """The configured scheduler address (``$WIDESKY_DASK_SCHEDULER``), or None for the local process pool."""
    a = os.environ.get(SCHEDULER_ENV, "").strip()
    return check_address(a) if a else None


def dask_map(fn, jobs, address: str, timeout_s: float = 30.0):
    """Run ``fn`` over ``jobs`` on the Dask cluster at ``address``; yields the results in the order of ``jobs``.

    Raises ConnectionError (with the address) when the scheduler cannot be reached within ``timeout_s`` [s]."""
    from distributed import Client

    check_address(address)
    try:
        client = Client(address, timeout=timeout_s, set_as_default=False)
    except OSError as e:  # includes TimeoutError
        raise ConnectionError(f"scheduler={address!r}: cannot connect ({e})") from None
    with client:
        futures = client.map(fn, list(jobs), pure=False)
        for f in futures:  # in submission order; the workers run them as they can
            yield f.result()


def pool_map(fn, jobs, processes, progress, desc):
    """Map ``fn`` over ``jobs`` on a spawn process pool (one BLAS/OpenMP thread per worker), or on a Dask cluster
    when one is configured (:func:`scheduler_address`); yields results."""
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    bar = None
    if progress:
        bar = tqdm(total=len(jobs), desc=desc)
    address = scheduler_address()
    if address and jobs:
        for r in dask_map(fn, jobs, address):
            if bar is not None:
                bar.update()
            yield r
    elif processes <= 1 or len(jobs) <= 1:
        for j in jobs:
            r = fn(j)
            if bar is not None:
                bar.update()
            yield r
    else:
        with mp.get_context("spawn").Pool(processes) as pool:
            for r in pool.imap_unordered(fn, jobs):
                if bar is not None:
                    bar.update()
                yield r
    if bar is not None:
        bar.close()
