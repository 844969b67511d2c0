"""Whole-body 3D inverse kinematics and dynamics of a trial, file to file.

The pipeline is :mod:`predgait.dynamics.inverse3d_trial` (marker map, trial, result).
Steps: read the markers (TRC or C3D) and plates (GRF .mot or the C3D's), read the marker
map, build the 35-DOF body for the subject, calibrate the marker frames on a static trial
(or on the first frames of the walk), fit every frame (:mod:`predgait.kinematics.ik3d`),
low-pass the coordinates, differentiate, assign the plates to the feet and run RNEA
(:mod:`predgait.dynamics.inverse3d`). Outputs (one folder, written whole or not at all):
``kinematics3d.sto`` (deg, m), ``inverse_dynamics3d.sto`` and ``.csv`` (N m per Cardan
axis, pelvis residual force N and moment N m in the lab), ``ik_residuals.csv`` (m per
marker, RMS, flag), ``clinical_angles.sto`` (deg) and ``clinical_moments.sto`` (N m) with
clinical names and signs, the ankles' in the ISB joint coordinate system (header ``axes``;
both also in ``clinical.csv``), ``subtalar_moments.sto`` (N m, the ankle moment about
Gait2354's subtalar axis, :mod:`predgait.kinematics.subtalar_axis`), ``model.osim`` and
``motion.mot`` (the body and its motion for OpenSim) and ``summary.json``.

The marker map is described in :mod:`predgait.dynamics.inverse3d_trial`.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from predgait.analysis.plausibility import record
from predgait.data import (
    read_trc,
    write_csv,
    write_storage,
)
from predgait.dynamics.inverse3d_trial import (
    TRUSTED_WEIGHT,
    Inverse3DResult,
    clinical,
    inverse_fullbody,
    read_marker_map,
    read_trial,
)
from predgait.kinematics.ik3d import (
    IKOptions,
    coordinate_columns,
)
from predgait.kinematics.subtalar_axis import subtalar_moments
from predgait.report.figures import plots_wanted
from predgait.report.tidy import write_summary


def _finite(reduce, values: np.ndarray) -> float | None:
    """``reduce`` of the finite values; None when there are none (every frame flagged)."""
    return float(reduce(values)) if np.isfinite(values).any() else None


def _limited(result: Inverse3DResult) -> dict[str, int]:
    """Joint -> frames its coordinates were held at a limit against the markers."""
    at_limit = result.ik.at_limit
    if at_limit is None or not at_limit.any():
        return {}
    pm = result.model.pin_model
    out: dict[str, int] = {}
    for joint in range(2, pm.njoints):
        start, nv = pm.joints[joint].idx_v, pm.joints[joint].nv
        frames = int(at_limit[:, start:start + nv].any(axis=1).sum())
        if frames:
            out[pm.names[joint]] = frames
    return out


#: Joints whose bodies make up the lower body (the free-flyer root carries the pelvis).
LOWER_BODY_JOINTS = ("hip_", "knee_", "ankle_")


def ik_rms_by_region(result: Inverse3DResult) -> dict[str, float | None]:
    """Marker RMS (m) over the lower body (pelvis and legs) and the rest (trunk, head, arms).

    The mean over all markers of a full-body set is dominated by the arms when the static
    trial fits them poorly (e.g. a T-pose); gait analyses read the lower body.
    """
    pm, ik = result.model.pin_model, result.ik
    lower = np.array([
        (joint == 1 or pm.names[joint].startswith(LOWER_BODY_JOINTS))
        for joint in (pm.frames[pm.getFrameId(f)].parentJoint for f in ik.marker_frames)])
    regions = {"pelvis_and_legs": lower, "trunk_head_and_arms": ~lower}
    return {name: (float(np.sqrt(np.nanmean(ik.residuals[:, cols] ** 2))) if cols.any()
                   else None) for name, cols in regions.items()}


#: Weight above which the IK fit trusts a marker (arm and trunk markers weigh 0.2).


def _trusted(ik) -> dict:
    """Frame RMS over the markers weighted above :data:`TRUSTED_WEIGHT`, m."""
    rms = ik.trusted_rms(TRUSTED_WEIGHT)
    weights = ik.weights if ik.weights is not None else np.ones(len(ik.marker_names))
    names = [m for m, w in zip(ik.marker_names, weights, strict=True) if w > TRUSTED_WEIGHT]
    if not names:
        return {"mean": None, "max": None, "markers": []}
    return {"mean": float(np.nanmean(rms)), "max": float(np.nanmax(rms)), "markers": names,
            "weight_above": TRUSTED_WEIGHT}


def summary(result: Inverse3DResult) -> dict:
    """Headline numbers: IK RMS, pelvis residuals, joint moments, clinical ranges."""
    dyn, ik = result.dynamics, result.ik
    mass = result.model.total_mass()
    angles, moments = clinical(result)
    fmag = np.linalg.norm(dyn.residual_force, axis=1)
    mmag = np.linalg.norm(dyn.residual_moment, axis=1)
    loaded = (result.sides != "").any(axis=0) if result.sides is not None and \
        len(result.sides) else np.zeros(fmag.size, dtype=bool)
    on_plates = {
        "frames": int(loaded.sum()),
        "force_rms_N": float(np.sqrt(np.mean(fmag[loaded] ** 2))) if loaded.any() else None,
        "moment_rms_Nm": float(np.sqrt(np.mean(mmag[loaded] ** 2))) if loaded.any() else None,
        "note": "frames with a plate loaded. Whenever a foot stands outside the plates the "
                "pelvis residual carries that unmeasured ground reaction (~ body weight)",
    }
    valid = result.valid
    peaks = {k: _finite(np.nanmax, np.abs(v[valid])) for k, v in dyn.joint_moments.items()}
    return record({
        "status": result.status(),
        "frames": int(ik.time.size),
        "ik_flagged_at_joint_limits": _limited(result),
        "ik_rms_m": {"mean": float(ik.rms.mean()), "max": float(ik.rms.max())},
        "ik_trusted_rms_m": _trusted(ik),
        "ik_weighted_rms_m": {"mean": float(np.nanmean(ik.weighted_rms)),
                              "max": float(np.nanmax(ik.weighted_rms)),
                              "note": "sqrt(sum w r^2 / sum w) with the fit's weights: the "
                                      "error frames are flagged on"},
        "ik_rms_by_region_m": ik_rms_by_region(result),
        "ik_flagged_frames": [float(ik.time[i]) for i in ik.failed_frames],
        "ik_marker_rms_m": {m: float(np.sqrt(np.nanmean(ik.residuals[:, i] ** 2)))
                            for i, m in enumerate(ik.marker_names)},
        "pelvis_residual_force_N": {"rms": float(np.sqrt(np.mean(fmag**2))),
                                    "max": float(fmag.max())},
        "pelvis_residual_moment_Nm": {"rms": float(np.sqrt(np.mean(mmag**2))),
                                      "max": float(mmag.max())},
        "pelvis_residual_while_plates_loaded": on_plates,
        "peak_joint_moments_Nm": peaks,
        "clinical_angle_range_deg": {k: [_finite(np.nanmin, v), _finite(np.nanmax, v)]
                                     for k, v in angles.items()},
        "clinical_moment_range_Nm_per_kg": {k: [_finite(np.nanmin, v / mass),
                                                _finite(np.nanmax, v / mass)]
                                            for k, v in moments.items()},
        "stances": [vars(s) for s in result.stances],
        "provenance": result.provenance,
    }, inverse3d_checks(result, moments, fmag, loaded))


def inverse3d_checks(result: Inverse3DResult, moments: dict, residual: np.ndarray,
                     loaded: np.ndarray) -> list:
    """Plausibility of a full-body inverse result (:mod:`predgait.analysis.plausibility`).

    Peak |clinical moment| per hip/knee/ankle moment (N m/kg), each plate's peak vertical
    force (BW), the largest pelvis residual force (N; over the frames with a plate loaded,
    when there are some: elsewhere it carries the unmeasured ground reaction, which the
    mass and stance warnings already say) against the peak ground reaction, the per-marker
    RMS of the trusted markers (IK weight > 0.5), the given mass against the plates'.
    """
    from predgait.analysis.plausibility import (
        grf_check,
        joint_moment_checks,
        marker_check,
        mass_check,
        residual_check,
    )

    mass, valid = result.model.total_mass(), result.valid
    weight = mass * result.model.gravity
    checks = joint_moment_checks({k: _finite(np.nanmax, np.abs(v[valid]) / mass)
                                  for k, v in moments.items()})
    if result.plates:
        vertical = np.array([p.force[:, 2] for p in result.plates])
        checks.append(grf_check(float(np.nanmax(vertical)) / weight,
                                "peak vertical ground reaction (one plate)"))
        total = np.linalg.norm(np.sum([p.force for p in result.plates], axis=0), axis=1)
        window = loaded & valid if (loaded & valid).any() else valid
        if window.any():
            checks.append(residual_check(float(residual[window].max()),
                                         float(np.nanmax(total))))
    ik = result.ik
    checks.append(marker_check({m: float(np.sqrt(np.nanmean(ik.residuals[:, i] ** 2)))
                                for i, m in enumerate(ik.marker_names)
                                if m in result.trusted}))
    plates = result.plate_mass
    checks.append(mass_check(mass, plates.mass if plates else None))
    return checks


#: The axes of the clinical angles and moments (header ``axes`` of the clinical files).
AXES = ("ankles: ISB joint coordinate system (predgait.kinematics.ankle_jcs; Wu et al. "
        "2002): dorsiflexion about the shank's medio-lateral axis, inversion about the "
        "floating axis (the Cardan X after the sagittal rotation, sequence Y-X-Z), internal "
        "rotation about the foot's vertical axis; moments: the net ankle moment projected "
        "on these axes. Other joints: their Cardan X-Y-Z coordinates and generalised forces")


#: The axis of ``subtalar_moments.sto`` (header ``axes``).
SUBTALAR_AXES = ("Gait2354's subtalar axis (Delp et al. 1990, after Inman 1976) fixed in the "
                 "foot frame, through the ankle centre (predgait.kinematics.subtalar_axis): "
                 "the moment OpenSim reports as subtalar_angle_<side>_moment; a model axis, "
                 "the clinical inversion moment is in clinical_moments.sto")


def write_outputs(result: Inverse3DResult, folder: Path) -> dict:
    """Write the output files into an existing (staging) folder; returns the summary."""
    time, model, dyn = result.ik.time, result.model, result.dynamics
    prov = "; ".join(f"{k}={v}" for k, v in result.provenance.items())
    hide = ~result.valid

    def masked(values: np.ndarray) -> np.ndarray:
        out = np.array(values, dtype=float)
        out[hide] = np.nan
        return out

    kin = {k: masked(v) for k, v in coordinate_columns(result.q, model.joint_names).items()}
    write_storage(folder / "kinematics3d.sto", time, kin, in_degrees=True,
                  header={"units": "deg (angles: Cardan X-Y-Z), m (pelvis_t*)",
                          "provenance": prov})
    cols = {f"{n}_moment": m for n, m in dyn.joint_moments.items()}
    cols |= {"pelvis_residual_force": dyn.residual_force,
             "pelvis_residual_moment": dyn.residual_moment}
    cols = {k: masked(v) for k, v in cols.items()}
    write_storage(folder / "inverse_dynamics3d.sto", time, cols,
                  header={"units": "N m (joint moments about each Cardan axis; "
                                   "pelvis_residual_moment about the pelvis origin, lab frame), "
                                   "N (pelvis_residual_force, lab frame)",
                          "provenance": prov})
    units = {k: "N m" for k in cols} | {"pelvis_residual_force": "N"}
    write_csv(folder / "inverse_dynamics3d.csv", time, cols, units=units, provenance=prov)
    angles, moments = clinical(result)
    signs = "signs: predgait.kinematics.clinical.CLINICAL_3D (flexion, adduction, internal " \
            "rotation, dorsiflexion, inversion positive; internal moments toward + angle)"
    write_storage(folder / "clinical_angles.sto", time, angles, in_degrees=True,
                  header={"units": "deg", "conventions": signs, "axes": AXES,
                          "provenance": prov})
    write_storage(folder / "clinical_moments.sto", time, moments,
                  header={"units": "N m", "conventions": signs, "axes": AXES,
                          "provenance": prov})
    write_csv(folder / "clinical.csv", time, angles | moments,
              units=dict.fromkeys(angles, "deg") | dict.fromkeys(moments, "N m"),
              provenance=prov)
    subtalar = subtalar_moments(model.joint_names, result.q[:, 7:], dyn.tau[:, 6:])
    write_storage(folder / "subtalar_moments.sto", time,
                  {k: masked(v) for k, v in subtalar.items()},
                  header={"units": "N m", "conventions": "internal moment, inversion +",
                          "axes": SUBTALAR_AXES, "provenance": prov})
    res = {f"{m}": result.ik.residuals[:, i] for i, m in enumerate(result.ik.marker_names)}
    res |= {"rms": result.ik.rms, "flagged": (~result.ik.converged).astype(float)}
    write_csv(folder / "ik_residuals.csv", time, res, units=dict.fromkeys(res, "m") |
              {"flagged": "1"}, provenance=prov)
    write_opensim(result, folder)
    info = summary(result)
    if plots_wanted():
        from predgait.report.clinical_plots import save_clinical_plots
        from predgait.report.viewer import plate_arrows, write_motion

        save_clinical_plots(folder, time, angles, moments, info["stances"],
                            body_mass=result.model.total_mass())
        write_motion(folder, result.model, time, result.q, label="measured (IK)",
                     grf=plate_arrows(result.plates, time, time) or None)
    return write_summary(folder / "summary.json", info)


def write_opensim(result: Inverse3DResult, folder: Path) -> None:
    """Write ``model.osim`` and ``motion.mot`` for OpenSim into ``folder``.

    The model: the scaled, calibrated body (:mod:`predgait.models.osim_write`); the motion:
    its coordinates (deg, m) at every frame, flagged frames as fitted.
    """
    markers = tuple(zip(result.ik.marker_frames, result.ik.marker_names, strict=True))
    (folder / "model.osim").write_text(_osim_text(result.model, markers), encoding="utf-8")
    prov = "; ".join(f"{k}={v}" for k, v in result.provenance.items())
    write_storage(folder / "motion.mot", result.ik.time,
                  coordinate_columns(result.q, result.model.joint_names), in_degrees=True,
                  header={"units": "deg (rotations), m (pelvis_t*)", "model": "model.osim",
                          "provenance": prov})


def scaled_urdf(result: Inverse3DResult) -> str:
    """The scaled body's URDF with the calibrated marker frames the IK fitted.

    So the per-marker residuals can be recomputed from the outputs.
    """
    return _scaled_urdf(result.model, tuple(result.ik.marker_frames))


# A model's texts depend on the model only: a batch worker's trials of one subject share
# its calibrated model (the same object), so each text is made once per subject.
@functools.lru_cache(maxsize=8)
def _osim_text(model, markers: tuple[tuple[str, str], ...]) -> str:
    from predgait.models.osim_write import osim_text

    return osim_text(model, dict(markers))


@functools.lru_cache(maxsize=8)
def _scaled_urdf(model, frames: tuple[str, ...]) -> str:
    from predgait.kinematics.ik3d import marker_placements
    from predgait.models.urdf import with_fixed_frames

    return with_fixed_frames(model.urdf, marker_placements(model, frames))


def run_inverse_fullbody(trial_files: Sequence[str | Path], marker_map: str | Path, *,
                         mass: float, height: float, sex: str = "male",
                         out_dir: str | Path, static: str | Path | None = None,
                         window: tuple[float, float] | None = None,
                         cutoff: float | None = 6.0, grf_cutoff: float | None = None,
                         limit_margin: float = 0.0, force: bool = False) -> dict:
    """Whole-body IK and ID of a trial, written to ``out_dir`` (see module docstring).

    ``limit_margin`` (deg) widens every joint range of the model for the IK.

    Returns:
        The summary (also written as summary.json).
    """
    from predgait.workflows.output import staged_output

    markers, plates = read_trial(trial_files)
    static_markers = read_trc(static) if static is not None else None
    mmap = read_marker_map(marker_map)
    result = inverse_fullbody(markers, plates, mmap, mass=mass, height=height, sex=sex,
                              static=static_markers, window=window, cutoff=cutoff,
                              grf_cutoff=grf_cutoff,
                              options=IKOptions(limit_margin=np.radians(limit_margin)))
    inputs = [*trial_files, marker_map] + ([static] if static else [])
    with staged_output(out_dir, force=force, inputs=inputs) as stage:
        info = write_outputs(result, stage)
        if result.scaling is not None:
            (stage / "scaled_model.urdf").write_text(scaled_urdf(result))
    return info
