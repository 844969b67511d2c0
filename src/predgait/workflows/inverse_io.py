"""Inverse dynamics: problem files in, result folder out (STO, CSV, JSON, PNG)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from predgait import __version__
from predgait.data import Side, write_csv, write_storage
from predgait.data.bundled import bundled_path
from predgait.dynamics.inverse_trial import (
    POINT_NAMES,
    HipRegression,
    InverseOptions,
    InverseResult,
    StaticCentre,
)
from predgait.problemfile import Table
from predgait.report.gait_plots import cycle_axis, save_gait_plots
from predgait.workflows.output import staged_output

TRIAL_KEYS = ("markers", "grf", "static", "mass", "height", "side", "model")
OPTION_KEYS = ("cutoff", "grf_cutoff", "threshold", "scale_to_markers", "max_gap_frames")


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
    table.check_keys(("trial", "points", "options"))
    trial = table.table("trial", required=True)
    trial.check_keys(TRIAL_KEYS)
    points = table.table("points", required=True)
    points.check_keys(POINT_NAMES)
    opts = table.table("options")
    opts.check_keys(OPTION_KEYS)
    side = trial.get("side", str, "right")
    if side not in ("right", "left"):
        raise trial.error("side", f"'{side}' is not one of: right, left.")
    return InverseOptions(
        markers=_path(trial, "markers") or trial.get("markers", str),
        grf=_path(trial, "grf"), static=_path(trial, "static"),
        mass=trial.number("mass", low=20, high=300, unit="kg"),
        height=trial.number("height", None, low=0.5, high=2.5, unit="m"),
        model=_path(trial, "model"), side=Side(side),
        points={name: _point(points, name) for name in points.data},
        cutoff=opts.number("cutoff", 6.0, low=0.5, high=100, unit="Hz"),
        grf_cutoff=opts.number("grf_cutoff", 6.0, low=0.5, high=500, unit="Hz")
        if opts.get("grf_cutoff", (float, bool), 6.0) is not False else None,
        threshold=opts.number("threshold", 20.0, low=1, high=500, unit="N"),
        scale_to_markers=opts.get("scale_to_markers", bool, True),
        max_gap_frames=int(opts.number("max_gap_frames", 10, low=0, high=1000)),
    )


def result_columns(result: InverseResult) -> tuple[dict, dict]:
    """Kinematics and kinetics columns (SI) of a result."""
    kin = dict(result.clinical_angles())
    kinetics = dict(result.clinical_moments())
    for joint in ("ankle", "knee", "hip"):
        force = result.joint_force[joint]
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
    angles = result.clinical_angles()
    return {
        "status": "completed",
        "predgait": __version__,
        "window": "first gait cycle" if xlabel.startswith("%") else "whole trial",
        "peak_moments_n_m_per_kg": {
            f"{k}_min": float(v[mask].min() / result.body_mass) for k, v in moments.items()
        } | {f"{k}_max": float(v[mask].max() / result.body_mass) for k, v in moments.items()},
        "angle_range_deg": {k: [float(np.degrees(v[mask].min())), float(np.degrees(v[mask].max()))]
                            for k, v in angles.items()},
        "ik_rms_residual_m": result.ik.rms(),
        "ik_frames_not_converged": int((~result.ik.converged).sum()),
        "heel_strikes_s": [float(t) for t in result.events.heel_strikes],
        "toe_offs_s": [float(t) for t in result.events.toe_offs],
        "ground_reaction": "measured" if result.has_grf else "none (moments valid in swing only)",
        "provenance": result.provenance,
    }


def write_inverse_outputs(result: InverseResult, out: str | Path, *, force: bool = False,
                          inputs=()) -> Path:
    """kinematics.sto/.csv, inverse_dynamics.sto/.csv, summary.json and PNG plots."""
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
        (stage / "summary.json").write_text(json.dumps(summary(result), indent=2) + "\n")
        save_gait_plots(result, stage)
    return Path(out)
