"""The ``predict_muscles_2d`` problem (Moco's example2DWalking prediction): spec, solve, summary.

Reads a problem file (problems/predict_2d_muscles.toml), builds the muscle-driven NLP of
:mod:`predgait.problems.muscle_gait` on an OpenSim planar gait model (default: the bundled
2D_gait.osim), solves a tracking stage on the reference coordinates (as Moco's example
starts its prediction from a MocoTrack solution), then the prediction from it; checks
the dynamics at every node with Pinocchio, builds the stride from right heel strike and
writes solution.sto / states.sto / controls.sto (OpenSim column names), muscle_forces.sto,
grf.sto, summary.json and a plot. The human-likeness checks
(:mod:`predgait.analysis.human_likeness`) that fail are listed as warnings ("completed
with warnings"). An Ipopt failure writes the best point reached as ``partial_*`` files
with summary.json (status "not converged") and raises SolveFailed (exit 3).
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from predgait.problemfile import Table
from predgait.problems.collocation import Transcription
from predgait.problems.muscle_gait import Goal
from predgait.problems.muscle_multistart import MultiStartOptions, parse_multistart
from predgait.textfile import source_name

DEG = np.pi / 180.0
#: Tracking-stage weight per rad^2 of mean squared coordinate error.
TRACKING_WEIGHT = 100.0
#: Coordinates given in m in [bounds] (the rest in deg).
TRANSLATIONS = ("pelvis_tx", "pelvis_ty")


class Preset(enum.Enum):
    """Coordinate bounds: Moco's example, or normal walking's joint ranges."""

    MOCO = "moco"
    PHYSIOLOGICAL = "physiological"


@dataclass(frozen=True)
class MusclePredictSpec:
    """A parsed ``predict_muscles_2d`` problem file."""

    source: Path | None = None
    osim: Path | None = None               # None: the bundled 2D_gait.osim
    compliant_tendons: str | tuple[str, ...] = ()   # [model]: "all" or muscle names
    reference: Path | None = None          # None: the bundled referenceCoordinates.sto
    nodes: int = 50
    transcription: Transcription = Transcription.TRAPEZOIDAL
    goal: Goal = Goal()
    duration: tuple[float, float] = (0.4, 0.6)
    preset: Preset = Preset.MOCO
    bounds: dict = field(default_factory=dict)   # OpenSim coordinate -> (low, high) SI
    tracking_stage: bool = False
    metabolic_stage: bool = False   # [guess] first solve without the metabolic term
    tracking_weight: float = TRACKING_WEIGHT
    max_iter: int = 3000
    moco_solution: Path | None = None
    human_checks: bool = True
    multistart: MultiStartOptions = MultiStartOptions()   # [multistart]: issue 26 item 6


#: ``[model] osim`` names of the bundled models besides "bundled" (2D_gait.osim).
BUNDLED_MODELS = {"bundled_toes": "2D_gait_toes.osim"}


def bundled_file(name: str) -> Path:
    """A file of the bundled Moco example2DWalking data (datasets/moco_2d_walking)."""
    from predgait.data.bundled import bundled_path

    return bundled_path(f"moco_2d_walking/{name}")


def parse_muscle_predict(table: Table) -> MusclePredictSpec:
    """MusclePredictSpec from a problem table (errors name the file, key and line)."""
    from predgait.models.osim import read_osim

    table.check_keys(("kind", "model", "guess", "grid", "goal", "bounds", "solver",
                      "compare", "check", "multistart"))
    model, guess, grid = table.table("model"), table.table("guess"), table.table("grid")
    goal, bounds, solver = table.table("goal"), table.table("bounds"), table.table("solver")
    compare, check = table.table("compare"), table.table("check")
    model.check_keys(("osim", "compliant_tendons"))
    guess.check_keys(("reference", "tracking_stage", "tracking_weight", "metabolic_stage"))
    grid.check_keys(("nodes", "transcription"))
    goal.check_keys(("speed", "speed_constraint", "speed_weight", "effort_weight",
                     "acceleration_weight", "metabolic_weight", "loading_rate_weight",
                     "duration"))
    solver.check_keys(("max_iter",))
    compare.check_keys(("moco_solution",))
    check.check_keys(("human_likeness",))
    osim_name = model.get("osim", str, "bundled")
    compliant = model.data.get("compliant_tendons", ())
    if not (compliant == "all" or (isinstance(compliant, list | tuple)
                                    and all(isinstance(n, str) for n in compliant))):
        raise model.error("compliant_tendons", 'give "all" or a list of muscle names '
                                               '(e.g. ["soleus", "gastroc", "vasti"]).')
    osim_path = (None if osim_name == "bundled" else bundled_file(BUNDLED_MODELS[osim_name])
                 if osim_name in BUNDLED_MODELS else model.path_value("osim", None))
    reference = guess.path_value("reference", None) \
        if guess.get("reference", str, "bundled") != "bundled" else None
    osim = read_osim(osim_path or bundled_file("2D_gait.osim"))
    from predgait.errors import InputError
    from predgait.problems.muscle_gait_setup import compliant_rows

    try:       # the muscles named exist and pair left/right: checked before any solve
        compliant_rows(tuple(m.name for m in osim.muscles), compliant, "")
    except InputError as error:
        raise model.error("compliant_tendons", str(error).removeprefix(": ")) from None
    names = [c.name for c in osim.coordinates]
    ranges = {}
    for key in bounds.data:
        if key == "preset":
            continue
        if key not in names:
            raise bounds.error(key, f"no coordinate '{key}' in {source_name(osim.source)}; "
                                    f"its coordinates: {', '.join(names)}.")
        low, high = bounds.numbers(key, length=2, increasing=True)
        unit = 1.0 if key in TRANSLATIONS else DEG
        ranges[key] = (low * unit, high * unit)
    duration = goal.numbers("duration", [0.4, 0.6], low=0.05, high=10.0, unit="s", length=2)
    if duration[0] > duration[1]:
        raise goal.error("duration", "give [shortest, longest] in s, shortest <= longest.")
    d = Goal()
    moco = compare.path_value("moco_solution", None)
    return MusclePredictSpec(
        source=table.path, osim=osim_path, reference=reference,
        compliant_tendons=compliant if isinstance(compliant, str) else tuple(compliant),
        nodes=int(grid.number("nodes", 50, low=4, high=400)),
        transcription=grid.choice("transcription", Transcription,
                                  Transcription.TRAPEZOIDAL.value),
        goal=Goal(speed=goal.number("speed", d.speed, low=0.05, high=10.0, unit="m/s"),
                  speed_constraint=goal.get("speed_constraint", bool, d.speed_constraint),
                  speed_weight=goal.number("speed_weight", d.speed_weight, low=0.0, high=1e9),
                  effort_weight=goal.number("effort_weight", d.effort_weight, low=0.0,
                                            high=1e9),
                  acceleration_weight=goal.number("acceleration_weight",
                                                  d.acceleration_weight, low=0.0, high=1e9),
                  metabolic_weight=goal.number("metabolic_weight", d.metabolic_weight,
                                               low=0.0, high=1e9),
                  loading_rate_weight=goal.number("loading_rate_weight",
                                                  d.loading_rate_weight, low=0.0, high=1e9)),
        duration=(duration[0], duration[1]),
        preset=bounds.choice("preset", Preset, Preset.MOCO.value), bounds=ranges,
        tracking_stage=guess.get("tracking_stage", bool, False),
        tracking_weight=guess.number("tracking_weight", TRACKING_WEIGHT, low=0.0, high=1e9),
        metabolic_stage=guess.get("metabolic_stage", bool, False),
        max_iter=int(solver.number("max_iter", 3000, low=1, high=100000)),
        moco_solution=moco, human_checks=check.get("human_likeness", bool, True),
        multistart=parse_multistart(table.table("multistart")))


@dataclass(frozen=True, eq=False)
class MusclePrediction:
    """A solved (or failed) prediction with everything the outputs need."""

    plant: object
    planar: object
    gait: object              # MuscleGait
    stages: tuple             # (what, MuscleGait) before the final solve
    check: dict
    stride: object            # Stride from right heel strike
    build_s: float
    multistart: dict | None = None   # the spread of a [multistart] (muscle_multistart)
    reused_from: str | None = None   # the stored solves evaluated instead of solving


def coordinate_ranges(spec: MusclePredictSpec) -> dict:
    """Coordinate bounds of the spec: its preset overridden by its own ranges."""
    from predgait.problems.muscle_gait_setup import MOCO_BOUNDS, PHYSIOLOGICAL_BOUNDS

    base = MOCO_BOUNDS if spec.preset is Preset.MOCO else PHYSIOLOGICAL_BOUNDS
    return {**base, **spec.bounds}


def stages_before(spec: MusclePredictSpec) -> list[tuple[str, object, str]]:
    """The solves before the prediction, in order: (what, Goal, name) each.

    Tracking the reference (``[guess] tracking_stage``), then the goal without its metabolic
    term (``[guess] metabolic_stage``, when the goal has one; measured on
    problems/predict_2d_muscles_human.toml: from that gait the whole goal converges in ~480
    Ipopt iterations, from the reference in ~2000). Each starts from the previous one's
    solution when it converged.
    """
    before = [("tracking the reference",
               replace(spec.goal, tracking_weight=spec.tracking_weight),
               f"tracking referenceCoordinates on {spec.nodes} intervals")] \
        if spec.tracking_stage else []
    if spec.metabolic_stage and spec.goal.metabolic_weight > 0:
        before.append(("without the metabolic term", replace(spec.goal, metabolic_weight=0.0),
                       f"the goal without its metabolic term on {spec.nodes} intervals"))
    return before


def solve_prediction(spec: MusclePredictSpec, before_solving=None, *,
                     reuse: bool = False) -> MusclePrediction:
    """Build, solve (tracking stage, then prediction), check; failures are returned too.

    ``gait.solved.success`` says whether the final solve converged. ``before_solving(plant,
    planar)``, if given, is called once the problem is built, before its first solve (a
    muscle scenario starts building its edited problem there, on a second thread).
    ``reuse``: evaluate the solves stored by an earlier run of the same problem instead of
    solving it, and store a converged one (:mod:`predgait.problems.muscle_baseline_store`:
    a muscle scenario's baseline).
    All of it on one BLAS thread: NumPy's least squares (the path fits, the guess) round
    differently with 1 and 2 OpenBLAS threads, and this NLP's optimum follows round-off
    (20 intervals: the knee landed at 6.8 or 10 deg by the process' thread count).
    """
    from predgait.blas_threads import one_blas_thread

    with one_blas_thread():
        return _solve_prediction(spec, before_solving, reuse)


def _solve_prediction(spec: MusclePredictSpec, before_solving=None,
                      reuse: bool = False) -> MusclePrediction:
    """:func:`solve_prediction` on the threads it was called with."""
    from predgait.data.storage import read_storage
    from predgait.models.osim import read_osim
    from predgait.problems import ipopt_progress
    from predgait.problems import muscle_baseline_store as baseline_store
    from predgait.problems.muscle_gait import MuscleGaitProblem
    from predgait.problems.muscle_gait_check import node_check
    from predgait.problems.muscle_gait_setup import (
        bounds_for,
        compliant_rows,
        plant_2d_gait,
        reference_guess,
    )
    from predgait.problems.muscle_gait_stride import from_right_heel_strike, full_stride

    clock = time.perf_counter()
    osim_path = spec.osim or bundled_file("2D_gait.osim")
    reference_path = spec.reference or bundled_file("referenceCoordinates.sto")
    plant, planar = plant_2d_gait(read_osim(osim_path))
    plant = replace(plant, compliant=compliant_rows(
        plant.muscle_names, spec.compliant_tendons,
        f"{source_name(spec.source) if spec.source else 'problem'}: [model]"))
    problem = MuscleGaitProblem(plant, spec.nodes, tx_row=0, max_iter=spec.max_iter,
                                transcription=spec.transcription,
                                metabolic=spec.goal.metabolic_weight > 0)
    storage = read_storage(reference_path)
    guess, reference = reference_guess(planar, storage, plant, problem.n)
    bounds = bounds_for(plant, planar, coordinate_ranges(spec), spec.duration)
    key = (baseline_store.baseline_key(spec, [osim_path, reference_path])
           if reuse and spec.multistart.starts == 1 and baseline_store.enabled() else None)
    stored = baseline_store.load(key) if key else None
    if stored is None:
        problem.build_solver()   # Ipopt's derivatives: most of the build
    build_s = time.perf_counter() - clock
    if before_solving is not None:
        before_solving(plant, planar)
    if stored is not None:
        solves, reused = stored
        ipopt_progress.stage(f"reused the baseline solved by an earlier run ({reused}; "
                             "PREDGAIT_SOLVER_CACHE=off solves it again)")
        gaits = [problem.evaluate(s.solved.w, s.p, s.solved) for s in solves]
        stages = [(s.name, g) for s, g in zip(solves[:-1], gaits[:-1], strict=True)]
        gait, start = gaits[-1], guess
    else:
        stages, gait, start = _solve_stages(spec, problem, guess, reference, bounds)
        reused = None
        if key and gait.solved.success:
            goals = [goal for _, goal, _ in stages_before(spec)]
            baseline_store.store(key, [
                *(baseline_store.StoredSolve(name, problem.parameters(goal, reference),
                                             g.solved)
                  for (name, g), goal in zip(stages, goals, strict=True)),
                baseline_store.StoredSolve("prediction", problem.parameters(spec.goal),
                                           gait.solved)])
    spread = None
    if spec.multistart.starts > 1:
        from predgait.problems.muscle_multistart import StartRun, multistart

        first = "tracking stage solution" if start is not guess else "reference coordinates"
        result = multistart(problem, plant, planar, storage, bounds, spec.goal,
                            spec.multistart, StartRun(first, gait), max_iter=spec.max_iter)
        gait, spread = result.gait, result.spread
    check = node_check(plant, gait)
    stride = from_right_heel_strike(full_stride(plant, gait, check["contact_point_speed"]),
                                    plant)
    return MusclePrediction(plant, planar, gait, tuple(stages), check, stride, build_s,
                            spread, None if reused is None else str(reused))


def _solve_stages(spec: MusclePredictSpec, problem, guess, reference, bounds):
    """(stages, gait, start): the solves before the prediction, then it, and its start.

    The stages are :func:`stages_before`'s; each starts from the previous one's solution
    when it converged.
    """
    stages, start = [], guess
    before = stages_before(spec)
    total = len(before) + 1
    for i, (what, goal, name) in enumerate(before):
        solved = problem.solve(start, bounds, goal, reference,
                               label=f"stage {i + 1}/{total} {what}")
        stages.append((name, solved))
        if solved.solved.success:
            start = solved.path
    gait = problem.solve(start, bounds, spec.goal, label=f"stage {total}/{total} predictive"
                         if before else "predictive")
    return stages, gait, start


def grf_balance(grf, body_weight: float) -> dict:
    """Momentum balance of a periodic stride's ground reaction (an OpenSim GRF table).

    Over a whole periodic stride the mean vertical ground reaction equals body weight and
    the mean fore-aft one is zero (the body returns to the same velocity). A solution whose
    forces, at its own time points, miss part of the impulse (e.g. at heel-strike impacts
    between collocation points) shows it here.

    Returns:
        ``mean_vertical_bw`` (mean vertical force / body weight, 1 for a balanced stride),
        ``mean_fore_aft_n`` (N), ``peak_vertical_bw`` (both feet), ``samples``.
    """
    t = grf.time
    vertical = sum(grf.column(f"ground_force_{s}_vy") for s in ("r", "l"))
    fore_aft = sum(grf.column(f"ground_force_{s}_vx") for s in ("r", "l"))
    period = t[-1] - t[0]
    return {"mean_vertical_bw": float(np.trapezoid(vertical, t) / period / body_weight),
            "mean_fore_aft_n": float(np.trapezoid(fore_aft, t) / period),
            "peak_vertical_bw": float(vertical.max() / body_weight), "samples": int(t.size)}


def symmetry_gaps(half) -> dict:
    """How far a half-stride MocoTrajectory is from its left/right periodicity, per kind.

    For every state the example's MocoPeriodicityGoal pairs (coordinate values but
    pelvis_tx, speeds, muscle activations; labels with ``_r``/``_l`` swapped, the others
    with themselves) the largest |final value of the pair - initial value| (rad, m, rad/s,
    m/s, activation); 0 for a trajectory that holds the goal.

    Returns:
        {"value", "speed", "activation"} -> largest gap of that kind (None when absent).
    """
    def mirrored(label: str) -> str:
        return label.replace("_r/", "_x/").replace("_l/", "_r/").replace("_x/", "_l/")

    gaps: dict[str, float | None] = {"value": None, "speed": None, "activation": None}
    for label, values in half.columns.items():
        kind = label.rsplit("/", 1)[-1]
        if kind not in gaps or label.endswith("pelvis_tx/value"):
            continue
        pair = half.columns.get(mirrored(label))
        if pair is None:
            continue
        gap = float(abs(pair[-1] - values[0]))
        gaps[kind] = gap if gaps[kind] is None else max(gaps[kind], gap)
    return gaps


def moco_comparison(path: Path | None, planar, stride) -> dict:
    """Objective and kinematics RMS (deg, from right heel strike) against Moco's solution."""
    from predgait.analysis.human_likeness import resample_stride
    from predgait.data.storage import read_storage

    if path is None or not Path(path).is_file():
        return {"available": False,
                "why": "no Moco solution given" if path is None else f"{path} not found"}
    half = read_storage(path)
    full_path = Path(path).with_name(Path(path).stem + "_fullcycle.sto")
    grf_path = Path(path).with_name(Path(path).stem + "_fullcycle_grf.sto")
    table = read_storage(full_path) if full_path.is_file() else half
    t = table.time - table.time[0]
    if grf_path.is_file():
        grf = read_storage(grf_path)
        on = np.interp(table.time, grf.time, grf.column("ground_force_r_vy")) > 20.0
        onsets = np.flatnonzero(on[:-1] & ~np.roll(on[:-1], 1))
        k = int(onsets[0]) if onsets.size else 0
    else:
        k = 0
    ours = planar.osim_from_q(stride.q)
    rms = {}
    for name in planar.osim_coordinates[2:]:
        label = next((c for c in table.columns if c.endswith(f"/{name}/value")), None)
        if label is None:
            continue
        values = table.columns[label][:-1]
        rolled = np.concatenate([values[k:], values[:k + 1]])
        theirs = resample_stride(t[:rolled.size], rolled)
        mine = resample_stride(stride.t, ours[name])
        rms[name] = float(np.degrees(np.sqrt(np.mean((mine - theirs) ** 2))))
    objective = half.header.get("objective")
    balance = grf_balance(read_storage(grf_path), planar.model.total_mass()
                          * planar.model.gravity) if grf_path.is_file() else None
    return {"available": True, "file": source_name(path), "grf_balance": balance,
            "symmetry_gaps": symmetry_gaps(half),
            "objective": float(objective) if objective else None,
            "status": half.header.get("status"),
            "iterations": int(half.header["num_iterations"])
            if "num_iterations" in half.header else None,
            "solver_duration_s": float(half.header["solver_duration"])
            if "solver_duration" in half.header else None,
            "kinematics_rms_deg": rms,
            "max_kinematics_rms_deg": max(rms.values()) if rms else None}


def _solved(s) -> dict:
    return {"status": s.status, "success": s.success, "iterations": s.iterations,
            "solve_time_s": s.seconds, "objective": s.objective,
            "constraint_violation": s.constraint_violation}


def prediction_summary(spec: MusclePredictSpec, pred: MusclePrediction) -> dict:
    """The JSON summary: solver, objective terms, gait measures, checks, comparison."""
    from predgait.analysis.human_likeness import human_checks, resample_stride
    from predgait.analysis.plausibility import record
    from predgait.kinematics.osim2d_angles import leg_angles_deg
    from predgait.problems.muscle_gait_check import slip_per_stride
    from predgait.problems.muscle_gait_stride import gait_measures

    plant, gait, stride = pred.plant, pred.gait, pred.stride
    weight = plant.model.total_mass() * plant.model.gravity
    slip = slip_per_stride(stride.t, stride.grf[:, :, 2], stride.speed, weight)
    measures = gait_measures(stride, plant, slip, weight)
    curves = leg_angles_deg(pred.planar, stride.q, "r")
    curves = {k: resample_stride(stride.t, v) for k, v in curves.items()}
    checks = []
    if spec.human_checks and gait.solved.success:
        right = measures["right"]
        checks = human_checks(curves, toe_off_percent=right["toe_off_percent"] or 60.0,
                              vertical_grf_bw=right["vertical_grf"],
                              slip_m=max(measures["right"]["slip_m"],
                                         measures["left"]["slip_m"]))
    s = gait.solved
    total = pred.build_s + sum(g.solved.seconds for _, g in pred.stages) + (
        pred.multistart["seconds"] if pred.multistart else s.seconds)
    return record({
        "status": "completed" if s.success else "not converged", "kind": "predict_muscles_2d",
        "ipopt": _solved(s),
        "stages_before": [{"what": what, **_solved(g.solved)} for what, g in pred.stages],
        "build_s": pred.build_s, "total_s": total,
        # the stored solves of an earlier run, evaluated (their Ipopt figures are that run's)
        "reused_from": pred.reused_from,
        "objective": s.objective, "objective_terms": gait.terms,
        "goal": vars(spec.goal), "nodes": spec.nodes, "bounds": spec.preset.value,
        "transcription": spec.transcription.value, "dynamics": "implicit (M a + h = tau residual)",
        "duration_s": gait.path.duration, "gait": measures,
        "pinocchio_check": {k: v for k, v in pred.check.items()
                            if k not in ("residual", "contact_point_speed")},
        "right_leg_deg": {k: v[::10].tolist() for k, v in curves.items()},
        "moco": moco_comparison(spec.moco_solution, pred.planar, stride),
        "multistart": pred.multistart,
        "provenance": {"problem": source_name(spec.source) if spec.source else None,
                       "model": source_name(pred.planar.osim.source)},
    }, checks, key="human_likeness")
