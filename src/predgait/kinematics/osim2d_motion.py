"""The planar leg's and gait7's motions as coordinates of OpenSim's 2D gait model.

OpenSim's planar gait model (``2D_gait.osim``, Moco's example2DWalking; bundled as
``moco_2d_walking/2D_gait.osim``) has a PlanarJoint pelvis (``pelvis_tilt``,
``pelvis_tx``, ``pelvis_ty``) and PinJoints ``hip_flexion_<s>``, ``knee_angle_<s>``,
``ankle_angle_<s>`` and ``lumbar``, all about OpenSim's +Z (right) with unrotated joint
frames, so a body's angle in the lab is the sum of the coordinates above it. OpenSim's
+Z is predgait's -Y, so that angle is minus the segment's predgait pitch. Hence, with the
clinical signs of :mod:`predgait.kinematics.clinical` (kind ``osim2d``):

* ``hip_flexion`` = hip flexion, ``knee_angle`` = -knee flexion (negative in flexion:
  the model's range is -120..10 deg), ``ankle_angle`` = ankle dorsiflexion;
* ``pelvis_tilt`` = -(HAT pitch) for gait7, whose one trunk segment is the pelvis and
  torso with ``lumbar`` = 0; 0 for the leg, which has no pelvis (its hip flexion is the
  thigh against the vertical);
* ``pelvis_tx``, ``pelvis_ty`` place the pelvis so that the model's hip centre
  (:data:`HIP_IN_PELVIS`) lies on predgait's hip centre (lab X forward, Z up = OpenSim's
  X, Y), m.

The segments keep predgait's angles, not its lengths: on the generic model the feet do
not land where predgait's are. The leg's knee is its model hinge (``kinematics.sto``'s
``knee_flexion`` is that minus the standing knee of the static trial).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait.data.events import Side
from predgait.errors import InputError
from predgait.kinematics.clinical import clinical_joint, thigh_pitch

#: OpenSim model whose coordinates the motion files hold.
OSIM_MODEL = "2D_gait.osim (opensim-core 4.6 Moco example2DWalking; bundled: " \
             "moco_2d_walking/2D_gait.osim)"
#: Hip joint centre in 2D_gait.osim's pelvis frame (X forward, Y up), m: the translation
#: of the pelvis offset frames of its joints hip_r and hip_l (their Z, +-0.0823 m, is
#: lateral).
HIP_IN_PELVIS = (-0.068277800171117897, -0.063835397331130098)
#: The rotational coordinates among those written (the rest are translations, m).
TRANSLATIONS = ("pelvis_tx", "pelvis_ty")


def _side_letter(side: Side | str) -> str:
    return Side(side).value[0]


def _pelvis(hip_x: np.ndarray, hip_z: np.ndarray, tilt: np.ndarray) -> dict[str, np.ndarray]:
    """pelvis_tilt (rad), pelvis_tx, pelvis_ty (m) putting the model's hip at (hip_x, hip_z)."""
    ox, oy = HIP_IN_PELVIS
    c, s = np.cos(tilt), np.sin(tilt)
    return {"pelvis_tilt": tilt, "pelvis_tx": hip_x - (c * ox - s * oy),
            "pelvis_ty": hip_z - (s * ox + c * oy)}


def _leg_angles(clinical: dict[str, np.ndarray], s: str) -> dict[str, np.ndarray]:
    """OpenSim coordinates of one leg from its clinical angles (rad), by the osim2d signs."""
    return {f"{coordinate}_{s}": clinical_joint("osim2d", f"{coordinate}_{s}").clinical(
        clinical[joint]) for joint, coordinate in (("hip", "hip_flexion"),
                                                   ("knee", "knee_angle"),
                                                   ("ankle", "ankle_angle"))}


def leg_coordinates(model, q: np.ndarray, *, side: Side | str = Side.RIGHT
                    ) -> dict[str, np.ndarray]:
    """2D_gait.osim coordinates of the planar leg's motion (rad, m).

    Args:
        model: the leg Model (kind ``leg``).
        q: (n, 5) leg coordinates.
        side: the leg's side (its coordinates end in ``_r`` or ``_l``).

    Returns:
        pelvis_tilt (0), pelvis_tx, pelvis_ty, hip_flexion_<s>, knee_angle_<s>,
        ankle_angle_<s> -> (n,).
    """
    import pinocchio as pin

    q = np.atleast_2d(np.asarray(q, float))
    pm = model.pin_model
    data = pm.createData()
    frame = pm.getFrameId("hip_center")
    hip = np.empty((len(q), 3))
    for k, row in enumerate(q):
        pin.framesForwardKinematics(pm, data, row)
        hip[k] = data.oMf[frame].translation
    clinical = {j: clinical_joint("leg", j).clinical(value) for j, value in
                (("hip", thigh_pitch(q)), ("knee", q[:, 4]), ("ankle", q[:, 3]))}
    return _pelvis(hip[:, 0], hip[:, 2], np.zeros(len(q))) \
        | _leg_angles(clinical, _side_letter(side))


def gait7_coordinates(model, q: np.ndarray) -> dict[str, np.ndarray]:
    """2D_gait.osim coordinates of a gait7 motion (rad, m): pelvis, both legs, lumbar 0.

    Args:
        model: the gait7 Model (base_x, base_z: the hip centre; base_pitch: the HAT).
        q: (n, 9) gait7 coordinates.
    """
    q = np.atleast_2d(np.asarray(q, float))

    def column(name):
        return q[:, model.coordinate_index(name)]

    out = _pelvis(column("base_x"), column("base_z"), -column("base_pitch"))
    for s in ("r", "l"):
        out |= _leg_angles({j: clinical_joint(model, f"{j}_{s}").clinical(column(f"{j}_{s}"))
                            for j in ("hip", "knee", "ankle")}, s)
    return out | {"lumbar": np.zeros(len(q))}


def osim2d_coordinates(model, q: np.ndarray, *, side: Side | str = Side.RIGHT
                       ) -> dict[str, np.ndarray]:
    """2D_gait.osim coordinates (rad, m) of a leg or gait7 motion (``side``: the leg's)."""
    if model.kind == "leg":
        return leg_coordinates(model, q, side=side)
    if model.kind == "gait7":
        return gait7_coordinates(model, q)
    raise InputError(f"a {model.kind} model has no counterpart in OpenSim's 2D gait model; "
                     "motion files are written for the leg and gait7.")


def write_osim2d_motion(path: Path, model, time: np.ndarray, q: np.ndarray, *,
                        side: Side | str = Side.RIGHT, header: dict | None = None) -> None:
    """Write the motion as a .mot of 2D_gait.osim's coordinates (deg; pelvis_t* m).

    Args:
        path: the .mot file (written whole or not at all).
        model: a leg or gait7 Model.
        time: (n,) s.
        q: (n, nq) model coordinates.
        side: the leg's side (leg only).
        header: further header entries (provenance).
    """
    from predgait.data.storage import write_storage

    columns = {name: value if name in TRANSLATIONS else np.degrees(value)
               for name, value in osim2d_coordinates(model, q, side=side).items()}
    write_storage(path, time, columns, in_degrees=True, header={
        "units": "deg (rotations), m (pelvis_tx, pelvis_ty)", "model": OSIM_MODEL,
        "predgait_model": model.kind} | (header or {}))
