"""``predgait simulate``: problem files, outputs, bad input, divergence."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from predgait.cli import main
from predgait.data.storage import read_storage
from predgait.errors import InputError
from predgait.workflows.simulate import CollapseSpec, parse_spec

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def test_collapse_cli_writes_outputs(tmp_path, capsys, assert_tidy_result):
    out = tmp_path / "collapse"
    code = main(["simulate", str(PROBLEMS / "collapse.toml"), "--out", str(out),
                 "--set", "collapse.duration=0.45"])
    assert code == 0
    summary = assert_tidy_result(out / "summary.json")
    assert summary["status"] == "event" and 0.2 < summary["time_to_fall_s"] < 0.45
    assert summary["stability_at_start"]["unstable"] >= 1
    for name in ("states.sto", "stick.png", "stick.gif", "angles.png"):
        assert (out / name).is_file()
    sto = read_storage(out / "states.sto")
    assert "knee" in sto.columns and "knee_speed" in sto.columns
    assert "time to fall" in capsys.readouterr().out


def test_rod_cli_body_beats_inertial(tmp_path, assert_tidy_result):
    out = tmp_path / "rod"
    code = main(["simulate", str(PROBLEMS / "rod.toml"), "--out", str(out),
                 "--set", "rod.step_study=[]", "--set", "rod.duration=1.5"])
    assert code == 0
    rms = assert_tidy_result(out / "summary.json")["rms"]
    assert rms["body"]["base_pitch"] < rms["inertial"]["base_pitch"]


def test_unknown_key_names_key_and_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('kind = "collapse"\n[collapse]\nduration = 0.2\nshank_dg = 5.0\n')
    with pytest.raises(InputError, match=r"shank_dg.*line 4"):
        parse_spec(bad)
    assert main(["simulate", str(bad), "--out", str(tmp_path / "o")]) == 2


def test_bad_values_and_overrides(tmp_path):
    with pytest.raises(InputError, match="step"):
        parse_spec(PROBLEMS / "collapse.toml", ["integrator.step=5.0"])
    with pytest.raises(InputError, match="method"):
        parse_spec(PROBLEMS / "collapse.toml", ["integrator.method='leapfrog'"])
    spec = parse_spec(PROBLEMS / "collapse.toml", ["passive.knee.k=100"])
    assert isinstance(spec, CollapseSpec)
    assert spec.passive["knee"].elements[0].k == 100


def test_divergence_writes_partial_and_exits_nonzero(tmp_path, capsys):
    out = tmp_path / "div"
    code = main(["simulate", str(PROBLEMS / "collapse.toml"), "--out", str(out),
                 "--set", "integrator.method='euler'", "--set", "integrator.step=0.05",
                 "--set", "collapse.duration=5.0", "--set", "fall.segment_angle_deg=179",
                 "--set", "compare=[]", "--set", "passive.knee.c=0",
                 "--set", "passive.knee.k=200000"])
    assert code == 1
    assert (out / "states_partial.sto").is_file()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "diverged"
    err = capsys.readouterr().err
    assert "t = " in err and "partial" in err


def test_resynthesis_subject01(tmp_path, assert_tidy_result,
                               assert_leg_knee_starts_on_measured):
    out = tmp_path / "re"
    code = main(["simulate", str(PROBLEMS / "resynthesis.toml"), "--out", str(out),
                 "--set", "simulation.duration=0.5", "--set", "stability.times=[0.05, 0.2, 0.4]",
                 "--set", "integrator.method='rk4'",
                 "--set", "integrator.step=0.002"])
    assert code == 0
    s = assert_tidy_result(out / "summary.json")
    runs = {r["name"]: r for r in s["runs"]}
    # Without passive elements the leg leaves the measured path within 0.5 s; with the
    # thesis' k=100, c=100 knee it stays closer (Fig. 4.2.9).
    assert s["time_to_threshold_s"] is not None and s["time_to_threshold_s"] < 0.5
    assert runs["knee k=100 c=100"]["rms_deg"]["knee"] < runs["main"]["rms_deg"]["knee"]
    assert np.isfinite(s["grf_rms_n"]["z"])
    for name in ("grf.png", "contributions.png", "stick.gif"):
        assert (out / name).is_file()
    # states.sto's stated unit (rad) is its values': the knee starts on the measured one.
    assert_leg_knee_starts_on_measured(out / "states.sto")
