"""Output files read back: a known angle comes out in the unit their header states.

Through the CLI (``predgait inverse``, leg and whole body) on subject01_walk1: the right
knee's swing peak flexion is a known angle (Kadaba et al. 1990: 55-70 deg in normal
gait; the whole-body fit to this trial reaches ~64 deg), so every file that carries it,
read in the unit its header (.sto ``inDegrees`` and ``units``) or its units line (.csv)
names, must give it in degrees after the stated conversion. An angle written in radians
under a "deg" header (peak ~1.1) or in degrees under "rad" (~3700 deg) fails.
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
