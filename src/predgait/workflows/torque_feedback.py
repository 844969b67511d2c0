"""``predgait solve`` kind ``torque_feedback``: torques plus time-varying LQR feedback.

The driven leg's stance has a +35..+39 /s unstable mode, so no open-loop torque history
holds the measured motion for a whole gait cycle (issue 19; the thesis' open-loop
correction, kind ``torque_correction``, stays as the comparison). This kind returns a
feedforward torque history (the inverse-dynamics moments, or those plus the open-loop
correction) and a stabilising feedback law around the measured motion: time-varying LQR
from the linearisation of the leg's free dynamics along it (:mod:`predgait.dynamics.lqr`).
The forward engine re-simulates the window with and without the feedback; the
feedforward correction and the feedback effort are reported against the
inverse-dynamics uncertainty (the moments recomputed with marker and force cut-offs of
``cutoffs_hz``, default 4-8 Hz).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from predgait.kinematics.clinical import LEG_FREE_JOINTS, clinical_joint
from predgait.problemfile import Table
from predgait.workflows.trials import LegTrial, leg_trial

JOINTS = LEG_FREE_JOINTS


class Feedforward(enum.Enum):
    """The torque history the feedback is added to."""

    INVERSE_DYNAMICS = "inverse_dynamics"
    CORRECTED = "corrected"     # plus the open-loop correction (kind torque_correction)


@dataclass(frozen=True)
class FeedbackSpec:
    """A parsed ``torque_feedback`` problem file (problems/torque_feedback.toml)."""

    source: Path
    trial: LegTrial
    window: tuple[float, float] | None      # None: the first gait cycle
    feedforward: Feedforward
    angle_deg: float
    rate_deg_s: float
    torque_n_m: float
    node_step: float
    horizon: float
    threshold_deg: float
    step: float
    cutoffs_hz: tuple[float, ...]
    correction_nodes: int


def parse_feedback(table: Table) -> FeedbackSpec:
    """FeedbackSpec from a problem file (errors name the file, key and line)."""
    table.check_keys(("kind", "trial", "window", "feedforward", "lqr", "check", "uncertainty",
                      "correction"))
    window = table.numbers("window", None, length=2)
    if window is not None and window[0] >= window[1]:
        raise table.error("window", "give [start, end] in s from heel strike, start < end "
                                    "(or leave it out for the first gait cycle).")
    lqr = table.table("lqr")
    lqr.check_keys(("angle_deg", "rate_deg_s", "torque_n_m", "node_step_s", "horizon_s"))
    check = table.table("check")
    check.check_keys(("threshold_deg", "step"))
    unc = table.table("uncertainty")
    unc.check_keys(("cutoffs_hz",))
    cutoffs = unc.numbers("cutoffs_hz", [4.0, 5.0, 6.0, 7.0, 8.0], low=0.5, high=50,
                          unit="Hz")
    if len(set(cutoffs)) < 2:
        raise unc.error("cutoffs_hz", "give at least two different cut-offs (Hz).")
    corr = table.table("correction")
    corr.check_keys(("nodes",))
    return FeedbackSpec(
        source=table.path, trial=leg_trial(table.table("trial")),
        window=None if window is None else (float(window[0]), float(window[1])),
        feedforward=table.choice("feedforward", Feedforward, Feedforward.INVERSE_DYNAMICS),
        angle_deg=lqr.number("angle_deg", 1.0, low=0.01, high=45, unit="deg"),
        rate_deg_s=lqr.number("rate_deg_s", 20.0, low=0.1, high=2000, unit="deg/s"),
        torque_n_m=lqr.number("torque_n_m", 10.0, low=0.01, high=1000, unit="N m"),
        node_step=lqr.number("node_step_s", 0.005, low=5e-4, high=0.05, unit="s"),
        horizon=lqr.number("horizon_s", 0.3, low=0.0, high=5.0, unit="s"),
        threshold_deg=check.number("threshold_deg", 2.0, low=0.1, high=45, unit="deg"),
        step=check.number("step", 2.5e-4, low=1e-5, high=5e-3, unit="s"),
        cutoffs_hz=tuple(float(c) for c in cutoffs),
        correction_nodes=int(corr.number("nodes", 100, low=10, high=2000)))


def _window(spec: FeedbackSpec, inverse) -> tuple[float, float]:
    from predgait.errors import InputError

    window = spec.window or inverse.first_cycle()
    if window is None:
        raise InputError(f"{spec.source}: the trial has no full gait cycle; give window = "
                         "[start, end] in s.")
    lo, hi = float(inverse.time[0]), float(inverse.time[-1])
    if window[0] < lo - 1e-9 or window[1] > hi + 1e-9:
        raise InputError(f"{spec.source}: window {window[0]:g}..{window[1]:g} s is outside "
                         f"the trial's {lo:g}..{hi:g} s; shorten it.")
    return float(window[0]), float(window[1])


def moment_band(spec: FeedbackSpec, inverse, times: np.ndarray) -> np.ndarray:
    """(len(cutoffs), m, 2) ankle and knee model torques at ``times`` for each cut-off."""
    from predgait.dynamics.inverse_trial import run_inverse

    options = spec.trial.options()
    out = []
    for cutoff in spec.cutoffs_hz:
        result = run_inverse(replace(options, cutoff=cutoff, grf_cutoff=cutoff))
        out.append(np.column_stack([np.interp(times, result.time, result.tau[:, 3 + j])
                                    for j in range(2)]))
    return np.array(out)


def _corrected(spec, inverse, drivers, window):
    from predgait.problems.collocation import NodeData, Transcription
    from predgait.problems.fitting import correct_torques

    transcription = Transcription.HERMITE_SIMPSON
    nodes = NodeData.from_drivers(drivers, *window,
                                  transcription.grid_intervals(spec.correction_nodes))
    fit = correct_torques(inverse.model, nodes, transcription=transcription)
    return drivers.with_torque_change(fit.t, fit.torque_change)


def _simulate(inverse, drivers, window, spec, feedback=None):
    from predgait.analysis.deviation import deviation
    from predgait.dynamics.forward import FallLimit, simulate_leg
    from predgait.dynamics.integrators import IntegratorOptions, Method
    from predgait.errors import SimulationDiverged

    options = IntegratorOptions(method=Method.RK4, step=spec.step)
    try:
        sim = simulate_leg(inverse.model, drivers, window, feedback=feedback, options=options,
                           fall=FallLimit(segment_angle_deg=90.0))
    except SimulationDiverged as exc:
        sim = exc.partial
    dev = deviation(sim, inverse.time, inverse.q, threshold_deg=spec.threshold_deg)
    error = np.degrees(np.abs(dev.error))
    return sim, {
        "status": sim.status, "end_s": float(sim.t[-1]),
        "whole_window": bool(sim.t[-1] >= window[1] - 1e-9),
        "time_to_threshold_s": dev.time_to_threshold,
        "max_deviation_deg": {j: float(error[:, i].max()) for i, j in enumerate(JOINTS)},
        "rms_deviation_deg": {j: float(np.degrees(dev.rms[j])) for j in JOINTS}}


def _rms(values: np.ndarray) -> dict:
    return {j: float(np.sqrt(np.mean(values[:, i] ** 2))) for i, j in enumerate(JOINTS)}


def solve_feedback(spec: FeedbackSpec) -> dict:
    """Gains, re-simulations and the torque split (everything written by run_feedback)."""
    from predgait.dynamics.drivers import LegDrivers
    from predgait.dynamics.forward import LegSystem
    from predgait.dynamics.lqr import BrysonWeights, tvlqr

    inverse = spec.trial.inverse()
    window = _window(spec, inverse)
    drivers = LegDrivers.from_inverse(inverse)
    feedforward = (drivers if spec.feedforward is Feedforward.INVERSE_DYNAMICS
                   else _corrected(spec, inverse, drivers, window))
    end = min(window[1] + spec.horizon, float(inverse.time[-1]))
    n_nodes = max(2, int(np.ceil((end - window[0]) / spec.node_step)) + 1)
    nodes = np.linspace(window[0], end, n_nodes)
    weights = BrysonWeights(spec.angle_deg, spec.rate_deg_s, spec.torque_n_m)
    controller = tvlqr(LegSystem(inverse.model, feedforward), feedforward.reference, nodes,
                       weights)
    open_sim, open_loop = _simulate(inverse, feedforward, window, spec)
    sim, closed = _simulate(inverse, feedforward, window, spec, feedback=controller)
    t = sim.t
    measured = np.array([drivers.joint_torque(s) for s in t])
    ff = np.array([feedforward.joint_torque(s) for s in t])
    fb = np.array([controller.torque(s, q, v) for s, q, v in zip(t, sim.q, sim.v,
                                                                 strict=True)])
    band = moment_band(spec, inverse, t)
    half_width = 0.5 * (band.max(axis=0) - band.min(axis=0))
    return {"inverse": inverse, "window": window, "controller": controller, "sim": sim,
            "open_sim": open_sim, "open_loop": open_loop, "closed": closed, "t": t,
            "measured": measured, "feedforward": ff, "feedback": fb, "band": band,
            "half_width": half_width}


def _solution(spec: FeedbackSpec, r: dict) -> dict:
    from predgait.analysis.plausibility import (
        FEEDFORWARD_SOURCE,
        at_most,
        feedback_checks,
        record,
    )
    from predgait.textfile import source_name

    half_rms = _rms(r["half_width"])
    correction = _rms(r["feedforward"] - r["measured"])
    feedback = _rms(r["feedback"])
    total = _rms(r["feedforward"] + r["feedback"])
    closed = r["closed"]
    holds = closed["whole_window"] and closed["time_to_threshold_s"] is None
    peak = {j: float(np.abs(r["feedback"][:, i]).max()) for i, j in enumerate(JOINTS)}
    measured = {j: float(np.abs(r["measured"][:, i]).max()) for i, j in enumerate(JOINTS)}
    checks = feedback_checks(peak, measured) + [
        at_most(f"RMS {j} feedback torque", feedback[j], _rms(r["feedforward"])[j],
                unit="N m", source=FEEDFORWARD_SOURCE) for j in JOINTS]
    return record({
        "status": "completed" if holds else "does not hold",
        "holds_within_threshold": holds,
        "kind": "torque_feedback", "feedforward": spec.feedforward.value,
        "window_s": list(r["window"]), "threshold_deg": spec.threshold_deg,
        "with_feedback": closed, "without_feedback": r["open_loop"],
        "torque_rms_n_m": {"total": total, "feedforward": _rms(r["feedforward"]),
                           "feedforward_correction": correction, "feedback": feedback},
        "feedback_share_of_total_rms": {j: feedback[j] / max(total[j], 1e-12)
                                        for j in JOINTS},
        "inverse_dynamics_uncertainty": {
            "cutoffs_hz": list(spec.cutoffs_hz),
            "half_range_rms_n_m": half_rms,
            "half_range_max_n_m": {j: float(r["half_width"][:, i].max())
                                   for i, j in enumerate(JOINTS)},
            "correction_over_uncertainty": {j: correction[j] / max(half_rms[j], 1e-12)
                                            for j in JOINTS},
            "feedback_over_uncertainty": {j: feedback[j] / max(half_rms[j], 1e-12)
                                          for j in JOINTS}},
        "lqr": {"angle_deg": spec.angle_deg, "rate_deg_s": spec.rate_deg_s,
                "torque_n_m": spec.torque_n_m, "node_step_s": spec.node_step,
                "horizon_s": spec.horizon,
                "max_gain": {"stiffness_n_m_per_rad": float(
                    np.abs(r["controller"].gains[:, :, :2]).max()),
                    "damping_n_m_s_per_rad": float(np.abs(r["controller"].gains[:, :, 2:]).max())},
                "method": "time-varying LQR along the measured motion (Kirk 1970; "
                          "Tedrake, Underactuated Robotics), Pinocchio RNEA derivatives"},
        "provenance": {"problem": source_name(spec.source), "model": r["inverse"].model.source,
                       **r["inverse"].provenance},
    }, checks)


def _gain_columns(controller) -> dict:
    states = ("ankle_angle", "knee_angle", "ankle_rate", "knee_rate")
    return {f"{joint}_from_{state}": controller.gains[:, i, k]
            for i, joint in enumerate(JOINTS) for k, state in enumerate(states)}


def run_feedback(spec: FeedbackSpec, out: Path, *, force: bool = False) -> dict:
    """Solve and write solution.json, corrected_moments.sto, feedback_gains.sto, a plot."""
    from predgait.data import write_storage
    from predgait.report.figures import plots_wanted
    from predgait.report.tidy import write_summary
    from predgait.workflows.output import staged_output

    r = solve_feedback(spec)
    solution = _solution(spec, r)
    inputs = [spec.source, spec.trial.inverse_problem]
    with staged_output(out, force=force, inputs=inputs) as stage:
        solution = write_summary(stage / "solution.json", solution)
        clinical = {}
        for i, joint in enumerate(JOINTS):
            sign = clinical_joint("leg", joint)
            name = f"{sign.angle}_moment"
            clinical[f"{name}_inverse_dynamics"] = sign.clinical(r["measured"][:, i])
            clinical[f"{name}_feedforward"] = sign.clinical(r["feedforward"][:, i])
            clinical[f"{name}_feedback"] = sign.clinical(r["feedback"][:, i])
            clinical[f"{name}_total"] = sign.clinical(r["feedforward"][:, i] + r["feedback"][:, i])
            band = sign.clinical(r["band"][:, :, i])
            clinical[f"{name}_id_cutoff_min"] = band.min(axis=0)
            clinical[f"{name}_id_cutoff_max"] = band.max(axis=0)
        write_storage(stage / "corrected_moments.sto", r["t"], clinical,
                      header={"units": "N m (clinical sign)",
                              "what": "feedforward + LQR feedback along the re-simulation"})
        controller = r["controller"]
        write_storage(stage / "feedback_gains.sto", controller.times, _gain_columns(controller),
                      header={"units": "N m/rad, N m s/rad (model sign)",
                              "what": "u = -K(t) (x - x_ref(t)), x = ankle, knee angles, rates"})
        if plots_wanted():
            from predgait.report.feedback_plots import save_feedback_plot

            save_feedback_plot(stage / "torque_feedback.png", r, spec.threshold_deg)
    return solution


def summary_lines(solution: dict) -> list[str]:
    """Terminal summary of a torque_feedback solution."""
    closed, opened = solution["with_feedback"], solution["without_feedback"]

    def when(result):
        hit = result["time_to_threshold_s"]
        limit = f"{solution['threshold_deg']:g} deg"
        return f"stays within {limit}" if hit is None else f"leaves {limit} at {hit:.3f} s"

    unc = solution["inverse_dynamics_uncertainty"]
    rms = solution["torque_rms_n_m"]
    verdict = "holds" if solution["holds_within_threshold"] else "does not hold"
    lines = [f"torque_feedback ({solution['feedforward']} + time-varying LQR): {verdict} "
             f"over {solution['window_s'][0]:.3f}...{solution['window_s'][1]:.3f} s",
             f"  with feedback: {when(closed)}; max "
             + ", ".join(f"{j} {v:.2f} deg" for j, v in closed["max_deviation_deg"].items()),
             f"  without feedback: {when(opened)}"]
    for joint in JOINTS:
        lines.append(
            f"  {joint}: torque RMS {rms['total'][joint]:.2f} N m = feedforward "
            f"{rms['feedforward'][joint]:.2f} (correction "
            f"{rms['feedforward_correction'][joint]:.3f}) + feedback "
            f"{rms['feedback'][joint]:.3f} N m; inverse-dynamics uncertainty "
            f"(cut-offs {min(unc['cutoffs_hz']):g}-{max(unc['cutoffs_hz']):g} Hz) "
            f"+-{unc['half_range_rms_n_m'][joint]:.2f} N m RMS")
    from predgait.analysis.plausibility import warning_lines

    return lines + warning_lines(solution)
