"""The leg's and gait7's motions as OpenSim's 2D gait model's coordinates (issue 31, item 5).

Known answers: set angles written as a .mot read back (predgait's STO/MOT reader) in
degrees with OpenSim's signs (knee_angle negative in flexion). Structure: on the bundled
2D_gait.osim built by predgait (joint values equal to OpenSim's), the written coordinates
turn the femur, tibia and calcaneus as predgait's thigh, shank and foot and put the hip
centre on predgait's (1e-9). With OpenSim 4.6 in ``$OPENSIM_PYTHON``
(benchmarks/opensim_planar_motion.py) OpenSim itself loads the .mot on 2D_gait.osim and
gives the same poses; otherwise that test is skipped, "peer not available".
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.data.storage import read_storage
from predgait.dynamics.gait7_motion import gait7_model
from predgait.errors import InputError
from predgait.kinematics.osim2d_angles import relative_pitch
from predgait.kinematics.osim2d_motion import (
    HIP_IN_PELVIS,
    TRANSLATIONS,
    osim2d_coordinates,
    write_osim2d_motion,
)
from predgait.models.loading import load_model
from predgait.models.osim import bundled_2d_gait, bundled_2d_gait_path
from predgait.models.osim_model import build_model

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
TIME = np.array([0.0, 0.01, 0.02])


def _frame_positions(model, q, frame: str) -> np.ndarray:
    pm = model.pin_model
    data = pm.createData()
    fid = pm.getFrameId(frame)
    out = []
    for row in np.atleast_2d(q):
        pin.framesForwardKinematics(pm, data, row)
        out.append(data.oMf[fid].translation.copy())
    return np.array(out)


def _leg_q() -> np.ndarray:
    """Leg poses: foot pitch, ankle, knee (rad); ankle centre at x, z (m)."""
    return np.array([[0.30, 0.08, 0.10, 0.20, -0.50],
                     [0.45, 0.09, -0.20, 0.10, -1.00],
                     [0.60, 0.08, 0.00, 0.00, 0.00]])


@pytest.fixture(scope="module")
def planar():
    return build_model(bundled_2d_gait())


def test_leg_angles_read_back_in_degrees_with_opensims_signs(tmp_path):
    leg = load_model("leg")
    q = _leg_q()
    write_osim2d_motion(tmp_path / "motion.mot", leg, TIME, q, side="right")
    mot = read_storage(tmp_path / "motion.mot")
    assert mot.in_degrees and mot.header["units"].startswith("deg")
    # row 0: thigh pitch 0.1 + 0.2 - 0.5 = -0.2 rad -> hip flexion +11.46 deg; knee
    # flexed 0.5 rad -> knee_angle -28.65 deg; ankle dorsiflexed 0.2 rad -> +11.46 deg
    np.testing.assert_allclose(mot.column("hip_flexion_r"), [11.459156, 63.025357, 0.0],
                               atol=1e-5)
    np.testing.assert_allclose(mot.column("knee_angle_r"), [-28.647890, -57.295780, 0.0],
                               atol=1e-5)
    np.testing.assert_allclose(mot.column("ankle_angle_r"), [11.459156, 5.729578, 0.0],
                               atol=1e-5)
    np.testing.assert_array_equal(mot.column("pelvis_tilt"), 0.0)
    # row 2 stands upright: the hip centre is the shank and thigh lengths above the ankle
    lengths = _frame_positions(leg, np.zeros(5), "hip_center")[0, 2]
    assert mot.column("pelvis_tx")[2] == pytest.approx(0.60 - HIP_IN_PELVIS[0], abs=1e-9)
    assert mot.column("pelvis_ty")[2] == pytest.approx(0.08 + lengths - HIP_IN_PELVIS[1],
                                                       abs=1e-9)
    write_osim2d_motion(tmp_path / "left.mot", leg, TIME, q, side="left")
    left = read_storage(tmp_path / "left.mot")
    assert set(left.columns) == {"pelvis_tilt", "pelvis_tx", "pelvis_ty", "hip_flexion_l",
                                 "knee_angle_l", "ankle_angle_l"}
    np.testing.assert_array_equal(left.column("knee_angle_l"), mot.column("knee_angle_r"))


def test_gait7_angles_read_back_in_degrees_with_opensims_signs(tmp_path):
    model = gait7_model(72.6, 1.8034)
    q = np.zeros((3, model.nq))
    values = {"base_x": 1.2, "base_z": 0.9, "base_pitch": 0.1, "hip_r": 0.3, "knee_r": 0.6,
              "ankle_r": 0.2, "hip_l": -0.4, "knee_l": 0.1, "ankle_l": -0.15}
    for name, value in values.items():
        q[:, model.coordinate_index(name)] = value
    write_osim2d_motion(tmp_path / "motion.mot", model, TIME, q)
    mot = read_storage(tmp_path / "motion.mot")
    expected = {"pelvis_tilt": -5.729578,      # HAT leaning forward 0.1 rad
                "hip_flexion_r": -17.188734,   # hip extended 0.3 rad
                "knee_angle_r": -34.377468,    # knee flexed 0.6 rad
                "ankle_angle_r": -11.459156,   # plantarflexed 0.2 rad
                "hip_flexion_l": 22.918312, "knee_angle_l": -5.729578,
                "ankle_angle_l": 8.594367, "lumbar": 0.0}
    for name, value in expected.items():
        np.testing.assert_allclose(mot.column(name), value, atol=1e-5, err_msg=name)
    c, s = np.cos(-0.1), np.sin(-0.1)
    ox, oy = HIP_IN_PELVIS
    np.testing.assert_allclose(mot.column("pelvis_tx"), 1.2 - (c * ox - s * oy), atol=1e-9)
    np.testing.assert_allclose(mot.column("pelvis_ty"), 0.9 - (s * ox + c * oy), atol=1e-9)


def _on_2d_gait(planar, columns: dict) -> np.ndarray:
    """2D_gait.osim's predgait q at OpenSim coordinates (rad, m; missing ones at 0)."""
    names = planar.osim_coordinates
    n = len(next(iter(columns.values())))
    return planar.q_from_osim({name: columns.get(name, np.zeros(n)) for name in names})


