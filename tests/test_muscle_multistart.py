"""One answer, not one of many (issue 26 item 6): heel-strike alignment, grids, multi-start.

* The heel strike is found between nodes (a known answer on a piecewise-linear force);
  Moco's own solution (tests/reference/osim2d/moco_prediction, OpenSim 4.6) read from it
  has its right heel strike where its force table says, and our model's dynamics at
  Moco's trajectory nearly vanish (Moco's solution is a solution of our model too).
* Two small grids (16 and 20 intervals; the product grids 30/50/75 are in
  benchmarks/bench_predict_grids.py) agree from heel strike within a loose bound.
* A multi-start on 16 intervals through solve_prediction (the problem file's
  [multistart]): the best is the least objective of the converged, the spread is in
  the summary, the perturbed starts are seeded; the [multistart] table's bad input.

The comparison of our 50-interval solution with Moco's (issue: within 5 deg RMS,
objective equal or lower) is a 40-50 s process (build + solve) on the loaded 2-core
machine: it is in benchmarks/bench_predict_grids.py, not here (measured there: objective
6.09x Moco's, knee 35 deg RMS: the goal is not met). This file takes 75 s of CPU alone
(120 s with the multi-start's former seed 7, whose perturbed start needed 313 iterations).
"""

from pathlib import Path

import numpy as np
import pytest

from predgait.blas_threads import one_blas_thread
from predgait.data.bundled import bundled_path
from predgait.data.storage import read_storage
from predgait.errors import InputError
from predgait.models.osim import bundled_2d_gait
from predgait.problems.gait_agreement import (
    agreement_table,
    gait_curves,
    heel_strike_curves,
    heel_strike_time,
    moco_curves,
)
from predgait.problems.muscle_gait import Goal, MuscleGaitProblem
from predgait.problems.muscle_gait_setup import (
    MOCO_BOUNDS,
    bounds_for,
    plant_2d_gait,
    reference_guess,
)
from predgait.problems.muscle_multistart import (
    MultiStartOptions,
    perturbed,
)

MOCO = Path(__file__).resolve().parent / "reference" / "osim2d" / "moco_prediction"
SOLUTION = MOCO / "gaitPrediction_solution.sto"
GRF = MOCO / "gaitPrediction_solution_fullcycle_grf.sto"
#: Looser bound for 16 vs 20 intervals (the issue's 3 deg is for 30/50/75). Measured with
#: the default BLAS threads: 16 vs 20 hip 1.5, knee 2.7, ankle 2.3 deg; with one BLAS thread
#: (the solve's setting since 2026-12-07, so the iterates do not depend on the thread count)
#: hip 2.5, knee 2.3, 4.7 deg max (bound raised from 4 to 5 then); 12 vs 16 up to 6.3 deg.
SMALL_GRID_RMS_DEG = 5.0


@pytest.fixture(scope="module")
def setup():
    plant, planar = plant_2d_gait(bundled_2d_gait())
    storage = read_storage(bundled_path("moco_2d_walking/referenceCoordinates.sto"))
    bounds = bounds_for(plant, planar, MOCO_BOUNDS, (0.4, 0.6))
    return plant, planar, storage, bounds


def _solve(setup, n):
    plant, planar, storage, bounds = setup
    problem = MuscleGaitProblem(plant, n, tx_row=0, max_iter=3000)
    guess, _ = reference_guess(planar, storage, plant, problem.n)
    with one_blas_thread():      # as the product solves: the path must not follow the threads
        return problem, problem.solve(guess, bounds, Goal())


@pytest.fixture(scope="module")
def grid16(setup):
    return _solve(setup, 16)


