"""Compliant tendons in the muscle-driven gait NLP (``[model] compliant_tendons``).

* the node function's tendon outputs are :meth:`MuscleSet.compliant_tendon` (De Groote et al.
  2016's implicit form, checked against OpenSim in test_muscles) of the chosen muscles, and
  the rigid-tendon force of the others, at sampled states;
* with a near-inextensible tendon the equilibrium tendon force is the rigid-tendon force;
* the problem file's choice is parsed and checked (unknown muscle, one side only);
* a small-grid solve carries the tendon states, holds the equilibrium at every node and
  writes the states into solution.sto.
"""

from dataclasses import replace

import casadi as cs
import numpy as np
import pytest
from scipy.optimize import brentq

from predgait.data.storage import read_storage
from predgait.errors import InputError
from predgait.models.osim import bundled_2d_gait
from predgait.problemfile import load_problem
from predgait.problems.muscle_gait import Goal, MuscleGaitProblem
from predgait.problems.muscle_gait_dynamics import node_function
from predgait.problems.muscle_gait_setup import (
    PHYSIOLOGICAL_BOUNDS,
    bounds_for,
    compliant_rows,
    plant_2d_gait,
    reference_guess,
)
from predgait.problems.muscle_prediction import bundled_file, parse_muscle_predict

CHOSEN = ("soleus", "gastroc", "vasti")


@pytest.fixture(scope="module")
def plants():
    plant, planar = plant_2d_gait(bundled_2d_gait())
    compliant = replace(plant, compliant=compliant_rows(plant.muscle_names, CHOSEN))
    return plant, compliant, planar


def _lengths_and_speeds(plant):
    q, v = cs.SX.sym("q", plant.model.nq), cs.SX.sym("v", plant.model.nq)
    length = plant.paths.lengths(q)
    return cs.Function("ls", [q, v], [length, cs.jacobian(length, q) @ v])


def test_rows_of_the_chosen_muscles(plants):
    plant, compliant, _ = plants
    names = [plant.muscle_names[i] for i in compliant.compliant]
    assert sorted(names) == sorted(f"{m}_{s}" for m in CHOSEN for s in "rl")
    assert compliant_rows(plant.muscle_names, "all") == tuple(range(18))
    with pytest.raises(InputError, match="soleus_r but not the other side"):
        compliant_rows(plant.muscle_names, ["soleus_r"])
    with pytest.raises(InputError, match="no muscle named 'achilles'"):
        compliant_rows(plant.muscle_names, ["achilles"])


def test_node_tendon_outputs_are_the_muscle_model(plants):
    plant, compliant, planar = plants
    node = node_function(compliant)
    assert node.n_in() == 8 and node_function(plant).n_in() == 6
    guess, _ = reference_guess(
        planar, read_storage(bundled_file("referenceCoordinates.sto")), plant, 10
    )
    rows, rigid = list(compliant.compliant), list(compliant.rigid)
    ls = _lengths_and_speeds(plant)
    rng = np.random.default_rng(3)
    fmax = np.array([m.max_isometric_force for m in plant.muscle_set.muscles])
    for k in (0, 4, 8):
        q, v, a = guess.q[k], guess.v[k], guess.a[k]
        act = rng.uniform(0.02, 0.9, plant.n_muscles)
        ft = rng.uniform(0.05, 1.5, len(rows))
        dft = rng.uniform(-8.0, 8.0, len(rows))
        out = node(q, v, a, act, act, 0.0, ft, dft)
        length, speed = (np.array(x).ravel() for x in ls(q, v))
        sub = compliant.subset(rows)
        want = sub.compliant_tendon(length[rows], speed[rows], act[rows], ft, dft)
        np.testing.assert_allclose(np.array(out[8]).ravel(), want.residual, atol=1e-10)
        force = np.array(out[4]).ravel()
        np.testing.assert_allclose(force[rows], fmax[rows] * ft, rtol=1e-12)
        np.testing.assert_allclose(
            np.array(out[5]).ravel()[rows], want.norm_fiber_velocity, atol=1e-10
        )
        rigid_force = np.array(node_function(plant)(q, v, a, act, act, 0.0)[4]).ravel()
        np.testing.assert_allclose(force[rigid], rigid_force[rigid], rtol=1e-12)
        # the skeleton receives those forces: the residual changes by the muscles' torques
        base = node_function(plant)(q, v, a, act, act, 0.0)
        change = np.array(out[0] - base[0]).ravel()
        torque = np.array(out[6] - base[6]).ravel()
        np.testing.assert_allclose(change, -torque, atol=1e-8)
        assert np.abs(change).max() > 1.0  # the forces differ, and reach the skeleton


