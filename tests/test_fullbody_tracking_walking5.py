"""Whole-body tracking of opensim-core's walking5 (two plates: a left and a right stance).

The solution of problems/fullbody_tracking_walking5.toml (1.97-2.96 s, 62 nodes) is
re-simulated by the forward engine on its contact springs: without feedback the body falls
within 0.15 s; with the time-varying LQR (Bryson's rule: the same torque cost on every
joint, a height error on every sole point) it completes the window, across the right heel
strike (2.41 s) where the former inertia-scaled torque cost (1-2 N m/rad on the feet) fell
at 0.44 s, and the left heel's landing beside the plates (~2.90 s) where the law without
the sole-height weight fell at 2.94 s. Its corrected torques (issue 27 item 1): the hips'
and lumbar's corrections cancel the measured data's pelvis moment, which keeps them above
0.15 N m/kg (the yardstick stays a strict xfail).
"""

from pathlib import Path

import numpy as np
import pytest

PROBLEM = (Path(__file__).resolve().parents[1] / "problems"
           / "fullbody_tracking_walking5.toml")


@pytest.fixture(scope="module")
def walking5():
    from predgait.problemfile import load_problem
    from predgait.workflows.fullbody_tracking import parse_tracking
    from predgait.workflows.fullbody_tracking_run import hold_with_feedback, solve_spec

    spec = parse_tracking(load_problem(PROBLEM))
    drive, data, solution = solve_spec(spec)
    info, _, run = hold_with_feedback(spec, drive, data, solution)
    return data, solution, info, run, drive


def test_feedback_holds_walking5_across_the_heel_strike(walking5):
    data, solution, info, run, _ = walking5
    assert solution.status == "Solve_Succeeded"
    assert np.abs(solution.tau[:, :6]).max() < 1e-6                # no pelvis residual
    without, with_fb = info["without_feedback"], info["with_feedback"]
    # Without feedback it falls at once (under 0.1 s before issue 27's smoother torques, 0.104 s
    # with them; the window is 1 s).
    assert without["status"] == "event" and without["time_to_fall_s"] < 0.15
    assert with_fb["status"] == "completed" and with_fb["time_to_fall_s"] is None
    assert run.t.size == data.nodes and run.t[-1] == pytest.approx(data.time[-1])
    assert with_fb["joint_rms_from_solution_deg"] < 3.0
    # The right foot's engine contact forces stay near its plate across its stance (the
    # left's include the landing beside the plates, which they do not measure).
    grf = with_fb["grf_rms_from_plates_percent_bw"]
    assert max(grf["r_x"], grf["r_y"], grf["r_z"]) < 25.0
    # The RK4 step is inside its stability limit for the closed loop's fastest rate.
    assert info["rk4_step_s"] * info["closed_loop_fastest_rate_1_s"] < 2.78


def test_walking5_hip_corrections_cancel_the_measured_pelvis_moment(walking5):
    """Issue 27 item 1 on walking5: the measured moments leave the pelvis a sagittal
    moment (51.5 N m RMS at 72 kg, up to 107 N m in each terminal stance; subject01: 17.5),
    which the solution, with no residual, cancels with the hips and lumbar (their summed
    corrections minus it: 12 N m RMS), so one of the three corrections is at least 14 N m
    RMS (0.19 N m/kg, 0.23 with the plates' 57.9 kg): the 0.15 N m/kg goal is out of reach
    for the hips and lumbar together on these data. The knees meet it."""
    from predgait.workflows.fullbody_tracking import pelvis_moment_share, torque_deviation

    data, solution, _, _, drive = walking5
    share = pelvis_moment_share(drive, data, solution)
    assert share["residual_my"] > 40.0
    assert share["left"] < 0.3 * share["residual_my"]
    per_kg = torque_deviation(drive.model, data, solution)["sagittal_rms_n_m_per_kg"]
    assert per_kg["knee_r_y"] <= 0.15 and per_kg["knee_l_y"] <= 0.15


@pytest.mark.xfail(strict=True, reason="walking5's measured pelvis moment (above) and the "
                   "toe-tip contact after heel-off: issue 27 item 1, docs/DEVELOPING.md")
def test_walking5_corrected_torques_meet_the_issue_27_yardstick(walking5):
    """Corrected minus measured sagittal torques within 0.15 N m/kg RMS, no corrected
    torque above its measured peak + 30 N m, no node-to-node change above 30 N m."""
    from predgait.workflows.fullbody_tracking import torque_deviation

    data, solution, _, _, drive = walking5
    worst = torque_deviation(drive.model, data, solution)["worst"]
    assert worst["sagittal_rms_n_m_per_kg"]["value"] <= 0.15
    assert worst["spike_n_m"]["value"] <= 30.0
    assert worst["node_change_n_m"]["value"] <= 30.0
