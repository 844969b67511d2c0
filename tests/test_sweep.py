"""Sweeps: grid and random points, local processes and a local Dask cluster, failures kept."""

import math

import pytest
from dask import distributed

from predgait.errors import InputError
from predgait.scenarios.sweep import (
    PointStatus,
    SweepPoint,
    grid_points,
    outcomes_table,
    random_points,
    run_sweep,
)


def pendulum_period(point: SweepPoint) -> dict:
    """Small-angle period of a pendulum of length L; fails on a non-positive length."""
    length = point.values["length"]
    if length <= 0:
        raise InputError(f"length {length} m must be positive")
    return {"period": 2 * math.pi * math.sqrt(length / point.values["g"])}


def test_grid_and_random_points():
    points = grid_points({"length": [0.5, 1.0, 2.0], "g": [9.81, 1.62]})
    assert len(points) == 6 and points[1].values == {"length": 0.5, "g": 1.62}
    assert points[1].overrides == ("length=0.5", "g=1.62")
    sample = random_points({"length": (0.1, 1.0)}, 5, seed=3)
    assert sample == random_points({"length": (0.1, 1.0)}, 5, seed=3)
    assert all(0.1 <= p.values["length"] <= 1.0 for p in sample)


@pytest.mark.parametrize("workers", [1, 2])
def test_local_sweep_keeps_order_and_failures(workers):
    points = grid_points({"length": [1.0, -1.0, 0.25], "g": [9.81]})
    outcomes = run_sweep(pendulum_period, points, workers=workers, progress=False)
    assert [o.point.index for o in outcomes] == [0, 1, 2]
    assert outcomes[0].ok and outcomes[0].metrics["period"] == pytest.approx(2.00607, abs=1e-4)
    assert not outcomes[1].ok and "must be positive" in outcomes[1].reason
    assert outcomes[2].metrics["period"] == pytest.approx(outcomes[0].metrics["period"] / 2)
    header, rows = outcomes_table(outcomes)
    assert header[:3] == ["index", "length", "g"] and rows[1][3] == "failed"


def test_dask_local_cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        points = grid_points({"length": [1.0, 4.0, 0.0], "g": [9.81]})
        outcomes = run_sweep(pendulum_period, points, scheduler=client, progress=False)
    assert outcomes[1].metrics["period"] == pytest.approx(2 * outcomes[0].metrics["period"])
    assert not outcomes[2].ok


def test_unreachable_scheduler():
    with pytest.raises(InputError, match="cannot reach the Dask scheduler"):
        run_sweep(pendulum_period, grid_points({"length": [1.0], "g": [9.81]}),
                  scheduler="tcp://127.0.0.1:9", progress=False, connect_timeout=1)


def crash_once_at_index_1(point: SweepPoint, marker) -> dict:
    """Kills its worker process (as SIGKILL or the OOM killer would) the first time point 1
    runs; point 3 kills it every time."""
    import os
    import signal

    if point.index == 3 or (point.index == 1 and not marker.exists()):
        marker.touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return pendulum_period(point)


def test_killed_local_worker_is_recorded_and_the_sweep_completes(tmp_path):
    import functools

    points = grid_points({"length": [1.0, 2.0, 0.5, 4.0, 0.25], "g": [9.81]})
    task = functools.partial(crash_once_at_index_1, marker=tmp_path / "crashed")
    outcomes = run_sweep(task, points, workers=2, progress=False)
    assert [o.point.index for o in outcomes] == [0, 1, 2, 3, 4]
    assert [o.ok for o in outcomes] == [True, True, True, False, True]
    assert "worker process died" in outcomes[3].reason
    assert outcomes[1].metrics["period"] == pytest.approx(2.00607 * math.sqrt(2), abs=1e-4)


def diverges_for_long_pendulums(point: SweepPoint) -> dict:
    from predgait.errors import SimulationDiverged

    if point.values["length"] > 2:
        raise SimulationDiverged("diverged at t = 0.120 s (edited leg)")
    return pendulum_period(point)


