"""``predgait scenario``: predict the gait after a model edit (surgery, orthosis, cast)."""

from __future__ import annotations

import argparse
from pathlib import Path

from predgait.cli import add_output_options

DESCRIPTION = """\
Edit the leg (scale a segment, move a COM, add mass, add a passive element such as an
ankle-foot orthosis or a stiffer knee, restrict a range of motion, lock a joint), re-simulate
the measured walk with the same drive and PD control, and compare with the unedited leg.
Writes summary.json (metrics), states_baseline.sto, states_edited.sto, edited_leg.urdf and
comparison plots into --out. Example files: problems/scenario_*.toml.
With predicts = true (problems/scenario_*_predict.toml) the edited and the unedited gait7
are given new gaits by predictive collocation instead (predgait solve predict_gait7):
summary.json, states/torques/grf_{baseline,edited}.sto, edited_gait7.urdf, plots; an
Ipopt failure exits 3 and writes nothing.
With kind = "muscle_scenario" (problems/scenario_muscle_*.toml: [[muscle_edit]] tables on
the muscle-driven 2D_gait.osim, baseline = a predict_muscles_2d file) the baseline and the
edited model are predicted (the edited one from the baseline's solution): baseline_*.sto,
edited_*.sto, summary.json (kinematics from heel strike, cost of transport, GRF, the
published finding reproduced or contradicted), scenario.png; --set baseline.KEY=VALUE
overrides the baseline file (baseline.grid.nodes=20). An Ipopt failure exits 3.
"""


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``scenario``."""
    cmd = commands.add_parser("scenario", help="what-if: edit the model, predict the gait",
                              description=DESCRIPTION,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    cmd.add_argument("scenario", type=Path, help="SCENARIO.toml")
    add_output_options(cmd, overrides="edit.0.k=200")
    cmd.add_argument("--every", type=int, default=20, metavar="N",
                     help="predicted scenarios: show Ipopt's progress (objective, constraint "
                          "violation) every N iterations and each stage (0: none)")
    cmd.set_defaults(run=run)


def write_scenario(result, out: Path, *, force: bool = False) -> dict:
    """Write the scenario's result folder whole or not at all; returns its summary."""
    from predgait.analysis.plausibility import record
    from predgait.data import write_storage
    from predgait.report.figures import plots_wanted
    from predgait.report.scenario_plots import save_scenario_plot
    from predgait.report.tidy import write_summary
    from predgait.scenarios.edits import edit_record
    from predgait.scenarios.run import scenario_checks
    from predgait.workflows.output import staged_output

    with staged_output(out, force=force, inputs=[result.spec.source]) as stage:
        summary = {"status": result.metrics["status"], "scenario": result.spec.name,
                   "trial": "bundled:subject01", "side": result.spec.side,
                   "torques": result.spec.torques.value, "gains": result.spec.gains.value,
                   "edits": [edit_record(e) for e in result.spec.edits],
                   "window_s": list(result.spec.window),
                   "control": {"kp_n_m_per_rad": result.spec.kp,
                               "kd_n_m_s_per_rad": result.spec.kd},
                   "metrics": result.metrics}
        summary = record(summary, scenario_checks(result.metrics))
        write_summary(stage / "summary.json", summary)
        for name, sim in (("baseline", result.baseline), ("edited", result.edited)):
            columns = {n: sim.q[:, i] for i, n in enumerate(sim.coordinate_names)}
            columns |= {f"{n}_speed": sim.v[:, i] for i, n in enumerate(sim.coordinate_names)}
            write_storage(stage / f"states_{name}.sto", sim.t, columns,
                          header={"units": "m, rad, m/s, rad/s", "scenario": result.spec.name})
        (stage / "edited_leg.urdf").write_text(result.edited_urdf)
        if plots_wanted():
            save_scenario_plot(stage, result)
    return summary


def run(args: argparse.Namespace) -> int:
    """Run and write a scenario."""
    from predgait.analysis.plausibility import warning_lines
    from predgait.scenarios.run import load_scenario, run_scenario
    from predgait.workflows.output import check_out

    check_out(args.out, force=args.force, inputs=[args.scenario])  # before any computation
    if _kind(args.scenario) == "muscle_scenario":
        return _run_muscle(args)
    spec = load_scenario(args.scenario, args.set)
    if spec.predicts:
        return _run_predicted(spec, args)
    result = run_scenario(spec)
    summary = write_scenario(result, args.out, force=args.force)
    m = result.metrics
    print(f"scenario '{result.spec.name}': {summary['status']}; wrote {args.out}/")
    if m["status"].startswith("diverged"):
        import sys

        print(f"predgait: error: the scenario {m['status']}, so it has no metrics: "
              f"{m['message']} Partial states in {args.out}/.", file=sys.stderr)
        return 1
    print(f"  knee angle change RMS {m['knee_rms_change_deg']:.1f} deg (max "
          f"{m['knee_max_change_deg']:.1f}); ankle {m['ankle_rms_change_deg']:.1f} deg")
    print(f"  extra feedback torque RMS: knee {m['knee_extra_feedback_rms_n_m']:.1f} N m, "
          f"ankle {m['ankle_extra_feedback_rms_n_m']:.1f} N m")
    for line in warning_lines(summary):
        print(line)
    return 0


