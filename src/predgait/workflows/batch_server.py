"""The forkserver a local batch's Dask worker processes fork from (its start and its end).

Started as early as the batch command knows it runs a local cluster (before it reads the
dataset file and imports Dask), it imports Dask's ``distributed``, the modules a trial runs
on (:data:`WORKER_MODULES`) and warms the first trials' calibrations
(:mod:`predgait.workflows.batch_preload`) while this process does its own start-up; each
worker (a killed worker's replacement too) then starts with all of that. It is ended as
soon as the batch no longer needs it, so the run does not wait for its interpreter's
teardown when it exits. Light on purpose: this module imports no NumPy.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import os
import signal
from pathlib import Path

#: The modules a batch trial runs on, imported once in the process workers fork from.
WORKER_MODULES = ("predgait.workflows.batch_trial", "predgait.dynamics.inverse3d_trial",
                  "predgait.workflows.inverse3d", "predgait.dynamics.inverse_trial",
                  "predgait.workflows.inverse_io")


def wanted(workers: int, scheduler: str | None) -> bool:
    """A local Dask cluster of ``workers`` processes may run the batch."""
    return workers > 1 and scheduler is None and \
        importlib.util.find_spec("distributed") is not None


def _server():
    import multiprocessing
    from multiprocessing import forkserver

    if "forkserver" not in multiprocessing.get_all_start_methods():
        return None
    return getattr(forkserver, "_forkserver", None)


def running() -> bool:
    """A forkserver is running for this process (ours or another's)."""
    server = _server()
    return server is not None and getattr(server, "_forkserver_pid", None) is not None


def start(dataset: str | Path, *, first: int = 2, trials: list[str] | None = None) -> bool:
    """Start the forkserver; False when there is none on this platform or one runs already.

    It warms the calibrations of the dataset file's ``first`` trials (only those of them
    whose ids ``trials`` lists, when given; :mod:`predgait.workflows.batch_preload`).
    """
    from multiprocessing import forkserver

    from predgait.workflows.batch_preload import ENV

    if _server() is None or running():
        return False
    forkserver.set_forkserver_preload(["distributed", *WORKER_MODULES,
                                       "predgait.workflows.batch_preload"])
    os.environ[ENV] = json.dumps({"dataset": str(Path(dataset).resolve()), "first": first,
                                  "trials": trials})
    try:   # the forkserver reads it as it starts
        forkserver.ensure_running()
    finally:
        os.environ.pop(ENV, None)
    return True


def stop() -> None:
    """End the forkserver (its workers have ended): at once, without its teardown."""
    server = _server()
    pid = getattr(server, "_forkserver_pid", None)
    if pid is None:
        return
    with contextlib.suppress(OSError):
        os.kill(pid, signal.SIGTERM)
    with contextlib.suppress(Exception):
        server._stop()   # closes its pipe and waits for it
