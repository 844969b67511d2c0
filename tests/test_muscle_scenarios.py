"""Muscle-driven scenarios solved (issue 26 item 7) on a small grid.

The baseline (problems/predict_2d_muscles_impact.toml, the scenarios' own, on NODES
intervals) is solved once; each shipped scenario's edited model is solved from it, and
each edit must change the solved gait where physics says it must: an ankle spring's
torque is in the dynamics (Pinocchio's residual vanishes with it and equals the spring's
torque without it); a weakened muscle delivers less force than before and never more than
its new maximum; a fused knee stays at its angle with the weld's reaction holding it. The
published-finding sentence follows the numbers; bad input exits 2 with one message, a
failed baseline exits 3.

Loading-response knee flexion (issue 26 item 5; the last section, on the same baseline,
solved once per process): no prediction of 2D_gait.osim flexes the knee in loading
response: the knee lands still extending and the ground reaction passes through or in
front of it, held by the hamstrings the hip needs anyway.
problems/scenario_muscle_strong_vasti.toml doubles the vasti; then the reaction passes
behind the knee and the vasti brake a flexion wave, as in humans. The baseline must still
fail the >= 8 deg check (if it passes, the scenario's header and the README's explanation
are out of date) and the stronger vasti must pass it with their force and a flexing ground
reaction.
"""

import json
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from predgait.analysis.human_likeness import MIN_LOADING_KNEE_DEG
from predgait.scenarios.muscle_predict import load_muscle_scenario, solve_muscle_scenario
from predgait.scenarios.muscle_scenario_compare import finding, leg_measures

REPO = Path(__file__).resolve().parents[1]
NODES = 20
SET = (f"baseline.grid.nodes={NODES}", "baseline.check.human_likeness=false")


def scenario(name: str):
    run = load_muscle_scenario(REPO / "problems" / f"scenario_muscle_{name}.toml", SET)
    return solve_muscle_scenario(run)


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "predgait", *args], capture_output=True,
                          text=True, timeout=300)


@pytest.fixture(scope="module")
def weakness():
    return scenario("plantarflexor_weakness")


def test_afo_spring_torque_is_in_the_dynamics(weakness):
    """The scenario's node residual and Pinocchio's check both carry the spring torque."""
    from predgait.scenarios.muscle_edits import muscle_scenario
    from predgait.scenarios.muscle_predict import scenario_check, scenario_node

    base = weakness.baseline                       # the unedited gait (cached baseline)
    run = load_muscle_scenario(REPO / "problems" / "scenario_muscle_afo_2d.toml", SET)
    sc = muscle_scenario(run.spec.edits, base.planar, base.plant.muscle_set)
    plant = sc.edited_plant(base.plant)
    node = scenario_node(plant, sc.built, sc)
    p = base.gait.path
    rows = [sc.built.osim_coordinates.index(f"ankle_angle_{s}") for s in "rl"]
    k = int(np.argmax(np.abs(p.q[:, rows[0]])))    # the node of the largest ankle angle
    r = np.array(node(p.q[k], p.v[k], p.a[k], p.act[k], p.exc[k], p.u[k:k + 1])[0]).ravel()
    spring = -286.5 * p.q[k, rows] - 0.5 * p.v[k, rows]          # N m, the file's AFO
    assert abs(spring[0]) > 5.0
    np.testing.assert_allclose(r[rows] - base.gait.residual[k, rows], -spring, atol=1e-6)
    others = [i for i in range(plant.model.nq) if i not in rows]
    np.testing.assert_allclose(r[others], base.gait.residual[k, others], atol=1e-6)
    # Pinocchio: the baseline gait violates the AFO model's dynamics by the spring torque
    check = scenario_check(plant, sc.built, sc, base.gait)
    assert check["max_residual_without_springs"] < 0.05
    assert check["max_residual"] == pytest.approx(check["spring_torque_peak_n_m"], rel=0.02)


