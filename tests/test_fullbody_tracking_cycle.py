"""Whole-body tracking over the whole first right gait cycle of subject01 (issue 18).

The solution of problems/fullbody_tracking.toml (0.633-1.867 s, 75 nodes) satisfies the
equations of motion with no pelvis residual while staying near the measured angles and
plate forces; the forward engine re-simulating the free body from its first state on
the contact springs (RK4) falls within 0.1 s without feedback and completes the whole
cycle with the time-varying LQR, near the solution's joint angles and the plate forces.
"""

from pathlib import Path

import numpy as np
import pytest

PROBLEM = Path(__file__).resolve().parents[1] / "problems" / "fullbody_tracking.toml"


@pytest.fixture(scope="module")
def cycle():
    from predgait.problemfile import load_problem
    from predgait.workflows.fullbody_tracking import parse_tracking
    from predgait.workflows.fullbody_tracking_run import hold_with_feedback, solve_spec

    spec = parse_tracking(load_problem(PROBLEM))
    drive, data, solution = solve_spec(spec)
    info, lqr, run = hold_with_feedback(spec, drive, data, solution)
    return drive, data, solution, info, run


def test_cycle_solution_is_consistent_and_near_the_data(cycle):
    drive, data, solution, _, _ = cycle
    assert data.time[0] == pytest.approx(0.633, abs=0.01)
    assert data.time[-1] == pytest.approx(1.867, abs=0.01)
    # Both feet have a stance in the window.
    assert data.contact[:, :2].any() and data.contact[:, 2:].any()
    assert solution.status == "Solve_Succeeded"
    assert np.abs(solution.tau[:, :6]).max() < 1e-6                # no pelvis residual
    angles = np.degrees(solution.q[:, 7:] - data.q[:, 7:])
    assert np.sqrt(np.mean(angles**2, axis=0)).max() < 5.0         # each joint, deg RMS
    body_weight = drive.model.total_mass() * drive.model.gravity
    grf = solution.foot_forces() - data.force
    assert 100 * np.sqrt(np.mean(grf**2, axis=0)).max() / body_weight < 10.0


def test_feedback_completes_the_cycle_that_falls_without_it(cycle):
    _, data, _, info, run = cycle
    without, with_fb = info["without_feedback"], info["with_feedback"]
    assert without["status"] == "event" and without["time_to_fall_s"] < 0.1
    assert with_fb["status"] == "completed" and with_fb["time_to_fall_s"] is None
    assert run.t[-1] == pytest.approx(data.time[-1])
    assert run.t.size == data.nodes                                # every node reached
    assert with_fb["joint_rms_from_solution_deg"] < 3.0
    # The engine's own contact forces stay near the plates over the whole cycle.
    assert max(with_fb["grf_rms_from_plates_percent_bw"].values()) < 10.0
