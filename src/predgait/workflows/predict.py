"""``predgait solve`` kind ``predict_gait7``: a tracking or predictive gait7 cycle.

Reads a problem file (problems/predict_gait7.toml), maps the bundled walk onto gait7,
solves the collocation problem of :mod:`predgait.problems.predictive` (tracking weight 0:
purely predictive), re-evaluates the dynamics at every node with Pinocchio, re-simulates
the stride with the engine plus TVLQR feedback (:mod:`predgait.simulations.
gait7_predicted`) and writes solution.json, states.sto, motion.mot (OpenSim 2D gait
coordinates), torques.sto, grf.sto and plots.
An Ipopt failure raises :class:`~predgait.errors.SolveFailed` (status and constraint
violation reached) before anything is written. The spec and staged solve are
:mod:`predgait.problems.predictive_solve`, the checked prediction
:func:`predgait.scenarios.predict.predict` (which scenarios call on an edited model).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait.analysis.plausibility import record, warning_lines
from predgait.models.loading import Model
from predgait.problems.predictive import JOINTS
from predgait.problems.predictive_solve import PredictSpec, parse_predict
from predgait.scenarios.predict import Prediction, predict, predict_checks
from predgait.textfile import source_name

__all__ = ["parse_predict", "prediction_summary", "run_predict", "summary_lines",
           "write_prediction"]


#: What the torque-driven gait7 prediction is and is not (issue 26: it is not human).
MODEL_NOTE = ("torque-driven 7-link gait: stiff-legged (little loading-response knee flexion, "
              "no ankle push-off, a heel-strike GRF spike); not for clinical prediction: "
              "use the muscle-driven predict_2d_muscles")


def prediction_summary(spec: PredictSpec, prediction: Prediction) -> dict:
    """The JSON summary of a prediction (solver, objective terms, checks, gait measures)."""
    g, s = prediction.gait, prediction.gait.solved
    ref = prediction.measured.reference
    err = np.degrees(g.q - ref.q)[:, 2:]
    fz = g.foot_fz()
    res = prediction.residuals
    return record({
        "status": "solved", "kind": "predict_gait7", "model_note": MODEL_NOTE,
        "ipopt_status": s.status,
        "iterations": s.iterations, "solve_time_s": s.seconds, "objective": s.objective,
        "stages_before": [{"what": what, "status": x.status, "iterations": x.iterations,
                           "solve_time_s": x.seconds} for what, x in prediction.stages],
        "constraint_violation": s.constraint_violation, "ipopt_history": s.history,
        "weights": vars(spec.weights), "objective_terms": g.terms,
        "nodes": spec.nodes, "cycle": spec.cycle.value, "transcription": "trapezoidal",
        "dynamics": "implicit (inverse-dynamics residual)",
        "speed_m_s": g.speed, "cycle_duration_s": g.duration,
        "gait": prediction.measures,
        "vs_measured": {
            "angle_rms_deg": dict(zip(g.coordinate_names[2:],
                                      np.sqrt(np.mean(err ** 2, axis=0)).tolist(),
                                      strict=True)),
            "vertical_grf_correlation": {
                side: float(np.corrcoef(fz[:, i], ref.foot_fz[:, i])[0, 1])
                for i, side in enumerate(("right", "left"))}},
        "pinocchio_check": {
            "max_base_residual_n": float(np.abs(res["base_residual_n"]).max()),
            "max_torque_mismatch_n_m": float(np.abs(res["torque_mismatch_n_m"]).max()),
            "max_defect": res["defects"]},
        "resimulation": None if prediction.resimulation is None
        else prediction.resimulation.summary(),
        "contact": vars(spec.contact), "ground_z_m": spec.ground_z,
        "provenance": {"problem": source_name(spec.source) if spec.source else None,
                       "trial_window_s": [prediction.measured.start,
                                          prediction.measured.start
                                          + prediction.measured.duration]},
    }, predict_checks(spec, prediction))


def write_prediction(stage: Path, model: Model, prediction: Prediction, prefix: str = "") -> None:
    """states.sto, motion.mot, torques.sto and grf.sto of the stride into ``stage``.

    ``motion.mot``: the stride as OpenSim's 2D gait model's coordinates (deg, m;
    :mod:`predgait.kinematics.osim2d_motion`).
    """
    from predgait.data.storage import write_storage
    from predgait.kinematics.osim2d_motion import write_osim2d_motion

    st = prediction.stride
    names = model.coordinate_names
    write_storage(stage / f"{prefix}states.sto", st["t"],
                  {n: st["q"][:, i] for i, n in enumerate(names)}
                  | {f"{n}_speed": st["v"][:, i] for i, n in enumerate(names)},
                  header={"units": "m, rad, m/s, rad/s (gait7 coordinates)",
                          "what": "predicted stride (collocation nodes)"})
    write_osim2d_motion(stage / f"{prefix}motion.mot", model, st["t"], st["q"],
                        header={"what": "predicted stride (collocation nodes)"})
    write_storage(stage / f"{prefix}torques.sto", st["t"],
                  {j: st["tau"][:, i] for i, j in enumerate(JOINTS)},
                  header={"units": "N m (model sign: + hip extension, knee flexion, "
                                   "ankle plantarflexion)", "what": "active joint torques"})
    frames = ("heel_r", "toe_r", "heel_l", "toe_l")
    write_storage(stage / f"{prefix}grf.sto", st["t"],
                  {f"{f}_{axis}": st["contact"][:, i, k] for i, f in enumerate(frames)
                   for k, axis in enumerate(("fx", "fz"))},
                  header={"units": "N (lab frame)", "what": "contact forces"})


def run_predict(spec: PredictSpec, out: Path, *, force: bool = False) -> dict:
    """Solve, check and write (whole or not at all); returns the summary."""
    from predgait.dynamics.gait7_motion import gait7_model
    from predgait.report.figures import plots_wanted
    from predgait.report.tidy import write_summary
    from predgait.workflows.output import staged_output

    prediction = predict(spec)
    model = gait7_model(spec.mass, spec.height)
    summary = prediction_summary(spec, prediction)
    with staged_output(out, force=force, inputs=[spec.source]) as stage:
        summary = write_summary(stage / "solution.json", summary)
        write_prediction(stage, model, prediction)
        if plots_wanted():
            from predgait.report.predict_plots import save_prediction_plots

            save_prediction_plots(stage, model, {"predicted": prediction})
    return summary


def summary_lines(summary: dict) -> list[str]:
    """Console lines of a prediction summary."""
    g, chk = summary["gait"], summary["pinocchio_check"]
    lines = [f"predict_gait7: {summary['status']}; Ipopt {summary['ipopt_status']} in "
             f"{summary['iterations']} iterations, "
             f"{summary['solve_time_s']:.1f} s ({summary['nodes']} nodes, "
             f"{summary['cycle']} cycle)" + "".join(
                 f"; before it {x['what']}: {x['iterations']} iterations, "
                 f"{x['solve_time_s']:.1f} s" for x in summary["stages_before"]),
             f"  speed {g['speed_m_s']:.3f} m/s, stride {g['stride_time_s']:.3f} s, steps "
             f"right {g['right']['step_length_m']:.3f} m / left "
             f"{g['left']['step_length_m']:.3f} m, cadence {g['cadence_steps_min']:.1f} "
             "steps/min",
             *(f"  {side} foot: {g[side]['stance_phases']} stance phase(s), "
               f"{100 * g[side]['stance_fraction']:.0f} % of the stride; vertical GRF "
               f"loading peak {g[side]['vertical_grf']['loading_peak_bw']:.2f} BW, valley "
               f"{g[side]['vertical_grf']['valley_bw']:.2f}, push-off "
               f"{g[side]['vertical_grf']['push_off_peak_bw']:.2f}" for side in ("right",)),
             "  objective terms: " + ", ".join(f"{k} {v:.4g}"
                                                for k, v in summary["objective_terms"].items()),
             f"  Pinocchio at every node: base residual {chk['max_base_residual_n']:.2g} N, "
             f"torque mismatch {chk['max_torque_mismatch_n_m']:.2g} N m"]
    rs = summary["resimulation"]
    if rs is not None:
        lines.append(f"  engine re-simulation with TVLQR: {rs['status']} to {rs['end_s']:.3f} s, "
                     f"max deviation {rs['max_angle_deviation_deg']:.2f} deg, "
                     f"{rs['max_position_deviation_m'] * 1000:.1f} mm; feedback RMS "
                     f"{rs['feedback_rms_n_m']:.2f} N m vs feedforward "
                     f"{rs['feedforward_rms_n_m']:.2f} N m")
    lines.append(f"  note: {summary['model_note']}")
    return lines + warning_lines(summary)
