"""Predicted gait of a muscle-driven scenario: the baseline prediction, then the edited one.

A ``kind = "muscle_scenario"`` file (problems/scenario_muscle_*.toml) names its baseline
problem (``predict_2d_muscles.toml``, kind ``predict_muscles_2d``) and holds
``[[muscle_edit]]`` tables (:mod:`predgait.scenarios.muscle_edits`). The baseline is
solved as ``predgait solve`` does (:func:`predgait.problems.muscle_prediction.solve_prediction`,
cached per process), then the edited model's problem is built on the same grid and goal
(:class:`predgait.problems.muscle_gait.MuscleGaitProblem`) with

* the edited plant (:meth:`MuscleScenario.edited_plant`: muscle parameters, transferred
  paths);
* the baseline's bounds merged with the scenario's coordinate bounds, and its speed and
  acceleration bounds (0 for a fused coordinate);
* the springs' generalised forces (an orthosis) added to the applied forces of every node,
  so the residual is M a + h - tau_muscles - tau_lumbar - J^T F - tau_springs;
* no dynamics residual row for a fused coordinate (the weld's reaction torque holds it:
  an arthrodesis, not a muscle-braced knee);
* a whole stride with plain periodicity when an edit acts on one side only
  (:attr:`MuscleScenario.symmetric` false), the half stride with left/right symmetry
  otherwise;

and solved from the baseline solution. A half-stride edit has the baseline's variables and
constraints, and (without a fused coordinate, whose dynamics row is dropped) its constraints,
so Ipopt starts from the baseline's primal-dual point (its multipliers too,
:data:`~predgait.problems.muscle_gait.WARM_START`); a whole-stride edit starts from the
baseline's motion (mirrored into a whole stride) alone: a cold start, its constraints are
not the baseline's. Why the warm start (measured on the four shipped half-stride scenarios at 50
intervals, ``benchmarks/scenario_starts.py``): from the baseline's motion alone the adaptive
barrier first pushes every variable off the baseline's active bounds and the solve lands in
another local optimum, one that moves with round-off (the rectus femoris transfer's swing
knee read 64.6 deg one run and 60.2 the next); from the primal-dual point each edit
reached a lower objective. Pinocchio re-evaluates the edited gait at every node, springs
included.

The edited problem does not depend on the baseline's solution, only on its model: it is
built on a second thread (:func:`edited_problem`) while the baseline is solved (CasADi
3.8's wheels are built with thread-safe symbolics and release the GIL while they compute).
Building it (~3.5 s CPU at 50 intervals since the derivatives are assembled node by node,
:mod:`predgait.problems.muscle_gait_derivatives`; ~21 s before) then overlaps the
baseline's solve on a machine with a free core; on a busy one it only competes with it.
The edited NLP and its numbers are those of a build on the main thread. The edited
``build_s`` is the wait for it after the baseline.
"""

from __future__ import annotations

import contextvars
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from predgait.errors import InputError, SolveFailed
from predgait.problemfile import load_problem

#: Baseline predictions solved in this process, by (problem file, overrides, spec).
_BASELINES: dict = {}


@dataclass(frozen=True, eq=False)
class MuscleScenarioRun:
    """What a muscle scenario needs before solving: the parsed files and the edited model.

    Attributes:
        spec: :class:`~predgait.scenarios.muscle_edits.MuscleScenarioSpec`.
        baseline: The baseline's :class:`~predgait.problems.muscle_prediction.MusclePredictSpec`.
        overrides: ``--set`` overrides applied to the baseline file.
    """

    spec: object
    baseline: object
    overrides: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class MuscleScenarioResult:
    """The baseline and edited predictions (MusclePrediction each) and the scenario."""

    run: MuscleScenarioRun
    scenario: object          # MuscleScenario
    baseline: object          # MusclePrediction of the unedited model
    edited: object            # MusclePrediction of the edited model (plant, planar edited)
    edited_build_s: float = 0.0   # s, the edited problem's own build (second thread)
    edited_start: str = ""        # where Ipopt started the edited solve (module docstring)


