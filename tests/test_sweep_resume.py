"""A sweep whose Dask scheduler is killed mid-way: one error line, the finished points
written (results.csv marks the rest 'not run'), and --resume finishes only the rest
(issue 29, item 8). A real scheduler and worker run as processes; the task of point 2
kills the scheduler (SIGKILL) after points 0 and 1 have come back."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from predgait.cli import main

REPO = Path(__file__).resolve().parents[1]
SWEEP = REPO / "problems" / "sweep_knee_stiffness.toml"   # a 4 x 3 grid
KILLER = "PREDGAIT_TEST_KILL_PID"


def fake_metrics(scenario, point):
    """Known metrics of a point (its index); point 2 kills the scheduler when asked to.

    Point 1's ground reaction is 3 BW (a plausibility warning), the others' 1.2 BW.
    """
    from predgait.analysis.plausibility import grf_check
    from predgait.scenarios.sweep import PointResult

    if point.index == 2 and os.environ.get(KILLER):
        time.sleep(1.5)  # points 0 and 1 reach the client first
        os.kill(int(os.environ[KILLER]), signal.SIGKILL)
        time.sleep(30)
    return PointResult({"knee_rms_change_deg": float(point.index),
                        "knee_extra_feedback_rms_n_m": 1.0,
                        "knee_peak_angle_deg": point.values["edit.0.k"]},
                       (grf_check(3.0 if point.index == 1 else 1.2),))


def _rows(out: Path) -> list[dict]:
    with (out / "results.csv").open() as handle:
        return list(csv.DictReader(handle))


@pytest.fixture
def cluster(tmp_path):
    """A Dask scheduler and one single-threaded worker, as processes."""
    pytest.importorskip("distributed")
    address_file = tmp_path / "scheduler.json"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parent),
                                                        os.environ.get("PYTHONPATH", "")])}
    scheduler = subprocess.Popen(   # it unpickles the task graph: it needs this module too
        [sys.executable, "-m", "distributed.cli.dask_scheduler", "--scheduler-file",
         str(address_file), "--port", "0", "--no-dashboard"], env=env,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    env[KILLER] = str(scheduler.pid)
    worker = None
    try:
        deadline = time.time() + 60
        while not address_file.is_file() and time.time() < deadline:
            time.sleep(0.2)
        time.sleep(0.3)
        address = json.loads(address_file.read_text())["address"]
        worker = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
             "--nworkers", "1", "--no-dashboard"], env=env,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        yield address
    finally:
        for process in (worker, scheduler):
            if process is not None:
                process.kill()
                process.wait()


def test_lost_scheduler_writes_the_finished_points_and_resume_finishes(
        cluster, tmp_path, monkeypatch, capfd):
    import predgait.scenarios.run as scenario_run
    import test_sweep_resume

    monkeypatch.setattr(scenario_run, "scenario_metrics", test_sweep_resume.fake_metrics)
    out = tmp_path / "sweep"
    status = main(["sweep", str(SWEEP), "--out", str(out), "--scheduler", cluster,
                   "--no-plots"])
    err = capfd.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("predgait: ")]
    assert status == 2 and "Traceback" not in err, err[-3000:]
    assert len(lines) == 1 and lines[0].startswith("predgait: error: "), err[-3000:]
    assert "Dask scheduler" in lines[0] and "--resume" in lines[0]
    rows = _rows(out)
    done = [r for r in rows if r["status"] == "ok"]
    assert len(rows) == 12 and [r["index"] for r in done][:2] == ["0", "1"]
    assert all(r["status"] in ("ok", "not run") for r in rows) and len(done) < 12
    for row in done:
        assert float(row["knee_rms_change_deg"]) == float(row["index"])
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"].startswith("incomplete") and summary["not_run"] == 12 - len(done)
    [warning] = summary["warnings"]   # point 1's, recorded with the finished points
    assert warning.startswith("point 1 (edit.0.k=0.0, edit.0.theta0_deg=10.0): peak vertical")

    ran = []
    monkeypatch.setattr(scenario_run, "scenario_metrics",
                        lambda s, p: ran.append(p.index) or fake_metrics(s, p))
    monkeypatch.delenv(KILLER, raising=False)
    assert main(["sweep", str(SWEEP), "--out", str(out), "--resume", "--workers", "1",
                 "--no-plots"]) == 0
    assert sorted(ran) == [int(r["index"]) for r in rows if r["status"] == "not run"]
    final = _rows(out)
    assert [r["status"] for r in final] == ["ok"] * 12
    assert [float(r["knee_rms_change_deg"]) for r in final] == [float(i) for i in range(12)]
    for before, after in zip(rows, final, strict=True):  # finished rows kept as they were
        if before["status"] == "ok":
            assert before == after
    final_summary = json.loads((out / "summary.json").read_text())
    assert final_summary["status"] == "completed with warnings"   # point 1's, kept
    assert final_summary["warnings"] == [warning] and len(final_summary["plausibility"]) == 12
    assert [float(r["plausibility_warnings"]) for r in final] == [0, 1] + [0] * 10
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scheduler.json", "sweep"]


def test_resume_of_another_sweep_is_refused(tmp_path, capsys, monkeypatch):
    import predgait.scenarios.run as scenario_run

    monkeypatch.setattr(scenario_run, "scenario_metrics", fake_metrics)
    out = tmp_path / "sweep"
    out.mkdir()
    (out / "results.csv").write_text("index,edit.0.k,status,seconds,reason\n0,7.0,ok,1.0,\n")
    status = main(["sweep", str(SWEEP), "--out", str(out), "--resume", "--workers", "1"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and "line 2 is not a point of this sweep" in err[0]
