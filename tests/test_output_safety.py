"""Outputs never replace an input, are checked before any work, honour the umask and
leave no staging folder behind (errors, SIGTERM, killed runs); provenance names files
the way the user gave them.
"""

from __future__ import annotations

import os
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from cli_checks import one_error as _one_error
from predgait.cli import main
from predgait.data import write_csv
from predgait.workflows.output import remove_stale_stages, staged_output

REPO = Path(__file__).resolve().parents[1]
PROBLEMS = REPO / "problems"
SEGMENTS = ("segment,mass_kg,length_m,com_from_proximal,inertia_kg_m2\n"
            "foot,1.05,0.26,0.5,0.0044\nshank,3.37,0.43,0.433,0.0504\n"
            "thigh,7.26,0.43,0.433,0.1330\n")




def test_inverse_out_holding_the_problem_file_is_refused(tmp_path, capsys, monkeypatch):
    folder = tmp_path / "dir"
    folder.mkdir()
    shutil.copy(PROBLEMS / "inverse_subject01.toml", folder / "p.toml")
    monkeypatch.chdir(tmp_path)
    status = main(["inverse", "dir/p.toml", "--out", "dir", "--force"])
    _one_error(capsys, status, "holds the input")
    assert (folder / "p.toml").read_text() == (PROBLEMS / "inverse_subject01.toml").read_text()


def test_simulate_out_holding_the_inverse_problem_is_refused(tmp_path, capsys, monkeypatch):
    (tmp_path / "inv").mkdir()
    shutil.copy(PROBLEMS / "inverse_subject01.toml", tmp_path / "inv" / "inverse.toml")
    problem = (PROBLEMS / "resynthesis.toml").read_text().replace(
        'source = "bundled:subject01"', 'inverse_problem = "inv/inverse.toml"')
    (tmp_path / "re.toml").write_text(problem)
    monkeypatch.chdir(tmp_path)
    status = main(["simulate", "re.toml", "--out", "inv", "--force"])
    _one_error(capsys, status, "inverse.toml")
    assert (tmp_path / "inv" / "inverse.toml").is_file()


def test_report_into_its_own_folder_is_refused(tmp_path, capsys, monkeypatch):
    res = tmp_path / "res"
    res.mkdir()
    (res / "summary.json").write_text('{"status": "ok"}\n')
    monkeypatch.chdir(tmp_path)
    status = main(["report", "res", "-o", "res/summary.json", "--force"])
    _one_error(capsys, status, "inside the input folder")
    assert (res / "summary.json").read_text() == '{"status": "ok"}\n'


def test_model_build_over_its_segment_table_is_refused(tmp_path, capsys, monkeypatch):
    (tmp_path / "seg.csv").write_text(SEGMENTS)
    monkeypatch.chdir(tmp_path)
    status = main(["model", "build", "leg", "--segments", "seg.csv", "-o", "seg.csv", "--force"])
    _one_error(capsys, status, "seg.csv")
    assert (tmp_path / "seg.csv").read_text() == SEGMENTS


@pytest.mark.parametrize("command", [
    ["sweep", str(PROBLEMS / "sweep_knee_stiffness.toml")],
    ["scenario", str(PROBLEMS / "scenario_stiff_knee.toml")],
    ["solve", str(PROBLEMS / "knee_fit.toml")],
    ["simulate", str(PROBLEMS / "resynthesis.toml")],
    ["inverse", str(PROBLEMS / "inverse_subject01.toml")],
])
def test_existing_out_is_refused_before_any_work(command, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    started = time.perf_counter()
    status = main([*command, "--out", str(out)])
    _one_error(capsys, status, "exists", "--force")
    assert time.perf_counter() - started < 5.0  # no point, solve or simulation was run
    assert [p.name for p in out.iterdir()] == ["keep.txt"]


def test_missing_parent_folder_says_how_to_create_it(tmp_path, capsys):
    status = main(["simulate", str(PROBLEMS / "rod.toml"), "--out", str(tmp_path / "a" / "b")])
    _one_error(capsys, status, "mkdir -p")


def test_staged_output_honours_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        with staged_output(tmp_path / "res") as stage:
            write_csv(stage / "a.csv", np.arange(3.0), {"x": np.ones(3)})
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "res").stat().st_mode) == 0o755
    assert stat.S_IMODE((tmp_path / "res" / "a.csv").stat().st_mode) == 0o644


