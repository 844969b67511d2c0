"""``predgait batch``: a dataset's trials in parallel on Dask, then its tables and report.

The results folder holds ``batch.json`` (which dataset), ``trials/<id>/`` (one per trial,
each written whole as soon as it finishes, :mod:`predgait.workflows.batch_trial`) and, when
the run ends, the dataset files: ``results.csv`` (tidy long table; ``results.parquet`` too
when pyarrow is installed), ``curves.csv`` (mean +- SD per subject and condition),
``status.csv`` (per trial: status, cycles, flagged frames, reason), ``summary.json``,
``report.html`` and the figures. Trials run on a local Dask cluster (``workers``
processes, one thread each) or an existing scheduler, through the sweep's runner
(:func:`predgait.scenarios.sweep.run_sweep`: a failed trial is recorded with its reason,
the trials of a killed worker are rerun by Dask). ``resume`` skips the trials whose
whole result carries the same content hash (inputs, settings, predgait version).
"""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import json
import os
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from predgait import __version__
from predgait.errors import InputError
from predgait.report.dataset_tables import CURVES, TIDY, mean_curves, read_cycles, write_rows
from predgait.textfile import check_not_input
from predgait.workflows import batch_server
from predgait.workflows.batch_spec import Dataset
from predgait.workflows.batch_trial import TrialPoint, finished_digest, run_trial

BATCH_JSON = "batch.json"
STATUS = ("trial", "subject", "condition", "status", "cycles", "flagged_frames", "seconds",
          "reason")


@dataclass
class BatchRun:
    """What a batch did: per trial id its status row; counts; where it wrote."""

    out: Path
    rows: dict[str, dict] = field(default_factory=dict)
    ran: int = 0
    seconds: float = 0.0
    interrupted: str = ""

    def count(self, status: str) -> int:
        """Trials with this status."""
        return sum(row["status"] == status for row in self.rows.values())


def check_results_folder(out: Path, dataset: Dataset, *, resume: bool, force: bool) -> None:
    """Refuse a bad ``out`` before any work, then claim it.

    Refused: another dataset's results, files predgait did not write, or results of this
    dataset without ``resume`` / ``force``.
    """
    from predgait.workflows.output import check_out

    inputs = [dataset.path, *(p for job in dataset.trials for p in (job.markers, job.grf) if p)]
    if out.exists() and out.is_dir() and any(out.iterdir()):
        try:
            owner = json.loads((out / BATCH_JSON).read_text())["dataset"]
        except (OSError, ValueError, KeyError, TypeError):
            raise InputError(f"{out} holds files that are not predgait batch results; choose "
                             "another --out folder.") from None
        if owner != dataset.name:
            raise InputError(f"{out} holds the results of dataset '{owner}', not "
                             f"'{dataset.name}'; choose another --out folder.")
        if not (resume or force):
            raise InputError(f"{out} holds results of this dataset; add --resume to run only "
                             "the new, changed and failed trials, or --force to rerun all.")
    check_out(out, force=True, inputs=inputs)
    check_not_input(out, inputs)


def _publish(out: Path, fill) -> None:
    """Write the dataset files, each one whole.

    ``fill(folder)`` writes them into a temporary folder in ``out``; each file is then
    renamed into ``out``.
    """
    stage = Path(tempfile.mkdtemp(prefix=".dataset-", dir=out))
    try:
        fill(stage)
        for path in sorted(stage.iterdir()):
            os.replace(path, out / path.name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


@contextlib.contextmanager
def _local_cluster(workers: int, dataset: Dataset, todo: list[TrialPoint]):
    """A local Dask cluster's client (``workers`` processes, one thread each), or None.

    None: the runner's local processes (one worker, or dask is not installed). The workers
    fork from a forkserver (:mod:`predgait.workflows.batch_server`; started here unless
    the command started it already, and then ended here).
    """
    if workers <= 1 or importlib.util.find_spec("distributed") is None:
        yield None   # without dask: concurrent.futures processes, warm across trials too
        return
    first = todo[:workers]
    started = batch_server.start(dataset.path, first=first[-1].index + 1,
                                 trials=[p.job.id for p in first])
    method = "forkserver" if batch_server.running() else "spawn"
    import dask
    from dask.distributed import Client, LocalCluster

    from predgait.scenarios.sweep import _quiet_dask

    # also a killed worker's replacement is forked from the forkserver
    with dask.config.set({"distributed.worker.multiprocessing-method": method}):
        with _quiet_dask():
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=50)
            client = Client(cluster)
        try:
            yield client
        finally:
            with _quiet_dask(), contextlib.suppress(Exception):
                client.close(timeout=10)
                cluster.close(timeout=10)
            if started:
                batch_server.stop()


