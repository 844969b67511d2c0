"""Muscle scenarios from two starts: the baseline's motion (cold) vs its primal-dual point (warm).

Usage: python benchmarks/scenario_starts.py [NAME ...] [--set KEY=VALUE ...]

NAME: shipped half-stride scenarios (problems/scenario_muscle_NAME.toml; default: the four
whose edits keep the baseline's structure: plantarflexor_weakness, soleus_contracture,
rectus_transfer, afo_2d). The baseline is solved once per process; each scenario's edited
problem is then built twice (:func:`predgait.scenarios.muscle_predict.edited_problem` with
``warm=False`` and ``warm=True``) and solved from the baseline's motion, the warm one with
the baseline's multipliers too (:data:`predgait.problems.muscle_gait.WARM_START`). Prints
per start: Ipopt iterations, solve seconds, objective, the right leg's swing knee peak and
ankle range, and the finding sentence (:func:`predgait.scenarios.muscle_scenario_compare.finding`).
``predgait scenario`` uses the warm start (module docstring of
:mod:`predgait.scenarios.muscle_predict`); this measures why. Times carry the load printed.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ("plantarflexor_weakness", "soleus_contracture", "rectus_transfer", "afo_2d")


def solve_from(run, base, built):
    """The edited MusclePrediction of ``built`` started as ``predgait scenario`` does."""
    from predgait.problems.muscle_prediction import MusclePrediction
    from predgait.scenarios import muscle_predict as mp

    bounds = mp.scenario_bounds(built.plant, built.planar, run.baseline, built.scenario,
                                whole=False)
    multipliers = base.gait.solved.multipliers if built.warm else None
    gait = built.problem.solve(base.gait.path, bounds, run.baseline.goal,
                               label="edited model", multipliers=multipliers)
    check = mp.scenario_check(built.plant, built.planar, built.scenario, gait)
    stride = mp.edited_stride(built.plant, gait, check, whole=False)
    return MusclePrediction(built.plant, built.planar, gait, (), check, stride, 0.0)


def main(argv=None) -> None:
    from predgait.scenarios import muscle_predict as mp
    from predgait.scenarios.muscle_scenario_compare import compare, finding, scenario_kind

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", default=DEFAULT)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override of the scenario file (e.g. baseline.grid.nodes=30)")
    args = parser.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.1f} (1 min)")
    for name in args.names:
        run = mp.load_muscle_scenario(ROOT / "problems" / f"scenario_muscle_{name}.toml",
                                      tuple(args.set))
        base = mp.baseline_prediction(run)
        kind = scenario_kind(run.spec.edits)
        scenario, plant = mp.edited_model(run, base.plant, base.planar)
        for warm in (False, True):
            built = mp.edited_problem(run, scenario, plant, warm=warm)
            clock = time.perf_counter()
            edited = solve_from(run, base, built)
            seconds = time.perf_counter() - clock
            s = edited.gait.solved
            right = compare(base, edited)["legs"]["r"]
            print(f"{name:24s} {'warm' if warm else 'cold'}: {s.status}, {s.iterations:4d} "
                  f"iterations, {seconds:5.1f} s, objective {s.objective:.6f} (baseline "
                  f"{base.gait.solved.objective:.6f}); swing knee "
                  f"{right['swing_knee_flexion_peak_deg']['edited']:.1f} deg, ankle range "
                  f"{right['range_deg']['ankle']['edited']:.1f} deg")
            print(f"    {finding(kind, compare(base, edited))}")


if __name__ == "__main__":
    main()
