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

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from predgait.errors import InputError

ANGLES = ("hip_flexion", "knee_flexion", "ankle_dorsiflexion")


@dataclass(frozen=True)
class ClinicalJoint:
    """A joint on its clinical angle: angle = sign * sum(q[coordinates]).

    The conjugate clinical moment M acts as the generalised force sign * M on each of
    the coordinates (a moment positive toward the positive angle).

    Attributes:
        angle: Clinical angle name (e.g. "knee_flexion").
        coordinates: Model coordinates whose sum is the (signed) angle.
        sign: +1 or -1.
    """

    angle: str
    coordinates: tuple[str, ...]
    sign: float

    def clinical(self, value):
        """Model value -> clinical value: an angle, rate or generalised force times the sign.

        The sign is +-1, so the same call turns a clinical value back into the model's.
        Works on floats, arrays and CasADi values.
        """
        return self.sign * value

    def generalized_force(self, moment: Callable, angle_sum, rate_sum):
        """Generalised force on each coordinate of a clinical moment law.

        Args:
            moment: (clinical angle, clinical rate) -> clinical moment (N m), positive
                toward the positive angle (a passive element, a spring).
            angle_sum: Sum of ``q`` over :attr:`coordinates` (rad), model sign.
            rate_sum: Sum of ``v`` over :attr:`coordinates` (rad/s), model sign.

        Returns:
            sign * moment(sign * angle_sum, sign * rate_sum): the generalised force the
            moment applies to each of the coordinates (virtual work M d(angle)). The one
            composition of passive torques of predgait (simulator, drivers, fitting and
            predictive problems).
        """
        return self.clinical(moment(self.clinical(angle_sum), self.clinical(rate_sum)))


#: THE joint-sign table of the planar models (simulator, drivers and fitting use it
#: through :func:`clinical_joint`). Leg (:mod:`predgait.models.urdf`): ankle = ankle
#: dorsiflexion, knee = -knee flexion, thigh pitch (base_pitch + ankle + knee) = -hip
#: flexion (no pelvis: the thigh against the vertical). gait7 (:mod:`predgait.models.
#: gait7`): positive hip extension, knee flexion, ankle plantarflexion.
PLANAR_JOINTS: dict[str, dict[str, ClinicalJoint]] = {
    "leg": {"ankle": ClinicalJoint("ankle_dorsiflexion", ("ankle",), 1.0),
            "knee": ClinicalJoint("knee_flexion", ("knee",), -1.0),
            "hip": ClinicalJoint("hip_flexion", ("base_pitch", "ankle", "knee"), -1.0)},
    "gait7": {f"{joint}_{side}": ClinicalJoint(f"{angle}_{side}", (f"{joint}_{side}",), sign)
              for side in ("r", "l")
              for joint, angle, sign in (("hip", "hip_flexion", -1.0),
                                         ("knee", "knee_flexion", 1.0),
                                         ("ankle", "ankle_dorsiflexion", -1.0))},
    # OpenSim's planar gait models (2D_gait.osim): joints named after their coordinates,
    # values as OpenSim's (knee_angle negative in flexion).
    "osim2d": {f"{coordinate}_{side}": ClinicalJoint(f"{angle}_{side}", (f"{coordinate}_{side}",),
                                                      sign)
               for side in ("r", "l")
               for coordinate, angle, sign in (("hip_flexion", "hip_flexion", 1.0),
                                               ("knee_angle", "knee_flexion", -1.0),
                                               ("ankle_angle", "ankle_dorsiflexion", 1.0))},
}
#: The planar leg's free joints (model coordinates 3 and 4, after base x, z, pitch).
LEG_FREE_JOINTS = ("ankle", "knee")


def clinical_joint(model, joint: str) -> ClinicalJoint:
    """The :class:`ClinicalJoint` of ``joint`` on ``model``: THE way to a clinical sign.

    Every clinical angle, moment and passive torque of predgait (outputs, plots, the
    simulator, the fitting and predictive problems) takes its sign from here.

    Args:
        model: A model (its ``kind``: leg, gait7, osim2d, or the whole body) or a kind
            name ("leg", "gait7", "osim2d", "fullbody") where no model is at hand.
        joint: Joint name ("knee", "hip_r", "knee_r_y", ...).

    Raises:
        InputError: The model has no such joint (the message lists those it has).
    """
    kind = model if isinstance(model, str) else model.kind
    table = PLANAR_JOINTS.get(kind)
    if table is None:  # the whole body: every joint coordinate is its own joint
        names = CLINICAL_3D if isinstance(model, str) else model.coordinate_names
        table = {name: ClinicalJoint(CLINICAL_3D[name][0], (name,), CLINICAL_3D[name][1])
                 for name in names if name in CLINICAL_3D}
    if joint not in table:
        raise InputError(f"passive elements on '{joint}': the {kind} model has "
                         f"joints {', '.join(table) or 'none'}.")
    return table[joint]


