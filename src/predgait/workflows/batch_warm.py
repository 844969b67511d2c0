"""What a batch worker keeps warm across trials: each subject's static calibrations.

A worker process computes a subject's full-body calibration
(:func:`predgait.dynamics.fullbody_calibration.calibrate_fullbody`) and leg calibration
(:func:`predgait.dynamics.leg_static.leg_static`) once and reuses them for the subject's
other trials: keyed by the content hash of the static trial and the other files they read
(marker map, model), with every setting they depend on, so a trial's numbers are those the
single-trial command computes. The :data:`KEPT` most recently used are kept.
"""

from __future__ import annotations

import dataclasses
from collections import OrderedDict
from collections.abc import Callable

import numpy as np

from predgait.workflows.batch_spec import digest

#: Calibrations a worker keeps (the most recently used).
KEPT = 16
_kept: OrderedDict = OrderedDict()   # content hash -> calibration


def _warm(key: str, make: Callable):
    """The value kept under ``key``, else ``make()`` kept; the least recently used go."""
    value = _kept.pop(key, None)
    if value is None:
        value = make()
    _kept[key] = value   # the most recently used last
    while len(_kept) > KEPT:
        _kept.popitem(last=False)
    return value


def fullbody_calibration(body: dict) -> tuple:
    """(marker map, static trial, full-body calibration) of a batch trial's subject.

    ``body``: the trial's full-body settings (:class:`predgait.workflows.batch_spec.TrialJob`);
    without a static trial the walk calibrates: (map, None, None).
    """
    from predgait.data import read_trc
    from predgait.dynamics import fullbody_calibration as calibration
    from predgait.dynamics.inverse3d_trial import read_marker_map
    from predgait.kinematics.ik3d import IKOptions

    if body["static"] is None:
        return read_marker_map(body["marker_map"]), None, None
    options = IKOptions()

    def make():
        marker_map, static = read_marker_map(body["marker_map"]), read_trc(body["static"])
        return marker_map, static, calibration.calibrate_fullbody(
            marker_map, mass=body["mass"], height=body["height"], sex=body["sex"],
            static=static, options=options)

    settings = {k: body[k] for k in ("mass", "height", "sex")} | {"ik": repr(options)}
    return _warm("fullbody " + digest([body["static"], body["marker_map"]], settings), make)


def leg_calibration(options, turn: np.ndarray):
    """The leg's static calibration for ``options`` and the walk's rotation ``turn`` (3, 3).

    None without a static trial or with the mass weighed on each trial's plates.
    """
    from predgait.dynamics import leg_static

    if options.static is None or isinstance(options.mass, str):
        return None
    settings = dataclasses.asdict(options) | {"markers": "", "grf": "",
                                              "turn": np.asarray(turn).tolist()}
    key = "leg " + digest([options.static, options.model], settings)
    return _warm(key, lambda: leg_static.leg_static(options, turn))


def warm(job) -> None:
    """Compute and keep the calibrations a trial ``job`` uses (each failure left to it).

    ``job``: a :class:`predgait.workflows.batch_spec.TrialJob`; its full-body calibration
    and, per leg side, the leg calibration for its walk's rotation.
    """
    import contextlib

    if job.fullbody is not None and job.fullbody["static"] is not None:
        with contextlib.suppress(Exception):
            fullbody_calibration(job.fullbody)
    for options in job.legs:
        if options.static is None or isinstance(options.mass, str):
            continue
        with contextlib.suppress(Exception):
            from predgait.dynamics.leg_measurements import read_trial

            leg_calibration(options, read_trial(options)[1])
