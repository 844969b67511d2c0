"""Predictive gait7 collocation (issue 13): tracking, prediction, Pinocchio check, engine.

Known answers: with a high tracking weight the solution reproduces the measured gait7
motion and GRF; every node satisfies the dynamics when Pinocchio (RNEA + the engine's
contact force) re-evaluates it, independent of the ADAM expressions the optimiser used;
with tracking weight 0 a periodic walking gait at the given speed emerges; the engine
re-simulates it with TVLQR feedback within a small deviation.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from predgait.cli import main
from predgait.data.storage import read_storage
from predgait.dynamics.gait7_motion import gait7_model
from predgait.problems.predictive import Cycle, Guess, Weights, mirror_matrix
from predgait.problems.predictive_solve import TRACKING_STAGE, PredictSpec
from predgait.scenarios.predict import predict

NODES = 40
SPEC = PredictSpec(nodes=NODES, resimulate=False)


@pytest.fixture(scope="module")
def model():
    return gait7_model(SPEC.mass, SPEC.height)


@pytest.fixture(scope="module")
def tracking(model):
    return predict(replace(SPEC, weights=TRACKING_STAGE), model)


@pytest.fixture(scope="module")
def predictive(model, tracking):
    g = tracking.gait
    return predict(replace(SPEC, resimulate=True), model, guess=Guess(g.q, g.v, g.a))


def _pinocchio_agrees(prediction):
    res = prediction.residuals
    assert np.abs(res["base_residual_n"]).max() < 1e-3          # N, N m (solver tol 1e-6)
    assert np.abs(res["torque_mismatch_n_m"]).max() < 1e-6      # ADAM == Pinocchio
    assert res["defects"]["q"] < 1e-8 and res["defects"]["v"] < 1e-6


def test_tracking_reproduces_the_measured_gait7_motion(tracking):
    g, ref = tracking.gait, tracking.measured.reference
    assert g.solved.success
    rms = np.degrees(np.sqrt(np.mean((g.q - ref.q)[:, 2:] ** 2, axis=0)))
    assert rms.max() < 3.0, rms
    fz = g.foot_fz()
    for i in range(2):
        assert np.corrcoef(fz[:, i], ref.foot_fz[:, i])[0, 1] > 0.9
    _pinocchio_agrees(tracking)


def test_predictive_gait_is_periodic_walking_at_the_speed(model, tracking, predictive):
    g = predictive.gait
    assert g.solved.success
    _pinocchio_agrees(predictive)
    x = model.coordinate_index("base_x")
    mirror = mirror_matrix(model, Cycle.HALF)
    end = mirror @ g.q[0]
    end[x] += g.speed * g.duration
    assert np.abs(g.q[-1] - end).max() < 1e-6
    assert np.abs(g.v[-1] - mirror @ g.v[0]).max() < 1e-6
    assert (g.q[-1, x] - g.q[0, x]) / g.duration == pytest.approx(tracking.gait.speed, 1e-9)
    weight = model.total_mass() * model.gravity
    for side in ("right", "left"):
        m = predictive.measures[side]
        assert m["stance_phases"] == 1                     # one stance, one swing
        assert 0.5 < m["stance_fraction"] < 0.8
    for side in ("right", "left"):                         # double bump
        grf = predictive.measures[side]["vertical_grf"]
        assert grf["loading_peak_bw"] > grf["valley_bw"] + 0.1
        assert grf["push_off_peak_bw"] > grf["valley_bw"] + 0.1
    stride = predictive.stride                             # the same from the raw forces
    fz = stride["contact"][:-1, :2, 1].sum(axis=1)
    stance = np.flatnonzero(fz > 20.0)
    stance = stance[stance < fz.size - 5]                  # the next stride's strike
    thirds = np.array_split(fz[stance], 3)
    assert thirds[0].max() / weight == pytest.approx(
        predictive.measures["right"]["vertical_grf"]["loading_peak_bw"], abs=0.05)
    assert thirds[1].min() / weight == pytest.approx(
        predictive.measures["right"]["vertical_grf"]["valley_bw"], abs=0.05)
    # purely predictive: far less effort than the tracked (measured) gait
    assert g.terms["effort"] < 0.5 * tracking.gait.terms["effort"]
    assert g.terms["effort"] < tracking.gait.terms["effort"]


def test_predictive_objective_falls_over_the_iterations(predictive):
    history = np.array(predictive.gait.solved.history["objective"])
    assert history[-1] < history[0]
    assert history[-1] == pytest.approx(predictive.gait.solved.objective, rel=1e-6)


def test_engine_resimulates_the_predicted_stride_with_feedback(predictive):
    rerun = predictive.resimulation
    assert rerun.run.t[-1] == pytest.approx(predictive.stride["t"][-1])
    assert rerun.max_angle_deviation_deg < 1.0
    assert rerun.max_position_deviation_m < 0.01
    assert rerun.feedback_rms_n_m < 0.2 * rerun.feedforward_rms_n_m


def test_full_stride_mirrors_the_half_cycle(model, predictive):
    st, g = predictive.stride, predictive.gait
    n = g.t.size
    assert st["t"].size == 2 * n - 1
    right, left = model.coordinate_index("knee_r"), model.coordinate_index("knee_l")
    np.testing.assert_allclose(st["q"][n - 1:, right], g.q[:, left])
    np.testing.assert_allclose(st["contact"][n - 1:, 0], g.contact[:, 2])


def test_stride_from_heel_strike_starts_at_the_right_touch_down(model, predictive):
    from predgait.problems.predictive_check import STANCE_THRESHOLD_N, heel_strikes

    st, al = predictive.stride, predictive.aligned
    fz_r = al["contact"][:, :2, 1].sum(axis=1)
    assert al["t"][0] == 0.0 and fz_r[0] > STANCE_THRESHOLD_N and fz_r[-2] <= STANCE_THRESHOLD_N
    assert al["t"][-1] == pytest.approx(st["t"][-1] - st["t"][0])
    assert np.all(np.diff(al["t"]) > 0)
    # the same gait, re-phased: the node the solver's stride had at the right heel strike
    k = heel_strikes(st)["right"]
    np.testing.assert_allclose(al["q"][0], st["q"][k])
    x = model.coordinate_index("base_x")
    assert al["q"][-1, x] - al["q"][0, x] == pytest.approx(st["q"][-1, x] - st["q"][0, x])
    assert np.all(np.diff(al["q"][:, x]) > 0)


def test_the_same_gait_started_elsewhere_aligns_to_the_same_curves(model, predictive):
    """What scenario comparisons rely on (predicted_metrics compares aligned strides)."""
    from predgait.problems.predictive_check import from_heel_strike
    from predgait.scenarios.predict import percent_of_stride

    st = predictive.stride
    shift, x = 7, model.coordinate_index("base_x")
    advance = st["q"][-1, x] - st["q"][0, x]
    period = st["t"][-1] - st["t"][0]
    later = {}
    for key, values in st.items():
        rolled = np.concatenate([values[shift:-1], values[:shift + 1]])
        if key == "t":
            rolled[-shift - 1:] += period
        if key == "q":
            rolled[-shift - 1:, x] += advance
        later[key] = rolled
    again = from_heel_strike(model, later)
    knee = model.coordinate_index("knee_r")
    np.testing.assert_allclose(percent_of_stride(again, knee),
                               percent_of_stride(predictive.aligned, knee), atol=1e-12)
    assert np.abs(percent_of_stride(again, knee)
                  - np.interp(np.linspace(0, 1, 101), np.linspace(0, 1, len(later["t"])),
                              later["q"][:, knee])).max() > 0.05


def test_step_lengths_per_side_add_up_to_the_stride(predictive):
    g = predictive.measures
    right, left = g["right"]["step_length_m"], g["left"]["step_length_m"]
    assert right + left == pytest.approx(2 * g["step_length_m"], abs=1e-6)
    # a symmetric half cycle mirrored: both steps alike
    assert right == pytest.approx(left, abs=0.02)
    assert 0.3 < right < 1.0


def test_weights_vector_order():
    assert Weights(1, 2, 3, 4).vector().tolist() == [1, 2, 3, 4]


PROBLEM = Path(__file__).resolve().parents[1] / "problems" / "predict_gait7.toml"


def test_cli_solve_writes_a_tracking_prediction(tmp_path, capsys):
    out = tmp_path / "predict"
    code = main(["solve", str(PROBLEM), "--out", str(out), "--no-plots",
                 "--set", f"grid.nodes={NODES}", "--set", "weights.tracking=1",
                 "--set", "weights.grf=10", "--set", "weights.effort=0.01"])
    assert code == 0
    summary = json.loads((out / "solution.json").read_text())
    assert summary["ipopt_status"] == "Solve_Succeeded"
    assert max(summary["vs_measured"]["angle_rms_deg"].values()) < 3.0
    assert summary["pinocchio_check"]["max_base_residual_n"] < 1e-3
    assert summary["resimulation"]["max_angle_deviation_deg"] < 1.0
    states = read_storage(out / "states.sto")
    assert states.time.size == 2 * NODES + 1
    # Its stated unit (rad): a prediction tracking the measured gait within 3 deg reaches
    # the knee's swing peak, 55-70 deg in normal gait (Kadaba 1990).
    assert states.header["units"].startswith("m, rad") and not states.in_degrees
    assert 45.0 < np.degrees(np.nanmax(states.column("knee_r"))) < 75.0
    motion = read_storage(out / "motion.mot")   # OpenSim 2D gait coordinates (issue 31)
    assert motion.in_degrees and motion.header["units"].startswith("deg")
    np.testing.assert_allclose(motion.column("knee_angle_r"),
                               -np.degrees(states.column("knee_r")), atol=1e-6)
    printed = capsys.readouterr().out
    assert "Pinocchio at every node" in printed
    assert "not for clinical prediction" in printed and "stiff-legged" in summary["model_note"]
    # Live progress (solve --every 5, the default): a line every 5 Ipopt iterations.
    label = f"predictive on {NODES} intervals"
    iterations = summary["iterations"]
    lines = [x for x in printed.splitlines() if x.startswith(f"  {label}: iter ")]
    assert [int(x.split()[-7]) for x in lines] == list(range(0, iterations + 1, 5))
    history = summary["ipopt_history"]["objective"]   # the same iterates as Ipopt's history
    assert [float(x.split()[-5]) for x in lines] == pytest.approx(
        history[::5], rel=1e-3, abs=1e-9)
    assert f"{label}: Ipopt stopped after {iterations} iterations" in printed
    steps = summary["gait"]["right"]["step_length_m"], summary["gait"]["left"]["step_length_m"]
    assert f"steps right {steps[0]:.3f} m / left {steps[1]:.3f} m" in printed
    from predgait.report.headline import headline

    head = headline(out)
    assert head.title == "Predicted gait (gait7)" and head.ok
    assert f"{summary['gait']['speed_m_s']:.2f} m/s" in head.sentence


def test_cli_impossible_speed_exits_3_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "never"
    code = main(["solve", str(PROBLEM), "--out", str(out), "--set", "grid.nodes=20",
                 "--set", "gait.speed=6.0", "--set", "gait.stride_time=1.0",
                 "--set", "solver.max_iter=150"])
    assert code == 3
    err = capsys.readouterr().err
    assert "predgait: solve failed: Ipopt" in err and "constraint violation" in err
    assert not out.exists()


@pytest.mark.parametrize(("key", "value", "words"), [
    ("grid.cycle", '"quarter"', "cycle"), ("weights.effort", "-1", "effort"),
    ("contact.stiffness", "0", "stiffness"), ("grid.nodes", "2", "nodes")])
def test_cli_bad_problem_values_exit_2(tmp_path, capsys, key, value, words):
    code = main(["solve", str(PROBLEM), "--out", str(tmp_path / "x"), "--set",
                 f"{key}={value}"])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("predgait: error:") and words in err
    assert not (tmp_path / "x").exists()