@dataclass(frozen=True, eq=False)
class EditedProblem:
    """The edited model's NLP, ready to solve (:func:`edited_problem`).

    Attributes:
        scenario: The :class:`~predgait.scenarios.muscle_edits.MuscleScenario`.
        plant: The edited MusclePlant; planar: its OsimPlanarModel.
        problem: Its :class:`~predgait.problems.muscle_gait.MuscleGaitProblem`.
        whole: Solved as a whole stride (a one-sided edit).
        warm: Started from the baseline's primal-dual point (module docstring).
        seconds: Wall time of the build, s; cpu_seconds: its thread's CPU time, s.
    """

    scenario: object
    plant: object
    planar: object
    problem: object
    whole: bool
    warm: bool
    seconds: float
    cpu_seconds: float


def load_muscle_scenario(path: str | Path, overrides=()) -> MuscleScenarioRun:
    """Read a muscle scenario file and its baseline problem file.

    ``--set`` overrides starting with ``baseline.`` apply to the baseline problem file
    (``baseline.grid.nodes=20``), the others to the scenario file.

    Raises:
        InputError: A missing baseline file, a baseline that is not a
            ``predict_muscles_2d`` problem, any edit error (file, key, line).
    """
    from predgait.dynamics.muscles import MuscleSet
    from predgait.models.osim import read_osim
    from predgait.problems.muscle_prediction import bundled_file, parse_muscle_predict
    from predgait.scenarios.muscle_edits import parse_muscle_scenario

    own = [o for o in overrides if not o.startswith("baseline.")]
    theirs = tuple(o[len("baseline."):] for o in overrides if o.startswith("baseline."))
    table = load_problem(path, own)
    base_path = table.path_value("baseline")
    if not base_path.is_file():
        raise table.error("baseline", f"{base_path} not found; give the baseline problem "
                                      "file (e.g. \"predict_2d_muscles.toml\") from this "
                                      "file's folder.")
    base_table = load_problem(base_path, theirs)
    if base_table.data.get("kind") != "predict_muscles_2d":
        raise table.error("baseline", f"{base_path.name} is kind "
                                      f"{base_table.data.get('kind')!r}; a muscle scenario's "
                                      "baseline is a 'predict_muscles_2d' problem.")
    base = parse_muscle_predict(base_table)
    osim = read_osim(base.osim or bundled_file("2D_gait.osim"))
    spec = parse_muscle_scenario(table, MuscleSet.from_osim(osim),
                                 tuple(c.name for c in osim.coordinates))
    return MuscleScenarioRun(spec, base, theirs)


def baseline_prediction(run: MuscleScenarioRun, before_solving=None):
    """The baseline MusclePrediction, solved once per process and problem.

    A converged baseline is also stored on disk for later runs
    (:mod:`predgait.problems.muscle_baseline_store`).

    ``before_solving(plant, planar)`` is called with the baseline's model before it is
    solved (:func:`~predgait.problems.muscle_prediction.solve_prediction`), or at once
    when it is already solved.
    """
    from predgait.problems.muscle_prediction import solve_prediction

    key = (str(run.baseline.source), run.overrides, repr(run.baseline))
    if key not in _BASELINES:
        from predgait.problems.ipopt_progress import stage

        stage("part 1/2: the unedited model's gait (baseline)")
        _BASELINES[key] = solve_prediction(run.baseline, before_solving, reuse=True)
    elif before_solving is not None:
        before_solving(_BASELINES[key].plant, _BASELINES[key].planar)
    return _BASELINES[key]


def scenario_node(plant, planar, scenario, metabolic: bool = False):
    """The node function of ``plant`` with the scenario's spring forces in its residual."""
    import casadi as cs

    from predgait.problems.muscle_gait_dynamics import node_function

    base = node_function(plant, metabolic)
    inputs = base.sx_in()          # q, v, a, act, exc, u (and ft, dft: compliant tendons)
    out = base(*inputs)
    r = out[0] - scenario.passive_forces(planar, inputs[0], inputs[1])
    return cs.Function("muscle_scenario_node", inputs, [r, *out[1:]],
                       base.name_in(), base.name_out())


def whole_stride_guess(plant, path):
    """A whole-stride Trajectory from a symmetric half stride (the second half mirrored)."""
    from predgait.problems.muscle_gait import Trajectory, mirror_rows

    mq = mirror_rows(plant.model.coordinate_names)
    mm = mirror_rows(plant.muscle_names)
    second_q = path.q[1:][:, mq]
    second_q[:, 0] += path.q[-1, 0] - path.q[0, 0]
    return Trajectory(2.0 * path.duration, np.concatenate([path.q, second_q]),
                      np.concatenate([path.v, path.v[1:][:, mq]]),
                      np.concatenate([path.a, path.a[1:][:, mq]]),
                      np.concatenate([path.act, path.act[1:][:, mm]]),
                      np.concatenate([path.exc, path.exc[1:][:, mm]]),
                      np.concatenate([path.u, path.u[1:]]))


