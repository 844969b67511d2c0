"""Optimisation speed on 1 s of the bundled trial with 100 collocation intervals.

Run: python benchmarks/bench_optimisation.py

Reference (issue 6, OpenSim 4.6 Moco on a machine like ours, quoted, not measured here:
opensim is not in this project's dependencies): tracking 1 s of a 3-DOF leg with 50 mesh
intervals ~2.8 s (34 Ipopt iterations); one knee stiffness as a MocoParameter ~0.85 s
(13 iterations).
"""

import time

from predgait.dynamics.drivers import LegDrivers
from predgait.problems.collocation import NodeData, free_dynamics
from predgait.problems.fitting import correct_torques, fit_feedback, fit_knee
from predgait.workflows.inverse import bundled_inverse

MOCO_TRACKING = 2.8
MOCO_PARAMETER = 0.85


def timed(function, *args, **kwargs):
    start = time.perf_counter()
    result = function(*args, **kwargs)
    return result, time.perf_counter() - start


def main():
    inverse = bundled_inverse("right")
    drivers = LegDrivers.from_inverse(inverse)
    free_dynamics(inverse.model)  # symbolic dynamics built once per model (cached)
    for nodes in (100, 500):
        first = NodeData.from_drivers(drivers, 0.0, 1.0, nodes)
        other = NodeData.from_drivers(drivers, -0.1, 0.9, nodes)  # same grid, cached solver
        for name, function, moco in (("knee k, c fit", fit_knee, MOCO_PARAMETER),
                                     ("torque correction", correct_torques, MOCO_TRACKING),
                                     ("feedback gains", fit_feedback, MOCO_TRACKING)):
            _, built = timed(function, inverse.model, first)
            fit, total = timed(function, inverse.model, other)
            s = fit.solved
            print(f"{nodes:4d} nodes, {name:18s}: first call (builds the NLP) "
                  f"{built * 1e3:7.1f} ms;"
                  f" next window {total * 1e3:6.1f} ms ({s.iterations:3d} Ipopt iterations, "
                  f"{s.seconds * 1e3:6.1f} ms in Ipopt) -> {moco / total:6.1f}x / "
                  f"{moco / built:5.1f}x faster than the quoted Moco {moco} s")


if __name__ == "__main__":
    main()
