"""The 3D ankle's clinical angles and moments in the joint coordinate system (ISB).

The model's ankle (:mod:`predgait.models.fullbody`) is a Cardan X-Y-Z chain from the shank
to the foot, inversion first: R = Rx(a) Ry(b) Rz(c). Its X axis is fixed in the shank, so
a foot rotated about the shank (toe-out) or plantarflexed tilts it out of the foot's frontal
plane and the large plantarflexion moment leaks into "inversion". Gait labs report the
ankle complex in the joint coordinate system of Grood & Suntay (1983) instead, as the ISB
recommends (Wu et al. 2002, J Biomech 35:543-548, section 3.3.2):

* e1, fixed in the shank: its medio-lateral axis (the model's Y): dorsiflexion;
* e3, fixed in the foot: its vertical axis (the model's Z): internal rotation;
* e2 = e1 x e3 / |e1 x e3|, the floating axis, perpendicular to both: inversion. It is the
  Cardan X after the sagittal rotation, i.e. the X of the sequence Y-X-Z,
  R = Ry(beta) Rx(alpha) Rz(gamma).

Moments: M, the net moment the shank applies to the foot about the ankle centre, follows
from the chain's generalised forces (tau_i = M . b_i on the X-Y-Z axes b_i); its JCS
components are M . e1, M . e2, M . e3, the generalised forces of the Y-X-Z chain (the
virtual work of M on each JCS rotation). Both are returned in the model's coordinate slots
and signs (x: about e2, y: about e1, z: about e3), so the one sign table,
:data:`predgait.kinematics.clinical.CLINICAL_3D`, turns them into clinical values.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Ankle coordinates of the whole body, per side, in the model's X, Y, Z order.
ANKLES = {side: (f"ankle_{side}_x", f"ankle_{side}_y", f"ankle_{side}_z") for side in "rl"}


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    one, zero = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([one, zero, zero], -1), np.stack([zero, c, -s], -1),
                     np.stack([zero, s, c], -1)], -2)


def _ry(b):
    c, s = np.cos(b), np.sin(b)
    one, zero = np.ones_like(b), np.zeros_like(b)
    return np.stack([np.stack([c, zero, s], -1), np.stack([zero, one, zero], -1),
                     np.stack([-s, zero, c], -1)], -2)


def _rz(c_):
    c, s = np.cos(c_), np.sin(c_)
    one, zero = np.ones_like(c_), np.zeros_like(c_)
    return np.stack([np.stack([c, -s, zero], -1), np.stack([s, c, zero], -1),
                     np.stack([zero, zero, one], -1)], -2)


def cardan_xyz_rotation(q_xyz: np.ndarray) -> np.ndarray:
    """(n, 3, 3): the foot frame in the shank frame, R = Rx(a) Ry(b) Rz(c).

    Args:
        q_xyz: (n, 3) rad, the model's ankle coordinates (x, y, z).
    """
    q_xyz = np.asarray(q_xyz, dtype=float)
    return _rx(q_xyz[:, 0]) @ _ry(q_xyz[:, 1]) @ _rz(q_xyz[:, 2])


def cardan_xyz_axes(q_xyz: np.ndarray) -> np.ndarray:
    """(n, 3, 3): columns = the X-Y-Z chain's rotation axes in the shank frame.

    Args:
        q_xyz: (n, 3) rad, the model's ankle coordinates (x, y, z).
    """
    rx, rxy = _rx(q_xyz[:, 0]), _rx(q_xyz[:, 0]) @ _ry(q_xyz[:, 1])
    return np.stack([np.broadcast_to([1.0, 0.0, 0.0], (len(q_xyz), 3)), rx[:, :, 1],
                     rxy[:, :, 2]], axis=-1)


def ankle_moment(q_xyz: np.ndarray, tau_xyz: np.ndarray) -> np.ndarray:
    """(n, 3) N m: the moment the shank applies to the foot, in the shank frame.

    Solves tau_i = M . b_i on the chain's axes (:func:`cardan_xyz_axes`; they are
    independent away from gimbal lock, |b| = 90 deg).

    Args:
        q_xyz: (n, 3) rad, the model's ankle coordinates.
        tau_xyz: (n, 3) N m, their generalised forces.
    """
    axes = cardan_xyz_axes(np.asarray(q_xyz, dtype=float))
    return np.linalg.solve(np.swapaxes(axes, 1, 2), np.asarray(tau_xyz, dtype=float)[..., None]
                           )[..., 0]


def jcs_angles(q_xyz: np.ndarray) -> np.ndarray:
    """(n, 3) rad: the JCS angles (alpha about e2, beta about e1, gamma about e3).

    In the model's x, y, z slots: Rx(a) Ry(b) Rz(c) = Ry(beta) Rx(alpha) Rz(gamma).
    """
    rot = cardan_xyz_rotation(q_xyz)
    alpha = np.arcsin(np.clip(-rot[:, 1, 2], -1.0, 1.0))
    beta = np.arctan2(rot[:, 0, 2], rot[:, 2, 2])
    gamma = np.arctan2(rot[:, 1, 0], rot[:, 1, 1])
    return np.stack([alpha, beta, gamma], axis=-1)


def jcs_axes(q_xyz: np.ndarray) -> np.ndarray:
    """(n, 3, 3): columns = e2 (floating), e1 (shank Y), e3 (foot Z) in the shank frame."""
    q_xyz = np.asarray(q_xyz, dtype=float)
    foot_z = cardan_xyz_axes(q_xyz)[:, :, 2]
    e1 = np.broadcast_to([0.0, 1.0, 0.0], foot_z.shape)
    e2 = np.cross(e1, foot_z)
    e2 /= np.linalg.norm(e2, axis=-1, keepdims=True)
    return np.stack([e2, e1, foot_z], axis=-1)


def jcs_moments(q_xyz: np.ndarray, tau_xyz: np.ndarray) -> np.ndarray:
    """(n, 3) N m: the ankle moment about e2, e1, e3 (model x, y, z slots and signs)."""
    moment = ankle_moment(q_xyz, tau_xyz)
    return np.einsum("nij,ni->nj", jcs_axes(q_xyz), moment)


def in_jcs(joint_names: Sequence[str], q_joints: np.ndarray, tau_joints: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """Joint coordinates and generalised forces with each ankle's three in the JCS.

    Args:
        joint_names: the whole body's joint coordinate names.
        q_joints: (n, n_joints) rad.
        tau_joints: (n, n_joints) N m.

    Returns:
        Copies of both whose ``ankle_<side>_x/_y/_z`` columns hold the JCS angles and
        moments (:func:`jcs_angles`, :func:`jcs_moments`); the other columns unchanged.
    """
    names = list(joint_names)
    q_out, tau_out = np.array(q_joints, dtype=float), np.array(tau_joints, dtype=float)
    for coordinates in ANKLES.values():
        if not set(coordinates) <= set(names):
            continue
        cols = [names.index(c) for c in coordinates]
        q_out[:, cols] = jcs_angles(q_out[:, cols])
        tau_out[:, cols] = jcs_moments(np.asarray(q_joints, dtype=float)[:, cols],
                                       np.asarray(tau_joints, dtype=float)[:, cols])
    return q_out, tau_out
