"""Riener & Edrich (1999): passive elastic knee and ankle moments of the relaxed leg.

R. Riener, T. Edrich, "Identification of passive elastic joint moments in the lower
extremities", J Biomech 32:539-544 (1999): moments measured on ten healthy subjects with
relaxed muscles, fitted as sums of exponentials of the hip, knee and ankle angles (the
bi-articular muscles couple the joints). In the paper's terms, angles in DEGREES
(h hip flexion, k knee flexion, a ankle PLANTARflexion, 0 = upright standing) and each
moment (N m) positive toward its joint's positive angle:

    M_knee  = exp(1.800 - 0.0460 a - 0.0352 k + 0.0217 h)
              - exp(-3.971 - 0.0004 a + 0.0495 k - 0.0128 h) - 4.820
              + exp(2.220 - 0.150 k)
    M_ankle = exp(2.1016 - 0.0843 a - 0.0176 k) - exp(-7.9763 + 0.1949 a + 0.0008 k)
              - 1.792

Where the equations and conventions were taken from: gurchiek/nms-dyn,
general_library/biomx/MuscleContractionDynamics/PassiveJointMomentModelsWithMuscles/
rienerEdrich1999Passive{Knee,Ankle}Moment.m (commit fecab56; "flipped sign of ankle
angle [and ankle moment] from riener and edrich paper s.t. dorsiflexion > 0"). One
coefficient differs there: its knee extension term reads exp(2.220 - 1.50 k). It is
taken here as 0.150 per degree: every other angle coefficient of the paper is below
0.2 per degree, and 1.50 would make the term vanish (< 0.01 N m) 5 deg into flexion, an
extension stop stiffer than any the paper's subjects could be measured against; check
it against the paper before relying on the knee within ~15 deg of full extension.

The signs agree with the anatomy, which checks the conventions: with the knee straight a
dorsiflexed ankle stretches the gastrocnemius, so the ankle is pushed into plantarflexion
(M_ankle > 0 for a < 0) and the knee into flexion (-0.0460 a), less so with the knee flexed
(-0.0176 k); hip flexion stretches the hamstrings (+0.0217 h, knee flexion moment); deep
knee flexion stretches the quadriceps (-exp(... + 0.0495 k), an extension moment) and hip
flexion slackens rectus femoris (-0.0128 h).

In predgait's clinical convention (:mod:`predgait.kinematics.clinical`: knee flexion and
ankle DORSIflexion positive, rad; a moment positive toward the positive angle) the knee
moment is M_knee itself and the ankle dorsiflexion moment is -M_ankle, with
a = -dorsiflexion. The leg model has no pelvis, so its hip flexion is the thigh against
the vertical; the paper's is the thigh against the pelvis, larger by the pelvis' anterior
tilt (~10 deg in walking): see :data:`HIP_TILT_DEG`.
"""

from __future__ import annotations

import numpy as np

#: The paper, for outputs.
SOURCE = ("Riener & Edrich 1999, J Biomech 32:539-544 (coefficients and signs as in "
          "gurchiek/nms-dyn, knee extension term 0.150/deg)")
#: Typical anterior pelvic tilt in walking, deg (e.g. Perry & Burnfield 2010, Gait
#: Analysis, 2nd ed.): the hip angle against the pelvis exceeds the thigh's against the vertical by
#: about this much; outputs show the literature knee moment with it as a sensitivity.
HIP_TILT_DEG = 10.0


def knee_moment(hip_flexion, knee_flexion, ankle_dorsiflexion):
    """Passive knee flexion moment, N m (clinical; angles in rad, arrays broadcast)."""
    h, k = np.degrees(hip_flexion), np.degrees(knee_flexion)
    a = -np.degrees(ankle_dorsiflexion)          # the paper's plantarflexion
    return (np.exp(1.800 - 0.0460 * a - 0.0352 * k + 0.0217 * h)
            - np.exp(-3.971 - 0.0004 * a + 0.0495 * k - 0.0128 * h) - 4.820
            + np.exp(2.220 - 0.150 * k))


def ankle_moment(knee_flexion, ankle_dorsiflexion):
    """Passive ankle dorsiflexion moment, N m (clinical; angles in rad, arrays broadcast)."""
    k = np.degrees(knee_flexion)
    a = -np.degrees(ankle_dorsiflexion)          # the paper's plantarflexion
    plantarflexion_moment = (np.exp(2.1016 - 0.0843 * a - 0.0176 * k)
                             - np.exp(-7.9763 + 0.1949 * a + 0.0008 * k) - 1.792)
    return -plantarflexion_moment


def passive_moment(joint: str, hip_flexion, knee_flexion, ankle_dorsiflexion):
    """``knee`` or ``ankle`` passive clinical moment, N m, at clinical angles (rad)."""
    if joint == "knee":
        return knee_moment(hip_flexion, knee_flexion, ankle_dorsiflexion)
    if joint == "ankle":
        return ankle_moment(knee_flexion, ankle_dorsiflexion)
    raise ValueError(f"Riener & Edrich 1999 give the knee and the ankle, not {joint!r}")