def test_error_inside_the_block_leaves_nothing(tmp_path):
    with pytest.raises(RuntimeError), staged_output(tmp_path / "res") as stage:
        (stage / "half.txt").write_text("partial")
        raise RuntimeError("fails mid-way")
    assert list(tmp_path.iterdir()) == []


def test_stale_staging_folder_of_a_killed_run_is_removed(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    stale = tmp_path / f".res.predgait-{dead.stdout.strip()}-abc123"
    stale.mkdir()
    (stale / "states.sto").write_text("partial")
    live = tmp_path / f".other.predgait-{os.getpid()}-xyz"
    live.mkdir()
    assert remove_stale_stages(tmp_path) == [stale]
    assert not stale.exists() and live.exists()
    with staged_output(tmp_path / "res2") as stage:
        (stage / "a.txt").write_text("whole")
    assert sorted(p.name for p in tmp_path.iterdir()) == [live.name, "res2"]


def test_sigterm_mid_run_leaves_no_staging_folder(tmp_path):
    """A real run, terminated while it writes into its staging folder."""
    command = [sys.executable, "-m", "predgait", "simulate", str(PROBLEMS / "resynthesis.toml"),
               "--out", "res"]
    process = subprocess.Popen(command, cwd=tmp_path, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not list(tmp_path.glob(".res.predgait-*")) and time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()
        time.sleep(0.05)
    assert list(tmp_path.glob(".res.predgait-*")), "the run never started staging"
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 143, err
    assert "terminated; no output was completed" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


TERMINATED_INSIDE_EXEC = """
import argparse, sys
from predgait import cli

def run(args):  # SIGTERM lands inside an exec of a string, as while a dataclass is built
    exec("import os, signal\\nos.kill(os.getpid(), signal.SIGTERM)\\nwhile True: pass")

class Parser:
    def parse_args(self, argv):
        return argparse.Namespace(verbose=False, run=run)

cli.build_parser = Parser
sys.exit(cli.main([]))
"""


def test_sigterm_inside_exec_still_exits_with_its_status(tmp_path):
    """Under ``python -m`` a handled KeyboardInterrupt that left an exec'd string made
    CPython end the process by SIGINT (exit -2 in CI); SIGTERM is now its own exception."""
    (tmp_path / "terminated_run.py").write_text(TERMINATED_INSIDE_EXEC)
    done = subprocess.run([sys.executable, "-m", "terminated_run"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 143, done.stderr
    assert done.stderr.strip() == "predgait: terminated; no output was completed."


def test_provenance_names_bundled_files_and_user_paths(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    shutil.copy(PROBLEMS / "inverse_subject01.toml", tmp_path / "inv.toml")
    assert main(["inverse", "inv.toml", "--out", "res"]) == 0
    texts = [p.read_text() for p in (tmp_path / "res").iterdir() if p.suffix in
             (".sto", ".csv", ".json")]
    joined = "\n".join(texts)
    assert "bundled:subject01_walk1/subject01_walk1.trc" in joined
    assert "site-packages" not in joined and ".predgait-" not in joined
    assert str(REPO / "src") not in joined


def test_solve_out_holding_the_inverse_problem_is_refused(tmp_path, capsys, monkeypatch):
    (tmp_path / "inv").mkdir()
    shutil.copy(PROBLEMS / "inverse_subject01.toml", tmp_path / "inv" / "inverse.toml")
    problem = (PROBLEMS / "knee_fit.toml").read_text().replace(
        'source = "bundled:subject01"', 'inverse_problem = "inv/inverse.toml"')
    (tmp_path / "fit.toml").write_text(problem)
    monkeypatch.chdir(tmp_path)
    started = time.perf_counter()
    status = main(["solve", "fit.toml", "--out", "inv", "--force"])
    _one_error(capsys, status, "inverse.toml")
    assert time.perf_counter() - started < 5.0  # refused before the solve
    assert (tmp_path / "inv" / "inverse.toml").is_file()