def run_batch(dataset: Dataset, out: str | Path, *, workers: int = 2,
              scheduler: str | None = None, resume: bool = False, force: bool = False,
              normative: Path | None = None, progress: bool = True,
              connect_timeout: float = 10.0) -> BatchRun:
    """Run the dataset's trials and write the results folder (see the module docstring).

    Raises:
        InputError: a bad results folder, normative file or scheduler, before any work.
    """
    from predgait.scenarios.sweep import SweepInterrupted, _dask_client, run_sweep

    out = Path(out)
    if workers < 1:
        raise InputError(f"--workers = {workers}: give at least 1.")
    check_results_folder(out, dataset, resume=resume, force=force)
    bands = None
    if normative is not None:
        from predgait.report.dataset_tables import read_normative

        bands = read_normative(normative)
    # An unreachable scheduler is an error now, before any work.
    client = _dask_client(scheduler, connect_timeout) if scheduler else None
    (out / "trials").mkdir(parents=True, exist_ok=True)
    (out / BATCH_JSON).write_text(json.dumps({"dataset": dataset.name,
                                              "predgait": __version__}) + "\n")
    run = BatchRun(out)
    todo = []
    for index, job in enumerate(dataset.trials):
        if resume and finished_digest(out / "trials" / job.id) == job.digest:
            run.rows[job.id] = _row(job, "unchanged", out=out)
        else:
            todo.append(TrialPoint(index, {}, job))
    task = functools.partial(run_trial, str(out.resolve()))
    started = time.perf_counter()
    given = contextlib.nullcontext(client) if client is not None else None
    try:
        with given or _local_cluster(min(workers, len(todo)), dataset,   # 0-1: here
                                     todo) as target:
            outcomes = run_sweep(task, todo, workers=workers, scheduler=target,
                                 progress=progress, desc="batch", unit="trial")
    except SweepInterrupted as exc:
        outcomes, run.interrupted = list(exc.finished.values()), str(exc)
    finally:
        if client is not None:
            with contextlib.suppress(Exception):
                client.close(timeout=5)
    run.seconds, run.ran = time.perf_counter() - started, len(outcomes)
    for outcome in outcomes:
        job = dataset.trials[outcome.point.index]
        if outcome.ok:
            status = "flagged" if outcome.metrics.get("flagged_frames") else "ok"
            run.rows[job.id] = _row(job, status, out=out)
        else:
            run.rows[job.id] = _row(job, "failed", reason=outcome.reason)
    for job in dataset.trials:
        run.rows.setdefault(job.id, _row(job, "not run"))
    run.rows = {job.id: run.rows[job.id] for job in dataset.trials}
    _write_dataset(run, dataset, bands)
    return run


def _row(job, status: str, *, out: Path | None = None, reason: str = "") -> dict:
    row = {"trial": job.id, "subject": job.subject, "condition": job.condition,
           "status": status, "cycles": 0, "flagged_frames": 0, "seconds": 0.0,
           "reason": reason}
    if out is not None:
        info = json.loads((out / "trials" / job.id / "trial.json").read_text())
        row |= {k: info[k] for k in ("cycles", "flagged_frames", "seconds")}
        row["reason"] = "; ".join(f"{name}: {n['status']}" for name, n in
                                  info["analyses"].items() if n["status"] != "completed")
    return row


def _write_dataset(run: BatchRun, dataset: Dataset, bands) -> None:
    """results.csv (+ .parquet), curves.csv, status.csv, summary.json, figures, report."""
    from predgait.report.dataset_report import write_report
    from predgait.report.tidy import write_summary

    whole = [run.out / "trials" / trial for trial, info in run.rows.items()
             if info["status"] in ("ok", "flagged", "unchanged")]
    cycles = [c for folder in whole for c in read_cycles(folder)]
    curves = mean_curves(cycles)
    failed = [r for r in run.rows.values() if r["status"] == "failed"]
    summary = {"dataset": dataset.name, "predgait": __version__,
               "status": ("incomplete: " + run.interrupted if run.interrupted else
                          "completed" if not failed else
                          f"completed with {len(failed)} failed trials"),
               "trials": len(run.rows),
               **{k: run.count(k) for k in ("ok", "flagged", "unchanged", "failed", "not run")},
               "cycles": len({(*c.key, c.cycle) for c in cycles}),
               "ran": run.ran, "wall_time_s": run.seconds,
               "trials_per_minute": 60 * run.ran / run.seconds if run.seconds else None,
               "failures": {r["trial"]: r["reason"] for r in failed}}

    def fill(stage: Path) -> None:
        with (stage / "results.csv").open("w") as handle:   # the trials' tidy rows, joined
            handle.write(",".join(TIDY) + "\n")
            for folder in whole:
                text = (folder / "cycles.csv").read_text()
                handle.write(text[text.index("\n") + 1:])
        write_rows(stage / "curves.csv", CURVES, curves)
        write_rows(stage / "status.csv", STATUS, ([r[k] for k in STATUS]
                                                  for r in run.rows.values()))
        write_summary(stage / "summary.json", summary)
        with contextlib.suppress(ImportError):
            _write_parquet(stage / "results.parquet", cycles)
        write_report(stage, dataset.name, list(run.rows.values()), cycles, curves, bands)

    _publish(run.out, fill)


def _write_parquet(path: Path, cycles) -> None:
    """The tidy table as Parquet (pyarrow; ImportError without it).

    Built column by column from the cycles' arrays: 101 rows per cycle.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    n = 101
    rows = pa.array(np.repeat(np.arange(len(cycles)), n))   # row -> its cycle

    def each(values: list) -> pa.Array:   # one entry per cycle -> one per row
        return pa.array(values).take(rows)

    columns = {name: each([c.key[i] for c in cycles]) for i, name in enumerate(TIDY[:5])}
    columns["cycle"] = each([c.cycle for c in cycles])
    columns["percent"] = np.tile(np.arange(n, dtype=np.int64), len(cycles))
    columns["variable"] = each([c.variable for c in cycles])
    columns["value"] = (np.concatenate([np.asarray(c.values, dtype=float) for c in cycles])
                        if cycles else np.empty(0))
    columns["unit"] = each([c.unit for c in cycles])
    columns["flagged"] = each([int(c.flagged) for c in cycles])
    pq.write_table(pa.table({k: columns[k] for k in TIDY}), path)
