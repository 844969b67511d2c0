"""Optimisation: ADAM dynamics vs Pinocchio, parameter recovery, re-simulation, failures."""

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import casadi as cs
import numpy as np
import pytest

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forces import JointFeedback
from predgait.dynamics.forward import LegSystem, simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.dynamics.passive import LinearSpringDamper, PassiveJoint
from predgait.errors import InputError, SolveFailed
from predgait.problems.collocation import NodeData, free_dynamics
from predgait.problems.fitting import correct_torques, fit_feedback, fit_knee

REPO = Path(__file__).resolve().parents[1]
FINE = IntegratorOptions(method=Method.RK4, step=2e-4)


@pytest.fixture(scope="module")
def trial():
    inverse = bundled_inverse("right")
    return inverse, LegDrivers.from_inverse(inverse)


def synthetic_nodes(trial, n, t1, **simulate):
    """Nodes whose 'measured' motion is a fine Pinocchio simulation with known inputs."""
    inverse, drivers = trial
    t = np.linspace(0.0, t1, n + 1)
    driving = simulate.pop("drivers", drivers).with_passive(simulate.pop("passive", None))
    sim = simulate_leg(inverse.model, driving, (0.0, t1), options=FINE, t_eval=t,
                       **simulate)
    assert sim.status == "completed"
    nodes = NodeData.from_drivers(drivers, 0.0, t1, n)
    return replace(nodes, x_ref=np.column_stack([sim.q[:, 3:], sim.v[:, 3:]]))


def test_adam_dynamics_and_gradients_equal_pinocchio(trial):
    inverse, drivers = trial
    system = LegSystem(inverse.model, drivers)
    f = free_dynamics(inverse.model)
    inputs = f.sx_in()
    jac = cs.Function("j", inputs, [cs.jacobian(f(*inputs), inputs[0])])
    rng = np.random.default_rng(0)
    for t in rng.uniform(0.0, 1.0, 4):
        x = np.concatenate([inverse.q[30, 3:], inverse.v[30, 3:]]) + rng.normal(0, 0.1, 4)
        args = (x, drivers.prescribed_q(t), drivers.prescribed_qd(t), drivers.prescribed_qdd(t),
                drivers.joint_torque(t),
                np.array([drivers.hip_force(t)[0], drivers.hip_force(t)[2],
                          drivers.hip_moment(t)[1]]))
        np.testing.assert_allclose(np.array(f(*args)).ravel(), system(t, x), rtol=1e-8,
                                   atol=1e-8)
        numeric = np.column_stack([(system(t, x + e) - system(t, x - e)) / 2e-6
                                   for e in np.eye(4) * 1e-6])
        np.testing.assert_allclose(np.array(jac(*args)), numeric, rtol=1e-5, atol=1e-4)


def test_knee_fit_recovers_the_spring_and_damper(trial):
    passive = {"knee": PassiveJoint((LinearSpringDamper(40.0, 3.0, np.radians(5)),))}
    nodes = synthetic_nodes(trial, 200, 0.5, passive=passive)
    fit = fit_knee(trial[0].model, nodes)
    assert fit.parameters["k"] == pytest.approx(40.0, rel=0.03)
    assert fit.parameters["c"] == pytest.approx(3.0, rel=0.05)
    assert fit.parameters["theta0"] == pytest.approx(np.radians(5), abs=np.radians(0.5))
    assert fit.confidence95["k"] > 0
    assert max(fit.rms_deg.values()) < 0.1


def test_torque_correction_recovers_known_offsets(trial):
    inverse, drivers = trial
    shifted = LegDrivers.from_inverse(inverse, torque_offsets=[3.0, -2.0])
    nodes = synthetic_nodes(trial, 200, 0.5, drivers=shifted)
    fit = correct_torques(inverse.model, nodes, tracking_weight=1e6, effort_weight=1e-4,
                          smooth_weight=1.0)
    inner = slice(20, -20)  # the ends are weakly determined by the motion
    np.testing.assert_allclose(fit.torque_change[inner].mean(axis=0), [3.0, -2.0], atol=0.3)
    assert max(fit.rms_deg.values()) < 0.05


