"""Passive elements act with the clinical sign everywhere (simulator, drivers, fitting).

The expected signs here come from physics, not from the joint-sign table: a passive
element's clinical moment M(theta, rate) pushes the clinical angle toward the element's
neutral angle, so with the model at rest, gravity off and the element alone acting, the
clinical angular acceleration has the sign of M (M_ff^-1 is positive definite). Clinical
angles are computed from segment geometry (the knee flexes when the thigh-shank angle
closes, etc.), independently of the code under test. Then the drivers must subtract
the element's generalised force at the measured state with the same sign (round trip:
inverse dynamics with the elements, forward with the same elements, same motion), and
the fitting problems must use the simulator's torque.
"""

from pathlib import Path

import numpy as np
import pytest

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forces import PassiveTorques, joint_passive_torque, passive_generalized
from predgait.dynamics.forward import simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.dynamics.partitioned import PartitionedSystem
from predgait.dynamics.passive import ExponentialLimits, LinearSpringDamper, PassiveJoint
from predgait.kinematics.clinical import PLANAR_JOINTS
from predgait.models.gait7 import build_gait7_urdf
from predgait.models.loading import load_model, model_from_urdf

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
THETA0 = np.radians(12.0)


def _models():
    leg = load_model("leg", gravity=0.0)
    gait7 = model_from_urdf(build_gait7_urdf(72.6, 1.8034), source="gait7", gravity=0.0)
    return {"leg": leg, "gait7": gait7}


MODELS = _models()


def _positions(model, q):
    import pinocchio as pin

    data = model.pin_model.createData()
    pin.framesForwardKinematics(model.pin_model, data, q)
    return lambda name: data.oMf[model.frame_id(name)].translation


def _segment_pitch(low, high):
    """Pitch about +Y of an upright segment: its top toward +X is positive."""
    d = high - low
    return np.arctan2(d[0], d[2])


def _sole_pitch(heel, toe):
    """Pitch about +Y of the sole line: the toe going down is positive."""
    d = toe - heel
    return np.arctan2(-d[2], d[0])


def clinical_angle(model, joint, q):
    """Clinical angle (rad) from the segment geometry alone, relative to the neutral pose.

    Knee flexion: shank pitch minus thigh pitch (in a squat the knee goes forward: the
    shank tilts forward, the thigh backward). Hip flexion: the thigh swinging forward of
    the trunk (the leg has no trunk: the vertical). Ankle dorsiflexion: shank pitch minus
    sole pitch (toe down = plantarflexion).
    """
    def angles(config):
        at = _positions(model, config)
        sfx = f"_{joint[-1]}" if model.kind == "gait7" else ""
        ankle, knee, hip = at(f"ankle_center{sfx}"), at(f"knee_center{sfx}"), at("hip_center")
        shank, thigh = _segment_pitch(ankle, knee), _segment_pitch(knee, hip)
        trunk = config[2] if model.kind == "gait7" else 0.0  # HAT pitch (the base)
        sole = _sole_pitch(at(f"heel{sfx}"), at(f"toe{sfx}"))
        return {"hip": -(thigh - trunk), "knee": shank - thigh, "ankle": shank - sole}

    import pinocchio as pin

    name = joint.split("_")[0]
    return angles(q)[name] - angles(pin.neutral(model.pin_model))[name]


ELEMENTS = {
    "linear": PassiveJoint((LinearSpringDamper(k=60.0, c=0.0, theta0=THETA0),)),
    "exponential": PassiveJoint((ExponentialLimits(lower=THETA0 - 0.2, upper=THETA0 + 0.2,
                                                   k_lower=3.0, b_lower=10.0,
                                                   k_upper=3.0, b_upper=10.0),)),
}
CASES = [(kind, joint, element) for kind in MODELS for joint in PLANAR_JOINTS[kind]
         for element in ELEMENTS]


def _pose(model, rng):
    q = np.zeros(model.nq)
    q[3:] = rng.normal(0.0, 0.25, model.nq - 3)
    q[2] = rng.normal(0.0, 0.1)
    return q


def _still_system(model, joint, element, q):
    """Everything but the base free, at rest at q, the element alone acting."""
    def motion(t):
        return q.copy(), np.zeros(model.pin_model.nv), np.zeros(model.pin_model.nv)

    return PartitionedSystem(model, range(3, model.pin_model.nv), motion,
                             [PassiveTorques.on(model, {joint: ELEMENTS[element]})])


