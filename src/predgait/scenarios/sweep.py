"""Parameter sweeps: a grid or a random sample of ``--set`` overrides, run in parallel.

Points run in local processes by default (``concurrent.futures``) or on a Dask cluster
(``dask.distributed``, imported only then) when a scheduler address is given. A point
that fails is recorded with its reason and the sweep goes on. Results come back in the
order of the points, whatever order they finished in. A Dask scheduler lost mid-sweep
raises :class:`SweepInterrupted` holding the points that had finished (the CLI writes
them and ``--resume`` runs the rest).
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import enum
import itertools
import logging
import math
import os
import re
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field, replace

import numpy as np

from predgait.analysis.plausibility import Check
from predgait.errors import InputError, PredgaitError, SimulationDiverged

#: The metric holding a point's number of failed plausibility checks (a float, as every
#: metric: results.csv is read back as numbers by --resume).
WARNINGS_METRIC = "plausibility_warnings"


@dataclass(frozen=True)
class SweepPoint:
    """One point: its index and the ``key=value`` overrides that define it."""

    index: int
    values: Mapping[str, float]

    @property
    def overrides(self) -> tuple[str, ...]:
        """The point as ``--set`` assignments."""
        return tuple(f"{key}={value!r}" for key, value in self.values.items())


def point_label(point: SweepPoint) -> str:
    """How a point's warnings name it: ``point 3 (edit.0.k=100.0)``."""
    values = ", ".join(f"{k}={v!r}" for k, v in point.values.items())
    return f"point {point.index} ({values})"


@dataclass(frozen=True)
class PointResult:
    """What a task may return instead of bare metrics: metrics and plausibility checks.

    ``checks``: :class:`~predgait.analysis.plausibility.Check` of the point's result
    (the same checks as the single run of its command).
    """

    metrics: Mapping[str, float]
    checks: tuple[Check, ...] = ()
    payload: object = None   # anything else the caller wants back (picklable)


class PointStatus(enum.StrEnum):
    """How a sweep point ended (results.csv's ``status`` column)."""

    OK = "ok"
    FAILED = "failed"
    DIVERGED = "diverged"
    NOT_RUN = "not run"   # an interrupted sweep did not reach it


@dataclass(frozen=True)
class SweepOutcome:
    """What one point gave: metrics, or the reason it failed."""

    point: SweepPoint
    ok: bool
    metrics: Mapping[str, float] = field(default_factory=dict)
    reason: str = ""
    seconds: float = 0.0
    status: PointStatus | None = None   # None: OK or FAILED from ``ok``
    checks: tuple[Check, ...] = ()      # plausibility of the point's result
    payload: object = None              # the task's PointResult.payload

    def __post_init__(self):
        if self.status is None:
            object.__setattr__(self, "status",
                               PointStatus.OK if self.ok else PointStatus.FAILED)


class SweepInterrupted(PredgaitError):
    """The Dask scheduler was lost mid-sweep; ``finished`` maps point index -> outcome."""

    def __init__(self, message: str, finished: Mapping[int, SweepOutcome]):
        super().__init__(message)
        self.finished = dict(finished)


def grid_points(axes: Mapping[str, Sequence[float]]) -> list[SweepPoint]:
    """Every combination of the axis values (first axis slowest)."""
    names = list(axes)
    combos = itertools.product(*(axes[name] for name in names))
    return [SweepPoint(i, dict(zip(names, combo, strict=True))) for i, combo in enumerate(combos)]


def random_points(ranges: Mapping[str, tuple[float, float]], count: int, *,
                  seed: int = 0) -> list[SweepPoint]:
    """``count`` points drawn uniformly in the ranges with a seeded generator."""
    rng = np.random.default_rng(seed)
    points = []
    for i in range(count):
        values = {name: float(rng.uniform(lo, hi)) for name, (lo, hi) in ranges.items()}
        points.append(SweepPoint(i, values))
    return points