def scenario_bounds(plant, planar, base_spec, scenario, *, whole: bool):
    """The baseline's box bounds with the scenario's coordinate, speed and acceleration ones."""
    from predgait.problems.muscle_gait_setup import bounds_for
    from predgait.problems.muscle_prediction import coordinate_ranges

    ranges = {**coordinate_ranges(base_spec), **scenario.coordinate_bounds}
    low, high = base_spec.duration
    duration = (2.0 * low, 2.0 * high) if whole else (low, high)
    bounds = bounds_for(plant, planar, ranges, duration)
    v, a = bounds.v.copy(), bounds.a.copy()
    for name, (lo, hi) in scenario.speed_bounds.items():
        row = planar.osim_coordinates.index(name)
        sign = float(planar.signs[row])
        v[row] = a[row] = sorted((sign * lo, sign * hi))
    return replace(bounds, v=v, a=a)


def scenario_check(plant, planar, scenario, gait) -> dict:
    """Pinocchio's residual at every node with the springs' forces, per :func:`node_check`.

    ``residual`` = RNEA - muscles - lumbar - contacts - springs; ``max_residual`` over the
    rows that are dynamics (a fused coordinate's row is the weld's reaction torque,
    ``fused_reaction_peak_n_m``); ``max_residual_without_springs``: the same leaving the
    springs out (an orthosis' torque shows there); ``spring_torque_peak_n_m``.
    """
    from predgait.problems.muscle_gait_check import node_check

    raw = node_check(plant, gait)
    p = gait.path
    springs = np.array([np.asarray(scenario.passive_forces(planar, q, v), float)
                        for q, v in zip(p.q, p.v, strict=True)])
    fused = [planar.osim_coordinates.index(n) for n in scenario.fused]
    free = [i for i in range(plant.model.nq) if i not in fused]
    residual = raw["residual"] - springs
    return {**raw, "residual": residual,
            "max_residual": float(np.abs(residual[:, free]).max()),
            "max_residual_without_springs": float(np.abs(raw["residual"][:, free]).max()),
            "nlp_residual_max": float(np.abs(gait.residual[:, free]).max()),
            "spring_torque_peak_n_m": float(np.abs(springs).max()),
            "fused_reaction_peak_n_m": {planar.osim_coordinates[i]:
                                        float(np.abs(residual[:, i]).max()) for i in fused},
            "max_acceleration_error": None}


def edited_stride(plant, gait, check, *, whole: bool):
    """The edited gait's stride from right heel strike."""
    from predgait.problems.muscle_gait_stride import (
        Stride,
        from_right_heel_strike,
        full_stride,
    )

    speed = check["contact_point_speed"]
    if not whole:
        return from_right_heel_strike(full_stride(plant, gait, speed), plant)
    p = gait.path
    stride = Stride(t=p.t, q=p.q, v=p.v, act=p.act, exc=p.exc, u=p.u, force=gait.force,
                    grf=gait.grf, points=gait.points, speed=speed,
                    distance=float(p.q[-1, 0] - p.q[0, 0]), duration=p.duration)
    return from_right_heel_strike(stride, plant)


def edited_model(run: MuscleScenarioRun, plant, planar):
    """(MuscleScenario, edited plant) of the baseline's model; input errors raised here."""
    from predgait.scenarios.muscle_edits import muscle_scenario

    scenario = muscle_scenario(run.spec.edits, planar, plant.muscle_set)
    unknown = [n for n in scenario.coordinate_bounds
               if n not in scenario.built.osim_coordinates]
    if unknown:
        raise InputError(f"{run.spec.source}: coordinates {unknown} are not in the model.")
    return scenario, scenario.edited_plant(plant)


