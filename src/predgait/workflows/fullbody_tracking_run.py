"""Run a ``fullbody_tracking`` spec and write its result folder.

See :mod:`predgait.workflows.fullbody_tracking`.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from predgait import __version__
from predgait.analysis.plausibility import (
    grf_check,
    joint_moment_checks,
    mass_check,
    record,
    residual_check,
    warning_lines,
)
from predgait.data import write_storage
from predgait.kinematics.ik3d import coordinate_columns
from predgait.problems.fullbody_tracking import (
    TrackingData,
    TrackingSolution,
    solve_tracking,
)
from predgait.report.console import foot_flat_text
from predgait.report.tidy import write_summary
from predgait.simulations.forward3d import FullbodyDrive
from predgait.workflows.forward3d_run import inverse_for
from predgait.workflows.fullbody_tracking import (
    TrackingSpec,
    deviations,
    gait_cycle,
    parse_tracking,  # noqa: F401  (predgait solve finds the kind's parser here)
    plate_height,
    tracking_data,
)
from predgait.workflows.output import staged_output


def solve_spec(spec: TrackingSpec) -> tuple[FullbodyDrive, TrackingData, TrackingSolution]:
    """IK + ID of the trial, then the tracking problem on the window.

    Raises:
        SolveFailed: Ipopt did not converge.
    """
    from predgait.problems.ipopt_progress import stage

    stage("stage 1/3: whole-body IK + inverse dynamics of the trial")
    inverse = inverse_for(spec.trial)
    drive = FullbodyDrive.from_inverse(inverse)
    window = spec.window or gait_cycle(drive, inverse.stances)
    data = tracking_data(drive, plate_height(inverse), window, contact=spec.contact,
                         contact_height=spec.contact_height, stride=spec.stride,
                         fade_nodes=spec.fade_nodes)
    stage(f"stage 2/3: tracking problem on {window[0]:.3f}..{window[1]:.3f} s "
          "(building it takes a while)")
    return drive, data, solve_tracking(drive.model, data, spec.weights,
                                       max_iter=spec.max_iter, solver=spec.solver,
                                       convex_iterations=spec.convex_iterations,
                                       label="stage 2/3 whole-body tracking")


def write_solution(folder: Path, drive: FullbodyDrive, solution: TrackingSolution,
                   header: dict) -> None:
    """kinematics3d.sto, corrected_moments3d.sto and contact_forces.sto."""
    names = drive.model.joint_names
    t = solution.time
    write_storage(folder / "kinematics3d.sto", t, coordinate_columns(solution.q, names),
                  in_degrees=True, header=header | {
        "units": "deg (angles: Cardan X-Y-Z), m (pelvis_t*)",
        "what": "dynamically consistent (corrected) kinematics"})
    moments = {f"{n}_moment": solution.tau[:, 6 + i] for i, n in enumerate(names)}
    moments |= {f"pelvis_residual_{k}": solution.tau[:, i]
                for i, k in enumerate(("fx", "fy", "fz", "mx", "my", "mz"))}
    write_storage(folder / "corrected_moments3d.sto", t, moments, header=header | {
        "units": "N m (joint moments about each Cardan axis); N, N m (pelvis residual, "
                 "pelvis frame: zero to the solver's tolerance)"})
    forces = {p: solution.forces[:, i] for i, p in enumerate(solution.points)}
    forces |= {f"foot_{s}": solution.foot_forces()[:, j] for j, s in enumerate("rl")}
    write_storage(folder / "contact_forces.sto", t, forces, header=header | {
        "units": "N (lab frame, on each sole point and each foot)"})


def summary_of(spec: TrackingSpec, drive, data, solution, *, feedback=None) -> dict:
    """The summary.json content."""
    model = drive.model
    return record({
        "kind": "fullbody_tracking", "status": "solved",
        "window_s": [float(data.time[0]), float(data.time[-1])], "nodes": int(data.nodes),
        "solver": spec.solver, "convex_iterations": spec.convex_iterations,
        "ipopt_status": solution.status,
        "iterations": solution.iterations, "objective": solution.objective,
        "solve_time_s": solution.seconds, "build_time_s": solution.build_seconds,
        "pelvis_residual_max_n": float(np.abs(solution.tau[:, :3]).max()),
        "pelvis_residual_max_n_m": float(np.abs(solution.tau[:, 3:6]).max()),
        "measured_pelvis_residual_rms_n": float(np.sqrt(np.mean(
            drive.tau[np.isin(drive.time, data.time), :3] ** 2))),
        "floor_z_m": data.ground_z, "belt_velocity_m_per_s": data.belt_velocity,
        "floor": floor_summary(data),
        "contact_nodes": {p: int(data.contact[:, i].sum())
                          for i, p in enumerate(data.points)},
        "deviation": deviations(model, data, solution),
        "feedback": feedback,
        "provenance": {"problem": spec.source, "trial": drive.source,
                       "predgait": __version__, "mass_kg": round(model.total_mass(), 3),
                       **drive.calibration},
    }, [*tracking_checks(model, solution),
        mass_check(model.total_mass(), drive.calibration.get("plates_weigh_kg"))])


def floor_summary(data: TrackingData) -> dict:
    """The contacts' floor (m), its source, the plates' COP plane and the foot-moment plane.

    The last is the floor (issue 27): the moments are about the plates' line of action there.
    """
    return {"z_m": float(data.ground_z), "source": data.floor_source,
            "plates_cop_plane_z_m": data.plate_z,
            "foot_moment_plane_z_m": float(np.median(data.cop[:, :, 2]))}


def tracking_checks(model, solution) -> list:
    """Plausibility (:mod:`predgait.analysis.plausibility`) of a tracked whole-body gait.

    Peak |joint moment| of the hip, knee and ankle coordinates (N m/kg), each foot's peak
    vertical force (BW), the pelvis residual force against the peak foot force.
    """
    mass = model.total_mass()
    feet = solution.foot_forces()
    peak = float(np.linalg.norm(feet.sum(axis=1), axis=1).max())
    checks = joint_moment_checks({n: float(np.abs(solution.tau[:, 6 + i]).max()) / mass
                                  for i, n in enumerate(model.joint_names)})
    checks.append(grf_check(float(feet[:, :, 2].max()) / (mass * model.gravity),
                            "peak vertical ground reaction (one foot)"))
    checks.append(residual_check(float(np.linalg.norm(solution.tau[:, :3], axis=1).max()),
                                 peak))
    return checks


def hold_with_feedback(spec: TrackingSpec, drive, data, solution):
    """Re-simulate the solution without and with LQR feedback.

    Returns:
        (summary dict, the gains, the run with feedback).
    """
    from predgait.simulations.fullbody_feedback import body_system, feedback_gains, resimulate

    model = drive.model
    body_weight = model.total_mass() * model.gravity
    floor = {"ground_z": data.ground_z, "belt_velocity": data.belt_velocity}
    system, history, ground = body_system(model, solution, spec.contact.contact, **floor)
    without = resimulate(system, history, ground, solution, step=spec.step)
    started = time.perf_counter()
    lqr = feedback_gains(system, history, solution, spec.feedback)
    gains_s = time.perf_counter() - started
    closed, history, ground = body_system(model, solution, spec.contact.contact,
                                          feedback=lqr, **floor)
    with_fb = resimulate(closed, history, ground, solution, step=spec.step)
    info = {"weights": vars(spec.feedback), "rk4_step_s": spec.step,
            "gains_time_s": gains_s, "closed_loop_fastest_rate_1_s": lqr.fastest_rate,
            "without_feedback": without.summary(solution, data, body_weight),
            "with_feedback": with_fb.summary(solution, data, body_weight)}
    return info, lqr, with_fb


def write_gains(path: Path, lqr, solution: TrackingSolution, names) -> None:
    """``feedback_gains.npz``: K(t) as float32 with its times, reference and row names."""
    np.savez_compressed(path, times=lqr.times, gains=lqr.gains.astype(np.float32),
                        q_ref=solution.q, v_ref=solution.v,
                        actuated=np.array(names),
                        state=np.array([f"d{n}" for n in ("pelvis_x", "pelvis_y", "pelvis_z",
                                                          "pelvis_rx", "pelvis_ry",
                                                          "pelvis_rz", *names)]
                                       + [f"v_{n}" for n in ("pelvis_vx", "pelvis_vy",
                                                             "pelvis_vz", "pelvis_wx",
                                                             "pelvis_wy", "pelvis_wz",
                                                             *names)]),
                        units=np.array("N m per (m or rad) and per (m/s or rad/s); "
                                       "u = -K(t) [pin.difference(q_ref, q), v - v_ref]"))


def run_tracking(spec: TrackingSpec, out: Path, *, force: bool = False) -> dict:
    """Solve, re-simulate and write ``out``; returns the summary.

    Raises:
        SolveFailed: Ipopt did not converge (nothing written).
    """
    from predgait.problems.ipopt_progress import stage
    from predgait.report.figures import plots_wanted

    drive, data, solution = solve_spec(spec)
    stage("stage 3/3: LQR gains and re-simulation without and with feedback")
    feedback, lqr, run = hold_with_feedback(spec, drive, data, solution)
    header = {"provenance": f"problem={spec.source}; trial={drive.source}; "
                            f"predgait={__version__}"}
    names = drive.model.joint_names
    with staged_output(out, force=force, inputs=[spec.source]) as stage:
        write_solution(stage, drive, solution, header)
        write_gains(stage / "feedback_gains.npz", lqr, solution, names)
        write_storage(stage / "resimulated_kinematics3d.sto", run.t,
                      coordinate_columns(run.q, names), in_degrees=True, header=header | {
                          "units": "deg (angles: Cardan X-Y-Z), m (pelvis_t*)",
                          "what": "forward re-simulation with the LQR feedback, "
                                  f"{feedback['with_feedback']['status']}"})
        if plots_wanted():
            from predgait.report.fullbody_tracking_plots import save_tracking_plots

            save_tracking_plots(stage, drive.model, data, solution, simulated=(run.t, run.q))
        return write_summary(stage / "summary.json",
                             summary_of(spec, drive, data, solution, feedback=feedback))



def summary_lines(info: dict) -> list[str]:
    """What ``predgait solve`` prints for ``kind = "fullbody_tracking"``."""
    dev = info["deviation"]
    lines = [
        f"fullbody_tracking: {info['status']}; Ipopt {info['ipopt_status']} in "
        f"{info['iterations']} iterations, "
        f"{info['solve_time_s']:.1f} s ({info['nodes']} nodes, "
        f"{info['window_s'][0]:.3f}..{info['window_s'][1]:.3f} s)",
        f"  pelvis residual max {info['pelvis_residual_max_n']:.2e} N "
        f"(measured data: {info['measured_pelvis_residual_rms_n']:.1f} N RMS)",
        f"  joints moved {dev['all_joints_rms_deg']:.2f} deg RMS; GRF differs "
        + ", ".join(f"{k} {v:.1f}" for k, v in dev["grf_rms_percent_bw"].items())
        + " % BW RMS",
    ]
    floor = info.get("floor")
    if floor:
        plates = floor["plates_cop_plane_z_m"]
        lines.append(f"  floor z = {floor['z_m']:.4f} m ({floor['source']}); foot moments "
                     "about the plates' line of action there"
                     + ("" if plates is None else f" (plates' COP plane {plates:.4f} m)"))
    torque = dev.get("torque")
    if torque:
        rms, peak, step = (torque["worst"][k] for k in
                           ("sagittal_rms_n_m_per_kg", "peak_n_m", "node_change_n_m"))
        lines.append(
            f"  joint torques vs measured: worst sagittal {rms['value']:.3f} N m/kg RMS "
            f"({rms['joint']}), peak difference {peak['value']:.0f} N m ({peak['joint']}), "
            f"largest node-to-node change {step['value']:.0f} N m ({step['joint']})")
    for name in ("without_feedback", "with_feedback"):
        run = info["feedback"][name]
        fell = run["time_to_fall_s"]
        ending = (f"falls at {fell:.3f} s" if fell is not None
                  else f"diverges after {run['simulated_s']:.3f} s" if run["status"] == "diverged"
                  else "completes the window")
        lines.append(f"  re-simulated {name.replace('_', ' ')}: {ending}"
                     f" ({run['status']}; joints {run['joint_rms_from_solution_deg']:.2f} "
                     "deg RMS from the solution)")
    feet = foot_flat_text(info["provenance"].get("foot_flat_calibration"))
    if feet:
        lines.append(f"  feet levelled at loaded mid-stance (foot flat): {feet}")
    return lines + warning_lines(info)
