"""The thesis' own equations (Appendix A; eqs. 3.2.29-3.2.34) against predgait.dynamics.forward.

Appendix A: 21 linear equations in 21 unknowns at each instant: 9 Newton-Euler equations
(3 per segment, eqs. 3.3.3-3.3.5), 4 hinge constraints at the acceleration level (ankle,
knee; eqs. 3.3.6-3.3.8), 3 moment drivers (ankle, knee, hip), 2 hip-force drivers and 3
foot-motion drivers. Written here in OUR conventions: lab frame X forward, Z up, angles
and moments about +Y (a positive pitch tilts a segment's top toward +X), and the joint
forces in LAB components rather than the distal segment's frame. Expressing the joint
forces in segment frames (the thesis) is a rotation of 4 unknowns and changes neither
the accelerations nor the ground reaction compared here. The moment of a force F at
arm r about +Y is r_z F_x - r_x F_z. The printed matrix in the thesis' Appendix A is
partly illegible in our copy (duplicated/missing entries), so the system is derived
again from 3.3.3-3.3.8 rather than transcribed.

Unknowns x (21): foot, shank, thigh COM accelerations and angular accelerations
(9), ground force F_G (2) and moment M_G about the heel (1), the shank-on-foot ankle
force F_A (2), thigh-on-shank knee force F_K (2), pelvis-on-thigh hip force F_H (2),
ankle torque tau_a and knee torque tau_k (on the distal segment, about +Y) and hip
moment M_H (3).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from predgait.dynamics.drivers import LegDrivers, constant
from predgait.dynamics.forward import (
    ForceFrame,
    LegSystem,
    RodForces,
    rod_system,
)
from predgait.models.loading import load_model


def cross_y(r, f):
    """Moment about +Y of force (f_x, f_z) at arm (r_x, r_z)."""
    return r[1] * f[0] - r[0] * f[1]


def thesis_leg_system(model, q, v, a_base, tau_a, tau_k, hip_force, hip_moment):
    """(A, B) of the 21 x 21 system at one state; see the module docstring."""
    pm = model.pin_model
    data = pm.createData()
    pin.forwardKinematics(pm, data, q)
    pin.updateFramePlacements(pm, data)
    xz = [0, 2]
    body = {"f": 1, "l": 2, "t": 3}
    com = {s: data.oMi[j].act(pm.inertias[j].lever)[xz] for s, j in body.items()}
    mass = {s: pm.inertias[j].mass for s, j in body.items()}
    inertia = {s: pm.inertias[j].inertia[1, 1] for s, j in body.items()}
    point = {n: data.oMf[model.frame_id(f)].translation[xz]
             for n, f in (("A", "ankle_center"), ("K", "knee_center"), ("Hip", "hip_center"),
                          ("H", "heel"))}
    omega = {"f": v[2], "l": v[2] + v[3], "t": v[2] + v[3] + v[4]}
    g = model.gravity
    A, B = np.zeros((21, 21)), np.zeros(21)
    acc = {"f": 0, "l": 3, "t": 6}
    FG, MG, FA, FK, FH, TA, TK, MH = 9, 11, 12, 14, 16, 18, 19, 20

    def force_terms(row, col, sign, arm):
        """Add sign * F (at arm) to the x, z and moment rows of one segment."""
        A[row, col] -= sign
        A[row + 1, col + 1] -= sign
        A[row + 2, col] -= sign * arm[1]      # d(cross_y)/dF_x = r_z
        A[row + 2, col + 1] -= -sign * arm[0]  # d(cross_y)/dF_z = -r_x

    for s, r in acc.items():  # m a - sum F = -m g e_z ; I alpha - sum M = 0 (3.3.3-3.3.5)
        A[r, r], A[r + 1, r + 1], A[r + 2, r + 2] = mass[s], mass[s], inertia[s]
        B[r + 1] = -mass[s] * g
    force_terms(0, FG, 1.0, point["H"] - com["f"])
    A[2, MG] -= 1.0
    force_terms(0, FA, 1.0, point["A"] - com["f"])
    A[2, TA] += 1.0                                      # foot gets -tau_a
    force_terms(3, FA, -1.0, point["A"] - com["l"])
    force_terms(3, FK, 1.0, point["K"] - com["l"])
    A[5, TA] -= 1.0
    A[5, TK] += 1.0                                      # shank: +tau_a - tau_k
    force_terms(6, FK, -1.0, point["K"] - com["t"])
    force_terms(6, FH, 1.0, point["Hip"] - com["t"])
    A[8, TK] -= 1.0
    A[8, MH] -= 1.0                                      # thigh: +tau_k + M_H
    # Hinge constraints (3.3.6-3.3.8): a_c + alpha (r_z, -r_x) - omega^2 r equal on both
    # segments at the joint; omega^2 terms go to B.
    row = 9
    for joint, (a_seg, b_seg) in (("A", ("f", "l")), ("K", ("l", "t"))):
        for sign, s in ((1.0, a_seg), (-1.0, b_seg)):
            r = point[joint] - com[s]
            A[row, acc[s]] += sign
            A[row, acc[s] + 2] += sign * r[1]
            A[row + 1, acc[s] + 1] += sign
            A[row + 1, acc[s] + 2] += -sign * r[0]
            B[row] += sign * omega[s] ** 2 * r[0]
            B[row + 1] += sign * omega[s] ** 2 * r[1]
        row += 2
    # Drivers: moments (14-16), hip force (17-18), foot motion (19-21).
    for col, value in ((TA, tau_a), (TK, tau_k), (MH, hip_moment[1]), (FH, hip_force[0]),
                       (FH + 1, hip_force[2])):
        A[row, col], B[row] = 1.0, value
        row += 1
    r = com["f"] - point["A"]
    foot_acc = (np.array(a_base[:2]) + a_base[2] * np.array([r[1], -r[0]])
                - omega["f"] ** 2 * r)
    for col, value in ((0, foot_acc[0]), (1, foot_acc[1]), (2, a_base[2])):
        A[row, col], B[row] = 1.0, value
        row += 1
    assert row == 21
    return A, B


@pytest.mark.parametrize("seed", range(6))
def test_appendix_a_equals_pinocchio(seed):
    """Shank/thigh accelerations and the ground reaction agree at random states."""
    rng = np.random.default_rng(seed)
    model = load_model("leg")
    q = np.concatenate([rng.uniform(-0.5, 0.5, 2), rng.uniform(-0.4, 0.4, 1),
                        rng.uniform(-0.5, 0.5, 1), rng.uniform(-1.2, 0.1, 1)])
    v = rng.normal(0, 2.0, 5)
    a_base = rng.normal(0, 3.0, 3)
    tau = rng.normal(0, 40.0, 2)
    hip_f, hip_m = np.array([rng.normal(0, 100), 0, rng.normal(-500, 100)]), \
        np.array([0, rng.normal(0, 40), 0])
    drivers = LegDrivers(prescribed_q=constant(q[:3]), prescribed_qd=constant(v[:3]),
                         prescribed_qdd=constant(a_base), joint_torque=constant(tau),
                         hip_force=constant(hip_f), hip_moment=constant(hip_m))
    system = LegSystem(model, drivers)
    x = np.concatenate([q[3:], v[3:]])
    a = system(0.0, x)[2:]
    grf, _, m_heel = system.ground_reaction(0.0, x)
    A, B = thesis_leg_system(model, q, v, a_base, tau[0], tau[1], hip_f, hip_m)
    sol = np.linalg.solve(A, B)
    alpha_f, alpha_l, alpha_t = sol[2], sol[5], sol[8]
    np.testing.assert_allclose([alpha_l - alpha_f, alpha_t - alpha_l], a, rtol=1e-9,
                               atol=1e-8)
    np.testing.assert_allclose(sol[9:11], grf[[0, 2]], rtol=1e-9, atol=1e-7)
    np.testing.assert_allclose(sol[11], m_heel, rtol=1e-9, atol=1e-7)


def test_appendix_a_system_is_not_trivially_satisfied():
    """Perturbing one inertia in the thesis system changes the answer (the check can fail)."""
    model = load_model("leg")
    q, v = np.array([0, 0, 0.1, 0.2, -0.4]), np.array([0, 0, 0.3, -1.0, 2.0])
    A, B = thesis_leg_system(model, q, v, np.zeros(3), 5.0, -3.0, np.zeros(3), np.zeros(3))
    A2 = A.copy()
    A2[5, 5] *= 1.1
    assert not np.allclose(np.linalg.solve(A, B)[5], np.linalg.solve(A2, B)[5])


def thesis_rod(model, q, forces, t, frame):
    """Thesis eqs. 3.2.29-3.2.34 in our sign convention.

    The printed moment equations (3.2.31, 3.2.34) give each end force the opposite
    moment sign to the cross product with theta tilting the top toward +X (which
    3.2.32-3.2.33 use); we use the cross product: for end A at d_A along the rod axis,
    inertial: + d_A cos(theta) F_AX - d_A sin(theta) F_AZ; body: + d_A F_Ax. In 3.2.34
    the first "F_Bx" is read as F_Ax (a misprint: the top's moment arm is L2 - L1).
    """
    pm = model.pin_model
    m, inertia = pm.inertias[1].mass, pm.inertias[1].inertia[1, 1]
    d_a = pm.frames[model.frame_id("top")].placement.translation[2]
    d_b = -pm.frames[model.frame_id("bottom")].placement.translation[2]
    th, g = q[2], model.gravity
    fa, fb, ma = forces.top_force(t), forces.bottom_force(t), forces.top_moment(t)
    c, s = np.cos(th), np.sin(th)
    if frame is ForceFrame.INERTIAL:
        return np.array([(fa[0] + fb[0]) / m, (fa[1] + fb[1] - m * g) / m,
                         (ma + d_a * c * fa[0] - d_a * s * fa[1] - d_b * c * fb[0]
                          + d_b * s * fb[1]) / inertia])
    sx, sz = fa[0] + fb[0], fa[1] + fb[1]
    return np.array([(sx * c + sz * s) / m, (-sx * s + sz * c - m * g) / m,
                     (ma + d_a * fa[0] - d_b * fb[0]) / inertia])


@pytest.mark.parametrize("frame", list(ForceFrame), ids=lambda f: f.value)
def test_rod_equations_equal_pinocchio(frame):
    rng = np.random.default_rng(3)
    model = load_model("rod")
    for _ in range(5):
        q, v = rng.normal(0, 0.5, 3), rng.normal(0, 2, 3)
        moment = float(rng.normal(0, 2))
        forces = RodForces(top_force=constant(rng.normal(0, 10, 2)),
                           top_moment=lambda t, m=moment: m,
                           bottom_force=constant(rng.normal(0, 10, 2)))
        got = rod_system(model, forces, frame)(0.0, np.concatenate([q, v]))[3:]
        np.testing.assert_allclose(got, thesis_rod(model, q, forces, 0.0, frame),
                                   rtol=1e-10, atol=1e-10)