def test_weakness_lowers_plantarflexor_force(weakness):
    e, b = weakness.edited, weakness.baseline
    assert e.gait.solved.success, e.gait.solved.status
    assert e.check["max_residual"] < 0.05
    for side in "rl":
        for name in (f"soleus_{side}", f"gastroc_{side}"):
            i = e.plant.muscle_names.index(name)
            fmax = e.plant.muscle_set.muscles[i].max_isometric_force
            assert fmax == pytest.approx(0.2 * b.plant.muscle_set.muscles[i].max_isometric_force)
            assert e.stride.force[:, i].max() < b.stride.force[:, i].max()
            assert e.stride.force[:, i].max() <= 1.05 * fmax        # active + passive


def test_scenario_writes_both_gaits_and_a_finding(weakness, tmp_path, monkeypatch):
    import predgait.workflows.muscle_scenario as ws

    monkeypatch.setattr("predgait.scenarios.muscle_predict.solve_muscle_scenario",
                        lambda run: weakness)
    out = tmp_path / "out"
    summary = ws.run_muscle_scenario(weakness.run, out)
    written = json.loads((out / "summary.json").read_text())
    assert "Ong et al. 2019" in written["finding"]
    assert written["edited_start"].startswith("warm: the baseline's primal-dual point")
    # no human-likeness check was run on this baseline (SET): nothing to warn about
    assert written["baseline"]["human_likeness"] == [] and written["plausibility"] == []
    assert written["status"] == "completed" and written["warnings"] == []
    assert not re.search(r"\.\s+[A-Z]", written["finding"])      # one sentence
    for name in ("baseline", "edited"):
        assert (out / f"{name}_states.sto").is_file()
    c = summary["comparison"]
    assert c["speed_m_s"]["edited"] == pytest.approx(1.2, abs=1e-4)
    assert c["edited"]["cost_of_transport_j_kg_m"] > 0
    assert set(c["legs"]["r"]["rms_change_deg"]) == {"hip", "knee", "ankle"}


@pytest.mark.parametrize("baseline_passes", [False, True])
def test_a_baseline_failing_normal_gait_warns_through_record(weakness, monkeypatch,
                                                            baseline_passes):
    """The baseline's human-likeness checks (here one, failing or passing) become the
    scenario's plausibility check: its warning and status, as every result's."""
    from predgait.analysis.plausibility import Check, record, warning_lines
    from predgait.problems import muscle_prediction
    from predgait.workflows.muscle_scenario import scenario_summary, summary_lines

    real = muscle_prediction.prediction_summary
    knee = Check("loading-response knee flexion", 3.0, ">= 8 deg", "Perry 1992",
                 baseline_passes, "deg")

    def with_human_checks(spec, pred):
        out = real(spec, pred)
        return record(out, [knee], key="human_likeness") if pred is weakness.baseline else out

    monkeypatch.setattr(muscle_prediction, "prediction_summary", with_human_checks)
    summary = scenario_summary(weakness)
    [check] = summary["plausibility"]
    assert check["name"] == "baseline gait: failed checks against normal gait"
    assert check["bound"] == "<= 0 of 1" and check["passed"] == baseline_passes
    if baseline_passes:
        assert summary["status"] == "completed" and summary["warnings"] == []
        return
    assert summary["status"] == "completed with warnings"
    [line] = summary["warnings"]
    assert line.startswith("baseline gait: failed checks against normal gait = 1, outside "
                           "<= 0 of 1") and "not yet human" in line
    assert summary["baseline"]["warnings"] == [knee.line()]
    assert f"  warning: {line}" in summary_lines(summary)
    assert warning_lines(summary) == [f"  warning: {line}"]


def _comparison(cost=0.0, ankle=(20.0, 20.0), swing=(50.0, 50.0)):
    leg = {"range_deg": {"ankle": {"baseline": ankle[0], "edited": ankle[1]}},
           "swing_knee_flexion_peak_deg": {"baseline": swing[0], "edited": swing[1]}}
    return {"cost_of_transport_change_percent": cost, "legs": {"r": leg}}


