"""The ankle moment about Gait2354's subtalar axis (kinematics/subtalar_axis.py) and the
walking IK's held foot inversion (marker map ``[ik] foot_inversion``), issue 27 item 2.

Synthetic: the axis is the .osim's, mirrored on the left; a known moment along and across
it, turned through the model's ankle chain, comes back as its component along the axis;
the chain's rotation is the model's foot frame in its shank frame (Pinocchio).

Real data, through the CLI (``predgait inverse --model fullbody``, subject01 with its
static trial, ``subtalar_moments.sto``) against OpenSim's Gait2354 subtalar moment
(tests/data/opensim_gait2354_reference/inverse_dynamics.sto), stance (vertical force
> 20 N), right / left, measured: with the foot's inversion held at the model's neutral, as
Gait2354's IK holds its subtalar joint, r 0.992 / 0.956 (stance means 9.1 / 6.4 N m
against 13.8 / 12.0: our ankle centre, the malleoli mid-point, lies 10-12 mm lateral of
Gait2354's ankle joint); with the inversion fitted, r 0.897 / 0.769. The clinical (ISB
joint coordinate system) inversion moment of the same runs stays at r -0.06 / -0.71
(docs/DEVELOPING.md, tests/test_inverse3d_joint_axes.py).
"""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.cli import main
from predgait.data import read_storage
from predgait.dynamics.inverse3d_trial import FootInversion, read_marker_map
from predgait.errors import InputError
from predgait.kinematics.ankle_jcs import cardan_xyz_axes, cardan_xyz_rotation
from predgait.kinematics.subtalar_axis import subtalar_axis, subtalar_moment
from predgait.models.loading3d import fullbody_for_subject

REPO = Path(__file__).resolve().parents[1]
MAP = REPO / "problems" / "markers_fullbody_subject01.toml"
REFERENCE = Path(__file__).resolve().parent / "data" / "opensim_gait2354_reference"
DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_subject01_walk1"
GRF = {"r": "ground_force_vy", "l": "1_ground_force_vy"}


def test_axis_is_gait2354s_in_the_foot_frame():
    right, left = subtalar_axis("r"), subtalar_axis("l")
    np.testing.assert_allclose(np.linalg.norm(right), 1.0, atol=1e-6)
    # 37.2 deg above the foot's long axis, 8.7 deg medial (+Y: left, medial on the right).
    assert np.degrees(np.arcsin(right[2])) == pytest.approx(37.2, abs=0.1)
    assert np.degrees(np.arctan2(right[1], right[0])) == pytest.approx(8.7, abs=0.1)
    # The left is the mirror image (Y -> -Y), negated as Gait2354's left axis.
    np.testing.assert_allclose(left, -right * [1.0, -1.0, 1.0])
    with pytest.raises(ValueError, match="side"):
        subtalar_axis("x")


def test_cardan_rotation_is_the_models_foot_in_its_shank():
    model = fullbody_for_subject(72.6, 1.8)
    names = model.joint_names
    pm, data = model.pin_model, model.pin_model.createData()
    rng = np.random.default_rng(3)
    for side in "rl":
        q = model.neutral()
        angles = rng.uniform(-0.4, 0.4, 3)
        for coordinate, value in zip("xyz", angles, strict=True):
            q[7 + names.index(f"ankle_{side}_{coordinate}")] = value
        pin.framesForwardKinematics(pm, data, q)
        shank = data.oMf[model.frame_id(f"shank_{side}")].rotation
        foot = data.oMf[model.frame_id(f"foot_{side}")].rotation
        np.testing.assert_allclose(shank.T @ foot, cardan_xyz_rotation(angles[None])[0],
                                   atol=1e-12)


@pytest.mark.parametrize("side", ["r", "l"])
def test_moment_about_the_axis_of_a_known_wrench(side):
    rng = np.random.default_rng(7)
    q = rng.uniform(-0.5, 0.5, (20, 3))
    along = rng.uniform(-30.0, 30.0, 20)
    axis = subtalar_axis(side)
    across = np.cross(axis, rng.normal(size=(20, 3))) * 50.0   # perpendicular to the axis
    in_foot = along[:, None] * axis + across
    in_shank = np.einsum("nij,nj->ni", cardan_xyz_rotation(q), in_foot)
    tau = np.einsum("nji,nj->ni", cardan_xyz_axes(q), in_shank)   # tau_i = M . b_i
    np.testing.assert_allclose(subtalar_moment(side, q, tau), along, atol=1e-9)


def test_foot_inversion_option_is_read_and_checked(tmp_path):
    assert read_marker_map(MAP).foot_inversion is FootInversion.FITTED
    held = tmp_path / "held.toml"
    held.write_text(MAP.read_text() + '\n[ik]\nfoot_inversion = "held"\n')
    assert read_marker_map(held).foot_inversion is FootInversion.HELD
    assert FootInversion.HELD.held_coordinates() == ("ankle_r_x", "ankle_l_x")
    bad = tmp_path / "bad.toml"
    bad.write_text(MAP.read_text() + '\n[ik]\nfoot_inversion = "locked"\n')
    with pytest.raises(InputError, match="fitted, held"):
        read_marker_map(bad)


def _stance_r(folder: Path, side: str) -> float:
    reference = read_storage(REFERENCE / "inverse_dynamics.sto")
    grf = read_storage(DATA / "subject01_walk1_grf.mot")
    stance = np.interp(reference.time, grf.time, grf.column(GRF[side])) > 20.0
    ours = read_storage(folder / "subtalar_moments.sto")
    values = np.interp(reference.time, ours.time, ours.column(f"subtalar_{side}_moment"))
    theirs = reference.column(f"subtalar_angle_{side}_moment")
    assert np.isfinite(values[stance]).all()
    return float(np.corrcoef(values[stance], theirs[stance])[0, 1])


def _inverse(tmp_path: Path, foot_inversion: str) -> Path:
    marker_map = tmp_path / f"{foot_inversion}.toml"
    marker_map.write_text(MAP.read_text() + f'\n[ik]\nfoot_inversion = "{foot_inversion}"\n')
    out = tmp_path / foot_inversion
    assert main(["inverse", str(DATA / "subject01_walk1.trc"), "--grf",
                 str(DATA / "subject01_walk1_grf.mot"), "--static",
                 str(DATA / "subject01_static.trc"), "--mass", "72.6", "--height", "1.8034",
                 "--model", "fullbody", "--marker-map", str(marker_map), "--out", str(out),
                 "--no-plots"]) == 0
    return out


def test_subject01_subtalar_moment_agrees_with_opensims(tmp_path):
    if not DATA.is_dir():
        pytest.skip("shared data not available")
    held = _inverse(tmp_path, "held")
    header = (held / "subtalar_moments.sto").read_text().split("endheader")[0]
    assert "Gait2354's subtalar axis" in header and "units=N m" in header
    assert "foot_inversion=held" in header
    r_held = {side: _stance_r(held, side) for side in "rl"}
    assert min(r_held.values()) >= 0.8, r_held                  # measured 0.992 / 0.956
    # With the foot's roll fitted to its markers the axis rolls with it: the left foot's
    # agreement drops (measured 0.769), which is why the hold compares like with like.
    fitted = _inverse(tmp_path, "fitted")
    assert _stance_r(fitted, "l") < r_held["l"] - 0.1
