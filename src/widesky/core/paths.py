"""Where widesky finds data files: the one data-path resolver.

Two places, with the same relative names (``solar/ASTMG173.csv``, ``glazing/CLEAR_3.DAT``, ...):

- **Runtime data** ships inside the package, under ``widesky/data/<relative>``: what a default run needs
  (the ASTM G173 reference spectra, the IGDB glazing samples, the 6S band-gas table, a TMY3 weather year;
  sources and licences in NOTICE and docs/data-sources.md). :func:`runtime_file` returns it; no folder or
  environment variable is needed.
- **Reference data** (validation spectra, the dataset generator's inputs under GPL containers, the ASHRAE 140
  files) is read from a folder the user names, never shipped:

  1. the ``data_dir`` argument of the function called, else
  2. the environment variable ``WIDESKY_DATA_DIR``, else
  3. ``../shared/data`` beside a source checkout (the folder holding ``pyproject.toml``), when it exists.

  A folder named by 1 or 2 that does not exist is an error (:class:`DataNotFoundError`), never silently
  replaced by 3. :func:`data_dir`, :func:`data_file` and :func:`has_data` resolve it.

Expensive products computed from the reference data (Mie tables, band-model fits) are cached under
``WIDESKY_CACHE_DIR`` (default ``~/.cache/widesky``), see :func:`cache_dir`.

This module is part of the core layer: it imports nothing from widesky's other packages.
"""

from __future__ import annotations

import os
from pathlib import Path, PurePosixPath

__all__ = ["DataNotFoundError", "data_dir", "data_file", "has_data", "cache_dir", "runtime_file",
           "runtime_files", "data_reference", "DATA_PREFIX", "RUNTIME_DATA_DIR"]

RUNTIME_DATA_DIR = Path(__file__).resolve().parents[1] / "data"
"""The package's own data folder (``widesky/data``)."""

_CHECKOUT = Path(__file__).resolve().parents[3]      # src/widesky/core/paths.py in a source checkout
_REPO_SIBLING = (_CHECKOUT.parent / "shared" / "data") if (_CHECKOUT / "pyproject.toml").is_file() else None
"""``../shared/data`` beside a source checkout; None for an installed package (no checkout around it)."""

_WHERE = ("name it with --data-dir on the command line where the command has that option (data_dir=... in "
          "Python), set WIDESKY_DATA_DIR, or place the reference data at ../shared/data beside the source checkout "
          "(docs/data-sources.md lists each file and where to get it)")


class DataNotFoundError(FileNotFoundError):
    """A required data file or folder is missing."""


def data_dir(path=None) -> Path:
    """Resolve the reference data folder (see module docstring); raise DataNotFoundError if absent."""
    env = os.environ.get("WIDESKY_DATA_DIR")
    for cand, name in ((path, "data_dir"), (env, "WIDESKY_DATA_DIR"), (_REPO_SIBLING, None)):
        if cand is None or cand == "":
            continue
        p = Path(cand).expanduser()
        if p.is_dir():
            return p
        if name is not None:          # a folder the user named is not replaced by another one
            raise DataNotFoundError(f"{name}={str(p)!r} is not a directory")
    raise DataNotFoundError(f"no reference data folder: {_WHERE}")


def data_file(relative: str, path=None) -> Path:
    """Full path of ``relative`` inside the reference data folder; raise DataNotFoundError if missing."""
    f = data_dir(path) / _checked(relative)
    if not f.is_file():
        raise DataNotFoundError(f"reference data file {relative!r} not found in {f.parent} "
                                "(docs/data-sources.md says where to get it)")
    return f


def has_data(path=None) -> bool:
    """True when a reference data folder can be resolved."""
    try:
        data_dir(path)
    except DataNotFoundError:
        return False
    return True


def runtime_file(relative: str, data_dir=None) -> Path:
    """A data file shipped in the package: ``widesky/data/<relative>``.

    Parameters
    ----------
    relative : str
        The file's name relative to the data folder, as in the reference folder (``solar/ASTMG173.csv``).
    data_dir : path-like, optional
        Read the file of the same relative name from this folder instead (an explicit choice only:
        ``WIDESKY_DATA_DIR`` does not redirect runtime data).

    Raises
    ------
    DataNotFoundError
        Naming the file when it is missing (a damaged installation, or not in ``data_dir``).
    """
    if data_dir is not None:
        return data_file(relative, data_dir)
    f = RUNTIME_DATA_DIR / _checked(relative)
    if not f.is_file():
        raise DataNotFoundError(f"runtime data file {relative!r} is missing from the package ({f}); "
                                "reinstall widesky")
    return f


def runtime_files(folder: str) -> list[str]:
    """Names of the files shipped in ``widesky/data/<folder>`` (sorted; licence texts left out)."""
    d = RUNTIME_DATA_DIR / _checked(folder)
    return sorted(p.name for p in d.iterdir() if p.is_file() and not p.name.startswith("LICENSE")) \
        if d.is_dir() else []


DATA_PREFIX = "data:"
"""Prefix of a file name given by its data-folder name (``data:weather/<file>.epw``), see :func:`data_reference`."""


def data_reference(name: str, data_dir=None) -> Path:
    """The file that ``data:<relative>`` names: the one shipped in the package, else the one in the reference data
    folder (``data_dir``, ``WIDESKY_DATA_DIR`` or ``../shared/data``).

    Raises
    ------
    ValueError
        If ``name`` does not start with ``data:`` or leaves the folder.
    DataNotFoundError
        Naming the file, what ships in that folder and the reference folder tried.
    """
    if not str(name).startswith(DATA_PREFIX):
        raise ValueError(f"{name!r} is not a data-folder name ({DATA_PREFIX}<folder>/<file>)")
    relative = str(name)[len(DATA_PREFIX):]
    try:
        return runtime_file(relative)
    except DataNotFoundError:
        pass
    try:
        return data_file(relative, data_dir)
    except DataNotFoundError as exc:
        folder = str(PurePosixPath(relative).parent)
        shipped = ", ".join(f"{DATA_PREFIX}{folder}/{n}" for n in runtime_files(folder)) or "none"
        raise DataNotFoundError(f"{name!r} is not shipped in the package (shipped there: {shipped}), and {exc}") \
            from None


def cache_dir() -> Path:
    """Cache directory for computed products (created on demand)."""
    p = Path(os.environ.get("WIDESKY_CACHE_DIR", "~/.cache/widesky")).expanduser() / "build"
    p.mkdir(parents=True, exist_ok=True)
    return p


def _checked(relative) -> str:
    """``relative`` as given, after checking that it stays inside the folder."""
    r = PurePosixPath(str(relative).replace("\\", "/"))
    if r.is_absolute() or ".." in r.parts or not r.parts:
        raise ValueError(f"data file name {relative!r} must be relative, inside the data folder")
    return str(relative)
