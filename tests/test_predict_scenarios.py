"""Scenarios with ``predicts = true``: edits solved as predictive gait7 problems (issue 13).

Directions checked against the unedited prediction of the same grid: a locked knee keeps
its angle at the lock while hip and ankle change; a mass added to both shanks raises the
swing hip torque. Edits on both legs keep the half-cycle symmetry (fast); 20 nodes per
half cycle keep the tests short (the directions, not the gait's details, are checked).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from predgait.cli import main
from predgait.problemfile import load_problem
from predgait.problems.predictive_solve import PredictSpec
from predgait.scenarios.edits import AddMass, LockJoint
from predgait.scenarios.predict import (
    edited_gait7,
    edited_prediction,
    joint_constraints,
    predict,
    predicted_metrics,
)
from predgait.scenarios.run import parse_scenario

REPO = Path(__file__).resolve().parents[1]
SPEC = PredictSpec(nodes=20, resimulate=False)
BOTH = ("r", "l")


@pytest.fixture(scope="module")
def baseline():
    return predict(SPEC)


def _edited(baseline, edits):
    model = edited_gait7(SPEC, edits, BOTH)
    bounds, springs = joint_constraints(model, edits, BOTH)
    edited = edited_prediction(SPEC, model, bounds, springs, baseline)
    return model, edited, predicted_metrics(edited_gait7(SPEC, (), ()), baseline, edited, BOTH)


def test_locked_knee_stays_locked_and_hip_and_ankle_change(baseline):
    lock = math.radians(10.0)
    model, edited, metrics = _edited(baseline, (LockJoint("knee", lock),))
    assert edited.gait.solved.success
    for s in BOTH:
        knee = edited.gait.q[:, model.coordinate_index(f"knee_{s}")]
        np.testing.assert_allclose(knee, lock, atol=1e-7)       # gait7 knee + = flexion
        assert metrics[f"knee_{s}_range_deg"] < 1e-5
        assert metrics[f"knee_{s}_baseline_range_deg"] > 30.0
        assert metrics[f"hip_{s}_rms_change_deg"] > 2.0
        assert metrics[f"ankle_{s}_rms_change_deg"] > 2.0
    assert metrics["effort"] > metrics["baseline_effort"]       # a stiff leg costs effort
    res = edited.residuals                                      # Pinocchio on the edit
    assert np.abs(res["base_residual_n"]).max() < 1e-3


def test_added_shank_mass_raises_the_swing_hip_torque(baseline):
    model, edited, metrics = _edited(baseline, (AddMass("shank", 2.0, 0.5),))
    assert edited.gait.solved.success
    shank = [link for link in model.pin_model.inertias][1:]
    assert sum(i.mass for i in shank) == pytest.approx(72.6 + 4.0, rel=1e-6)
    for s in BOTH:
        assert metrics[f"swing_hip_torque_rms_{s}_n_m"] > \
            metrics[f"baseline_swing_hip_torque_rms_{s}_n_m"]
    assert np.abs(edited.residuals["torque_mismatch_n_m"]).max() < 1e-6


def test_scenario_file_parses_predicts_and_refuses_predict_without_it(tmp_path):
    spec = parse_scenario(load_problem(REPO / "problems" / "scenario_afo_predict.toml"))
    assert spec.predicts and spec.side == "right" and spec.predict.nodes == 40
    bad = tmp_path / "bad.toml"
    bad.write_text('side = "both"\n[[edit]]\nkind = "passive"\njoint = "ankle"\nk = 1.0\n')
    code = main(["scenario", str(bad), "--out", str(tmp_path / "x")])
    assert code == 2


def test_model_unable_to_stand_exits_3_and_writes_nothing(tmp_path, capsys):
    scenario = tmp_path / "crouch.toml"
    scenario.write_text('name = "knees locked at 150 deg"\nside = "both"\npredicts = true\n'
                        '[[edit]]\nkind = "lock_joint"\njoint = "knee"\nangle_deg = 150.0\n'
                        '[predict.grid]\nnodes = 20\n[predict.solver]\nmax_iter = 60\n')
    out = tmp_path / "never"
    assert main(["scenario", str(scenario), "--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert "predgait: solve failed: Ipopt" in err and "constraint violation" in err
    assert not out.exists()


def test_springs_match_the_engine_passive_elements(baseline):
    """An orthosis spring in the NLP equals the engine's passive element (Pinocchio check)."""
    from predgait.scenarios.edits import PassiveEdit

    model = edited_gait7(SPEC, (), ())
    bounds, springs = joint_constraints(model, (PassiveEdit("ankle", 100.0, 1.0, 0.1),), BOTH)
    edited = edited_prediction(SPEC, model, bounds, springs, baseline)
    assert len(springs) == 2
    assert np.abs(edited.residuals["torque_mismatch_n_m"]).max() < 1e-6


