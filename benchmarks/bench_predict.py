"""Predictive gait7 collocation speed (issue 13): build, tracking and predictive solves.

Half a gait cycle of the bundled walk with left/right symmetry, trapezoidal, implicit
dynamics, Hunt-Crossley heel/toe contact (problems/predict_gait7.toml), at 40 nodes (the
default) and 50. Per grid, min / median of the repeats (wall and CPU):

* build: the NLP and its Ipopt solver (exact Hessian), from a fresh model object;
* tracking, cold: tracking weights from the measured motion;
* predictive, cold: the whole :func:`predgait.workflows.predict.predict` recipe from the
  measured motion (tracking stage, then effort only; on grids other than 40 intervals the
  40-interval solution resampled, then the final grid), problems already built, no
  engine re-simulation; Ipopt iterations of every stage;
* predictive, warm: the predictive problem again from its own solution.

OpenSim Moco's predictive 2D walking example needs its model file (2D_gait.osim), which
the opensim wheel does not ship; without it, or without OPENSIM_PYTHON, the peer row
prints "peer not available" and no ratio is printed.

Run:  .venv/bin/python benchmarks/bench_predict.py [--repeat 3] [--nodes 40 50]
"""

from __future__ import annotations

import argparse
import os
import subprocess
from dataclasses import replace

from timing import NOT_AVAILABLE, time_call

from predgait.models.gait7 import build_gait7_urdf
from predgait.models.loading import model_from_urdf
from predgait.problems.predictive import Cycle, Guess, PredictiveProblem, Start, Weights
from predgait.problems.predictive_data import carrying_depth, measured_cycle
from predgait.simulations.gait7_motion import bundled_gait7_motion, gait7_model
from predgait.workflows.predict import TRACKING_STAGE, PredictSpec, default_bounds, predict

SPEC = PredictSpec()


def fresh_model():
    """A new gait7 object (no cached symbolic model or problem)."""
    return model_from_urdf(build_gait7_urdf(SPEC.mass, SPEC.height), source="bench")


def peer_line() -> str:
    """Why the Moco peer cannot run here (or that it could, were its model given)."""
    python = os.environ.get("OPENSIM_PYTHON")
    if not python:
        return f"OpenSim Moco 2D walking: {NOT_AVAILABLE} (OPENSIM_PYTHON not set)"
    try:
        subprocess.run([python, "-c", "import opensim; opensim.MocoStudy"], check=True,
                       capture_output=True, timeout=120)
    except (OSError, subprocess.SubprocessError):
        return f"OpenSim Moco 2D walking: {NOT_AVAILABLE} (no opensim with Moco in {python})"
    return (f"OpenSim Moco 2D walking: {NOT_AVAILABLE} (opensim with Moco found, but its "
            "example model 2D_gait.osim is not shipped with the wheel; no ratio)")


def bench(nodes: int, repeat: int) -> None:
    model = gait7_model(SPEC.mass, SPEC.height)
    motion = bundled_gait7_motion(model)
    measured = measured_cycle(model, motion, Cycle.HALF, nodes, ground_z=SPEC.ground_z,
                              sink=carrying_depth(model, SPEC.contact))
    kw = {"speed": measured.speed, "duration": measured.duration, "bounds": default_bounds()}

    def build():
        problem = PredictiveProblem(fresh_model(), nodes, Cycle.HALF, SPEC.contact,
                                    SPEC.ground_z, SPEC.max_penetration)
        problem.solver(Start.MEASURED)
        problem.solver(Start.SOLUTION)
        return problem

    print(f"{nodes} nodes, build (NLP + 2 Ipopt solvers): "
          f"{time_call(build, repeat).describe('s')}")
    problem = build()
    runs = {}

    def tracking():
        runs["tracking"] = problem.solve(measured.guess, measured.reference, TRACKING_STAGE,
                                         **kw)

    t = time_call(tracking, repeat)
    s = runs["tracking"].solved
    print(f"{nodes} nodes, tracking from the measured motion: {t.describe('s')}; "
          f"{s.iterations} iterations, {s.status}")

    def predictive_cold():
        runs["predictive"] = predict(replace(SPEC, nodes=nodes, resimulate=False))

    t = time_call(predictive_cold, repeat, warmup=True)     # warm-up builds the problems
    run = runs["predictive"]
    p = run.gait
    stages = " + ".join(str(x.iterations) for _, x in run.stages)
    print(f"{nodes} nodes, predictive recipe from the measured motion: {t.describe('s')}; "
          f"{stages} + {p.solved.iterations} iterations, {p.solved.status}, effort "
          f"{p.terms['effort']:.3f}, stance phases per foot "
          f"{run.measures['right']['stance_phases']}")

    def predictive_warm():
        runs["warm"] = problem.solve(Guess(p.q, p.v, p.a), measured.reference, Weights(),
                                     start=Start.SOLUTION, **kw)

    t = time_call(predictive_warm, repeat)
    print(f"{nodes} nodes, predictive from its own solution (warm): {t.describe('s')}; "
          f"{runs['warm'].solved.iterations} iterations, {runs['warm'].solved.status}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--nodes", type=int, nargs="+", default=[40, 50])
    args = parser.parse_args()
    for nodes in args.nodes:
        bench(nodes, args.repeat)
    print(peer_line())


if __name__ == "__main__":
    main()
