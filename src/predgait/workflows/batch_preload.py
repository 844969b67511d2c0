"""Imported once by the forkserver that a local batch's Dask workers fork from.

It computes the static calibrations of the batch's first trials
(:func:`predgait.workflows.batch_warm.warm`) in the forkserver, so every worker forked from
it starts with them warm (and with the modules and models they load), instead of each
worker computing the same calibration for its first trial. The batch names the dataset
file and the trials in the environment variable :data:`ENV` (JSON: ``dataset``, ``first``:
how many of the file's first trials to read, ``trials``: the ids among them to warm, or
null: all of them). The calibrations are
the functions the trials call, keyed as they key them, so a trial's numbers do not change;
anything that fails here is left to the trial, which computes (and reports) it itself.
"""

from __future__ import annotations

import contextlib
import json
import os

#: The environment variable naming what to warm (set only for the forkserver's start).
ENV = "PREDGAIT_BATCH_WARM"


def _warm_from_environment() -> None:
    text = os.environ.pop(ENV, None)
    if not text:
        return
    with contextlib.suppress(Exception):   # the trials compute what is not warm
        from predgait.workflows.batch_spec import read_dataset
        from predgait.workflows.batch_warm import warm

        spec = json.loads(text)
        wanted = spec.get("trials")
        for job in read_dataset(spec["dataset"], first=spec["first"]).trials:
            if not wanted or job.id in wanted:
                warm(job)


_warm_from_environment()
