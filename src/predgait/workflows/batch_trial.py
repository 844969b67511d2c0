"""One trial of ``predgait batch``, run on a worker: analyses, files, tidy cycle rows.

The trial's folder ``trials/<id>/`` is written whole or not at all (a staging folder
renamed into place), so an interrupted batch leaves every finished trial whole: per leg
side ``leg_<side>/`` (the files of ``predgait inverse``, same numbers), ``fullbody/`` (those
of ``predgait inverse --model fullbody``), ``cycles.csv`` and ``cycles.npz`` (its gait
cycles: tidy rows and the same numbers, :mod:`predgait.report.dataset_tables`) and
``trial.json`` (status, flags, the content hash that ``--resume`` compares). Models are
cached per worker process (:func:`predgait.models.loading.load_model`, the full-body
builder's caches), so a worker keeps them warm across trials, and so are each subject's
static calibrations (:mod:`predgait.workflows.batch_warm`: once per subject per worker).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from predgait.report.dataset_tables import cycles_of, write_cycles
from predgait.report.figures import plots_off
from predgait.scenarios.sweep import PointResult, SweepPoint
from predgait.textfile import source_name
from predgait.workflows.batch_spec import TrialJob
from predgait.workflows.batch_warm import fullbody_calibration, leg_calibration

#: File that marks a whole trial result (written last in its staging folder).
TRIAL_JSON = "trial.json"


def _leg(options, stage: Path, key: dict) -> tuple[list, dict]:
    """Leg inverse of one side into ``stage/leg_<side>``; its tidy rows and notes."""
    from predgait.dynamics.inverse_trial import run_inverse
    from predgait.dynamics.leg_measurements import read_trial
    from predgait.workflows.inverse_io import write_inverse_outputs

    trial, turn = read_trial(options)
    result = run_inverse(options, loaded=(trial, turn), static=leg_calibration(options, turn))
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


def _fullbody(body: dict, stage: Path, key: dict) -> tuple[list, dict]:
    """Full-body inverse into ``stage/fullbody``; its tidy rows and notes.

    Cycles: between the starts of consecutive stances of the same foot on the plates.
    """
    from predgait.dynamics.inverse3d_trial import clinical, inverse_fullbody, read_trial
    from predgait.workflows.inverse3d import scaled_urdf, write_outputs

    markers, plates = read_trial(body["files"])
    marker_map, static, calibration = fullbody_calibration(body)
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


def run_trial(out: str, point: TrialPoint) -> PointResult:
    """Analyse ``point.job`` and write ``<out>/trials/<id>/`` whole (the batch task).

    Returns:
        Metrics: ``cycles`` (all analyses), ``flagged_frames``, ``seconds``; payload: the
        arrays of its ``cycles.npz`` (:func:`predgait.report.dataset_tables.cycle_arrays`),
        so the batch need not read them back.

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
        arrays = write_cycles(stage, rows)
        flagged = sum(n["flagged_frames"] for n in notes.values())
        cycles = sum(n["cycles"] for n in notes.values())
        info = {"trial": job.id, "subject": job.subject, "condition": job.condition,
                "markers": source_name(job.markers), "grf": source_name(job.grf),
                "digest": job.digest, "analyses": notes, "cycles": cycles,
                "flagged_frames": flagged, "seconds": time.perf_counter() - start}
        (stage / TRIAL_JSON).write_text(json.dumps(info, indent=1) + "\n")
    return PointResult({"cycles": float(cycles), "flagged_frames": float(flagged),
                        "seconds": info["seconds"]}, payload=arrays)


def finished_digest(folder: Path) -> str | None:
    """The content hash of a whole trial result in ``folder`` (None: none there)."""
    try:
        return json.loads((folder / TRIAL_JSON).read_text())["digest"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