def _lab_pitch(planar, q, body: str) -> np.ndarray:
    return relative_pitch(planar, q, "ground", body) if body != "ground" else 0.0


def test_the_leg_motion_poses_2d_gait_as_predgaits_leg(planar):
    leg = load_model("leg")
    q = _leg_q()
    for side, s in (("right", "r"), ("left", "l")):
        qo = _on_2d_gait(planar, osim2d_coordinates(leg, q, side=side))
        pitches = {"calcn": q[:, 2], "tibia": q[:, 2] + q[:, 3], "femur": q[:, 2:].sum(axis=1)}
        for body, pitch in pitches.items():
            np.testing.assert_allclose(_lab_pitch(planar, qo, f"{body}_{s}"), pitch,
                                       atol=1e-12, err_msg=body)
        hip = _frame_positions(planar.model, qo, planar.body_link(f"femur_{s}"))
        np.testing.assert_allclose(hip[:, [0, 2]], _frame_positions(leg, q, "hip_center")[
            :, [0, 2]], atol=1e-9)


def test_the_gait7_motion_poses_2d_gait_as_predgaits_gait7(planar):
    model = gait7_model(72.6, 1.8034)
    q = np.random.default_rng(7).uniform(-0.6, 0.6, (5, model.nq))
    q[:, :2] = [1.0, 0.9]
    qo = _on_2d_gait(planar, osim2d_coordinates(model, q))
    for body in ("pelvis", "torso"):
        np.testing.assert_allclose(_lab_pitch(planar, qo, body), q[:, 2], atol=1e-12)
    for side in ("r", "l"):
        chain = q[:, 2].copy()
        for body, joint in (("femur", "hip"), ("tibia", "knee"), ("calcn", "ankle")):
            chain = chain + q[:, model.coordinate_index(f"{joint}_{side}")]
            np.testing.assert_allclose(_lab_pitch(planar, qo, f"{body}_{side}"), chain,
                                       atol=1e-12, err_msg=f"{body}_{side}")
        hip = _frame_positions(planar.model, qo, planar.body_link(f"femur_{side}"))
        np.testing.assert_allclose(hip[:, [0, 2]], q[:, :2], atol=1e-9)


