"""``predgait solve`` of a ``predict_muscles_2d`` problem: parse, run, write the result folder.

The problem itself (spec, solve, summary) is :mod:`predgait.problems.muscle_prediction`.
"""

from __future__ import annotations

from pathlib import Path

from predgait.errors import SolveFailed
from predgait.problems.muscle_prediction import (
    MusclePredictSpec,
    parse_muscle_predict,  # noqa: F401  (the CLI resolves the parser here)
    prediction_summary,
    solve_prediction,
)


def run_muscle_predict(spec: MusclePredictSpec, out: Path, *, force: bool = False) -> dict:
    """Solve, check and write (whole or not at all); SolveFailed after writing a partial."""
    from predgait.report.figures import plots_wanted
    from predgait.report.tidy import write_summary
    from predgait.workflows.muscle_gait_files import write_gait_files
    from predgait.workflows.output import staged_output

    pred = solve_prediction(spec)
    summary = prediction_summary(spec, pred)
    ok = pred.gait.solved.success
    inputs = [spec.source, spec.osim, spec.reference, spec.multistart.tracking_solution]
    with staged_output(out, force=force, inputs=inputs) as stage:
        write_gait_files(stage, pred.planar, pred.plant, pred.gait, pred.stride,
                         status=pred.gait.solved.status, prefix="" if ok else "partial_")
        summary = write_summary(stage / "summary.json", summary)
        if ok and plots_wanted():
            from predgait.report.muscle_gait_plots import save_muscle_gait_plots

            save_muscle_gait_plots(stage / "prediction.png", pred.plant, pred.planar,
                                   pred.stride)
    if not ok:
        s = pred.gait.solved
        raise SolveFailed(f"Ipopt (prediction): {s.status} after {s.iterations} iterations "
                          f"({s.seconds:.1f} s), constraint violation "
                          f"{s.constraint_violation:.3g}; the best point is in {out}/ as "
                          "partial_*.sto (not a gait)", best=pred.gait)
    return summary


#: The goal weight of each objective term (summary "goal"); speed is a cost only when
#: it is not the endpoint constraint.
TERM_WEIGHTS = {"speed": "speed_weight", "effort": "effort_weight",
                "tracking": "tracking_weight", "acceleration": "acceleration_weight",
                "metabolic": "metabolic_weight", "loading_rate": "loading_rate_weight"}


def weighted_terms(summary: dict) -> list[tuple[str, float, float]]:
    """(term, weight, unweighted value) of the terms in the objective (weight > 0)."""
    goal = summary["goal"]
    out = []
    for name, value in summary["objective_terms"].items():
        weight = goal.get(TERM_WEIGHTS[name], 0.0)
        if name == "speed" and goal.get("speed_constraint"):
            weight = 0.0
        if weight > 0:
            out.append((name, weight, value))
    return out


def summary_lines(summary: dict) -> list[str]:
    """Console lines (the headline) of a prediction summary."""
    from predgait.analysis.plausibility import warning_lines

    g, ip = summary["gait"], summary["ipopt"]
    right = g["right"]
    vg = right["vertical_grf"]
    lines = [f"predict_muscles_2d: {summary['status']}; Ipopt {ip['status']} in "
             f"{ip['iterations']} iterations, {ip['solve_time_s']:.1f} s (build "
             f"{summary['build_s']:.1f} s, total {summary['total_s']:.1f} s, "
             f"{summary['nodes']} intervals)" + "".join(
                 f"; before it {x['what']}: {x['iterations']} iterations, "
                 f"{x['solve_time_s']:.1f} s" for x in summary["stages_before"]),
             f"  speed {g['speed_m_s']:.3f} m/s, stride {g['stride_length_m']:.3f} m in "
             f"{g['stride_time_s']:.3f} s, cadence {g['cadence_steps_min']:.1f} steps/min, "
             f"right stance {right['stance_percent']:.0f} %",
             f"  right vertical GRF: peak {vg['peak_bw']:.2f} BW, loading "
             f"{vg['loading_peak_bw']:.2f}, trough {vg['valley_bw']:.2f}, push-off "
             f"{vg['push_off_peak_bw']:.2f}; slip right {1000 * right['slip_m']:.1f} mm, "
             f"left {1000 * g['left']['slip_m']:.1f} mm per stride",
             "  objective " + f"{summary['objective']:.5g} = " + " + ".join(
                 f"{k} {w:.4g} x {v:.4g}" for k, w, v in weighted_terms(summary)),
             f"  Pinocchio at every node: residual {summary['pinocchio_check']['max_residual']:.2g}"
             f" N (N m), ABA - a {summary['pinocchio_check']['max_acceleration_error']:.2g}"]
    moco = summary["moco"]
    if moco["available"]:
        lines.append(f"  Moco's solution: objective {moco['objective']}, kinematics RMS up to "
                     f"{moco['max_kinematics_rms_deg']:.1f} deg")
    ms = summary.get("multistart")
    if ms:
        lines.append(f"  multi-start: {ms['converged']} of {ms['starts']} converged, objective "
                     f"{ms['objective_min']:.5g} / {ms['objective_median']:.5g} / "
                     f"{ms['objective_max']:.5g} (min / median / max), kinematics up to "
                     f"{ms['max_kinematics_rms_deg_vs_best']:.1f} deg RMS from the best "
                     f"({ms['best']}); all starts {ms['seconds']:.1f} s" if ms["converged"] else
                     f"  multi-start: none of {ms['starts']} starts converged")
    lines += warning_lines(summary)
    return lines

