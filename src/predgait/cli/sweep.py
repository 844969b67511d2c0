"""``predgait sweep``: a grid or random sample of scenario parameters, run in parallel."""

from __future__ import annotations

import argparse
import csv
import functools
import time
from pathlib import Path

from predgait.cli import add_output_options

DESCRIPTION = """\
Run a scenario file over a grid or a random sample of its parameters (any key that
'predgait scenario --set' accepts, e.g. edit.0.k). Runs in local processes (--workers)
or on a Dask cluster (--scheduler tcp://HOST:PORT; needs pip install ".[dask]"). A failed
or diverged run is recorded with its reason and the sweep goes on; the exit status is 1
when any point failed, unless --allow-failures. Writes results.csv, summary.json and
plots (outcome against parameter; a heat map for a 2-D grid) into --out.
A sweep whose Dask scheduler is lost writes the points that finished (the others are
'not run' in results.csv, summary.json says incomplete); --resume on the same --out runs
only those and completes the folder.
Example: problems/sweep_knee_stiffness.toml.
"""


METRICS_PLOTTED = ("knee_rms_change_deg", "knee_extra_feedback_rms_n_m", "knee_peak_angle_deg")


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``sweep``."""
    cmd = commands.add_parser("sweep", help="parameter sweep of a scenario (parallel, Dask)",
                              description=DESCRIPTION,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    cmd.add_argument("sweep", type=Path, help="SWEEP.toml")
    cmd.add_argument("--workers", type=int, default=2, metavar="N",
                     help="local worker processes (default 2)")
    cmd.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address")
    cmd.add_argument("--allow-failures", action="store_true",
                     help="exit 0 even when some points failed or diverged")
    cmd.add_argument("--resume", action="store_true",
                     help="finish the incomplete sweep in --out (run only its 'not run' "
                          "points; the finished ones are kept)")
    add_output_options(cmd)
    cmd.set_defaults(run=run)


def sweep_points(path: Path):
    """The scenario path and the points of a sweep file."""
    from predgait.problemfile import load_problem
    from predgait.scenarios.sweep import grid_points, random_points

    table = load_problem(path)
    table.expect_command("sweep")
    table.check_keys(("scenario", "grid", "random"))
    scenario = table.path_value("scenario")
    if not scenario.is_file():
        raise table.error("scenario", f"{scenario} not found.")
    if table.has("grid") == table.has("random"):
        raise table.error("grid", "give exactly one of [grid] or [random].")
    if table.has("grid"):
        grid = table.table("grid")
        axes = {}
        for key in grid.data:
            values = grid.get(key, list)
            if not values or not all(isinstance(v, int | float) for v in values):
                raise grid.error(key, "give a list of numbers.")
            axes[key] = values
        return scenario, grid_points(axes)
    rnd = table.table("random")
    rnd.check_keys(("count", "seed", "ranges"))
    ranges = rnd.table("ranges", required=True)
    bounds = {}
    for key in ranges.data:
        pair = ranges.get(key, list)
        if len(pair) != 2 or not pair[0] < pair[1]:
            raise ranges.error(key, "give [low, high] with low < high.")
        bounds[key] = (float(pair[0]), float(pair[1]))
    return scenario, random_points(bounds, int(rnd.number("count", low=1, high=10000)),
                                   seed=int(rnd.number("seed", 0, low=0, high=2**31)))


def _baseline(scenario: Path, keys) -> dict:
    """The scenario file's own value of each swept key (``edit.0.k`` style), if it has one."""
    from predgait.problemfile import load_problem

    values = {}
    for key in keys:
        node = load_problem(scenario).data
        for part in key.split("."):
            node = node[int(part)] if isinstance(node, list) and part.isdigit() else (
                node.get(part) if isinstance(node, dict) else None)
            if node is None:
                break
        if isinstance(node, int | float):
            values[key] = float(node)
    return values


def finished_outcomes(out: Path, points) -> dict:
    """The finished points of an earlier (incomplete) sweep in ``out``, by index.

    Raises:
        InputError: No results.csv in ``out``, or its points are not this sweep's.
    """
    from predgait.errors import InputError
    from predgait.scenarios.sweep import PointStatus, SweepOutcome

    path = out / "results.csv"
    try:  # not read_text: an input may not be overwritten, and this folder will be
        rows = list(csv.reader(path.read_text(encoding="utf-8").splitlines()))
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"--resume: cannot read {path} ({exc}); resume the --out folder of "
                         "an interrupted sweep (or drop --resume).") from None
    header, by_index = (rows or [[]])[0], {p.index: p for p in points}
    if "status" not in header or header[0] != "index" or header[-2:] != ["seconds", "reason"]:
        raise InputError(f"{path}: line 1 is not the header of a predgait sweep results.csv.")
    status_at = header.index("status")
    params, metrics = header[1:status_at], header[status_at + 1:-2]
    checks = _earlier_checks(out)
    finished = {}
    for number, row in enumerate(rows[1:], start=2):
        try:
            point = by_index[int(row[0])]
            same = (len(row) == len(header) and set(params) == set(point.values)
                    and all(float(row[1 + i]) == float(point.values[name])
                            for i, name in enumerate(params)))
            values = [float(v) for v in row[status_at + 1:-2]]
            seconds = float(row[-2])
        except (KeyError, ValueError, IndexError):
            same = False
        if not same:
            raise InputError(f"{path}: line {number} is not a point of this sweep file; "
                             "--resume the folder this sweep wrote.")
        try:
            status = PointStatus(row[status_at])
        except ValueError:
            raise InputError(f"{path}: line {number} has the status '{row[status_at]}'; "
                             f"a sweep writes {', '.join(map(repr, PointStatus))}.") from None
        if status is PointStatus.NOT_RUN:
            continue
        found = {name: v for name, v in zip(metrics, values, strict=True) if v == v}
        ok = status is PointStatus.OK
        finished[point.index] = SweepOutcome(point, ok, found if ok else {},
                                             reason=row[-1], seconds=seconds, status=status,
                                             checks=checks.get(point.index, ()))
    return finished


