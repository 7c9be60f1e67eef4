"""Test-session setup shared by all tests.

What a default run needs ships in the package (``widesky/data``); the public reference data that tests compare
against (``../shared/data`` beside the checkout, see docs/data-sources.md) does not. The tests use the reference
folder of the checkout that holds them: ``WIDESKY_DATA_DIR`` when set, else this checkout's ``../shared/data``
(exported as ``WIDESKY_DATA_DIR``, so subprocesses see it too), else none. In the last case the package's own
fallback (``../shared/data`` beside the source checkout it was installed from, editable installs) is switched off
as well, so that tests on a clone or copy without the folder see what a user sees. Tests marked ``reference``
skip with one reason, :data:`REFERENCE_SKIP_REASON`, when there is no folder.
"""

import os
from pathlib import Path

# Subprocesses the tests start (`python -m widesky.cli ...`, sphinx) must import the installed package, not
# the checkout's source folders, which lack the compiled C core in a non-editable install (as in CI):
# Python 3.11+ leaves the working directory off sys.path with PYTHONSAFEPATH set.
os.environ.setdefault("PYTHONSAFEPATH", "1")

_SIBLING = Path(__file__).resolve().parents[1].parent / "shared" / "data"

REFERENCE_SKIP_REASON = "reference data folder absent (../shared/data beside the checkout, or WIDESKY_DATA_DIR)"

if not os.environ.get("WIDESKY_DATA_DIR"):
    if _SIBLING.is_dir():
        os.environ["WIDESKY_DATA_DIR"] = str(_SIBLING)
    else:
        import widesky.core.paths as _paths
        _paths._REPO_SIBLING = None


def pytest_collection_modifyitems(config, items):
    """Tests marked ``reference`` need the reference data folder: skip them, saying so, when it is absent."""
    import pytest
    from widesky.core.paths import has_data
    if has_data():
        return
    skip = pytest.mark.skip(reason=REFERENCE_SKIP_REASON)
    for it in items:
        if "reference" in it.keywords:
            it.add_marker(skip)
