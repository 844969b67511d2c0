"""Clinical angles and moments of the planar leg: the one place of their signs.

Model coordinates (see :mod:`predgait.models.urdf`): ``base_pitch`` is the foot pitch,
``ankle`` and ``knee`` are rotations of the child about +Y (a positive pitch tilts a
segment's top toward +X). Reported values (ARCHITECTURE.md conventions):

* ankle dorsiflexion = q_ankle (shank tilting forward over a flat foot);
* knee flexion = -q_knee (thigh pitch minus shank pitch is negative in flexion);
* hip flexion = -(thigh pitch): the leg model has no pelvis, so the thigh is measured
  against the vertical (a level pelvis).

A moment is positive when it acts toward the positive angle: ankle dorsiflexion moment
= tau_ankle, knee flexion moment = -tau_knee, hip flexion moment = -(moment about +Y the
pelvis applies to the thigh). These are internal (muscle) moments, as in Winter (2009).
"""

from __future__ import annotations

import numpy as np

ANGLES = ("hip_flexion", "knee_flexion", "ankle_dorsiflexion")
#: Clinical sign of each model joint coordinate and its torque.
JOINT_SIGN = {"ankle": 1.0, "knee": -1.0}
#: Clinical name of each model joint.
CLINICAL_NAME = {"ankle": "ankle_dorsiflexion", "knee": "knee_flexion"}


def thigh_pitch(q: np.ndarray) -> np.ndarray:
    """Absolute thigh pitch, rad: foot pitch + ankle + knee. ``q`` is (..., 5)."""
    return q[..., 2] + q[..., 3] + q[..., 4]


def clinical_angles(q: np.ndarray) -> dict[str, np.ndarray]:
    """Hip flexion, knee flexion, ankle dorsiflexion (rad) from leg coordinates (..., 5)."""
    return {
        "hip_flexion": -thigh_pitch(q),
        "knee_flexion": JOINT_SIGN["knee"] * q[..., 4],
        "ankle_dorsiflexion": JOINT_SIGN["ankle"] * q[..., 3],
    }


def clinical_moments(tau: np.ndarray, hip_moment_y: np.ndarray) -> dict[str, np.ndarray]:
    """Clinical joint moments (N m) from joint torques (..., 5) and the hip moment about +Y."""
    return {
        "hip_flexion_moment": -np.asarray(hip_moment_y),
        "knee_flexion_moment": JOINT_SIGN["knee"] * tau[..., 4],
        "ankle_dorsiflexion_moment": JOINT_SIGN["ankle"] * tau[..., 3],
    }


def joint_powers(moments: dict[str, np.ndarray], rates: dict[str, np.ndarray]
                 ) -> dict[str, np.ndarray]:
    """Joint power (W) = clinical moment x clinical angular velocity, per joint."""
    return {name.replace("_moment", "_power"): moments[name] * rates[name.replace("_moment", "")]
            for name in moments}
