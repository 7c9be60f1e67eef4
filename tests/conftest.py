"""Test-session setup shared by all tests.

The public reference data (``../shared/data`` beside the checkout, see docs/data-sources.md) is
found through ``WIDESKY_DATA_DIR``. The installed package resolves ``../shared/data`` relative to its
own location, which for a non-editable install is site-packages, so point it at the checkout's
sibling here when the caller has not chosen a directory. Tests that need the data skip cleanly
when it is absent.
"""

import os
from pathlib import Path

# Subprocesses the tests start (`python -m skymodel.cli ...`, sphinx) must import the installed package, not
# the checkout's source folders, which lack the compiled C core in a non-editable install (as in CI):
# Python 3.11+ leaves the working directory off sys.path with PYTHONSAFEPATH set.
os.environ.setdefault("PYTHONSAFEPATH", "1")

_SIBLING = Path(__file__).resolve().parents[1].parent / "shared" / "data"

if not os.environ.get("WIDESKY_DATA_DIR") and _SIBLING.is_dir():
    os.environ["WIDESKY_DATA_DIR"] = str(_SIBLING)


def pytest_collection_modifyitems(config, items):
    """Tests marked ``reference`` need the input data directory: skip them, saying so, when it is absent."""
    import pytest
    from skymodel.generator.paths import has_data
    if has_data():
        return
    skip = pytest.mark.skip(reason="input data directory absent (set WIDESKY_DATA_DIR)")
    for it in items:
        if "reference" in it.keywords:
            it.add_marker(skip)
