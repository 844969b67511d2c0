"""Sweep throughput: 64 scenarios of the leg (1 s each) on 1 and 2 local workers.

Run: python benchmarks/bench_sweep.py
"""

import functools
import time
from pathlib import Path

from predgait.scenarios.run import scenario_metrics
from predgait.scenarios.sweep import grid_points, run_sweep

SCENARIO = Path(__file__).resolve().parents[1] / "problems" / "scenario_stiff_knee.toml"


def main():
    points = grid_points({"edit.0.k": [0.0, 25.0, 50.0, 75.0, 100.0, 150.0, 200.0, 300.0],
                          "edit.0.theta0_deg": [0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0]})
    task = functools.partial(scenario_metrics, SCENARIO)
    rates = {}
    for workers in (1, 2):
        start = time.perf_counter()
        outcomes = run_sweep(task, points, workers=workers, progress=False)
        seconds = time.perf_counter() - start
        rates[workers] = len(points) / seconds
        failed = sum(not o.ok for o in outcomes)
        print(f"{len(points)} scenarios (1 s of the leg each), {workers} worker(s): "
              f"{seconds:6.2f} s, {rates[workers]:5.2f} scenarios/s, {failed} failed")
    print(f"speed-up of 2 workers over 1: {rates[2] / rates[1]:.2f}x")


if __name__ == "__main__":
    main()
