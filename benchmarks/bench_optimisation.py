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
Peer (when OPENSIM_PYTHON names a Python that imports opensim; else "peer not
available"): OpenSim Moco on the same leg, window and grid (benchmarks/opensim_moco_leg.py:
MocoParameter fit of a SpringGeneralizedForce on the knee; MocoTrack of the measured
coordinates with the ankle and knee CoordinateActuators kept near the measured moments),
each repeat a fresh process stopped after ``--peer-minutes``: its build + solve inside the
process (the first solve, cold) beside predgait's cold in-process row, its whole process
beside ``predgait solve``'s. What differs is printed with the rows (Moco leaves the foot
free on residual actuators, tracked, where predgait prescribes it; limited-memory Hessian
and tolerance 1e-4, predgait exact Hessian and 1e-8). A Moco run that does not finish in
time or whose Ipopt fails is reported as such, with how far it got, and no ratio.
``--grid`` also prints both transcriptions at 50 and 100 intervals for all three problems.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

from moco_peer import moco_inputs, run_moco
from timing import REPO, Row, Timing, environment, print_rows, time_call, time_process

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.problems import collocation, fitting, solver_cache
from predgait.problems.collocation import NodeData, Transcription
from predgait.problems.fitting import correct_torques, fit_feedback, fit_knee

NO_PEER = "no Moco counterpart of this row"
HS = Transcription.HERMITE_SIMPSON
INTERVALS = 100
OURS_SIZE = (f"leg with the foot prescribed: 2 free DOF, 4 states, {INTERVALS} "
             f"Hermite-Simpson intervals ({2 * INTERVALS + 1} nodes), exact Hessian, tol 1e-8")


def clear_generated() -> None:
    """Forget every generated function, so the next solve is cold."""
    for cached in (collocation.free_dynamics, fitting._knee_problem,
                   fitting._correction_problem, fitting._feedback_problem):
        cached.cache_clear()


def moco_rows(inverse, drivers, name: str, repeat: int, minutes: float
              ) -> tuple[Timing | None, Timing | None, str]:
    """Moco's (in process, whole process, what it did or why not) for problem ``name``."""
    runs = run_moco(moco_inputs(inverse, drivers, name, INTERVALS), repeat, minutes)
    f = runs.facts
    size = (f"Moco: 5 DOF (foot free on residual actuators, tracked), 10 states, "
            f"{INTERVALS} Hermite-Simpson intervals ({2 * INTERVALS + 1} points), "
            "limited-memory Hessian, tol 1e-4")
    if f:
        size = (f"Moco {f['version']}: 5 DOF (foot free on residual actuators, tracked), "
                f"{f['states']} states, {f['controls']} controls, {INTERVALS} "
                f"Hermite-Simpson intervals ({f['points']} points), limited-memory Hessian, "
                "tol 1e-4")
    if runs.in_process is None:
        return None, None, f"{size}; {runs.why}"
    found = (f"k, c, theta0 = {', '.join(f'{v:.4g}' for v in f['parameters'])}; "
             if f["parameters"] else "")
    return runs.in_process, runs.whole, (
        f"{size}; {f['iterations']} iterations, {f['status']}; {found}RMS ankle, knee "
        f"{f['rms_deg'][0]:.2f}, {f['rms_deg'][1]:.2f} deg")


def rows(repeat: int, *, peer_minutes: float = 10.0, peer_repeat: int = 1) -> list[Row]:
    """The compared rows (for run_all.py); Moco runs ``peer_repeat`` times, each bounded."""
    inverse = bundled_inverse("right")
    drivers = LegDrivers.from_inverse(inverse)
    grid = HS.grid_intervals(INTERVALS)
    first = NodeData.from_drivers(drivers, 0.0, 1.0, grid)
    other = NodeData.from_drivers(drivers, -0.1, 0.9, grid)
    out = []
    with tempfile.TemporaryDirectory() as folder:
        cache = {solver_cache.FOLDER: folder, solver_cache.SWITCH: "on",
                 "PREDGAIT_COMPILE": "now"}  # compiled in the foreground: timed here
        for name, function, problem in (("knee_fit", fit_knee, "knee_fit.toml"),
                                        ("torque_correction", correct_torques,
                                         "torque_correction.toml")):
            moco_inside, moco_whole, moco_does = moco_rows(inverse, drivers, name,
                                                           peer_repeat, peer_minutes)

            def cold(function=function):
                clear_generated()
                return function(inverse.model, first, transcription=HS)

            with environment({solver_cache.SWITCH: "off"}):
                in_memory = time_call(cold, repeat)
                fit = function(inverse.model, first, transcription=HS)
            out.append(Row(f"{name} cold, in process (1 s, {INTERVALS} Hermite-Simpson "
                           "intervals), solver cache off", in_memory,
                           "generate the SX solver in memory, then Ipopt; imports excluded; "
                           f"{OURS_SIZE}; {fit.solved.iterations} iterations; "
                           + "".join(f"{k} {v:.4g}, " for k, v in fit.parameters.items()
                                     if name == "knee_fit") + "RMS ankle, knee "
                           f"{fit.rms_deg['ankle']:.2f}, {fit.rms_deg['knee']:.2f} deg",
                           moco_inside, f"build the study and solve, first in a fresh "
                           f"process, imports excluded; {moco_does}", unit="s"))
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
                peer = moco_whole if label == "solver cache off" else None
                out.append(Row(f"predgait solve problems/{problem}, whole CLI process, "
                               f"{label}", whole, "imports, inverse dynamics, solve, "
                               "re-simulation checks, files, plots", peer,
                               "whole Python process: import opensim, build, solve, write "
                               f"back; {moco_does}" if peer else NO_PEER, unit="s"))
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
    parser.add_argument("--peer-minutes", type=float, default=10.0,
                        help="stop each Moco run after this many minutes (default 10)")
    parser.add_argument("--peer-repeat", type=int, default=1,
                        help="fresh Moco processes per problem (default 1)")
    args = parser.parse_args()
    print_rows(rows(args.repeat, peer_minutes=args.peer_minutes,
                    peer_repeat=args.peer_repeat))
    if args.grid:
        grid_table()


if __name__ == "__main__":
    main()
