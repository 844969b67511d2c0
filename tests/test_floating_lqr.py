"""Bryson's-rule weights of the whole-body LQR (dynamics/floating_lqr.py) on known answers.

A joint alone (I x'' = u) under x^2 / angle^2 + u^2 / torque^2 and no rate weight has the
LQR gains Kp = torque / angle and Kd = sqrt(2 I Kp) (damping ratio 1/sqrt(2)), whatever
its inertia: the foot (0.005 kg m^2) and the thigh get the same stiffness.
"""

from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import solve_continuous_are

from predgait.dynamics.floating_lqr import FLOATING_WEIGHTS, floating_matrices


@pytest.mark.parametrize("inertia", [0.005, 1.5])   # kg m^2: a foot, a thigh
def test_joint_alone_gets_the_double_integrators_gains(inertia):
    weights = replace(FLOATING_WEIGHTS, angle_deg=5.0, torque_n_m=25.0)
    q, r = floating_matrices(weights, 3)                   # 6 root rows + 3 joints: nv = 9
    nv, joint = 9, 7                              # the middle joint
    a_mat = np.array([[0.0, 1.0], [0.0, 0.0]])
    b_mat = np.array([[0.0], [1.0 / inertia]])
    block = np.ix_([joint, nv + joint], [joint, nv + joint])
    s = solve_continuous_are(a_mat, b_mat, q[block], r[1:2, 1:2])
    kp, kd = (b_mat.T @ s / r[1, 1]).ravel()
    assert kp == pytest.approx(25.0 / np.radians(5.0), rel=1e-9)
    assert kd == pytest.approx(np.sqrt(2 * inertia * kp), rel=1e-9)
    assert np.all(np.diag(q)[nv + 6:] == 0.0)   # no weight on the joint rates
    assert np.all(np.diag(q)[nv:nv + 6] > 0.0)  # the pelvis keeps its rate weight


def test_sole_height_weight_is_the_points_height_change():
    """dq^T W dq = sum_i (dz_i / height)^2 for a small tangent step dq (round trip through
    pin.integrate and the frames' placements), in a pitched and rolled pose."""
    import pinocchio as pin

    from predgait.dynamics.floating_lqr import sole_height_weights
    from predgait.models.fullbody import CONTACTS
    from predgait.models.loading3d import load_fullbody

    model = load_fullbody()
    pm, data = model.pin_model, model.pin_model.createData()
    rng = np.random.default_rng(3)
    quat = pin.Quaternion(pin.rpy.rpyToMatrix(0.2, -0.3, 1.0)).coeffs()
    q = np.concatenate([[0.1, -0.2, 0.9], quat, rng.uniform(-0.4, 0.4, model.nv - 6)])
    weight = sole_height_weights(model, q, CONTACTS, 0.002)
    step = 1e-6 * rng.standard_normal(model.nv)

    def heights(config):
        pin.framesForwardKinematics(pm, data, config)
        return np.array([data.oMf[model.frame_id(p)].translation[2] for p in CONTACTS])

    dz = heights(pin.integrate(pm, q, step)) - heights(q)
    assert step @ weight @ step == pytest.approx(np.sum((dz / 0.002) ** 2), rel=1e-4)
