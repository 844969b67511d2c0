"""One trial of ``predgait batch``, run on a worker: analyses, files, tidy cycle rows.

The trial's folder ``trials/<id>/`` is written whole or not at all (a staging folder
renamed into place), so an interrupted batch leaves every finished trial whole: per leg
side ``leg_<side>/`` (the files of ``predgait inverse``, same numbers), ``fullbody/`` (those
of ``predgait inverse --model fullbody``), ``cycles.csv`` and ``cycles.npz`` (its gait
cycles: tidy rows and the same numbers, :mod:`predgait.report.dataset_tables`) and
``trial.json`` (status, flags, the content hash that ``--resume`` compares). Models are
cached per worker process (:func:`predgait.models.loading.load_model`, the full-body
builder's caches), so a worker keeps them warm across trials, and so is each subject's
full-body calibration (:func:`subject_calibration`: computed once per subject per worker).
"""

from __future__ import annotations

import json
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from predgait.report.dataset_tables import cycles_of, write_cycles
from predgait.report.figures import plots_off
from predgait.scenarios.sweep import SweepPoint
from predgait.textfile import source_name
from predgait.workflows.batch_spec import TrialJob, digest

#: File that marks a whole trial result (written last in its staging folder).
TRIAL_JSON = "trial.json"
#: Subjects' full-body calibrations a worker keeps (the most recently used).
CALIBRATIONS_KEPT = 8
_calibrations: OrderedDict = OrderedDict()   # content hash -> (marker map, calibration)


def _leg(options, stage: Path, key: dict) -> tuple[list, dict]:
    """Leg inverse of one side into ``stage/leg_<side>``; its tidy rows and notes."""
    from predgait.dynamics.inverse_trial import run_inverse
    from predgait.workflows.inverse_io import write_inverse_outputs

    result = run_inverse(options)
    inputs = [p for p in (options.markers, options.grf, options.static) if p]
    write_inverse_outputs(result, stage / f"leg_{options.side}", inputs=inputs)
    mass = result.body_mass
    columns = {k: (np.degrees(v), "deg") for k, v in result.anatomical_angles().items()}
    columns |= {k: (v / mass, "N m/kg") for k, v in result.clinical_moments().items()}
    cycles = result.events.cycles()
    rows = cycles_of(key | {"analysis": "leg", "side": str(options.side)}, result.time,
                      cycles, columns)
    return rows, {"status": result.status(), "flagged_frames": int(result.ik.flagged.sum()),
                  "frames": int(result.time.size), "cycles": len(cycles)}


def _side_of(name: str) -> tuple[str, str]:
    """(variable, side) of a full-body clinical column (``hip_flexion_r`` -> right)."""
    stem, moment = (name.removesuffix("_moment"), "_moment") if name.endswith("_moment") \
        else (name, "")
    for suffix, side in (("_r", "right"), ("_l", "left")):
        if stem.endswith(suffix):
            return stem.removesuffix(suffix) + moment, side
    return name, "both"


def subject_calibration(body: dict):
    """(marker map, static trial, full-body calibration) of a trial's subject, kept warm.

    Computed once per worker for each content hash of the static trial and marker map
    files with the mass, height and sex (the calibration the single-trial command
    computes from them); without a static trial the walk calibrates: (map, None, None).
    """
    from predgait.data import read_trc
    from predgait.dynamics import fullbody_calibration
    from predgait.dynamics.inverse3d_trial import read_marker_map
    from predgait.kinematics.ik3d import IKOptions

    if body["static"] is None:
        return read_marker_map(body["marker_map"]), None, None
    options = IKOptions()
    key = digest([body["static"], body["marker_map"]],
                 {k: body[k] for k in ("mass", "height", "sex")} | {"ik": repr(options)})
    kept = _calibrations.pop(key, None)
    if kept is None:
        marker_map, static = read_marker_map(body["marker_map"]), read_trc(body["static"])
        kept = (marker_map, static, fullbody_calibration.calibrate_fullbody(
            marker_map, mass=body["mass"], height=body["height"], sex=body["sex"],
            static=static, options=options))
    _calibrations[key] = kept   # the most recently used last
    while len(_calibrations) > CALIBRATIONS_KEPT:
        _calibrations.popitem(last=False)
    return kept