def _earlier_checks(out: Path) -> dict:
    """Point index -> plausibility checks the earlier run of a resumed sweep recorded.

    From its summary.json (``plausibility``); none when it has none or cannot be read.
    """
    import json

    from predgait.scenarios.sweep import checks_by_point

    try:
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
        return checks_by_point(summary.get("plausibility", []))
    except (OSError, ValueError, TypeError, AttributeError):
        return {}


def run(args: argparse.Namespace) -> int:
    """Run the sweep and write its results."""
    from predgait.analysis.plausibility import warning_lines
    from predgait.errors import PredgaitError
    from predgait.scenarios.run import load_scenario, scenario_metrics
    from predgait.scenarios.sweep import (
        PointStatus,
        SweepInterrupted,
        SweepOutcome,
        run_sweep,
    )
    from predgait.workflows.output import check_out

    force = args.force or args.resume  # --resume completes its own folder
    check_out(args.out, force=force, inputs=[args.sweep])  # before any computation
    scenario, points = sweep_points(args.sweep)
    load_scenario(scenario)  # a bad scenario file fails here, once, not in every run
    check_out(args.out, force=force, inputs=[args.sweep, scenario])
    finished = finished_outcomes(args.out, points) if args.resume else {}
    started = time.perf_counter()
    task = functools.partial(scenario_metrics, scenario.resolve())  # any worker's folder
    todo = [p for p in points if p.index not in finished]
    try:
        ran = run_sweep(task, todo, workers=args.workers, scheduler=args.scheduler)
        lost = None
    except SweepInterrupted as exc:
        ran, lost = list(exc.finished.values()), exc
    outcomes = {**finished, **{o.point.index: o for o in ran}}
    seconds = time.perf_counter() - started
    if lost is not None:
        outcomes = [outcomes.get(p.index) or SweepOutcome(p, False, status=PointStatus.NOT_RUN)
                    for p in points]
        _write(args, scenario, outcomes, seconds, force, len(ran), incomplete=str(lost))
        raise PredgaitError(f"{lost}; wrote the {len(finished) + len(ran)} finished points to "
                            f"{args.out}/results.csv (the others are "
                            f"'{PointStatus.NOT_RUN}'); run the same "
                            "command with --resume to finish the rest.")
    outcomes = [outcomes[p.index] for p in points]
    failed, summary = _write(args, scenario, outcomes, seconds, force, len(ran))
    print(f"sweep: {len(outcomes)} runs ({len(failed)} failed) in {seconds:.1f} s "
          f"({len(ran) / seconds:.2f} per s); wrote {args.out}/")
    for line in warning_lines(summary):
        print(line)
    if failed and not args.allow_failures:
        import sys

        first = failed[0]
        print(f"predgait: error: {len(failed)} of {len(outcomes)} sweep points failed (first: "
              f"{dict(first.point.values)}: {first.reason}); see {args.out}/results.csv. "
              "Add --allow-failures to accept them.", file=sys.stderr)
        return 1
    return 0


def _write(args, scenario: Path, outcomes, seconds: float, force: bool, ran: int, *,
           incomplete: str = "") -> list:
    """Write results.csv, summary.json and the plots; return the failed outcomes, summary.

    summary.json records every point's plausibility checks, named after the point
    (:func:`predgait.analysis.plausibility.record`: ``warnings``, a status "... with
    warnings" / "... and warnings").

    ``ran``: the points run in ``seconds`` (a resumed sweep ran only the rest).
    """
    from predgait.analysis.plausibility import record
    from predgait.report.figures import plots_wanted
    from predgait.report.sweep_plots import save_sweep_plots
    from predgait.report.tidy import write_summary
    from predgait.scenarios.sweep import PointStatus, labelled_checks, outcomes_table
    from predgait.textfile import source_name
    from predgait.workflows.output import staged_output

    with staged_output(args.out, force=force, inputs=[args.sweep, scenario]) as stage:
        header, rows = outcomes_table(outcomes)
        with (stage / "results.csv").open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(header)
            writer.writerows(rows)
        done = [o for o in outcomes if o.status is not PointStatus.NOT_RUN]
        failed = [o for o in done if not o.ok]
        diverged = [o for o in failed if o.status is PointStatus.DIVERGED]
        status = ("completed" if not failed else
                  f"completed with failures: {len(failed)} of {len(outcomes)} points "
                  f"({len(diverged)} diverged) have no result")
        if incomplete:
            status = (f"incomplete: {len(outcomes) - len(done)} of {len(outcomes)} points not "
                      f"run ({incomplete}); finish with --resume")
        summary = {"status": status,
                   "scenario": source_name(scenario), "runs": len(done),
                   "not_run": len(outcomes) - len(done),
                   "failed": len(failed), "diverged": len(diverged),
                   "failures": [{"point": o.point.values, "reason": o.reason} for o in failed],
                   "wall_time_s": seconds, "scenarios_per_second": ran / seconds,
                   "workers": "dask" if args.scheduler else args.workers}
        summary = write_summary(stage / "summary.json",
                                record(summary, labelled_checks(done)))
        if plots_wanted() and done and not incomplete:
            save_sweep_plots(done, stage, METRICS_PLOTTED,
                             baseline=_baseline(scenario, outcomes[0].point.values))
    return failed, summary
