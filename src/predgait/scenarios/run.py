"""A what-if scenario: edit the leg, re-simulate the measured gait, compare with baseline.

The baseline is the measured trial's leg driven forward by its inverse-dynamics torques
(``torques = "measured"``) or by the torques after predgait's torque correction
(``"corrected"``), the hip load and the prescribed foot motion, with PD feedback toward
the measured motion standing in for the subject's control (thesis 4.2 future work); the
gains are the scenario file's (``gains = "fixed"``) or fitted on the measured trial
(``"fitted"``, as ``predgait solve feedback_gains``). With ``reoptimize = true`` the
edited leg's torques are corrected again toward the measured motion (segment edits only),
so the metrics then tell the change in joint moments the edit demands. The scenario keeps
that same drive and control and changes the body: segment edits regenerate the URDF,
joint edits change passive elements, ranges of motion or lock a joint. What changes is
the prediction: joint angles, ground reaction, time to fall, and the feedback torque the
subject would need to keep walking the same way (a measure of the extra effort).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forces import JointFeedback
from predgait.dynamics.forward import FallLimit, SimulationResult, simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method, Status
from predgait.dynamics.inverse_options import bundled_source
from predgait.dynamics.inverse_trial import InverseResult, bundled_inverse
from predgait.dynamics.passive import ExponentialLimits, LinearSpringDamper, PassiveJoint
from predgait.errors import InputError, SimulationDiverged
from predgait.kinematics.clinical import leg_clinical
from predgait.models.loading import GRAVITY, model_from_urdf
from predgait.models.urdf import leg_urdf
from predgait.problemfile import Table, load_problem
from predgait.scenarios.edits import (
    LockJoint,
    PassiveEdit,
    RangeOfMotion,
    apply_segment_edits,
    parse_edit,
)

#: Stiffness of the range-of-motion stops of a restricted joint (exponential form of
#: predgait.dynamics.passive.ExponentialLimits), N m and 1/rad.
ROM_STIFFNESS = (2.0, 30.0)
#: A shank or thigh pitch past this (deg from vertical) counts as a fall; in normal swing
#: the shank reaches about 60 deg behind the vertical, so the thesis-style 60 deg is too tight.
FALL_ANGLE_DEG = 90.0
#: Collocation intervals of the torque correction / gain fit a scenario may run.
FIT_INTERVALS = 100


class Torques(enum.Enum):
    """Which joint torques drive baseline and edited leg."""

    MEASURED = "measured"      # inverse-dynamics moments
    CORRECTED = "corrected"    # after predgait's torque correction over the window


class Gains(enum.Enum):
    """Where the PD gains of the stand-in control come from."""

    FIXED = "fixed"            # kp, kd of the scenario file
    FITTED = "fitted"          # fitted on the measured trial (predgait solve feedback_gains)


@dataclass(frozen=True)
class ScenarioSpec:
    """A scenario file, parsed (see problems/scenario_*.toml)."""

    name: str
    source: Path
    side: str
    window: tuple[float, float]
    kp: float
    kd: float
    options: IntegratorOptions
    edits: tuple
    torques: Torques = Torques.MEASURED
    gains: Gains = Gains.FIXED
    reoptimize: bool = False
    predicts: bool = False     # solve the predictive gait7 problem instead (scenarios/predict)
    predict: object = None     # its PredictSpec ([predict] table as predict_gait7.toml)


@dataclass(frozen=True)
class ScenarioResult:
    """Baseline and edited simulations with the comparison metrics."""

    spec: ScenarioSpec
    baseline: SimulationResult
    edited: SimulationResult
    metrics: dict
    feedback_baseline: np.ndarray
    feedback_edited: np.ndarray
    edited_urdf: str


def parse_scenario(table: Table) -> ScenarioSpec:
    """ScenarioSpec from a TOML table (errors name file, key and line)."""
    table.check_keys(("name", "trial", "side", "window", "control", "integrator", "edit",
                      "predicts", "predict"))
    bundled_source(table, "trial")
    predicts = table.get("predicts", bool, False)
    side = table.get("side", str, "right")
    sides = ("right", "left", "both") if predicts else ("right", "left")
    if side not in sides:
        raise table.error("side", f"'{side}' is not one of: {', '.join(sides)}.")
    predict = None
    if predicts:
        from predgait.problems.predictive_solve import parse_predict

        predict = parse_predict(table.table("predict"))
    elif table.has("predict"):
        raise table.error("predict", "a [predict] table needs predicts = true.")
    window = table.numbers("window", [0.0, 1.0], length=2, low=-5.0, high=30.0, unit="s")
    if not window[0] < window[1]:
        raise table.error("window", "give [start, end] in s from heel strike, start < end.")
    control = table.table("control")
    control.check_keys(("kp", "kd", "torques", "gains", "reoptimize"))
    options = IntegratorOptions.from_table(
        table.table("integrator"), keys=("method", "step"),
        default=IntegratorOptions(method=Method.RK4, step=2e-3))
    edits = []
    for edit in table.tables("edit"):
        edits.append(parse_edit(edit))
    return ScenarioSpec(
        name=table.get("name", str, table.path.stem), source=table.path, side=side,
        window=(float(window[0]), float(window[1])),
        kp=control.number("kp", 300.0, low=0, high=1e4, unit="N m/rad"),
        kd=control.number("kd", 30.0, low=0, high=1e3, unit="N m s/rad"),
        options=options, edits=tuple(edits),
        torques=control.choice("torques", Torques, "measured"),
        gains=control.choice("gains", Gains, "fixed"),
        reoptimize=control.get("reoptimize", bool, False), predicts=predicts,
        predict=predict)


def load_scenario(path: str | Path, overrides=()) -> ScenarioSpec:
    """Read and parse a scenario file with ``--set`` overrides."""
    table = load_problem(path, overrides)
    table.expect_command("scenario")
    return parse_scenario(table)


def _passive_for(edits) -> dict[str, PassiveJoint]:
    elements: dict[str, list] = {}
    for edit in edits:
        if isinstance(edit, PassiveEdit):
            elements.setdefault(edit.joint, []).append(
                LinearSpringDamper(edit.k, edit.c, edit.theta0))
        elif isinstance(edit, RangeOfMotion):
            k, b = ROM_STIFFNESS
            elements.setdefault(edit.joint, []).append(
                ExponentialLimits(lower=edit.lower, upper=edit.upper, k_lower=k, b_lower=b,
                                  k_upper=k, b_upper=b))
    return {joint: PassiveJoint(tuple(items)) for joint, items in elements.items()}


def _locked(drivers: LegDrivers, model, locks) -> tuple[LegDrivers, tuple[str, ...]]:
    """Drivers whose reference holds each locked joint still; the remaining free joints."""
    if not locks:
        return drivers, ("ankle", "knee")
    index = {lock.joint: model.coordinate_index(lock.joint) for lock in locks}
    value = {lock.joint: leg_clinical(lock.joint, lock.angle) for lock in locks}

    def hold(function, zero: bool):
        def held(t):
            out = np.array(function(t), dtype=float)
            for joint, i in index.items():
                out[i] = 0.0 if zero else value[joint]
            return out
        return held

    free = tuple(j for j in ("ankle", "knee") if j not in index)
    if not free:
        raise InputError("both ankle and knee are locked: nothing is left to simulate.")
    return replace(drivers, reference_q=hold(drivers.reference_q, False),
                   reference_qd=hold(drivers.reference_qd, True),
                   reference_qdd=hold(drivers.reference_qdd, True)), free


def _simulate(model, drivers, spec: ScenarioSpec, passive, free, gains) -> SimulationResult:
    free_index = [model.coordinate_index(j) for j in free]
    joint = [i - 3 for i in free_index]
    feedback = JointFeedback(np.array(free_index), drivers.reference, gains[0][joint],
                             gains[1][joint])
    x0 = np.concatenate([drivers.reference_q(spec.window[0])[free_index],
                         drivers.reference_qd(spec.window[0])[free_index]])
    try:
        return simulate_leg(model, drivers.with_passive(passive), spec.window, x0,
                            feedback=feedback,
                            options=spec.options, free=free,
                            fall=FallLimit(segment_angle_deg=FALL_ANGLE_DEG))
    except SimulationDiverged as exc:
        return exc.partial


def _feedback_torque(result: SimulationResult, drivers: LegDrivers, gains) -> np.ndarray:
    """PD torque (n, 2) N m (ankle, knee; model sign) along a simulated motion."""
    ref_q = np.array([drivers.reference_q(t) for t in result.t])
    ref_qd = np.array([drivers.reference_qd(t) for t in result.t])
    return gains[0] * (ref_q[:, 3:] - result.q[:, 3:]) + gains[1] * (ref_qd[:, 3:]
                                                                    - result.v[:, 3:])


def _drive_and_gains(spec: ScenarioSpec, inverse: InverseResult, drivers: LegDrivers):
    """Drivers (measured or corrected torques) and PD gains (fixed or fitted), arrays (2,)."""
    gains = (np.full(2, spec.kp), np.full(2, spec.kd))
    if spec.torques is Torques.MEASURED and spec.gains is Gains.FIXED:
        return drivers, gains
    from predgait.problems.collocation import NodeData
    from predgait.problems.fitting import correct_torques, fit_feedback

    nodes = NodeData.from_drivers(drivers, *spec.window, FIT_INTERVALS)
    if spec.gains is Gains.FITTED:
        p = fit_feedback(inverse.model, nodes).parameters
        gains = (np.array([p["kp_ankle"], p["kp_knee"]]), np.array([p["kd_ankle"], p["kd_knee"]]))
    if spec.torques is Torques.CORRECTED:
        fit = correct_torques(inverse.model, nodes)
        drivers = drivers.with_torque_change(fit.t, fit.torque_change)
    return drivers, gains


def _diverged(base: SimulationResult, edit: SimulationResult) -> dict | None:
    """Metrics of a scenario whose baseline or edited run diverged: status and time only."""
    for run, which in ((edit, "edited leg"), (base, "baseline")):
        if run.status is Status.DIVERGED:
            return {"status": f"diverged at t = {run.t[-1]:.3f} s ({which})",
                    "simulated_s": float(run.t[-1] - run.t[0]),
                    "time_to_fall_s": None, "baseline_time_to_fall_s": None,
                    "message": run.message}
    return None


def _metrics(base: SimulationResult, edit: SimulationResult, fb_base, fb_edit, drivers) -> dict:
    diverged = _diverged(base, edit)
    if diverged is not None:  # a diverged run is no result: no metric values
        return diverged
    n = min(len(base.t), len(edit.t))
    diff = np.degrees(edit.q[:n, 3:] - base.q[:n, 3:])
    tau = np.array([drivers.joint_torque(t) for t in edit.t])
    metrics = {"status": edit.status, "simulated_s": float(edit.t[-1] - edit.t[0]),
               "time_to_fall_s": edit.time_to_fall, "baseline_time_to_fall_s": base.time_to_fall}
    for i, joint in enumerate(("ankle", "knee")):
        metrics[f"{joint}_rms_change_deg"] = float(np.sqrt(np.mean(diff[:, i] ** 2)))
        metrics[f"{joint}_max_change_deg"] = float(np.abs(diff[:, i]).max())
        peak = np.degrees(leg_clinical(joint, edit.q[:, 3 + i])).max()
        metrics[f"{joint}_peak_angle_deg"] = float(peak)
        metrics[f"{joint}_feedback_rms_n_m"] = float(np.sqrt(np.mean(fb_edit[:, i] ** 2)))
        metrics[f"{joint}_extra_feedback_rms_n_m"] = float(
            np.sqrt(np.mean((fb_edit[:n, i] - fb_base[:n, i]) ** 2)))
        power = (tau[:, i] + fb_edit[:, i]) * edit.v[:, 3 + i]
        metrics[f"{joint}_active_work_j"] = float(np.trapezoid(power, edit.t))
    # Peaks for the plausibility checks (a dict: a sweep's results.csv keeps numbers only).
    joints = ("ankle", "knee")
    metrics["peaks"] = {
        "feedback_n_m": {j: float(np.abs(fb_edit[:, i]).max()) for i, j in enumerate(joints)},
        "measured_drive_n_m": {j: float(np.abs(tau[:, i]).max()) for i, j in enumerate(joints)},
        "drive_plus_feedback_n_m": {j: float(np.abs(tau[:, i] + fb_edit[:, i]).max())
                                    for i, j in enumerate(joints)}}
    if edit.grf is not None:
        metrics["peak_vertical_grf_n"] = float(edit.grf[:, 2].max())
        metrics["baseline_peak_vertical_grf_n"] = float(base.grf[:, 2].max())
    return metrics


def _reoptimized(spec: ScenarioSpec, model, drivers: LegDrivers, locks) -> LegDrivers:
    """Torque correction on the edited leg toward the measured motion (the new target)."""
    if locks:
        raise InputError(f"{spec.source}: reoptimize works with both joints free; drop "
                         "reoptimize or the lock_joint edit.")
    if _passive_for(spec.edits):
        raise InputError(f"{spec.source}: reoptimize does not yet include passive-element "
                         "edits; drop reoptimize or those edits.")
    from predgait.problems.collocation import NodeData
    from predgait.problems.fitting import correct_torques

    nodes = NodeData.from_drivers(drivers, *spec.window, FIT_INTERVALS)
    fit = correct_torques(model, nodes)
    return drivers.with_torque_change(fit.t, fit.torque_change)


def run_scenario(spec: ScenarioSpec, *, inverse: InverseResult | None = None) -> ScenarioResult:
    """Simulate baseline and edited leg over the window; compare."""
    inverse = inverse or bundled_inverse(spec.side)
    if inverse.leg is None:
        raise InputError("scenarios need a leg built from anthropometry (not a URDF file).")
    lo, hi = inverse.time[0], inverse.time[-1]
    if spec.window[0] < lo or spec.window[1] > hi:
        raise InputError(f"{spec.source}: window {spec.window} s is outside the trial "
                         f"{lo:.3f}..{hi:.3f} s (time from heel strike).")
    drivers, gains = _drive_and_gains(spec, inverse, LegDrivers.from_inverse(inverse))
    baseline = _simulate(inverse.model, drivers, spec, {}, ("ankle", "knee"), gains)
    params = apply_segment_edits(inverse.leg, spec.edits)
    model = model_from_urdf(leg_urdf(params), source=f"{inverse.model.source} + {spec.name}")
    locks = [e for e in spec.edits if isinstance(e, LockJoint)]
    edited_drivers, free = _locked(drivers, model, locks)
    if spec.reoptimize:
        edited_drivers = _reoptimized(spec, model, edited_drivers, locks)
    edited = _simulate(model, edited_drivers, spec, _passive_for(spec.edits), free, gains)
    fb_base = _feedback_torque(baseline, drivers, gains)
    fb_edit = _feedback_torque(edited, edited_drivers, gains)
    metrics = _metrics(baseline, edited, fb_base, fb_edit, drivers)
    metrics.update({"kp_ankle": float(gains[0][0]), "kp_knee": float(gains[0][1]),
                    "kd_ankle": float(gains[1][0]), "kd_knee": float(gains[1][1])})
    if "peaks" in metrics:
        metrics["peaks"]["body_mass_kg"] = float(inverse.body_mass)
    return ScenarioResult(spec, baseline, edited, metrics, fb_base, fb_edit, model.urdf)


def scenario_checks(metrics: dict) -> list:
    """Plausibility of a leg scenario (:mod:`predgait.analysis.plausibility`).

    Per joint: the peak |feedback torque| against the peak |measured drive|, the peak
    |drive + feedback| (N m/kg) against walking's joint moments; the peak vertical
    ground reaction (BW). None for a diverged run (it has no metrics).
    """
    from predgait.analysis.plausibility import feedback_checks, grf_check, joint_moment_checks

    peaks = metrics.get("peaks")
    if peaks is None:
        return []
    mass = peaks["body_mass_kg"]
    checks = feedback_checks(peaks["feedback_n_m"], peaks["measured_drive_n_m"])
    checks += joint_moment_checks({f"{j} moment (drive + feedback)": v / mass
                                   for j, v in peaks["drive_plus_feedback_n_m"].items()})
    if "peak_vertical_grf_n" in metrics:
        checks.append(grf_check(metrics["peak_vertical_grf_n"] / (mass * GRAVITY)))
    return checks


def scenario_metrics(path: str | Path, point):
    """Sweep task: the metrics of a scenario file with a sweep point's overrides.

    Returns a :class:`~predgait.scenarios.sweep.PointResult`: the numeric metrics and the
    plausibility checks ``predgait scenario`` records for the same run.
    """
    from predgait.scenarios.sweep import PointResult

    spec = load_scenario(path, point.overrides)
    if spec.predicts:
        from predgait.scenarios.predict import predicted_scenario_checks, run_predicted_scenario

        result = run_predicted_scenario(spec, spec.predict)
        return PointResult({k: v for k, v in result.metrics.items()
                            if isinstance(v, int | float)},
                           tuple(predicted_scenario_checks(result)))
    metrics = run_scenario(spec).metrics
    if metrics["status"].startswith("diverged"):
        raise SimulationDiverged(metrics["status"])
    return PointResult({k: (np.nan if v is None else v) for k, v in metrics.items()
                        if isinstance(v, int | float) or v is None},
                       tuple(scenario_checks(metrics)))