@pytest.mark.parametrize(("kind", "joint", "element"), CASES)
def test_simulator_passive_moment_has_the_clinical_sign(kind, joint, element):
    model = MODELS[kind]
    rng = np.random.default_rng(hash((kind, joint)) % 2**32)
    for side in (-1.0, 1.0):  # clinical angle above and below the neutral / range
        q = _pose(model, rng)
        # move the joint so that its clinical angle is theta0 +- 0.4 rad
        row = model.coordinate_index(PLANAR_JOINTS[kind][joint].coordinates[-1])
        for _ in range(30):  # Newton on the geometric clinical angle
            target = THETA0 + side * 0.4
            err = clinical_angle(model, joint, q) - target
            dq = np.zeros(model.nq)
            dq[row] = 1e-6
            slope = (clinical_angle(model, joint, q + dq) - clinical_angle(model, joint, q)) / 1e-6
            q[row] -= err / slope
        angle = clinical_angle(model, joint, q)
        assert angle == pytest.approx(THETA0 + side * 0.4, abs=1e-6)
        moment = float(ELEMENTS[element].moment(angle, 0.0))
        assert np.sign(moment) == -side  # the element restores toward its range
        system = _still_system(model, joint, element, q)
        a_free = system(0.0, system.state(q, np.zeros(model.pin_model.nv)))[model.pin_model.nv - 3:]
        dt = 1e-4
        q_next = q.copy()
        q_next[3:] += 0.5 * a_free * dt ** 2
        accel = (clinical_angle(model, joint, q_next) - angle) / (0.5 * dt ** 2)
        assert np.sign(accel) == np.sign(moment)


@pytest.mark.parametrize(("kind", "joint", "element"), CASES)
def test_drivers_offset_is_the_simulator_force(kind, joint, element):
    """The drivers' measured-state passive force (subtracted) equals the simulator's."""
    model = MODELS[kind]
    rng = np.random.default_rng(7)
    q, v = _pose(model, rng), rng.normal(0.0, 1.0, model.pin_model.nv)
    forces = PassiveTorques.on(model, {joint: ELEMENTS[element]})
    offset = passive_generalized(model, {joint: ELEMENTS[element]}, q, v)[0]
    np.testing.assert_allclose(offset, forces(0.0, q, v, None), rtol=1e-12, atol=1e-12)
    assert np.any(offset != 0.0)


@pytest.mark.parametrize("element", list(ELEMENTS))
@pytest.mark.parametrize("joint", ["ankle", "knee"])
def test_fitting_torque_is_the_simulator_torque(joint, element):
    model = MODELS["leg"]
    rng = np.random.default_rng(5)
    q, v = _pose(model, rng), rng.normal(0.0, 1.0, model.pin_model.nv)
    row = model.coordinate_index(joint)
    fitting = joint_passive_torque(model, joint, ELEMENTS[element])
    simulator = PassiveTorques.on(model, {joint: ELEMENTS[element]})(0.0, q, v, None)
    assert float(fitting(q[row], v[row])) == pytest.approx(simulator[row], rel=1e-12)


def test_fitting_symbolic_knee_is_the_simulator_knee():
    """The knee fit's CasADi passive torque equals the simulator's (same table)."""
    import casadi as cs

    from predgait.problems.fitting import _knee_passive

    model = MODELS["leg"]
    law = _knee_passive(model, cs.DM([40.0, 3.0, THETA0]))
    element = PassiveJoint((LinearSpringDamper(40.0, 3.0, THETA0),))
    for qk, vk in ((-0.6, 1.0), (0.1, -2.0)):
        q, v = np.zeros(5), np.zeros(5)
        q[4], v[4] = qk, vk
        expected = PassiveTorques.on(model, {"knee": element})(0.0, q, v, None)[4]
        assert float(law(qk, vk)) == pytest.approx(expected, rel=1e-12)


@pytest.fixture(scope="module")
def subject01():
    return bundled_inverse("right")


PASSIVE = {"ankle": PassiveJoint((LinearSpringDamper(80.0, 2.0, np.radians(-8.0)),
                                  ExponentialLimits(lower=-0.5, upper=0.4))),
           "knee": PassiveJoint((LinearSpringDamper(40.0, 3.0, np.radians(15.0)),
                                 ExponentialLimits())),
           "hip": PassiveJoint((LinearSpringDamper(60.0, 4.0, np.radians(10.0)),))}


