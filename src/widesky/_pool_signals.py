"""Ctrl-C in the ray caster's helper processes: end quietly (no traceback), since the parent reports it.

Imported first by the fork server that :mod:`widesky.irradiance.raycast` starts (its preload list), before the
heavy modules, so that a Ctrl-C while it starts does not print an import traceback; the pool's workers, forked
from it, inherit the handler (the fork server restores it in each child), and their initializer sets it again.
"""

import os
import signal


def quiet_interrupt(signum, frame):
    """SIGINT handler of a helper process: exit at once with status 128 + signal number, printing nothing."""
    os._exit(128 + signum)


signal.signal(signal.SIGINT, quiet_interrupt)   # on import: only helper processes import this module
