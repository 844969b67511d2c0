"""The comparison table of issue 14 in one run: predgait and OpenSim 4.6 side by side.

Run:  OPENSIM_PYTHON=/path/to/python-with-opensim GAIT2354_DIR=/path/to/Gait2354_Simbody \\
      python benchmarks/run_all.py [--repeat N]

Each row times predgait and, in the same run, the peer (OpenSim in the Python named by
OPENSIM_PYTHON; its Gait2354 tool set-ups in GAIT2354_DIR, see opensim_subject01.py): N
repeats each, min and median of wall and CPU time, and what each side does (frames, DOF,
nodes, cold or cached). A row without a peer prints "peer not available". On a machine
shared with other work the wall times are noisy: compare the CPU column too.
"""

from __future__ import annotations

import argparse
import platform
import time

import bench_forward
import bench_fullbody
import bench_inverse
import bench_optimisation
import bench_startup
from timing import markdown_table, opensim_python, print_rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    repeat = parser.parse_args().repeat
    print(f"predgait vs OpenSim 4.6, {repeat} repeats per row, min / median; "
          f"{platform.node()}, {platform.processor() or platform.machine()}, "
          f"{time.strftime('%Y-%m-%d %H:%M %Z')}; peer: {opensim_python() or 'none'}")
    rows = []
    for section, measure in (("start-up", bench_startup.rows),
                             ("leg inverse dynamics", bench_inverse.rows),
                             ("full body", bench_fullbody.rows),
                             ("leg forward dynamics", bench_forward.rows),
                             ("optimisation", bench_optimisation.rows)):
        print(f"\n== {section}")
        section_rows = measure(repeat)
        print_rows(section_rows)
        rows.extend(section_rows)
    print("\n" + markdown_table(rows))


if __name__ == "__main__":
    main()
