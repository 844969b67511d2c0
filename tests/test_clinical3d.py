"""Clinical signs of the whole-body coordinates (predgait.kinematics.clinical.CLINICAL_3D).

Each clinical angle is set to +0.3 rad from the neutral pose and the distal landmark must
move the way the clinical name says (forward, medially, up...), checked with Pinocchio's
forward kinematics: an independent check of every sign in the table.
"""

import numpy as np
import pinocchio as pin
import pytest

from predgait.kinematics.clinical import CLINICAL_3D, clinical_angles_3d
from predgait.models.loading3d import load_fullbody

MEDIAL = {"r": 1.0, "l": -1.0}  # +Y (left) is medial for the right limbs

#: clinical name (side-less) -> (landmark frame or (body, point in body frame), axis, sign)
EXPECTED = {
    "hip_flexion": ("knee_center", 0, 1.0),                 # knee forward
    "hip_adduction": ("knee_center", 1, "medial"),          # knee toward the midline
    "hip_internal_rotation": ("knee_lat", 0, 1.0),          # lateral knee marker forward
    "knee_flexion": ("ankle_center", 0, -1.0),              # ankle backward
    "knee_adduction": ("ankle_center", 1, "medial"),        # ankle medially (varus)
    "knee_internal_rotation": ("ankle_lat", 0, 1.0),        # lateral malleolus forward
    "ankle_dorsiflexion": ("toe", 2, 1.0),                  # toes up
    "ankle_inversion": (("foot", "lateral"), 2, -1.0),      # lateral edge down
    "ankle_internal_rotation": ("toe", 1, "medial"),        # toes medially
    "shoulder_flexion": ("elbow_center", 0, 1.0),           # elbow forward
    "shoulder_adduction": ("elbow_center", 1, "medial"),    # elbow medially
    "shoulder_internal_rotation": ("elbow_lat", 0, 1.0),    # lateral elbow forward
    "elbow_flexion": ("wrist", 0, 1.0),                     # wrist forward
}
TRUNK = {"lumbar_flexion": ("head_top", 0, 1.0), "lumbar_bending_left": ("head_top", 1, 1.0),
         "lumbar_rotation_left": ("sternum", 1, 1.0)}


@pytest.fixture(scope="module")
def body():
    return load_fullbody()


def _position(body, q, landmark, side):
    pm, data = body.pin_model, body.pin_model.createData()
    pin.framesForwardKinematics(pm, data, q)
    if isinstance(landmark, tuple):  # a point on the lateral edge of the foot
        frame = data.oMf[body.frame_id(f"{landmark[0]}_{side}")]
        return frame.act(np.array([0.05, -0.05 * MEDIAL[side], -0.05]))
    name = f"{landmark}_{side}" if side else landmark
    return data.oMf[body.frame_id(name)].translation.copy()


def _cases():
    for coordinate, (clinical, _) in CLINICAL_3D.items():
        side = clinical[-1] if clinical[-2] == "_" else ""
        base = clinical[:-2] if side else clinical
        yield coordinate, clinical, side, (EXPECTED | TRUNK)[base]


@pytest.mark.parametrize("case", list(_cases()), ids=lambda c: c[1])
def test_positive_clinical_angle_moves_the_landmark_as_named(body, case):
    coordinate, clinical, side, (landmark, axis, direction) = case
    sign = CLINICAL_3D[coordinate][1]
    q = body.neutral()
    index = 7 + body.joint_names.index(coordinate)
    before = _position(body, q, landmark, side)
    q[index] = sign * 0.3  # clinical angle +0.3 rad
    after = _position(body, q, landmark, side)
    expected = MEDIAL[side] if direction == "medial" else direction
    assert (after - before)[axis] * expected > 0.01


def test_every_joint_has_a_clinical_name(body):
    assert set(CLINICAL_3D) == set(body.joint_names)
    angles = clinical_angles_3d(body.joint_names, np.ones((2, len(body.joint_names))))
    assert len(angles) == 29 and angles["knee_flexion_r"][0] == 1.0
    assert angles["hip_flexion_l"][1] == -1.0
