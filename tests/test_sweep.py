"""Sweeps: grid and random points, local processes and a local Dask cluster, failures kept."""

import math

import pytest
from dask import distributed

from predgait.errors import InputError
from predgait.scenarios.sweep import (
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
