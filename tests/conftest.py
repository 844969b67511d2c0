"""Shared fixtures: the real-data folder beside the checkout, and the shipped models."""

import json
import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The third-party trials in ../shared/data (CI clones the repo beside shared/)."""
    if not SHARED_DATA.is_dir():
        raise FileNotFoundError(f"{SHARED_DATA} is missing: clone predgait beside shared/.")
    return SHARED_DATA


#: Text that is a Python repr rather than a value: None/True/nan as words, ``Name(...)``,
#: ``array(``, a dict or list printed as text, ``<... object at 0x...>``.
PYTHON_REPR = re.compile(r"^(None|True|False|nan|-?inf)$|^[A-Za-z_][\w.]*\(.*\)$|array\(|"
                         r"^[\[{].*[\]}]$|object at 0x")


def _strings(value):
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for key, item in value.items():
            yield key
            yield from _strings(item)
    elif isinstance(value, list):
        for item in value:
            yield from _strings(item)


@pytest.fixture(scope="session")
def assert_tidy_json():
    """A check that a summary file holds JSON values only, no string that is a Python repr."""
    def check(path: Path) -> dict:
        text = Path(path).read_text()
        data = json.loads(text)
        assert "NaN" not in text and "Infinity" not in text  # json.loads accepts both
        bad = [s for s in _strings(data) if PYTHON_REPR.search(s.strip())]
        assert not bad, f"{path}: Python reprs in JSON: {bad[:5]}"
        return data
    return check
