"""Multi-start of the muscle-driven gait NLP: one answer, and how far the others are.

Issue 26 item 6. An NLP of this size (a stiff contact model, free duration) has several
local optima; which one Ipopt finds depends on the start. The problem file's
``[multistart]`` table solves the same NLP (same grid, bounds and goal) from ``starts``
starts, in this order, until there are that many:

1. the workflow's own start (the reference coordinates, or the tracking stage's
   solution), already solved by the caller;
2. a MocoTrajectory given as ``tracking_solution`` (e.g. Moco's
   gaitTracking_solution.sto: coordinates, activations, excitations, lumbar control);
3. the solution on each of ``grids`` (other interval counts, each solved from the
   reference coordinates), resampled onto this grid;
4. the reference coordinates perturbed with a seeded RNG (``seed``): every angle gets
   sigma * (c + s sin(2 pi t / T + phi)) with c, s ~ N(0, 1), phi ~ U(0, 2 pi),
   sigma = ``perturbation_deg`` (speeds and accelerations are its derivatives), the
   duration a factor 1 + 0.1 N(0, 1), each muscle's activation and excitation U(0.01, 0.2).

The best is the converged solve of least objective; the spread (objective min / median /
max over the converged solves, right-leg kinematics RMS from heel strike of each converged
solve against the best: :mod:`predgait.problems.gait_agreement`) goes in summary.json.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

#: Keys of the [multistart] table.
KEYS = ("starts", "seed", "perturbation_deg", "grids", "tracking_solution")


@dataclass(frozen=True)
class MultiStartOptions:
    """The ``[multistart]`` table; ``starts = 1`` is a single solve (no multi-start)."""

    starts: int = 1
    seed: int = 0
    perturbation_deg: float = 5.0
    grids: tuple[int, ...] = ()
    tracking_solution: Path | None = None


def parse_multistart(table) -> MultiStartOptions:
    """MultiStartOptions from the problem file's ``[multistart]`` (a problemfile Table)."""
    table.check_keys(KEYS)
    d = MultiStartOptions()
    grids = table.numbers("grids", [], low=4, high=400)
    if any(g != int(g) for g in grids):
        raise table.error("grids", "give whole numbers of intervals, e.g. [30, 75].")
    tracking = table.path_value("tracking_solution", None)
    if tracking is not None and not tracking.is_file():
        raise table.error("tracking_solution", f"{tracking} is not a file; give a "
                                               "MocoTrajectory .sto (e.g. Moco's "
                                               "gaitTracking_solution.sto) or remove the key.")
    return MultiStartOptions(
        starts=int(table.number("starts", d.starts, low=1, high=50)),
        seed=int(table.number("seed", d.seed, low=0, high=2**31 - 1)),
        perturbation_deg=table.number("perturbation_deg", d.perturbation_deg, low=0.0,
                                      high=45.0, unit="deg"),
        grids=tuple(int(g) for g in grids),
        tracking_solution=tracking)


@dataclass(frozen=True, eq=False)
class StartRun:
    """One start: its label and the solved MuscleGait."""

    label: str
    gait: object


@dataclass(frozen=True, eq=False)
class MultiStart:
    """All runs, the best one (index into runs) and the spread (JSON-ready)."""

    runs: tuple[StartRun, ...]
    best: int
    spread: dict

    @property
    def gait(self):
        """The best MuscleGait."""
        return self.runs[self.best].gait


def resample(path, intervals: int):
    """A Trajectory on ``intervals`` uniform intervals (linear in normalised time)."""
    from predgait.problems.muscle_gait import Trajectory

    old = np.linspace(0.0, 1.0, path.q.shape[0])
    new = np.linspace(0.0, 1.0, intervals + 1)

    def at(values):
        values = np.asarray(values, float)
        if values.ndim == 1:
            return np.interp(new, old, values)
        return np.column_stack([np.interp(new, old, c) for c in values.T])

    return Trajectory(path.duration, at(path.q), at(path.v), at(path.a), at(path.act),
                      at(path.exc), at(path.u))


def perturbed(path, rng: np.random.Generator, sigma: float, rows: list[int]):
    """``path`` with smooth random angle offsets (rad ``sigma``) on ``rows`` (see above)."""
    t = path.t
    scale = float(np.clip(1.0 + 0.1 * rng.standard_normal(), 0.7, 1.3))
    omega = 2.0 * np.pi / path.duration
    q, v, a = path.q.copy(), path.v.copy(), path.a.copy()
    for row in rows:
        c, s = sigma * rng.standard_normal(2)
        phi = rng.uniform(0.0, 2.0 * np.pi)
        q[:, row] += c + s * np.sin(omega * t + phi)
        v[:, row] += s * omega * np.cos(omega * t + phi)
        a[:, row] -= s * omega ** 2 * np.sin(omega * t + phi)
    m = path.act.shape[1]
    act = np.tile(rng.uniform(0.01, 0.2, m), (t.size, 1))
    exc = np.tile(rng.uniform(0.01, 0.2, m), (t.size, 1))
    return replace(path, duration=path.duration * scale, q=q, v=v / scale, a=a / scale ** 2,
                   act=act, exc=exc)