def test_heel_strike_between_nodes_known_answer():
    t = np.linspace(0.0, 1.0, 33)                      # a stride of 1 s, 32 intervals
    fz = np.clip(1000.0 * (t - 0.3), 0.0, 500.0) * (t < 0.8)
    assert heel_strike_time(t, fz, 20.0) == pytest.approx(0.32, abs=1e-12)
    curves = heel_strike_curves(t, {"hip": np.sin(2 * np.pi * t)}, fz, 20.0)
    expected = np.sin(2 * np.pi * (0.32 + np.linspace(0.0, 1.0, 101)))
    np.testing.assert_allclose(curves["hip"], expected, atol=0.01)
    # the first node above the threshold (0.34375 s) would be 0.15 away somewhere
    node = np.sin(2 * np.pi * (0.34375 + np.linspace(0.0, 1.0, 101)))
    assert np.abs(node - expected).max() > 0.1
    with pytest.raises(InputError, match="never touches down"):
        heel_strike_time(t, np.full_like(t, 100.0))


def test_moco_reference_heel_strike_and_our_dynamics_on_it(setup):
    plant, planar, _, _ = setup
    curves = moco_curves(SOLUTION, GRF)
    half = read_storage(SOLUTION)
    assert float(half.header["objective"]) == pytest.approx(0.021924, rel=1e-4)
    forces = read_storage(GRF)
    fz = forces.column("ground_force_r_vy")
    t_hs = heel_strike_time(forces.time, fz)
    assert fz[np.searchsorted(forces.time, t_hs)] > 20.0 > fz[np.searchsorted(forces.time,
                                                                              t_hs) - 1]
    assert -1.0 < curves["knee"].min() and curves["knee"].max() < 50.0 + 1e-6  # Moco's bound
    # Moco's trajectory in our model: the skeletal residual (M a + h - tau) is small
    from predgait.problems.muscle_gait_dynamics import node_function

    path, _ = reference_guess(planar, half, plant, half.time.size - 1)
    node = node_function(plant)
    residual = np.array([np.array(node(path.q[k], path.v[k], path.a[k], path.act[k],
                                       path.exc[k], path.u[k])[0]).ravel()
                         for k in range(path.q.shape[0])])
    weight = plant.model.total_mass() * plant.model.gravity
    assert np.median(np.abs(residual)) < 0.02 * weight
    # and the effort, Moco's objective, by Simpson's rule on its Hermite-Simpson points
    controls = np.column_stack([half.columns[f"/{m}"] for m in plant.muscle_names]
                               + [half.columns["/lumbarAct"]])
    f = (np.abs(controls) ** 3).sum(axis=1)
    h = half.time[-1] - half.time[0]
    simpson = h / 6.0 / 50 * (f[0:-1:2] + 4 * f[1::2] + f[2::2]).sum()
    distance = path.q[-1, 0] - path.q[0, 0]
    assert 10.0 * simpson / distance == pytest.approx(0.021924, rel=2e-3)


def test_small_grids_agree_from_heel_strike(setup, grid16):
    """16 and 20 intervals agree once the 20-interval grid is also started from the
    16-interval solution (the multi-start's resampled-grid start): from its own guess it
    lands, depending on rounding alone, in another optimum (measured: 0.163, +24 %, with
    one BLAS thread; 0.136 with the default threads, before the derivatives were assembled
    node by node). The solves run on one BLAS thread, as the product's do: with the default
    threads one CI run took 171 s for this test, another under 15 s."""
    from predgait.problems.muscle_multistart import resample

    plant, planar, _, bounds = setup
    _, coarse = grid16
    problem, own = _solve(setup, 20)
    with one_blas_thread():
        from_coarse = problem.solve(resample(coarse.path, problem.n), bounds, Goal())
    fine = min((g for g in (own, from_coarse) if g.solved.success),
               key=lambda g: g.solved.objective)
    assert coarse.solved.success and fine.solved.success
    curves = {"16": gait_curves(plant, planar, coarse), "20": gait_curves(plant, planar, fine)}
    (row,) = agreement_table(curves)
    assert row["max"] < SMALL_GRID_RMS_DEG, row
    assert row["max"] > 0.0                                  # two different solutions
    objectives = coarse.solved.objective, fine.solved.objective
    assert abs(objectives[0] / objectives[1] - 1.0) < 0.1, objectives   # measured 3.2 %


