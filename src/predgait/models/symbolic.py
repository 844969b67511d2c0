"""CasADi dynamics of a predgait model, built by ADAM from the same URDF as Pinocchio.

ADAM gives a floating base (6 velocities); predgait's base moves in the sagittal plane
only. In ADAM's mixed representation the base velocity is (linear velocity of the base
origin, angular velocity), both in the world frame, so with the planar coordinates
``q_b = (x, z, pitch)`` the 6-D base velocity is ``S @ qd_b`` with a constant selection
``S`` (rows vx, vz, wy). Hence ``M = S^T M6 S`` and ``h = S^T h6`` exactly, and the
accelerations are the plain second derivatives, as with Pinocchio's PX-PZ-RY root.

All functions are named CasADi functions with named inputs and outputs (STYLE.md 4):
``mass_matrix(q) -> M``, ``bias_force(q, v) -> h`` (Coriolis, centrifugal, gravity),
``forward_dynamics(q, v, tau) -> a`` and ``frame_position(q) -> p`` per frame.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as cs
import numpy as np

from predgait.models.adam_import import kindyn_class, representations
from predgait.models.loading import Model

#: Rows of ADAM's 6-D mixed base velocity (vx, vy, vz, wx, wy, wz) kept by the plane.
_PLANAR_ROWS = (0, 2, 4)


def _selection(n_joints: int) -> np.ndarray:
    """(6 + n, 3 + n) matrix mapping planar velocities to ADAM's velocities."""
    sel = np.zeros((6 + n_joints, 3 + n_joints))
    for col, row in enumerate(_PLANAR_ROWS):
        sel[row, col] = 1.0
    sel[6:, 3:] = np.eye(n_joints)
    return sel


def _joint_part(vector: cs.SX) -> cs.SX:
    """Joint entries of a planar vector; ADAM 0.5 needs at least one even with no joint."""
    return vector[3:] if vector.shape[0] > 3 else cs.SX.zeros(1)


def base_transform(q_base: cs.SX) -> cs.SX:
    """4x4 world-from-base transform of a planar base (x, z, pitch about +Y)."""
    x, z, pitch = q_base[0], q_base[1], q_base[2]
    c, s = cs.cos(pitch), cs.sin(pitch)
    return cs.vertcat(
        cs.horzcat(c, 0, s, x),
        cs.horzcat(0, 1, 0, 0),
        cs.horzcat(-s, 0, c, z),
        cs.horzcat(0, 0, 0, 1),
    )


@dataclass(frozen=True, eq=False)
class SymbolicModel:
    """CasADi functions of a planar model (see module docstring)."""

    nq: int
    mass_matrix: cs.Function
    bias_force: cs.Function
    forward_dynamics: cs.Function
    kindyn: object  # adam.casadi.KinDynComputations

    def frame_position(self, frame: str) -> cs.Function:
        """``frame_position(q) -> p``: world position of a frame or link, m (3,)."""
        return _frame_position(self, frame)


@functools.lru_cache(maxsize=64)
def _frame_position(model: SymbolicModel, frame: str) -> cs.Function:
    q = cs.SX.sym("q", model.nq)
    transform = model.kindyn.forward_kinematics(frame, base_transform(q[:3]), _joint_part(q))
    return cs.Function(f"position_{frame}", [q], [transform[:3, 3]], ["q"], ["p"])


@functools.lru_cache(maxsize=16)
def symbolic_model(model: Model) -> SymbolicModel:
    """Build (and cache) the ADAM/CasADi dynamics of ``model`` with its gravity."""
    joints = list(model.joint_names)
    gravity = np.array([0.0, 0.0, -model.gravity, 0.0, 0.0, 0.0])
    kindyn = kindyn_class("casadi")(model.urdf, joints, gravity=gravity)
    kindyn.set_frame_velocity_representation(representations().MIXED_REPRESENTATION)
    n_joints = len(joints)
    sel = _selection(n_joints)
    q = cs.SX.sym("q", 3 + n_joints)
    v = cs.SX.sym("qd", 3 + n_joints)
    tau = cs.SX.sym("tau", 3 + n_joints)
    transform = base_transform(q[:3])
    velocity6 = sel @ v
    mass6 = kindyn.mass_matrix(transform, _joint_part(q))[: 6 + n_joints, : 6 + n_joints]
    bias6 = kindyn.bias_force(transform, _joint_part(q), velocity6[:6],
                              _joint_part(cs.vertcat(v[:3], velocity6[6:])))[: 6 + n_joints]
    mass = sel.T @ mass6 @ sel
    bias = sel.T @ bias6
    a = cs.solve(mass, tau - bias)
    return SymbolicModel(
        nq=3 + n_joints,
        mass_matrix=cs.Function("mass_matrix", [q], [mass], ["q"], ["M"]),
        bias_force=cs.Function("bias_force", [q, v], [bias], ["q", "qd"], ["h"]),
        forward_dynamics=cs.Function("forward_dynamics", [q, v, tau], [a],
                                     ["q", "qd", "tau"], ["qdd"]),
        kindyn=kindyn,
    )