def _synthetic_inverse(model, duration=0.2, rate=1000.0):
    """Smooth leg motion with a hip load; joint torques by RNEA (inverse dynamics)."""
    import pinocchio as pin

    t = np.arange(0.0, duration + 0.5 / rate, 1.0 / rate)
    amp = np.array([0.05, 0.02, 0.1, 0.3, -0.5])
    freq = np.array([1.0, 2.0, 1.5, 2.5, 3.0])
    off = np.array([0.0, 0.0, 0.05, 0.1, -0.3])
    w = 2 * np.pi * freq
    q = off + amp * np.sin(np.outer(t, w))
    v = amp * w * np.cos(np.outer(t, w))
    a = -amp * w ** 2 * np.sin(np.outer(t, w))
    hip_force = np.column_stack([20 * np.sin(3 * t), 0 * t, -300 + 30 * np.cos(2 * t)])
    hip_moment = np.column_stack([0 * t, 10 * np.sin(5 * t), 0 * t])
    pm, data = model.pin_model, model.pin_model.createData()
    tau = np.zeros_like(q)
    fid = model.frame_id("hip_center")
    for k in range(t.size):
        jac = pin.computeFrameJacobian(pm, data, q[k], fid, pin.LOCAL_WORLD_ALIGNED)
        tau[k] = pin.rnea(pm, data, q[k], v[k], a[k]) - jac[:3].T @ hip_force[k] \
            - jac[3:].T @ hip_moment[k]
    from types import SimpleNamespace

    return SimpleNamespace(time=t, q=q, v=v, a=a, tau=tau, hip_force=hip_force,
                           hip_moment=hip_moment, model=model)


def test_round_trip_inverse_then_forward_with_passive_elements():
    """Noise-free motion: inverse dynamics (total moments), drivers with the elements
    subtracted at the measured motion, forward with the same elements: the motion comes
    back per joint to 1e-7 rad over 0.1 s, and the ground reaction equals the one
    without elements (the hip element is reacted by the foot either way)."""
    inverse = _synthetic_inverse(load_model("leg"))
    options = IntegratorOptions(method=Method.RK4, step=5e-4)
    t = inverse.time[inverse.time <= 0.1 + 1e-12]
    runs = {}
    for name, drivers in (("bare", LegDrivers.from_inverse(inverse)),
                          ("elements", LegDrivers.from_inverse(inverse, passive=PASSIVE))):
        runs[name] = simulate_leg(inverse.model, drivers, (0.0, 0.1), options=options,
                                  t_eval=t)
        for i, joint in ((3, "ankle"), (4, "knee")):
            err = np.max(np.abs(runs[name].q[:, i] - inverse.q[: t.size, i]))
            assert err < 1e-7, f"{name}: {joint} off by {err:.2e} rad"
    np.testing.assert_allclose(runs["elements"].grf, runs["bare"].grf, rtol=1e-6, atol=1e-4)
    # the elements really act: added to the drive instead, they change the motion
    added = simulate_leg(inverse.model,
                         LegDrivers.from_inverse(inverse).with_passive(PASSIVE), (0.0, 0.1),
                         options=options, t_eval=t)
    assert np.max(np.abs(added.q[:, 3:] - inverse.q[: t.size, 3:])) > np.radians(0.5)


def test_subject01_with_passive_elements_tracks_like_without(subject01):
    """Subject01, right leg: the elements given to the drivers leave the driven leg on
    the measured motion for 0.1 s (they act on its deviation only)."""
    options = IntegratorOptions(method=Method.RK4, step=1e-3)
    t = subject01.time[(subject01.time >= 0.0) & (subject01.time <= 0.1)]
    span = (float(t[0]), float(t[-1]))
    measured = subject01.q[np.searchsorted(subject01.time, t)]
    with_elements = simulate_leg(subject01.model,
                                 LegDrivers.from_inverse(subject01, passive=PASSIVE), span,
                                 options=options, t_eval=t)
    assert np.max(np.abs(with_elements.q[:, 3:] - measured[:, 3:])) < np.radians(0.5)
    added = simulate_leg(subject01.model,
                         LegDrivers.from_inverse(subject01).with_passive(PASSIVE), span,
                         options=options, t_eval=t)
    assert np.max(np.abs(added.q[:, 3:] - measured[:, 3:])) > np.radians(1.0)
