"""What-if scenarios on the bundled trial: null edits change nothing, edits act as they should."""

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from dask import distributed

from predgait.problemfile import load_problem
from predgait.scenarios.edits import AddMass, LockJoint, PassiveEdit
from predgait.scenarios.run import load_scenario, parse_scenario, run_scenario, scenario_metrics
from predgait.scenarios.sweep import grid_points, run_sweep

REPO = Path(__file__).resolve().parents[1]
STIFF_KNEE = REPO / "problems" / "scenario_stiff_knee.toml"


@pytest.fixture(scope="module")
def spec():
    return replace(load_scenario(STIFF_KNEE), window=(0.0, 0.6), edits=())


def test_no_edit_reproduces_the_baseline(spec):
    result = run_scenario(spec)
    np.testing.assert_allclose(result.edited.q, result.baseline.q, atol=1e-12)
    assert result.metrics["knee_rms_change_deg"] == 0.0
    # The PD-controlled baseline tracks the measured motion closely.
    assert result.metrics["knee_feedback_rms_n_m"] < 5.0


def test_corrected_torques_and_fitted_gains(spec):
    from predgait.scenarios.run import Gains, Torques

    fitted = replace(spec, torques=Torques.CORRECTED, gains=Gains.FITTED)
    null = run_scenario(fitted)
    np.testing.assert_allclose(null.edited.q, null.baseline.q, atol=1e-12)
    assert null.metrics["kp_knee"] != spec.kp          # the gains were fitted
    assert null.metrics["knee_feedback_rms_n_m"] < 5.0
    stiff = run_scenario(replace(fitted, edits=(PassiveEdit("knee", 80.0, 0.0, 0.0),)))
    assert stiff.metrics["knee_rms_change_deg"] > 0.1


def test_reoptimized_torques_after_adding_mass(spec):
    cast = replace(spec, edits=(AddMass("shank", 2.0, 0.5),))
    plain = run_scenario(cast)
    again = run_scenario(replace(cast, reoptimize=True))
    # Re-optimised torques carry the cast: less correction is left to the feedback.
    extra = "knee_extra_feedback_rms_n_m"
    assert again.metrics[extra] < plain.metrics[extra]
    with pytest.raises(Exception, match="reoptimize works with both joints free"):
        run_scenario(replace(spec, edits=(LockJoint("knee", 0.1),), reoptimize=True))


def test_zero_mass_and_zero_spring_are_null_edits(spec):
    result = run_scenario(replace(spec, edits=(AddMass("shank", 0.0, 0.5),
                                               PassiveEdit("knee", 0.0, 0.0, 0.0))))
    assert result.metrics["knee_max_change_deg"] < 1e-9


def test_stiffer_spring_needs_more_control(spec):
    extra = [run_scenario(replace(spec, edits=(PassiveEdit("knee", k, 0.0, 0.0),))).metrics[
        "knee_extra_feedback_rms_n_m"] for k in (20.0, 80.0)]
    assert 0 < extra[0] < extra[1]


def test_locked_knee_stays_at_its_angle(spec):
    result = run_scenario(replace(spec, edits=(LockJoint("knee", np.radians(10)),)))
    np.testing.assert_allclose(-result.edited.q[:, 4], np.radians(10), atol=1e-12)
    assert result.edited.free == ("ankle",)


def test_scenario_file_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(STIFF_KNEE.read_text().replace('joint = "knee"', 'joint = "elbow"'))
    with pytest.raises(Exception, match=r"edit.0.joint.*'elbow' is not one of: ankle, knee"):
        load_scenario(bad)
    bad.write_text(STIFF_KNEE.read_text().replace("window = [0.0, 1.0]", "window = [0.0, 9.0]"))
    with pytest.raises(Exception, match="outside the trial"):
        run_scenario(parse_scenario(load_problem(bad)))


def test_sweep_of_the_real_scenario_locally_and_on_dask():
    points = grid_points({"edit.0.k": [0.0, 80.0]})
    local = run_sweep(lambda_free_task, points, workers=2, progress=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        remote = run_sweep(lambda_free_task, points, scheduler=client, progress=False)
    for a, b in zip(local, remote, strict=True):
        assert a.ok and b.ok
        assert a.metrics["knee_rms_change_deg"] == pytest.approx(b.metrics["knee_rms_change_deg"])
    assert abs(local[1].metrics["knee_rms_change_deg"]
               - local[0].metrics["knee_rms_change_deg"]) > 0.01


def lambda_free_task(point):
    """Module-level (picklable) sweep task on the stiff-knee scenario."""
    return scenario_metrics(STIFF_KNEE, point)


def test_cli_scenario_and_sweep(tmp_path, assert_tidy_result,
                                assert_leg_knee_starts_on_measured):
    run = [sys.executable, "-m", "predgait"]
    result = subprocess.run([*run, "scenario", str(STIFF_KNEE), "--set", "window=[0.0, 0.5]",
                             "--out", str(tmp_path / "s")], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    assert {"summary.json", "states_baseline.sto", "states_edited.sto", "edited_leg.urdf",
            "angles.png"} <= {p.name for p in (tmp_path / "s").iterdir()}
    edits = assert_tidy_result(tmp_path / "s" / "summary.json")["edits"]
    # states_baseline.sto in its stated unit (rad): the knee starts on the measured one.
    assert_leg_knee_starts_on_measured(tmp_path / "s" / "states_baseline.sto")
    assert edits == [{"kind": "passive", "joint": "knee", "k": 100.0, "c": 2.0,
                      "theta0_deg": 10.0}]
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'scenario = "{STIFF_KNEE}"\n[grid]\n"edit.0.k" = [0.0, 100.0]\n'
                     f'"edit.0.c" = [0.0, -5.0]\n')
    result = subprocess.run([*run, "sweep", str(sweep), "--out", str(tmp_path / "w")],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 1, result.stderr  # failed points: written, and said so
    assert "predgait: error: 2 of 4 sweep points failed" in result.stderr
    rows = (tmp_path / "w" / "results.csv").read_text().splitlines()
    assert len(rows) == 5
    # A negative damping is refused by the scenario file check: recorded, sweep goes on.
    assert sum(",failed," in row for row in rows) == 2
    assert "outside 0..10000" in rows[2]
    failures = assert_tidy_result(tmp_path / "w" / "summary.json")["failures"]
    assert [f["point"]["edit.0.c"] for f in failures] == [-5.0, -5.0]