def test_sweep_over_a_predicted_orthosis(tmp_path):
    """scenario_metrics runs predicted scenarios; a 0 N m/rad orthosis changes nothing."""
    import functools

    from predgait.scenarios.run import scenario_metrics
    from predgait.scenarios.sweep import grid_points, run_sweep

    scenario = tmp_path / "afo.toml"
    scenario.write_text('side = "both"\npredicts = true\n[[edit]]\nkind = "passive"\n'
                        'joint = "ankle"\nk = 0.0\nc = 0.0\n[predict.grid]\nnodes = 20\n'
                        '[predict.check]\nresimulate = false\n')
    points = grid_points({"edit.0.k": [0.0, 150.0]})
    outcomes = run_sweep(functools.partial(scenario_metrics, scenario), points, workers=1,
                         progress=False)
    assert all(o.ok for o in outcomes), [o.reason for o in outcomes]
    none, spring = (o.metrics for o in outcomes)
    assert none["effort"] == pytest.approx(none["baseline_effort"], rel=1e-4)
    assert none["ankle_r_rms_change_deg"] < 0.05
    assert spring["ankle_r_rms_change_deg"] > 0.5


def test_other_grids_start_from_the_coarse_solution_resampled(monkeypatch, baseline):
    """Grid continuation: tracking and predictive on START_INTERVALS, then the final grid."""
    from predgait.problems import predictive_solve

    monkeypatch.setattr(predictive_solve, "START_INTERVALS", SPEC.nodes)
    fine = predict(replace(SPEC, nodes=SPEC.nodes + 4))
    # (a start that failed on this machine's floating-point path is a stage of its own)
    solved = [(what, s) for what, s in fine.stages if s.success]
    assert all(what.endswith("(failed)") for what, s in fine.stages if not s.success)
    assert [what for what, _ in solved] == ["tracking on 20 intervals",
                                            "predictive on 20 intervals"]
    assert solved[1][1].objective == pytest.approx(baseline.gait.solved.objective, rel=1e-6)
    assert fine.gait.solved.success and fine.gait.t.size == SPEC.nodes + 5
    assert np.abs(fine.residuals["base_residual_n"]).max() < 1e-3
    # the refined gait stays the coarse one: same stances, angles within a few degrees
    # (the effort moves by ~12 %: trapezoidal error at 20-24 intervals)
    from predgait.problems.predictive_data import resampled_guess

    for side in ("right", "left"):
        assert fine.measures[side]["stance_phases"] == baseline.measures[side]["stance_phases"]
    coarse = resampled_guess(baseline.gait, SPEC.nodes + 4).q
    change = np.degrees(np.sqrt(np.mean((fine.gait.q - coarse)[:, 2:] ** 2, axis=0)))
    assert change.max() < 5.0, change


def test_cli_predicted_scenario_writes_both_gaits(tmp_path, capsys):
    import json

    scenario = tmp_path / "afo.toml"
    scenario.write_text('name = "orthosis both sides"\nside = "both"\npredicts = true\n'
                        '[[edit]]\nkind = "passive"\njoint = "ankle"\nk = 100.0\nc = 1.0\n'
                        '[predict.grid]\nnodes = 20\n[predict.check]\nresimulate = false\n')
    out = tmp_path / "out"
    assert main(["scenario", str(scenario), "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["predicts"] and summary["edits"][0]["kind"] == "passive"
    assert summary["edited"]["pinocchio_check"]["max_torque_mismatch_n_m"] < 1e-6
    for name in ("baseline_states.sto", "edited_torques.sto", "edited_grf.sto",
                 "edited_gait7.urdf", "predicted_stick.png", "predicted_grf.png"):
        assert (out / name).is_file(), name
    assert "swing hip torque" in capsys.readouterr().out
    # baseline_states.sto in its stated unit (rad): its right knee's range is the one the
    # summary gives in degrees, and its swing peak is a knee's (Kadaba 1990: 55-70 deg).
    from predgait.data.storage import read_storage

    def find(tree, key):
        if isinstance(tree, dict):
            if key in tree:
                return tree[key]
            return next((v for v in (find(t, key) for t in tree.values()) if v is not None),
                        None)
        return None

    states = read_storage(out / "baseline_states.sto")
    assert states.header["units"].startswith("m, rad") and not states.in_degrees
    knee = np.degrees(states.column("knee_r"))     # gait7: + knee flexion
    assert np.ptp(knee) == pytest.approx(find(summary, "knee_r_baseline_range_deg"), abs=0.5)
    assert 45.0 < knee.max() < 75.0
