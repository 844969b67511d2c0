"""``predgait solve`` kind ``predict_gait7``: a tracking or predictive gait7 cycle.

Reads a problem file (problems/predict_gait7.toml), maps the bundled walk onto gait7,
solves the collocation problem of :mod:`predgait.problems.predictive` (tracking weight 0:
purely predictive), re-evaluates the dynamics at every node with Pinocchio, re-simulates
the stride with the engine plus TVLQR feedback (:mod:`predgait.simulations.
gait7_predicted`) and writes solution.json, states.sto, torques.sto, grf.sto and plots.
An Ipopt failure raises :class:`~predgait.errors.SolveFailed` (status and constraint
violation reached) before anything is written. Scenarios call :func:`predict` on an
edited model (:mod:`predgait.scenarios.predict`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from predgait.dynamics.contact import HuntCrossleyContact
from predgait.dynamics.inverse_trial import bundled_source
from predgait.errors import SolveFailed
from predgait.models.gait7 import LIMITS
from predgait.models.loading import Model
from predgait.problemfile import Table
from predgait.problems.predictive import (
    DEFAULT_CONTACT,
    JOINTS,
    Cycle,
    Guess,
    PredictedGait,
    Start,
    Weights,
    problem_for,
)
from predgait.textfile import source_name

#: Weights of the first stage of a predictive solve (tracking weight 0): a tracking
#: solve from the measured guess, whose solution starts the requested problem. From the
#: measured motion directly, Ipopt ends in bouncing (3 stances per foot) or infeasible
#: local solutions; from the tracked (dynamically consistent) one, in a walking gait.
TRACKING_STAGE = Weights(tracking=1.0, grf=10.0, effort=1e-2, acceleration=1e-4)
#: Grid (intervals per half cycle) of the staged start: a predictive solve on another grid
#: starts from the solution on this one, resampled (grid continuation). From the tracked
#: motion directly, 50 intervals ended in a stuttering gait (3 stances per foot); from
#: the 40-interval gait resampled, in the same walking gait refined (17 iterations).
START_INTERVALS = 40
#: The starts (Ipopt barriers, :class:`Start`) tried in turn by a solve from each start.
RESTARTS = {Start.MEASURED: (Start.MEASURED,),
            Start.SOLUTION: (Start.SOLUTION, Start.RESAMPLED, Start.MEASURED),
            Start.RESAMPLED: (Start.RESAMPLED, Start.SOLUTION, Start.MEASURED)}


@dataclass(frozen=True)
class PredictSpec:
    """A parsed ``predict_gait7`` problem file (see problems/predict_gait7.toml)."""

    source: Path | None = None
    mass: float = 72.6
    height: float = 1.8034
    ground_z: float = -0.0075
    nodes: int = 40
    cycle: Cycle = Cycle.HALF
    speed: float | None = None          # m/s; None: the measured speed
    stride_time: float | None = None    # s; None: the measured stride time
    weights: Weights = Weights()
    contact: HuntCrossleyContact = DEFAULT_CONTACT
    max_penetration: float = 0.03
    max_iter: int = 1000
    resimulate: bool = True
    provenance: dict = field(default_factory=dict)


def parse_predict(table: Table) -> PredictSpec:
    """PredictSpec from a problem table (errors name the file, key and line)."""
    table.check_keys(("kind", "trial", "model", "grid", "gait", "weights", "contact",
                      "solver", "check"))
    trial = table.table("trial")
    trial.check_keys(("source",))
    bundled_source(trial)
    model, grid, gait = table.table("model"), table.table("grid"), table.table("gait")
    model.check_keys(("mass", "height", "ground_z"))
    grid.check_keys(("nodes", "cycle"))
    gait.check_keys(("speed", "stride_time"))
    weights, contact = table.table("weights"), table.table("contact")
    weights.check_keys(("tracking", "grf", "effort", "acceleration"))
    contact.check_keys(("stiffness", "exponent", "dissipation", "friction",
                        "slip_velocity_scale"))
    solver, check = table.table("solver"), table.table("check")
    solver.check_keys(("max_iter", "max_penetration"))
    check.check_keys(("resimulate",))
    d, hc = PredictSpec(), DEFAULT_CONTACT
    return PredictSpec(
        source=table.path,
        mass=model.number("mass", d.mass, low=1.0, high=500.0, unit="kg"),
        height=model.number("height", d.height, low=0.3, high=3.0, unit="m"),
        ground_z=model.number("ground_z", d.ground_z, low=-1.0, high=1.0, unit="m"),
        nodes=int(grid.number("nodes", d.nodes, low=4, high=400)),
        cycle=grid.choice("cycle", Cycle, d.cycle.value),
        speed=gait.number("speed", None, low=0.0, high=20.0, unit="m/s")
        if gait.has("speed") else None,
        stride_time=gait.number("stride_time", low=0.1, high=10.0, unit="s")
        if gait.has("stride_time") else None,
        weights=Weights(*(weights.number(k, getattr(d.weights, k), low=0.0, high=1e9)
                          for k in ("tracking", "grf", "effort", "acceleration"))),
        contact=HuntCrossleyContact(
            stiffness=contact.number("stiffness", hc.stiffness, low=1e3, high=1e10,
                                     unit="N/m^exponent"),
            exponent=contact.number("exponent", hc.exponent, low=1.0, high=3.0),
            dissipation=contact.number("dissipation", hc.dissipation, low=0.0, high=100.0,
                                       unit="s/m"),
            friction=contact.number("friction", hc.friction, low=0.0, high=5.0),
            slip_velocity_scale=contact.number("slip_velocity_scale", hc.slip_velocity_scale,
                                               low=1e-4, high=1.0, unit="m/s")),
        max_penetration=solver.number("max_penetration", d.max_penetration, low=1e-4,
                                      high=0.2, unit="m"),
        max_iter=int(solver.number("max_iter", d.max_iter, low=1, high=100000)),
        resimulate=check.get("resimulate", bool, True))


def default_bounds() -> dict[str, tuple[float, float]]:
    """The model's joint ranges (gait7 LIMITS), rad."""
    return {j: LIMITS[j[:-2]] for j in JOINTS}


