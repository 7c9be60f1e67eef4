"""The generator's cache of solved sky states (one ``.npz`` per state), shared by the build and its error report.

Folder: ``$WIDESKY_CACHE_DIR`` (default ``~/.cache/widesky``) / ``dataset-build`` / the solver key of the
configuration, so that a change of the solver settings never reuses stale solves.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from widesky.core.atomic import atomic_write


def cache_root(config) -> Path:
    """Cache folder of the solved states of ``config`` (``$WIDESKY_CACHE_DIR`` or ``~/.cache/widesky``)."""
    base = Path(os.environ.get("WIDESKY_CACHE_DIR", "~/.cache/widesky")).expanduser()
    p = base / "dataset-build" / config.solver_key()
    p.mkdir(parents=True, exist_ok=True)
    return p


def save_state(path: Path, d: dict):
    """Write a solved state (dict of arrays and lists of arrays) atomically to ``path`` [.npz]."""
    flat = {}
    for k, v in d.items():
        if isinstance(v, list):
            flat[f"{k}__n"] = np.array(len(v))
            for i, x in enumerate(v):
                flat[f"{k}__{i}"] = np.asarray(x)
        else:
            flat[k] = np.asarray(v)
    with atomic_write(path) as tmp:
        np.savez(tmp, **flat)


def load_state(path: Path) -> dict:
    """Read a state written by :func:`save_state`."""
    with np.load(path) as z:
        keys = list(z.keys())
        d = {k: z[k] for k in keys if "__" not in k}
        for k in keys:
            if k.endswith("__n"):
                name = k[:-3]
                d[name] = [z[f"{name}__{i}"] for i in range(int(z[k]))]
    return d


def state_file(config, visibility_km: float, elevation_deg: float, kind="fit", albedo=None) -> Path:
    """Cache file of one solved state [.npz] (validation states carry their albedo in the name)."""
    tail = "" if albedo is None else f"_a{albedo:.4f}"
    return cache_root(config) / f"{kind}_v{visibility_km:.4f}_e{elevation_deg:.4f}{tail}.npz"


def ground_file(config, visibility_km: float) -> Path:
    """Cache file of one visibility's ground response [.npz]."""
    return cache_root(config) / f"ground_v{visibility_km:.4f}.npz"


def validation_states(config):
    """Held-out sky states (seeded): list of (kind, visibility [km], elevation [deg], albedo [1]).

    ``on``: grid visibility, elevation and albedo (held-out directions only); ``off``: visibility log-uniform in the
    grid's range, elevation uniform in [max(2, lowest solved), 88] deg and albedo uniform in [0, 1] (between grid
    points: the error a user sees)."""
    rng = np.random.default_rng(config.seed)
    vis = np.asarray(config.visibilities_km, float)
    ele = np.asarray(config.elevations_deg, float)
    alb = np.asarray(config.albedos, float)
    out = []
    ele_ok = ele[ele >= max(2.0, config.min_solve_elevation_deg)]
    for _ in range(int(config.validation_on_grid)):
        out.append(("on", float(rng.choice(vis)), float(rng.choice(ele_ok)), float(rng.choice(alb))))
    for _ in range(int(config.validation_off_grid)):
        v = float(np.exp(rng.uniform(np.log(vis[0]), np.log(vis[-1]))))
        e = float(rng.uniform(max(2.0, ele_ok[0]), min(88.0, ele[-1])))
        out.append(("off", round(v, 3), round(e, 3), round(float(rng.uniform(0, 1)), 3)))
    return out
