"""The predictive gait7 problem as specified, and its staged solve with restarts.

:class:`PredictSpec` is a parsed ``predict_gait7`` problem file (problems/
predict_gait7.toml, :func:`parse_predict`); :func:`staged_guess` and
:func:`solve_with_restarts` are how a purely predictive solve (tracking weight 0) is
started: a tracking stage from the measured motion, grid continuation from
``START_INTERVALS``, and Ipopt restarts from other barriers (``RESTARTS``) when a start
fails on this machine's floating-point path. The checked prediction (Pinocchio residuals,
engine re-simulation) is :func:`predgait.scenarios.predict.predict`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

from predgait.dynamics.contact import HuntCrossleyContact
from predgait.dynamics.inverse_options import bundled_source
from predgait.errors import SolveFailed
from predgait.models.gait7 import LIMITS
from predgait.models.loading import Model
from predgait.problemfile import Table
from predgait.problems.predictive import (
    DEFAULT_CONTACT,
    JOINTS,
    Cycle,
    Guess,
    PredictedGait,
    Start,
    Weights,
    problem_for,
)

#: Weights of the first stage of a predictive solve (tracking weight 0): a tracking
#: solve from the measured guess, whose solution starts the requested problem. From the
#: measured motion directly, Ipopt ends in bouncing (3 stances per foot) or infeasible
#: local solutions; from the tracked (dynamically consistent) one, in a walking gait.
TRACKING_STAGE = Weights(tracking=1.0, grf=10.0, effort=1e-2, acceleration=1e-4)
#: Grid (intervals per half cycle) of the staged start: a predictive solve on another grid
#: starts from the solution on this one, resampled (grid continuation). From the tracked
#: motion directly, 50 intervals ended in a stuttering gait (3 stances per foot); from
#: the 40-interval gait resampled, in the same walking gait refined (17 iterations).
START_INTERVALS = 40
#: The starts (Ipopt barriers, :class:`Start`) tried in turn by a solve from each start.
RESTARTS = {Start.MEASURED: (Start.MEASURED,),
            Start.SOLUTION: (Start.SOLUTION, Start.RESAMPLED, Start.MEASURED),
            Start.RESAMPLED: (Start.RESAMPLED, Start.SOLUTION, Start.MEASURED)}


@dataclass(frozen=True)
class PredictSpec:
    """A parsed ``predict_gait7`` problem file (see problems/predict_gait7.toml)."""

    source: Path | None = None
    mass: float = 72.6
    height: float = 1.8034
    ground_z: float = -0.0075
    nodes: int = 40
    cycle: Cycle = Cycle.HALF
    speed: float | None = None          # m/s; None: the measured speed
    stride_time: float | None = None    # s; None: the measured stride time
    weights: Weights = Weights()
    contact: HuntCrossleyContact = DEFAULT_CONTACT
    max_penetration: float = 0.03
    max_iter: int = 1000
    resimulate: bool = True
    provenance: dict = field(default_factory=dict)


def parse_predict(table: Table) -> PredictSpec:
    """PredictSpec from a problem table (errors name the file, key and line)."""
    table.check_keys(("kind", "trial", "model", "grid", "gait", "weights", "contact",
                      "solver", "check"))
    trial = table.table("trial")
    trial.check_keys(("source",))
    bundled_source(trial)
    model, grid, gait = table.table("model"), table.table("grid"), table.table("gait")
    model.check_keys(("mass", "height", "ground_z"))
    grid.check_keys(("nodes", "cycle"))
    gait.check_keys(("speed", "stride_time"))
    weights, contact = table.table("weights"), table.table("contact")
    weights.check_keys(("tracking", "grf", "effort", "acceleration"))
    contact.check_keys(("stiffness", "exponent", "dissipation", "friction",
                        "slip_velocity_scale"))
    solver, check = table.table("solver"), table.table("check")
    solver.check_keys(("max_iter", "max_penetration"))
    check.check_keys(("resimulate",))
    d, hc = PredictSpec(), DEFAULT_CONTACT
    return PredictSpec(
        source=table.path,
        mass=model.number("mass", d.mass, low=1.0, high=500.0, unit="kg"),
        height=model.number("height", d.height, low=0.3, high=3.0, unit="m"),
        ground_z=model.number("ground_z", d.ground_z, low=-1.0, high=1.0, unit="m"),
        nodes=int(grid.number("nodes", d.nodes, low=4, high=400)),
        cycle=grid.choice("cycle", Cycle, d.cycle.value),
        speed=gait.number("speed", None, low=0.0, high=20.0, unit="m/s")
        if gait.has("speed") else None,
        stride_time=gait.number("stride_time", low=0.1, high=10.0, unit="s")
        if gait.has("stride_time") else None,
        weights=Weights(*(weights.number(k, getattr(d.weights, k), low=0.0, high=1e9)
                          for k in ("tracking", "grf", "effort", "acceleration"))),
        contact=HuntCrossleyContact(
            stiffness=contact.number("stiffness", hc.stiffness, low=1e3, high=1e10,
                                     unit="N/m^exponent"),
            exponent=contact.number("exponent", hc.exponent, low=1.0, high=3.0),
            dissipation=contact.number("dissipation", hc.dissipation, low=0.0, high=100.0,
                                       unit="s/m"),
            friction=contact.number("friction", hc.friction, low=0.0, high=5.0),
            slip_velocity_scale=contact.number("slip_velocity_scale", hc.slip_velocity_scale,
                                               low=1e-4, high=1.0, unit="m/s")),
        max_penetration=solver.number("max_penetration", d.max_penetration, low=1e-4,
                                      high=0.2, unit="m"),
        max_iter=int(solver.number("max_iter", d.max_iter, low=1, high=100000)),
        resimulate=check.get("resimulate", bool, True))


def default_bounds() -> dict[str, tuple[float, float]]:
    """The model's joint ranges (gait7 LIMITS), rad."""
    return {j: LIMITS[j[:-2]] for j in JOINTS}


