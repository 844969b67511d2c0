"""Optimisation speed on 1 s of the bundled trial, 50 and 100 collocation intervals.

Run: python benchmarks/bench_optimisation.py

Reference (issue 6, OpenSim 4.6 Moco on a machine like ours, quoted, not measured here:
opensim is not in this project's dependencies): tracking 1 s of a 3-DOF leg with 50 mesh
intervals ~2.8 s (34 Ipopt iterations); one knee stiffness as a MocoParameter ~0.85 s
(13 iterations).
"""

import time

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.problems.collocation import NodeData, Transcription, free_dynamics
from predgait.problems.fitting import correct_torques, fit_feedback, fit_knee

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
    print("Moco figures are QUOTED from the issue (opensim is not installable here); the\n"
          "ratio is quoted Moco time / our time on the same kind of problem.")
    for transcription in Transcription:
        for intervals in (50, 100):
            grid = transcription.grid_intervals(intervals)
            first = NodeData.from_drivers(drivers, 0.0, 1.0, grid)
            other = NodeData.from_drivers(drivers, -0.1, 0.9, grid)  # same grid: cached solver
            for name, function, moco in (("knee k, c fit", fit_knee, MOCO_PARAMETER),
                                         ("torque correction", correct_torques, MOCO_TRACKING),
                                         ("feedback gains", fit_feedback, MOCO_TRACKING)):
                _, built = timed(function, inverse.model, first, transcription=transcription)
                fit, total = timed(function, inverse.model, other, transcription=transcription)
                s = fit.solved
                print(f"{transcription.value:15s} {intervals:4d} intervals, {name:18s}: first "
                      f"call (builds the NLP) {built * 1e3:7.1f} ms; next window "
                      f"{total * 1e3:6.1f} ms ({s.iterations:3d} Ipopt iterations, "
                      f"{s.seconds * 1e3:6.1f} ms in Ipopt) -> {moco / total:6.1f}x "
                      f"(first call {moco / built:5.1f}x) vs quoted Moco {moco} s")


if __name__ == "__main__":
    main()
