"""The net ankle moment about Gait2354's subtalar axis, the axis fixed in the foot.

OpenSim's Gait2354 model (Delp et al. 1990, IEEE TBME 37:757-767; its subtalar axis after
Inman 1976, The Joints of the Ankle) reports a "subtalar moment": the generalised force of
its subtalar joint, i.e. the net moment the talus applies to the calcaneus projected on the
subtalar axis. That axis is fixed in the talus (and, with the joint at 0 as Gait2354's IK
holds it, in the calcaneus): in OpenSim's talus frame (X forward, Y up, Z right) the right
axis is (0.78718, 0.60475, -0.12095) (``gait2354_simbody.osim`` and ``subject01_simbody.osim``,
opensim-models commit 20a888b), 37.2 deg above the foot's long axis and 8.7 deg medial of
it; the left is its mirror image, negated so that + is inversion on both sides.

Here the same axis is carried in predgait's foot frame (X forward, Y to the left, Z up;
the static trial's foot frame is level and headed from the heel to the toe landmark,
:mod:`predgait.kinematics.static_feet`) and taken through the ankle centre (the malleoli
mid-point): Gait2354 puts it through its subtalar joint 54/47/9 mm behind, below and
lateral of its ankle joint, which changes the moment on subject01 by < 0.1 in r (measured
in docs/DEVELOPING.md), so no force (only the joint moment) is needed. It is a model
axis, not a clinical one: gait labs report the inversion moment about the ISB joint
coordinate system's floating axis (:mod:`predgait.kinematics.ankle_jcs`), which is
perpendicular to the shank's transmalleolar axis and so takes in a share of the
plantarflexion moment where the foot points away from the shank's heading (tibial torsion).

Sign: + is an internal moment toward inversion, as OpenSim's ``subtalar_angle`` moment.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from predgait.kinematics.ankle_jcs import ANKLES, ankle_moment, cardan_xyz_rotation

#: Gait2354's right subtalar axis in OpenSim's talus frame (X forward, Y up, Z right),
#: unit vector, from subject01_simbody.osim (the generic gait2354_simbody.osim's).
GAIT2354_RIGHT_OSIM = np.array([0.78717961, 0.60474746, -0.12094949])


def subtalar_axis(side: str) -> np.ndarray:
    """(3,) unit vector: Gait2354's subtalar axis in predgait's foot frame, + = inversion.

    OpenSim's talus (X forward, Y up, Z right) to predgait's foot (X forward, Y left, Z
    up): (x, y, z) -> (x, -z, y). Left: the right axis mirrored (Y -> -Y) and negated, as
    Gait2354's left subtalar axis (-0.78718, -0.60475, -0.12095).

    Args:
        side: "r" or "l".
    """
    x, y, z = GAIT2354_RIGHT_OSIM
    right = np.array([x, -z, y])
    if side == "r":
        return right
    if side == "l":
        return -right * np.array([1.0, -1.0, 1.0])
    raise ValueError(f"subtalar_axis: side {side!r}; 'r' or 'l'.")


def subtalar_moment(side: str, q_xyz: np.ndarray, tau_xyz: np.ndarray) -> np.ndarray:
    """(n,) N m: the net ankle moment about Gait2354's subtalar axis (inversion +).

    Args:
        side: "r" or "l".
        q_xyz: (n, 3) rad, the model's ankle coordinates (x, y, z) of that side.
        tau_xyz: (n, 3) N m, their generalised forces (the shank's moment on the foot).
    """
    q_xyz = np.asarray(q_xyz, dtype=float)
    axis_in_shank = cardan_xyz_rotation(q_xyz) @ subtalar_axis(side)
    return np.einsum("ni,ni->n", ankle_moment(q_xyz, tau_xyz), axis_in_shank)


def subtalar_moments(joint_names: Sequence[str], q_joints: np.ndarray,
                     tau_joints: np.ndarray) -> dict[str, np.ndarray]:
    """``subtalar_<side>_moment`` -> (n,) N m, per side whose ankle the body has.

    Args:
        joint_names: the whole body's joint coordinate names.
        q_joints: (n, n_joints) rad, its joint coordinates (the model's Cardan ones).
        tau_joints: (n, n_joints) N m, their generalised forces.
    """
    names = list(joint_names)
    out = {}
    for side, coordinates in ANKLES.items():
        if set(coordinates) <= set(names):
            cols = [names.index(c) for c in coordinates]
            out[f"subtalar_{side}_moment"] = subtalar_moment(
                side, np.asarray(q_joints, dtype=float)[:, cols],
                np.asarray(tau_joints, dtype=float)[:, cols])
    return out