def run_point(task: Callable[[SweepPoint], Mapping[str, float]], point: SweepPoint) -> SweepOutcome:
    """Run one point, turning any failure into a recorded outcome (never raising)."""
    start = time.perf_counter()
    try:
        answer = task(point)
        payload = None
        if isinstance(answer, PointResult):
            checks = tuple(c for c in answer.checks if c is not None)
            metrics = {**answer.metrics,
                       WARNINGS_METRIC: float(sum(not c.passed for c in checks))}
            payload = answer.payload
        else:
            checks, metrics = (), dict(answer)
    except SimulationDiverged as exc:
        return SweepOutcome(point, False, reason=str(exc), status=PointStatus.DIVERGED,
                            seconds=time.perf_counter() - start)
    except PredgaitError as exc:
        return SweepOutcome(point, False, reason=str(exc), seconds=time.perf_counter() - start)
    except Exception as exc:  # noqa: BLE001 - a sweep records every failure and goes on
        where = traceback.extract_tb(exc.__traceback__)[-1]
        place = f"{os.path.basename(where.filename)}:{where.lineno}"
        reason = f"{type(exc).__name__}: {exc} (at {place})"
        return SweepOutcome(point, False, reason=reason, seconds=time.perf_counter() - start)
    return SweepOutcome(point, True, metrics, seconds=time.perf_counter() - start,
                        checks=checks, payload=payload)


def labelled_checks(outcomes: Sequence[SweepOutcome]) -> list[Check]:
    """Every point's checks, each named after its point (:func:`point_label`), in order."""
    return [replace(c, name=f"{point_label(o.point)}: {c.name}")
            for o in outcomes for c in o.checks]


def checks_by_point(entries: Sequence[Mapping]) -> dict[int, tuple[Check, ...]]:
    """Point index -> checks, from the ``plausibility`` entries of a sweep's summary.json.

    The inverse of :func:`labelled_checks`; entries not named after a point are left out.
    """
    found: dict[int, list[Check]] = {}
    for entry in entries:
        match = re.match(r"point (\d+) \(.*?\): (.*)$", str(entry.get("name", "")), re.S)
        if match:
            found.setdefault(int(match.group(1)), []).append(
                Check(**{**entry, "name": match.group(2)}))
    return {index: tuple(checks) for index, checks in found.items()}


def _dask_client(scheduler: str, timeout: float):
    try:
        from dask.distributed import Client
    except ImportError:
        raise InputError("--scheduler needs dask.distributed: pip install 'dask[distributed]'."
                         ) from None
    try:
        return Client(scheduler, timeout=timeout)
    except ValueError as exc:
        raise InputError(f"--scheduler {scheduler!r} is not a Dask scheduler address ({exc}); "
                         "give tcp://HOST:PORT, e.g. tcp://127.0.0.1:8786.") from None
    except (OSError, TimeoutError) as exc:
        raise InputError(f"cannot reach the Dask scheduler at {scheduler} ({exc}); start one "
                         "with 'dask scheduler' or drop --scheduler.") from None


def run_sweep(task: Callable[[SweepPoint], Mapping[str, float]], points: Sequence[SweepPoint],
              *, workers: int = 2, scheduler: str | None = None,
              progress: bool = True, connect_timeout: float = 10.0, desc: str = "sweep",
              unit: str = "run") -> list[SweepOutcome]:
    """Run ``task`` at every point; failed points are recorded, not raised.

    Args:
        task: A picklable (module-level) function of a point returning its metrics.
        points: The points to run.
        workers: Local processes (ignored with ``scheduler``); 1 runs in this process.
        scheduler: Address of a Dask scheduler (``tcp://host:port``), or a
            ``dask.distributed.Client``.
        progress: Show a progress bar.
        connect_timeout: Seconds to wait for the Dask scheduler.
        desc: The progress bar's label.
        unit: The progress bar's unit.
    """
    from tqdm import tqdm  # here: a batch worker imports this module, not the bar

    if workers < 1:
        raise InputError(f"--workers = {workers}: give at least 1.")
    outcomes: dict[int, SweepOutcome] = {}
    if scheduler is not None:  # connect first: a bad address is one error line, no bar
        client = (_dask_client(scheduler, connect_timeout) if isinstance(scheduler, str)
                  else scheduler)
    bar = tqdm(total=len(points), desc=desc, unit=unit, disable=not progress)
    try:
        if scheduler is not None:
            _run_dask(client, task, points, outcomes, bar,
                      owned=isinstance(scheduler, str))
        elif workers == 1 or len(points) <= 1:
            for point in points:
                outcomes[point.index] = run_point(task, point)
                bar.update()
        else:
            _run_local(task, points, workers, outcomes, bar)
    finally:
        bar.close()
    return [outcomes[point.index] for point in points]


