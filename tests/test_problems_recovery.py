"""Known answers on noisy synthetic data (Hermite-Simpson) and the real-trial check.

Synthetic "measured" motions are fine Pinocchio simulations (RK4, 0.2 ms) of the bundled
subject01 drive with known inputs, plus seeded Gaussian angle noise; the fits must find
the inputs within their stated intervals. The real-trial check re-simulates the fitted
inputs with Pinocchio (outside the optimiser) as ``predgait solve`` does.
"""

from dataclasses import replace

import numpy as np
import pytest

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forces import JointFeedback
from predgait.dynamics.forward import simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.dynamics.passive import LinearSpringDamper, PassiveJoint
from predgait.problems.collocation import NodeData, Transcription
from predgait.problems.fitting import correct_torques, fit_feedback, fit_knee
from predgait.workflows.solve import Kind, SolveSpec, resimulations, solve_problem

HS = Transcription.HERMITE_SIMPSON
FINE = IntegratorOptions(method=Method.RK4, step=2e-4)


@pytest.fixture(scope="module")
def trial():
    inverse = bundled_inverse("right")
    return inverse, LegDrivers.from_inverse(inverse)


def noisy_nodes(trial, intervals, t1, *, noise_deg, seed, **simulate):
    """HS grid nodes whose reference is a known-input simulation plus angle noise."""
    inverse, drivers = trial
    n = HS.grid_intervals(intervals)
    t = np.linspace(0.0, t1, n + 1)
    driving = simulate.pop("drivers", drivers).with_passive(simulate.pop("passive", None))
    sim = simulate_leg(inverse.model, driving, (0.0, t1), options=FINE, t_eval=t,
                       **simulate)
    assert sim.status == "completed"
    x_ref = np.column_stack([sim.q[:, 3:], sim.v[:, 3:]])
    x_ref[1:, :2] += np.radians(noise_deg) * np.random.default_rng(seed).normal(
        size=(n, 2))
    return replace(NodeData.from_drivers(drivers, 0.0, t1, n), x_ref=x_ref)


def test_knee_fit_recovers_k_c_theta0_within_its_intervals_from_noisy_data(trial):
    truth = {"k": 40.0, "c": 3.0, "theta0": np.radians(5.0)}
    passive = {"knee": PassiveJoint((LinearSpringDamper(**truth),))}
    nodes = noisy_nodes(trial, 60, 0.3, noise_deg=0.1, seed=11, passive=passive)
    fit = fit_knee(trial[0].model, nodes, transcription=HS)
    for name, value in truth.items():
        half = fit.confidence95[name]
        # within 2.5 half-widths of the 95 % interval (Gauss-Newton, seeded noise) and
        # the interval itself informative (a few % of k, c)
        assert abs(fit.parameters[name] - value) < 2.5 * half + 1e-9, (name, fit.parameters)
    assert fit.confidence95["k"] < 0.1 * truth["k"]
    assert fit.confidence95["c"] < 0.2 * truth["c"]
    # the residual is the noise: 0.1 deg
    assert fit.diagnostics["residual_sd_deg"] == pytest.approx(0.1, rel=0.2)


def test_hermite_simpson_is_more_accurate_than_trapezoidal_on_a_coarse_grid(trial):
    passive = {"knee": PassiveJoint((LinearSpringDamper(40.0, 3.0, np.radians(5)),))}
    inverse, drivers = trial
    errors = {}
    for transcription in Transcription:
        n = transcription.grid_intervals(30)
        t = np.linspace(0.0, 0.3, n + 1)
        sim = simulate_leg(inverse.model, drivers.with_passive(passive), (0.0, 0.3),
                           options=FINE, t_eval=t)
        nodes = replace(NodeData.from_drivers(drivers, 0.0, 0.3, n),
                        x_ref=np.column_stack([sim.q[:, 3:], sim.v[:, 3:]]))
        fit = fit_knee(inverse.model, nodes, transcription=transcription)
        errors[transcription] = abs(fit.parameters["k"] - 40.0)
    assert errors[HS] < 0.5, errors
    assert errors[HS] < 0.2 * errors[Transcription.TRAPEZOIDAL], errors


