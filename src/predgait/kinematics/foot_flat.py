"""Static-free "foot flat" calibration: the sole parallel to the floor at loaded mid-stance.

Gait labs' foot-flat option sets the foot's long axis parallel to the floor in the static
trial instead of taking it from the heel and toe markers, whose heights above the sole
differ from foot to foot and shoe to shoe (Vicon Plug-in Gait Reference Guide, static
subject calibration, "Left/Right Foot Flat" options; pyCGM2, Leboeuf et al. 2019, Gait
Posture 69:235-241, ``leftFlatFoot``/``rightFlatFoot``: "set the longitudinal axis of the
foot parallel to the ground"). Without a static trial the same is done on the walk: the
frames where a foot is loaded on a plate (vertical force >= :data:`LOADED_FRACTION` of body
weight) and nearly still (angular speed <= :data:`STILL_DEG_S`, ankle centre speed <=
:data:`STILL_M_S`) are its flat-foot frames; there the sole stands on the floor.

The correction is one rotation ``C`` of the foot frame about its origin (the ankle centre)
per foot: the smallest rotation that turns the foot's Z axis onto the lab vertical, averaged
over the flat-foot frames (pitch and roll; the heading stays). The foot's marker offsets
``o`` become ``C^T o``, so inverse kinematics then finds the foot frame ``R C`` with the same
marker fit, and its sole (the contact frames, Z = const in the foot) parallel to the floor
there. The sole's depth below the ankle centre is set to the ankle centre's mean height
above the plates' surface in those frames (the shoe), in the Pinocchio model AND the URDF
(the symbolic dynamics read the URDF).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from enum import Enum

import numpy as np
import pinocchio as pin

from predgait.data.trial import ForcePlate
from predgait.kinematics.ik3d import with_marker_frames
from predgait.models.loading import new_data
from predgait.models.loading3d import Model3D

LOADED_FRACTION = 0.2   # of body weight: the foot carries load
STILL_DEG_S = 20.0      # deg/s: foot angular speed of a flat foot
STILL_M_S = 0.1         # m/s: ankle-centre speed of a flat foot
MIN_FRAMES = 3          # flat-foot frames needed to calibrate a foot
FEET = ("r", "l")


class FootFlatMode(Enum):
    """Foot flat: ``auto`` and ``on`` level the feet, ``off`` does not.

    Without a static trial the soles are levelled on the walk (this module); with one, the
    static trial's feet stand flat (:mod:`predgait.kinematics.static_feet`).
    """

    AUTO = "auto"
    ON = "on"
    OFF = "off"

    def applies(self, has_static: bool) -> bool:
        """Whether the walk's soles are levelled (only without a static trial)."""
        return self is not FootFlatMode.OFF and not has_static


@dataclass(frozen=True)
class FootFlat:
    """The calibration of one foot.

    Attributes:
        side: ``r`` or ``l``.
        times: (k,) s, the flat-foot frames used.
        pitch_deg: sole tilt before, toe down positive (rotation about the foot's Y), deg.
        roll_deg: sole tilt before about the foot's X (positive: its +Y, left, side up), deg.
        sole_depth_m: depth of the sole below the ankle centre after (before: the model's).
        previous_depth_m: the model's sole depth before, m.
        floor_z_m: the plates' surface the sole was set on (lab Z), m.
    """

    side: str
    times: np.ndarray
    pitch_deg: float
    roll_deg: float
    sole_depth_m: float
    previous_depth_m: float
    floor_z_m: float

    def summary(self) -> dict:
        """JSON-ready description."""
        return {"frames": int(self.times.size),
                "time_s": [round(float(self.times[0]), 4), round(float(self.times[-1]), 4)],
                "pitch_corrected_deg": round(self.pitch_deg, 2),
                "roll_corrected_deg": round(self.roll_deg, 2),
                "sole_depth_m": round(self.sole_depth_m, 4),
                "model_sole_depth_m": round(self.previous_depth_m, 4),
                "floor_z_m": round(self.floor_z_m, 4)}


def foot_poses(model: Model3D, q: np.ndarray, side: str) -> tuple[np.ndarray, np.ndarray]:
    """Foot frame rotations (n, 3, 3) and origins (n, 3), m, lab frame."""
    pm, data = model.pin_model, new_data(model.pin_model)
    fid = model.frame_id(f"foot_{side}")
    rot, pos = np.empty((q.shape[0], 3, 3)), np.empty((q.shape[0], 3))
    for k, row in enumerate(q):
        pin.framesForwardKinematics(pm, data, row)
        rot[k], pos[k] = data.oMf[fid].rotation, data.oMf[fid].translation
    return rot, pos


def flat_frames(time: np.ndarray, rot: np.ndarray, pos: np.ndarray, load: np.ndarray,
                weight: float) -> np.ndarray:
    """(n,) bool: frames where the foot is loaded and nearly still (module docstring).

    Args:
        time: (n,) s.
        rot: (n, 3, 3) foot rotations (:func:`foot_poses`).
        pos: (n, 3) m, foot origins (the ankle centre).
        load: (n,) N, vertical plate force on this foot.
        weight: body weight, N.
    """
    n = time.size
    omega = np.zeros(n)
    for k in range(1, n - 1):
        omega[k] = np.linalg.norm(pin.log3(rot[k - 1].T @ rot[k + 1])) / (time[k + 1]
                                                                         - time[k - 1])
    omega[0], omega[-1] = omega[min(1, n - 1)], omega[max(n - 2, 0)]
    speed = np.linalg.norm(np.gradient(pos, time, axis=0), axis=1) if n > 1 else np.zeros(n)
    return ((load >= LOADED_FRACTION * weight) & (np.degrees(omega) <= STILL_DEG_S)
            & (speed <= STILL_M_S))