@dataclass(frozen=True, eq=False)
class Prediction:
    """A solved cycle with its measured counterpart and its checks."""

    gait: PredictedGait
    measured: object          # MeasuredCycle
    residuals: dict
    stride: dict
    measures: dict
    resimulation: object | None
    springs: tuple
    stages: tuple = ()        # (what, Solved) of the stages before the final solve


def measured_for(spec: PredictSpec, model: Model):
    """The measured cycle (guess and reference) of ``spec`` on ``model``."""
    from predgait.problems.predictive_data import carrying_depth, measured_cycle
    from predgait.simulations.gait7_motion import bundled_gait7_motion, gait7_model

    motion = bundled_gait7_motion(gait7_model(spec.mass, spec.height))
    return measured_cycle(model, motion, spec.cycle, spec.nodes, ground_z=spec.ground_z,
                          sink=carrying_depth(model, spec.contact))


def predict(spec: PredictSpec, model: Model | None = None, *, bounds=None, springs=(),
            guess: Guess | None = None, start: Start | None = None,
            resimulate: bool | None = None) -> Prediction:
    """Solve ``spec`` on ``model`` (default: the unedited gait7) and check the result.

    ``guess`` defaults to the staged start (measured motion, tracking, grid continuation);
    ``start`` (Ipopt's barrier, :class:`Start`) to SOLUTION when a guess is given,
    RESAMPLED when it is the grid continuation's.

    Raises:
        SolveFailed: Ipopt did not converge (message: status, iterations, violation).
    """
    from predgait.problems.predictive_check import (
        full_stride,
        gait_measures,
        node_residuals,
        passive_joints,
    )
    from predgait.simulations.gait7_motion import gait7_model

    model = model or gait7_model(spec.mass, spec.height)
    measured = measured_for(spec, model)
    duration = measured.duration if spec.stride_time is None else (
        spec.stride_time / (2 if spec.cycle is Cycle.HALF else 1))
    speed = measured.speed if spec.speed is None else spec.speed
    problem = problem_for(model, spec.nodes, spec.cycle, spec.contact, spec.ground_z,
                          spec.max_penetration, spec.max_iter)
    kw = {"speed": speed, "duration": duration, "springs": springs,
          "bounds": default_bounds() if bounds is None else bounds}
    stages = []
    if guess is None and spec.weights.tracking == 0:
        guess, stages, resampled = _staged_guess(spec, model, kw)
        if start is None and resampled:
            start = Start.RESAMPLED
    if start is None:
        start = Start.MEASURED if guess is None else Start.SOLUTION
    gait = _solve(problem, guess or measured.guess, measured.reference, spec.weights, kw,
                  start=start, what=f"predictive on {spec.nodes} intervals", failed=stages)
    _check_solved(gait, "solve")
    residuals = node_residuals(model, gait, spec.contact, spec.ground_z, springs)
    stride = full_stride(model, gait)
    rerun = None
    if spec.resimulate if resimulate is None else resimulate:
        from predgait.simulations.gait7_predicted import resimulate as run_engine

        rerun = run_engine(model, stride, spec.contact, spec.ground_z, passive_joints(springs))
    measures = gait_measures(stride, speed, model.total_mass() * model.gravity)
    return Prediction(gait, measured, residuals, stride, measures, rerun, tuple(springs),
                      tuple(stages))


