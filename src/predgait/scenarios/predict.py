"""A what-if scenario solved as a predictive gait7 problem (``predicts = true``).

Instead of re-simulating the measured gait with PD feedback toward it (which pins the
outcome to the old gait, :mod:`predgait.scenarios.run`), the edited body gets a new gait
of its own: the predictive collocation problem of :mod:`predgait.problems.predictive`
is solved on the edited gait7 and compared with the same problem on the unedited one.

Edits on gait7 (the scenario's ``side``, or both legs with ``side = "both"``):

* segment edits (scale mass/length, move COM, add mass) regenerate the URDF from the
  edited leg parameters (:func:`predgait.models.gait7.build_gait7_urdf`);
* ``lock_joint``: the joint's range is fixed at the angle (lower = upper bound);
* ``range_of_motion``: bounds on the joint angle (hard limits, not stiff stops);
* ``passive``: a linear spring-damper on the joint (an orthosis) in the dynamics.

:func:`predict` is the checked prediction (the staged solve of
:mod:`predgait.problems.predictive_solve`, Pinocchio residuals at every node, gait measures
and the engine re-simulation with TVLQR of :mod:`predgait.simulations.gait7_predicted`);
the unedited one is the baseline.

One edited leg breaks the left/right symmetry, so both predictions are then full cycles
(twice the nodes), the unedited one started from its mirrored half cycle; with
``side = "both"`` they are half cycles.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from predgait.analysis.plausibility import FEEDFORWARD_SOURCE, at_most, grf_check
from predgait.kinematics.clinical import clinical_joint
from predgait.models.anthropometry import leg_from_subject
from predgait.models.gait7 import build_gait7_urdf
from predgait.models.loading import GRAVITY, Model, model_from_urdf
from predgait.problems.predictive import (
    Cycle,
    Guess,
    PassiveSpring,
    PredictedGait,
    Start,
    problem_for,
)
from predgait.problems.predictive_check import STANCE_THRESHOLD_N
from predgait.problems.predictive_solve import (
    PredictSpec,
    check_solved,
    default_bounds,
    measured_for,
    solve_with_restarts,
    staged_guess,
)
from predgait.scenarios.edits import (
    LockJoint,
    PassiveEdit,
    RangeOfMotion,
    apply_segment_edits,
)

SIDE_SUFFIX = {"right": ("r",), "left": ("l",), "both": ("r", "l")}
ANGLES = ("hip", "knee", "ankle")


@dataclass(frozen=True, eq=False)
class Prediction:
    """A solved cycle with its measured counterpart and its checks (:func:`predict`)."""

    gait: PredictedGait
    measured: object          # MeasuredCycle
    residuals: dict
    stride: dict
    measures: dict
    resimulation: object | None
    springs: tuple
    stages: tuple = ()        # (what, Solved) of the stages before the final solve
    aligned: dict | None = None   # the stride from the right heel strike (from_heel_strike)


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
    from predgait.dynamics.gait7_motion import gait7_model
    from predgait.problems.predictive_check import (
        from_heel_strike,
        full_stride,
        gait_measures,
        node_residuals,
        passive_joints,
        step_lengths,
    )

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
        guess, stages, resampled = staged_guess(spec, model, kw)
        if start is None and resampled:
            start = Start.RESAMPLED
    if start is None:
        start = Start.MEASURED if guess is None else Start.SOLUTION
    gait = solve_with_restarts(problem, guess or measured.guess, measured.reference,
                               spec.weights, kw, start=start,
                               what=f"predictive on {spec.nodes} intervals", failed=stages)
    check_solved(gait, "solve")
    residuals = node_residuals(model, gait, spec.contact, spec.ground_z, springs)
    stride = full_stride(model, gait)
    rerun = None
    if spec.resimulate if resimulate is None else resimulate:
        from predgait.simulations.gait7_predicted import resimulate as run_engine

        rerun = run_engine(model, stride, spec.contact, spec.ground_z, passive_joints(springs))
    aligned = from_heel_strike(model, stride)
    measures = gait_measures(stride, speed, model.total_mass() * model.gravity,
                             step_lengths(aligned))
    return Prediction(gait, measured, residuals, stride, measures, rerun, tuple(springs),
                      tuple(stages), aligned)


@dataclass(frozen=True, eq=False)
class PredictedScenario:
    """Unedited and edited predictions, their models and the comparison."""

    spec: object                 # ScenarioSpec
    baseline: Prediction
    edited: Prediction
    model: Model
    edited_model: Model
    metrics: dict


def edited_gait7(spec: PredictSpec, edits, sides) -> Model:
    """gait7 with the segment edits applied to the legs of ``sides`` ("r"/"l")."""
    leg = apply_segment_edits(leg_from_subject(spec.mass, spec.height), edits)
    urdf = build_gait7_urdf(spec.mass, spec.height, {s: leg for s in sides})
    return model_from_urdf(urdf, source=f"gait7 for {spec.mass:g} kg, {spec.height:g} m "
                                        f"+ edits on {'/'.join(sides)}")


def joint_constraints(model: Model, edits, sides) -> tuple[dict, tuple[PassiveSpring, ...]]:
    """Bounds (coordinate -> (lower, upper) rad) and springs of the joint edits."""
    bounds, springs = default_bounds(), []
    for edit in edits:
        for s in sides:
            if not isinstance(edit, LockJoint | RangeOfMotion | PassiveEdit):
                continue
            name = f"{edit.joint}_{s}"
            joint = clinical_joint(model, name)
            if isinstance(edit, LockJoint):
                bounds[name] = (joint.clinical(edit.angle), joint.clinical(edit.angle))
            elif isinstance(edit, RangeOfMotion):
                bounds[name] = tuple(sorted((joint.clinical(edit.lower),
                                             joint.clinical(edit.upper))))
            else:
                springs.append(PassiveSpring(name, edit.k, edit.c, edit.theta0))
    return bounds, tuple(springs)


def baseline_prediction(spec: PredictSpec, cycle: Cycle) -> Prediction:
    """The unedited prediction as a ``cycle`` (a full one from the mirrored half)."""
    half = predict(replace(spec, cycle=Cycle.HALF, resimulate=spec.resimulate
                           and cycle is Cycle.HALF))
    if cycle is Cycle.HALF:
        return half
    st = half.stride
    return predict(replace(spec, cycle=Cycle.FULL, nodes=2 * spec.nodes),
                   guess=Guess(st["q"], st["v"], st["a"]))


def edited_prediction(spec: PredictSpec, model: Model, bounds, springs,
                      baseline: Prediction) -> Prediction:
    """The edited model's prediction from the unedited gait.

    Started as from a solution, with Ipopt's adaptive barrier (a null edit then stays at
    the unedited optimum); if that fails, ``predict`` restarts with the other barriers
    (a right-ankle orthosis on a full cycle: adaptive ran out of 1000 iterations, monotone
    from mu = 0.1 converged in 260). See :class:`Start` and ``RESTARTS``.

    Raises:
        SolveFailed: Every start failed (the last attempt's status and violation).
    """
    g = baseline.gait
    return predict(spec, model, bounds=bounds, springs=springs, guess=Guess(g.q, g.v, g.a),
                   start=Start.SOLUTION)


def run_predicted_scenario(scenario, spec: PredictSpec) -> PredictedScenario:
    """Predict the unedited and the edited gait of ``scenario`` (a ScenarioSpec).

    Raises:
        SolveFailed: Ipopt did not converge on either (status and violation).
    """
    from predgait.problems.ipopt_progress import stage

    sides = SIDE_SUFFIX[scenario.side]
    cycle = Cycle.HALF if len(sides) == 2 else Cycle.FULL
    stage(f"scenario '{scenario.name}', part 1/2: the unedited 7-link model's gait")
    baseline = baseline_prediction(spec, cycle)
    model = edited_gait7(spec, (), ())
    edited_model = edited_gait7(spec, scenario.edits, sides)
    bounds, springs = joint_constraints(edited_model, scenario.edits, sides)
    full = replace(spec, cycle=cycle, nodes=spec.nodes * (1 if cycle is Cycle.HALF else 2))
    stage(f"scenario '{scenario.name}', part 2/2: the edited model's gait")
    edited = edited_prediction(full, edited_model, bounds, springs, baseline)
    return PredictedScenario(scenario, baseline, edited, model, edited_model,
                             predicted_metrics(model, baseline, edited, sides))


def predict_checks(spec: PredictSpec, prediction: Prediction) -> list:
    """Plausibility (:mod:`predgait.analysis.plausibility`) of a predicted gait.

    Peak vertical GRF of either foot (BW); the re-simulation's TVLQR feedback against its
    feedforward (RMS, N m).
    """
    m = prediction.measures
    weight = spec.mass * GRAVITY
    checks = [grf_check(max(m[s]["peak_fz_n"] for s in ("right", "left")) / weight)]
    rs = prediction.resimulation
    if rs is not None:
        r = rs.summary()
        checks.append(at_most("RMS re-simulation feedback torque", r["feedback_rms_n_m"],
                              r["feedforward_rms_n_m"], unit="N m",
                              source=FEEDFORWARD_SOURCE))
    return checks


def predicted_scenario_checks(result: PredictedScenario) -> list:
    """:func:`predict_checks` of the edited and the unedited gait, each name saying which."""
    spec = result.spec.predict
    return [replace(c, name=f"{which} gait: {c.name}")
            for which, gait in (("edited", result.edited), ("unedited", result.baseline))
            for c in predict_checks(spec, gait)]


def _swing_hip_torque(model: Model, prediction: Prediction, s: str) -> float:
    """RMS hip torque (N m) of side ``s`` while its foot is off the ground."""
    st = prediction.stride
    foot = {"r": slice(0, 2), "l": slice(2, 4)}[s]
    swing = st["contact"][:, foot, 1].sum(axis=1) < STANCE_THRESHOLD_N
    column = ["hip_l", "knee_l", "ankle_l", "hip_r", "knee_r", "ankle_r"].index(f"hip_{s}")
    return float(np.sqrt(np.mean(st["tau"][swing, column] ** 2))) if swing.any() else 0.0


def percent_of_stride(aligned: dict, column: int) -> np.ndarray:
    """One coordinate of a stride from heel strike on 0, 1, ..., 100 % of the stride."""
    t = aligned["t"]
    return np.interp(np.linspace(0.0, t[-1], 101), t, aligned["q"][:, column])


def predicted_metrics(model: Model, base: Prediction, edited: Prediction, sides) -> dict:
    """Angles, torques, GRF, effort and their changes from the unedited prediction.

    Angle changes compare the two gaits at the same % of the stride, each from its own
    right heel strike (``Prediction.aligned``), not at the same solver time.
    """
    b, e = base.aligned, edited.aligned
    out = {"status": "solved", "edited_sides": list(sides),
           "effort": edited.gait.terms["effort"],
           "baseline_effort": base.gait.terms["effort"],
           "effort_change_percent": 100 * (edited.gait.terms["effort"]
                                           / base.gait.terms["effort"] - 1),
           "step_length_m": edited.measures["step_length_m"],
           "step_length_right_m": edited.measures["right"]["step_length_m"],
           "step_length_left_m": edited.measures["left"]["step_length_m"],
           "cadence_steps_min": edited.measures["cadence_steps_min"],
           "speed_m_s": edited.measures["speed_m_s"]}
    for s in ("r", "l"):
        side = {"r": "right", "l": "left"}[s]
        for joint in ANGLES:
            name = f"{joint}_{s}"
            i, joint_sign = model.coordinate_index(name), clinical_joint(model, name)
            angle_e = np.degrees(joint_sign.clinical(percent_of_stride(e, i)))
            angle_b = np.degrees(joint_sign.clinical(percent_of_stride(b, i)))
            out[f"{name}_range_deg"] = float(angle_e.max() - angle_e.min())
            out[f"{name}_baseline_range_deg"] = float(angle_b.max() - angle_b.min())
            out[f"{name}_rms_change_deg"] = float(np.sqrt(np.mean((angle_e - angle_b) ** 2)))
        out[f"swing_hip_torque_rms_{s}_n_m"] = _swing_hip_torque(model, edited, s)
        out[f"baseline_swing_hip_torque_rms_{s}_n_m"] = _swing_hip_torque(model, base, s)
        out[f"stance_fraction_{s}"] = edited.measures[side]["stance_fraction"]
        out[f"peak_vertical_grf_{s}_n"] = edited.measures[side]["peak_fz_n"]
        out[f"baseline_peak_vertical_grf_{s}_n"] = base.measures[side]["peak_fz_n"]
    if edited.resimulation is not None:
        out["resimulation_max_deviation_deg"] = edited.resimulation.max_angle_deviation_deg
        out["resimulation_feedback_rms_n_m"] = edited.resimulation.feedback_rms_n_m
    return out
