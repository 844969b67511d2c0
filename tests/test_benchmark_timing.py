"""The benchmarks' timing harness: interleaved sides and the load line (issue 27)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from timing import load_text, time_interleaved  # noqa: E402


def test_sides_are_interleaved_and_each_timed():
    calls = []
    first, second = time_interleaved([lambda: calls.append("A"), lambda: calls.append("B")],
                                     repeat=3)
    assert calls == ["A", "B"] * 3
    assert len(first.wall) == len(second.wall) == 3 and len(first.cpu) == 3


def test_load_line_names_the_cores():
    text = load_text()
    assert text.startswith("load average ") and "cores" in text
