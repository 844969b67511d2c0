"""Clinical leg angles of 2D_gait.osim: hip flexion is the thigh against the trunk."""

import numpy as np
import pytest

from predgait.kinematics.osim2d_angles import leg_angles_deg
from predgait.models.osim_model import build_model
from predgait.problems.muscle_prediction import bundled_file


@pytest.fixture(scope="module")
def planar():
    return build_model(bundled_file("2D_gait.osim"))


def _q(planar, rng):
    values = {c: rng.uniform(-0.6, 0.6) for c in planar.osim_coordinates}
    return values, planar.q_from_osim(values)


@pytest.mark.parametrize("side", ["r", "l"])
def test_hip_is_thigh_against_trunk(planar, side):
    """All pin joints of 2D_gait.osim turn about the same axis, so the thigh-trunk angle is
    hip_flexion - lumbar whatever the pelvis does (the closed form, not the code's FK)."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        values, q = _q(planar, rng)
        angles = leg_angles_deg(planar, q[None], side)
        expected = np.degrees(values[f"hip_flexion_{side}"] - values["lumbar"])
        assert angles["hip"][0] == pytest.approx(expected, abs=1e-9)
        assert angles["knee"][0] == pytest.approx(-np.degrees(values[f"knee_angle_{side}"]))
        assert angles["ankle"][0] == pytest.approx(np.degrees(values[f"ankle_angle_{side}"]))


def test_pelvis_tilt_alone_is_not_hip_flexion(planar):
    values = {c: 0.0 for c in planar.osim_coordinates} | {"pelvis_tilt": -0.35}
    angles = leg_angles_deg(planar, planar.q_from_osim(values)[None], "r")
    assert angles["hip"][0] == pytest.approx(0.0, abs=1e-9)