def test_finding_follows_the_numbers():
    assert "reproduces Hanada" in finding("knee_fusion", _comparison(cost=22.0))
    assert "contradicts Hanada" in finding("knee_fusion", _comparison(cost=-3.0))
    assert "direction, not the size" in finding("knee_fusion", _comparison(cost=80.0))
    afo = finding("afo", _comparison(cost=-2.0, ankle=(25.0, 18.0)))
    assert "(reproduces Ploeger" in afo and "(contradicts the rise" in afo
    assert "contradicts the aim" in finding("rectus_transfer", _comparison(swing=(50, 45)))
    assert "reproduces the aim" in finding("rectus_transfer", _comparison(swing=(50, 58)))
    assert "premise" not in finding("rectus_transfer", _comparison(swing=(50, 58)))
    assert "premise is not tested" in finding("rectus_transfer", _comparison(swing=(63, 58)))


def test_unknown_muscle_exit_2(tmp_path):
    text = (REPO / "problems" / "scenario_muscle_plantarflexor_weakness.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('"soleus", "gastroc"', '"soleus", "gastrocnemius"')
                   .replace('"predict_2d_muscles_impact.toml"',
                            json.dumps(str(REPO / "problems" / "predict_2d_muscles_impact.toml"))))
    result = run_cli("scenario", str(bad), "--out", str(tmp_path / "out"))
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("predgait: error:")
    assert "gastrocnemius" in lines[0] and "line" in lines[0]
    assert not (tmp_path / "out").exists()


def test_failed_baseline_exit_3(tmp_path):
    out = tmp_path / "out"
    result = run_cli("scenario", str(REPO / "problems" / "scenario_muscle_afo_2d.toml"),
                     "--out", str(out), "--no-plots", "--set", "baseline.grid.nodes=8",
                     "--set", "baseline.solver.max_iter=3")
    assert result.returncode == 3, result.stderr
    assert "solve failed" in result.stderr and "baseline" in result.stderr
    assert not out.exists()


def test_fused_knee_residual_row_is_dropped():
    """The fused knee's bounds and whole-stride setup, without solving (fast)."""
    from predgait.scenarios.muscle_edits import muscle_scenario
    from predgait.scenarios.muscle_predict import scenario_bounds

    run = load_muscle_scenario(REPO / "problems" / "scenario_muscle_knee_fusion_2d.toml", SET)
    from predgait.models.osim import read_osim
    from predgait.problems.muscle_gait_setup import plant_2d_gait
    from predgait.problems.muscle_prediction import bundled_file

    plant, planar = plant_2d_gait(read_osim(bundled_file("2D_gait.osim")))
    sc = muscle_scenario(run.spec.edits, planar, plant.muscle_set)
    assert sc.fused == ("knee_angle_r",) and not sc.symmetric
    bounds = scenario_bounds(plant, planar, run.baseline, sc, whole=True)
    row = planar.osim_coordinates.index("knee_angle_r")
    assert np.all(bounds.q[row] == 0.0) and np.all(bounds.v[row] == 0.0)
    assert np.all(bounds.a[row] == 0.0)
    assert bounds.duration == pytest.approx((0.8, 1.2))        # a whole stride
    left = planar.osim_coordinates.index("knee_angle_l")
    assert bounds.q[left, 0] < -0.5                           # the sound knee still bends


def test_fused_knee_stays_at_its_angle():
    """Right knee fused (a whole stride): held at 0, the weld's reaction holds it."""
    r = scenario("knee_fusion_2d")
    e = r.edited
    assert e.gait.solved.success, e.gait.solved.status
    p = e.gait.path
    assert p.q.shape[0] == 2 * NODES + 1                       # a whole stride, not mirrored
    assert r.edited_start == "cold: the baseline's motion mirrored into a whole stride"
    row = e.planar.osim_coordinates.index("knee_angle_r")
    left = e.planar.osim_coordinates.index("knee_angle_l")
    np.testing.assert_allclose(p.q[:, row], 0.0, atol=1e-9)
    np.testing.assert_allclose(p.v[:, row], 0.0, atol=1e-9)
    assert e.check["max_residual"] < 0.05                     # every other row is dynamics
    assert e.check["fused_reaction_peak_n_m"]["knee_angle_r"] > 5.0   # N m, the weld's
    assert -p.q[:, left].min() > np.radians(30.0)             # the sound knee swings