def edited_problem(run: MuscleScenarioRun, scenario, plant, *,
                   warm: bool | None = None) -> EditedProblem:
    """The edited model's NLP on the baseline's grid and goal (module docstring).

    ``warm``: built to start from the baseline's primal-dual point; by default when the
    edit keeps the baseline's structure, False for a cold start (benchmarks/scenario_starts.py).
    """
    import time

    from predgait.problems.muscle_gait import WARM_START, MuscleGaitProblem

    clock, cpu = time.perf_counter(), time.thread_time()
    planar = scenario.built
    whole = not scenario.symmetric
    if warm is None:        # the baseline's variables and constraints
        warm = not (whole or scenario.fused)
    elif warm and (whole or scenario.fused):
        raise ValueError("a warm start needs the baseline's variables and constraints")
    fused = {planar.osim_coordinates.index(n) for n in scenario.fused}
    spec = run.baseline
    metabolic = spec.goal.metabolic_weight > 0
    problem = MuscleGaitProblem(
        plant, 2 * spec.nodes if whole else spec.nodes, tx_row=0, max_iter=spec.max_iter,
        transcription=spec.transcription, metabolic=metabolic,
        node=scenario_node(plant, planar, scenario, metabolic),
        residual_rows=[i for i in range(plant.model.nq) if i not in fused],
        symmetric=not whole, ipopt_options=WARM_START if warm else None)
    problem.build_solver()    # Ipopt's derivatives: most of the build, on this thread
    return EditedProblem(scenario, plant, planar, problem, whole, warm,
                         time.perf_counter() - clock, time.thread_time() - cpu)


def solve_muscle_scenario(run: MuscleScenarioRun) -> MuscleScenarioResult:
    """Baseline, then the edited prediction from it; SolveFailed if the baseline fails.

    The edited model is checked once the baseline's problem is built (input errors before
    any solve) and its problem built on a second thread while the baseline solves (module
    docstring). An edited solve that does not converge is returned
    (``edited.gait.solved.success`` false): the caller writes its best point as partial
    and exits 3.
    """
    from predgait.blas_threads import one_blas_thread

    with one_blas_thread():     # as solve_prediction: the answer must not follow the threads
        return _solve_muscle_scenario(run)


def _solve_muscle_scenario(run: MuscleScenarioRun) -> MuscleScenarioResult:
    """:func:`solve_muscle_scenario` on the BLAS threads it was called with."""
    import time

    from predgait.problems.ipopt_progress import stage
    from predgait.problems.muscle_prediction import MusclePrediction

    building = []
    with ThreadPoolExecutor(max_workers=1) as pool:
        def before_solving(plant, planar):
            scenario, edited_plant = edited_model(run, plant, planar)
            # the copied context carries the progress reporting (ipopt_progress)
            building.append(pool.submit(contextvars.copy_context().run, edited_problem,
                                        run, scenario, edited_plant))

        base = baseline_prediction(run, before_solving)
        s = base.gait.solved
        if not s.success:
            raise SolveFailed(f"Ipopt (baseline {Path(str(run.baseline.source)).name}): "
                              f"{s.status} after {s.iterations} iterations; no scenario is "
                              "solved without a baseline gait", best=base.gait)
        stage("part 2/2: the edited model's gait")
        clock = time.perf_counter()
        built = building[0].result()
    stage(f"edited model: its problem was built in {built.seconds:.1f} s ({built.cpu_seconds:.1f}"
          f" s CPU) on a second thread; waited {time.perf_counter() - clock:.1f} s for it "
          "after the baseline")
    scenario, plant, planar, spec = built.scenario, built.plant, built.planar, run.baseline
    bounds = scenario_bounds(plant, planar, spec, scenario, whole=built.whole)
    guess = (whole_stride_guess(base.plant, base.gait.path) if built.whole
             else base.gait.path)
    multipliers = base.gait.solved.multipliers if built.warm else None
    build_s = time.perf_counter() - clock
    gait = built.problem.solve(guess, bounds, spec.goal, label="edited model",
                               multipliers=multipliers)
    check = scenario_check(plant, planar, scenario, gait)
    stride = edited_stride(plant, gait, check, whole=built.whole)
    edited = MusclePrediction(plant, planar, gait, (), check, stride, build_s)
    start = ("warm: the baseline's primal-dual point (its multipliers too)" if built.warm
             else "cold: the baseline's motion" + (" mirrored into a whole stride"
                                                   if built.whole else ""))
    return MuscleScenarioResult(run, scenario, base, edited, built.seconds, start)
