"""``predgait batch``: every trial of a dataset file, in parallel, into one results folder."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from predgait.cli import add_output_options

DESCRIPTION = """\
Analyse every trial of a dataset file (TOML: [[subjects]] with mass, height, static trial,
leg problem files and/or marker map; [[trials]] with subject, condition and the marker
files by glob or list; see problems/batch_subject01.toml): per trial the planar leg inverse
dynamics (each side the subject's problem files name) and/or the 35-DOF full-body one.
Trials run on a local Dask cluster (--workers N processes, which keep Python and the
models warm), or on an existing one (--scheduler tcp://HOST:PORT); without dask installed
they run in local processes. A failed trial is recorded with its reason and the rest go
on; each finished trial's folder (trials/<id>/: the files of 'predgait inverse') is whole
as soon as it finishes, so an interrupted run loses nothing finished. --resume runs only
the trials that are new, changed (content hash of inputs and settings) or failed.
Writes results.csv (tidy long table: subject, condition, trial, analysis, side, cycle,
percent, variable, value, unit, flagged; results.parquet too when pyarrow is installed),
curves.csv (mean +- SD per subject and condition, and over all subjects), status.csv,
summary.json and report.html with its figures. Exit status 1 when a trial failed, unless
--allow-failures.
"""


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``batch``."""
    cmd = commands.add_parser("batch", help="every trial of a dataset, in parallel (Dask)",
                              description=DESCRIPTION,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    cmd.add_argument("dataset", type=Path, help="DATASET.toml")
    cmd.add_argument("--workers", type=int, default=2, metavar="N",
                     help="local Dask worker processes (default 2; 1, or one trial to run: "
                          "in this process)")
    cmd.add_argument("--scheduler", metavar="ADDRESS",
                     help="an existing Dask scheduler, tcp://HOST:PORT (its workers need "
                          "predgait, and the trial files and --out at the same paths: one "
                          "machine or a shared file system)")
    cmd.add_argument("--resume", action="store_true",
                     help="keep the whole results of unchanged trials in --out; run the rest")
    cmd.add_argument("--normative", type=Path, metavar="BAND.csv",
                     help="normative band drawn under the curves: CSV with variable, percent, "
                          "mean, sd (the variables' units: deg, N m/kg)")
    cmd.add_argument("--allow-failures", action="store_true",
                     help="exit 0 even when some trials failed")
    add_output_options(cmd)
    cmd.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Check the dataset, run its trials, write the results folder."""
    from predgait.workflows import batch_server

    # the workers' forkserver imports Dask and warms up while this process reads the dataset
    early = batch_server.wanted(args.workers, args.scheduler) and \
        args.dataset.is_file() and batch_server.start(args.dataset, first=args.workers)
    try:
        return _run(args)
    finally:
        if early:
            batch_server.stop()


def _run(args: argparse.Namespace) -> int:
    from predgait.errors import PredgaitError
    from predgait.workflows.batch import run_batch
    from predgait.workflows.batch_spec import read_dataset

    dataset = read_dataset(args.dataset)
    try:
        batch = run_batch(dataset, args.out, workers=args.workers, scheduler=args.scheduler,
                          resume=args.resume, force=args.force, normative=args.normative)
    except KeyboardInterrupt:   # every finished trial's folder is whole
        whole = len(list((args.out / "trials").glob("*/trial.json")))
        print(f"predgait: interrupted; {whole} finished trials are whole in {args.out}/trials; "
              "run the same command with --resume to finish the rest.", file=sys.stderr)
        return 130
    counts = ", ".join(f"{batch.count(s)} {s}" for s in ("ok", "flagged", "unchanged",
                                                          "failed", "not run")
                       if batch.count(s))
    rate = f" ({60 * batch.ran / batch.seconds:.1f} per minute)" if batch.ran else ""
    print(f"batch {dataset.name}: {len(batch.rows)} trials ({counts}); ran {batch.ran} in "
          f"{batch.seconds:.1f} s{rate}; wrote {args.out}/")
    if batch.interrupted:
        raise PredgaitError(f"{batch.interrupted}; the finished trials are in {args.out}/trials; "
                            "run the same command with --resume to finish the rest.")
    failed = [r for r in batch.rows.values() if r["status"] == "failed"]
    if failed and not args.allow_failures:
        print(f"predgait: error: {len(failed)} of {len(batch.rows)} trials failed (first: "
              f"{failed[0]['trial']}: {failed[0]['reason']}); see {args.out}/status.csv. "
              "Add --allow-failures to accept them.", file=sys.stderr)
        return 1
    return 0