def test_stiff_tendon_equilibrium_is_the_rigid_force(plants):
    """Static (v = 0, d f_T/dt = 0): the f_T solving the equilibrium residual is the rigid
    tendon's force / F_max when the tendon barely stretches (strain 0.05 % at F_max)."""
    plant, _, planar = plants
    stiff = plant.muscle_set.edited(plant.muscle_names, tendon_strain_at_one_norm_force=5e-4)
    guess, _ = reference_guess(
        planar, read_storage(bundled_file("referenceCoordinates.sto")), plant, 10
    )
    length, _ = (
        np.array(x).ravel() for x in _lengths_and_speeds(plant)(guess.q[3], 0 * guess.q[3])
    )
    act = np.full(plant.n_muscles, 0.4)
    rigid = stiff.rigid_tendon(length, 0 * length, act).tendon_force
    fmax = np.array([m.max_isometric_force for m in stiff.muscles])
    for i in range(plant.n_muscles):
        one = replace(stiff, muscles=(stiff.muscles[i],))

        def residual(f, i=i, one=one):
            return float(
                one.compliant_tendon(
                    length[i : i + 1], np.zeros(1), act[i : i + 1], np.array([f]), np.zeros(1)
                ).residual[0]
            )

        f = brentq(residual, 1e-6, 4.0)
        assert f * fmax[i] == pytest.approx(rigid[i], rel=0.02, abs=2.0)


def test_problem_file_option(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('kind = "predict_muscles_2d"\n[model]\ncompliant_tendons = ["soleus"]\n')
    assert parse_muscle_predict(load_problem(path)).compliant_tendons == ("soleus",)
    path.write_text('kind = "predict_muscles_2d"\n[model]\ncompliant_tendons = ["tendo"]\n')
    with pytest.raises(InputError, match="compliant_tendons.*line 3.*no muscle named 'tendo'"):
        parse_muscle_predict(load_problem(path))
    path.write_text('kind = "predict_muscles_2d"\n[model]\ncompliant_tendons = "some"\n')
    with pytest.raises(InputError, match="compliant_tendons"):
        parse_muscle_predict(load_problem(path))


def test_small_grid_solve_holds_the_tendon_equilibrium(plants, tmp_path):
    from predgait.problems.muscle_gait_check import node_check
    from predgait.problems.muscle_gait_stride import from_right_heel_strike, full_stride
    from predgait.workflows.muscle_gait_files import write_gait_files

    _, plant, planar = plants
    n = 16  # measured: 169 Ipopt iterations, ~11 s (8 intervals did not converge)
    problem = MuscleGaitProblem(plant, n, tx_row=0, max_iter=1000)
    guess, _ = reference_guess(
        planar, read_storage(bundled_file("referenceCoordinates.sto")), plant, n
    )
    bounds = bounds_for(plant, planar, PHYSIOLOGICAL_BOUNDS, (0.4, 0.6))
    gait = problem.solve(guess, bounds, Goal(loading_rate_weight=3e-3))
    assert gait.solved.success, gait.solved.status
    ft = gait.path.ft
    assert ft.shape == (n + 1, 6) and ft.min() >= -1e-8
    assert np.abs(gait.tendon_residual).max() < 1e-4
    # the tendon forces act on the skeleton: F_max f_T is the muscle force of those rows
    fmax = np.array([plant.muscle_set.muscles[i].max_isometric_force for i in plant.compliant])
    np.testing.assert_allclose(gait.force[:, list(plant.compliant)], ft * fmax, rtol=1e-9)
    # periodic with left/right symmetry: the last f_T is the other side's first one
    names = [plant.muscle_names[i] for i in plant.compliant]
    other = [names.index(nm[:-1] + ("l" if nm.endswith("r") else "r")) for nm in names]
    np.testing.assert_allclose(ft[-1], ft[0, other], atol=1e-5)
    check = node_check(plant, gait)
    assert check["max_residual"] < 1.0
    whole = full_stride(plant, gait, check["contact_point_speed"])
    stride = from_right_heel_strike(whole, plant)
    # rolled and moved to x = 0 together: each contact keeps its place beside the pelvis
    ahead = whole.points[:, :, 0] - whole.q[:, [0]]
    rolled = stride.points[:, :, 0] - stride.q[:, [0]]
    assert stride.q[0, 0] == 0.0
    assert np.isclose(ahead, rolled[0], atol=1e-12).all(axis=1).any()
    write_gait_files(tmp_path, planar, plant, gait, stride, status="test")
    solution = read_storage(tmp_path / "solution.sto")
    np.testing.assert_allclose(
        solution.columns["/soleus_r/normalized_tendon_force"],
        ft[:, names.index("soleus_r")],
        atol=1e-6,
    )


def test_speed_row_is_the_average_speed_constraint(plants):
    """``speed_constraint = false`` frees the row distance - speed * duration (no other)."""
    _, plant, planar = plants
    n = 4
    problem = MuscleGaitProblem(plant, n, tx_row=0)
    guess, _ = reference_guess(
        planar, read_storage(bundled_file("referenceCoordinates.sto")), plant, n
    )
    w = problem.pack(guess)
    p = np.zeros(problem.p.numel())
    p[0] = 1.3
    g = np.array(cs.Function("g", [problem.w, problem.p], [problem.nlp["g"]])(w, p)).ravel()
    distance = guess.q[-1, 0] - guess.q[0, 0]
    assert g[problem.speed_row] == pytest.approx(distance - 1.3 * guess.duration, abs=1e-12)
