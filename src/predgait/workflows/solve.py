"""``predgait solve``: problem file -> spec -> collocation solve -> Pinocchio re-simulation.

Every result is checked outside the optimiser: the fitted passive knee, the corrected
torques or the fitted gains drive the numeric forward simulation
(:func:`predgait.dynamics.forward.simulate_leg`, Pinocchio) from the measured initial
state, and its deviation from the measured motion is reported next to the optimiser's
own tracking error, with the uncorrected moments as the baseline. The driven leg is
unstable (thesis 4.2), so an open-loop re-simulation drifts in the end; the time until it
deviates by more than ``threshold_deg`` is the figure of merit.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from predgait.analysis.deviation import deviation
from predgait.analysis.plausibility import feedback_checks, record
from predgait.data import write_storage
from predgait.data.events import Side
from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forces import JointFeedback
from predgait.dynamics.forward import FallLimit, simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.inverse_trial import InverseResult
from predgait.dynamics.passive import LinearSpringDamper, PassiveJoint
from predgait.errors import SimulationDiverged
from predgait.kinematics.clinical import LEG_FREE_JOINTS, clinical_joint
from predgait.problemfile import Table
from predgait.problems.collocation import NodeData, Transcription
from predgait.problems.fitting import FitResult, correct_torques, fit_feedback, fit_knee
from predgait.report.diagnostics import save_diagnostics
from predgait.report.figures import plots_wanted
from predgait.report.tidy import write_summary
from predgait.textfile import source_name
from predgait.workflows.output import staged_output
from predgait.workflows.trials import LegTrial, leg_trial


class Kind(enum.Enum):
    """The problems ``predgait solve`` knows."""

    KNEE_FIT = "knee_fit"
    TORQUE_CORRECTION = "torque_correction"
    FEEDBACK_GAINS = "feedback_gains"
    #: Handled by :mod:`predgait.workflows.decomposition` (no collocation).
    PASSIVE_DECOMPOSITION = "passive_decomposition"


@dataclass(frozen=True)
class SolveSpec:
    """A parsed problem file (see problems/knee_fit.toml and siblings)."""

    kind: Kind
    source: Path
    inverse_problem: Path | None
    side: Side
    window: tuple[float, float]
    nodes: int
    transcription: Transcription
    weights: dict
    threshold_deg: float
    perturbation_deg: float
    max_iter: int
    check_step: float = 2.5e-4
    trial: LegTrial | None = None


WEIGHT_KEYS = {Kind.KNEE_FIT: (), Kind.TORQUE_CORRECTION: ("tracking", "effort", "smoothness"),
               Kind.FEEDBACK_GAINS: ("regularization",)}


def parse_solve(table: Table) -> SolveSpec:
    """SolveSpec from a problem file (errors name the file, key and line)."""
    table.check_keys(("kind", "trial", "window", "nodes", "transcription", "weights", "check",
                      "solver"))
    kind = table.choice("kind", Kind)
    trial = leg_trial(table.table("trial"))
    window = table.get("window", list, [0.0, 1.0])
    if len(window) != 2 or not all(isinstance(v, int | float) for v in window) \
            or window[0] >= window[1]:
        raise table.error("window", "give [start, end] in s from heel strike, start < end.")
    weights = table.table("weights")
    weights.check_keys(WEIGHT_KEYS[kind])
    check = table.table("check")
    check.check_keys(("threshold_deg", "perturbation_deg", "step"))
    solver = table.table("solver")
    solver.check_keys(("max_iter",))
    return SolveSpec(
        kind=kind, source=table.path, inverse_problem=trial.inverse_problem, side=trial.side,
        window=(float(window[0]), float(window[1])),
        nodes=int(table.number("nodes", 100, low=10, high=2000)),
        transcription=table.choice("transcription", Transcription,
                                   Transcription.HERMITE_SIMPSON),
        weights={k: weights.number(k, low=0.0) for k in weights.data},
        threshold_deg=check.number("threshold_deg", 2.0, low=0.1, high=45, unit="deg"),
        perturbation_deg=check.number("perturbation_deg", 3.0, low=0.0, high=30, unit="deg"),
        max_iter=int(solver.number("max_iter", 300, low=1, high=10000)),
        check_step=check.number("step", 2.5e-4, low=1e-5, high=5e-3, unit="s"), trial=trial)


def _inverse(spec: SolveSpec) -> InverseResult:
    return (spec.trial or LegTrial(spec.side, spec.inverse_problem)).inverse()


def solve_problem(spec: SolveSpec, inverse: InverseResult, drivers: LegDrivers) -> FitResult:
    """Build and solve the problem of ``spec`` (raises SolveFailed when Ipopt fails)."""
    nodes = NodeData.from_drivers(drivers, *spec.window,
                                  spec.transcription.grid_intervals(spec.nodes))
    w = spec.weights
    common = {"max_iter": spec.max_iter, "transcription": spec.transcription}
    if spec.kind is Kind.KNEE_FIT:
        return fit_knee(inverse.model, nodes, **common)
    if spec.kind is Kind.TORQUE_CORRECTION:
        return correct_torques(inverse.model, nodes, tracking_weight=w.get("tracking", 1e4),
                               effort_weight=w.get("effort", 1.0),
                               smooth_weight=w.get("smoothness", 10.0), **common)
    return fit_feedback(inverse.model, nodes, perturbation_deg=spec.perturbation_deg,
                        regularization=w.get("regularization", 1e-10), **common)


def resimulate(inverse, drivers, window, *, step: float, threshold_deg: float, passive=None,
               feedback=None, x0=None):
    """Pinocchio re-simulation (RK4) over ``window`` and its deviation from the measured.

    Args:
        inverse: The trial's InverseResult (the measured motion).
        drivers: LegDrivers of the run; ``passive`` elements are ADDED to them.
        window: (t0, t1) s.
        step: RK4 step, s.
        threshold_deg: Deviation reported as first crossed.
        passive: Optional joint -> PassiveJoint added to the drive.
        feedback: Optional JointFeedback.
        x0: Optional initial free state (default: the measured one).

    Returns:
        (simulation, report dict: status, end, time to the threshold, time from which it
        stays within it, largest deviation, RMS per coordinate in deg).
    """
    options = IntegratorOptions(method=Method.RK4, step=step)
    if passive is not None:
        drivers = drivers.with_passive(passive)
    try:
        sim = simulate_leg(inverse.model, drivers, window, x0,
                           feedback=feedback, options=options,
                           fall=FallLimit(segment_angle_deg=90.0))
    except SimulationDiverged as exc:
        sim = exc.partial
    dev = deviation(sim, inverse.time, inverse.q, threshold_deg=threshold_deg)
    outside = np.flatnonzero(np.degrees(np.abs(dev.error)).max(axis=1) > threshold_deg)
    within_after = None if sim.t[-1] < window[1] - 1e-9 else (
        float(dev.t[0]) if outside.size == 0 else
        float(dev.t[outside[-1] + 1]) if outside[-1] + 1 < dev.t.size else None)
    return sim, {"status": sim.status, "end_s": float(sim.t[-1]),
                 "time_to_threshold_s": dev.time_to_threshold,
                 "within_threshold_from_s": within_after,
                 "max_deviation_deg": float(np.degrees(np.abs(dev.error)).max()),
                 "rms_deg": {k: float(np.degrees(v)) for k, v in dev.rms.items()}}


def deviation_wording(result: dict, threshold_deg: float) -> str:
    """One phrase for a :func:`resimulate` report: when it leaves and re-enters the band.

    E.g. "stays within 2 deg for the whole window (to 1.230 s)", "leaves 2 deg at
    0.412 s, back within it from 0.950 s (end 1.230 s)", "leaves 2 deg at 0.412 s and is
    not back within it by the end (0.800 s)".
    """
    limit = f"{threshold_deg:g} deg"
    left, back, end = (result["time_to_threshold_s"], result["within_threshold_from_s"],
                       result["end_s"])
    if left is None:
        if back is None:   # stopped early (diverged or fell) without crossing the band
            status = getattr(result["status"], "value", result["status"])
            return f"stays within {limit} until the run stops at {end:.3f} s ({status})"
        return f"stays within {limit} for the whole window (to {end:.3f} s)"
    if back is None:
        return f"leaves {limit} at {left:.3f} s and is not back within it by the end ({end:.3f} s)"
    return f"leaves {limit} at {left:.3f} s, back within it from {back:.3f} s (end {end:.3f} s)"


def _resimulate(inverse, drivers, spec, *, passive=None, feedback=None, x0=None):
    return resimulate(inverse, drivers, spec.window, step=spec.check_step,
                      threshold_deg=spec.threshold_deg, passive=passive, feedback=feedback,
                      x0=x0)


def check_by_resimulation(spec: SolveSpec, inverse: InverseResult, drivers: LegDrivers,
                          fit: FitResult) -> tuple[dict, object]:
    """Re-simulate with Pinocchio: uncorrected baseline and the optimised inputs.

    Returns:
        (report, the re-simulation with the fitted inputs).
    """
    report, sims = resimulations(spec, inverse, drivers, fit)
    return report, sims["with_fit"]


def resimulations(spec: SolveSpec, inverse: InverseResult, drivers: LegDrivers,
                  fit: FitResult) -> tuple[dict, dict]:
    """Like :func:`check_by_resimulation`, with every re-simulation: (report, name -> sim)."""
    baseline_sim, baseline = _resimulate(inverse, drivers, spec)
    report, sims = {"baseline_uncorrected": baseline}, {"baseline_uncorrected": baseline_sim}
    p = fit.parameters
    if spec.kind is Kind.KNEE_FIT:
        passive = {"knee": PassiveJoint((LinearSpringDamper(p["k"], p["c"], p["theta0"]),))}
        sim, report["with_fit"] = _resimulate(inverse, drivers, spec, passive=passive)
    elif spec.kind is Kind.TORQUE_CORRECTION:
        corrected = drivers.with_torque_change(fit.t, fit.torque_change)
        sim, report["with_fit"] = _resimulate(inverse, corrected, spec)
    else:
        gains = JointFeedback(np.arange(3, 5), drivers.reference,
                              np.array([p["kp_ankle"], p["kp_knee"]]),
                              np.array([p["kd_ankle"], p["kd_knee"]]))
        sim, report["with_fit"] = _resimulate(inverse, drivers, spec, feedback=gains)
        x0 = np.concatenate([drivers.reference_q(spec.window[0])[3:],
                             drivers.reference_qd(spec.window[0])[3:]])
        x0[:2] += np.radians(spec.perturbation_deg) * np.array([1.0, -1.0])
        sims["with_fit_perturbed_start"], report["with_fit_perturbed_start"] = _resimulate(
            inverse, drivers, spec, feedback=gains, x0=x0)
    sims["with_fit"] = sim
    return report, sims


KNEE_FIT_MEANING = (
    "stabilising spring-damper added to the measured moments so that the synthesized "
    "motion stays near the measured one (thesis Fig. 4.2.9); not tissue properties: the "
    "measured moments already contain the knee's passive moment (for that, use kind "
    "passive_decomposition)")
#: Angle change per unit parameter (deg) beyond which open-loop intervals are formal only.
FORMAL_SENSITIVITY_DEG = 1e4


def _meaningful_intervals(spec: SolveSpec, fit: FitResult) -> dict:
    """95 % half-widths, or why one means nothing (knee fit on a bound or on instability)."""
    if spec.kind is not Kind.KNEE_FIT:
        return fit.confidence95
    sensitivity = fit.diagnostics.get("sensitivity_deg", {})
    out = {}
    for name, half in fit.confidence95.items():
        if name in ("k", "c") and fit.parameters[name] <= 1e-4:
            out[name] = f"not meaningful: {name} sits on its lower bound 0"
        elif sensitivity and max(sensitivity.values()) > FORMAL_SENSITIVITY_DEG:
            out[name] = (f"not meaningful: the angles change by up to "
                         f"{max(sensitivity.values()):.1e} deg per unit of a parameter (the "
                         "open-loop fit balances on the leg's instability)")
        else:
            out[name] = half
    return out


def solve_checks(spec: SolveSpec, fit: FitResult, drivers: LegDrivers, sim) -> list:
    """Plausibility of a leg fit (:mod:`predgait.analysis.plausibility`).

    What the fit adds to the measured drive (the torque correction, the fitted knee
    spring's moment, the fitted PD feedback along the re-simulation), peak per joint,
    against the measured peak moment.
    """
    measured = np.array([drivers.joint_torque(t) for t in sim.t])
    peak_measured = {j: float(np.abs(measured[:, i]).max())
                     for i, j in enumerate(LEG_FREE_JOINTS)}
    p = fit.parameters
    if spec.kind is Kind.TORQUE_CORRECTION:
        added, what = fit.torque_change, "torque correction"
    elif spec.kind is Kind.KNEE_FIT:
        knee = clinical_joint("leg", "knee")
        spring = LinearSpringDamper(p["k"], p["c"], p["theta0"])
        moment = spring.moment(knee.clinical(sim.q[:, 4]), knee.clinical(sim.v[:, 4]))
        added, what = np.column_stack([np.zeros_like(moment), moment]), "fitted spring moment"
    else:
        law = JointFeedback(np.arange(3, 5), drivers.reference,
                            np.array([p["kp_ankle"], p["kp_knee"]]),
                            np.array([p["kd_ankle"], p["kd_knee"]]))
        added = np.array([law.torque(t, q, v) for t, q, v in zip(sim.t, sim.q, sim.v,
                                                                 strict=True)])
        what = "feedback torque"
    peaks = {j: float(np.abs(added[:, i]).max()) for i, j in enumerate(LEG_FREE_JOINTS)
             if np.abs(added[:, i]).max() > 0}
    return feedback_checks(peaks, peak_measured, what=what)


def run_solve(spec: SolveSpec, out: Path, *, force: bool = False) -> dict:
    """Solve, check, and write solution.json, states.sto, corrected_moments.sto, plots."""
    inverse = _inverse(spec)
    drivers = LegDrivers.from_inverse(inverse)
    fit = solve_problem(spec, inverse, drivers)
    check, sims = resimulations(spec, inverse, drivers, fit)
    sim = sims["with_fit"]
    s = fit.solved
    solution = {
        "status": "solved" if s.success else s.status, "kind": spec.kind.value,
        "ipopt_status": s.status, "iterations": s.iterations, "solve_time_s": s.seconds,
        "objective": s.objective, "constraint_violation": s.constraint_violation,
        "parameters": fit.parameters, "confidence95": _meaningful_intervals(spec, fit),
        "ipopt_history": s.history,
        "optimiser_tracking_rms_deg": fit.rms_deg, "resimulation_check": check,
        "window_s": list(spec.window), "threshold_deg": spec.threshold_deg, "nodes": spec.nodes,
        "transcription": spec.transcription.value, "diagnostics": fit.diagnostics,
        "provenance": {"problem": source_name(spec.source), "model": inverse.model.source,
                       **inverse.provenance},
    }
    if spec.kind is Kind.KNEE_FIT:
        solution["what"] = KNEE_FIT_MEANING
    record(solution, solve_checks(spec, fit, drivers, sim))
    with staged_output(out, force=force,
                       inputs=[spec.source, spec.inverse_problem]) as stage:
        solution = write_summary(stage / "solution.json", solution)
        names = ("ankle", "knee", "ankle_speed", "knee_speed")
        write_storage(stage / "states.sto", fit.t, dict(zip(names, fit.x.T, strict=True)),
                      header={"units": "rad, rad/s (model coordinates)",
                              "what": "optimised (collocation) states"})
        write_storage(stage / "resimulated_states.sto", sim.t,
                      {n: sim.q[:, i] for i, n in enumerate(sim.coordinate_names)},
                      header={"units": "m, rad", "what": "Pinocchio re-simulation"})
        if fit.torque_change is not None:
            original = np.array([drivers.joint_torque(t) for t in fit.t])
            corrected = original + fit.torque_change
            clinical = {}
            for i, joint in enumerate(LEG_FREE_JOINTS):
                sign = clinical_joint("leg", joint)
                clinical[f"{sign.angle}_moment"] = sign.clinical(original[:, i])
                clinical[f"{sign.angle}_moment_corrected"] = sign.clinical(corrected[:, i])
            write_storage(stage / "corrected_moments.sto", fit.t, clinical,
                          header={"units": "N m (clinical sign)"})
        if plots_wanted():
            from predgait.report.solve_plots import save_solve_plots

            save_solve_plots(stage, inverse, fit, sim, drivers, threshold_deg=spec.threshold_deg,
                             time_to_threshold=check["with_fit"]["time_to_threshold_s"])
            labels = {"baseline_uncorrected": "re-simulated, uncorrected (before)",
                      "with_fit": "re-simulated, fitted (after)",
                      "with_fit_perturbed_start": "re-simulated, fitted, perturbed start"}
            save_diagnostics(stage, inverse.time, inverse.q, fit,
                             {labels[k]: v for k, v in sims.items()})
    return solution
