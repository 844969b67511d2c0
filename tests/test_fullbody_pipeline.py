"""Whole-body IK + ID on the OpenSim example trial subject01_walk1 (real data)."""

import json
from pathlib import Path

import numpy as np
import pytest

from predgait.data import read_storage
from predgait.dynamics.inverse3d_trial import read_marker_map
from predgait.errors import InputError
from predgait.workflows.inverse3d import run_inverse_fullbody

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_subject01_walk1"
MAP = REPO / "problems" / "markers_fullbody_subject01.toml"
TRIAL = [DATA / "subject01_walk1.trc", DATA / "subject01_walk1_grf.mot"]

pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="shared data not available")


def test_subject01_whole_body(tmp_path, assert_tidy_result):
    info = run_inverse_fullbody(TRIAL, MAP, mass=72.6, height=1.8034, sex="male",
                                out_dir=tmp_path / "out", static=DATA / "subject01_static.trc")
    out = tmp_path / "out"
    for name in ("kinematics3d.sto", "inverse_dynamics3d.sto", "inverse_dynamics3d.csv",
                 "ik_residuals.csv", "summary.json"):
        assert (out / name).is_file()
    assert assert_tidy_result(out / "summary.json")["frames"] == 151
    # Plate 0 is the right foot, plate 1 the left (subject01_walk1_grf.xml).
    assert {(s["plate"], s["side"]) for s in info["stances"]} == {("0", "r"), ("1", "l")}
    legs = [m for m in info["ik_marker_rms_m"] if m.startswith(("R.Heel", "L.Heel", "R.Shank",
                                                                 "L.Shank", "R.Midfoot"))]
    assert max(info["ik_marker_rms_m"][m] for m in legs) < 0.015
    assert info["ik_rms_m"]["mean"] < 0.06
    # The mean is the arms' (T-pose static trial); the pelvis and legs fit to under a
    # centimetre. Their region RMS is the RMS over the pelvis, thigh, shank and foot markers.
    per_marker = info["ik_marker_rms_m"]
    lower = [m for m in per_marker if any(part in m for part in (
        "ASIS", "Sacral", "Thigh", "Shank", "Heel", "Toe", "Midfoot"))]
    region = info["ik_rms_by_region_m"]
    assert len(lower) == 23
    assert region["pelvis_and_legs"] == pytest.approx(
        np.sqrt(np.mean([per_marker[m] ** 2 for m in lower])), rel=1e-6)
    assert region["pelvis_and_legs"] < 0.01 < 0.05 < region["trunk_head_and_arms"]
    weight = 72.6 * 9.81
    assert info["pelvis_residual_force_N"]["rms"] < 0.15 * weight
    peaks = info["peak_joint_moments_Nm"]
    # Sagittal peaks: the ankle's within 5 % of OpenSim's on this trial (Gait2354: 128.0 N m,
    # 1.76 N m/kg, at 1.233 s about its oblique ankle axis; ours 131 N m about the Cardan Y
    # axis, of a 132 N m moment), knee and hip < 1.5 N m/kg (walking ranges).
    reference = read_storage(REPO / "tests" / "data" / "opensim_gait2354_reference"
                             / "inverse_dynamics.sto").column("ankle_angle_r_moment")
    assert abs(peaks["ankle_r_y"] / np.abs(reference).max() - 1.0) < 0.05
    assert peaks["knee_r_y"] < 1.5 * 72.6 and peaks["hip_r_y"] < 1.5 * 72.6
    # The 3D viewer draws each plate's ground reaction at its COP, under the loaded foot:
    # within 0.15 m (horizontally) of a point of that foot's stick lines.
    viewer = json.loads((out / "viewer.json").read_text())
    arrows = {a["name"]: a for a in viewer["arrows"]}
    assert set(arrows) == {"ground reaction, plate 0", "ground reaction, plate 1"}
    body = viewer["bodies"][0]["lines"]
    near = 0
    for arrow in arrows.values():
        for k, origin in enumerate(arrow["origin"]):
            if origin is None or origin[0] is None:
                continue
            points = np.array([p for line in body for p in line[k]], dtype=float)
            gap = np.min(np.hypot(points[:, 0] - origin[0], points[:, 1] - origin[1]))
            assert gap < 0.15, (arrow["name"], viewer["time"][k], gap)
            near += 1
    assert near > 20


