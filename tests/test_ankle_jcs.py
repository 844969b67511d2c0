"""The ankle's joint coordinate system (kinematics/ankle_jcs.py): known answers.

Cross-implementation: two Pinocchio chains from the shank to the foot, the model's Cardan
X-Y-Z and the JCS's Y-X-Z (the ISB sequence: flexion about the shank's medio-lateral
axis, then the floating axis, then the foot's vertical axis), put the foot in the same
orientation and carry the same external wrench; the JCS angles and moments converted
from the X-Y-Z chain must equal the Y-X-Z chain's coordinates and generalised forces
(Pinocchio's RNEA, not this module, computes both). Then the defining properties: a pure
moment about the shank's medio-lateral axis is all dorsiflexion, none of it inversion,
whatever the pose (the leak the model's Cardan X shows when the foot is inverted).
"""

import numpy as np
import pinocchio as pin
import pytest

from predgait.kinematics.ankle_jcs import (
    ankle_moment,
    in_jcs,
    jcs_angles,
    jcs_axes,
    jcs_moments,
)

RNG = np.random.default_rng(27)


def chain(order: str) -> pin.Model:
    """Revolute joints about ``order``'s axes in turn; a unit-mass foot on the last."""
    model = pin.Model()
    joint = 0
    for axis in order:
        joint = model.addJoint(joint, {"x": pin.JointModelRX(), "y": pin.JointModelRY(),
                                       "z": pin.JointModelRZ()}[axis], pin.SE3.Identity(),
                               f"r{axis}")
    model.appendBodyToJoint(joint, pin.Inertia.Random(), pin.SE3.Identity())
    model.gravity.linear = np.zeros(3)
    return model


def generalised_forces(model: pin.Model, q: np.ndarray, wrench: pin.Force) -> np.ndarray:
    """Joint torques that hold the foot still against an external wrench (world frame)."""
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    fext = pin.StdVec_Force()
    for _ in range(model.njoints):
        fext.append(pin.Force.Zero())
    fext[model.njoints - 1] = data.oMi[model.njoints - 1].actInv(wrench)
    return pin.rnea(model, data, q, np.zeros(3), np.zeros(3), fext)


def rotation(model: pin.Model, q: np.ndarray) -> np.ndarray:
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    return data.oMi[model.njoints - 1].rotation


@pytest.mark.parametrize("case", range(8))
def test_jcs_equals_a_yxz_chain(case):
    xyz, yxz = chain("xyz"), chain("yxz")
    q_xyz = RNG.uniform(-0.6, 0.6, 3)
    wrench = pin.Force(RNG.normal(0, 100, 3), RNG.normal(0, 50, 3))
    angles = jcs_angles(q_xyz[None])[0]          # (alpha, beta, gamma) in x, y, z slots
    q_yxz = angles[[1, 0, 2]]
    np.testing.assert_allclose(rotation(yxz, q_yxz), rotation(xyz, q_xyz), atol=1e-12)
    tau_xyz = generalised_forces(xyz, q_xyz, wrench)
    tau_yxz = generalised_forces(yxz, q_yxz, wrench)
    moments = jcs_moments(q_xyz[None], tau_xyz[None])[0]
    np.testing.assert_allclose(moments[[1, 0, 2]], tau_yxz, atol=1e-9)
    # The moment itself: the wrench's moment about the (common) joint centre, negated.
    np.testing.assert_allclose(ankle_moment(q_xyz[None], tau_xyz[None])[0], -wrench.angular,
                               atol=1e-9)


def test_floating_axis_is_perpendicular_to_shank_ml_and_foot_vertical():
    q = RNG.uniform(-0.6, 0.6, (20, 3))
    axes = jcs_axes(q)
    e2, e1, e3 = axes[:, :, 0], axes[:, :, 1], axes[:, :, 2]
    np.testing.assert_allclose(np.einsum("ni,ni->n", e2, e1), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("ni,ni->n", e2, e3), 0.0, atol=1e-12)
    assert (e2[:, 0] > 0).all()                  # forward, as the shank's X


def test_a_sagittal_moment_is_no_inversion_in_any_pose():
    """100 N m about the shank's medio-lateral axis: JCS 100 dorsiflexion, 0 inversion;
    the model's Cardan X-Y-Z reads it as 100 cos(a) about its tilted Y."""
    q = np.array([[0.25, -0.3, 0.14], [-0.2, 0.35, -0.12], [0.0, 0.4, 0.2]])
    model = chain("xyz")
    wrench = pin.Force(np.zeros(3), np.array([0.0, -100.0, 0.0]))  # external on the foot
    tau = np.array([generalised_forces(model, row, wrench) for row in q])
    moments = jcs_moments(q, tau)
    np.testing.assert_allclose(moments[:, 1], 100.0, atol=1e-9)      # about e1
    np.testing.assert_allclose(moments[:, 0], 0.0, atol=1e-9)        # about e2
    np.testing.assert_allclose(tau[:, 1], 100.0 * np.cos(q[:, 0]), atol=1e-9)


def test_in_jcs_replaces_only_the_ankles():
    names = ("hip_r_x", "ankle_r_x", "ankle_r_y", "ankle_r_z", "ankle_l_x", "ankle_l_y",
             "ankle_l_z", "elbow_r")
    q = RNG.uniform(-0.5, 0.5, (4, len(names)))
    tau = RNG.normal(0, 30, (4, len(names)))
    q_out, tau_out = in_jcs(names, q, tau)
    for cols in ([1, 2, 3], [4, 5, 6]):
        np.testing.assert_allclose(q_out[:, cols], jcs_angles(q[:, cols]))
        np.testing.assert_allclose(tau_out[:, cols], jcs_moments(q[:, cols], tau[:, cols]))
    np.testing.assert_array_equal(q_out[:, [0, 7]], q[:, [0, 7]])
    np.testing.assert_array_equal(tau_out[:, [0, 7]], tau[:, [0, 7]])
    # At the neutral ankle the JCS and the Cardan X-Y-Z axes coincide.
    q[:, 1:7] = 0.0
    q_out, tau_out = in_jcs(names, q, tau)
    np.testing.assert_allclose(q_out, q, atol=1e-12)
    np.testing.assert_allclose(tau_out, tau, atol=1e-9)