def leg_clinical(joint: str, value):
    """A leg joint's model angle, rate or torque ``value`` in its clinical sign (and back)."""
    return clinical_joint("leg", joint).clinical(value)


def thigh_pitch(q: np.ndarray) -> np.ndarray:
    """Absolute thigh pitch, rad: foot pitch + ankle + knee. ``q`` is (..., 5)."""
    return q[..., 2] + q[..., 3] + q[..., 4]


def clinical_angles(q: np.ndarray) -> dict[str, np.ndarray]:
    """Hip flexion, knee flexion, ankle dorsiflexion (rad) from leg coordinates (..., 5)."""
    return {
        "hip_flexion": leg_clinical("hip", thigh_pitch(q)),
        "knee_flexion": leg_clinical("knee", q[..., 4]),
        "ankle_dorsiflexion": leg_clinical("ankle", q[..., 3]),
    }


def clinical_moments(tau: np.ndarray, hip_moment_y: np.ndarray) -> dict[str, np.ndarray]:
    """Clinical joint moments (N m) from joint torques (..., 5) and the hip moment about +Y."""
    return {
        "hip_flexion_moment": leg_clinical("hip", np.asarray(hip_moment_y)),
        "knee_flexion_moment": leg_clinical("knee", tau[..., 4]),
        "ankle_dorsiflexion_moment": leg_clinical("ankle", tau[..., 3]),
    }


def joint_powers(moments: dict[str, np.ndarray], rates: dict[str, np.ndarray]
                 ) -> dict[str, np.ndarray]:
    """Joint power (W) = clinical moment x clinical angular velocity, per joint."""
    return {name.replace("_moment", "_power"): moments[name] * rates[name.replace("_moment", "")]
            for name in moments}


# ------------------------------------------------------------------- whole body (3D)
#: Whole body (:mod:`predgait.models.fullbody`): model coordinate -> (clinical name, sign),
#: clinical = sign * model. Every segment frame has X forward, Y left, Z up in the neutral
#: pose and child = parent Rx Ry Rz (Cardan X-Y-Z, thesis 2.3.2), so a positive Y
#: rotation swings a distal segment backward (hip and shoulder extension, knee flexion,
#: ankle plantarflexion) and a positive X or Z rotation moves it toward +Y: medially
#: (adduction, inversion, internal rotation) on the right, laterally on the left.
#: Trunk: lumbar X tilts the head to the right, Y forward, Z turns it left.
CLINICAL_3D: dict[str, tuple[str, float]] = {}
for _side, _medial in (("r", 1.0), ("l", -1.0)):
    CLINICAL_3D |= {
        f"hip_{_side}_x": (f"hip_adduction_{_side}", _medial),
        f"hip_{_side}_y": (f"hip_flexion_{_side}", -1.0),
        f"hip_{_side}_z": (f"hip_internal_rotation_{_side}", _medial),
        f"knee_{_side}_x": (f"knee_adduction_{_side}", _medial),
        f"knee_{_side}_y": (f"knee_flexion_{_side}", 1.0),
        f"knee_{_side}_z": (f"knee_internal_rotation_{_side}", _medial),
        f"ankle_{_side}_x": (f"ankle_inversion_{_side}", _medial),
        f"ankle_{_side}_y": (f"ankle_dorsiflexion_{_side}", -1.0),
        f"ankle_{_side}_z": (f"ankle_internal_rotation_{_side}", _medial),
        f"shoulder_{_side}_x": (f"shoulder_adduction_{_side}", _medial),
        f"shoulder_{_side}_y": (f"shoulder_flexion_{_side}", -1.0),
        f"shoulder_{_side}_z": (f"shoulder_internal_rotation_{_side}", _medial),
        f"elbow_{_side}": (f"elbow_flexion_{_side}", -1.0),
    }
CLINICAL_3D |= {"lumbar_x": ("lumbar_bending_left", -1.0), "lumbar_y": ("lumbar_flexion", 1.0),
                "lumbar_z": ("lumbar_rotation_left", 1.0)}
#: Pelvis orientation in the lab (Cardan X-Y-Z of ``ik3d.pelvis_cardan``, lab X forward):
#: anterior tilt = +Y, left side up = +X, turning left (right side forward) = +Z.
PELVIS_3D = ("pelvis_left_up", "pelvis_anterior_tilt", "pelvis_rotation_left")


def clinical_angles_3d(joint_names, q_joints: np.ndarray) -> dict[str, np.ndarray]:
    """Clinical joint angles (rad) from whole-body joint coordinates (n, n_joints).

    Also gives each joint's moment: the generalised force of a coordinate times the same
    sign is the moment conjugate to the clinical angle (positive = acting toward the
    positive angle, e.g. a hip flexor moment; internal moments, as in Winter 2009).
    """
    q_joints = np.asarray(q_joints)
    joints = [clinical_joint("fullbody", n) for n in joint_names]
    return {j.angle: j.clinical(q_joints[..., i]) for i, j in enumerate(joints)}
