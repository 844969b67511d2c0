"""predgait's planar inverse dynamics against OpenSim's own results on the same trial.

OpenSim's Gait2354 pipeline (scaled 3D model, IK, InverseDynamicsTool with coordinates
low-passed at 6 Hz) was run by the OpenSim team on the very markers and ground reactions
predgait bundles (tests/data/opensim_gait2354_reference/README.md). Different models (3D
with a pelvis vs a planar foot-shank-thigh), different joint centres (OpenSim's scaled
model vs Harrington + static calibration) and different IK: the curves must have the same
shape and timing, and stay within the differences such model choices are known to make.

The bounds are measured margins, not wishes (right / left, t = 0.4..1.6 s):
ankle r = 0.997 / 0.996, RMS 0.07 / 0.10 N m/kg; knee r = 0.983 / 0.943, RMS 0.10 / 0.17;
hip r = 0.83 / 0.80, RMS 0.21 / 0.24 (the hip depends most on the hip-centre estimate
and on the pelvis the planar model lacks). Measured cause: Harrington's hip centre lies
27 / 28 mm anterior and 21 / 14 mm superior of the hip of OpenSim's scaled model
(subject01_simbody.osim posed by its own IK, opensim-models commit 20a888b); with our hip
centre moved there, the hip RMS falls to 0.11 / 0.12 (r 0.95 / 0.93): about 700 N x 27 mm =
0.26 N m/kg in stance. Harrington's regression (validated against imaging) is kept.
A one-frame (17 ms) time misalignment drops the ankle r to 0.990 and fails; a sign error
or a 10 % scale error fails too.
"""

from pathlib import Path

import numpy as np
import pytest

from predgait.data import read_storage
from predgait.dynamics.inverse_trial import bundled_inverse

REFERENCE = Path(__file__).resolve().parent / "data" / "opensim_gait2354_reference"
MASS = 72.6

#: predgait clinical moment -> (OpenSim coordinate, sign), min Pearson r, max RMS N m/kg.
MOMENTS = {
    "ankle_dorsiflexion_moment": ("ankle_angle", 1.0, 0.993, 0.12),
    "knee_flexion_moment": ("knee_angle", -1.0, 0.92, 0.22),
    "hip_flexion_moment": ("hip_flexion", 1.0, 0.75, 0.30),
}


def on_reference_times(result, values, times):
    """Our values at the reference times (both are the 60 Hz marker frames)."""
    lab_time = result.time + result.provenance["time_zero_s"]
    assert lab_time[0] <= times[0] and times[-1] <= lab_time[-1]
    return np.interp(times, lab_time, values)


@pytest.fixture(scope="module")
def opensim_id():
    storage = read_storage(REFERENCE / "inverse_dynamics.sto")
    assert not storage.in_degrees
    return storage


@pytest.fixture(scope="module")
def opensim_ik():
    storage = read_storage(REFERENCE / "subject01_walk1_ik.mot")
    assert storage.in_degrees
    return storage


@pytest.mark.parametrize("side", ["right", "left"])
@pytest.mark.parametrize("moment", list(MOMENTS))
def test_moments_match_opensim_inverse_dynamics(opensim_id, side, moment):
    coordinate, sign, min_r, max_rms = MOMENTS[moment]
    result = bundled_inverse(side)
    theirs = sign * opensim_id.column(f"{coordinate}_{side[0]}_moment") / MASS
    ours = on_reference_times(result, result.clinical_moments()[moment] / result.body_mass,
                              opensim_id.time)
    r = np.corrcoef(ours, theirs)[0, 1]
    rms = np.sqrt(np.mean((ours - theirs) ** 2))
    assert r >= min_r, (side, moment, r)
    assert rms <= max_rms, (side, moment, rms)


def test_push_off_peak_matches_opensim(opensim_id):
    """Right push-off (inside the reference window): the peak plantarflexor moment."""
    result = bundled_inverse("right")
    theirs = opensim_id.column("ankle_angle_r_moment")
    ours = on_reference_times(result, result.clinical_moments()["ankle_dorsiflexion_moment"],
                              opensim_id.time)
    assert ours.min() / MASS == pytest.approx(theirs.min() / MASS, abs=0.15)  # -1.71 vs -1.76
    t_ours, t_theirs = opensim_id.time[np.argmin(ours)], opensim_id.time[np.argmin(theirs)]
    assert t_ours == pytest.approx(t_theirs, abs=0.034)                        # 2 frames


#: clinical angle -> min r, max |mean offset| deg, max RMS deg after removing the offset.
ANGLES = {
    "hip_flexion": (0.99, 6.0, 3.0),
    "knee_flexion": (0.99, 8.0, 3.5),
    "ankle_dorsiflexion": (0.95, 4.0, 3.0),
}


def opensim_angle(ik, name, s):
    if name == "hip_flexion":   # thigh against the vertical: hip flexion + pelvis tilt
        return ik.column(f"hip_flexion_{s}") + ik.column("pelvis_tilt")
    if name == "knee_flexion":
        return -ik.column(f"knee_angle_{s}")
    return ik.column(f"ankle_angle_{s}")


@pytest.mark.parametrize("side", ["right", "left"])
@pytest.mark.parametrize("angle", list(ANGLES))
def test_angles_match_opensim_inverse_kinematics(opensim_ik, side, angle):
    """Shapes agree closely; constant offsets come from the segment-axis definitions.

    Measured offsets (predgait - OpenSim): knee -6.7 / -2.6 deg (right / left): predgait's
    knee angle is between the hip-knee and knee-ankle joint-centre lines, which already
    read -4.8 / -2.5 deg in the static standing trial, while OpenSim's is the scaled
    model's femur-tibia angle; hip -4.4 / -2.9 deg; ankle -1.3 / +2.7 deg.
    """
    min_r, max_offset, max_rms = ANGLES[angle]
    result = bundled_inverse(side)
    theirs = opensim_angle(opensim_ik, angle, side[0])
    ours = on_reference_times(result, np.degrees(result.clinical_angles()[angle]),
                              opensim_ik.time)
    difference = ours - theirs
    assert np.corrcoef(ours, theirs)[0, 1] >= min_r
    assert abs(difference.mean()) <= max_offset, difference.mean()
    assert np.sqrt(np.mean((difference - difference.mean()) ** 2)) <= max_rms


#: Knee flexion calibrated on the static trial vs OpenSim's IK: max RMS deg (measured
#: 3.2 / 2.2 right / left; the uncalibrated hinge angle: 7.2 / 3.4).
ANATOMICAL_KNEE_RMS = {"right": 3.5, "left": 2.5}


@pytest.mark.parametrize("side", ["right", "left"])
def test_anatomical_knee_angle_matches_opensim(opensim_ik, side):
    """Standing straight reads 0: the hinge angle minus its static-trial value."""
    result = bundled_inverse(side)
    assert np.degrees(result.knee_static) == pytest.approx(
        {"right": -4.8, "left": -2.5}[side], abs=0.1)     # hyperextended joint-centre lines
    theirs = opensim_angle(opensim_ik, "knee_flexion", side[0])
    ours = on_reference_times(result, np.degrees(result.anatomical_angles()["knee_flexion"]),
                              opensim_ik.time)
    raw = on_reference_times(result, np.degrees(result.clinical_angles()["knee_flexion"]),
                             opensim_ik.time)
    rms, rms_raw = (np.sqrt(np.mean((x - theirs) ** 2)) for x in (ours, raw))
    assert np.corrcoef(ours, theirs)[0, 1] >= 0.99
    assert rms <= ANATOMICAL_KNEE_RMS[side] < rms_raw
