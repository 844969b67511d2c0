"""``predgait scenario`` of a ``kind = "muscle_scenario"`` file: write both predicted gaits.

:func:`run_muscle_scenario` solves (:mod:`predgait.scenarios.muscle_predict`), compares
(:mod:`predgait.scenarios.muscle_scenario_compare`) and writes, whole or not at all:

* ``baseline_*.sto`` and ``edited_*.sto``: each gait's solution, states, controls, muscle
  forces and GRF in OpenSim's column names (:mod:`predgait.workflows.muscle_gait_files`);
* ``summary.json``: status, edits, the comparison (kinematics from each leg's own heel
  strike, speed/stride/cadence, Bhargava cost of transport and effort, GRF peaks), ONE
  sentence on the published finding, both predictions' own summaries;
* ``scenario.png``: baseline vs edited, per leg from its heel strike.

An edited problem Ipopt does not solve: its best point as ``partial_edited_*.sto``, the
summary with status "not converged" and no comparison or finding (not a gait), then
SolveFailed (exit 3).
"""

from __future__ import annotations

import dataclasses
import enum
from pathlib import Path

import numpy as np

from predgait.errors import SolveFailed


def edit_record(edit) -> dict:
    """A JSON-ready record of one muscle edit (its type and fields)."""
    fields = {f.name: getattr(edit, f.name) for f in dataclasses.fields(edit)}
    return {"edit": type(edit).__name__,
            **{k: (v.value if isinstance(v, enum.Enum) else v) for k, v in fields.items()}}


def scenario_summary(result) -> dict:
    """summary.json of a solved (or failed) scenario."""
    from predgait.analysis.plausibility import baseline_check, record
    from predgait.problems.muscle_prediction import coordinate_ranges, prediction_summary
    from predgait.scenarios.muscle_scenario_compare import compare, finding, scenario_kind
    from predgait.textfile import source_name

    run, sc = result.run, result.scenario
    ok = result.edited.gait.solved.success
    quiet = dataclasses.replace(run.baseline, human_checks=False, moco_solution=None)
    out = {"status": "completed" if ok else "not converged", "kind": "muscle_scenario",
           "scenario": run.spec.name, "scenario_file": source_name(run.spec.source),
           "baseline_file": source_name(run.baseline.source),
           "edits": [edit_record(e) for e in run.spec.edits],
           "symmetric": sc.symmetric,
           "solved": "half stride with left/right symmetry" if sc.symmetric
           else "whole stride (one-sided edit), periodic",
           "fused": list(sc.fused),
           "springs": [edit_record(s) for s in sc.passive_torques],
           # the edited problem's own build, on a second thread while the baseline built
           # and solved; edited.build_s is the wait for it after the baseline
           "edited_problem_build_s": result.edited_build_s,
           "edited_start": result.edited_start,
           # the baseline's stored solves (an earlier run's), evaluated, not solved again
           "baseline_reused_from": result.baseline.reused_from,
           "pinocchio_check": {k: v for k, v in result.edited.check.items()
                               if k not in ("residual", "contact_point_speed")}}
    if ok:
        kind = scenario_kind(run.spec.edits)
        comparison = compare(result.baseline, result.edited)
        low = {**coordinate_ranges(run.baseline), **sc.coordinate_bounds}["knee_angle_r"][0]
        comparison["knee_flexion_limit_deg"] = float(-np.degrees(low))
        out |= {"finding_kind": kind, "finding": finding(kind, comparison),
                "comparison": comparison}
    # The baseline is checked against normal gait (an edited gait need not be normal): a
    # comparison built on a baseline that fails those checks says so.
    checked = dataclasses.replace(run.baseline, moco_solution=None)
    out["baseline"] = prediction_summary(checked, result.baseline)
    out["edited"] = prediction_summary(quiet, result.edited)
    human = out["baseline"].get("human_likeness", [])
    return record(out, [baseline_check(sum(not c["passed"] for c in human), len(human))]
                  if ok else [])