def test_diverged_point_has_status_and_no_metrics():
    points = grid_points({"length": [1.0, 3.0], "g": [9.81]})
    outcomes = run_sweep(diverges_for_long_pendulums, points, workers=1, progress=False)
    assert outcomes[1].status is PointStatus.DIVERGED and not outcomes[1].metrics
    header, rows = outcomes_table(outcomes)
    assert rows[1][header.index("status")] == "diverged"
    assert math.isnan(rows[1][header.index("period")])


def test_scheduler_that_is_not_an_address():
    with pytest.raises(InputError, match="not a Dask scheduler address"):
        run_sweep(pendulum_period, grid_points({"length": [1.0], "g": [9.81]}),
                  scheduler="not an address", progress=False, connect_timeout=1)


def fake_scenario_metrics(path, point) -> dict:
    """Stands in for a scenario run: diverges for the stiffest knee."""
    from pathlib import Path

    from predgait.errors import SimulationDiverged

    assert Path(path).is_absolute()  # a worker started in any folder finds the scenario
    if point.values["edit.0.k"] >= 200:
        raise SimulationDiverged("diverged at t = 0.010 s (edited leg)")
    return {"knee_rms_change_deg": point.values["edit.0.k"] / 100}


@pytest.mark.parametrize("allow", [False, True])
def test_sweep_command_reports_failed_points(allow, tmp_path, monkeypatch, capsys):
    import csv
    import json
    from pathlib import Path

    from predgait.cli import main

    monkeypatch.setattr("predgait.scenarios.run.scenario_metrics", fake_scenario_metrics)
    problem = Path(__file__).resolve().parents[1] / "problems" / "sweep_knee_stiffness.toml"
    monkeypatch.chdir(tmp_path)
    status = main(["sweep", str(problem), "--workers", "1", "--out", "res",
                   *(["--allow-failures"] if allow else [])])
    err = capsys.readouterr().err
    assert status == (0 if allow else 1), err
    summary = json.loads((tmp_path / "res" / "summary.json").read_text())
    assert summary["status"].startswith("completed with failures: 3 of 12 points (3 diverged)")
    rows = list(csv.DictReader((tmp_path / "res" / "results.csv").open()))
    assert [r["status"] for r in rows].count("diverged") == 3
    assert all(r["knee_rms_change_deg"] == "nan" for r in rows if r["status"] == "diverged")


def slow_scenario_metrics(path, point) -> dict:
    """Stands in for a scenario run of a few seconds."""
    import time

    time.sleep(3.0)
    return {"knee_rms_change_deg": 1.0}


def test_sigterm_stops_a_local_sweep_at_once(tmp_path, monkeypatch, capsys):
    import os
    import signal
    import threading
    import time
    from pathlib import Path

    from predgait.cli import main

    monkeypatch.setattr("predgait.scenarios.run.scenario_metrics", slow_scenario_metrics)
    problem = Path(__file__).resolve().parents[1] / "problems" / "sweep_knee_stiffness.toml"
    monkeypatch.chdir(tmp_path)
    timer = threading.Timer(1.5, os.kill, (os.getpid(), signal.SIGTERM))
    started = time.perf_counter()
    timer.start()
    status = main(["sweep", str(problem), "--workers", "2", "--out", "res"])
    seconds = time.perf_counter() - started
    timer.join()
    assert status == 143, capsys.readouterr().err
    assert seconds < 3.0 + 2.0  # not 12 points x 3 s / 2 workers = 18 s
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------- plausibility of the points (issue 30)
def checked_scenario_metrics(path, point):
    """Stands in for a scenario run: its ground reaction is 3 BW for the stiffest knee."""
    from predgait.analysis.plausibility import grf_check
    from predgait.scenarios.sweep import PointResult

    peak = 3.0 if point.values["edit.0.k"] >= 200 else 1.2
    return PointResult({"knee_rms_change_deg": 1.0}, (grf_check(peak),))


def passing_scenario_metrics(path, point):
    from predgait.analysis.plausibility import grf_check
    from predgait.scenarios.sweep import PointResult

    return PointResult({"knee_rms_change_deg": 1.0}, (grf_check(1.2),))


