"""Deviation of a synthesized whole-body motion from the measured one (thesis 2.4).

Joint angles and pelvis Cardan angles (X obliquity, Y tilt, Z rotation; R = Rx Ry Rz,
:func:`predgait.kinematics.ik3d.pelvis_cardan`) in degrees, pelvis position in metres:
RMS and maximum over the run, and the first time each leaves a band.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from predgait.dynamics.falls import pelvis_angle_error


def deviations3d(t: np.ndarray, q: np.ndarray, measured: np.ndarray,
                 joint_names: Sequence[str], *, band_deg: float = 5.0,
                 band_m: float = 0.05) -> dict:
    """Simulated minus measured whole-body motion.

    Args:
        t: (n,) s.
        q: (n, nq) simulated free-flyer configurations at ``t``.
        measured: (n, nq) measured configurations at ``t``.
        joint_names: Names of q[:, 7:].
        band_deg: deg, band of the joint and pelvis angles.
        band_m: m, band of the pelvis position (distance from the measured one).

    Returns:
        RMS and max (deg, m), the worst joint, and the time (s after t[0], None = never)
        at which the joints (naming the first out), the pelvis position and the pelvis
        angles first leave their band.
    """
    joints = np.degrees(q[:, 7:] - measured[:, 7:])
    angles = np.degrees(np.array([pelvis_angle_error(a, b)
                                  for a, b in zip(q, measured, strict=True)]))
    offset = q[:, :3] - measured[:, :3]
    distance = np.linalg.norm(offset, axis=1)

    def first(over):
        return float(t[np.argmax(over)] - t[0]) if over.any() else None

    size = np.abs(joints)
    out = size > band_deg
    row = int(np.argmax(out.any(axis=1)))
    return {
        "band_deg": band_deg, "band_m": band_m,
        "joint_rms_deg": float(np.sqrt(np.mean(joints**2))),
        "joint_max_deg": float(size.max()),
        "joint_max_name": joint_names[int(np.argmax(size.max(axis=0)))] if size.any() else None,
        "joint_leaves_band_s": first(out.any(axis=1)),
        "joint_leaving_band": joint_names[int(np.argmax(out[row]))] if out.any() else None,
        "joint_rms_deg_each": dict(zip(joint_names, np.sqrt(np.mean(joints**2, axis=0))
                                       .tolist(), strict=True)),
        "pelvis_position_rms_m": float(np.sqrt(np.mean(distance**2))),
        "pelvis_position_rms_m_xyz": np.sqrt(np.mean(offset**2, axis=0)).tolist(),
        "pelvis_position_max_m": float(distance.max()),
        "pelvis_position_leaves_band_s": first(distance > band_m),
        "pelvis_angle_rms_deg": float(np.sqrt(np.mean(angles**2))),
        "pelvis_angle_max_deg": float(np.abs(angles).max()),
        "pelvis_angle_leaves_band_s": first(np.abs(angles).max(axis=1) > band_deg),
    }
