"""3D inverse kinematics recovers known joint angles from synthesized markers."""

import numpy as np
import pinocchio as pin
import pytest

from predgait.errors import InputError
from predgait.kinematics.ik3d import (
    calibrate_markers,
    pelvis_cardan,
    solve_ik,
    weighted_rms,
    with_marker_frames,
)
from predgait.models.loading3d import load_fullbody

BODIES = ("pelvis", "torso", "thigh_r", "shank_r", "foot_r", "thigh_l", "shank_l", "foot_l",
          "upper_arm_r", "forearm_r", "upper_arm_l", "forearm_l")


@pytest.fixture(scope="module")
def setup():
    rng = np.random.default_rng(1)
    placements = {}
    for body in BODIES:  # three non-collinear markers on every segment
        down = 0.0 if body in ("pelvis", "torso", "foot_r", "foot_l") else -0.15
        for j in range(3):
            placements[f"{body}_m{j}"] = (body, rng.uniform(-0.1, 0.1, 3) + [0, 0, down])
    model = with_marker_frames(load_fullbody(), placements)
    pm, data = model.pin_model, model.pin_model.createData()
    n = 20
    time = np.arange(n) / 60
    lower, upper = pm.lowerPositionLimit[7:], pm.upperPositionLimit[7:]
    amp, phase = rng.uniform(0.05, 0.3, 29), rng.uniform(0, 6, 29)
    elbows = [model.joint_names.index(f"elbow_{s}") for s in "rl"]
    qs = []
    for t in time:
        q = model.neutral()
        q[:3] = [0.6 + 1.2 * t, 0.01, 0.95]
        rot = pin.rpy.rpyToMatrix(0.05 * np.sin(6 * t), 0.1, 0.3 * np.sin(3 * t))
        q[3:7] = pin.Quaternion(rot).coeffs()
        q[7:] = np.clip(amp * np.sin(2 * np.pi * t + phase), lower + 0.01, upper - 0.01)
        q[7:][elbows] = -0.5  # a bent elbow makes the humerus' axial rotation observable
        qs.append(q)
    qs = np.array(qs)
    frames = tuple(placements)
    ids = [model.frame_id(f) for f in frames]
    xyz = np.empty((n, len(frames), 3))
    for k in range(n):
        pin.framesForwardKinematics(pm, data, qs[k])
        xyz[k] = [data.oMf[i].translation for i in ids]
    return model, time, qs, frames, xyz, rng


def test_recovers_angles_exact_markers(setup):
    model, time, qs, frames, xyz, _ = setup
    result = solve_ik(model, time, xyz, frames)
    assert result.converged.all()
    assert result.rms.max() < 1e-6
    np.testing.assert_allclose(result.q[:, 7:], qs[:, 7:], atol=1e-4)
    np.testing.assert_allclose(result.q[:, :3], qs[:, :3], atol=1e-6)
    np.testing.assert_allclose(pelvis_cardan(result.q), pelvis_cardan(qs), atol=1e-4)


def test_recovers_angles_with_noise(setup):
    model, time, qs, frames, xyz, rng = setup
    noisy = xyz + rng.normal(0, 0.001, xyz.shape)  # 1 mm
    result = solve_ik(model, time, noisy, frames)
    assert result.converged.all()
    assert 0.0005 < np.median(result.rms) < 0.0015
    assert np.degrees(np.abs(result.q[:, 7:] - qs[:, 7:])).max() < 3.0


def test_missing_markers_and_flagged_frames(setup):
    model, time, qs, frames, xyz, _ = setup
    bad = xyz.copy()
    bad[5, 0] = np.nan                  # a missing marker: left out of that frame
    bad[9, 4] += [0.0, 0.0, 0.5]        # a marker 0.5 m off: frame flagged, run goes on
    result = solve_ik(model, time, bad, frames)
    assert np.isnan(result.residuals[5, 0])
    np.testing.assert_allclose(result.q[5, 7:], qs[5, 7:], atol=1e-3)
    assert list(result.failed_frames) == [9]
    assert result.converged[10:].all()


