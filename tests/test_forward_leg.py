"""Leg forward dynamics: energy, fixed base, inverse-then-forward, falls, divergence."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from predgait.dynamics.drivers import LegDrivers, constant
from predgait.dynamics.forces import JointFeedback
from predgait.dynamics.forward import FallLimit, LegSystem, simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.passive import LinearSpringDamper, PassiveJoint
from predgait.errors import InputError, SimulationDiverged
from predgait.models.loading import load_model

LEG = load_model("leg")


def energy(q, v):
    pm = LEG.pin_model
    data = pm.createData()
    return pin.computeKineticEnergy(pm, data, q, v) + pin.computePotentialEnergy(pm, data, q)


@pytest.mark.parametrize("options", [
    IntegratorOptions(method=Method.RK4, step=1e-3),
    IntegratorOptions(method=Method.RADAU, step=1e-2, rtol=1e-9, atol=1e-11),
], ids=["rk4", "radau"])
def test_double_pendulum_conserves_energy(options):
    """Foot held still, no torques: a double pendulum (shank, thigh); energy constant."""
    x0 = np.radians([5.0, -10.0, 0.0, 0.0])
    sim = simulate_leg(LEG, LegDrivers.still(), (0.0, 0.6), x0, options=options)
    e = np.array([energy(q, v) for q, v in zip(sim.q, sim.v, strict=True)])
    swing = np.ptp(sim.q[:, 4])
    assert swing > 1.0                      # it really falls and swings
    assert np.max(np.abs(e - e[0])) < 1e-5 * (1 + abs(e[0]))
    # and a coarse explicit Euler does not conserve it (the check can fail)
    bad = simulate_leg(LEG, LegDrivers.still(), (0.0, 0.6), x0,
                       options=IntegratorOptions(method=Method.EULER, step=1e-2))
    e_bad = np.array([energy(q, v) for q, v in zip(bad.q, bad.v, strict=True)])
    assert np.max(np.abs(e_bad - e_bad[0])) > 1e-2


def test_prescribed_still_base_equals_fixed_base_model():
    """A still foot at the origin gives the accelerations of a fixed-base URDF model."""
    fixed = pin.buildModelFromXML(LEG.urdf)
    fixed.gravity.linear = np.array([0.0, 0.0, -LEG.gravity])
    fdata = fixed.createData()
    rng = np.random.default_rng(0)
    for _ in range(5):
        qj, vj, tau = rng.normal(0, 0.5, 2), rng.normal(0, 2, 2), rng.normal(0, 30, 2)
        drivers = LegDrivers.still(joint_torque=tau)
        got = LegSystem(LEG, drivers)(0.0, np.concatenate([qj, vj]))[2:]
        want = pin.aba(fixed, fdata, qj, vj, tau)
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10)


def smooth_motion(t):
    """Smooth synthetic q, v, a (5,) of a stepping leg, t in s."""
    w = 2 * np.pi * 0.9
    amp = np.array([0.05, 0.02, 0.15, 0.2, -0.5])
    off = np.array([0.1, 0.08, 0.0, 0.05, -0.6])
    ph = np.array([0.0, 0.5, 1.0, 1.5, 2.0])
    q = off + amp * np.sin(w * t + ph)
    return q, amp * w * np.cos(w * t + ph), -amp * w * w * np.sin(w * t + ph)


def test_inverse_then_forward_reproduces_motion():
    """Torques and reaction from RNEA on smooth motion (with a hip load) drive it back."""
    pm = LEG.pin_model
    data = pm.createData()
    hip_f, hip_m = np.array([20.0, 0.0, -300.0]), np.array([0.0, 10.0, 0.0])
    system0 = LegSystem(LEG, LegDrivers.still(hip_force=hip_f, hip_moment=hip_m))

    def tau_of(t):
        q, v, a = smooth_motion(t)
        J = pin.computeFrameJacobian(pm, data, q, LEG.frame_id("hip_center"),
                                     pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        return pin.rnea(pm, data, q, v, a) - J[:3].T @ hip_f - J[3:].T @ hip_m

    drivers = LegDrivers(
        prescribed_q=lambda t: smooth_motion(t)[0][:3],
        prescribed_qd=lambda t: smooth_motion(t)[1][:3],
        prescribed_qdd=lambda t: smooth_motion(t)[2][:3],
        joint_torque=lambda t: tau_of(t)[3:], hip_force=constant(hip_f),
        hip_moment=constant(hip_m), reference_q=lambda t: smooth_motion(t)[0],
        reference_qd=lambda t: smooth_motion(t)[1])
    sim = simulate_leg(LEG, drivers, (0.0, 0.4), options=IntegratorOptions(
        method=Method.RK4, step=1e-3))
    want = np.array([smooth_motion(t)[0] for t in sim.t])
    # the leg is unstable (errors grow ~e-fold per 0.05 s), so the window is short
    np.testing.assert_allclose(sim.q, want, atol=1e-6)
    # the reported ground reaction is RNEA's base force (no loads on the foot besides it)
    k = len(sim.t) // 2
    base = tau_of(sim.t[k])[:3]
    np.testing.assert_allclose(sim.grf[k, [0, 2]], base[:2], rtol=1e-6, atol=1e-6)
    del system0


def test_collapse_falls_and_reports_time_to_fall():
    """Thesis 4.2 collapse test: foot fixed, shank 5 deg, thigh -5 deg absolute."""
    x0 = np.radians([5.0, -10.0, 0.0, 0.0])
    opts = IntegratorOptions(method=Method.MODIFIED_EULER, step=1e-3, iterations=10)
    sim = simulate_leg(LEG, LegDrivers.still(), (0.0, 1.0), x0, options=opts,
                       fall=FallLimit(segment_angle_deg=60.0))
    assert sim.status == "event"
    assert 0.15 < sim.time_to_fall < 0.8
    thigh = sim.q[-1, 2] + sim.q[-1, 3] + sim.q[-1, 4]
    shank = sim.q[-1, 2] + sim.q[-1, 3]
    assert max(abs(thigh), abs(shank)) == pytest.approx(np.radians(60), abs=1e-6)
    hip = simulate_leg(LEG, LegDrivers.still(), (0.0, 1.0), x0, options=opts,
                       fall=FallLimit(segment_angle_deg=None, hip_height=0.6))
    assert hip.time_to_fall is not None and hip.time_to_fall > 0.1
    # a stiff knee spring holds it up: no fall within 1 s
    stiff = LegDrivers.still(passive={"knee": PassiveJoint((LinearSpringDamper(2000, 50),)),
                                      "ankle": PassiveJoint((LinearSpringDamper(2000, 50),))})
    held = simulate_leg(LEG, stiff, (0.0, 1.0), x0, options=opts,
                        fall=FallLimit(segment_angle_deg=60.0))
    assert held.status == "completed" and held.time_to_fall is None


def test_pd_feedback_holds_the_reference():
    ref_q = np.array([0.0, 0.0, 0.0, 0.1, -0.2])
    fb = JointFeedback(np.arange(3, 5), lambda t: (ref_q, np.zeros(5)),
                       kp=np.array([800.0, 800.0]), kd=np.array([60.0, 60.0]))
    x0 = np.array([0.12, -0.25, 0.0, 0.0])
    sim = simulate_leg(LEG, LegDrivers.still(), (0.0, 1.5), x0, feedback=fb,
                       options=IntegratorOptions(method=Method.RK4, step=1e-3))
    assert np.max(np.abs(sim.q[-1, 3:] - ref_q[3:])) < 0.05


def test_divergence_names_time_and_coordinate_and_keeps_partial():
    drivers = LegDrivers.still(joint_torque=(5e5, -5e5))
    with pytest.raises(SimulationDiverged) as info:
        simulate_leg(LEG, drivers, (0.0, 1.0), np.zeros(4),
                     options=IntegratorOptions(method=Method.EULER, step=0.01))
    message = str(info.value)
    assert "t = " in message and ("ankle" in message or "knee" in message)
    partial = info.value.partial
    assert partial.partial and partial.status == "diverged"
    assert partial.t[-1] < 1.0 and np.all(np.isfinite(partial.q))


def test_bad_inputs():
    opts = IntegratorOptions()
    with pytest.raises(InputError, match="x0"):
        simulate_leg(LEG, LegDrivers.still(), (0, 0.1), np.zeros(3), options=opts)
    with pytest.raises(InputError, match="passive"):
        simulate_leg(LEG, LegDrivers.still(passive={"elbow": PassiveJoint()}), (0, 0.1),
                     np.zeros(4), options=opts)
    with pytest.raises(InputError, match="rod"):
        simulate_leg(load_model("rod"), LegDrivers.still(), (0, 0.1), np.zeros(4),
                     options=opts)
