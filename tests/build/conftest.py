"""Shared fixtures of the skymodel.build tests."""

import pytest

from skymodel.build.paths import has_data


def pytest_collection_modifyitems(config, items):
    # tests marked `reference` need the public input data directory (../shared/data or WIDESKY_DATA_DIR)
    if has_data():
        return
    skip = pytest.mark.skip(reason="input data directory absent (set WIDESKY_DATA_DIR)")
    for it in items:
        if "reference" in it.keywords and "tests/build" in str(it.fspath):
            it.add_marker(skip)
