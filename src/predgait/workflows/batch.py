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
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from predgait import __version__
from predgait.errors import InputError
from predgait.report.dataset_tables import (
    CURVES,
    TIDY,
    cycles_from_arrays,
    mean_curves,
    read_cycle_arrays,
    write_rows,
)
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


#: Dask's monitors that sample the cluster while trials run, which a batch does not read:
#: off, the workers' statistical profiler (every 10 ms) and GIL-contention poll (every
#: 1 ms); every 1 s instead of 20 ms, each server's event-loop health tick; every 5 s
#: instead of 0.5 s, the host CPU, memory and I/O samples (the dashboard's); every 1 s
#: instead of 0.1 s, the nannies' check of their worker's memory against its limits.
QUIET_WORKERS = {"distributed.worker.profile.enabled": False,
                 "distributed.admin.system-monitor.gil.enabled": False,
                 "distributed.admin.tick.interval": "1s",
                 "distributed.admin.system-monitor.interval": "5s",
                 "distributed.worker.memory.monitor-interval": "1s"}


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
    settings = {"distributed.worker.multiprocessing-method": method, **QUIET_WORKERS}
    with dask.config.set(settings):
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
    threading.Thread(target=_load_pyarrow, daemon=True).start()   # the tail's, meanwhile
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
    arrays = {}   # trial id -> its cycles' arrays, as the worker returned them
    for outcome in outcomes:
        job = dataset.trials[outcome.point.index]
        if outcome.ok:
            status = "flagged" if outcome.metrics.get("flagged_frames") else "ok"
            run.rows[job.id] = _row(job, status, out=out)
            if isinstance(outcome.payload, dict):
                arrays[job.id] = outcome.payload
        else:
            run.rows[job.id] = _row(job, "failed", reason=outcome.reason)
    for job in dataset.trials:
        run.rows.setdefault(job.id, _row(job, "not run"))
    run.rows = {job.id: run.rows[job.id] for job in dataset.trials}
    _write_dataset(run, dataset, bands, arrays)
    return run


def _load_pyarrow() -> None:
    """Import pyarrow's Parquet writer and its kernels (the table's, once; nothing without)."""
    with contextlib.suppress(ImportError):
        import pyarrow as pa
        import pyarrow.parquet  # noqa: F401

        pa.array([0]).take(pa.array([0]))


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


def _write_dataset(run: BatchRun, dataset: Dataset, bands, arrays: dict) -> None:
    """results.csv (+ .parquet), curves.csv, status.csv, summary.json, figures, report.

    ``arrays``: trial id -> its cycles' arrays as its worker returned them; the other
    whole trials' (unchanged, kept by ``resume``) are read from their ``cycles.npz``.
    """
    from predgait.report.dataset_report import write_report
    from predgait.report.tidy import write_summary

    whole = [trial for trial, info in run.rows.items()
             if info["status"] in ("ok", "flagged", "unchanged")]
    parts = [arrays[trial] if trial in arrays else
             read_cycle_arrays(run.out / "trials" / trial) for trial in whole]
    cycles = [c for part in parts for c in cycles_from_arrays(part)]
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
        import concurrent.futures

        # the Parquet table is built and written (pyarrow, without the GIL) meanwhile
        with concurrent.futures.ThreadPoolExecutor(1) as pool:
            parquet = pool.submit(_write_parquet, stage / "results.parquet", parts)
            _join_tables(stage / "results.csv",
                         [run.out / "trials" / trial / "cycles.csv" for trial in whole])
            write_rows(stage / "curves.csv", CURVES, curves)
            write_rows(stage / "status.csv", STATUS, ([r[k] for k in STATUS]
                                                      for r in run.rows.values()))
            write_summary(stage / "summary.json", summary)
            write_report(stage, dataset.name, list(run.rows.values()), cycles, curves, bands)
            with contextlib.suppress(ImportError):
                parquet.result()

    _publish(run.out, fill)


def _join_tables(path: Path, tables: list[Path]) -> None:
    """The tidy table: its header line, then each trial's ``cycles.csv`` after its header.

    Copied as bytes (by the kernel where it can), the same text as read and written.
    """
    with path.open("w") as handle:
        handle.write(",".join(TIDY) + "\n")
        handle.flush()
        target = handle.buffer.raw if hasattr(handle.buffer, "raw") else handle.buffer
        for table in tables:
            with table.open("rb") as source:
                source.readline()   # its header
                start, size = source.tell(), os.fstat(source.fileno()).st_size
                _copy(source, target, start, size - start)


def _copy(source, target, start: int, count: int) -> None:
    """``count`` bytes of ``source`` from ``start`` appended to ``target`` (files)."""
    copy = getattr(os, "copy_file_range", None)
    if copy is not None:
        try:
            while count > 0:
                done = copy(source.fileno(), target.fileno(), count, start)
                if done == 0:
                    break
                start, count = start + done, count - done
            if count <= 0:
                return
        except OSError:
            pass   # e.g. a file system without it: the rest by reading and writing
    source.seek(start)
    while count > 0:
        chunk = source.read(min(count, 1 << 22))
        if not chunk:
            break
        target.write(chunk)
        count -= len(chunk)


def _write_parquet(path: Path, parts: list[dict]) -> None:
    """The tidy table as Parquet (pyarrow; ImportError without it).

    Built column by column from the trials' cycle arrays (:func:`cycle_arrays`): 101 rows
    per cycle; the same table (types and values) as built from the rows.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    n = 101
    keys = np.concatenate([p["keys"] for p in parts]) if parts else np.empty((0, 8), str)
    count = len(keys)
    if not count:   # as from no rows: the text and number columns without a type
        columns = {name: pa.array([]) for name in TIDY}
        columns["percent"], columns["value"] = np.empty(0, np.int64), np.empty(0)
        pq.write_table(pa.table({k: columns[k] for k in TIDY}), path)
        return
    rows = pa.array(np.repeat(np.arange(count), n))   # row -> its cycle

    def text(column: int) -> pa.Array:   # one string per cycle -> one per row
        unique, index = np.unique(keys[:, column], return_inverse=True)
        return pa.array(unique.tolist(), type=pa.string()).take(
            pa.array(np.repeat(index.reshape(-1), n)))

    columns = {name: text(i) for i, name in enumerate(TIDY[:5])}
    columns["cycle"] = pa.array(keys[:, 5].astype(np.int64)).take(rows)
    columns["percent"] = np.tile(np.arange(n, dtype=np.int64), count)
    columns["variable"] = text(6)
    columns["value"] = np.concatenate([p["values"] for p in parts]).reshape(-1)
    columns["unit"] = text(7)
    columns["flagged"] = pa.array(
        np.concatenate([p["flagged"] for p in parts]).astype(np.int64)).take(rows)
    pq.write_table(pa.table({k: columns[k] for k in TIDY}), path)