@pytest.mark.parametrize(("task", "warned"), [(checked_scenario_metrics, 3),
                                              (passing_scenario_metrics, 0)])
def test_sweep_points_warnings_go_through_record(task, warned, tmp_path, monkeypatch, capsys):
    import csv
    import json
    from pathlib import Path

    from predgait.analysis.plausibility import grf_check
    from predgait.cli import main

    monkeypatch.setattr("predgait.scenarios.run.scenario_metrics", task)
    problem = Path(__file__).resolve().parents[1] / "problems" / "sweep_knee_stiffness.toml"
    assert main(["sweep", str(problem), "--workers", "1", "--out", str(tmp_path / "res"),
                 "--no-plots"]) == 0
    summary = json.loads((tmp_path / "res" / "summary.json").read_text())
    rows = list(csv.DictReader((tmp_path / "res" / "results.csv").open()))
    assert [float(r["plausibility_warnings"]) for r in rows] == [
        int(warned > 0 and float(r["edit.0.k"]) >= 200) for r in rows]
    assert len(summary["plausibility"]) == 12 and len(summary["warnings"]) == warned
    printed = capsys.readouterr().out
    if not warned:
        assert summary["status"] == "completed" and "  warning: " not in printed
        return
    assert summary["status"] == "completed with warnings"
    stiff = [r for r in rows if float(r["edit.0.k"]) >= 200]
    for row, line in zip(stiff, summary["warnings"], strict=True):
        assert line == (f"point {row['index']} (edit.0.k=200.0, edit.0.theta0_deg="
                        f"{float(row['edit.0.theta0_deg'])!r}): {grf_check(3.0).line()}")
        assert f"  warning: {line}" in printed


def test_labelled_checks_read_back_by_point():
    import json

    from predgait.analysis.plausibility import grf_check, record
    from predgait.report.tidy import json_ready
    from predgait.scenarios.sweep import SweepOutcome, checks_by_point, labelled_checks

    outcomes = [SweepOutcome(SweepPoint(0, {"k": 1.0}), True, checks=(grf_check(3.0),)),
                SweepOutcome(SweepPoint(4, {"k": 2.0}), True,
                             checks=(grf_check(1.0), grf_check(2.5, "peak (x): y")))]
    summary = json.loads(json.dumps(json_ready(record({}, labelled_checks(outcomes)))))
    assert checks_by_point(summary["plausibility"]) == {0: outcomes[0].checks,
                                                        4: outcomes[1].checks}
    assert summary["warnings"][1].startswith("point 4 (k=2.0): peak (x): y = 2.5 BW")


def test_a_stiff_knee_sweep_point_warns_as_the_scenario_command_does(tmp_path, capsys):
    """The real scenario task: each point records the checks 'predgait scenario' records
    for the same settings (the stiff knee's feedback exceeds the measured moments)."""
    import csv
    import json
    from pathlib import Path

    from predgait.cli import main

    problems = Path(__file__).resolve().parents[1] / "problems"
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'scenario = "{problems / "scenario_stiff_knee.toml"}"\n\n[grid]\n'
                     '"edit.0.k" = [1.0, 100.0]\n')
    assert main(["sweep", str(sweep), "--workers", "1", "--out", str(tmp_path / "sw"),
                 "--no-plots"]) == 0
    assert main(["scenario", str(problems / "scenario_stiff_knee.toml"), "--set",
                 "edit.0.k=100.0", "--out", str(tmp_path / "sc"), "--no-plots"]) == 0
    capsys.readouterr()
    summary = json.loads((tmp_path / "sw" / "summary.json").read_text())
    single = json.loads((tmp_path / "sc" / "summary.json").read_text())
    assert summary["status"] == single["status"] == "completed with warnings"
    ours = [w.removeprefix("point 1 (edit.0.k=100.0): ") for w in summary["warnings"]
            if w.startswith("point 1 ")]
    assert ours == single["warnings"] and any("ankle feedback torque" in w for w in ours)
    rows = list(csv.DictReader((tmp_path / "sw" / "results.csv").open()))
    assert float(rows[1]["plausibility_warnings"]) == len(ours)
