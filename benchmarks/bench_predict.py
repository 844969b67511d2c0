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

gait7 has no peer: no other tool solves this problem, so no ratio is printed for it.

Muscle case (issue 26, ``--case muscles`` or ``both``): ``predgait solve
problems/predict_2d_muscles.toml`` (Moco's example2DWalking prediction on the bundled
2D_gait.osim, 50 intervals) cold, each repeat a fresh process (model read, path fit, NLP
and Ipopt built, solved, checked, written): wall and CPU, build time, Ipopt iterations,
objective. Peer, in the same run and interleaved with ours (predgait, Moco, predgait, ...):
OpenSim Moco's own example2DWalking (benchmarks/opensim_moco_2d_walking.py in the Python
named by OPENSIM_PYTHON, a fresh process per repeat, at most ``--peer-minutes``): the same
model file, the same predictive problem (half stride, symmetry, 1.2 m/s, effort cubed per
distance, duration in [0.4, 0.6] s, the example's bounds, 50 mesh intervals), solved by the
example's recipe: its tracking stage, then the prediction from that solution
(Hermite-Simpson, Ipopt tolerance 1e-4). Ours solves the prediction from the reference
coordinates (trapezoidal, Ipopt tolerances 1e-4 on the scaled NLP, as Moco's) without a
tracking stage: the two recipes deliver the same thing, a predicted gait of this problem,
and the ratio is of those whole processes (cold vs cold), with Moco's predictive stage alone
beside it.
MOCO_2D_GAIT_DIR may name another folder with the example's files (2D_gait.osim,
referenceCoordinates.sto, referenceGRF.sto, referenceGRF.xml); by default the copies
bundled with predgait are used. Without OPENSIM_PYTHON, or if Moco does not finish in
``--peer-minutes``, the peer prints "peer not available" and no ratio is printed.
With ``--moco-solution`` (Moco's gaitPrediction_solution.sto, e.g. from
benchmarks/opensim_moco_2d_walking.py --write) its objective and kinematics beside ours
(no time: a time from a file is not a measurement of this run); with ``--coretypes`` one
run per OPENBLAS_CORETYPE and the spread of the objective and kinematics between them; two
muscle scenarios (cold process; the edited re-solve from the baseline and its build; then
again with the baseline that run stored, as a user's second scenario of a baseline); the
human-likeness run (problems/predict_2d_muscles_physiological.toml) with its failed checks.

Run:  [OPENSIM_PYTHON=... MOCO_2D_GAIT_DIR=...] .venv/bin/python benchmarks/bench_predict.py
      [--repeat 3] [--peer-repeat 1] [--nodes 40 50] [--peer-minutes 60]
      [--case gait7|muscles|both]
      [--moco-solution FILE] [--coretypes Haswell SkylakeX]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import tempfile
from dataclasses import replace

from timing import HERE, NOT_AVAILABLE, Timing, load_text, opensim_python, ratio, time_call

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


PEER = "OpenSim Moco example2DWalking"
#: The example's files bundled with predgait (2D_gait.osim, references, referenceGRF.xml).
BUNDLED_MOCO_FILES = HERE.parent / "src" / "predgait" / "datasets" / "moco_2d_walking"


#: Muscle scenarios timed (issue 26: a re-solve from the baseline in under 20 s).
SCENARIOS = ("scenario_muscle_plantarflexor_weakness.toml", "scenario_muscle_afo_2d.toml")


def moco_folder() -> str | None:
    """MOCO_2D_GAIT_DIR, else the bundled copies of the example's files."""
    folder = os.environ.get("MOCO_2D_GAIT_DIR") or str(BUNDLED_MOCO_FILES)
    return folder if os.path.isfile(os.path.join(folder, "referenceGRF.xml")) else None


def run_moco(python: str, folder: str, minutes: float) -> tuple[dict | None, float, float, str]:
    """One cold run of Moco's example: (its JSON or None, wall s, CPU s of the process, why)."""
    import resource
    import time

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    try:
        done = subprocess.run([python, str(HERE / "opensim_moco_2d_walking.py")],
                              capture_output=True, text=True, timeout=60 * minutes,
                              env={**os.environ, "MOCO_2D_GAIT_DIR": folder})
    except subprocess.TimeoutExpired:
        return None, 0.0, 0.0, f"the Moco run did not finish in {minutes:g} min"
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    if done.returncode != 0 or not done.stdout.strip():
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return None, wall, cpu, f"the Moco run failed in {python}: {last}"
    return json.loads(done.stdout.strip().splitlines()[-1]), wall, cpu, ""


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


def solve_muscles(problem: str, extra: tuple[str, ...] = (), env: dict | None = None,
                  command: str = "solve") -> tuple[float, float, dict]:
    """One cold ``predgait COMMAND`` of a muscle problem file in a fresh process: (wall s,
    CPU s, summary).

    Cold: its own empty cache folder (no stored baseline), unless ``env`` gives one.
    """
    import resource
    import sys
    import time
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "predgait", command,
                               str(HERE.parent / "problems" / problem), "--out", str(out),
                               "--no-plots", *extra], capture_output=True, text=True,
                              env={**os.environ, "PREDGAIT_CACHE_DIR": str(Path(tmp) / "cache"),
                                   **(env or {})})
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
        if not (out / "summary.json").is_file():
            raise SystemExit(f"{problem}: {done.stderr.strip()[-400:]}")
        return wall, cpu, json.loads((out / "summary.json").read_text())


