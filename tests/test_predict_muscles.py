"""Muscle-driven 2D gait prediction (Moco's example2DWalking) on a small grid.

One solve on 16 intervals (the product grid is 50: benchmarks/bench_predict.py) from the
bundled referenceCoordinates.sto: it converges, the periodicity (left/right symmetry)
and the 1.2 m/s average speed hold, Pinocchio's RNEA/ABA re-evaluation of every node
equals the NLP's dynamics (and a perturbed contact force is seen), the STO files carry
OpenSim's column names and the solution's values; bad input is refused (exit 2) and an
infeasible problem exits 3 with its best point written as partial, never as a gait.
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from predgait.data import read_storage
from predgait.problems.muscle_gait import mirror_rows
from predgait.problems.muscle_gait_check import node_check
from predgait.problems.muscle_prediction import MusclePredictSpec, solve_prediction

REPO = Path(__file__).resolve().parents[1]
NODES = 16


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "predgait", *args], capture_output=True,
                          text=True, timeout=300)


@pytest.fixture(scope="module")
def prediction():
    return solve_prediction(MusclePredictSpec(nodes=NODES, human_checks=False))


def test_converges_at_the_desired_speed(prediction):
    s = prediction.gait.solved
    assert s.success, s.status
    path = prediction.gait.path
    distance = path.q[-1, 0] - path.q[0, 0]
    assert distance / path.duration == pytest.approx(1.2, abs=1e-6)
    assert 0.4 - 1e-9 <= path.duration <= 0.6 + 1e-9
    assert prediction.gait.terms["effort"] > 0


def test_left_right_symmetry(prediction):
    plant, path = prediction.plant, prediction.gait.path
    mq = mirror_rows(plant.model.coordinate_names)
    keep = [i for i in range(plant.model.nq) if i != 0]          # all but pelvis_tx
    np.testing.assert_allclose(path.q[-1, keep], path.q[0, mq[keep]], atol=1e-5)
    np.testing.assert_allclose(path.v[-1], path.v[0, mq], atol=1e-5)
    mm = mirror_rows(plant.muscle_names)
    np.testing.assert_allclose(path.act[-1], path.act[0, mm], atol=1e-5)
    assert path.u[-1] == pytest.approx(path.u[0], abs=1e-5)
    assert plant.muscle_names[mm[0]] == "hamstrings_l"            # the pairs are real ones


def test_pinocchio_agrees_with_the_nlp_dynamics(prediction):
    check = prediction.check
    weight = prediction.plant.model.total_mass() * prediction.plant.model.gravity
    assert check["max_residual"] < 0.05                            # N, N m (body weight 608 N)
    assert check["nlp_residual_max"] < 0.05
    assert check["max_acceleration_error"] < 0.5                   # rad/s^2 of up to ~1e2
    stance = prediction.gait.grf[:, :, 2].sum(axis=1).max()
    assert 0.8 * weight < stance < 3.0 * weight                     # the feet carry the body
    # the check can fail: 10 N more on one sphere shows up as a residual of about 10 N
    bumped = prediction.gait.grf.copy()
    bumped[:, 0, 2] += 10.0
    other = node_check(prediction.plant, _with(prediction.gait, grf=bumped))
    assert other["max_residual"] > 5.0


def _with(gait, **changes):
    from dataclasses import replace

    return replace(gait, **changes)


def test_sto_files_use_opensim_names_and_values(prediction, tmp_path):
    from predgait.workflows.muscle_gait_files import write_gait_files

    names = write_gait_files(tmp_path, prediction.planar, prediction.plant, prediction.gait,
                             prediction.stride, status="Solve_Succeeded")
    assert (tmp_path / names[0]).is_file()
    solution = read_storage(tmp_path / "solution.sto")
    assert solution.header["num_states"] == "38" and solution.header["num_controls"] == "19"
    knee = solution.column("/jointset/knee_r/knee_angle_r/value")
    path = prediction.gait.path
    row = prediction.plant.model.coordinate_names.index("knee_angle_r")
    np.testing.assert_allclose(knee, path.q[:, row], atol=1e-8)
    tilt = solution.column("/jointset/groundPelvis/pelvis_tilt/value")
    np.testing.assert_allclose(tilt, -path.q[:, 2], atol=1e-8)   # base_pitch = -pelvis_tilt
    states = read_storage(tmp_path / "states.sto")
    assert states.time.size == 2 * NODES + 1                      # full stride by mirroring
    assert "/soleus_l/activation" in states.columns
    grf = read_storage(tmp_path / "grf.sto")
    weight = prediction.plant.model.total_mass() * prediction.plant.model.gravity
    vertical = grf.column("ground_force_r_vy") + grf.column("ground_force_l_vy")
    assert np.mean(vertical) == pytest.approx(weight, rel=0.05)   # average GRF = weight


def test_unknown_key_is_refused(tmp_path):
    problem = tmp_path / "p.toml"
    problem.write_text((REPO / "problems" / "predict_2d_muscles.toml").read_text()
                       .replace("[grid]\n", "[grid]\nnode = 10\n"))
    result = run_cli("solve", str(problem), "--out", str(tmp_path / "out"))
    assert result.returncode == 2
    assert "grid.node" in result.stderr and "line" in result.stderr
    assert not (tmp_path / "out").exists()


def test_unknown_coordinate_bound_is_refused(tmp_path):
    result = run_cli("solve", str(REPO / "problems" / "predict_2d_muscles.toml"), "--out",
                     str(tmp_path / "out"), "--set", "bounds.knee_r=[-10, 0]")
    assert result.returncode == 2 and "knee_angle_r" in result.stderr


def test_infeasible_bounds_exit_3_with_a_partial_point(tmp_path):
    out = tmp_path / "out"
    result = run_cli("solve", str(REPO / "problems" / "predict_2d_muscles.toml"), "--out",
                     str(out), "--no-plots", "--set", "grid.nodes=8",
                     "--set", "solver.max_iter=40", "--every", "10",
                     "--set", "bounds.knee_angle_r=[10, 20]",     # symmetry: knee_l(T) =
                     "--set", "bounds.knee_angle_l=[-50, -40]")   # knee_r(0): impossible
    assert result.returncode == 3, result.stderr
    assert "solve failed" in result.stderr and "not a gait" in result.stderr
    # Live progress every 10 iterations (solve --every 10), each line with both measures.
    iters = [line for line in result.stdout.splitlines() if ": iter " in line]
    assert [int(line.split()[-7]) for line in iters] == [0, 10, 20, 30, 40], result.stdout
    assert all("objective" in line and "constraint violation" in line for line in iters)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "not converged"
    assert not summary["ipopt"]["success"]
    assert (out / "partial_states.sto").is_file() and not (out / "states.sto").exists()


def test_cli_lists_the_files_it_wrote(tmp_path, monkeypatch, capsys):
    """The console names what is in the folder (e.g. no plot under --no-plots), not a
    fixed list: the run is replaced by one writing two files."""
    import predgait.workflows.predict_muscles as workflow
    from predgait.cli import main

    def fake_run(spec, out, *, force=False):
        out.mkdir()
        for name in ("summary.json", "states.sto"):
            (out / name).write_text("x")
        return {}

    monkeypatch.setattr(workflow, "run_muscle_predict", fake_run)
    monkeypatch.setattr(workflow, "summary_lines", lambda summary: [])
    out = tmp_path / "out"
    assert main(["solve", str(REPO / "problems" / "predict_2d_muscles.toml"), "--out",
                 str(out), "--no-plots"]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {out}/ (states.sto, summary.json)"
