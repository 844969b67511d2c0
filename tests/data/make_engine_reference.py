"""Store the forward engines' answers on the shipped problems (engine_reference.npz).

Run from the repository root: ``python tests/data/make_engine_reference.py``. The
answers were stored from the engines as they were before they were merged into one
(LegSystem, the rod's ABA loop and PartitionedSystem); tests/test_engine_reference.py
checks that the current engine reproduces them to 1e-9.
"""

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from engine_cases import ANSWERS  # noqa: E402


def main() -> None:
    """Compute every case and write engine_reference.npz beside this script."""
    answers = {}
    for fn in ANSWERS.values():
        answers |= fn()
    np.savez_compressed(HERE / "engine_reference.npz", **answers)


if __name__ == "__main__":
    main()
