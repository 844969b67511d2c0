"""Clinical leg angles of an OpenSim planar gait model (2D_gait.osim), as gait labs plot them.

Knee flexion and ankle dorsiflexion are the model's coordinates with their clinical sign
(:func:`predgait.kinematics.clinical.clinical_joint`, kind ``osim2d``). Hip flexion is the
thigh against the trunk (the ``torso`` body), not the thigh against the pelvis
(``hip_flexion``): the measured yardsticks of :mod:`predgait.analysis.human_likeness`
(subject01's HAT, Winter's rib-cage-to-hip line) have no pelvis segment, and the
predicted pelvis of 2D_gait.osim tilts 15-20 deg forward against its torso, which
``hip_flexion`` would count as hip flexion.
"""

from __future__ import annotations

import numpy as np

from predgait.kinematics.clinical import clinical_joint

#: Angles per leg: name -> OpenSim coordinate stem (hip is taken against the trunk).
LEG_ANGLES = {"hip": "hip_flexion", "knee": "knee_angle", "ankle": "ankle_angle"}
#: Body whose orientation the hip flexion is measured against.
TRUNK_BODY = "torso"


def relative_pitch(planar, q: np.ndarray, proximal: str, distal: str) -> np.ndarray:
    """(n,) rotation of body ``distal`` relative to ``proximal`` about the lab's +Y, rad.

    Args:
        planar: an :class:`~predgait.models.osim_model.OsimPlanarModel`.
        q: (n, nq) or (nq,) model coordinates.
        proximal: OpenSim body the angle is measured against.
        distal: OpenSim body whose rotation is measured.
    """
    import pinocchio as pin

    model = planar.model.pin_model
    data = model.createData()
    ids = [model.getFrameId(planar.body_link(b)) for b in (proximal, distal)]
    out = []
    for row in np.atleast_2d(np.asarray(q, float)):
        pin.framesForwardKinematics(model, data, row)
        r = data.oMf[ids[0]].rotation.T @ data.oMf[ids[1]].rotation
        out.append(np.arctan2(r[0, 2], r[0, 0]))
    return np.asarray(out)


def leg_angles_deg(planar, q: np.ndarray, side: str = "r") -> dict[str, np.ndarray]:
    """Hip flexion (thigh vs trunk), knee flexion, ankle dorsiflexion of one leg, deg.

    Args:
        planar: an OsimPlanarModel with bodies ``torso`` and ``femur_<side>``.
        q: (n, nq) model coordinates.
        side: ``r`` or ``l``.

    Returns:
        {"hip", "knee", "ankle"} -> (n,) deg, clinical signs (flexion, dorsiflexion +).
    """
    values = planar.osim_from_q(np.atleast_2d(q))
    hip_sign = clinical_joint("osim2d", f"hip_flexion_{side}").clinical(1.0)
    # a thigh flexed by hip_flexion turns by -hip_flexion about +Y (see the test)
    hip = -hip_sign * relative_pitch(planar, q, TRUNK_BODY, f"femur_{side}")
    out = {"hip": np.degrees(hip)}
    for joint in ("knee", "ankle"):
        name = f"{LEG_ANGLES[joint]}_{side}"
        out[joint] = np.degrees(clinical_joint("osim2d", name).clinical(values[name]))
    return out