def run_muscle_scenario(run, out: Path, *, force: bool = False) -> dict:
    """Solve, compare, write (whole or not at all); SolveFailed after writing a partial."""
    from predgait.report.figures import plots_wanted
    from predgait.report.tidy import write_summary
    from predgait.scenarios.muscle_predict import solve_muscle_scenario
    from predgait.workflows.muscle_gait_files import write_gait_files
    from predgait.workflows.output import staged_output

    result = solve_muscle_scenario(run)
    summary = scenario_summary(result)
    ok = result.edited.gait.solved.success
    inputs = [run.spec.source, run.baseline.source, run.baseline.osim, run.baseline.reference]
    with staged_output(out, force=force, inputs=inputs) as stage:
        for name, pred in (("baseline", result.baseline), ("edited", result.edited)):
            write_gait_files(stage, pred.planar, pred.plant, pred.gait, pred.stride,
                             status=pred.gait.solved.status,
                             prefix=f"{name}_" if ok or name == "baseline"
                             else f"partial_{name}_")
        summary = write_summary(stage / "summary.json", summary)
        if ok and plots_wanted():
            from predgait.report.muscle_scenario_plots import save_muscle_scenario_plot

            save_muscle_scenario_plot(stage / "scenario.png", result.baseline, result.edited,
                                      title=run.spec.name)
    if not ok:
        s = result.edited.gait.solved
        raise SolveFailed(f"Ipopt (edited model, scenario '{run.spec.name}'): {s.status} "
                          f"after {s.iterations} iterations ({s.seconds:.1f} s), constraint "
                          f"violation {s.constraint_violation:.3g}; the best point is in "
                          f"{out}/ as partial_edited_*.sto (not a gait)",
                          best=result.edited.gait)
    return summary


def summary_lines(summary: dict) -> list[str]:
    """Console lines of a solved scenario."""
    c = summary["comparison"]
    b, e = summary["baseline"]["ipopt"], summary["edited"]["ipopt"]
    right = c["legs"]["r"]
    cot = (c["baseline"]["cost_of_transport_j_kg_m"], c["edited"]["cost_of_transport_j_kg_m"])
    reused = " (stored by an earlier run)" if summary.get("baseline_reused_from") else ""
    lines = [
        f"scenario '{summary['scenario']}' ({summary['solved']}): {summary['status']}; "
        f"baseline Ipopt {b['iterations']} iterations {b['solve_time_s']:.1f} s{reused}, edited "
        f"{e['status']} {e['iterations']} iterations {e['solve_time_s']:.1f} s",
        f"  cost of transport {cot[0]:.3f} -> {cot[1]:.3f} J/kg/m "
        f"({c['cost_of_transport_change_percent']:+.1f} %), effort "
        f"{c['effort_change_percent']:+.1f} %; stride {c['stride_length_m']['baseline']:.3f}"
        f" -> {c['stride_length_m']['edited']:.3f} m, cadence "
        f"{c['cadence_steps_min']['baseline']:.1f} -> {c['cadence_steps_min']['edited']:.1f}"
        " steps/min",
        "  right leg from its heel strike: " + ", ".join(
            f"{j} RMS change {right['rms_change_deg'][j]:.1f} deg, range "
            f"{right['range_deg'][j]['baseline']:.1f} -> {right['range_deg'][j]['edited']:.1f}"
            for j in ("hip", "knee", "ankle")),
        f"  right vertical GRF peak {right['peak_vertical_grf_bw']['baseline']:.2f} -> "
        f"{right['peak_vertical_grf_bw']['edited']:.2f} BW; initial contact "
        f"{right['initial_contact']['baseline']} -> {right['initial_contact']['edited']}",
        f"  {summary['finding']}",
        *(f"  warning: {w}" for w in summary.get("warnings", ()))]
    return lines
