"""Whole-body tracking over the whole first right gait cycle of subject01 (issue 18).

The solution of problems/fullbody_tracking.toml (0.633-1.867 s, 75 nodes) satisfies the
equations of motion with no pelvis residual while staying near the measured angles and
plate forces; the forward engine re-simulating the free body from its first state on
the contact springs (RK4) falls within 0.1 s without feedback and completes the whole
cycle with the time-varying LQR, near the solution's joint angles and the plate forces.

Walking known answer (issue 27): the engine walks part of that cycle (across the right
heel-off and the left heel strike) on its contact springs, driven by the solution's
torques plus the LQR feedback; tracked back from its motion and spring forces alone (no
torque target), the joint torques come out within 5 % RMS of the ones that drove it, and
their node-to-node change differs from the driving torques' by at most 2 % of the peak.
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
    return drive, data, solution, info, run, lqr


def test_cycle_solution_is_consistent_and_near_the_data(cycle):
    drive, data, solution, _, _, _ = cycle
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
    _, data, _, info, run, _ = cycle
    without, with_fb = info["without_feedback"], info["with_feedback"]
    assert without["status"] == "event" and without["time_to_fall_s"] < 0.1
    assert with_fb["status"] == "completed" and with_fb["time_to_fall_s"] is None
    assert run.t[-1] == pytest.approx(data.time[-1])
    assert run.t.size == data.nodes                                # every node reached
    assert with_fb["joint_rms_from_solution_deg"] < 3.0
    # The engine's own contact forces stay near the plates over the whole cycle.
    assert max(with_fb["grf_rms_from_plates_percent_bw"].values()) < 10.0


#: Known-answer window, s: the right heel-off (~1.2 s) and the left heel strike (~1.25 s).
KNOWN_WINDOW = (1.05, 1.40)


def engine_walk(drive, data, solution, lqr):
    """The engine's walk over KNOWN_WINDOW from the solution's state there: the time,
    motion, driving joint torques (n, 29) and spring forces (n, P, 3) at the nodes."""
    import pinocchio as pin

    from predgait.dynamics.integrators import IntegratorOptions, Method
    from predgait.dynamics.partitioned import simulate_partitioned
    from predgait.problemfile import load_problem
    from predgait.simulations.fullbody_feedback import body_system
    from predgait.workflows.fullbody_tracking import parse_tracking

    spec = parse_tracking(load_problem(PROBLEM))
    system, _, ground = body_system(drive.model, solution, spec.contact.contact,
                                    ground_z=data.ground_z, belt_velocity=data.belt_velocity,
                                    feedback=lqr)
    nodes = np.flatnonzero((data.time >= KNOWN_WINDOW[0]) & (data.time <= KNOWN_WINDOW[1]))
    t = data.time[nodes]
    sim = simulate_partitioned(system, (t[0], t[-1]),
                               system.state(solution.q[nodes[0]], solution.v[nodes[0]]),
                               options=IntegratorOptions(method=Method.RK4, step=spec.step),
                               t_eval=t)
    assert sim.t.size == t.size
    pm, pdata = system.pm, system.pm.createData()
    tau, forces = [], []
    for k, (q, v) in enumerate(zip(sim.q, sim.v, strict=True)):
        tau.append(solution.tau[nodes[k], 6:] + lqr.torque(t[k], q, v))
        pin.forwardKinematics(pm, pdata, q, v)
        pin.updateFramePlacements(pm, pdata)
        forces.append(ground.forces(pdata))
    return sim, np.array(tau), np.array(forces).reshape(t.size, -1, 3)


def test_walking_known_torques_recovered(cycle):
    from predgait.problems.fullbody_tracking import TrackingData, solve_tracking
    from predgait.workflows.fullbody_tracking import foot_cop_from_points

    drive, data, solution, _, _, lqr = cycle
    model = drive.model
    sim, tau, forces = engine_walk(drive, data, solution, lqr)
    on = forces[:, :, 2] > 1e-6
    # A real test case: a heel lifts off and a foot lands inside the window.
    assert (on[0] != on[-1]).any() and np.abs(tau).max() > 50.0
    force, cop, free = foot_cop_from_points(model, sim.q, forces, solution.points,
                                            data.ground_z)
    walk = TrackingData(sim.t, sim.q, sim.v, sim.a, on, force, cop, free, data.ground_z,
                        data.belt_velocity, stiffness=data.stiffness,
                        friction=data.friction, slip_transition=data.slip_transition,
                        points=solution.points, fade_nodes=0)
    back = solve_tracking(model, walk)
    assert back.status == "Solve_Succeeded"
    error = back.tau[:, 6:] - tau
    peak = np.abs(tau).max()
    assert np.sqrt(np.mean(error**2)) < 0.05 * np.sqrt(np.mean(tau**2))
    assert np.abs(np.diff(back.tau[:, 6:], axis=0) - np.diff(tau, axis=0)).max() < 0.02 * peak
