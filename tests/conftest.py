"""Shared fixtures: the real-data folder beside the checkout, and the shipped models."""

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