def _progress_line(line: str) -> None:
    print(line, flush=True)


def _kind(path: Path) -> str | None:
    """The file's top-level ``kind`` (None when absent; syntax errors surface later)."""
    from predgait.problemfile import load_problem

    return load_problem(path).data.get("kind")


def _run_muscle(args) -> int:
    """A muscle-driven scenario (problems/scenario_muscle_*.toml): baseline and edited."""
    import sys

    from predgait.errors import SolveFailed
    from predgait.problems.ipopt_progress import reporting
    from predgait.scenarios.muscle_predict import load_muscle_scenario
    from predgait.workflows.muscle_scenario import run_muscle_scenario, summary_lines

    run = load_muscle_scenario(args.scenario, args.set)
    try:
        with reporting(args.every, _progress_line):
            summary = run_muscle_scenario(run, args.out, force=args.force)
    except SolveFailed as exc:
        print(f"predgait: solve failed: {exc}", file=sys.stderr)
        return 3
    for line in summary_lines(summary):
        print(line)
    print(f"  wrote {args.out}/ (summary.json, baseline_*.sto, edited_*.sto, scenario.png)")
    return 0


def write_predicted_scenario(result, out: Path, *, force: bool = False) -> dict:
    """Write a predicted scenario's folder whole or not at all; returns the summary."""
    from predgait.analysis.plausibility import record
    from predgait.report.figures import plots_wanted
    from predgait.report.tidy import write_summary
    from predgait.scenarios.edits import edit_record
    from predgait.scenarios.predict import predicted_scenario_checks
    from predgait.workflows.output import staged_output
    from predgait.workflows.predict import prediction_summary, write_prediction

    spec = result.spec
    checks = predicted_scenario_checks(result)
    with staged_output(out, force=force, inputs=[spec.source]) as stage:
        summary = write_summary(stage / "summary.json", record({
            "status": result.metrics["status"], "scenario": spec.name, "predicts": True,
            "trial": "bundled:subject01", "side": spec.side,
            "edits": [edit_record(e) for e in spec.edits], "metrics": result.metrics,
            "baseline": prediction_summary(spec.predict, result.baseline),
            "edited": prediction_summary(spec.predict, result.edited)}, checks))
        write_prediction(stage, result.model, result.baseline, prefix="baseline_")
        write_prediction(stage, result.edited_model, result.edited, prefix="edited_")
        (stage / "edited_gait7.urdf").write_text(result.edited_model.urdf)
        if plots_wanted():
            from predgait.report.predict_plots import save_prediction_plots

            save_prediction_plots(stage, result.model,
                                  {"unedited": result.baseline, "edited": result.edited},
                                  models={"edited": result.edited_model})
    return summary


def _run_predicted(spec, args) -> int:
    import sys

    from predgait.errors import SolveFailed
    from predgait.problems.ipopt_progress import reporting
    from predgait.scenarios.predict import ANGLES, run_predicted_scenario

    try:
        with reporting(args.every, _progress_line):
            result = run_predicted_scenario(spec, spec.predict)
    except SolveFailed as exc:
        print(f"predgait: solve failed: {exc}", file=sys.stderr)
        return 3
    summary = write_predicted_scenario(result, args.out, force=args.force)
    m = result.metrics
    print(f"scenario '{spec.name}' (predicted gait7, edits on {spec.side}): "
          f"{summary['status']}; wrote {args.out}/")
    for s in m["edited_sides"]:
        print(f"  {s}: " + ", ".join(
            f"{j} range {m[f'{j}_{s}_range_deg']:.1f} deg (unedited "
            f"{m[f'{j}_{s}_baseline_range_deg']:.1f}, RMS change "
            f"{m[f'{j}_{s}_rms_change_deg']:.1f})" for j in ANGLES))
        print(f"  {s}: swing hip torque RMS {m[f'swing_hip_torque_rms_{s}_n_m']:.1f} N m "
              f"(unedited {m[f'baseline_swing_hip_torque_rms_{s}_n_m']:.1f})")
    print(f"  effort {m['effort']:.4g} (unedited {m['baseline_effort']:.4g}, "
          f"{m['effort_change_percent']:+.1f} %); steps right {m['step_length_right_m']:.3f}"
          f" / left {m['step_length_left_m']:.3f} m at "
          f"{m['speed_m_s']:.2f} m/s, cadence {m['cadence_steps_min']:.1f} steps/min")
    if "resimulation_max_deviation_deg" in m:
        print(f"  engine re-simulation of the edited gait with TVLQR: max deviation "
              f"{m['resimulation_max_deviation_deg']:.2f} deg, feedback RMS "
              f"{m['resimulation_feedback_rms_n_m']:.2f} N m")
    from predgait.analysis.plausibility import warning_lines

    for line in warning_lines(summary):
        print(line)
    return 0