def test_a_model_without_a_2d_gait_counterpart_is_refused():
    with pytest.raises(InputError, match="rod model has no counterpart"):
        osim2d_coordinates(load_model("rod"), np.zeros((2, 3)))


def test_opensim_plays_the_motions_on_2d_gait(tmp_path):
    from timing import opensim_python

    python = opensim_python()
    if python is None:
        print("peer not available")
        pytest.skip("peer not available (set OPENSIM_PYTHON to a Python with opensim 4.6)")
    leg = load_model("leg")
    model = gait7_model(72.6, 1.8034)
    q7 = np.random.default_rng(3).uniform(-0.5, 0.5, (4, model.nq))
    q7[:, :2] = [1.0, 0.9]
    cases = {"leg": (leg, _leg_q()), "gait7": (model, q7)}
    for name, (m, q) in cases.items():
        mot = tmp_path / f"{name}.mot"
        write_osim2d_motion(mot, m, np.arange(len(q)) * 0.01, q)
        out = tmp_path / f"{name}.npz"
        done = subprocess.run([python, str(REPO / "benchmarks" / "opensim_planar_motion.py"),
                               str(bundled_2d_gait_path()), str(mot), str(out)],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        peer = np.load(out)
        written = osim2d_coordinates(m, q)
        for j, label in enumerate(peer["labels"]):   # OpenSim holds the values in rad, m
            np.testing.assert_allclose(peer["coordinates"][:, j], written[label], atol=1e-8,
                                       err_msg=label)
        bodies = list(peer["bodies"])
        if name == "leg":
            pitches = {"calcn_r": q[:, 2], "tibia_r": q[:, 2] + q[:, 3],
                       "femur_r": q[:, 2:].sum(axis=1)}
            hips = {"femur_r": _frame_positions(m, q, "hip_center")}
        else:
            pitches = {"pelvis": q[:, 2], "torso": q[:, 2]}
            for side in ("r", "l"):
                chain = q[:, 2].copy()
                for body, joint in (("femur", "hip"), ("tibia", "knee"), ("calcn", "ankle")):
                    chain = chain + q[:, m.coordinate_index(f"{joint}_{side}")]
                    pitches[f"{body}_{side}"] = chain
            hips = {f"femur_{s}": np.column_stack([q[:, 0], 0 * q[:, 0], q[:, 1]])
                    for s in ("r", "l")}
        # OpenSim's angle about its +Z (right) is minus predgait's pitch about +Y (left)
        worst = max(np.abs(peer["angles"][:, bodies.index(b)] + p).max()
                    for b, p in pitches.items())
        hip_error = max(np.abs(peer["hips"][:, ["femur_r", "femur_l"].index(b), :2]
                               - h[:, [0, 2]]).max() for b, h in hips.items())
        print(f"OpenSim vs predgait ({name}): body angles max {worst:.1e} rad, hip centre "
              f"max {hip_error:.1e} m")
        assert worst < 1e-8 and hip_error < 1e-8


def test_the_rotations_are_written_in_degrees_and_the_translations_in_metres(tmp_path):
    model = gait7_model(72.6, 1.8034)
    q = np.zeros((2, model.nq))
    q[:, model.coordinate_index("base_z")] = 0.9
    q[:, model.coordinate_index("knee_r")] = np.pi / 2
    write_osim2d_motion(tmp_path / "m.mot", model, TIME[:2], q)
    mot = read_storage(tmp_path / "m.mot")
    assert mot.column("knee_angle_r")[0] == pytest.approx(-90.0)
    assert set(TRANSLATIONS) < set(mot.columns)
    assert mot.column("pelvis_ty")[0] == pytest.approx(0.9 - HIP_IN_PELVIS[1])
