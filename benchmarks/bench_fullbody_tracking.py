"""Whole-body tracking with contacts (issue 18): one stance and one gait cycle of subject01.

Times, in process, the tracking solve (CasADi + Ipopt, the pelvis rows from one RNEA pass
in SX; exact Hessian, constraint Jacobian and cost gradient assembled from one node's and
one interval's symbolic derivatives, the first ``[solver] convex_iterations`` on
eigen-clipped node Hessians) cold (symbolic functions built: caches cleared) and
warm (built once per model, reused), with nodes and iterations; then, for the cycle, the LQR gains
(linearisation at every node + Riccati) and the two forward re-simulations on the
contact springs (RK4). Goal of the issue: a whole cycle in under 60 s on 2 cores. CPU
is the figure to compare on a shared machine (the wall time there follows the load).

Solver peer: Crocoddyl FDDP on the same stance (crocoddyl_stance.py, in fresh processes of
CROCODDYL_PYTHON or this Python), its table printed after the rows; "crocoddyl not
installed" (or why it cannot run) otherwise. Peer (OpenSim Moco 3D tracking): not run,
"peer not available".

Run:  python benchmarks/bench_fullbody_tracking.py [--repeat N]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from timing import NOT_AVAILABLE, Row, Timing, print_rows, time_call  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
PROBLEM = REPO / "problems" / "fullbody_tracking.toml"
STANCE = (0.633, 0.9)


def _setup(window):
    from predgait.problemfile import load_problem
    from predgait.simulations.forward3d import FullbodyDrive
    from predgait.workflows.forward3d_run import inverse_for
    from predgait.workflows.fullbody_tracking import (
        gait_cycle,
        parse_tracking,
        plate_height,
        tracking_data,
    )

    overrides = [] if window is None else [f"window.start={window[0]}",
                                           f"window.end={window[1]}"]
    spec = parse_tracking(load_problem(PROBLEM, overrides))
    inverse = inverse_for(spec.trial)
    drive = FullbodyDrive.from_inverse(inverse)
    window = spec.window or gait_cycle(drive, inverse.stances)
    data = tracking_data(drive, plate_height(inverse), window, contact=spec.contact,
                         contact_height=spec.contact_height, stride=spec.stride,
                         fade_nodes=spec.fade_nodes)
    return spec, drive, data


def _solve_timings(spec, drive, data, repeat: int, solver: str = "ipopt"
                   ) -> tuple[Timing, Timing, object]:
    from predgait.problems import fullbody_tracking as tracking
    from predgait.problems import fullbody_tracking_fatrop as fatrop
    from predgait.problems import fullbody_tracking_stage as stage

    solutions = []

    def cold():
        stage.node_function.cache_clear()
        stage.stage_functions.cache_clear()
        fatrop.stage_form.cache_clear()
        warm()

    def warm():
        solutions.append(tracking.solve_tracking(
            drive.model, data, spec.weights, max_iter=spec.max_iter, solver=solver,
            convex_iterations=spec.convex_iterations if solver == "ipopt" else 0))

    return time_call(cold, repeat), time_call(warm, repeat), solutions[-1]


def rows(repeat: int = 1, notes: list[str] | None = None) -> list[Row]:
    """Stance and cycle, cold and warm; the cycle's feedback (for run_all.py).

    ``notes``, when given, receives the stance's Crocoddyl comparison lines.
    """
    out = []
    for name, window in (("one stance 0.633-0.9 s", STANCE), ("one gait cycle", None)):
        spec, drive, data = _setup(window)
        cold, warm, solution = _solve_timings(spec, drive, data, repeat)
        does = (f"{data.nodes} nodes x 117 unknowns, {solution.iterations} Ipopt iterations, "
                f"pelvis residual {abs(solution.tau[:, :6]).max():.1e}")
        out.append(Row(f"whole-body tracking, {name}, cold (symbolic build included)", cold,
                       does, None, "OpenSim Moco: " + NOT_AVAILABLE, unit="s"))
        out.append(Row(f"whole-body tracking, {name}, warm (symbolic functions cached)", warm,
                       does, None, "OpenSim Moco: " + NOT_AVAILABLE, unit="s"))
        if window == STANCE and notes is not None:
            from crocoddyl_stance import comparison

            notes += comparison(drive, data, solution, cold, warm, repeat)
    from predgait.workflows.fullbody_tracking_run import hold_with_feedback

    runs = []
    feedback = time_call(lambda: runs.append(hold_with_feedback(spec, drive, data,
                                                                 solution)), repeat)
    info = runs[-1][0]
    closed, opened = info["with_feedback"], info["without_feedback"]
    does = (f"LQR gains at {data.nodes} nodes ({info['gains_time_s']:.1f} s) + RK4 "
            f"{info['rk4_step_s']:g} s re-simulations: without feedback "
            f"{opened['status']} at {opened['simulated_s']:.3f} s ({opened['wall_time_s']:.1f}"
            f" s), with feedback {closed['status']} at {closed['simulated_s']:.3f} s "
            f"({closed['wall_time_s']:.1f} s)")
    out.append(Row("whole-body feedback for the gait cycle", feedback, does, None,
                   NOT_AVAILABLE, unit="s"))
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1)
    notes: list[str] = []
    print_rows(rows(parser.parse_args().repeat, notes))
    print("\n".join(notes))
