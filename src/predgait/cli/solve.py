"""``predgait solve``: knee spring/damper fit, torque correction, feedback gains."""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from predgait.cli import add_output_options

DESCRIPTION = """\
Optimisation of the leg driven by the measured moments (CasADi direct collocation on the
ADAM dynamics, Ipopt with exact Hessians), then a check by Pinocchio re-simulation.
Problem kinds (problems/knee_fit.toml, torque_correction.toml, feedback_gains.toml):
  knee_fit           k (N m/rad), c (N m s/rad), theta0 of a passive knee spring-damper
  torque_correction  smallest smooth changes of the ankle and knee moments (N m)
  feedback_gains     PD gains on the tracking error that reject a perturbed start
  torque_feedback    measured (or corrected) moments plus time-varying LQR feedback
                     around the measured motion, re-simulated over the first gait
                     cycle (problems/torque_feedback.toml): feedforward vs feedback
                     torque against the inverse-dynamics uncertainty (cut-offs 4-8 Hz)
  predict_gait7      tracking or predictive (tracking weight 0) gait cycle of the
                     7-link model on smooth heel/toe contact (problems/
                     predict_gait7.toml), checked by Pinocchio at every node and
                     re-simulated by the engine with TVLQR feedback
  predict_muscles_2d  OpenSim Moco's example2DWalking prediction on 2D_gait.osim (18
                     DeGrooteFregly2016 muscles, smooth sphere contacts; problems/
                     predict_2d_muscles.toml): half a stride, symmetry, 1.2 m/s, effort
                     per distance; states/controls as OpenSim STO, human-likeness checks
  fullbody_tracking  the 35-DOF body with its pelvis free made dynamically consistent:
                     corrected kinematics, joint torques, sole contact forces; then
                     re-simulated on the contact springs with and without time-varying
                     LQR feedback (problems/fullbody_tracking.toml)
  passive_decomposition  passive knee/ankle moments split from the measured moments
                     (no simulation; problems/passive_decomposition.toml), with
                     bootstrap intervals or "not identifiable"
  passive_swing      passive knee/ankle fitted to the measured angles of the quiet
                     phases by simulating the shank and foot under the measured thigh
                     (problems/passive_swing.toml), with bootstrap intervals
  passive_knee_ankle  the lab's answer per joint: the swing angles and the quiet
                     phases' moments fitted together (problems/passive_knee_ankle.toml);
                     parameters with intervals, a curve with a band, or how many more
                     quiet swings an answer needs; window and cut-off sensitivity
  passive_shooting   stabilising spring-dampers added to the measured moments, fitted
                     by multiple shooting over intervals shorter than the unstable time
                     constant (problems/passive_shooting.toml), beside the decomposition
Writes solution.json (status, iterations, solve time, objective, constraint violation,
parameters with 95 % intervals, re-simulation check), states.sto, resimulated_states.sto,
corrected_moments.sto (torque correction) and plots into --out. A solve that does not
converge is reported as such (exit 3) and writes nothing.
"""


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``solve``."""
    cmd = commands.add_parser("solve", help="fit passive knee, correct torques, fit gains",
                              description=DESCRIPTION,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    cmd.add_argument("problem", type=Path, help="PROBLEM.toml")
    add_output_options(cmd, overrides="nodes=200")
    cmd.add_argument("--every", type=int, default=5, metavar="N",
                     help="show Ipopt's progress every N iterations, live for the long "
                          "solves (predict_gait7, predict_muscles_2d, fullbody_tracking) "
                          "(0: summary only)")
    cmd.set_defaults(run=run)


@dataclass(frozen=True)
class _Workflow:
    """A solve kind run by its workflow module's ``parse``, ``run`` and ``summary_lines``."""

    module: str
    parse: str
    run: str
    exit_code: Callable[[dict], int] = lambda result: 0