def test_edited_problem_built_on_the_second_thread_solves_as_on_the_main_one(weakness):
    """The edited NLP built on the second thread while the baseline solved (the fixture's
    run) gives, bit for bit, the optimum of one built on the main thread afterwards."""
    from predgait.scenarios.muscle_predict import edited_model, edited_problem, scenario_bounds

    assert weakness.edited_build_s > 0.0
    base, run = weakness.baseline, weakness.run
    scenario, plant = edited_model(run, base.plant, base.planar)
    built = edited_problem(run, scenario, plant)
    assert built.warm                       # half stride, no fused row: the baseline's NLP
    bounds = scenario_bounds(plant, built.planar, run.baseline, scenario, whole=False)
    gait = built.problem.solve(base.gait.path, bounds, run.baseline.goal,
                               multipliers=base.gait.solved.multipliers)
    threaded = weakness.edited.gait.solved
    assert gait.solved.iterations == threaded.iterations
    assert gait.solved.objective == threaded.objective
    np.testing.assert_array_equal(gait.solved.w, threaded.w)


def test_warm_start_of_an_edit_that_changes_nothing_stays_at_the_baseline(weakness, tmp_path):
    """Known answer of the warm start: forces scaled by 1.0 is the baseline's own NLP, so
    from the baseline's primal-dual point Ipopt returns to the baseline's optimum in a few
    iterations (a cold start from the motion alone took more: benchmarks/scenario_starts.py)."""
    from predgait.scenarios.muscle_predict import edited_model, edited_problem, scenario_bounds

    base = weakness.baseline
    text = (REPO / "problems" / "scenario_muscle_plantarflexor_weakness.toml").read_text()
    path = tmp_path / "null_edit.toml"
    path.write_text(text.replace("scale = 0.2", "scale = 1.0").replace(
        'baseline = "predict_2d_muscles_impact.toml"',
        f'baseline = "{(REPO / "problems" / "predict_2d_muscles_impact.toml").as_posix()}"'))
    run = load_muscle_scenario(path, SET)
    scenario, plant = edited_model(run, base.plant, base.planar)
    bounds = scenario_bounds(plant, base.planar, run.baseline, scenario, whole=False)
    built = edited_problem(run, scenario, plant)
    assert built.warm
    solved = built.problem.solve(base.gait.path, bounds, run.baseline.goal,
                                 multipliers=base.gait.solved.multipliers).solved
    assert solved.success
    # Ipopt's tolerance is 1e-4 (scaled): a re-solve may polish the optimum a little
    assert solved.objective == pytest.approx(base.gait.solved.objective, rel=1e-3)
    assert solved.iterations <= 15, solved.iterations


def test_edited_model_errors_come_before_any_solve(monkeypatch):
    """A bad edited model (here a coordinate bound the model lacks) stops the run before
    the baseline is solved: one InputError naming the scenario file."""
    from predgait.errors import InputError
    from predgait.problems.muscle_gait import MuscleGaitProblem
    from predgait.scenarios import muscle_edits, muscle_predict

    run = load_muscle_scenario(REPO / "problems" / "scenario_muscle_afo_2d.toml", SET)
    real = muscle_edits.muscle_scenario

    def with_unknown_bound(*args, **kw):
        sc = real(*args, **kw)
        return replace(sc, coordinate_bounds={"subtalar_angle_r": (0.0, 0.1)})

    def no_solve(*args, **kw):
        raise AssertionError("solved before the edited model was checked")

    monkeypatch.setattr(muscle_edits, "muscle_scenario", with_unknown_bound)
    monkeypatch.setattr(MuscleGaitProblem, "solve", no_solve)
    # Ipopt's derivatives (most of the baseline's build, ~15 s) are not needed to reach
    # the check: the problem is still built, its solver is not
    monkeypatch.setattr(MuscleGaitProblem, "build_solver", lambda self: None)
    monkeypatch.setattr(muscle_predict, "_BASELINES", {})
    with pytest.raises(InputError, match="scenario_muscle_afo_2d.toml.*subtalar_angle_r"):
        solve_muscle_scenario(run)


