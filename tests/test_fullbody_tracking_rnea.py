"""The symbolic RNEA base rows of the whole-body tracking node (issue 27 item 5).

Known answer: Pinocchio's RNEA(q, v, a)[0:6] and its frame kinematics at random states
of the 35-DOF body, gravity included; the symbolic pass must be far cheaper than the
mass-matrix form it replaced (561k instructions for the node's Hessian); a joint type
the pass does not handle is refused with a message naming it.
"""

import casadi as cs
import numpy as np
import pinocchio as pin
import pytest

from predgait.errors import InputError
from predgait.models.loading3d import load_fullbody
from predgait.problems.fullbody_tracking_rnea import base_rows
from predgait.problems.fullbody_tracking_stage import POINTS, stage_functions


def _symbolic(pm, frames):
    rot, pos = cs.SX.sym("R", 3, 3), cs.SX.sym("p", 3)
    s, v, a = cs.SX.sym("s", pm.nv - 6), cs.SX.sym("v", pm.nv), cs.SX.sym("a", pm.nv)
    wrench, positions, velocities = base_rows(pm, rot, pos, s, v, a, frames)
    return cs.Function("rows", [rot, pos, s, v, a],
                       [wrench, cs.horzcat(*positions), cs.horzcat(*velocities)])


def test_base_rows_equal_pinocchio_rnea():
    pm = load_fullbody().pin_model
    data = pm.createData()
    rows = _symbolic(pm, POINTS)
    rng = np.random.default_rng(3)
    for _ in range(4):
        q = pin.randomConfiguration(pm, -np.ones(36), np.ones(36))
        q[7:] = rng.uniform(-1.0, 1.0, 29)
        v, a = rng.uniform(-3, 3, 35), rng.uniform(-10, 10, 35)
        placement = pin.XYZQUATToSE3(q[:7])
        wrench, xyz, vel = (np.asarray(x) for x in rows(
            placement.rotation, placement.translation, q[7:], v, a))
        np.testing.assert_allclose(wrench.ravel(), pin.rnea(pm, data, q, v, a)[:6],
                                   rtol=1e-10, atol=1e-8)
        pin.forwardKinematics(pm, data, q, v)
        pin.updateFramePlacements(pm, data)
        for i, name in enumerate(POINTS):
            fid = pm.getFrameId(name)
            np.testing.assert_allclose(xyz[:, i], data.oMf[fid].translation, atol=1e-12)
            lab = pin.getFrameVelocity(pm, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            np.testing.assert_allclose(vel[:, i], lab.linear, atol=1e-10)


def test_node_hessian_is_cheap():
    # ADAM's mass-matrix rows gave 561 096 instructions; the RNEA pass 148 608.
    stage = stage_functions(load_fullbody(), POINTS)
    assert stage.node_hessian.n_instructions() < 200_000


def test_other_joint_types_are_refused():
    pm = pin.Model()
    root = pm.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")
    slide = pm.addJoint(root, pin.JointModelPX(), pin.SE3.Identity(), "slide")
    pm.appendBodyToJoint(slide, pin.Inertia.FromSphere(1.0, 0.1), pin.SE3.Identity())
    with pytest.raises(InputError, match="slide"):
        _symbolic(pm, ())
