"""Is the muscle-driven prediction one answer? Grids, multi-start, BLAS kernels, Moco (issue 26.6).

Moco's example2DWalking prediction (problems/predict_2d_muscles.toml: Moco's bounds, goal
and guess) on the bundled 2D_gait.osim:

* grids: solved on each of ``--grids`` (default 30 50 75 intervals) from the reference
  coordinates, in one process (one model and path fit); per grid the status, iterations,
  solve time, objective, half-stride duration; then the right-leg kinematics RMS (deg)
  between every pair of grids from each one's own right heel strike
  (:mod:`predgait.problems.gait_agreement`; the issue's goal: within 3 deg);
* Moco: with ``--moco DIR`` (gaitPrediction_solution.sto and its _fullcycle_grf.sto, e.g.
  tests/reference/osim2d/moco_prediction), each grid's objective over Moco's and its
  kinematics RMS against Moco's solution (goal: objective equal or lower, within 5 deg);
* multi-start (``--starts N``, 0 to skip) on ``--nodes`` (50): the reference guess, Moco's
  tracking solution (``--tracking``), the 30-interval solution resampled and seeded
  perturbations (:mod:`predgait.problems.muscle_multistart`): best, spread, converged;
* OpenBLAS kernels (``--coretypes``, default: the machine's own and Haswell): one fresh
  process per OPENBLAS_CORETYPE solving ``--nodes`` intervals; each reports the kernel that
  actually ran (openblas_get_corename of CasADi's own OpenBLAS, which MUMPS calls, and of
  NumPy's via threadpoolctl when it is importable), objective, iterations and curves; then
  the differences.

Run:  OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_predict_grids.py
      [--grids 30 50 75] [--nodes 50] [--starts 4] [--moco DIR] [--tracking FILE]
      [--coretypes default Haswell]
The load average is printed: the figures are from a shared 2-core machine.

Measured (2026-12-04, commit 11db466 of branch muscles, load average 2-5 on 2 cores;
solve times are wall under that load):

    intervals | iterations | solve s | objective | half stride s
    30        | 93         | 13.4    | 0.137695  | 0.5058
    50        | 87         | 26.8    | 0.133524  | 0.4999
    75        | 114        | 23.5    | 0.133589  | 0.4998
    RMS from heel strike (hip, knee, ankle deg): 30-50 0.56, 0.61, 0.85; 30-75 0.55,
    0.57, 0.89; 50-75 0.11, 0.12, 0.10 (goal 3 deg: met).
    vs Moco's solution (objective 0.021924, 274 iterations, 1956 s): objective 6.09x
    (50), RMS hip 25.0, knee 35.4, ankle 9.3 deg (goal equal or lower, 5 deg: NOT met;
    same at 30 and 75, so not a grid effect).
    multi-start, 50 intervals, 4 starts, 4 converged: reference 0.133524 (best),
    Moco's tracking solution 0.133566, perturbed (seed 0) 0.133535, both within 0.02 deg
    of the best; the 30-interval solution resampled converged to another optimum,
    0.167195 (+25 %), up to 8.2 deg (ankle) away: median 0.13355, max 0.167195.
    OPENBLAS_CORETYPE default (NumPy/SciPy: SkylakeX) vs Haswell: CasADi's own OpenBLAS
    0.3.24, the one MUMPS calls, is built for CORE2 without DYNAMIC_ARCH and reports CORE2
    under both, so the solver's kernel does not change; NumPy's does, and its rounding
    (the reference guess differs by up to 2e-12) moves Ipopt's path: 50 intervals
    +0.012 % objective, 87 vs 91 iterations, RMS <= 0.014 deg; 30 intervals -1.66 %,
    93 vs 110 iterations, RMS <= 0.27 deg.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def setup(nodes: int):
    """(plant, planar, problem, storage, guess, bounds, goal) of Moco's problem."""
    from predgait.data.bundled import bundled_path
    from predgait.data.storage import read_storage
    from predgait.models.osim import bundled_2d_gait
    from predgait.problems.muscle_gait import Goal, MuscleGaitProblem
    from predgait.problems.muscle_gait_setup import (
        MOCO_BOUNDS,
        bounds_for,
        plant_2d_gait,
        reference_guess,
    )

    plant, planar = plant_2d_gait(bundled_2d_gait())
    storage = read_storage(bundled_path("moco_2d_walking/referenceCoordinates.sto"))
    bounds = bounds_for(plant, planar, MOCO_BOUNDS, (0.4, 0.6))
    problem = MuscleGaitProblem(plant, nodes, tx_row=0, max_iter=3000)
    guess, _ = reference_guess(planar, storage, plant, problem.n)
    return plant, planar, problem, storage, guess, bounds, Goal()