_WORKFLOWS = {
    "passive_decomposition": _Workflow(
        "predgait.workflows.decomposition", "parse_decomposition", "run_decomposition"),
    "passive_shooting": _Workflow(
        "predgait.workflows.shooting", "parse_shooting", "run_shooting"),
    "passive_swing": _Workflow(
        "predgait.workflows.passive_swing", "parse_swing", "run_swing"),
    "passive_knee_ankle": _Workflow(
        "predgait.workflows.passive_swing", "parse_knee_ankle", "run_swing"),
    "torque_feedback": _Workflow(
        "predgait.workflows.torque_feedback", "parse_feedback", "run_feedback",
        exit_code=lambda result: 0 if result["holds_within_threshold"] else 3),
    "predict_gait7": _Workflow(
        "predgait.workflows.predict", "parse_predict", "run_predict"),
    "predict_muscles_2d": _Workflow(
        "predgait.workflows.predict_muscles", "parse_muscle_predict", "run_muscle_predict"),
    "fullbody_tracking": _Workflow(
        "predgait.workflows.fullbody_tracking_run", "parse_tracking", "run_tracking"),
}


def run(args: argparse.Namespace) -> int:
    """Solve, check and write."""
    from predgait.problemfile import load_problem
    from predgait.workflows.output import check_out

    check_out(args.out, force=args.force, inputs=[args.problem])  # before any computation
    table = load_problem(args.problem, args.set)
    table.expect_command("solve")
    workflow = _WORKFLOWS.get(table.data.get("kind"))
    if workflow is not None:           # imports only what that kind needs
        return _run_workflow(workflow, table, args)
    return _run_collocation(table, args)


def _progress_line(line: str) -> None:
    print(line, flush=True)


def _run_workflow(workflow: _Workflow, table, args) -> int:
    """Parse, run, print the workflow's summary; a failed solve exits 3 and writes nothing."""
    from predgait.errors import SolveFailed
    from predgait.workflows.output import check_out

    module = importlib.import_module(workflow.module)
    spec = getattr(module, workflow.parse)(table)
    trial = getattr(spec, "trial", spec)
    inverse_problem = getattr(trial, "inverse_problem", None)
    if inverse_problem is not None:   # --out must not be where an input lives
        check_out(args.out, force=args.force, inputs=[args.problem, inverse_problem])
    from predgait.problems.ipopt_progress import reporting

    try:
        with reporting(args.every, _progress_line):   # live Ipopt lines of long solves
            result = getattr(module, workflow.run)(spec, args.out, force=args.force)
    except SolveFailed as exc:
        print(f"predgait: solve failed: {exc}", file=sys.stderr)
        return 3
    for line in module.summary_lines(result):
        print(line)
    written = ", ".join(sorted(p.name for p in Path(args.out).iterdir()))
    print(f"  wrote {args.out}/ ({written})")  # what is there, e.g. no plots with --no-plots
    return workflow.exit_code(result)


def _run_collocation(table, args) -> int:
    """``knee_fit``, ``torque_correction``, ``feedback_gains``: collocation, re-simulation."""
    from predgait.errors import SolveFailed
    from predgait.workflows.output import check_out
    from predgait.workflows.solve import deviation_wording, parse_solve, run_solve

    spec = parse_solve(table)
    check_out(args.out, force=args.force, inputs=[args.problem, spec.inverse_problem])
    try:
        solution = run_solve(spec, args.out, force=args.force)
    except SolveFailed as exc:
        print(f"predgait: solve failed: {exc}", file=sys.stderr)
        return 3
    if args.every > 0:
        from types import SimpleNamespace

        from predgait.report.diagnostics import ipopt_lines

        for line in ipopt_lines(SimpleNamespace(history=solution["ipopt_history"]),
                                every=args.every):
            print(line)
    check = solution["resimulation_check"]
    params = ", ".join(f"{k} = {v:.4g}" for k, v in solution["parameters"].items())

    print(f"{spec.kind.value}: {solution['status']}; Ipopt {solution['ipopt_status']} in "
          f"{solution['iterations']} iterations, {solution['solve_time_s']:.3f} s; {params}; "
          f"wrote {args.out}/")
    if "what" in solution:
        print(f"  these are a {solution['what']}")
    for name, half in solution["confidence95"].items():
        print(f"  {name}: 95 % interval " + (half if isinstance(half, str) else f"+-{half:.3g}"))
    print("  optimiser tracking RMS: " + ", ".join(
        f"{k} {v:.2f} deg" for k, v in solution["optimiser_tracking_rms_deg"].items()))
    for name, result in check.items():
        print(f"  re-simulation {name}: {deviation_wording(result, spec.threshold_deg)}")
    from predgait.analysis.plausibility import warning_lines

    for line in warning_lines(solution):
        print(line)
    return 0