def levelling_rotation(rot: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Foot-frame rotation C that makes the mean lab vertical the foot's Z; pitch, roll, deg.

    ``up`` = mean of ``R_k^T e_z`` (the lab vertical in the foot); C is the rotation about
    ``e_z x up`` taking e_z to ``up``, so the corrected frame R C has Z = e_z.
    """
    up = np.mean(rot[:, 2, :], axis=0)  # row 2 of R = R^T e_z
    up /= np.linalg.norm(up)
    axis = np.cross([0.0, 0.0, 1.0], up)
    angle = np.arctan2(np.linalg.norm(axis), up[2])
    correction = pin.exp3(axis / np.linalg.norm(axis) * angle) if angle > 1e-12 else np.eye(3)
    pitch = np.degrees(np.arctan2(-up[0], up[2]))  # foot X below the horizontal: toe down
    roll = np.degrees(np.arctan2(up[1], up[2]))    # foot +Y above the horizontal
    return correction, float(pitch), float(roll)


def sole_frames(model: Model3D, side: str) -> list[str]:
    """Contact frames on the sole of foot ``side`` (``*_contact_<side>``)."""
    return [f.name for f in model.pin_model.frames if f.type == pin.FrameType.BODY
            and "_contact_" in f.name and f.name.endswith(f"_{side}")]


def _in_foot(model: Model3D, frame: str, side: str) -> np.ndarray:
    pm = model.pin_model
    foot = pm.frames[model.frame_id(f"foot_{side}")].placement
    return foot.actInv(pm.frames[model.frame_id(frame)].placement).translation


def _urdf_with_origin(urdf: str, frame: str, xyz: np.ndarray) -> str:
    """The URDF with the fixed joint of massless link ``frame`` at ``xyz`` in its parent."""
    pattern = re.compile(rf'(<joint name="{frame}_fixed" type="fixed">\s*<parent link="[^"]*"/>'
                         rf'\s*<child link="{frame}"/>\s*<origin xyz=")[^"]*(")')
    text = " ".join(f"{v:.10g}" for v in xyz)
    new, count = pattern.subn(lambda m: m.group(1) + text + m.group(2), urdf)
    if count != 1:
        raise ValueError(f"URDF has no fixed joint for frame {frame!r}")
    return new


def calibrate_feet(model: Model3D, time: np.ndarray, q: np.ndarray,
                   plates: Sequence[ForcePlate], sides: np.ndarray,
                   markers: Mapping[str, str]) -> tuple[Model3D, dict[str, FootFlat | str]]:
    """Level each foot's sole at its flat-foot frames (module docstring).

    Args:
        model: whole body with calibrated marker frames.
        time: (n,) s.
        q: (n, nq) inverse kinematics (low-passed) of the walk.
        plates: plates resampled at ``time``.
        sides: (p, n) the foot (``r``, ``l`` or "") each plate loads per frame.
        markers: fitted marker frame -> body (frames riding on ``foot_r``/``foot_l`` rotate).

    Returns:
        The corrected model and, per foot, its :class:`FootFlat` or why it was not
        calibrated (a sentence).
    """
    weight = model.total_mass() * model.gravity
    floor = [float(np.median(p.cop[p.force[:, 2] > LOADED_FRACTION * weight, 2]))
             for p in plates if (p.force[:, 2] > LOADED_FRACTION * weight).any()]
    out: dict[str, FootFlat | str] = {}
    placements, urdf = {}, model.urdf
    for side in FEET:
        load = sum((np.where(sides[i] == side, p.force[:, 2], 0.0)
                    for i, p in enumerate(plates)), np.zeros(time.size))
        rot, pos = foot_poses(model, q, side)
        flat = flat_frames(time, rot, pos, load, weight)
        if flat.sum() < MIN_FRAMES:
            out[side] = (f"not calibrated: {int(flat.sum())} frames with the foot loaded "
                         f"(>= {LOADED_FRACTION:g} body weight) and still")
            continue
        correction, pitch, roll = levelling_rotation(rot[flat])
        body = f"foot_{side}"
        for frame, parent in markers.items():
            if parent == body:
                placements[frame] = (body, correction.T @ _in_foot(model, frame, side))
        floor_z = float(np.median(floor))
        depth = float(np.mean(pos[flat, 2]) - floor_z)
        previous = []
        for frame in sole_frames(model, side):
            xyz = _in_foot(model, frame, side)
            previous.append(-xyz[2])
            xyz = np.array([xyz[0], xyz[1], -depth])
            placements[frame] = (body, xyz)
            urdf = _urdf_with_origin(urdf, frame, xyz)
        out[side] = FootFlat(side, time[flat], pitch, roll, depth, float(np.mean(previous)),
                             floor_z)
    if not placements:
        return model, out
    moved = with_marker_frames(model, placements)
    return replace(moved, urdf=urdf, source=f"{moved.source}, feet levelled (foot flat)"), out