# Loading-response knee flexion (issue 26 item 5, module docstring)

@pytest.fixture(scope="module")
def strong_vasti():
    """The doubled vasti on the scenarios' baseline (solved once per process: the weakness
    fixture's when that ran first)."""
    run = load_muscle_scenario(REPO / "problems" / "scenario_muscle_strong_vasti.toml", SET)
    return solve_muscle_scenario(run)


def early_stance(gait, percent: float = 20.0) -> np.ndarray:
    """Rows of the stride (from right heel strike) within the first ``percent`` %."""
    t = gait.stride.t
    return np.flatnonzero(100.0 * (t - t[0]) / (t[-1] - t[0]) <= percent)


def reaction_behind_knee_cm(gait, row: int) -> float:
    """Where the right foot's ground reaction line passes the knee, cm (< 0: behind it)."""
    import pinocchio as pin

    model = gait.planar.model.pin_model
    data = model.createData()
    pin.framesForwardKinematics(model, data, gait.stride.q[row])
    knee = data.oMf[model.getFrameId(gait.planar.body_link("tibia_r"))].translation
    right = [i for i, s in enumerate(gait.plant.spheres) if s.name.endswith("_r")]
    centres = np.array([data.oMf[model.getFrameId(gait.plant.spheres[i].link)].act(
        np.array(gait.plant.spheres[i].location)) for i in right])
    force = gait.stride.grf[row, right]
    fz = force[:, 2]
    cop = float((centres[:, 0] * fz).sum() / fz.sum())      # under the sphere centres
    total = force.sum(axis=0)
    return 100.0 * (cop + total[0] / total[2] * knee[2] - knee[0])


def loading_reaction_line_cm(gait) -> float:
    """Mean of :func:`reaction_behind_knee_cm` over the first 20 % of the stride's rows
    where the right foot carries more than half the body weight (the impact's first rows,
    small forces far behind the knee, left out; the trapezoidal grid's horizontal force
    alternates row to row, hence a mean)."""
    weight = gait.plant.model.total_mass() * gait.plant.model.gravity
    fz = gait.stride.foot_fz(gait.plant)[:, 0]
    rows = [i for i in early_stance(gait) if fz[i] > 0.5 * weight]
    return float(np.mean([reaction_behind_knee_cm(gait, i) for i in rows]))


def test_baseline_knee_extends_in_loading_response(strong_vasti):
    base = strong_vasti.baseline
    assert base.gait.solved.success, base.gait.solved.status
    m = leg_measures(base.stride, base.plant, base.planar, "r")
    knee = m["curves"]["knee"]
    assert m["loading_knee_flexion_deg"] < 2.0          # measured 0.0 (50 intervals too)
    # lands flexed and extends: 6.8 -> 1.9 deg (10 -> 1 in another process: the landing
    # moves with round-off, the extension does not)
    assert knee[:11].min() < knee[0] - 3.0
    assert loading_reaction_line_cm(base) > 0.0         # in front of the knee: +3.0 cm


def test_strong_vasti_flex_the_knee_in_loading_response(strong_vasti):
    base, edited = strong_vasti.baseline, strong_vasti.edited
    assert edited.gait.solved.success, edited.gait.solved.status
    assert edited.check["max_residual"] < 0.05
    m = leg_measures(edited.stride, edited.plant, edited.planar, "r")
    assert m["initial_contact"] == "heel"
    assert m["loading_knee_flexion_deg"] >= MIN_LOADING_KNEE_DEG   # measured 13.9 (9.4 at 50)
    vasti = edited.plant.muscle_names.index("vasti_r")
    assert (edited.stride.force[early_stance(edited), vasti].max()
            > 5.0 * base.stride.force[early_stance(base), vasti].max())   # 1548 vs 116 N
    assert loading_reaction_line_cm(edited) < -2.0      # behind the knee: -6.4 cm
