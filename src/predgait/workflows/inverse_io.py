"""Inverse dynamics: problem files in, result folder out (STO, CSV, JSON, PNG)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from predgait import __version__
from predgait.analysis.plausibility import record
from predgait.data import Side, write_csv, write_storage
from predgait.data.body_weight import parse_mass
from predgait.data.bundled import bundled_path
from predgait.data.cutoffs import CutoffRule, parse_cutoff
from predgait.data.events import runs_of
from predgait.data.resample import RELEASE_FRACTION
from predgait.dynamics.inverse_options import (
    POINT_NAMES,
    THRESHOLD,
    HipRegression,
    InverseOptions,
    StaticCentre,
)
from predgait.errors import InputError
from predgait.kinematics.osim2d_motion import write_osim2d_motion
from predgait.problemfile import Table
from predgait.report.figures import plots_wanted
from predgait.report.gait_plots import cycle_axis, save_gait_plots
from predgait.report.tidy import write_summary
from predgait.workflows.output import staged_output

if TYPE_CHECKING:   # the result's module (pinocchio) is not needed to read problem files
    from predgait.dynamics.inverse_trial import InverseResult

TRIAL_KEYS = ("markers", "grf", "static", "mass", "height", "side", "model")
OPTION_KEYS = ("cutoff", "grf_cutoff", "threshold", "release", "scale_to_markers",
               "max_gap_frames", "limit_margin")


def _path(table: Table, key: str) -> Path | None:
    """A path; ``bundled:NAME`` names a file shipped with predgait."""
    value = table.get(key, str, None)
    if value is None:
        return None
    if value.startswith("bundled:"):
        return bundled_path(value.removeprefix("bundled:"))
    return table.path_value(key)


def _point(table: Table, key: str):
    value = table.data.get(key)
    if isinstance(value, str):
        return value
    sub = table.table(key)
    method = sub.get("method", str)
    if method == "harrington":
        sub.check_keys(("method", "rasis", "lasis", "sacrum"))
        return HipRegression(sub.get("rasis", str), sub.get("lasis", str), sub.get("sacrum", str))
    if method == "static_midpoint":
        sub.check_keys(("method", "medial", "lateral", "cluster"))
        cluster = sub.get("cluster", list)
        if len(cluster) != 3 or not all(isinstance(c, str) for c in cluster):
            raise sub.error("cluster", "give the names of three markers on the segment.")
        return StaticCentre(sub.get("medial", str), sub.get("lateral", str), tuple(cluster))
    raise sub.error("method", f"'{method}' is not one of: harrington, static_midpoint.")


def options_from_problem(table: Table) -> InverseOptions:
    """InverseOptions from a ``problems/inverse_*.toml`` file (see those files)."""
    table.expect_command("inverse")
    table.check_keys(("trial", "points", "options"))
    trial = table.table("trial", required=True)
    trial.check_keys(TRIAL_KEYS)
    return _options(trial, table.table("points", required=True), table.table("options"))


def options_from_trial(trial: Table, extra_keys=()) -> InverseOptions:
    """InverseOptions from another problem's ``[trial]`` table holding the inverse inputs.

    The same keys as an inverse problem file's ``[trial]`` (markers, grf, static, mass,
    height, side, model), with its ``[points]`` and ``[options]`` as the sub-tables
    ``[trial.points]`` and ``[trial.options]``; ``extra_keys`` are the caller's own.
    """
    trial.check_keys((*TRIAL_KEYS, "points", "options", *extra_keys))
    if not trial.has("points"):
        raise trial.error("points", "name the trial's markers in [trial.points] (hip, knee, "
                                    "ankle, heel, toe), as in an inverse problem file.")
    return _options(trial, trial.table("points"), trial.table("options"))


def _options(trial: Table, points: Table, opts: Table) -> InverseOptions:
    points.check_keys(POINT_NAMES)
    opts.check_keys(OPTION_KEYS)
    side = trial.get("side", str, "right")
    if side not in ("right", "left"):
        raise trial.error("side", f"'{side}' is not one of: right, left.")
    return InverseOptions(
        markers=_path(trial, "markers") or trial.get("markers", str),
        grf=_path(trial, "grf"), static=_path(trial, "static"),
        mass=parse_mass(trial),
        height=trial.number("height", None, low=0.5, high=2.5, unit="m"),
        model=_path(trial, "model"), side=Side(side),
        points={name: _point(points, name) for name in points.data},
        cutoff=_cutoff(opts, "cutoff", 6.0, (CutoffRule.AUTO,)),
        grf_cutoff=_cutoff(opts, "grf_cutoff", CutoffRule.MARKERS, (CutoffRule.MARKERS,)),
        threshold=opts.number("threshold", THRESHOLD, low=0.1, high=500, unit="N"),
        release=opts.number("release", RELEASE_FRACTION, low=0.0, high=1.0),
        scale_to_markers=opts.get("scale_to_markers", bool, True),
        max_gap_frames=int(opts.number("max_gap_frames", 10, low=0, high=1000)),
        limit_margin=opts.number("limit_margin", 0.0, low=0.0, high=180.0, unit="deg"),
    )


def _cutoff(table: Table, key: str, default, rules):
    """A cut-off key: Hz, 0 or false (unfiltered), or one of ``rules`` (a string)."""
    if key not in table.data:
        return default
    try:
        return parse_cutoff(table.data[key], field=key, rules=rules)
    except InputError as exc:
        words = ", ".join(["a number of Hz", "0 or false (unfiltered)", *(f'"{r}"' for r in rules)])
        raise table.error(key, f"{table.data[key]!r} is not a cut-off; give {words}.") from exc


def result_columns(result: InverseResult) -> tuple[dict, dict]:
    """Kinematics and kinetics columns (SI) of a result."""
    kin = dict(result.anatomical_angles())
    kinetics = dict(result.clinical_moments())
    for joint in ("ankle", "knee", "hip"):
        force = np.where(result.valid[:, None], result.joint_force[joint], np.nan)
        kinetics[f"{joint}_force_x"] = force[:, 0]
        kinetics[f"{joint}_force_z"] = force[:, 2]
    kinetics.update(result.powers())
    kinetics.update({"ground_force_x": result.grf[:, 0], "ground_force_z": result.grf[:, 2],
                     "ground_cop_x": result.cop[:, 0]})
    return kin, kinetics


def units_of(name: str) -> str:
    """Unit of an output column."""
    if name.endswith("_moment"):
        return "N m"
    if name.endswith("_power"):
        return "W"
    if "force" in name:
        return "N"
    if "cop" in name:
        return "m"
    return "rad"


def summary(result: InverseResult) -> dict:
    """Peaks (per kg), IK residuals, events and provenance as JSON-ready values."""
    mask, _, xlabel = cycle_axis(result)
    moments = result.clinical_moments()
    angles = result.anatomical_angles()
    ik = result.ik
    return record({
        "status": result.status(),
        "predgait": __version__,
        "window": "first gait cycle" if xlabel.startswith("%") else "whole trial",
        "peak_moments_n_m_per_kg": {
            f"{k}_min": _finite(np.nanmin, v[mask] / result.body_mass)
            for k, v in moments.items()
        } | {f"{k}_max": _finite(np.nanmax, v[mask] / result.body_mass)
             for k, v in moments.items()},
        "angle_range_deg": {k: [_finite(np.nanmin, np.degrees(v[mask])),
                                _finite(np.nanmax, np.degrees(v[mask]))]
                            for k, v in angles.items()},
        "ik_rms_residual_m": ik.rms(),
        "ik_frames_not_converged": int((~ik.converged).sum()),
        "flagged_frames": int(ik.flagged.sum()),
        "flagged_frames_at_joint_limits": ik.limited_coordinates(),
        "frames_without_results": int((~result.valid).sum()),
        "flagged_times_s": _runs(result.time, ik.flagged),
        "heel_strikes_s": [float(t) for t in result.events.heel_strikes],
        "toe_offs_s": [float(t) for t in result.events.toe_offs],
        "ground_reaction": "measured" if result.has_grf else "none (moments valid in swing only)",
        "provenance": result.provenance,
    }, inverse_checks(result, mask))


def inverse_checks(result: InverseResult, mask: np.ndarray) -> list:
    """Plausibility of a leg inverse result over the analysed window (``mask``).

    Peak |moment| per joint (N m/kg), the foot's peak vertical ground reaction (BW) and
    the given mass against the plates' (:mod:`predgait.analysis.plausibility`).
    """
    from predgait.analysis.plausibility import grf_check, joint_moment_checks, mass_check

    peaks = {k: _finite(np.nanmax, np.abs(v[mask]) / result.body_mass)
             for k, v in result.clinical_moments().items()}
    checks = joint_moment_checks(peaks)
    if result.has_grf:
        weight = result.body_mass * result.model.gravity
        checks.append(grf_check(float(np.nanmax(result.grf[mask, 2])) / weight,
                                f"peak vertical ground reaction ({result.side} foot)"))
    plates = result.plate_mass
    checks.append(mass_check(result.body_mass, plates.mass if plates else None))
    return checks


def _finite(reduce, values: np.ndarray) -> float | None:
    """``reduce`` of the finite values, None when there are none (every frame flagged)."""
    return float(reduce(values)) if np.isfinite(values).any() else None


def _runs(time: np.ndarray, flags: np.ndarray) -> list[list[float]]:
    """[start, end] times (s) of each run of flagged frames."""
    return [[float(time[run.start]), float(time[run.stop - 1])] for run in runs_of(flags)]


def write_inverse_outputs(result: InverseResult, out: str | Path, *, force: bool = False,
                          inputs=()) -> Path:
    """kinematics.sto/.csv, inverse_dynamics.sto/.csv, motion.mot, summary.json and PNG plots.

    ``motion.mot``: the leg's motion as OpenSim's 2D gait model's coordinates
    (:mod:`predgait.kinematics.osim2d_motion`), flagged frames as fitted.
    """
    kin, kinetics = result_columns(result)
    provenance = "; ".join(f"{k}={v}" for k, v in result.provenance.items())
    header = {"units": "SI (rad, N m, N, W, m, s)", "provenance": provenance,
              "time_zero": "heel strike of the analysed foot"}
    with staged_output(out, force=force, inputs=inputs) as stage:
        write_storage(stage / "kinematics.sto", result.time, kin, header=header)
        write_storage(stage / "inverse_dynamics.sto", result.time, kinetics, header=header)
        write_csv(stage / "kinematics.csv", result.time, kin,
                  units={k: units_of(k) for k in kin}, provenance=provenance)
        write_csv(stage / "inverse_dynamics.csv", result.time, kinetics,
                  units={k: units_of(k) for k in kinetics}, provenance=provenance)
        write_osim2d_motion(stage / "motion.mot", result.model, result.time, result.q,
                            side=result.side, header={
                                "provenance": provenance,
                                "time_zero": "heel strike of the analysed foot",
                                "flagged_frames": "as fitted (summary.json flagged_times_s)"})
        write_summary(stage / "summary.json", summary(result))
        if plots_wanted():
            from predgait.report.viewer import write_motion  # pinocchio: only for it

            save_gait_plots(result, stage)
            write_motion(stage, result.model, result.time, result.q, label="measured (IK)",
                         grf=(result.grf, result.cop))
    return Path(out)