def test_marker_map_naming_missing_markers(tmp_path):
    bad = tmp_path / "map.toml"
    bad.write_text('[markers]\nasis_r = "R.ASIS"\nheel_r = "R.Hell"\n')
    with pytest.raises(InputError, match="R.Hell are not in"):
        run_inverse_fullbody(TRIAL, bad, mass=72.6, height=1.8034, out_dir=tmp_path / "o")
    bad.write_text('[markers]\nnose = "R.ASIS"\n')
    with pytest.raises(InputError, match="not a model marker"):
        read_marker_map(bad)
    assert not (tmp_path / "o").exists()
    assert np.isfinite(len(read_marker_map(MAP).frames))


WALKING5 = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_walking5_c3d" / \
    "walking5.c3d"


def test_walking5_c3d_from_the_cli(tmp_path):
    """The C3D trial (no static trial, no arm markers, subject walking through the volume)."""
    from predgait.cli import main

    out = tmp_path / "w5"
    code = main(["inverse", str(WALKING5), "--model", "fullbody", "--marker-map",
                 str(REPO / "problems" / "markers_fullbody_walking5.toml"), "--mass", "72",
                 "--height", "1.75", "--out", str(out)])
    assert code == 0
    info = json.loads((out / "summary.json").read_text())
    # README: plate 1 is the left foot 1.964-2.470 s, plate 2 the right 2.383-2.968 s.
    stances = {(s["plate"], s["side"]): (s["start"], s["stop"]) for s in info["stances"]}
    assert set(stances) == {("1", "l"), ("2", "r")}
    assert abs(stances[("1", "l")][0] - 1.964) < 0.01 and abs(stances[("2", "r")][1] - 2.968) < 0.01
    # Vicon's joint centres and the clusters fit to about a centimetre.
    assert info["ik_rms_m"]["mean"] < 0.012
    assert max(info["ik_marker_rms_m"][m] for m in ("RHJC", "RKJC", "RAJC", "LAJC")) < 0.02
    prov = info["provenance"]
    assert "elbow_r" in prov["unobserved_joints_held_at_zero"]
    assert prov["trimmed"].startswith("kept") and "trial frames" in prov["marker_calibration"]
    # Knee flexion reaches a swing peak in the normal range (Kadaba 1990: 55-70 deg).
    assert 50.0 < info["clinical_angle_range_deg"]["knee_flexion_r"][1] < 80.0
    for name in ("clinical_angles.sto", "clinical_moments.sto", "clinical.csv"):
        assert (out / name).is_file()


def test_grf_cutoff_is_applied_and_recorded(tmp_path):
    """--grf-cutoff filters the plates (default: unfiltered, as OpenSim's ID tool)."""
    static = DATA / "subject01_static.trc"
    raw = run_inverse_fullbody(TRIAL, MAP, mass=72.6, height=1.8034, out_dir=tmp_path / "a",
                               static=static)
    smooth = run_inverse_fullbody(TRIAL, MAP, mass=72.6, height=1.8034, out_dir=tmp_path / "b",
                                  static=static, grf_cutoff=6.0)
    assert raw["provenance"]["grf_cutoff_hz"] is None
    assert smooth["provenance"]["grf_cutoff_hz"] == 6.0
    a, b = (r["peak_joint_moments_Nm"]["ankle_r_y"] for r in (raw, smooth))
    assert a != b and abs(a - b) < 0.1 * a


def test_problem_file_gives_the_full_body_its_trial(tmp_path):
    """`inverse PROBLEM.toml --model fullbody`: files, mass and height from its [trial]."""
    from predgait.cli import main

    problem = REPO / "problems" / "inverse_subject01.toml"
    code = main(["inverse", str(problem), "--model", "fullbody", "--marker-map", str(MAP),
                 "--no-plots", "--out", str(tmp_path / "cli")])
    assert code == 0
    run_inverse_fullbody(TRIAL, MAP, mass=72.6, height=1.8034, sex="male",
                         out_dir=tmp_path / "direct", static=DATA / "subject01_static.trc")
    from_file = json.loads((tmp_path / "cli" / "summary.json").read_text())
    direct = json.loads((tmp_path / "direct" / "summary.json").read_text())
    assert from_file["peak_joint_moments_Nm"] == pytest.approx(direct["peak_joint_moments_Nm"],
                                                               rel=1e-9)
    assert from_file["pelvis_residual_force_N"] == pytest.approx(direct["pelvis_residual_force_N"])
    # A flag still wins over the file's key: 7.4 kg more body weight than the plates carry.
    code = main(["inverse", str(problem), "--model", "fullbody", "--marker-map", str(MAP),
                 "--mass", "80", "--no-plots", "--out", str(tmp_path / "heavier")])
    heavier = json.loads((tmp_path / "heavier" / "summary.json").read_text())
    assert (heavier["pelvis_residual_force_N"]["rms"]
            > direct["pelvis_residual_force_N"]["rms"] + 30)