def test_multistart_picks_the_least_objective_and_reports_the_spread():
    from predgait.workflows.predict_muscles import (
        MusclePredictSpec,
        prediction_summary,
        solve_prediction,
    )

    # Seed 4: its perturbed start converges in 92 Ipopt iterations to a lower objective
    # than the reference start's (0.12838 vs 0.13071, measured), so the least is not the
    # first run; seed 7's start took 313-610 iterations (~40 s) to 0.13094.
    options = MultiStartOptions(starts=2, seed=4, perturbation_deg=3.0)
    spec = MusclePredictSpec(nodes=16, human_checks=False, multistart=options)
    pred = solve_prediction(spec)                    # the problem file's [multistart] path
    sp = prediction_summary(spec, pred)["multistart"]
    assert sp is pred.multistart and sp["starts"] == 2 and len(sp["runs"]) == 2
    assert [r["start"] for r in sp["runs"]] == ["reference coordinates",
                                                "perturbed reference 1 (seed 4)"]
    ok = [r["objective"] for r in sp["runs"] if r["success"]]
    assert sp["converged"] == len(ok) >= 1
    assert pred.gait.solved.objective == min(ok) == sp["objective_min"]
    assert sp["objective_min"] <= sp["objective_median"] <= sp["objective_max"]
    best = next(r for r in sp["runs"] if r["start"] == sp["best"])
    assert best["kinematics_rms_deg_vs_best"] == {"hip": 0.0, "knee": 0.0, "ankle": 0.0}
    assert sp["seconds"] >= sum(r["solve_time_s"] for r in sp["runs"])


def test_perturbed_starts_are_seeded_and_smooth(setup):
    plant, planar, storage, _ = setup
    path, _ = reference_guess(planar, storage, plant, 16)
    rows = list(range(2, plant.model.nq))
    a = perturbed(path, np.random.default_rng(3), np.radians(5.0), rows)
    b = perturbed(path, np.random.default_rng(3), np.radians(5.0), rows)
    c = perturbed(path, np.random.default_rng(4), np.radians(5.0), rows)
    np.testing.assert_array_equal(a.q, b.q)
    assert np.abs(a.q - c.q).max() > 1e-3
    np.testing.assert_array_equal(a.q[:, :2], path.q[:, :2])   # pelvis x, z untouched
    # speeds are the time derivative of the perturbed angles (duration rescaled too)
    dq = np.gradient(a.q[:, 5], a.t)
    assert np.abs(dq - a.v[:, 5])[2:-2].max() < 0.1 * np.abs(a.v[:, 5]).max()


def _problem(tmp_path, text):
    from predgait.problemfile import load_problem
    from predgait.problems.muscle_prediction import parse_muscle_predict

    path = tmp_path / "p.toml"
    path.write_text('kind = "predict_muscles_2d"\n' + text)
    return parse_muscle_predict(load_problem(path))


def test_multistart_table_parses_and_refuses_bad_input(tmp_path):
    spec = _problem(tmp_path, "[multistart]\nstarts = 4\nseed = 2\ngrids = [30, 75]\n")
    assert spec.multistart == MultiStartOptions(starts=4, seed=2, grids=(30, 75))
    assert _problem(tmp_path, "").multistart.starts == 1            # off by default
    for text, what in (("starts = 0", "multistart.starts"), ("grids = [30.5]", "grids"),
                       ("grid = [30]", "unknown key"),
                       ('tracking_solution = "missing.sto"', "is not a file")):
        with pytest.raises(InputError, match=what) as err:
            _problem(tmp_path, f"[multistart]\n{text}\n")
        assert "p.toml" in str(err.value) and "line 3" in str(err.value)