def _staged_guess(spec: PredictSpec, model: Model, kw: dict) -> tuple[Guess, list, bool]:
    """Guess of a predictive solve: tracking, then predictive on START_INTERVALS, resampled.

    The tracking stage starts from the measured motion; on a grid other than the final
    one (``cycle`` FULL counts twice the intervals), the predictive problem is solved
    there too and its solution resampled onto the final grid.
    """
    from predgait.problems.predictive_data import resampled_guess

    per_half = 2 if spec.cycle is Cycle.FULL else 1
    coarse = replace(spec, nodes=min(spec.nodes, START_INTERVALS * per_half))
    measured = measured_for(coarse, model)
    problem = problem_for(model, coarse.nodes, spec.cycle, spec.contact, spec.ground_z,
                          spec.max_penetration, spec.max_iter)
    first = problem.solve(measured.guess, measured.reference, TRACKING_STAGE, **kw)
    _check_solved(first, "tracking stage")
    stages = [(f"tracking on {coarse.nodes} intervals", first.solved)]
    guess = Guess(first.q, first.v, first.a)
    if coarse.nodes == spec.nodes:
        return guess, stages, False
    what = f"predictive on {coarse.nodes} intervals"
    second = _solve(problem, guess, measured.reference, spec.weights, kw,
                    start=Start.SOLUTION, what=what, failed=stages)
    _check_solved(second, f"predictive stage on {coarse.nodes} intervals")
    stages.append((what, second.solved))
    return resampled_guess(second, spec.nodes), stages, True


def _solve(problem, guess, reference, weights, kw: dict, *, start: Start, what: str,
           failed: list) -> PredictedGait:
    """Solve from ``start``; if Ipopt fails, again from the same guess with the next start.

    Ipopt's path through this non-convex problem depends on the machine's floating-point
    kernels: from the 20-interval tracking stage the adaptive barrier reached the
    predictive optimum with OpenBLAS's SkylakeX kernels and ended "infeasible" after 572
    iterations with its Haswell kernels, where the monotone barrier from mu = 1e-4
    converged (76 iterations, objective 0.359). Each failed attempt is appended to
    ``failed`` as a ``(what, Solved)`` stage.
    """
    tries = RESTARTS[start]
    for attempt in tries:
        gait = problem.solve(guess, reference, weights, start=attempt, **kw)
        if gait.solved.success or attempt is tries[-1]:
            return gait
        failed.append((f"{what} from a {attempt.value} start (failed)", gait.solved))


def _check_solved(gait: PredictedGait, what: str) -> None:
    s = gait.solved
    if not s.success:
        raise SolveFailed(f"Ipopt ({what}): {s.status} after {s.iterations} iterations "
                          f"({s.seconds:.1f} s), constraint violation "
                          f"{s.constraint_violation:.3g} (objective {s.objective:.4g}); "
                          "nothing written", best=gait)


def prediction_summary(spec: PredictSpec, prediction: Prediction) -> dict:
    """The JSON summary of a prediction (solver, objective terms, checks, gait measures)."""
    g, s = prediction.gait, prediction.gait.solved
    ref = prediction.measured.reference
    err = np.degrees(g.q - ref.q)[:, 2:]
    fz = g.foot_fz()
    res = prediction.residuals
    return {
        "status": "solved", "kind": "predict_gait7", "ipopt_status": s.status,
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
    }


def write_prediction(stage: Path, model: Model, prediction: Prediction, prefix: str = "") -> None:
    """states.sto, torques.sto and grf.sto of the stride into ``stage``."""
    from predgait.data.storage import write_storage

    st = prediction.stride
    names = model.coordinate_names
    write_storage(stage / f"{prefix}states.sto", st["t"],
                  {n: st["q"][:, i] for i, n in enumerate(names)}
                  | {f"{n}_speed": st["v"][:, i] for i, n in enumerate(names)},
                  header={"units": "m, rad, m/s, rad/s (gait7 coordinates)",
                          "what": "predicted stride (collocation nodes)"})
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
    from predgait.report.figures import plots_wanted
    from predgait.report.tidy import write_summary
    from predgait.simulations.gait7_motion import gait7_model
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
    lines = [f"predict_gait7: {summary['ipopt_status']} in {summary['iterations']} iterations, "
             f"{summary['solve_time_s']:.1f} s ({summary['nodes']} nodes, "
             f"{summary['cycle']} cycle)" + "".join(
                 f"; before it {x['what']}: {x['iterations']} iterations, "
                 f"{x['solve_time_s']:.1f} s" for x in summary["stages_before"]),
             f"  speed {g['speed_m_s']:.3f} m/s, stride {g['stride_time_s']:.3f} s, step "
             f"{g['step_length_m']:.3f} m, cadence {g['cadence_steps_min']:.1f} steps/min",
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
    return lines