def bench_muscles(repeat: int, peer_repeat: int, peer_minutes: float,
                  moco_solution: str | None, coretypes: list[str]) -> None:
    """The muscle-driven prediction cold (fresh processes) against Moco's example run here,
    interleaved; Moco's solution from a file; BLAS kernels."""
    extra = (("--set", f"compare.moco_solution={os.path.abspath(moco_solution)}")
             if moco_solution else ())
    python, folder = opensim_python(), moco_folder()
    why = ("OPENSIM_PYTHON is not set to a Python that imports opensim" if python is None
           else "MOCO_2D_GAIT_DIR has no referenceGRF.xml" if folder is None else "")
    print(f"muscles: {load_text()} at the start")
    ours, peer = [], []
    for i in range(max(repeat, peer_repeat if not why else 0)):
        if i < repeat:
            ours.append(solve_muscles("predict_2d_muscles.toml", extra))
        if i < peer_repeat and not why:
            run = run_moco(python, folder, peer_minutes)
            why = run[3]
            if not why:
                peer.append(run)
    print(f"muscles: {load_text()} at the end")
    timing = Timing(tuple(w for w, _, _ in ours), tuple(c for _, c, _ in ours))
    s = ours[0][2]
    ip = s["ipopt"]
    print(f"predgait, muscles (2D_gait.osim, {s['nodes']} intervals, {s['transcription']}), "
          f"cold `predgait solve` incl. reading, fitting, building, checking, writing: "
          f"{timing.describe('s')}; build {s['build_s']:.1f} s, Ipopt {ip['iterations']} "
          f"iterations {ip['solve_time_s']:.1f} s, {ip['status']}, objective "
          f"{s['objective']:.5g}")
    if peer:
        first = peer[0][0]
        moco = Timing(tuple(w for _, w, _, _ in peer), tuple(c for _, _, c, _ in peer))
        stages = {k: Timing(tuple(r[0][k]["wall"] for r in peer),
                            tuple(r[0][k]["cpu"] for r in peer))
                  for k in ("tracking", "predictive")}
        print(f"{PEER} (OpenSim {first['version']}), cold process, tracking stage then "
              f"prediction: {moco.describe('s')}")
        for stage, t in stages.items():
            r = first[stage]
            print(f"    {stage}: {t.describe('s')}; {r['mesh_intervals']} mesh intervals "
                  f"({r['transcription']}), iterations {[x[0][stage]['iterations'] for x in peer]}"
                  f", {r['status']}, objective {r['objective']:.5g}")
        print(f"ratio Moco/predgait, whole cold processes (same model and predictive problem, "
              f"each side's recipe): {ratio(timing, moco)}")
        print(f"ratio Moco's predictive stage alone / predgait's whole process: "
              f"{ratio(timing, stages['predictive'])}")
    else:
        print(f"{PEER}: {NOT_AVAILABLE} ({why}; no ratio)")
    moco = s["moco"]
    if moco["available"]:
        print(f"  Moco's solution from {moco_solution}: objective {moco['objective']:.5g}; "
              f"ours/Moco objective {s['objective'] / moco['objective']:.2f}; kinematics RMS "
              + ", ".join(f"{k} {v:.1f}" for k, v in moco["kinematics_rms_deg"].items())
              + " deg")
    elif moco_solution:
        print(f"  Moco's solution: {moco['why']}")
    kernels = {}
    for kind in coretypes:
        kernels[kind] = solve_muscles("predict_2d_muscles.toml",
                                      env={"OPENBLAS_CORETYPE": kind})[2]
    if kernels:
        objectives = {k: v["objective"] for k, v in kernels.items()}
        curves = [v["right_leg_deg"] for v in kernels.values()]
        import numpy as np

        spread = max(float(np.max(np.abs(np.subtract(curves[0][j], c[j]))))
                     for c in curves for j in c)
        print(f"  OPENBLAS_CORETYPE: objectives {objectives}; right-leg angles differ by "
              f"up to {spread:.2f} deg between kernels")
    for scenario in SCENARIOS:
        with tempfile.TemporaryDirectory() as cache:
            env = {"PREDGAIT_CACHE_DIR": cache}
            wall, cpu, summary = solve_muscles(scenario, env=env, command="scenario")
            b, e = summary["baseline"]["ipopt"], summary["edited"]["ipopt"]
            print(f"  scenario {scenario}, cold `predgait scenario` {wall:.1f} s wall ({cpu:.1f}"
                  f" s CPU): baseline {b['iterations']} iterations {b['solve_time_s']:.1f} s, "
                  f"edited re-solve from the baseline {e['status']} {e['iterations']} "
                  f"iterations {e['solve_time_s']:.1f} s; its problem built in "
                  f"{summary['edited_problem_build_s']:.1f} s on a second thread while the "
                  f"baseline built and solved, waited {summary['edited']['build_s']:.1f} s for "
                  f"after it; {load_text()}")
            wall, cpu, again = solve_muscles(scenario, env=env, command="scenario")
            e = again["edited"]["ipopt"]
            print(f"    again, with the baseline that run stored (evaluated, not solved): "
                  f"{wall:.1f} s wall ({cpu:.1f} s CPU); edited build "
                  f"{again['edited_problem_build_s']:.1f} s, Ipopt {e['iterations']} iterations "
                  f"{e['solve_time_s']:.1f} s; same finding: "
                  f"{again['finding'] == summary['finding']}; {load_text()}")
    _, _, phys = solve_muscles("predict_2d_muscles_physiological.toml")
    print(f"  physiological bounds: {phys['status']}, objective {phys['objective']:.5g}; "
          f"{len(phys['warnings'])} of {len(phys['human_likeness'])} checks fail: "
          + "; ".join(str(w) for w in phys["warnings"]))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--nodes", type=int, nargs="+", default=[40, 50])
    parser.add_argument("--peer-repeat", type=int, default=1,
                        help="Moco runs (each about 35 min on a 2-core machine; default 1)")
    parser.add_argument("--peer-minutes", type=float, default=60.0,
                        help="stop each Moco run after this many minutes (default 60)")
    parser.add_argument("--case", choices=("gait7", "muscles", "both"), default="both")
    parser.add_argument("--moco-solution", help="Moco's gaitPrediction_solution.sto")
    parser.add_argument("--coretypes", nargs="*", default=[],
                        help="OPENBLAS_CORETYPE values to compare (e.g. Haswell SkylakeX)")
    args = parser.parse_args()
    if args.case in ("gait7", "both"):
        for nodes in args.nodes:
            bench(nodes, args.repeat)
        print(f"gait7 predictive: {NOT_AVAILABLE} (no other tool solves this problem; no ratio)")
    if args.case in ("muscles", "both"):
        bench_muscles(args.repeat, args.peer_repeat, args.peer_minutes, args.moco_solution,
                      args.coretypes)


if __name__ == "__main__":
    main()