def test_torque_correction_recovers_a_known_smooth_offset_from_noisy_data(trial):
    inverse, drivers = trial

    def offset(t):
        return np.array([2.0 + 1.5 * np.sin(2 * np.pi * t / 0.4), -1.0])

    shifted = replace(drivers, joint_torque=lambda t: drivers.joint_torque(t) + offset(t))
    nodes = noisy_nodes(trial, 60, 0.3, noise_deg=0.02, seed=3, drivers=shifted)
    fit = correct_torques(inverse.model, nodes, tracking_weight=1e6, effort_weight=1e-4,
                          smooth_weight=100.0, transcription=HS)
    truth = np.array([offset(t) for t in nodes.t])
    inner = slice(20, -20)  # the ends are weakly determined by the motion
    error = np.abs(fit.torque_change[inner] - truth[inner])
    # RMS error < 0.2 N m on offsets of 1-3.5 N m (noise 0.02 deg; the residual = noise)
    assert np.sqrt(np.mean(error ** 2, axis=0)).max() < 0.2, error.max(axis=0)
    assert max(fit.rms_deg.values()) == pytest.approx(0.02, rel=0.25)


def test_feedback_fit_recovers_known_gains_from_a_noisy_perturbed_response(trial):
    inverse, drivers = trial
    kp, kd = np.array([150.0, 250.0]), np.array([5.0, 8.0])
    gains = JointFeedback(np.arange(3, 5), drivers.reference, kp, kd)
    x0 = np.concatenate([drivers.reference_q(0.0)[3:] + np.radians([3.0, -3.0]),
                         drivers.reference_qd(0.0)[3:]])
    nodes = noisy_nodes(trial, 60, 0.4, noise_deg=0.02, seed=5, feedback=gains, x0=x0)
    reference = np.column_stack([[drivers.reference_q(t)[3:] for t in nodes.t],
                                 [drivers.reference_qd(t)[3:] for t in nodes.t]])
    fit = fit_feedback(inverse.model, replace(nodes, feedback_ref=reference),
                       perturbation_deg=0.0, regularization=1e-14, transcription=HS)
    p = fit.parameters
    np.testing.assert_allclose([p["kp_ankle"], p["kp_knee"]], kp, rtol=0.02)
    np.testing.assert_allclose([p["kd_ankle"], p["kd_knee"]], kd, rtol=0.05)


def _spec(kind, **changes):
    spec = SolveSpec(kind=kind, source=None, inverse_problem=None, side="right",
                     window=(0.0, 1.0), nodes=100, transcription=HS,
                     weights={}, threshold_deg=2.0, perturbation_deg=3.0, max_iter=300)
    return replace(spec, **changes)


def test_real_trial_resimulation_of_corrected_torques_and_feedback_gains(trial):
    inverse, drivers = trial
    spec = _spec(Kind.TORQUE_CORRECTION)
    fit = solve_problem(spec, inverse, drivers)
    report, _ = resimulations(spec, inverse, drivers, fit)
    baseline = report["baseline_uncorrected"]["time_to_threshold_s"]
    after = report["with_fit"]["time_to_threshold_s"]
    # the uncorrected moments leave 2 deg within ~0.2 s (thesis 4.2: the leg falls); the
    # corrected ones hold markedly longer (open-loop, the unstable mode with eigenvalue
    # ~35 1/s still amplifies the remaining transcription error)
    assert 0.1 < baseline < 0.3
    assert after > baseline + 0.1
    assert max(fit.rms_deg.values()) < 0.05
    spec = _spec(Kind.FEEDBACK_GAINS)
    fit = solve_problem(spec, inverse, drivers)
    report, sims = resimulations(spec, inverse, drivers, fit)
    assert report["with_fit"]["time_to_threshold_s"] is None  # within 2 deg all along
    assert report["with_fit"]["end_s"] == pytest.approx(1.0)
    perturbed = report["with_fit_perturbed_start"]
    assert perturbed["end_s"] == pytest.approx(1.0)
    assert perturbed["within_threshold_from_s"] < 0.1  # back within 2 deg quickly
