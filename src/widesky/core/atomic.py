"""Output files written atomically, and output paths checked before any work is done: widesky's one helper.

Every file widesky writes goes to a temporary file in the destination's folder first and is renamed
over the destination (``os.replace``) only once it is complete, so a failure (a full disk, an error
half-way, an interrupt) never leaves a half-written file; several files that belong together are
renamed together at the end (:func:`atomic_outputs`; one file: :func:`atomic_write`). Caches that
parallel workers fill at the same time use it too: each worker writes its own temporary file, and the
last rename wins with a complete file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

__all__ = ["check_output_path", "atomic_outputs", "atomic_write", "plain_mode", "mark_interrupted",
           "clear_interrupted", "raise_if_interrupted", "interrupts_deferred"]

# Set by the command line's Ctrl-C handler (widesky.cli.main). Python drops an exception raised where it cannot be
# propagated (a weakref callback, a __del__, a library that catches KeyboardInterrupt), so a Ctrl-C can be lost and
# the command run on; every commit checks this flag first, so that an interrupted command writes nothing.
_INTERRUPTED = False


def mark_interrupted() -> None:
    """Record a Ctrl-C (SIGINT): from now on every commit of :func:`atomic_outputs` raises KeyboardInterrupt."""
    global _INTERRUPTED
    _INTERRUPTED = True


def clear_interrupted() -> None:
    """Forget a recorded Ctrl-C (at the start of a command)."""
    global _INTERRUPTED
    _INTERRUPTED = False


def raise_if_interrupted() -> None:
    """Raise KeyboardInterrupt where a Ctrl-C was recorded (:func:`mark_interrupted`) even if it was swallowed."""
    if _INTERRUPTED:
        raise KeyboardInterrupt


@contextlib.contextmanager
def interrupts_deferred():
    """Hold back Ctrl-C (SIGINT) for the few renames of a commit, so that they happen all or none: a Ctrl-C in
    between is recorded (:func:`mark_interrupted`) and raised as KeyboardInterrupt once they are done. A Python-level
    handler, not a signal mask: the kernel may hand the signal to any thread (BLAS, the ray caster's), and Python
    runs the handler in the main thread whichever received it. Outside the main thread it changes nothing."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending = []

    def hold(signum, frame):
        pending.append(signum)
        mark_interrupted()

    previous = signal.signal(signal.SIGINT, hold)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous if previous is not None else signal.default_int_handler)
    if pending:
        raise KeyboardInterrupt


def check_output_path(path, option="--output", suffixes=None) -> Path:
    """Check that ``path`` can be written, before the work that produces it starts.

    Raises
    ------
    ValueError
        Naming ``option`` when the path is a folder, its folder does not exist or is not writable, or
        its suffix is not one of ``suffixes`` (e.g. ``(".png", ".exr")``).
    """
    p = Path(path)
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise ValueError(f"{option} {str(path)!r}: expected a file name ending in {' or '.join(suffixes)}")
    if p.is_dir():
        raise ValueError(f"{option} {str(path)!r} is a folder: give a file name")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"{option} {str(path)!r}: folder {str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK):
        raise ValueError(f"{option} {str(path)!r}: folder {str(parent)!r} is not writable")
    return p


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def plain_mode(path, folder=False):
    """Give a file made by ``tempfile.mkstemp`` (0600) or a folder made by ``mkdtemp`` (0700) the mode a plain
    ``open()`` / ``mkdir()`` would have given it under the current umask."""
    os.chmod(path, (0o777 if folder else 0o666) & ~_umask())


@contextlib.contextmanager
def atomic_outputs(*paths):
    """Context manager yielding one temporary path per destination (same folder, ending in the same suffix, so tools
    that go by the suffix still work); on a normal exit every temporary file is renamed over its destination, on an
    exception all are removed.

    Example::

        with atomic_outputs("sky.png", "sky.exr") as (png, exr):
            write_png(png, r)
            write_exr(exr, r)
    """
    dests = [Path(p) for p in paths]
    temps = []
    try:
        for d in dests:
            fd, name = tempfile.mkstemp(prefix=f".{d.stem}.", suffix=".part" + d.suffix, dir=d.parent or ".")
            os.close(fd)
            os.chmod(name, 0o666 & ~_umask())  # as a plain open() would create it, not mkstemp's 0600
            temps.append(Path(name))
        yield temps
        raise_if_interrupted()      # a Ctrl-C that a library swallowed: commit nothing
        with interrupts_deferred():
            raise_if_interrupted()
            for t, d in zip(temps, dests):
                os.replace(t, d)
    except BaseException:
        for t in temps:
            with contextlib.suppress(OSError):
                t.unlink()
        raise


@contextlib.contextmanager
def atomic_write(path):
    """Context manager yielding the temporary path (a :class:`pathlib.Path` in ``path``'s folder, ending in
    its suffix) to write instead of ``path``; renamed over ``path`` on a normal exit, removed on an exception.

    Example::

        with atomic_write("table.npz") as tmp:
            np.savez(tmp, a=a)
    """
    with atomic_outputs(path) as (tmp,):
        yield tmp
