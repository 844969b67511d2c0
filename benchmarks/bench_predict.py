"""Predictive gait7 collocation speed (issue 13): build, tracking and predictive solves.

Half a gait cycle of the bundled walk with left/right symmetry, trapezoidal, implicit
dynamics, Hunt-Crossley heel/toe contact (problems/predict_gait7.toml), at 40 nodes (the
default) and 50. Per grid, min / median of the repeats (wall and CPU):

* build: the NLP and its Ipopt solver (exact Hessian), from a fresh model object;
* tracking, cold: tracking weights from the measured motion;
* predictive, cold: the whole :func:`predgait.scenarios.predict.predict` recipe from the
  measured motion (tracking stage, then effort only; on grids other than 40 intervals the
  40-interval solution resampled, then the final grid), problems already built, no
  engine re-simulation; Ipopt iterations of every stage;
* predictive, warm: the predictive problem again from its own solution.

Peer: OpenSim Moco's predictive 2D walking example (benchmarks/opensim_moco_2d_walking.py,
in the Python named by OPENSIM_PYTHON), each repeat a fresh process: the example's tracking
solve, then its predictive solve from that solution (10 coordinates, 18 muscles, 4 contact
spheres, 50 mesh intervals, Hermite-Simpson). Its files come from opensim-core's
repository, OpenSim/Examples/Moco/example2DWalking (2D_gait.osim, referenceCoordinates.sto,
referenceGRF.sto, referenceGRF.xml); neither the opensim wheel nor predgait ships them:
put them in a folder and name it in MOCO_2D_GAIT_DIR. Without OPENSIM_PYTHON, Moco or
that folder, the peer row prints "peer not available" and no ratio is printed. The two
problems differ (model, actuators, grid, objective): both sides' nodes, degrees of freedom
and iterations are printed beside the ratio, which compares the two recipes (Moco: set-up
and both solves; predgait: build + predictive recipe, min wall of each), not equal work.

Muscle case (issue 26, ``--case muscles`` or ``both``): ``predgait solve
problems/predict_2d_muscles.toml`` (Moco's example2DWalking prediction on 2D_gait.osim,
50 intervals) cold, each repeat a fresh process (model read, path fit, NLP and Ipopt
built, solved, checked, written): wall time, build time, Ipopt iterations, objective; with
``--moco-solution`` (Moco's gaitPrediction_solution.sto, e.g. from
benchmarks/opensim_moco_2d_walking.py --write) its objective, iterations and solver time beside
ours; with ``--coretypes`` one run per OPENBLAS_CORETYPE and the spread of the objective
and kinematics between them; the human-likeness run (problems/
predict_2d_muscles_physiological.toml) with its failed checks.

Run:  [OPENSIM_PYTHON=... MOCO_2D_GAIT_DIR=...] .venv/bin/python benchmarks/bench_predict.py
      [--repeat 3] [--nodes 40 50] [--peer-minutes 30] [--case gait7|muscles|both]
      [--moco-solution FILE] [--coretypes Haswell SkylakeX]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
from dataclasses import replace

from timing import HERE, NOT_AVAILABLE, Timing, time_call

from predgait.dynamics.gait7_motion import bundled_gait7_motion, gait7_model
from predgait.models.gait7 import build_gait7_urdf
from predgait.models.loading import model_from_urdf
from predgait.problems.predictive import Cycle, Guess, PredictiveProblem, Start, Weights
from predgait.problems.predictive_data import carrying_depth, measured_cycle
from predgait.problems.predictive_solve import TRACKING_STAGE, PredictSpec, default_bounds
from predgait.scenarios.predict import predict

SPEC = PredictSpec()


def fresh_model():
    """A new gait7 object (no cached symbolic model or problem)."""
    return model_from_urdf(build_gait7_urdf(SPEC.mass, SPEC.height), source="bench")


PEER = "OpenSim Moco 2D walking"


def run_peer(repeat: int, minutes: float) -> tuple[list[dict] | None, str]:
    """The Moco example ``repeat`` times (fresh processes, each at most ``minutes``), or
    None and why not."""
    python, folder = os.environ.get("OPENSIM_PYTHON"), os.environ.get("MOCO_2D_GAIT_DIR")
    if not python:
        return None, "OPENSIM_PYTHON not set"
    if not folder or not os.path.isfile(os.path.join(folder, "2D_gait.osim")):
        return None, ("MOCO_2D_GAIT_DIR does not name a folder with 2D_gait.osim (not "
                      "shipped with the opensim wheel: opensim-core's "
                      "OpenSim/Examples/Moco/example2DWalking)")
    runs = []
    for _ in range(repeat):
        try:
            done = subprocess.run([python, str(HERE / "opensim_moco_2d_walking.py")],
                                  capture_output=True, text=True, timeout=60 * minutes,
                                  env={**os.environ, "MOCO_2D_GAIT_DIR": folder})
        except subprocess.TimeoutExpired:
            return None, f"the Moco run did not finish in {minutes:g} min"
        if done.returncode != 0 or not done.stdout.strip():
            last = (done.stderr.strip().splitlines() or ["no output"])[-1]
            return None, f"the Moco run failed in {python}: {last}"
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    return runs, ""


def stage_timing(runs: list[dict], stages: tuple[str, ...]) -> Timing:
    """Wall and CPU of ``stages`` summed per run."""
    return Timing(tuple(sum(r[s]["wall"] for s in stages) for r in runs),
                  tuple(sum(r[s]["cpu"] for s in stages) for r in runs))


def report_peer(repeat: int, minutes: float, ours: dict[int, tuple[Timing, Timing]],
                nq: int) -> None:
    """The Moco rows and, only when it ran here, the ratio per predgait grid."""
    runs, why = run_peer(repeat, minutes)
    if runs is None:
        print(f"{PEER}: {NOT_AVAILABLE} ({why}; no ratio)")
        return
    first = runs[0]
    size = f"{first['coordinates']} DOF, {first['muscles']} muscles"
    for stage in ("tracking", "predictive"):
        r = first[stage]
        print(f"{PEER} (OpenSim {first['version']}), {stage}: "
              f"{stage_timing(runs, (stage,)).describe('s')}; {r['mesh_intervals']} mesh "
              f"intervals ({r['transcription']}), {r['time_points']} time points, {size}, "
              f"{r['states']} states, {r['controls']} controls, "
              f"iterations {[run[stage]['iterations'] for run in runs]}, {r['status']}")
    moco = stage_timing(runs, ("tracking", "predictive"))
    for nodes, (build, recipe) in ours.items():
        print(f"ratio Moco (tracking + predictive, set-up included; {size}, "
              f"{first['predictive']['time_points']} time points) / predgait (build + "
              f"predictive recipe; {nq} DOF, joint torques, {nodes} intervals, {nodes + 1} "
              f"nodes), min wall: {moco.best / (build.best + recipe.best):.1f}x (different "
              "problems, not equal work)")


def bench(nodes: int, repeat: int) -> tuple[Timing, Timing]:
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

    built = time_call(build, repeat)
    print(f"{nodes} nodes, build (NLP + 2 Ipopt solvers): {built.describe('s')}")
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

    t = recipe = time_call(predictive_cold, repeat, warmup=True)  # warm-up builds problems
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
    return built, recipe


def solve_muscles(problem: str, extra: tuple[str, ...] = (), env: dict | None = None
                  ) -> tuple[float, dict]:
    """One cold ``predgait solve`` of a muscle problem in a fresh process: (wall s, summary)."""
    import sys
    import tempfile
    import time
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "predgait", "solve",
                               str(HERE.parent / "problems" / problem), "--out", str(out),
                               "--no-plots", *extra], capture_output=True, text=True,
                              env={**os.environ, **(env or {})})
        wall = time.perf_counter() - start
        if not (out / "summary.json").is_file():
            raise SystemExit(f"{problem}: {done.stderr.strip()[-400:]}")
        return wall, json.loads((out / "summary.json").read_text())


def bench_muscles(repeat: int, moco_solution: str | None, coretypes: list[str]) -> None:
    """The muscle-driven prediction cold (fresh processes), Moco's solution, BLAS kernels."""
    extra = ("--set", f"compare.moco_solution={moco_solution}") if moco_solution else ()
    load = os.getloadavg()[0]
    runs = [solve_muscles("predict_2d_muscles.toml", extra) for _ in range(repeat)]
    walls = sorted(w for w, _ in runs)
    s = runs[0][1]
    ip = s["ipopt"]
    print(f"muscles (2D_gait.osim, {s['nodes']} intervals, {s['transcription']}), cold "
          f"predgait solve incl. reading, fitting, building, checking, writing: min "
          f"{walls[0]:.1f} s, median {walls[len(walls) // 2]:.1f} s (load average "
          f"{load:.1f} on {os.cpu_count()} cores); build {s['build_s']:.1f} s, Ipopt "
          f"{ip['iterations']} iterations {ip['solve_time_s']:.1f} s, {ip['status']}, "
          f"objective {s['objective']:.5g}")
    moco = s["moco"]
    if moco["available"]:
        print(f"  Moco's solution: objective {moco['objective']:.5g}, {moco['iterations']} "
              f"iterations, solver {moco['solver_duration_s']:.0f} s; ours/Moco objective "
              f"{s['objective'] / moco['objective']:.2f}; kinematics RMS "
              + ", ".join(f"{k} {v:.1f}" for k, v in moco["kinematics_rms_deg"].items())
              + " deg; Moco solver time / our cold wall "
              f"{moco['solver_duration_s'] / walls[0]:.0f}x")
    else:
        print(f"  Moco's solution: {NOT_AVAILABLE} ({moco['why']})")
    kernels = {}
    for kind in coretypes:
        kernels[kind] = solve_muscles("predict_2d_muscles.toml",
                                      env={"OPENBLAS_CORETYPE": kind})[1]
    if kernels:
        objectives = {k: v["objective"] for k, v in kernels.items()}
        curves = [v["right_leg_deg"] for v in kernels.values()]
        import numpy as np

        spread = max(float(np.max(np.abs(np.subtract(curves[0][j], c[j]))))
                     for c in curves for j in c)
        print(f"  OPENBLAS_CORETYPE: objectives {objectives}; right-leg angles differ by "
              f"up to {spread:.2f} deg between kernels")
    _, phys = solve_muscles("predict_2d_muscles_physiological.toml")
    print(f"  physiological bounds: {phys['status']}, objective {phys['objective']:.5g}; "
          f"{len(phys['warnings'])} of {len(phys['human_likeness'])} checks fail: "
          + "; ".join(f"{w['name']} {w['value']:.3g} ({w['bound']})"
                      for w in phys["warnings"]))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--nodes", type=int, nargs="+", default=[40, 50])
    parser.add_argument("--peer-minutes", type=float, default=30.0,
                        help="stop each Moco run after this many minutes (default 30)")
    parser.add_argument("--case", choices=("gait7", "muscles", "both"), default="both")
    parser.add_argument("--moco-solution", help="Moco's gaitPrediction_solution.sto")
    parser.add_argument("--coretypes", nargs="*", default=[],
                        help="OPENBLAS_CORETYPE values to compare (e.g. Haswell SkylakeX)")
    args = parser.parse_args()
    if args.case in ("gait7", "both"):
        ours = {nodes: bench(nodes, args.repeat) for nodes in args.nodes}
        report_peer(args.repeat, args.peer_minutes, ours, fresh_model().nq)
    if args.case in ("muscles", "both"):
        bench_muscles(args.repeat, args.moco_solution, args.coretypes)


if __name__ == "__main__":
    main()