def measured_for(spec: PredictSpec, model: Model):
    """The measured cycle (guess and reference) of ``spec`` on ``model``."""
    from predgait.dynamics.gait7_motion import bundled_gait7_motion, gait7_model
    from predgait.problems.predictive_data import carrying_depth, measured_cycle

    motion = bundled_gait7_motion(gait7_model(spec.mass, spec.height))
    return measured_cycle(model, motion, spec.cycle, spec.nodes, ground_z=spec.ground_z,
                          sink=carrying_depth(model, spec.contact))


def staged_guess(spec: PredictSpec, model: Model, kw: dict) -> tuple[Guess, list, bool]:
    """Guess of a predictive solve: tracking, then predictive on START_INTERVALS, resampled.

    The tracking stage starts from the measured motion; on a grid other than the final
    one (``cycle`` FULL counts twice the intervals), the predictive problem is solved
    there too and its solution resampled onto the final grid.
    """
    from predgait.problems.predictive_data import resampled_guess

    per_half = 2 if spec.cycle is Cycle.FULL else 1
    coarse = replace(spec, nodes=min(spec.nodes, START_INTERVALS * per_half))
    measured = measured_for(coarse, model)
    problem = problem_for(model, coarse.nodes, spec.cycle, spec.contact, spec.ground_z,
                          spec.max_penetration, spec.max_iter)
    first = problem.solve(measured.guess, measured.reference, TRACKING_STAGE, **kw,
                          label=f"tracking on {coarse.nodes} intervals")
    check_solved(first, "tracking stage")
    stages = [(f"tracking on {coarse.nodes} intervals", first.solved)]
    guess = Guess(first.q, first.v, first.a)
    if coarse.nodes == spec.nodes:
        return guess, stages, False
    what = f"predictive on {coarse.nodes} intervals"
    second = solve_with_restarts(problem, guess, measured.reference, spec.weights, kw,
                                 start=Start.SOLUTION, what=what, failed=stages)
    check_solved(second, f"predictive stage on {coarse.nodes} intervals")
    stages.append((what, second.solved))
    return resampled_guess(second, spec.nodes), stages, True


def solve_with_restarts(problem, guess, reference, weights, kw: dict, *, start: Start,
                        what: str, failed: list) -> PredictedGait:
    """Solve from ``start``; if Ipopt fails, again from the same guess with the next start.

    Ipopt's path through this non-convex problem depends on the machine's floating-point
    kernels: from the 20-interval tracking stage the adaptive barrier reached the
    predictive optimum with OpenBLAS's SkylakeX kernels and ended "infeasible" after 572
    iterations with its Haswell kernels, where the monotone barrier from mu = 1e-4
    converged (76 iterations, objective 0.359). Each failed attempt is appended to
    ``failed`` as a ``(what, Solved)`` stage.
    """
    tries = RESTARTS[start]
    for attempt in tries:
        gait = problem.solve(guess, reference, weights, start=attempt, **kw,
                             label=what if attempt is tries[0] else
                             f"{what}, again from a {attempt.value} start")
        if gait.solved.success or attempt is tries[-1]:
            return gait
        failed.append((f"{what} from a {attempt.value} start (failed)", gait.solved))


def check_solved(gait: PredictedGait, what: str) -> None:
    """Raise SolveFailed (status, iterations, violation) unless Ipopt converged."""
    s = gait.solved
    if not s.success:
        raise SolveFailed(f"Ipopt ({what}): {s.status} after {s.iterations} iterations "
                          f"({s.seconds:.1f} s), constraint violation "
                          f"{s.constraint_violation:.3g} (objective {s.objective:.4g}); "
                          "nothing written", best=gait)