@contextlib.contextmanager
def _quiet_dask():
    """Dask's own log records off (a lost scheduler logs tracebacks while reconnecting)."""
    names = [name for name in logging.root.manager.loggerDict
             if name.split(".")[0] in ("distributed", "tornado", "asyncio")]
    loggers = [logging.getLogger(name) for name in {"distributed", *names}]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)


def _run_dask(client, task, points, outcomes: dict, bar, *, owned: bool) -> None:
    """Run the points on a Dask cluster; a lost scheduler raises :class:`SweepInterrupted`.

    A point whose workers kept dying (``KilledWorker``) or that Dask could not run (e.g. a
    worker without the task's modules) is recorded as failed with the reason. ``owned``:
    the client was made here, so it is closed here.
    """
    from dask.distributed import KilledWorker
    from dask.distributed import as_completed as dask_completed

    address = getattr(getattr(client, "scheduler", None), "address", None) or "of the sweep"
    futures = client.map(run_point, [task] * len(points), points, pure=False)
    by_key = {future.key: point for future, point in zip(futures, points, strict=True)}
    lost = None
    with _quiet_dask():
        try:
            for future in dask_completed(futures):
                try:
                    outcome = future.result()
                except (concurrent.futures.CancelledError, OSError, TimeoutError):
                    raise
                except KilledWorker as exc:
                    outcome = SweepOutcome(by_key[future.key], False,
                                           reason=f"its Dask workers died ({exc})")
                except Exception as exc:  # noqa: BLE001 - e.g. a worker's other environment
                    first = (str(exc).strip().splitlines() or [""])[0][:200]
                    outcome = SweepOutcome(by_key[future.key], False,
                                           reason=f"Dask: {type(exc).__name__}: {first}")
                outcomes[outcome.point.index] = outcome
                bar.update()
        except concurrent.futures.CancelledError:
            lost = "connection lost"
        except (OSError, TimeoutError) as exc:
            lost = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        finally:
            if lost is not None or owned:
                with contextlib.suppress(Exception):
                    client.close(timeout=5)
    if lost is not None:
        raise SweepInterrupted(f"lost the Dask scheduler {address} after {len(outcomes)} of "
                               f"{len(points)} points ({lost[:200]})", outcomes)


def _stop(pool: ProcessPoolExecutor) -> None:
    """Cancel the points not started and end the worker processes running the others."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # no public API
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.kill()


def _run_local(task, points, workers: int, outcomes: dict, bar, *, retries: int = 2) -> None:
    """Run the points in local processes, surviving a worker process that dies.

    A dead worker (killed, out of memory, a crash in native code) breaks the pool: the
    points that had not finished run again in a new pool, at most ``retries`` times, and
    are then recorded as failed; every finished point is kept.
    """
    pending = list(points)
    for _ in range(retries + 1):
        broken = []
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(run_point, task, point): point for point in pending}
            try:
                for future in as_completed(futures):
                    try:
                        outcome = future.result()
                    except BrokenProcessPool:
                        broken.append(futures[future])
                        continue
                    outcomes[outcome.point.index] = outcome
                    bar.update()
            except BaseException:  # Ctrl-C / SIGTERM: stop now, not after every point
                _stop(pool)
                raise
        pending = sorted(broken, key=lambda p: p.index)
        if not pending:
            return
    for point in pending:
        outcomes[point.index] = SweepOutcome(
            point, False, reason=f"a worker process died while this point ran or waited "
                                 f"({retries + 1} attempts); see the system log "
                                 "(killed, out of memory?)")
        bar.update()


def outcomes_table(outcomes: Sequence[SweepOutcome]) -> tuple[list[str], list[list]]:
    """Header and rows (parameters, status, metrics, reason) for a CSV file."""
    params = list(dict.fromkeys(k for o in outcomes for k in o.point.values))
    metrics = list(dict.fromkeys(k for o in outcomes for k in o.metrics))
    header = ["index", *params, "status", *metrics, "seconds", "reason"]
    rows = []
    for o in outcomes:
        rows.append([o.point.index, *(o.point.values.get(p, math.nan) for p in params),
                     o.status, *(o.metrics.get(m, math.nan) for m in metrics),
                     round(o.seconds, 4), o.reason])
    return header, rows
