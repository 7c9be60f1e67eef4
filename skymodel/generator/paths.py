"""Where the generator finds its public input data and where it caches expensive products.

Inputs that no PyPI package ships (AFGL profiles, ozone cross-sections, OPAC optical constants,
solar spectra, validation spectra) are read from a directory the user names:

1. the ``data_dir`` argument of the function called, else
2. the environment variable ``WIDESKY_DATA_DIR``, else
3. ``../shared/data`` beside the repository checkout, when it exists.

A directory named by 1 or 2 that does not exist is an error (DataNotFoundError), never silently replaced by 3.

Nothing from that directory is copied into the package. Expensive products computed from it
(Mie tables, band-model fits) are cached under ``WIDESKY_CACHE_DIR`` (default ``~/.cache/widesky``).
"""

from __future__ import annotations

import os
from pathlib import Path

_REPO_SIBLING = Path(__file__).resolve().parents[2].parent / "shared" / "data"


class DataNotFoundError(FileNotFoundError):
    """A required public input file is missing from the data directory."""


def data_dir(path=None) -> Path:
    """Resolve the input data directory (see module docstring); raise DataNotFoundError if absent."""
    env = os.environ.get("WIDESKY_DATA_DIR")
    for cand, name in ((path, "data_dir"), (env, "WIDESKY_DATA_DIR"), (_REPO_SIBLING, None)):
        if cand is None or cand == "":
            continue
        p = Path(cand).expanduser()
        if p.is_dir():
            return p
        if name is not None:          # a directory the user named is not replaced by another one
            raise DataNotFoundError(f"{name}={str(p)!r} is not a directory")
    raise DataNotFoundError(
        "no input data directory: pass data_dir=..., set WIDESKY_DATA_DIR, or place the data set "
        f"at {_REPO_SIBLING} (see docs/atmosphere-and-solver.md, 'Inputs')")


def data_file(relative: str, path=None) -> Path:
    """Full path of ``relative`` inside the data directory; raise DataNotFoundError if missing."""
    f = data_dir(path) / relative
    if not f.is_file():
        raise DataNotFoundError(f"input file {relative!r} not found in data directory {f.parent}")
    return f


def has_data(path=None) -> bool:
    """True when an input data directory can be resolved."""
    try:
        data_dir(path)
    except DataNotFoundError:
        return False
    return True


def cache_dir() -> Path:
    """Cache directory for computed products (created on demand)."""
    p = Path(os.environ.get("WIDESKY_CACHE_DIR", "~/.cache/widesky")).expanduser() / "build"
    p.mkdir(parents=True, exist_ok=True)
    return p
