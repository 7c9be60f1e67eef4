"""Shared fixtures of the skymodel.generator tests."""

import pytest

from skymodel.generator.paths import has_data


def pytest_collection_modifyitems(config, items):
    # tests marked `reference` need the public input data directory (../shared/data or WIDESKY_DATA_DIR)
    if has_data():
        return
    skip = pytest.mark.skip(reason="input data directory absent (set WIDESKY_DATA_DIR)")
    for it in items:
        if "reference" in it.keywords and "tests/generator" in str(it.fspath):
            it.add_marker(skip)
