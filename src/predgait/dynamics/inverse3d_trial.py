"""Whole-body 3D inverse kinematics and dynamics of a trial (the 3D twin of inverse_trial).

Steps: read the markers (TRC or C3D) and plates (GRF .mot or the C3D's)
(:func:`read_trial`), read the marker map (:func:`read_marker_map`), build the 35-DOF body
for the subject and calibrate its marker frames on a static trial (or on the first frames
of the walk; :mod:`predgait.dynamics.fullbody_calibration`), fit every frame
(:mod:`predgait.kinematics.ik3d`), low-pass the coordinates, differentiate, assign the
plates to the feet and run RNEA (:mod:`predgait.dynamics.inverse3d`): :func:`inverse_fullbody` ->
:class:`Inverse3DResult`; :func:`clinical` gives its clinical angles and moments. The
files are written by :mod:`predgait.workflows.inverse3d`.

Marker map (TOML, read with :func:`predgait.problemfile.load_problem`)::

    [markers]     # model marker frame = trial marker (fitted from the start)
    asis_r = "R.ASIS"
    [segments]    # further trial markers riding on a model segment (placed by calibration)
    "R.Thigh.Upper" = "thigh_r"
    [weights]     # optional, model frame or trial marker = weight (default 1)
    [scaling]     # optional, segment lengths from the static trial (needs one), see
                  # predgait.kinematics.scaling; the scaled URDF is scaled_model.urdf
    [calibration] # optional
    foot_flat = "auto"   # "auto" or "on": the feet stand flat in the static trial (their
                         # frames level, headed from the heel to the toe landmark,
                         # predgait.kinematics.static_feet) or, without one, the soles are
                         # levelled at loaded mid-stance (predgait.kinematics.foot_flat);
                         # "off": neither (the static fit's pose)
    [ik]          # optional
    foot_inversion = "fitted"  # or "held": the walking IK holds each ankle's Cardan X
                         # (the foot's roll about the shank's forward axis) at the model's
                         # neutral 0, so the foot's frontal plane follows the shank's, as
                         # Gait2354's IK holds its subtalar joint at 0 (FootInversion)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path

import numpy as np
import pinocchio as pin

from predgait.data import (
    filter_plate,
    lowpass,
    read_c3d,
    read_grf_mot,
    read_trc,
    resample_plate,
)
from predgait.data.body_weight import PlateMass, plate_body_mass, resolve_mass
from predgait.data.medians import median
from predgait.data.trial import ForcePlate, Markers
from predgait.dynamics.fullbody_calibration import FullbodyCalibration, calibrate_fullbody
from predgait.dynamics.inverse3d import (
    InverseDynamics3D,
    Stance,
    assign_plates,
    inverse_dynamics_3d,
    velocities,
)
from predgait.errors import InputError
from predgait.kinematics.ankle_jcs import in_jcs
from predgait.kinematics.bounded_ik import frames_near
from predgait.kinematics.clinical import PELVIS_3D, clinical_angles_3d
from predgait.kinematics.foot_flat import FootFlatMode, calibrate_feet
from predgait.kinematics.ik3d import (
    IKOptions,
    IKResult,
    body_of,
    pelvis_cardan,
    solve_ik,
)
from predgait.kinematics.scaling import Scaling, ScalingSpec, read_scaling
from predgait.models.fullbody import JOINT_CENTRES, MARKERS
from predgait.models.loading3d import Model3D
from predgait.problemfile import load_problem
from predgait.textfile import source_name

BODIES = ("pelvis", "torso", "thigh_r", "thigh_l", "shank_r", "shank_l", "foot_r", "foot_l",
          "upper_arm_r", "upper_arm_l", "forearm_r", "forearm_l")


class FootInversion(Enum):
    """How the walking IK treats the foot's inversion (``[ik] foot_inversion``).

    ``fitted``: the ankle's three Cardan coordinates are fitted to the markers. ``held``:
    each ankle's X (inversion, the first rotation, fixed in the shank) is held at the
    model's neutral 0 through the walk, so the foot rolls with the shank, as OpenSim's
    Gait2354 IK holds its subtalar joint at 0 (its shipped subject01 results,
    tests/data/opensim_gait2354_reference). On subject01 the foot markers barely tell the
    roll (their RMS moves by 0-2 mm) while it decides how the ankle moment projects on a
    foot-fixed axis (the subtalar moment, :mod:`predgait.kinematics.subtalar_axis`;
    docs/DEVELOPING.md).
    """

    FITTED = "fitted"
    HELD = "held"

    def held_coordinates(self) -> tuple[str, ...]:
        """The coordinates the walking IK holds at 0."""
        return ("ankle_r_x", "ankle_l_x") if self is FootInversion.HELD else ()


@dataclass(frozen=True)
class MarkerMap:
    """Model frame <-> trial marker pairs, extra segment markers and weights."""

    frames: dict[str, str]                 # model frame -> trial marker
    segments: dict[str, str]               # trial marker -> body
    weights: dict[str, float] = field(default_factory=dict)  # frame or marker -> weight
    source: str = ""
    scaling: ScalingSpec | None = None     # [scaling]: segment lengths from a static trial
    foot_flat: FootFlatMode = FootFlatMode.AUTO  # [calibration] foot_flat
    foot_inversion: FootInversion = FootInversion.FITTED  # [ik] foot_inversion

    def fitted(self) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """(model frames, trial markers) fitted after calibration.

        Segment markers become frames named after the trial marker.
        """
        frames = tuple(self.frames) + tuple(self.segments)
        return frames, tuple(self.frames.values()) + tuple(self.segments)

    def check(self, names: Sequence[str], where: str) -> None:
        """InputError naming every mapped marker the trial lacks."""
        missing = [m for m in list(self.frames.values()) + list(self.segments) if m not in names]
        if missing:
            raise InputError(f"{self.source}: marker(s) {', '.join(missing)} are not in {where} "
                             f"(it has {', '.join(names)}). Fix the marker map.")


def read_marker_map(path: str | Path) -> MarkerMap:
    """Read a marker map TOML (see module docstring)."""
    table = load_problem(path)
    table.check_keys(["markers", "segments", "weights", "scaling", "calibration", "ik"])
    markers, segments, weights = (table.table(k) for k in ("markers", "segments", "weights"))
    frames = {k: markers.get(k, str) for k in markers.data}
    unknown = [k for k in frames if k not in MARKERS + JOINT_CENTRES]
    if unknown:
        raise markers.error(unknown[0], "not a model marker or joint-centre frame; frames: "
                                        f"{', '.join(MARKERS + JOINT_CENTRES)}.")
    segs = {k: segments.get(k, str) for k in segments.data}
    for name, body in segs.items():
        if body not in BODIES:
            raise segments.error(name, f"segment {body!r} unknown; choose from "
                                       f"{', '.join(BODIES)}.")
    if not frames:
        raise table.error("markers", "the map needs at least one model marker frame.")
    w = {k: weights.number(k, low=0.0, high=1e3) for k in weights.data}
    scaling = read_scaling(table.table("scaling"), frames) if table.has("scaling") else None
    calibration = table.table("calibration")
    calibration.check_keys(["foot_flat"])
    foot_flat = calibration.choice("foot_flat", FootFlatMode, FootFlatMode.AUTO)
    ik = table.table("ik")
    ik.check_keys(["foot_inversion"])
    foot_inversion = ik.choice("foot_inversion", FootInversion, FootInversion.FITTED)
    return MarkerMap(frames, segs, w, source=str(path), scaling=scaling, foot_flat=foot_flat,
                     foot_inversion=foot_inversion)


def read_trial(files: Sequence[str | Path]) -> tuple[Markers, tuple[ForcePlate, ...]]:
    """Markers and plates from a .trc (+ .mot) or a .c3d, lab frame, SI."""
    files = [Path(f) for f in files]
    by_ext = {f.suffix.lower(): f for f in files}
    if ".c3d" in by_ext:
        trial = read_c3d(by_ext[".c3d"])
        return trial.markers, trial.plates
    if ".trc" not in by_ext:
        raise InputError(f"trial files {', '.join(map(str, files))}: give a .trc (with its "
                         "GRF .mot) or a .c3d.")
    markers = read_trc(by_ext[".trc"])
    plates = read_grf_mot(by_ext[".mot"]) if ".mot" in by_ext else ()
    return markers, plates


def _filter_q(model: Model3D, time: np.ndarray, q: np.ndarray, cutoff: float | None):
    if not cutoff:
        return q
    rate = 1.0 / median(np.diff(time))   # np.median's value, without importing numpy.ma
    out = q.copy()
    out[:, :3] = lowpass(q[:, :3], rate, cutoff)
    out[:, 7:] = lowpass(q[:, 7:], rate, cutoff)
    ref = pin.Quaternion(q[0, 6], *q[0, 3:6]).toRotationMatrix()
    logs = np.array([pin.log3(ref.T @ pin.Quaternion(r[6], *r[3:6]).toRotationMatrix())
                     for r in q])
    for k, w in enumerate(lowpass(logs, rate, cutoff)):
        out[k, 3:7] = pin.Quaternion(ref @ pin.exp3(w)).coeffs()
    return out


#: Markers weighted above this in the IK are trusted: the trusted-marker error and the
#: plausibility check use them (issue 27: weights > 0.5).
TRUSTED_WEIGHT = 0.5


def _trim_unseen(markers: Markers, names: list[str]) -> tuple[Markers, str]:
    """Drop leading/trailing frames showing fewer than 3/4 of the mapped markers.

    Those frames have the subject outside the capture volume; the note says what went.
    """
    visible = np.isfinite(markers.select(names).xyz).all(axis=2).sum(axis=1)
    good = np.flatnonzero(visible >= max(3, 0.75 * len(names)))
    if good.size < 3:
        raise InputError(f"{markers.source}: fewer than 3 frames show 3/4 of the mapped "
                         "markers; check the marker map or the time window.")
    first, last = good[0], good[-1]
    if first == 0 and last == markers.n_frames - 1:
        return markers, "none"
    note = (f"kept {markers.time[first]:.3f}..{markers.time[last]:.3f} s; dropped {first} "
            f"leading and {markers.n_frames - 1 - last} trailing frames showing fewer than "
            "3/4 of the mapped markers")
    return markers.window(markers.time[first], markers.time[last]), note


@dataclass(frozen=True, eq=False)
class Inverse3DResult:
    """Everything the whole-body pipeline computed.

    ``plates`` are resampled at the IK times; ``sides`` (n_plates, n) says which foot
    ("r", "l" or "") each plate loads at each frame (:func:`assign_plates`).
    """

    model: Model3D
    ik: IKResult
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    dynamics: InverseDynamics3D
    plates: tuple[ForcePlate, ...]
    stances: list[Stance]
    provenance: dict
    sides: np.ndarray | None = None
    scaling: Scaling | None = None
    plate_mass: PlateMass | None = None   # body mass the plates measure (data.body_weight)
    trusted: tuple[str, ...] = ()   # trial markers with IK weight > TRUSTED_WEIGHT
    _clinical: dict = field(default_factory=dict, init=False, repr=False)  # clinical()'s

    @property
    def valid(self) -> np.ndarray:
        """(n,) bool: frames whose results stand.

        Not within 2 frames of a flagged IK frame (accelerations reach 2 frames).
        """
        return ~frames_near(self.ik.flagged, 2)

    def status(self) -> str:
        """``completed`` or ``completed with N flagged frames``."""
        n = int(self.ik.flagged.sum())
        return "completed" if n == 0 else f"completed with {n} flagged frames"


def inverse_fullbody(markers: Markers, plates: Sequence[ForcePlate], marker_map: MarkerMap, *,
                     mass: float | str, height: float, sex: str = "male",
                     static: Markers | None = None, window: tuple[float, float] | None = None,
                     cutoff: float | None = 6.0, grf_cutoff: float | None = None,
                     options: IKOptions | None = None,
                     calibration: FullbodyCalibration | None = None) -> Inverse3DResult:
    """IK + ID of a trial with the whole body (in memory; see :func:`run_inverse_fullbody`).

    ``mass``: kg, or "plates" (weighed on the plates, :mod:`predgait.data.body_weight`).
    ``cutoff`` (Hz) low-passes the IK coordinates; ``grf_cutoff`` (Hz) the plates (None:
    unfiltered, as OpenSim's InverseDynamicsTool). ``calibration``: the subject's body
    from :func:`~predgait.dynamics.fullbody_calibration.calibrate_fullbody` on this
    ``static``, map, mass, height, sex and options (a batch worker keeps it per subject);
    None: calibrated here.
    """
    options = options or IKOptions()
    weighed = mass == "plates"
    mass = resolve_mass(mass, plates, source=markers.source or "the trial")
    marker_map.check(markers.names, markers.source or "the trial")
    if calibration is None:
        calibration = calibrate_fullbody(marker_map, mass=mass, height=height, sex=sex,
                                         static=static, walk=markers, options=options)
    elif (calibration.mass, calibration.height, calibration.sex, calibration.options,
          calibration.from_static) != (mass, height, sex, options, static is not None):
        raise ValueError("inverse_fullbody: the calibration is another subject's (mass, "
                         "height, sex, IK options or static trial differ).")
    model, first, scaling = calibration.model, calibration.static_fit, calibration.scaling
    unobserved, centres = calibration.unobserved, calibration.centres
    frames, names = marker_map.fitted()
    if window is not None:
        markers = markers.window(*window)
    markers, trimmed = _trim_unseen(markers, list(names))
    weights = {f: marker_map.weights.get(f, marker_map.weights.get(m, 1.0))
               for f, m in zip(frames, names, strict=True)}

    held = unobserved + marker_map.foot_inversion.held_coordinates()

    def fit_walk(body):
        ik = solve_ik(body, markers.time, markers.select(list(names)).xyz, frames,
                      marker_names=names, weights=weights, locked=held, options=options)
        return ik, _filter_q(body, ik.time, ik.q, cutoff)

    ik, q = fit_walk(model)
    if grf_cutoff:
        plates = [filter_plate(p, grf_cutoff) for p in plates]   # a mean: same plate mass
    at_markers = tuple(resample_plate(p, ik.time) for p in plates)
    sides, stances = assign_plates(model, q, at_markers)
    feet = None
    if marker_map.foot_flat.applies(static is not None):  # level the soles, then refit
        model, feet = calibrate_feet(model, ik.time, q, at_markers, sides,
                                     {f: body_of(model, f) for f in frames})
        ik, q = fit_walk(model)
        sides, stances = assign_plates(model, q, at_markers)
    v, a = velocities(model, ik.time, q)
    dynamics = inverse_dynamics_3d(model, q, v, a, at_markers, sides)
    provenance = {
        "trial": source_name(markers.source),
        "marker_calibration": calibration.description,
        "marker_map": source_name(marker_map.source), "trimmed": trimmed,
        "unobserved_joints_held_at_zero": list(unobserved),
        "joint_limit_margin_deg": float(np.degrees(options.limit_margin)),
        "mass_from": "plates" if weighed else "given",
        "model": f"fullbody 35 DOF, de Leva 1996, {mass:g} kg, {height:g} m, {sex}"
                 + (", segment lengths scaled to the static trial" if scaling else ""),
        "scaling": None if scaling is None else {
            "factors": {k: round(v, 5) for k, v in scaling.factors.items()},
            "lengths_m": {k: round(v, 5) for k, v in scaling.lengths.items()}},
        "static_joint_centre_residual_mm": {
            f: round(1000 * float(np.sqrt(np.nanmean(first.residuals[:, i] ** 2))), 2)
            for i, f in enumerate(first.marker_frames) if f in centres and f in JOINT_CENTRES},
        "static_feet": calibration.static_feet,
        "foot_inversion": marker_map.foot_inversion.value,
        "foot_flat_calibration": None if feet is None else {
            side: f if isinstance(f, str) else f.summary() for side, f in feet.items()},
        "coordinate_cutoff_hz": cutoff, "grf_cutoff_hz": grf_cutoff,
        "window_s": [float(ik.time[0]), float(ik.time[-1])],
    }
    return Inverse3DResult(model, ik, q, v, a, dynamics, at_markers, stances, provenance,
                           sides, scaling, plate_body_mass(plates, gravity=model.gravity),
                           tuple(m for f, m in zip(frames, names, strict=True)
                                 if weights[f] > TRUSTED_WEIGHT))


def clinical(result: Inverse3DResult) -> tuple[dict, dict]:
    """Clinical angles (deg; pelvis first) and joint moments (N m); NaN at flagged frames.

    Names and signs: :data:`predgait.kinematics.clinical.CLINICAL_3D`. The ankles' three
    are in the ISB joint coordinate system (:mod:`predgait.kinematics.ankle_jcs`:
    dorsiflexion about the shank's medio-lateral axis, inversion about the floating axis,
    internal rotation about the foot's vertical axis); the other joints' are their Cardan
    coordinates. Computed once per result (the files, the summary and a batch's cycles all
    ask): new dicts of the same read-only arrays.
    """
    if not result._clinical:
        result._clinical.update(zip(("angles", "moments"), _clinical(result), strict=True))
        for values in result._clinical.values():
            for v in values.values():
                v.setflags(write=False)
    return dict(result._clinical["angles"]), dict(result._clinical["moments"])


def _clinical(result: Inverse3DResult) -> tuple[dict, dict]:
    names = result.model.joint_names
    q_joints, tau_joints = in_jcs(names, result.q[:, 7:], result.dynamics.tau[:, 6:])
    angles = dict(zip(PELVIS_3D, np.degrees(pelvis_cardan(result.q)).T, strict=True))
    angles |= {k: np.degrees(v) for k, v in clinical_angles_3d(names, q_joints).items()}
    moments = {f"{k}_moment": v for k, v in clinical_angles_3d(names, tau_joints).items()}
    valid = result.valid
    return ({k: np.where(valid, v, np.nan) for k, v in angles.items()},
            {k: np.where(valid, v, np.nan) for k, v in moments.items()})