def test_frames_are_flagged_on_the_weighted_error(setup):
    """A marker the fit weighs 0.2 half a metre off: the all-marker RMS (~0.08 m) is over
    the 0.05 m flag, the weighted one (~0.04 m) is not; the trusted markers stay exact."""
    model, time, qs, frames, xyz, _ = setup
    bad = xyz.copy()
    bad[9, 4] += [0.0, 0.0, 0.5]
    weights = {frames[4]: 0.2}
    result = solve_ik(model, time, bad, frames, weights=weights)
    assert result.rms[9] > 0.05 > result.weighted_rms[9]
    assert result.converged.all()
    assert result.trusted_rms()[9] < result.weighted_rms[9] < result.rms[9]
    assert result.trusted_rms()[:9].max() < 1e-6
    # The weighted RMS is sqrt(sum w r^2 / sum w) over the visible markers.
    residuals = np.array([[0.01, 0.1, np.nan], [0.02, np.nan, np.nan]])
    np.testing.assert_allclose(weighted_rms(residuals, [1.0, 0.2, 5.0]),
                               [np.sqrt((1e-4 + 0.2 * 1e-2) / 1.2), 0.02])


def test_calibration_recovers_marker_offsets(setup):
    model, time, qs, frames, xyz, _ = setup
    moved = with_marker_frames(model, {"thigh_r_m0": ("thigh_r", np.array([0.0, -0.05, -0.2]))})
    calibrated = calibrate_markers(moved, qs, xyz[:, 6:9], frames[6:9], {})
    data = calibrated.pin_model.createData()
    pin.framesForwardKinematics(calibrated.pin_model, data, qs[3])
    got = data.oMf[calibrated.frame_id("thigh_r_m0")].translation
    np.testing.assert_allclose(got, xyz[3, frames.index("thigh_r_m0")], atol=1e-12)


def test_bad_input(setup):
    model, time, _, frames, xyz, _ = setup
    with pytest.raises(InputError, match="shape"):
        solve_ik(model, time, xyz[:, :3], frames)
    with pytest.raises(InputError, match="no frame"):
        solve_ik(model, time, xyz[:, :1], ("nose",))


def test_frames_beyond_a_joint_limit_are_flagged_not_clipped(setup):
    """A right knee range narrowed below the motion: those frames end on the limit and are
    flagged (never outside it); the other frames fit the markers exactly."""
    model, time, qs, frames, xyz, _ = setup
    pm = pin.Model(model.pin_model)
    knee = pm.joints[pm.getJointId("knee_r_y")]   # flexion
    column = knee.idx_q
    values = qs[:, column]
    cut = float(np.median(values))
    upper = pm.upperPositionLimit.copy()
    upper[column] = cut
    pm.upperPositionLimit = upper
    narrow = type(model)(urdf=model.urdf, kind=model.kind, pin_model=pm, gravity=model.gravity,
                         source="narrowed knee")
    result = solve_ik(narrow, time, xyz, frames)
    beyond = values > cut + 1e-6
    assert beyond.any() and (~beyond).any()
    np.testing.assert_array_equal(~result.converged, beyond)
    assert result.at_limit[beyond, knee.idx_v].all()
    assert np.all(result.q[:, column] <= cut + 1e-12)
    assert result.rms[~beyond].max() < 1e-6


def test_a_limit_margin_widens_the_range(setup):
    """The same narrowed knee with a margin past the motion: nothing flagged, exact fit."""
    from predgait.kinematics.ik3d import IKOptions

    model, time, qs, frames, xyz, _ = setup
    pm = pin.Model(model.pin_model)
    column = pm.joints[pm.getJointId("knee_r_y")].idx_q
    upper = pm.upperPositionLimit.copy()
    upper[column] = float(np.median(qs[:, column]))
    pm.upperPositionLimit = upper
    narrow = type(model)(urdf=model.urdf, kind=model.kind, pin_model=pm, gravity=model.gravity,
                         source="narrowed knee")
    margin = float(qs[:, column].max() - upper[column]) + 0.05
    result = solve_ik(narrow, time, xyz, frames, options=IKOptions(limit_margin=margin))
    assert result.converged.all()
    assert result.rms.max() < 1e-6
