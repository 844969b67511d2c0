"""A muscle scenario's baseline stored on disk and evaluated again, not solved again.

:mod:`predgait.problems.muscle_baseline_store` on a 12-interval impact baseline with its
cache folder in a temporary directory: the second run must not build Ipopt's solver or
solve (both are replaced by functions that fail), and must give the first run's gait bit
for bit (decision vector, forces, stride, Pinocchio check); a changed problem and a damaged
file solve again; the cache switch turns it off.
"""

import dataclasses
import logging

import numpy as np
import pytest

from predgait.problemfile import load_problem
from predgait.problems import muscle_baseline_store as store
from predgait.problems import muscle_prediction as mp
from predgait.problems.muscle_gait import MuscleGaitProblem

OVERRIDES = ("grid.nodes=12", "check.human_likeness=false")


@pytest.fixture
def cache_on(tmp_path, monkeypatch):
    monkeypatch.setenv("PREDGAIT_SOLVER_CACHE", "on")
    monkeypatch.setenv("PREDGAIT_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.fixture
def spec():
    return mp.parse_muscle_predict(
        load_problem("problems/predict_2d_muscles_impact.toml", OVERRIDES))


def no_solver(*_args, **_kwargs):
    raise AssertionError("the stored baseline was solved again")


def test_a_stored_baseline_is_evaluated_not_solved_and_gives_the_same_gait(
        cache_on, spec, monkeypatch):
    first = mp.solve_prediction(spec, reuse=True)
    assert first.gait.solved.success and first.reused_from is None
    assert len(list(cache_on.glob("muscle-baseline-*.npz"))) == 1

    monkeypatch.setattr(MuscleGaitProblem, "solve", no_solver)
    monkeypatch.setattr(MuscleGaitProblem, "build_solver", no_solver)
    second = mp.solve_prediction(spec, reuse=True)
    assert second.reused_from is not None and second.reused_from.endswith(".npz")
    a, b = first.gait, second.gait
    np.testing.assert_array_equal(a.solved.w, b.solved.w)
    assert (a.solved.objective, a.solved.iterations, a.solved.status) == (
        b.solved.objective, b.solved.iterations, b.solved.status)
    np.testing.assert_array_equal(a.solved.multipliers[1], b.solved.multipliers[1])
    for name in ("grf", "force", "residual"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.terms == b.terms
    np.testing.assert_array_equal(first.stride.q, second.stride.q)
    np.testing.assert_array_equal(first.check["residual"], second.check["residual"])
    summary = mp.prediction_summary(spec, second)
    assert summary["ipopt"]["iterations"] == a.solved.iterations
    assert summary["reused_from"] == second.reused_from
    assert mp.prediction_summary(spec, first)["reused_from"] is None


def test_another_problem_does_not_reuse_it(spec, tmp_path):
    files = [mp.bundled_file("2D_gait.osim"), mp.bundled_file("referenceCoordinates.sto")]
    key = store.baseline_key(spec, files)
    faster = dataclasses.replace(spec, goal=dataclasses.replace(spec.goal, speed=1.3))
    assert store.baseline_key(faster, files) != key
    copy = tmp_path / "reference.sto"
    copy.write_bytes(files[1].read_bytes() + b"\n")
    assert store.baseline_key(spec, [files[0], copy]) != key
    assert store.baseline_key(spec, files) == key


def test_a_damaged_file_is_reported_and_solved_again(cache_on, caplog):
    cache_on.mkdir(parents=True)
    (cache_on / "muscle-baseline-abc.npz").write_bytes(b"not an npz file")
    with caplog.at_level(logging.WARNING):
        assert store.load("abc") is None
    assert "cannot be read" in caplog.text and "solving it again" in caplog.text


def test_the_cache_switch_turns_it_off(tmp_path, monkeypatch):
    monkeypatch.setenv("PREDGAIT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("PREDGAIT_SOLVER_CACHE", "off")
    assert not store.enabled()
    monkeypatch.setenv("PREDGAIT_SOLVER_CACHE", "on")
    assert store.enabled()
