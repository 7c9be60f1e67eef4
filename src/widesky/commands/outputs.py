"""The command line's output-path policy, checked before any computation.

* A **file** output (``poa -o x.h5``, ``thermal loads --output x.csv``, ``pv sweep -o s.csv``, ``sky render -o
  sky.png`` ...) is written atomically; its folder must already exist and be writable, the path must not be a
  folder, and its suffix must be one the command writes (:func:`widesky.core.atomic.check_output_path`).
* A **folder** output (``run -o report``, ``pv compare -o out``, ``thermal study --output out``) is created, with
  its parents, only once the results are ready (a failed or interrupted run leaves no empty folder); the path
  must not be a file, and the nearest folder that exists on it must be writable (:func:`check_output_folder`).
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["check_output_folder"]


def check_output_folder(path, option="--output") -> Path:
    """Check, before the work starts, that the folder ``path`` can be created or written to (nothing is created).

    Raises
    ------
    ValueError
        Naming ``option`` when ``path`` is a file, or the nearest existing folder on it is not writable or is a
        file.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ValueError(f"{option} {str(path)!r} is a file: give a folder (created if it does not exist)")
    q = p.absolute()
    while not q.exists():
        q = q.parent
    if not q.is_dir():
        raise ValueError(f"{option} {str(path)!r}: {str(q)!r} is a file, so the folder cannot be created")
    if not os.access(q, os.W_OK | os.X_OK):
        raise ValueError(f"{option} {str(path)!r}: folder {str(q)!r} is not writable")
    return p


def check_text_file(path, option, what="a text table") -> Path:
    """Refuse, naming ``option``, a missing file or one that is not text (NUL bytes or not UTF-8/Latin-1 text in
    its first 64 KiB: a binary file given where a table is expected)."""
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"{option}: file {str(path)!r} " + ("is a folder" if p.is_dir() else "not found")
                         + f"; expected: {what}")
    with open(p, "rb") as fh:
        head = fh.read(1 << 16)
    try:
        head.decode("utf-8")
        text = True
    except UnicodeDecodeError as exc:
        # a cut through a multi-byte character at the end of the sample is still text
        text = exc.start >= len(head) - 3
        if not text:       # Latin-1 tables (old instrument exports) are text if printable
            text = all(b >= 0x20 or b in b"\t\r\n" for b in head)
    if not text or b"\0" in head:
        raise ValueError(f"{option}: file {str(path)!r} is not a text file (binary data); expected: {what}")
    return p
