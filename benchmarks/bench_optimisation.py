"""Optimisation speed: knee fit and torque correction on 1 s of the bundled trial.

Run: python benchmarks/bench_optimisation.py [--repeat N] [--grid]

Rows (min / median of N repeats, wall and CPU):
  * cold, in process, solver cache off: the SX solver is generated in memory (ADAM
    dynamics, collocation NLP, Ipopt with the exact Hessian) and solved, as the first solve
    of a process does; imports excluded;
  * first run ever: the MX problem generated as C and compiled into the disk cache
    (problems/solver_cache.py, a temporary cache folder), once;
  * cold, in process, compiled solver loaded from that cache;
  * reused in process: the same problem on another 1 s window of the same grid (only Ipopt);
  * whole CLI processes: `predgait solve problems/knee_fit.toml` and
    `problems/torque_correction.toml` (imports, inverse dynamics, solve, re-simulation
    checks, files and plots), solver cache off and with the compiled solver cached.
The peer would be OpenSim Moco solving the same problems (MocoParameter on a passive knee;
a tracking problem with torque controls), cold, in the peer's Python; there is no such Moco
problem in benchmarks/ yet, so those rows print "peer not available".
``--grid`` also prints both transcriptions at 50 and 100 intervals for all three problems.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

from timing import REPO, Row, environment, print_rows, time_call, time_process

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.problems import collocation, fitting, solver_cache
from predgait.problems.collocation import NodeData, Transcription
from predgait.problems.fitting import correct_torques, fit_feedback, fit_knee

NO_PEER = "Moco: no same-work Moco problem in benchmarks/ yet"
HS = Transcription.HERMITE_SIMPSON


def clear_generated() -> None:
    """Forget every generated function, so the next solve is cold."""
    for cached in (collocation.free_dynamics, fitting._knee_problem,
                   fitting._correction_problem, fitting._feedback_problem):
        cached.cache_clear()


def rows(repeat: int) -> list[Row]:
    """The compared rows (for run_all.py)."""
    inverse = bundled_inverse("right")
    drivers = LegDrivers.from_inverse(inverse)
    grid = HS.grid_intervals(100)
    first = NodeData.from_drivers(drivers, 0.0, 1.0, grid)
    other = NodeData.from_drivers(drivers, -0.1, 0.9, grid)
    out = []
    with tempfile.TemporaryDirectory() as folder:
        cache = {solver_cache.FOLDER: folder, solver_cache.SWITCH: "on",
                 "PREDGAIT_COMPILE": "now"}  # compiled in the foreground: timed here
        for name, function, problem in (("knee_fit", fit_knee, "knee_fit.toml"),
                                        ("torque_correction", correct_torques,
                                         "torque_correction.toml")):
            def cold(function=function):
                clear_generated()
                return function(inverse.model, first, transcription=HS)

            with environment({solver_cache.SWITCH: "off"}):
                in_memory = time_call(cold, repeat)
            out.append(Row(f"{name} cold, in process (1 s, 100 Hermite-Simpson intervals), "
                           "solver cache off", in_memory,
                           "generate the SX solver in memory, then Ipopt; imports excluded",
                           None, NO_PEER, unit="s"))
            with environment(cache):
                compiled = time_call(cold, 1)
                loaded = time_call(cold, repeat)
                cached = time_call(lambda function=function: function(
                    inverse.model, other, transcription=HS), repeat)
                fit = function(inverse.model, other, transcription=HS)
            out.append(Row(f"{name} first run ever, in process: MX solver generated as C and "
                           "compiled into the cache", compiled,
                           f"{solver_cache.compiler()} {' '.join(solver_cache.FLAGS)}, once "
                           "per problem structure; the compiler runs as a child process, its "
                           "CPU is not in the CPU figure", None, NO_PEER, unit="s"))
            out.append(Row(f"{name} cold, in process, compiled solver loaded from the cache",
                           loaded, "build the MX problem, hash it, load the library, Ipopt",
                           None, NO_PEER, unit="s"))
            out.append(Row(f"{name} solver reused in process (another 1 s window)", cached,
                           f"Ipopt only: {fit.solved.iterations} iterations, "
                           f"{fit.solved.seconds * 1e3:.0f} ms in the solver", None, NO_PEER))
            command = [sys.executable, "-m", "predgait", "solve",
                       str(REPO / "problems" / problem), "--force"]
            for label, env in (("solver cache off", {solver_cache.SWITCH: "off"}),
                               ("compiled solver in the cache", cache)):
                with tempfile.TemporaryDirectory() as tmp:
                    whole = time_process([*command, "--out", f"{tmp}/out"], repeat,
                                         env={**os.environ, **env})
                out.append(Row(f"predgait solve problems/{problem}, whole CLI process, "
                               f"{label}", whole, "imports, inverse dynamics, solve, "
                               "re-simulation checks, files, plots", None, NO_PEER,
                               unit="s"))
    return out


def grid_table() -> None:
    """Both transcriptions, 50 and 100 intervals, all three problems: cold and cached."""
    inverse = bundled_inverse("right")
    drivers = LegDrivers.from_inverse(inverse)
    for transcription in Transcription:
        for intervals in (50, 100):
            grid = transcription.grid_intervals(intervals)
            first = NodeData.from_drivers(drivers, 0.0, 1.0, grid)
            other = NodeData.from_drivers(drivers, -0.1, 0.9, grid)
            for name, function in (("knee k, c fit", fit_knee),
                                   ("torque correction", correct_torques),
                                   ("feedback gains", fit_feedback)):
                start = time.perf_counter()
                function(inverse.model, first, transcription=transcription)
                built = time.perf_counter() - start
                start = time.perf_counter()
                fit = function(inverse.model, other, transcription=transcription)
                total = time.perf_counter() - start
                print(f"{transcription.value:15s} {intervals:4d} intervals, {name:18s}: cold "
                      f"{built * 1e3:7.1f} ms; cached {total * 1e3:6.1f} ms "
                      f"({fit.solved.iterations:3d} Ipopt iterations)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--grid", action="store_true")
    args = parser.parse_args()
    print_rows(rows(args.repeat))
    if args.grid:
        grid_table()


if __name__ == "__main__":
    main()