def _fullbody(body: dict, stage: Path, key: dict) -> tuple[list, dict]:
    """Full-body inverse into ``stage/fullbody``; its tidy rows and notes.

    Cycles: between the starts of consecutive stances of the same foot on the plates.
    """
    from predgait.dynamics.inverse3d_trial import clinical, inverse_fullbody, read_trial
    from predgait.workflows.inverse3d import scaled_urdf, write_outputs

    markers, plates = read_trial(body["files"])
    marker_map, static, calibration = subject_calibration(body)
    result = inverse_fullbody(markers, plates, marker_map, mass=body["mass"],
                              height=body["height"], sex=body["sex"], static=static,
                              calibration=calibration)
    folder = stage / "fullbody"
    folder.mkdir()
    write_outputs(result, folder)
    if result.scaling is not None:
        (folder / "scaled_model.urdf").write_text(scaled_urdf(result))
    angles, moments = clinical(result)
    mass = result.model.total_mass()
    by_side: dict[str, dict] = {"right": {}, "left": {}, "both": {}}
    for name, values in angles.items():
        variable, side = _side_of(name)
        by_side[side][variable] = (values, "deg")
    for name, values in moments.items():
        variable, side = _side_of(name)
        by_side[side][variable] = (values / mass, "N m/kg")
    rows, count = [], 0
    for side, columns in by_side.items():   # pelvis and trunk ("both"): right-foot cycles
        foot = "r" if side == "both" else side[0]
        starts = sorted(s.start for s in result.stances if s.side == foot)
        cycles = list(zip(starts[:-1], starts[1:], strict=True))
        count += len(cycles) if side != "both" else 0
        rows += cycles_of(key | {"analysis": "fullbody", "side": side}, result.ik.time,
                           cycles, columns)
    return rows, {"status": result.status(), "frames": int(result.ik.time.size),
                  "flagged_frames": len(result.ik.failed_frames), "cycles": count}


@dataclass(frozen=True)
class TrialPoint(SweepPoint):
    """A batch trial as a point of the sweep runner: its index in the dataset and job."""

    job: TrialJob | None = None


def run_trial(out: str, point: TrialPoint) -> dict[str, float]:
    """Analyse ``point.job`` and write ``<out>/trials/<id>/`` whole (the batch task).

    Returns:
        Metrics: ``cycles`` (all analyses), ``flagged_frames``, ``seconds``.

    Raises:
        PredgaitError (or anything else): recorded by the batch as the trial's reason.
    """
    from predgait.workflows.output import staged_output

    job = point.job
    start = time.perf_counter()
    key = {"subject": job.subject, "condition": job.condition, "trial": job.id}
    inputs = [job.markers, job.grf]
    rows, notes = [], {}
    with plots_off(), staged_output(Path(out) / "trials" / job.id, force=True,
                                    inputs=inputs) as stage:
        for options in job.legs:
            part, notes[f"leg_{options.side}"] = _leg(options, stage, key)
            rows += part
        if job.fullbody is not None:
            part, notes["fullbody"] = _fullbody(job.fullbody, stage, key)
            rows += part
        write_cycles(stage, rows)
        flagged = sum(n["flagged_frames"] for n in notes.values())
        cycles = sum(n["cycles"] for n in notes.values())
        info = {"trial": job.id, "subject": job.subject, "condition": job.condition,
                "markers": source_name(job.markers), "grf": source_name(job.grf),
                "digest": job.digest, "analyses": notes, "cycles": cycles,
                "flagged_frames": flagged, "seconds": time.perf_counter() - start}
        (stage / TRIAL_JSON).write_text(json.dumps(info, indent=1) + "\n")
    return {"cycles": float(cycles), "flagged_frames": float(flagged),
            "seconds": info["seconds"]}


def finished_digest(folder: Path) -> str | None:
    """The content hash of a whole trial result in ``folder`` (None: none there)."""
    try:
        return json.loads((folder / TRIAL_JSON).read_text())["digest"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
