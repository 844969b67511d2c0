"""Static-free foot-flat calibration (kinematics/foot_flat.py): a synthetic foot whose toe
marker sits higher than the model assumes is levelled by the recovered angle; walking5's
soles stand on the floor at loaded mid-stance; the URDF follows the moved sole frames."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.data.trial import ForcePlate, Markers
from predgait.dynamics.inverse3d import foot_points
from predgait.dynamics.inverse3d_trial import inverse_fullbody, read_marker_map, read_trial
from predgait.errors import InputError
from predgait.kinematics.foot_flat import (
    FootFlatMode,
    foot_poses,
    levelling_rotation,
    sole_frames,
)
from predgait.models.loading3d import fullbody_for_subject, model3d_from_urdf
from predgait.simulations.forward3d import FullbodyDrive, measured_ground

MASS, HEIGHT = 70.0, 1.75
TOE_RAISE = 0.02  # m: the toe marker 2 cm higher on the foot than the model's
FRAMES = ("asis_r", "asis_l", "psis_r", "psis_l", "knee_lat_r", "knee_lat_l", "knee_center_r",
          "knee_center_l", "ankle_lat_r", "ankle_lat_l", "ankle_center_r", "ankle_center_l",
          "heel_r", "heel_l", "toe_r", "toe_l", "c7", "sternum")
WALKING5 = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_walking5_c3d"


def test_levelling_rotation_turns_the_mean_vertical_onto_the_foot_z():
    tilt = pin.rpy.rpyToMatrix(np.radians(3.0), np.radians(-7.0), 0.4)  # roll, pitch, yaw
    rot = np.array([pin.rpy.rpyToMatrix(0.0, 0.0, yaw) @ tilt for yaw in (0.0, 0.05, -0.05)])
    correction, pitch, roll = levelling_rotation(rot)
    for r in rot:
        assert np.degrees(np.arccos((r @ correction)[2, 2])) < 0.01
    assert pitch == pytest.approx(-7.0, abs=0.05)  # foot X above the horizontal: toe up
    assert roll == pytest.approx(3.0, abs=0.05)  # foot +Y above the horizontal


def standing_trial(model, offset, n=30):
    """Markers of a standing body with the feet flat on z = 0; two plates.

    ``offset(side, frame, xyz)`` gives a foot marker's position in the foot frame on this
    subject from the model's (xyz, m).
    """
    pm, data = model.pin_model, model.pin_model.createData()
    time = np.arange(n) / 100.0
    qs = []
    for t in time:
        q = model.neutral()
        q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, 0.0, 0.3)).coeffs()
        q[model.joint_velocity_index("lumbar_y") + 1] = 0.1 * np.sin(4 * t)  # trunk sways
        qs.append(q)
    qs = np.array(qs)
    pin.framesForwardKinematics(pm, data, qs[0])
    qs[:, 2] -= data.oMf[model.frame_id("heel_contact_r")].translation[2]
    xyz = np.empty((n, len(FRAMES), 3))
    for k, q in enumerate(qs):
        pin.framesForwardKinematics(pm, data, q)
        for i, f in enumerate(FRAMES):
            xyz[k, i] = data.oMf[model.frame_id(f)].translation
            if f.startswith(("heel_", "toe_")):
                foot = data.oMf[model.frame_id(f"foot_{f[-1]}")]
                xyz[k, i] = foot.act(offset(f[-1], f, foot.actInv(xyz[k, i])))
    feet = foot_points(model, qs)
    plates = []
    for side in "rl":
        cop = 0.5 * (feet[side][0] + feet[side][1])
        force = np.tile([0.0, 0.0, 0.5 * MASS * 9.81], (n, 1))
        plates.append(ForcePlate(time, force, cop, np.zeros((n, 3)), side))
    names = tuple(f.upper() for f in FRAMES)
    return Markers(time, names, xyz, 100.0, "synthetic standing"), plates


def raised_toe(side, frame, xyz):
    return xyz + [0.0, 0.0, TOE_RAISE] if frame.startswith("toe_") else xyz


def marker_map(tmp_path, foot_flat="auto"):
    lines = ["[markers]", *(f'{f} = "{f.upper()}"' for f in FRAMES),
             "[calibration]", f'foot_flat = "{foot_flat}"']
    path = tmp_path / "map.toml"
    path.write_text("\n".join(lines) + "\n")
    return read_marker_map(path)


def procrustes_pitch(model, side):
    """Pitch (deg, toe down +) of the rotation about the ankle that best fits the model's
    heel and toe offsets to the raised markers (orthogonal Procrustes, SVD)."""
    pm = model.pin_model
    foot = pm.frames[model.frame_id(f"foot_{side}")].placement
    a = np.array([foot.actInv(pm.frames[model.frame_id(f"{m}_{side}")].placement).translation
                  for m in ("heel", "toe")])
    b = np.array([a[0], raised_toe(side, f"toe_{side}", a[1])])
    u, _, vt = np.linalg.svd(a.T @ b)
    rot = vt.T @ np.diag([1.0, 1.0, np.linalg.det(vt.T @ u.T)]) @ u.T
    return np.degrees(np.arctan2(-rot[2, 0], rot[2, 2]))  # lab vertical's X in the fit foot


PITCH = 6.0  # deg, toe down: the heel and toe markers of a foot pitched about the ankle


@pytest.mark.parametrize("case", ["raised toe", "pitched markers"])
def test_foot_markers_off_the_model_are_levelled_by_the_recovered_angle(tmp_path, case):
    model = fullbody_for_subject(MASS, HEIGHT)
    if case == "raised toe":  # a rigid fit cannot match: Procrustes angle, IK compromise
        offset, expected, tolerance, depth = raised_toe, procrustes_pitch, 0.3, 3e-3
    else:  # markers of the model's foot pitched by PITCH: IK recovers it exactly
        pitch = pin.rpy.rpyToMatrix(0.0, np.radians(PITCH), 0.0)

        def offset(side, frame, xyz):
            return pitch @ xyz

        def expected(model, side):
            return PITCH
        tolerance, depth = 0.05, 2e-4  # (the summary rounds to 0.1 mm)
    markers, plates = standing_trial(model, offset)
    off = inverse_fullbody(markers, plates, marker_map(tmp_path, "off"), mass=MASS,
                           height=HEIGHT, cutoff=None)
    on = inverse_fullbody(markers, plates, marker_map(tmp_path), mass=MASS, height=HEIGHT,
                          cutoff=None)
    assert off.provenance["foot_flat_calibration"] is None
    report = on.provenance["foot_flat_calibration"]
    for side in "rl":
        heel_off, toe_off = foot_points(off.model, off.q)[side]
        assert np.all(np.abs(heel_off[:, 2] - toe_off[:, 2]) > 0.01)  # tilted without
        heel, toe = foot_points(on.model, on.q)[side]
        assert np.abs(heel[:, 2]).max() < 1e-3 and np.abs(toe[:, 2]).max() < 1e-3
        rot, _ = foot_poses(on.model, on.q, side)
        assert np.degrees(np.arccos(np.clip(rot[:, 2, 2], -1.0, 1.0))).max() < 0.1
        entry = report[side]
        assert entry["frames"] == markers.n_frames
        assert entry["pitch_corrected_deg"] == pytest.approx(expected(model, side),
                                                             abs=tolerance)
        assert abs(entry["pitch_corrected_deg"]) > 3.0
        assert abs(entry["roll_corrected_deg"]) < 0.1
        assert entry["sole_depth_m"] == pytest.approx(entry["model_sole_depth_m"], abs=depth)


def test_sole_frames_move_in_the_urdf_too_and_the_plates_are_the_floor(tmp_path):
    model = fullbody_for_subject(MASS, HEIGHT)
    markers, plates = standing_trial(model, raised_toe)
    plates = [replace(p, cop=p.cop - [0.0, 0.0, 0.03]) for p in plates]  # floor 3 cm lower
    on = inverse_fullbody(markers, plates, marker_map(tmp_path), mass=MASS, height=HEIGHT,
                          cutoff=None)
    rebuilt = model3d_from_urdf(on.model.urdf)
    frames = sole_frames(on.model, "r") + sole_frames(on.model, "l")
    assert len(frames) >= 4
    for frame in frames:  # the centre-line points and the medial and lateral edges
        placed = on.model.pin_model.frames[on.model.frame_id(frame)].placement.translation
        again = rebuilt.pin_model.frames[rebuilt.frame_id(frame)].placement.translation
        np.testing.assert_allclose(again, placed, atol=1e-9)
    pm, data = on.model.pin_model, on.model.pin_model.createData()
    for q in on.q:
        pin.framesForwardKinematics(pm, data, q)
        heights = [data.oMf[on.model.frame_id(f)].translation[2] for f in frames]
        np.testing.assert_allclose(heights, -0.03, atol=1e-3)
    # The engine's and the tracking's floor is the plates' surface the soles were set on.
    floor, _ = measured_ground(FullbodyDrive.from_inverse(on))
    assert floor == pytest.approx(-0.03, abs=1e-4)


def test_bad_foot_flat_value_names_the_key(tmp_path):
    with pytest.raises(InputError, match="foot_flat"):
        marker_map(tmp_path, "sideways")


@pytest.mark.skipif(not (WALKING5 / "walking5.c3d").exists(), reason="walking5 not present")
def test_walking5_soles_on_the_floor_at_mid_stance():
    markers, plates = read_trial([WALKING5 / "walking5.c3d"])
    mmap = read_marker_map(Path(__file__).parents[1] / "problems"
                           / "markers_fullbody_walking5.toml")
    before = inverse_fullbody(markers, plates, replace(mmap, foot_flat=FootFlatMode.OFF),
                              mass=72.0, height=1.75)
    after = inverse_fullbody(markers, plates, mmap, mass=72.0, height=1.75)
    report = after.provenance["foot_flat_calibration"]
    for side in "rl":
        entry = report[side]
        assert entry["frames"] >= 5
        t0, t1 = entry["time_s"]
        flat = (after.ik.time >= t0) & (after.ik.time <= t1)
        heel, toe = foot_points(after.model, after.q)[side]
        assert np.abs(heel[flat, 2]).max() < 0.003 and np.abs(toe[flat, 2]).max() < 0.003
        heel0, toe0 = foot_points(before.model, before.q)[side]
        assert (heel0[flat, 2] - toe0[flat, 2]).min() > 0.015  # toe down before
        assert 3.0 < entry["pitch_corrected_deg"] < 12.0
    assert after.ik.flagged.sum() == before.ik.flagged.sum()