def start_guesses(problem, plant, planar, storage, bounds, goal, options: MultiStartOptions,
                  *, max_iter: int) -> list[tuple[str, object]]:
    """The starts after the caller's own: (label, Trajectory on ``problem``'s grid)."""
    from predgait.data.storage import read_storage
    from predgait.problems.muscle_gait import MuscleGaitProblem
    from predgait.problems.muscle_gait_setup import reference_guess

    want = options.starts - 1
    out = []
    if options.tracking_solution is not None and len(out) < want:
        tracked, _ = reference_guess(planar, read_storage(options.tracking_solution), plant,
                                     problem.n)
        out.append((f"tracking solution {options.tracking_solution.name}", tracked))
    for grid in options.grids:
        if len(out) >= want:
            break
        other = MuscleGaitProblem(plant, grid, tx_row=problem.tx_row, max_iter=max_iter,
                                  transcription=problem.transcription,
                                  metabolic=problem.metabolic)
        guess, _ = reference_guess(planar, storage, plant, other.n)
        solved = other.solve(guess, bounds, goal)
        if solved.solved.success:
            out.append((f"{grid}-interval solution resampled", resample(solved.path,
                                                                        problem.n)))
    reference, _ = reference_guess(planar, storage, plant, problem.n)
    rng = np.random.default_rng(options.seed)
    rows = list(range(2, plant.model.nq))          # pitch and the joints, not x, z
    sigma = np.radians(options.perturbation_deg)
    for k in range(want - len(out)):
        out.append((f"perturbed reference {k + 1} (seed {options.seed})",
                    perturbed(reference, rng, sigma, rows)))
    return out


def spread_of(runs: list[StartRun], best: int, plant, planar) -> dict:
    """Objective min / median / max over the converged runs, kinematics RMS vs the best."""
    from predgait.problems.gait_agreement import gait_curves, rms_deg

    converged = [i for i, r in enumerate(runs) if r.gait.solved.success]
    reference = gait_curves(plant, planar, runs[best].gait) if converged else None
    rows = []
    for run in runs:
        s = run.gait.solved
        row = {"start": run.label, "status": s.status, "success": s.success,
               "iterations": s.iterations, "solve_time_s": s.seconds,
               "objective": s.objective}
        if s.success and reference is not None:
            row["kinematics_rms_deg_vs_best"] = rms_deg(
                gait_curves(plant, planar, run.gait), reference)
        rows.append(row)
    objectives = np.array([runs[i].gait.solved.objective for i in converged])
    rms = [max(r["kinematics_rms_deg_vs_best"].values()) for r in rows
           if "kinematics_rms_deg_vs_best" in r]
    return {
        "starts": len(runs), "converged": len(converged), "best": runs[best].label,
        "objective_min": float(objectives.min()) if converged else None,
        "objective_median": float(np.median(objectives)) if converged else None,
        "objective_max": float(objectives.max()) if converged else None,
        "objective_relative_spread": float((objectives.max() - objectives.min())
                                           / objectives.min()) if converged else None,
        "max_kinematics_rms_deg_vs_best": float(max(rms)) if rms else None,
        "runs": rows,
    }


def multistart(problem, plant, planar, storage, bounds, goal, options: MultiStartOptions,
               first: StartRun, *, max_iter: int) -> MultiStart:
    """Solve the remaining starts of ``options`` and pick the best (see the module doc).

    Args:
        problem: the MuscleGaitProblem of the product grid.
        plant: the MusclePlant (plant_2d_gait).
        planar: its OsimPlanarModel.
        storage: the reference coordinates (perturbed and other-grid starts).
        bounds: the prediction's box bounds.
        goal: its Goal.
        options: the [multistart] table.
        first: the caller's own start, already solved.
        max_iter: Ipopt's limit for the other grids' problems.
    """
    clock = time.perf_counter()
    runs = [first]
    for label, guess in start_guesses(problem, plant, planar, storage, bounds, goal,
                                      options, max_iter=max_iter):
        runs.append(StartRun(label, problem.solve(guess, bounds, goal,
                                                  label=f"multistart: {label}")))
    converged = [i for i, r in enumerate(runs) if r.gait.solved.success]
    best = min(converged, key=lambda i: runs[i].gait.solved.objective) if converged else 0
    spread = spread_of(runs, best, plant, planar)
    # wall s of every start: the first solve, then the others (incl. the other grids)
    spread["seconds"] = first.gait.solved.seconds + time.perf_counter() - clock
    return MultiStart(tuple(runs), best, spread)
