"""Objective terms of the muscle-driven gait NLP beside Moco's effort (issue 26 item 5).

* ``metabolic``: the W integral the NLP carries (CasADi node output, trapezoidal) equals the
  muscles' Bhargava rates of :mod:`predgait.dynamics.metabolics` (NumPy) integrated along the
  same trajectory, per distance and body mass;
* ``acceleration``: the trapezoidal integral of the joint accelerations squared, by hand;
* a problem built without the metabolic rate refuses a metabolic goal.
"""

from pathlib import Path

import numpy as np
import pytest

from predgait.data.storage import read_storage
from predgait.errors import InputError
from predgait.models.osim import bundled_2d_gait
from predgait.problems.muscle_gait import GOAL_SIZE, Goal, MuscleGaitProblem
from predgait.problems.muscle_gait_setup import (
    MOCO_BOUNDS,
    bounds_for,
    plant_2d_gait,
    reference_guess,
)
from predgait.problems.muscle_prediction import bundled_file

INTERVALS = 8


@pytest.fixture(scope="module")
def built():
    plant, planar = plant_2d_gait(bundled_2d_gait())
    problem = MuscleGaitProblem(plant, INTERVALS, tx_row=0, metabolic=True)
    guess, _ = reference_guess(planar, read_storage(bundled_file("referenceCoordinates.sto")),
                               plant, INTERVALS)
    rng = np.random.default_rng(0)
    exc = rng.uniform(0.02, 0.6, guess.exc.shape)
    act = rng.uniform(0.02, 0.6, guess.act.shape)
    from dataclasses import replace

    return plant, planar, problem, replace(guess, exc=exc, act=act)


def _terms(problem, path):
    nq = problem.plant.model.nq
    goal = np.zeros(GOAL_SIZE)
    goal[:3] = 1.2, 0, 10
    p = np.concatenate([goal, np.zeros((INTERVALS + 1) * nq)])
    out = problem.outputs(problem.pack(path), p)
    return dict(zip(problem.term_names, (float(x) for x in out[6:]), strict=True))


def test_metabolic_term_is_the_bhargava_energy_per_distance_and_mass(built):
    from predgait.dynamics.metabolics import stride_rates

    plant, planar, problem, path = built
    rates = stride_rates(plant.muscle_set, plant.paths, path.q, path.v, path.exc, path.act,
                         body_mass=plant.model.total_mass())
    muscles = rates.muscle.sum(axis=0)                      # W, no basal rate
    energy = np.trapezoid(muscles, path.t)
    distance = path.q[-1, 0] - path.q[0, 0]
    expected = energy / distance / plant.model.total_mass()
    assert expected > 0.1
    assert _terms(problem, path)["metabolic"] == pytest.approx(expected, rel=1e-9)


def test_acceleration_term_by_hand(built):
    _, _, problem, path = built
    joints = path.a[:, 3:]
    square = (joints ** 2).sum(axis=1)
    expected = np.trapezoid(square, path.t) / joints.shape[1]
    assert _terms(problem, path)["acceleration"] == pytest.approx(expected, rel=1e-9)


def test_loading_rate_term_by_hand(built):
    """Each foot's vertical GRF (sum of its spheres, BW), its rate squared over each
    interval, times the interval: sum_k (F_k+1 - F_k)^2 / h, both feet."""
    plant, _, problem, path = built
    nq = plant.model.nq
    goal = np.zeros(GOAL_SIZE)
    goal[:3] = 1.2, 0, 10
    grf = np.array(problem.outputs(problem.pack(path),
                                   np.concatenate([goal, np.zeros((INTERVALS + 1) * nq)]))[1])
    weight = plant.model.total_mass() * plant.model.gravity
    h = path.duration / INTERVALS
    expected = 0.0
    for side in ("_r", "_l"):
        rows = [3 * i + 2 for i, s in enumerate(plant.spheres) if s.link.endswith(side)]
        assert len(rows) == 2
        vertical = grf[rows].sum(axis=0) / weight
        expected += (np.diff(vertical) ** 2).sum() / h
    assert expected > 1.0
    assert _terms(problem, path)["loading_rate"] == pytest.approx(expected, rel=1e-9)


def test_metabolic_goal_needs_the_metabolic_rate(built):
    plant, planar, _, path = built
    problem = MuscleGaitProblem(plant, 4, tx_row=0)
    assert "metabolic" not in problem.term_names     # never reported as 0 when not computed
    bounds = bounds_for(plant, planar, MOCO_BOUNDS, (0.4, 0.6))
    with pytest.raises(InputError, match="metabolic"):
        problem.solve(path, bounds, Goal(metabolic_weight=1.0))


HUMAN = Path(__file__).resolve().parents[1] / "problems" / "predict_2d_muscles_human.toml"


def _spec(*overrides):
    from predgait.problemfile import load_problem
    from predgait.problems.muscle_prediction import parse_muscle_predict

    return parse_muscle_predict(load_problem(HUMAN, overrides))


def test_metabolic_stage_solves_the_goal_without_its_metabolic_term_first():
    from dataclasses import replace

    from predgait.problems.muscle_prediction import stages_before

    spec = _spec()
    assert spec.metabolic_stage and spec.goal.metabolic_weight == 0.5
    (what, goal, _), = stages_before(spec)
    assert what == "without the metabolic term"
    assert goal == replace(spec.goal, metabolic_weight=0.0)       # every other term kept
    # After a tracking stage; none without a metabolic term or when not asked for.
    both = stages_before(_spec("guess.tracking_stage=true"))
    assert [w for w, _, _ in both] == ["tracking the reference", "without the metabolic term"]
    assert both[0][1].tracking_weight > 0 and both[1][1].tracking_weight == 0
    assert stages_before(_spec("goal.metabolic_weight=0")) == []
    assert stages_before(_spec("guess.metabolic_stage=false")) == []


def test_metabolic_stage_must_be_true_or_false():
    with pytest.raises(InputError, match="metabolic_stage"):
        _spec("guess.metabolic_stage=3")


def test_console_lists_only_the_weighted_terms_of_the_objective():
    """Terms whose weight is 0 (and speed when it is the endpoint constraint) are not in
    the objective: the console line shows weight x value of the others only."""
    from predgait.workflows.predict_muscles import weighted_terms

    goal = {"speed_constraint": True, "speed_weight": 5.0, "effort_weight": 10.0,
            "tracking_weight": 0.0, "acceleration_weight": 0.0, "metabolic_weight": 0.5,
            "loading_rate_weight": 0.003}
    terms = {"speed": 0.0, "effort": 0.0125, "tracking": 3.0, "acceleration": 1295.0,
             "loading_rate": 2.0, "metabolic": 3.1}
    summary = {"goal": goal, "objective_terms": terms}
    assert weighted_terms(summary) == [("effort", 10.0, 0.0125), ("loading_rate", 0.003, 2.0),
                                       ("metabolic", 0.5, 3.1)]
    goal["speed_constraint"] = False
    assert weighted_terms(summary)[0] == ("speed", 5.0, 0.0)
