"""The static trial's foot frames: level (foot flat) and headed from heel to toe.

In the static trial the whole-body IK poses each foot from the ankle centre and the heel
and toe landmarks at the model's generic places on the sole, but the heel marker sits on
the back of the heel, 3-7 cm above the sole: the fit rolls the feet (subject01: 7.5 deg
(r) and -14.4 deg (l), asymmetric), and the calibrated foot markers carry that roll into
every walking frame (6-28 deg of "inversion" where OpenSim's IK holds the joint at 0). Gait
labs build the foot frame from its landmarks instead (Vicon Plug-in Gait's static
calibration and its "Foot Flat" option; pyCGM2, Leboeuf et al. 2019, Gait Posture
69:235-241): here, in every static frame and by one rule for both feet,

* origin: the model's ankle centre, fitted to the malleoli mid-point (the static fit's
  ``static_joint_centre_residual_mm``; subject01: 4.5 / 5.6 mm, the chain's compromise
  with the hip and knee centres);
* foot flat (the foot stands on the level floor): Z the lab vertical, X the heel-to-toe
  direction in the floor plane, Y = Z x X.

The correction is one rotation ``C`` of each foot frame about the ankle centre, the mean
over the static frames of ``R_ik^T R_landmarks`` (projected onto a rotation): the foot's
marker offsets ``o`` become ``C^T o``, so the static pose with the foot turned by ``C``
fits the same markers (the calibration stays one consistent pose) and its frame is the
landmark frame. The sole frames keep their place in the foot frame (level in the static
trial).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from predgait.kinematics.ik3d import with_marker_frames
from predgait.models.loading import new_data
from predgait.models.loading3d import Model3D

SIDES = ("r", "l")
#: Landmark frames a foot's frame is built from (``<name>_<side>``).
LANDMARKS = ("heel_contact", "toe_contact")
UP = np.array([0.0, 0.0, 1.0])


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def foot_frames(heel: np.ndarray, toe: np.ndarray) -> np.ndarray:
    """Flat-foot frames from the heel and toe landmarks: (n, 3, 3), columns X, Y, Z (lab).

    Z is the lab vertical, X the heel-to-toe direction in the floor plane (the landmarks'
    heights above the sole do not tilt it), Y = Z x X.

    Args:
        heel: (n, 3) m, the heel landmark in the lab frame (Z up).
        toe: (n, 3) m, the toe landmark.
    """
    along = toe - heel
    x = _unit(along - along[..., 2:3] * UP)
    z = np.broadcast_to(UP, x.shape)
    return np.stack([x, np.cross(z, x), z], axis=-1)


def mean_rotation(rotations: np.ndarray) -> np.ndarray:
    """The rotation nearest (Frobenius) to the mean of (n, 3, 3) rotations."""
    u, _, vt = np.linalg.svd(np.mean(rotations, axis=0))
    return u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt


def level_static_feet(model: Model3D, q: np.ndarray, points: Mapping[str, np.ndarray],
                      bodies: Mapping[str, str]) -> tuple[Model3D, dict[str, dict | str]]:
    """Turn each foot's frame onto its landmark frame in the static pose (module docstring).

    Args:
        model: whole body with the markers calibrated on the static pose ``q``.
        q: (n, nq) the static trial's poses (IK).
        points: landmark frame -> (n, 3) m, its trial point in the same static frames
            (``heel_contact_<side>``, ``toe_contact_<side>``).
        bodies: calibrated marker frame -> the body it rides on (those on ``foot_<side>``
            turn with the foot).

    Returns:
        The model with the foot markers turned, and per side the correction (its roll,
        pitch and yaw, deg, about the foot's X, Y and Z axes: Pinocchio's rpy) or why the
        foot kept its IK pose.
    """
    pm, data = model.pin_model, new_data(model.pin_model)
    placements: dict[str, tuple[str, np.ndarray]] = {}
    report: dict[str, dict | str] = {}
    for side in SIDES:
        missing = [f"{n}_{side}" for n in LANDMARKS if f"{n}_{side}" not in points]
        if missing:
            report[side] = f"IK pose ({', '.join(missing)} not in [scaling.points])"
            continue
        target = foot_frames(points[f"heel_contact_{side}"], points[f"toe_contact_{side}"])
        foot = model.frame_id(f"foot_{side}")
        fitted = []
        for row in q:
            pin.framesForwardKinematics(pm, data, row)
            fitted.append(data.oMf[foot].rotation.copy())
        correction = mean_rotation(np.einsum("kji,kjl->kil", np.array(fitted), target))
        placement = pm.frames[foot].placement
        for frame, body in bodies.items():
            if body == f"foot_{side}":
                offset = placement.actInv(pm.frames[model.frame_id(frame)].placement).translation
                placements[frame] = (body, correction.T @ offset)
        report[side] = {"turned_deg": [
            round(float(a), 2) for a in np.degrees(pin.rpy.matrixToRpy(correction))]}
    if not placements:
        return model, report
    return with_marker_frames(model, placements), report
