"""Output files read back: a known angle comes out in the unit their header states.

Through the CLI (``predgait inverse``, leg and whole body) on subject01_walk1: the right
knee's swing peak flexion is a known angle (Kadaba et al. 1990: 55-70 deg in normal
gait; the whole-body fit to this trial reaches ~64 deg), so every file that carries it,
read in the unit its header (.sto ``inDegrees`` and ``units``) or its units line (.csv)
names, must give it in degrees after the stated conversion. An angle written in radians
under a "deg" header (peak ~1.1) or in degrees under "rad" (~3700 deg) fails.

Exact known answers through the CLI (``predgait inverse --model fullbody``): the body's own
markers held still in a known pose (right knee flexed 50 deg, the foot level), no plates.
Every angle file must give 50 deg in its stated unit; every moment file (model axes
``inverse_dynamics3d.sto/.csv``, clinical ``clinical_moments.sto``, ``clinical.csv``)
the statics worked by hand from the segments' masses and centres of mass (the knee holds
the shank and foot against their weights, the ankle the foot), in N m, and the pelvis
residual force the body weight in N (a moment per kg, in N mm or a force in kN fails).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from predgait.data import read_storage

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_subject01_walk1"
PROBLEM = REPO / "problems" / "inverse_subject01.toml"
MAP = REPO / "problems" / "markers_fullbody_subject01.toml"
#: Right knee swing peak flexion, deg (Kadaba 1990 normal range, widened by 5 deg).
KNEE_PEAK_DEG = (50.0, 75.0)

pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="shared data not available")


def to_degrees(unit: str) -> float:
    """Factor from a stated angle unit to degrees."""
    unit = unit.strip().lower()
    if unit.startswith("deg"):
        return 1.0
    if unit.startswith("rad"):
        return 180.0 / np.pi
    raise AssertionError(f"no angle unit in {unit!r}")


def sto_angle_deg(path: Path, column: str) -> np.ndarray:
    """A .sto angle column in degrees, by the file's own header."""
    table = read_storage(path)
    units = table.header.get("units", "").lower()
    stated = "deg" if units.startswith("deg") else "rad" if units.startswith(("rad", "si (rad")) \
        else None
    assert stated is not None, f"{path.name}: units header {units!r} names no angle unit"
    assert table.in_degrees == (stated == "deg"), \
        f"{path.name}: inDegrees={table.in_degrees} but units={units!r}"
    return table.column(column) * to_degrees(stated)


def csv_angle_deg(path: Path, column: str) -> np.ndarray:
    """A .csv angle column in degrees, by its '# units:' line."""
    lines = path.read_text().splitlines()
    [units] = [line for line in lines if line.startswith("# units:")]
    stated = dict(item.strip().split("=", 1) for item in units[len("# units:"):].split(","))
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    names = lines[header].split(",")
    values = np.genfromtxt(lines[header + 1:], delimiter=",")
    return values[:, names.index(column)] * to_degrees(stated[column])


def assert_knee_peak(values_deg: np.ndarray, where: str) -> float:
    peak = float(np.nanmax(values_deg))
    assert KNEE_PEAK_DEG[0] < peak < KNEE_PEAK_DEG[1], f"{where}: knee peak {peak:.3g} deg"
    return peak


def run_cli(*args) -> None:
    from predgait.cli import main

    assert main(["inverse", str(PROBLEM), "--no-plots", *map(str, args)]) == 0


@pytest.fixture(scope="module")
def leg(tmp_path_factory) -> Path:
    """The leg inverse's result folder (``predgait inverse``)."""
    out = tmp_path_factory.mktemp("units") / "leg"
    run_cli("--out", out)
    return out


def test_leg_inverse_files_state_their_angle_unit(leg):
    peaks = [assert_knee_peak(sto_angle_deg(leg / "kinematics.sto", "knee_flexion"),
                              "kinematics.sto"),
             assert_knee_peak(csv_angle_deg(leg / "kinematics.csv", "knee_flexion"),
                              "kinematics.csv")]
    assert peaks[0] == pytest.approx(peaks[1], abs=1e-6)


def test_leg_motion_for_opensim_states_its_angle_unit_and_opensims_sign(leg):
    """motion.mot: 2D_gait.osim's knee_angle_r, negative in flexion, in degrees; the model's
    hinge, which is kinematics.sto's knee flexion plus the static trial's standing knee."""
    knee = -sto_angle_deg(leg / "motion.mot", "knee_angle_r")
    assert_knee_peak(knee, "motion.mot")
    offset = knee - sto_angle_deg(leg / "kinematics.sto", "knee_flexion")
    offset = offset[np.isfinite(offset)]
    assert np.ptp(offset) < 1e-6 and abs(offset[0]) < 15.0