def kernels() -> dict:
    """The OpenBLAS kernel each loaded OpenBLAS runs (after a solve loaded them)."""
    import casadi

    out = {}
    lib = Path(casadi.__file__).parent / "libcasadi-tp-openblas.so.0"
    if lib.is_file():
        blas = ctypes.CDLL(str(lib))
        blas.openblas_get_corename.restype = ctypes.c_char_p
        out["casadi (MUMPS)"] = blas.openblas_get_corename().decode()
    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        out["numpy"] = "threadpoolctl not importable"
    else:
        for info in threadpool_info():
            if info.get("internal_api") == "openblas":
                out[Path(info["filepath"]).name] = info.get("architecture")
    return out


def child(nodes: int) -> None:
    """One solve; prints a JSON line (objective, iterations, kernels, curves)."""
    from predgait.problems.gait_agreement import gait_curves

    plant, planar, problem, _, guess, bounds, goal = setup(nodes)
    gait = problem.solve(guess, bounds, goal)
    s = gait.solved
    curves = gait_curves(plant, planar, gait) if s.success else {}
    print(json.dumps({"status": s.status, "iterations": s.iterations, "objective":
                      s.objective, "seconds": s.seconds, "kernels": kernels(),
                      "curves": {k: v.tolist() for k, v in curves.items()}}))


def grids_table(grids: list[int], moco: Path | None) -> None:
    from predgait.problems.gait_agreement import (
        agreement_table,
        gait_curves,
        moco_curves,
        rms_deg,
    )
    from predgait.problems.muscle_gait import MuscleGaitProblem
    from predgait.problems.muscle_gait_setup import reference_guess

    plant, planar, _, storage, _, bounds, goal = setup(grids[0])
    curves, objectives = {}, {}
    print("intervals | status | iterations | solve s | objective | half stride s")
    for n in grids:
        problem = MuscleGaitProblem(plant, n, tx_row=0, max_iter=3000)
        guess, _ = reference_guess(planar, storage, plant, problem.n)
        gait = problem.solve(guess, bounds, goal)
        s = gait.solved
        print(f"{n} | {s.status} | {s.iterations} | {s.seconds:.1f} | {s.objective:.6g} | "
              f"{gait.path.duration:.4f}", flush=True)
        if s.success:
            curves[f"{n}"], objectives[f"{n}"] = gait_curves(plant, planar, gait), s.objective
    print("grid a | grid b | hip | knee | ankle RMS deg (from right heel strike) | max")
    for row in agreement_table(curves):
        print(f"{row['a']} | {row['b']} | {row['hip']:.2f} | {row['knee']:.2f} | "
              f"{row['ankle']:.2f} | {row['max']:.2f}" + ("" if row["max"] <= 3.0
                                                            else "  (> 3 deg goal)"))
    if moco is None:
        return
    from predgait.data.storage import read_storage

    solution = moco / "gaitPrediction_solution.sto"
    theirs = moco_curves(solution, moco / "gaitPrediction_solution_fullcycle_grf.sto")
    moco_objective = float(read_storage(solution).header["objective"])
    print(f"vs Moco ({solution}, objective {moco_objective:.6g}):")
    for label, mine in curves.items():
        rms = rms_deg(mine, theirs)
        print(f"  {label} intervals: objective / Moco's {objectives[label] / moco_objective:.3f};"
              " RMS " + ", ".join(f"{k} {v:.2f}" for k, v in rms.items()) + " deg")


