"""Start-up: whole processes of `predgait --help` and `predgait model show leg`.

Compared, in the same run, with `python -c "import pinocchio"` in the same Python (the goal:
within 1.5x of it) and with `import opensim` in the peer's Python (OPENSIM_PYTHON). Each is
timed as a whole process, several repeats, min and median of wall and CPU.

Run:  python benchmarks/bench_startup.py [--repeat N]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from timing import NOT_AVAILABLE, Row, Timing, opensim_python, ratio, time_process

PREDGAIT = [sys.executable, "-m", "predgait"]


def measure(repeat: int) -> dict[str, Timing | None]:
    """Whole-process timings, keyed by what was run."""
    rows: dict[str, Timing | None] = {
        "python -c 'import pinocchio'": time_process(
            [sys.executable, "-c", "import pinocchio"], repeat),
        "predgait --help": time_process([*PREDGAIT, "--help"], repeat),
        "predgait model show leg": time_process([*PREDGAIT, "model", "show", "leg"], repeat),
    }
    peer = opensim_python()
    rows["OpenSim: python -c 'import opensim'"] = (
        time_process([peer, "-c", "import opensim"], repeat) if peer else None)
    return rows


def rows(repeat: int) -> list[Row]:
    """The compared rows (for run_all.py)."""
    measured = measure(repeat)
    pinocchio = measured["python -c 'import pinocchio'"]
    opensim = measured["OpenSim: python -c 'import opensim'"]
    return [Row(f"`{name}` vs `import opensim`, whole processes", measured[name],
                f"{measured[name].best / pinocchio.best:.2f}x wall, "
                f"{min(measured[name].cpu) / min(pinocchio.cpu):.2f}x CPU of `import pinocchio`"
                f" ({pinocchio.best:.2f} s wall, {min(pinocchio.cpu):.2f} s CPU; goal <= 1.5x)",
                opensim,
                "Python + import opensim", unit="s")
            for name in ("predgait --help", "predgait model show leg")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    repeat = parser.parse_args().repeat
    print(f"Start-up, whole processes, {repeat} repeats, min / median "
          f"({Path(sys.executable).parent.parent.name} Python)")
    rows = measure(repeat)
    for name, timing in rows.items():
        print(f"  {name:<40} {timing.describe('s') if timing else NOT_AVAILABLE}")
    pinocchio = rows["python -c 'import pinocchio'"]
    opensim = rows["OpenSim: python -c 'import opensim'"]
    for name in ("predgait --help", "predgait model show leg"):
        ours = rows[name]
        print(f"  {name}: {ours.best / pinocchio.best:.2f}x wall, "
              f"{min(ours.cpu) / min(pinocchio.cpu):.2f}x CPU of import pinocchio (min; goal "
              "<= 1.5x);"
              f" vs import opensim: {ratio(ours, opensim)}")


if __name__ == "__main__":
    main()