def test_feedback_gains_reject_a_perturbation(trial):
    inverse, drivers = trial
    nodes = NodeData.from_drivers(drivers, 0.0, 0.6, 300)
    fit = fit_feedback(inverse.model, nodes, perturbation_deg=3.0, regularization=1e-9)
    p = fit.parameters
    gains = JointFeedback(np.arange(3, 5), drivers.reference,
                          np.array([p["kp_ankle"], p["kp_knee"]]),
                          np.array([p["kd_ankle"], p["kd_knee"]]))
    x0 = np.concatenate([drivers.reference_q(0.0)[3:] + np.radians([3.0, -3.0]),
                         drivers.reference_qd(0.0)[3:]])
    t = np.linspace(0, 0.6, 61)
    with_gains = simulate_leg(inverse.model, drivers, (0, 0.6), x0, feedback=gains,
                              options=FINE, t_eval=t)
    ref = np.array([drivers.reference_q(tk)[3:] for tk in t])
    error = np.degrees(np.abs(with_gains.q[:, 3:] - ref))
    assert error[-10:].max() < 1.0      # back on the measured motion
    assert error[0].max() == pytest.approx(3.0)


def test_failures_are_reported_not_returned(trial):
    inverse, drivers = trial
    nodes = NodeData.from_drivers(drivers, 0.0, 0.5, 50)
    with pytest.raises(SolveFailed, match="Maximum_Iterations_Exceeded") as info:
        fit_knee(inverse.model, nodes, max_iter=1)
    assert info.value.best.iterations == 1
    with pytest.raises(InputError, match="outside the trial"):
        NodeData.from_drivers(drivers, 0.0, 9.0, 50)


def test_cli_solve_with_resimulation_check(tmp_path, assert_tidy_result):
    run = [sys.executable, "-m", "predgait", "solve"]
    out = tmp_path / "knee"
    result = subprocess.run([*run, str(REPO / "problems" / "knee_fit.toml"), "--set",
                             "nodes=200", "--set", "window=[0.0, 0.6]", "--out", str(out)],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr

    solution = assert_tidy_result(out / "solution.json")
    check = solution["resimulation_check"]
    assert solution["status"] == "solved"
    assert check["with_fit"]["time_to_threshold_s"] > \
        check["baseline_uncorrected"]["time_to_threshold_s"]
    # states.sto in its stated unit (rad, model coordinates): the optimised knee tracks the
    # measured one (the leg inverse's kinematics.sto, stated rad; knee flexion = -q_knee)
    # to within the fit's RMS, over a window where it moves by ~20 degrees.
    from predgait.cli import main
    from predgait.data import read_storage

    states = read_storage(out / "states.sto")
    assert states.header["units"].startswith("rad") and not states.in_degrees
    assert main(["inverse", str(REPO / "problems" / "inverse_subject01.toml"), "--no-plots",
                 "--out", str(tmp_path / "inverse")]) == 0
    measured = read_storage(tmp_path / "inverse" / "kinematics.sto")
    knee = np.degrees(np.interp(states.time, measured.time, measured.column("knee_flexion")))
    simulated = np.degrees(-states.column("knee"))
    assert np.ptp(knee) > 15.0
    assert np.sqrt(np.mean((simulated - knee - np.mean(simulated - knee)) ** 2)) < 2.0
    failed = subprocess.run([*run, str(REPO / "problems" / "torque_correction.toml"), "--set",
                             "solver.max_iter=1", "--out", str(tmp_path / "f")],
                            capture_output=True, text=True, timeout=300)
    assert failed.returncode == 3 and "solve failed" in failed.stderr
    assert not (tmp_path / "f").exists()