def multistart_run(nodes: int, starts: int, tracking: Path | None) -> None:
    from predgait.problems.muscle_multistart import MultiStartOptions, StartRun, multistart

    plant, planar, problem, storage, guess, bounds, goal = setup(nodes)
    first = StartRun("reference coordinates", problem.solve(guess, bounds, goal))
    options = MultiStartOptions(starts=starts, grids=(30,) if nodes != 30 else (),
                                tracking_solution=tracking)
    result = multistart(problem, plant, planar, storage, bounds, goal, options, first,
                        max_iter=3000)
    sp = result.spread
    print(f"multi-start on {nodes} intervals: {sp['converged']} of {sp['starts']} converged; "
          f"objective min {sp['objective_min']:.6g}, median {sp['objective_median']:.6g}, "
          f"max {sp['objective_max']:.6g}; best: {sp['best']}; kinematics RMS vs best up "
          f"to {sp['max_kinematics_rms_deg_vs_best']:.2f} deg")
    for r in sp["runs"]:
        rms = r.get("kinematics_rms_deg_vs_best")
        print(f"  {r['start']}: {r['status']}, {r['iterations']} iterations, "
              f"{r['solve_time_s']:.1f} s, objective {r['objective']:.6g}"
              + ("; RMS vs best " + ", ".join(f"{k} {v:.2f}" for k, v in rms.items())
                 if rms else ""))


def coretype_runs(nodes: int, coretypes: list[str]) -> None:
    from predgait.problems.gait_agreement import rms_deg

    runs = {}
    for kind in coretypes:
        env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
        if kind != "default":
            env["OPENBLAS_CORETYPE"] = kind
        clock = time.perf_counter()
        done = subprocess.run([sys.executable, __file__, "--child", str(nodes)], env=env,
                              capture_output=True, text=True)
        if done.returncode != 0:
            print(f"OPENBLAS_CORETYPE={kind}: failed: {done.stderr.strip()[-300:]}")
            continue
        runs[kind] = json.loads(done.stdout.strip().splitlines()[-1])
        r = runs[kind]
        print(f"OPENBLAS_CORETYPE={kind}: kernels {r['kernels']}; {r['status']}, "
              f"{r['iterations']} iterations, solve {r['seconds']:.1f} s (process "
              f"{time.perf_counter() - clock:.1f} s), objective {r['objective']:.8g}",
              flush=True)
    labels = [k for k in runs if runs[k]["curves"]]
    for a, b in zip(labels, labels[1:], strict=False):
        ca = {k: np.array(v) for k, v in runs[a]["curves"].items()}
        cb = {k: np.array(v) for k, v in runs[b]["curves"].items()}
        rms = rms_deg(ca, cb)
        dobj = runs[b]["objective"] / runs[a]["objective"] - 1.0
        print(f"  {a} vs {b}: objective {100 * dobj:+.4f} %, iterations "
              f"{runs[a]['iterations']} vs {runs[b]['iterations']}, RMS "
              + ", ".join(f"{k} {v:.3f}" for k, v in rms.items()) + " deg")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grids", type=int, nargs="*", default=[30, 50, 75])
    parser.add_argument("--nodes", type=int, default=50)
    parser.add_argument("--starts", type=int, default=4)
    parser.add_argument("--moco", type=Path,
                        default=HERE.parent / "tests" / "reference" / "osim2d" / "moco_prediction")
    parser.add_argument("--tracking", type=Path, default=None,
                        help="Moco's gaitTracking_solution.sto (a multi-start start)")
    parser.add_argument("--coretypes", nargs="*", default=["default", "Haswell"])
    parser.add_argument("--child", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child)
        return
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; "
          f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}, "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}", flush=True)
    moco = args.moco if (args.moco / "gaitPrediction_solution.sto").is_file() else None
    if args.grids:
        grids_table(args.grids, moco)
    if args.starts > 1:
        multistart_run(args.nodes, args.starts, args.tracking)
    if args.coretypes:
        coretype_runs(args.nodes, args.coretypes)


if __name__ == "__main__":
    main()