def test_whole_body_inverse_files_state_their_angle_unit(tmp_path, leg):
    out = tmp_path / "body"
    run_cli("--model", "fullbody", "--marker-map", MAP, "--out", out)
    peaks = [assert_knee_peak(sto_angle_deg(out / "kinematics3d.sto", "knee_r_y"),
                              "kinematics3d.sto"),
             assert_knee_peak(sto_angle_deg(out / "clinical_angles.sto", "knee_flexion_r"),
                              "clinical_angles.sto"),
             assert_knee_peak(csv_angle_deg(out / "clinical.csv", "knee_flexion_r"),
                              "clinical.csv")]
    assert max(peaks) - min(peaks) < 1e-6  # knee_r_y is knee flexion (sign +1)
    # Clinical signs through the writer (clinical_angles.sto / clinical_moments.sto): the
    # stance hip adducts (Kadaba 1990: 5-10 deg), the ankle dorsiflexes in late stance
    # (~10-15 deg), and the internal moments are the abductors' at the hip and the
    # plantarflexors' at push-off, negative (Winter 2009: ~0.8 and ~1.5 N m/kg).
    angles = read_storage(out / "clinical_angles.sto")
    assert 3.0 < np.nanmax(angles.column("hip_adduction_r")) < 15.0
    assert 5.0 < np.nanmax(angles.column("ankle_dorsiflexion_r")) < 25.0
    moments = read_storage(out / "clinical_moments.sto")
    assert moments.header["units"] == "N m"
    mass = 72.6
    assert -1.2 < np.nanmin(moments.column("hip_adduction_r_moment")) / mass < -0.4
    assert -2.0 < np.nanmin(moments.column("ankle_dorsiflexion_r_moment")) / mass < -1.0
    # The leg model's knee on the same trial agrees to within the models' difference.
    assert abs(np.nanmax(sto_angle_deg(leg / "kinematics.sto", "knee_flexion"))
               - peaks[0]) < 10.0


# ----------------------------------------------------------------- a known pose, known moments
#: The synthetic subject (no static trial, no plates) held still in a known pose.
SUBJECT = {"mass": 70.0, "height": 1.75}
KNEE_DEG = 50.0   # right knee flexion (model knee_r_y, + = flexion)
ANKLE_DEG = -50.0  # right ankle_r_y (+ = plantarflexion): the foot level again
PELVIS_Z = 0.95   # m, pelvis origin height


def write_trc(path: Path, time: np.ndarray, positions: dict[str, np.ndarray]) -> None:
    """Lab-frame marker positions (n, 3) m -> an OpenSim TRC (Y-up, mm)."""
    from predgait.data.frames import OPENSIM_TO_LAB

    names, rate = list(positions), 1.0 / float(time[1] - time[0])
    lines = [f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
             "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\t"
             "OrigDataStartFrame\tOrigNumFrames",
             f"{rate:g}\t{rate:g}\t{time.size}\t{len(names)}\tmm\t{rate:g}\t1\t{time.size}",
             "Frame#\tTime\t" + "\t\t\t".join(names),
             "\t\t" + "\t".join(f"X{i}\tY{i}\tZ{i}" for i in range(1, len(names) + 1)), ""]
    xyz = np.concatenate([1000.0 * positions[m] @ OPENSIM_TO_LAB for m in names], axis=1)
    lines += [f"{k + 1}\t{time[k]:.6f}\t" + "\t".join(f"{v:.9f}" for v in row)
              for k, row in enumerate(xyz)]
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def still_pose(tmp_path_factory):
    """``predgait inverse --model fullbody`` on the body's own markers, held in a known pose.

    Returns the result folder and the hand-computed moments (N m): the weights of the
    right shank and foot about the knee's flexion axis, and of the foot about the ankle's
    (statics: the joint holds the segments below it; no plates, so the pelvis residual
    carries the body weight).
    """
    import pinocchio as pin

    from predgait.cli import main
    from predgait.models.fullbody import MARKERS
    from predgait.models.loading3d import fullbody_for_subject

    folder = tmp_path_factory.mktemp("still")
    model = fullbody_for_subject(SUBJECT["mass"], SUBJECT["height"])
    q = model.neutral()
    q[2] = PELVIS_Z
    q[7 + model.joint_names.index("knee_r_y")] = np.radians(KNEE_DEG)
    q[7 + model.joint_names.index("ankle_r_y")] = np.radians(ANKLE_DEG)
    q[7 + model.joint_names.index("elbow_r")] = -0.5   # arms' axial rotation observable
    q[7 + model.joint_names.index("elbow_l")] = -0.5
    pm, data = model.pin_model, model.pin_model.createData()
    pin.framesForwardKinematics(pm, data, q)
    time = np.arange(60) / 60.0
    write_trc(folder / "still.trc", time,
              {m.upper(): np.tile(data.oMf[model.frame_id(m)].translation, (time.size, 1))
               for m in MARKERS})
    (folder / "map.toml").write_text("[markers]\n" + "".join(f'{m} = "{m.upper()}"\n'
                                                             for m in MARKERS))
    out = folder / "out"
    assert main(["inverse", str(folder / "still.trc"), "--model", "fullbody", "--marker-map",
                 str(folder / "map.toml"), "--mass", str(SUBJECT["mass"]), "--height",
                 str(SUBJECT["height"]), "--no-plots", "--out", str(out)]) == 0

    def weight_moment_y(bodies, joint):  # about the joint's +Y axis, lab, N m
        axis_point = data.oMi[pm.getJointId(joint)]
        total = 0.0
        for body in bodies:
            jid = pm.getJointId(body)
            com = data.oMi[jid].act(pm.inertias[jid].lever) - axis_point.translation
            weight = np.array([0.0, 0.0, -pm.inertias[jid].mass * model.gravity])
            total += np.cross(com, weight) @ axis_point.rotation[:, 1]
        return total

    # The joint holds its distal bodies against their weights: tau = -(moment of weight).
    knee = -weight_moment_y(("knee_r_z", "ankle_r_z"), "knee_r_y")
    ankle = -weight_moment_y(("ankle_r_z",), "ankle_r_y")
    return out, {"knee_r_y": knee, "ankle_r_y": ankle,
                 "weight": model.total_mass() * model.gravity}


