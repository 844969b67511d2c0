"""``predgait inverse`` from the command line: outputs, formats, bad input."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from predgait.data import read_storage

REPO = Path(__file__).resolve().parents[1]


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "predgait", *args], capture_output=True,
                          text=True, timeout=300)


def test_problem_file_writes_every_output(tmp_path, assert_tidy_result):
    out = tmp_path / "inv"
    result = run_cli("inverse", str(REPO / "problems" / "inverse_subject01.toml"), "--out",
                     str(out))
    assert result.returncode == 0, result.stderr
    names = {p.name for p in out.iterdir()}
    assert {"kinematics.sto", "inverse_dynamics.sto", "kinematics.csv", "inverse_dynamics.csv",
            "summary.json", "angles.png", "moments.png", "powers.png", "grf.png"} <= names
    kinematics = read_storage(out / "kinematics.sto")
    assert set(kinematics.columns) == {"hip_flexion", "knee_flexion", "ankle_dorsiflexion"}
    kinetics = read_storage(out / "inverse_dynamics.sto")
    for name in ("hip_flexion_moment", "knee_flexion_moment", "ankle_dorsiflexion_moment",
                 "knee_force_x", "ankle_dorsiflexion_power"):
        assert name in kinetics.columns
    summary = assert_tidy_result(out / "summary.json")
    assert summary["window"] == "first gait cycle"
    assert -2.0 < summary["peak_moments_n_m_per_kg"]["ankle_dorsiflexion_moment_min"] < -1.0
    again = run_cli("inverse", str(REPO / "problems" / "inverse_subject01.toml"), "--out",
                    str(out))
    assert again.returncode == 2 and "add --force" in again.stderr


def test_c3d_from_flags_and_winter_table(tmp_path, shared_data):
    c3d = shared_data / "opensim_walking5_c3d" / "walking5.c3d"
    result = run_cli("inverse", str(c3d), "--mass", "72", "--markers",
                     "hip=RHJC,knee=RKJC,ankle=RAJC,heel=RCAL,toe=RMT2", "--out",
                     str(tmp_path / "c3d"))
    assert result.returncode == 0, result.stderr
    winter = run_cli("inverse", str(REPO / "problems" / "inverse_winter_a1.toml"), "--out",
                     str(tmp_path / "winter"))
    assert winter.returncode == 0, winter.stderr
    assert "stance-phase moments are not valid" in winter.stdout
    summary = json.loads((tmp_path / "winter" / "summary.json").read_text())
    # Winter (2009) Table A.1 stride: heel contact frames 28 and 97 (1 cycle = 0.987 s).
    assert summary["heel_strikes_s"][1] == pytest.approx((97 - 28) / 69.9, abs=0.06)
    assert 55 < summary["angle_range_deg"]["knee_flexion"][1] < 75


@pytest.mark.parametrize("args,message", [
    (["missing.trc", "--mass", "70", "--markers", "hip=A,knee=B,ankle=C,toe=D"],
     "missing.trc: file not found"),
    (["{c3d}", "--markers", "hip=RHJC,knee=RKJC,ankle=RAJC,toe=RMT2"], "--mass (kg) is required"),
    (["{c3d}", "--mass", "70", "--markers", "hip=RHIP,knee=RKJC,ankle=RAJC,toe=RMT2"],
     "RHIP"),
    (["{c3d}", "--mass", "70", "--markers", "hip=RHJC,knee=RKJC,ankle=RAJC,toe=RMT2",
      "--cutoff", "200"], "--cutoff 200 Hz must lie"),
    (["{c3d}", "--mass", "70", "--markers", "hip=RHJC,kne=RKJC"], "unknown point 'kne'"),
    (["{c3d}", "--mass", "70", "--markers", "hip=RHJC,knee=RKJC,ankle=RAJC,toe=RMT2",
      "--grf-cutoff", "5000"], "--grf-cutoff 5000 Hz must lie"),
])
def test_bad_input(tmp_path, shared_data, args, message):
    c3d = str(shared_data / "opensim_walking5_c3d" / "walking5.c3d")
    out = tmp_path / "out"
    result = run_cli("inverse", *[a.replace("{c3d}", c3d) for a in args], "--out", str(out))
    assert result.returncode == 2, result.stdout
    assert message in result.stderr
    assert "Traceback" not in result.stderr
    assert not out.exists()


def test_missing_marker_lists_what_the_file_has(tmp_path, shared_data):
    c3d = str(shared_data / "opensim_walking5_c3d" / "walking5.c3d")
    result = run_cli("inverse", c3d, "--mass", "70", "--markers",
                     "hip=RHIP,knee=RKJC,ankle=RAJC,toe=RMT2", "--out", str(tmp_path / "o"))
    assert "RHJC" in result.stderr  # the available names are listed


def test_problem_file_typo(tmp_path):
    text = (REPO / "problems" / "inverse_subject01.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("cutoff = 6.0 ", "cutof = 6.0 "))
    result = run_cli("inverse", str(bad), "--out", str(tmp_path / "o"))
    assert result.returncode == 2
    assert "options.cutof" in result.stderr and "unknown key" in result.stderr


def test_fullbody_from_the_command_line(tmp_path, shared_data):
    d = shared_data / "opensim_subject01_walk1"
    out = tmp_path / "fb"
    result = run_cli("inverse", str(d / "subject01_walk1.trc"), "--grf",
                     str(d / "subject01_walk1_grf.mot"), "--static",
                     str(d / "subject01_static.trc"),
                     "--mass", "72.6", "--height", "1.8034", "--model", "fullbody",
                     "--marker-map", str(REPO / "problems" / "markers_fullbody_subject01.toml"),
                     "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert (out / "inverse_dynamics3d.sto").is_file()
    missing = run_cli("inverse", str(d / "subject01_walk1.trc"), "--mass", "72.6", "--height",
                      "1.8", "--model", "fullbody", "--out", str(tmp_path / "x"))
    assert missing.returncode == 2 and "needs --marker-map" in missing.stderr


def test_model_build_fullbody_and_gait7(tmp_path):
    for kind in ("fullbody", "gait7"):
        out = tmp_path / f"{kind}.urdf"
        result = run_cli("model", "build", kind, "--mass", "70", "--height", "1.75", "-o", str(out))
        assert result.returncode == 0, result.stderr
        shown = run_cli("model", "show", str(out))
        assert shown.returncode == 0 and "70.0" in shown.stdout, shown.stderr
