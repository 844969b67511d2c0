"""The suite's file order for its workers (issue 30 item 9, tests/conftest.py)."""

import tomllib

from conftest import LONG_FILES, REPO


def test_long_files_exist_and_keep_their_order_under_xdist():
    missing = [name for name in LONG_FILES if not (REPO / name).is_file()]
    assert not missing, f"LONG_FILES names files that are gone: {missing}"
    options = tomllib.loads((REPO / "pyproject.toml").read_text())
    addopts = options["tool"]["pytest"]["ini_options"]["addopts"].split()
    # loadfile keeps a file on one worker; xdist would otherwise re-sort the files by
    # their number of tests and start the one-test long files last.
    assert "--no-loadscope-reorder" in addopts and "loadfile" in addopts


def test_longest_files_first_then_the_most_tests_and_each_file_in_its_order():
    from types import SimpleNamespace

    from conftest import pytest_collection_modifyitems

    longest, second = sorted(LONG_FILES, key=lambda name: -LONG_FILES[name])[:2]
    ids = ["tests/a.py::t1", f"{second}::t1", "tests/b.py::t1", "tests/b.py::t2",
           f"{longest}::t2", f"{longest}::t1", "tests/a.py::t2", "tests/b.py::t3"]
    items = [SimpleNamespace(nodeid=i) for i in ids]
    pytest_collection_modifyitems(None, items)
    assert [i.nodeid for i in items] == [
        f"{longest}::t2", f"{longest}::t1", f"{second}::t1", "tests/b.py::t1",
        "tests/b.py::t2", "tests/b.py::t3", "tests/a.py::t1", "tests/a.py::t2"]