def test_a_known_pose_comes_out_in_the_stated_angle_unit(still_pose):
    out, _ = still_pose
    for name in ("kinematics3d.sto", "motion.mot"):
        knee = sto_angle_deg(out / name, "knee_r_y")
        np.testing.assert_allclose(knee, KNEE_DEG, atol=0.01, err_msg=name)
        table = read_storage(out / name)   # translations in m under inDegrees=yes
        assert "m (pelvis_t*)" in table.header["units"]
        np.testing.assert_allclose(table.column("pelvis_tz"), PELVIS_Z, atol=1e-4)
    np.testing.assert_allclose(sto_angle_deg(out / "clinical_angles.sto", "knee_flexion_r"),
                               KNEE_DEG, atol=0.01)
    np.testing.assert_allclose(csv_angle_deg(out / "clinical.csv", "knee_flexion_r"),
                               KNEE_DEG, atol=0.01)


def sto_moment_nm(path: Path, column: str) -> np.ndarray:
    """A .sto moment column in N m, by the file's own header (not in degrees)."""
    table = read_storage(path)
    assert not table.in_degrees, path.name
    assert table.header.get("units", "").startswith("N m"), table.header
    return table.column(column)


def csv_column(path: Path, column: str) -> tuple[np.ndarray, str]:
    """A .csv column and its unit from the '# units:' line."""
    lines = path.read_text().splitlines()
    [units] = [line for line in lines if line.startswith("# units:")]
    stated = dict(item.strip().split("=", 1) for item in units[len("# units:"):].split(","))
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    names = lines[header].split(",")
    values = np.genfromtxt(lines[header + 1:], delimiter=",")
    return values[:, names.index(column)], stated[column]


def test_known_moments_come_out_in_newton_metres(still_pose):
    """Statics by hand vs every moment file: a N m/kg, N mm or radian mix-up fails."""
    out, known = still_pose
    assert known["knee_r_y"] > 5.0 and known["ankle_r_y"] != 0.0   # a real lever arm
    for joint, moment in (("knee_r_y", known["knee_r_y"]), ("ankle_r_y", known["ankle_r_y"])):
        written = sto_moment_nm(out / "inverse_dynamics3d.sto", f"{joint}_moment")
        np.testing.assert_allclose(written, moment, rtol=1e-3, atol=1e-3)
        values, unit = csv_column(out / "inverse_dynamics3d.csv", f"{joint}_moment")
        assert unit == "N m"
        np.testing.assert_allclose(values, moment, rtol=1e-3, atol=1e-3)
    # Clinical signs: the knee's flexors hold the shank hanging behind the knee (+), the
    # ankle's dorsiflexors the level foot whose centre of mass lies ahead of the ankle (+).
    clinical = out / "clinical_moments.sto"
    np.testing.assert_allclose(sto_moment_nm(clinical, "knee_flexion_r_moment"),
                               known["knee_r_y"], rtol=1e-3)
    np.testing.assert_allclose(sto_moment_nm(clinical, "ankle_dorsiflexion_r_moment"),
                               -known["ankle_r_y"], rtol=1e-3, atol=1e-3)
    assert -known["ankle_r_y"] > 0.0
    values, unit = csv_column(out / "clinical.csv", "knee_flexion_r_moment")
    assert unit == "N m"
    np.testing.assert_allclose(values, known["knee_r_y"], rtol=1e-3)
    # No plates: the pelvis residual carries the body weight, upward, in N.
    force = sto_moment_nm(out / "inverse_dynamics3d.sto", "pelvis_residual_force_z")
    np.testing.assert_allclose(force, known["weight"], rtol=1e-3)
    values, unit = csv_column(out / "inverse_dynamics3d.csv", "pelvis_residual_force_z")
    assert unit == "N"
    np.testing.assert_allclose(values, known["weight"], rtol=1e-3)