def test_summary_headline_names_the_spread():
    from predgait.workflows.predict_muscles import summary_lines

    spread = {"starts": 3, "converged": 2, "best": "perturbed reference 1 (seed 0)",
              "objective_min": 0.12, "objective_median": 0.125, "objective_max": 0.13,
              "max_kinematics_rms_deg_vs_best": 1.5, "seconds": 12.0}
    vg = {"peak_bw": 1.2, "loading_peak_bw": 1.2, "valley_bw": 0.8, "push_off_peak_bw": 1.1}
    summary = {"gait": {"right": {"vertical_grf": vg, "slip_m": 0.0, "stance_percent": 60},
                        "left": {"slip_m": 0.0}, "speed_m_s": 1.2, "stride_length_m": 1.2,
                        "stride_time_s": 1.0, "cadence_steps_min": 120.0},
               "ipopt": {"status": "Solve_Succeeded", "iterations": 10, "solve_time_s": 1.0},
               "status": "completed", "build_s": 1.0, "total_s": 2.0, "nodes": 16,
               "stages_before": [], "objective": 0.12, "objective_terms": {"effort": 0.012},
               "goal": {"effort_weight": 10.0},
               "pinocchio_check": {"max_residual": 0.0, "max_acceleration_error": 0.0},
               "moco": {"available": False}, "warnings": [], "multistart": spread}
    line = next(x for x in summary_lines(summary) if "multi-start" in x)
    assert "2 of 3 converged" in line and "0.12 / 0.125 / 0.13" in line and "1.5 deg" in line
    assert "all starts 12.0 s" in line


def test_grf_balance_of_the_moco_solution():
    """Moco's committed optimum misses part of its stride's impulse (predgait's grf.sto
    averages to body weight: tests/test_predict_muscles.py)."""
    from predgait.data.storage import read_storage
    from predgait.problems.muscle_prediction import grf_balance

    weight = 62.0 * 9.80665        # 2D_gait.osim's mass, OpenSim's gravity
    moco = grf_balance(read_storage(MOCO / "gaitPrediction_solution_fullcycle_grf.sto"), weight)
    assert moco["samples"] == 201
    assert moco["mean_vertical_bw"] == pytest.approx(0.9826, abs=0.001)   # 597.5 N of 608.0
    assert moco["mean_fore_aft_n"] == pytest.approx(-3.62, abs=0.05)
    assert moco["peak_vertical_bw"] > 3.5


def test_moco_solution_drops_its_activation_periodicity():
    """Moco's committed optimum holds the example's periodicity on coordinates and speeds
    (to round-off) but not on the activations (up to 0.99: it starts with activations near 1
    it never builds up again): the 6x objective gap's first cause."""
    from predgait.problems.muscle_prediction import symmetry_gaps

    gaps = symmetry_gaps(read_storage(SOLUTION))
    assert gaps["value"] < 1e-9 and gaps["speed"] < 1e-9
    assert gaps["activation"] == pytest.approx(0.99, abs=0.01)


def test_paired_moco_solution_holds_its_periodicity():
    """A second Moco run of the example (moco_prediction_paired/README.md) holds every
    pair, activations included: the earlier run's dropped periodicity was that run's."""
    from predgait.problems.muscle_prediction import symmetry_gaps

    paired = MOCO.parent / "moco_prediction_paired" / "gaitPrediction_solution.sto"
    gaps = symmetry_gaps(read_storage(paired))
    assert max(gaps.values()) < 1e-6, gaps


def test_symmetry_gaps_known_answer():
    """A trajectory that holds the pairing has no gap; one activation off by 0.3 shows it."""
    from types import SimpleNamespace

    from predgait.problems.muscle_prediction import symmetry_gaps

    columns = {"/jointset/hip_r/hip_flexion_r/value": np.array([0.1, 0.5, 0.3]),
               "/jointset/hip_l/hip_flexion_l/value": np.array([0.3, 0.2, 0.1]),
               "/jointset/groundPelvis/pelvis_tx/value": np.array([0.0, 0.3, 0.6]),
               "/jointset/groundPelvis/pelvis_tx/speed": np.array([1.2, 1.1, 1.2]),
               "/soleus_r/activation": np.array([0.2, 0.5, 0.4]),
               "/soleus_l/activation": np.array([0.4, 0.1, 0.2])}
    gaps = symmetry_gaps(SimpleNamespace(columns=columns))
    assert gaps == {"value": 0.0, "speed": 0.0, "activation": 0.0}
    columns["/soleus_l/activation"] = np.array([0.4, 0.1, 0.5])
    assert symmetry_gaps(SimpleNamespace(columns=columns))["activation"] == \
        pytest.approx(0.3)
