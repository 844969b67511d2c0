"""Any trial, directly: a leg problem's [trial] takes the inputs of `predgait inverse`."""

import json
from pathlib import Path

import pytest

from predgait.cli import main
from predgait.problemfile import load_problem
from predgait.workflows.inverse_io import options_from_problem
from predgait.workflows.trials import leg_trial

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
WALKING5 = DATA / "opensim_walking5_c3d" / "walking5.c3d"


def _as_direct_trial(inverse_problem: Path) -> str:
    """An inverse problem file's tables moved under [trial] (points, options)."""
    text = inverse_problem.read_text()
    return text.replace("[points", "[trial.points").replace("[options]", "[trial.options]")


def test_direct_trial_reads_like_the_inverse_problem(tmp_path):
    source = REPO / "problems" / "inverse_subject01.toml"
    problem = tmp_path / "direct.toml"
    problem.write_text('kind = "passive_decomposition"\n' + _as_direct_trial(source))
    trial = leg_trial(load_problem(problem).table("trial"))
    assert trial.options() == options_from_problem(load_problem(source))
    assert trial.side == "right" and trial.inverse_problem is None


def test_solve_on_a_c3d_trial_given_directly(tmp_path):
    problem = tmp_path / "walking5.toml"
    problem.write_text(f'''kind = "passive_decomposition"
joints = ["knee"]
window_sensitivity = []   # this test is about the trial input (walking5: window-dependent)
[trial]
markers = "{WALKING5}"
mass = 72.0
side = "right"
[trial.points]
hip = "RHJC"
knee = "RKJC"
ankle = "RAJC"
heel = "RCAL"
toe = "RMT2"
[filter]
marker_cutoff = 8.0
sensitivity_hz = [6.0]
[uncertainty]
bootstrap = 20
[passive.knee]
elements = ["linear"]
''')
    out = tmp_path / "out"
    assert main(["solve", str(problem), "--out", str(out), "--no-plots"]) == 0
    solution = json.loads((out / "solution.json").read_text())
    assert "walking5.c3d" in solution["provenance"]["trial"]
    assert solution["quiet_swings"] >= 2
    assert solution["gait_cycles"] + solution["partial_cycles"] >= 2
    k = solution["parameters"]["knee.k"]
    assert k["status"] == "identified" and 0 < k["value"] < 100


@pytest.mark.parametrize(("extra", "words"), [
    ('inverse_problem = "inverse_subject01.toml"\n', "drop inverse_problem"),
    ('source = "bundled:subject01"\n', "drop source"),
])
def test_direct_trial_refuses_a_second_source(tmp_path, capsys, extra, words):
    problem = tmp_path / "p.toml"
    problem.write_text(f'kind = "passive_decomposition"\n[trial]\n{extra}markers = "{WALKING5}"\n'
                       'mass = 72.0\n[trial.points]\nhip = "RHJC"\n')
    assert main(["solve", str(problem), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("predgait: error:") and words in err


def test_direct_trial_needs_its_markers_named(tmp_path, capsys):
    problem = tmp_path / "p.toml"
    problem.write_text(f'kind = "torque_feedback"\n[trial]\nmarkers = "{WALKING5}"\n'
                       'mass = 72.0\n')
    assert main(["solve", str(problem), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "trial.points" in err or "[trial.points]" in err
