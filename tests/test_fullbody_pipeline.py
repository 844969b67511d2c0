"""Whole-body IK + ID on the OpenSim example trial subject01_walk1 (real data)."""

import json
from pathlib import Path

import numpy as np
import pytest

from predgait.errors import InputError
from predgait.workflows.inverse3d import read_marker_map, run_inverse_fullbody

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_subject01_walk1"
MAP = REPO / "problems" / "markers_fullbody_subject01.toml"
TRIAL = [DATA / "subject01_walk1.trc", DATA / "subject01_walk1_grf.mot"]

pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="shared data not available")


def test_subject01_whole_body(tmp_path):
    info = run_inverse_fullbody(TRIAL, MAP, mass=72.6, height=1.8034, sex="male",
                                out_dir=tmp_path / "out", static=DATA / "subject01_static.trc")
    out = tmp_path / "out"
    for name in ("kinematics3d.sto", "inverse_dynamics3d.sto", "inverse_dynamics3d.csv",
                 "ik_residuals.csv", "summary.json"):
        assert (out / name).is_file()
    assert json.loads((out / "summary.json").read_text())["frames"] == 151
    # Plate 0 is the right foot, plate 1 the left (subject01_walk1_grf.xml).
    assert {(s["plate"], s["side"]) for s in info["stances"]} == {("0", "r"), ("1", "l")}
    legs = [m for m in info["ik_marker_rms_m"] if m.startswith(("R.Heel", "L.Heel", "R.Shank",
                                                                 "L.Shank", "R.Midfoot"))]
    assert max(info["ik_marker_rms_m"][m] for m in legs) < 0.015
    assert info["ik_rms_m"]["mean"] < 0.06
    weight = 72.6 * 9.81
    assert info["pelvis_residual_force_N"]["rms"] < 0.15 * weight
    peaks = info["peak_joint_moments_Nm"]
    # Sagittal peaks within walking ranges (ankle ~1-1.6 N m/kg, knee and hip < 1.5 N m/kg).
    assert 0.7 * 72.6 < peaks["ankle_r_y"] < 1.8 * 72.6
    assert peaks["knee_r_y"] < 1.5 * 72.6 and peaks["hip_r_y"] < 1.5 * 72.6


def test_marker_map_naming_missing_markers(tmp_path):
    bad = tmp_path / "map.toml"
    bad.write_text('[markers]\nasis_r = "R.ASIS"\nheel_r = "R.Hell"\n')
    with pytest.raises(InputError, match="R.Hell are not in"):
        run_inverse_fullbody(TRIAL, bad, mass=72.6, height=1.8034, out_dir=tmp_path / "o")
    bad.write_text('[markers]\nnose = "R.ASIS"\n')
    with pytest.raises(InputError, match="not a model marker frame"):
        read_marker_map(bad)
    assert not (tmp_path / "o").exists()
    assert np.isfinite(len(read_marker_map(MAP).frames))
