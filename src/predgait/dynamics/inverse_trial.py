"""Measured trial in, joint moments out: the planar inverse-dynamics pipeline.

markers (TRC / C3D / CSV) + ground reactions (MOT / C3D plates)
  -> gap filling, Butterworth low-pass (Winter correction) of markers and forces
  -> joint centres (markers, Harrington hip regression, static-trial calibration)
  -> least-squares IK of the leg URDF (hinge-consistent coordinates)
  -> 5-point central differences -> Pinocchio RNEA with the ground reaction on the foot
  -> ankle, knee, hip moments, joint forces and powers; time zero at heel strike.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from predgait.data import (
    Side,
    differentiate,
    events_from_kinematics,
    events_from_plate,
    fill_gaps,
    filter_plate,
    lowpass,
    read_c3d,
    read_external_loads,
    read_grf_mot,
    read_markers_csv,
    read_trc,
    resample_plate,
)
from predgait.data.bundled import bundled_path, read_winter_table, subject_info
from predgait.data.cutoffs import Cutoff, CutoffRule, marker_cutoff, plate_cutoff
from predgait.data.events import Events
from predgait.data.frames import FileAxes, Forward, lab_rotation, rotate_markers, rotate_trial
from predgait.data.resample import RELEASE_FRACTION, check_plates_cover, hold_nearest
from predgait.data.trc import trc_span
from predgait.data.trial import ForcePlate, Markers, Trial
from predgait.dynamics.external import assign_contacts
from predgait.dynamics.inverse import LegInverse, LoadHistory, leg_inverse_dynamics
from predgait.errors import InputError
from predgait.kinematics import clinical
from predgait.kinematics.bounded_ik import frames_near
from predgait.kinematics.joint_centres import calibrate_centre, harrington_hip
from predgait.kinematics.planar_ik import IKResult, solve_ik
from predgait.models.anthropometry import LegParameters, leg_from_subject
from predgait.models.loading import Model, load_model, model_from_urdf
from predgait.models.urdf import leg_urdf
from predgait.textfile import source_name

log = logging.getLogger(__name__)
POINT_NAMES = ("hip", "knee", "ankle", "heel", "toe")
#: The bundled trial's name in problem files (``[trial] source``).
BUNDLED = "bundled:subject01"
#: Largest median horizontal distance (m) of a contact's COP from the foot's heel-toe
#: segment for the contact to load that foot.
NEAR_FOOT = 0.1

#: Fewest marker frames the pipeline analyses (the 5-point differences, the filter).
MIN_FRAMES = 20
#: N, default contact threshold: a contact must reach it; it lasts while the force stays
#: above ``RELEASE_FRACTION`` of it (:func:`predgait.data.resample.contact_frames`).
THRESHOLD = 10.0
#: A run whose IK flags more than this fraction of the frames is a failed run (exit 3).
MOST_FRAMES = 0.5



@dataclass(frozen=True)
class HipRegression:
    """Hip centre by Harrington et al. (2007) from these pelvis markers."""

    rasis: str
    lasis: str
    sacrum: str


@dataclass(frozen=True)
class StaticCentre:
    """Knee/ankle centre: mid-point of two static markers, carried by a 3-marker cluster."""

    medial: str
    lateral: str
    cluster: tuple[str, str, str]


PointSource = str | HipRegression | StaticCentre


@dataclass(frozen=True)
class InverseOptions:
    """Everything ``predgait inverse`` needs (units: kg, m, Hz, N).

    ``points`` maps hip, knee, ankle, heel, toe to a trial marker name or a joint-centre
    rule. ``cutoff``: Hz, ``CutoffRule.AUTO`` (residual analysis) or None (markers
    unfiltered). ``grf_cutoff``: Hz, None (forces unfiltered) or, by default,
    ``CutoffRule.MARKERS``: the markers' cut-off (Kristianslund et al. 2012, J Biomech
    45:666-671: the same cut-off for both avoids the impact artefacts of mismatched
    filtering). ``threshold``: N, contact threshold; a contact lasts while the force
    stays above ``release`` x threshold (hysteresis, see
    :func:`predgait.data.resample.contact_frames`; 1 = none). ``limit_margin``: deg added to both
    ends of the model's joint ranges for the IK.
    """

    markers: Path
    mass: float
    points: Mapping[str, PointSource]
    side: Side = Side.RIGHT
    grf: Path | None = None
    static: Path | None = None
    height: float | None = None
    model: Path | None = None
    cutoff: Cutoff = 6.0
    grf_cutoff: Cutoff = CutoffRule.MARKERS
    threshold: float = THRESHOLD
    release: float = RELEASE_FRACTION
    scale_to_markers: bool = True
    max_gap_frames: int = 10
    limit_margin: float = 0.0


@dataclass(frozen=True)
class InverseResult:
    """Planar inverse-dynamics results of one leg (see docs/DEVELOPING.md contract)."""

    time: np.ndarray
    model: Model
    side: str
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    hip_force: np.ndarray
    hip_moment: np.ndarray
    joint_force: dict[str, np.ndarray]
    grf: np.ndarray
    cop: np.ndarray
    free_moment: np.ndarray
    events: Events
    ik: IKResult
    body_mass: float
    has_grf: bool
    provenance: dict = field(default_factory=dict)
    leg: LegParameters | None = None
    flagged: np.ndarray | None = None
    knee_static: float = 0.0

    @property
    def valid(self) -> np.ndarray:
        """(n,) bool: frames whose results stand (see :func:`flagged_outputs`)."""
        return np.ones(self.time.size, dtype=bool) if self.flagged is None else ~self.flagged

    def _masked(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {k: np.where(self.valid, v, np.nan) for k, v in values.items()}

    def clinical_angles(self) -> dict[str, np.ndarray]:
        """Hip flexion, knee flexion, ankle dorsiflexion, rad (NaN at flagged frames)."""
        return self._masked(clinical.clinical_angles(self.q))

    def anatomical_angles(self) -> dict[str, np.ndarray]:
        """Clinical angles with the knee calibrated on the static trial, rad.

        The knee flexion of the model's hinge (between the hip-knee and knee-ankle
        joint-centre lines) minus its value standing in the static trial (``knee_static``),
        so that the straight standing knee reads 0 (the calibrated anatomical frames of
        Cappozzo et al. 1995, Clin Biomech 10:171-178). The ankle needs no offset: the foot
        is already calibrated flat on the static trial and the shank's forward lean
        standing is posture. Hip flexion is the thigh against the vertical.
        """
        angles = self.clinical_angles()
        angles["knee_flexion"] = angles["knee_flexion"] - self.knee_static
        return angles

    def clinical_rates(self) -> dict[str, np.ndarray]:
        """Their time derivatives, rad/s (NaN at flagged frames)."""
        return self._masked(clinical.clinical_angles(self.qd))

    def clinical_moments(self) -> dict[str, np.ndarray]:
        """Hip flexion, knee flexion, ankle dorsiflexion moments, N m (NaN at flagged frames)."""
        return self._masked(clinical.clinical_moments(self.tau, self.hip_moment[:, 1]))

    def status(self) -> str:
        """``completed`` or ``completed with N flagged frames``."""
        n = int(self.ik.flagged.sum())
        return "completed" if n == 0 else f"completed with {n} flagged frames"

    def powers(self) -> dict[str, np.ndarray]:
        """Joint powers, W."""
        return clinical.joint_powers(self.clinical_moments(), self.clinical_rates())

    def first_cycle(self) -> tuple[float, float] | None:
        """Start and end time (s) of the first full gait cycle, if the trial has one."""
        cycles = self.events.cycles()
        return cycles[0] if cycles else None


def read_trial(options: InverseOptions) -> tuple[Trial, np.ndarray]:
    """Markers and plates in the lab frame from TRC(+MOT), C3D or CSV(+MOT).

    Returns:
        The trial with X along the direction of travel, and the rotation (3, 3) that was
        applied after the reader (a static trial of the same session needs it too).
    """
    path = Path(options.markers)
    suffix = path.suffix.lower()
    if suffix == ".c3d":
        if options.grf is not None:
            raise InputError(f"{path}: a C3D file carries its own force plates; drop --grf.")
        return read_c3d(path), np.eye(3)
    plates: tuple[ForcePlate, ...] = ()
    if options.grf is not None:
        grf = Path(options.grf)
        xml = grf.with_suffix(".xml")
        names = read_external_loads(xml) if xml.is_file() else None
        plates = read_grf_mot(grf, names=names)
    if suffix == ".trc":
        span = trc_span(path)  # plates checked from the header, before the full read
        if span is not None:
            check_plates_cover(span[0], span[1], plates, source=str(options.grf),
                               markers=str(path))
        markers = read_trc(path)
    elif suffix == ".txt":
        markers = read_winter_table(path)
    elif suffix == ".csv":
        from predgait.textfile import read_text

        lines = read_text(path, what="CSV marker file").splitlines()
        header = next((line for line in lines if not line.startswith("#")), "")
        cols = [c.strip() for c in header.split(",")]
        names = [c[:-2] for c in cols if c.endswith("_x") and f"{c[:-2]}_z" in cols]
        if not names:
            raise InputError(f"{path}: no marker columns NAME_x, NAME_y, NAME_z in the header.")
        markers = read_markers_csv(path, {n: (f"{n}_x", f"{n}_y", f"{n}_z") for n in names})
    else:
        raise InputError(f"{path}: unknown marker file type '{suffix}'; give .trc, .c3d, .csv "
                         "or Winter's Table A.1 (.txt).")
    turn = progression_rotation(markers)
    return rotate_trial(Trial(markers=markers, plates=plates, source=str(path)), turn), turn


def progression_rotation(markers: Markers) -> np.ndarray:
    """Rotation about Z that turns the trial's direction of travel into +X.

    C3D files are turned by their reader; TRC/CSV files come in with the file's X
    forward, and an overground walk toward -X (or +-Y) is turned here. Treadmill-like
    trials (net travel < 0.3 m) keep their X axis.
    """
    return lab_rotation(FileAxes.Z_UP, Forward.AUTO, xyz=markers.xyz, source=markers.source)


def _needed_markers(points: Mapping[str, PointSource]) -> list[str]:
    names: list[str] = []
    for source in points.values():
        if isinstance(source, str):
            names.append(source)
        elif isinstance(source, HipRegression):
            names += [source.rasis, source.lasis, source.sacrum]
        else:
            names += list(source.cluster)
    return list(dict.fromkeys(names))


def joint_points(markers: Markers, options: InverseOptions, static: Markers | None
                 ) -> dict[str, np.ndarray]:
    """Positions (n, 3) of hip, knee, ankle centres and heel, toe markers."""
    missing = [p for p in POINT_NAMES if p not in options.points]
    if missing:
        raise InputError(f"no marker given for {', '.join(missing)}; give --markers "
                         "hip=NAME,knee=NAME,ankle=NAME,heel=NAME,toe=NAME (heel may be omitted "
                         "only when the foot is the ankle-toe line).")
    out = {}
    for point, source in options.points.items():
        if isinstance(source, str):
            out[point] = markers.get(source)
        elif isinstance(source, HipRegression):
            out[point] = harrington_hip(markers.get(source.rasis), markers.get(source.lasis),
                                        markers.get(source.sacrum), side=str(options.side))
        else:
            if static is None:
                raise InputError(f"the {point} centre is defined from a static trial; give "
                                 "--static STATIC.trc (or a marker name for it).")
            centre = calibrate_centre(static, point, source.medial, source.lateral,
                                      source.cluster)
            out[point] = centre.locate(markers)
    return out


def foot_pitch(points: Mapping[str, np.ndarray]) -> np.ndarray:
    """Pitch (n,) of the heel-to-toe line about +Y (toe down positive), rad."""
    d = points["toe"] - points["heel"]
    return np.arctan2(-d[..., 2], d[..., 0])


def measured_lengths(points: Mapping[str, np.ndarray]) -> dict[str, float]:
    """Thigh, shank and foot lengths (m): mean sagittal joint-centre and heel-toe distances."""
    def mean_distance(a, b):
        return float(np.nanmean(np.linalg.norm((points[a] - points[b])[..., [0, 2]], axis=-1)))

    return {"thigh": mean_distance("hip", "knee"), "shank": mean_distance("knee", "ankle"),
            "foot": mean_distance("toe", "heel")}


def _build_model(options: InverseOptions, calibration: dict[str, np.ndarray]
                 ) -> tuple[Model, LegParameters | None]:
    """The leg: a given URDF, or the regressions with lengths measured on the markers.

    Segment lengths come from the static trial when there is one, else from the walking
    trial's joint centres (``scale_to_markers``); the height (for the ankle height) may
    then be left out and is estimated from the leg length (Winter 2009, Fig. 4.1).
    """
    if options.model is not None:
        return load_model(options.model), None
    lengths = measured_lengths(calibration) if options.scale_to_markers else None
    height = options.height
    if height is None:
        if lengths is None:
            raise InputError("give --height (m) or --model LEG.urdf to build the leg model.")
        height = (lengths["thigh"] + lengths["shank"]) / (0.245 + 0.246)
    params = leg_from_subject(options.mass, height, lengths=lengths)
    model = model_from_urdf(leg_urdf(params), source=f"leg for {options.mass} kg, "
                                                      f"{height:.4g} m ({params.source})")
    return model, params


def _foot_grf(plates: tuple[ForcePlate, ...], time: np.ndarray, heel: np.ndarray,
              toe: np.ndarray, options: InverseOptions, grf_cutoff: float | None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ground reaction on the analysed foot.

    A plate named after the side (OpenSim's external-loads file maps MOT columns to
    ``right``/``left``) is that foot's. Otherwise each contact on a plate (a run of frames
    with the threshold and its hysteresis) is the foot's when the median horizontal
    distance of its COP from the foot's heel-toe segment is below ``NEAR_FOOT``.
    ``grf_cutoff``: Hz, or None for unfiltered forces.

    Returns:
        Force (n, 3) N, COP (n, 3) m on z = 0 (held where the force is below the
        threshold) and moment (n, 3) N m: the free moment plus whatever part of the
        plates' moment the COP does not carry (zero where the COP is defined and the
        plates lie at z = 0).
    """
    force, moment_o, free = (np.zeros((len(time), 3)) for _ in range(3))
    named = [p for p in plates if p.name == str(options.side)]
    for plate in named or plates:
        if grf_cutoff is not None:
            plate = filter_plate(plate, grf_cutoff, threshold=options.threshold,
                                 release=options.release)
        plate = resample_plate(plate, time, threshold=options.threshold,
                               release=options.release)
        use = np.zeros(len(time), dtype=bool)
        for contact in assign_contacts(plate.cop, plate.force[:, 2] != 0.0,
                                       {"foot": (heel, toe)}, reach=NEAR_FOOT):
            if named or contact.foot is not None:
                use[contact.samples] = True
        force[use] += plate.force[use]
        free[use] += plate.free_moment[use]
        moment_o[use] += np.cross(plate.cop[use], plate.force[use])
    fz = force[:, 2]
    cop = np.zeros_like(force)
    on = fz >= options.threshold
    # COP on the ground plane z = 0 of the summed wrench (sagittal components), held at
    # the nearest defined COP where the (kept) force is below the threshold.
    cop[on, 0] = -moment_o[on, 1] / fz[on]
    cop[on, 1] = moment_o[on, 0] / fz[on]
    cop = hold_nearest(cop, on, np.zeros(3))
    # Where the COP is held (and for plates off z = 0) the point does not carry the
    # plates' whole moment: the rest joins the free moment, so the wrench stays exact.
    return force, cop, free + moment_o - np.cross(cop, force)


def _cop_hint(plates: tuple[ForcePlate, ...], heel: np.ndarray, threshold: float) -> str:
    """Why no contact was found: how far the loaded COPs lie from the foot (units, axes)."""
    loaded = [p.cop[p.force[:, 2] >= threshold, :2] for p in plates]
    loaded = [c for c in loaded if len(c)]
    if not loaded:
        return " (no plate is loaded in the trial: check the force's sign and axes)"
    distance = np.linalg.norm(np.median(np.concatenate(loaded), axis=0)
                              - np.nanmedian(heel[:, :2], axis=0))
    if distance < 5.0:
        return ""
    return (f" (the loaded plates' COP lies {distance:.3g} m from the heel marker: check the "
            "COP columns' units, OpenSim's are m, and the axes)")


def _kinematic_events(time: np.ndarray, points: Mapping[str, np.ndarray], side: Side) -> Events:
    """Zeni et al. (2008) events with the hip centre as the pelvis reference."""
    names = ("heel", "toe", "hip")
    xyz = np.stack([points[n] for n in names], axis=1)
    markers = Markers(time=time, names=names, xyz=xyz, rate=1.0 / float(np.median(np.diff(time))),
                      source="joint centres")
    try:
        return events_from_kinematics(markers, side, heel="heel", toe="toe", pelvis=["hip"])
    except InputError:
        return Events(side=side, heel_strikes=np.array([]), toe_offs=np.array([]))


def flagged_outputs(ik_flagged: np.ndarray, *, stencil: int = 2) -> np.ndarray:
    """Frames whose outputs depend on a flagged IK frame (the 5-point differences reach +-2)."""
    return frames_near(ik_flagged, stencil)


def static_knee_flexion(model: Model, static_points: Mapping[str, np.ndarray]) -> float:
    """Mean knee flexion (rad) of the leg fitted to the static trial's joint centres."""
    pitch = foot_pitch(static_points)
    ik = solve_ik(model, {f"{k}_center": static_points[k] for k in ("hip", "knee", "ankle")},
                  pitch - np.mean(pitch), limit_margin=np.radians(30.0))
    return float(np.mean(clinical.clinical_angles(ik.q)["knee_flexion"]))


def run_inverse(options: InverseOptions, *, loaded: tuple[Trial, np.ndarray] | None = None
                ) -> InverseResult:
    """Run the pipeline (module docstring) on one trial and leg.

    ``loaded`` is the trial already read with its rotation (:func:`read_trial`), e.g. with
    noise added for a noise bootstrap; None reads ``options.markers``.
    """
    trial, turn = read_trial(options) if loaded is None else loaded
    needed = _needed_markers(options.points)
    if trial.markers.n_frames < MIN_FRAMES:
        raise InputError(f"{trial.source}: the trial has {trial.markers.n_frames} frames; "
                         f"inverse dynamics needs at least {MIN_FRAMES} (a gait cycle).")
    markers = fill_gaps(trial.markers, names=needed, max_gap_frames=options.max_gap_frames,
                        edges="trim")
    if markers.n_frames < MIN_FRAMES:
        raise InputError(f"{trial.source}: only {markers.n_frames} frames have all of "
                         f"{', '.join(needed)}; check the marker names.")
    cutoff, cutoff_note = marker_cutoff(markers.select(needed), options.cutoff)
    grf_cutoff = plate_cutoff(trial.plates, options.grf_cutoff, cutoff)
    if cutoff is not None:
        markers = markers.with_xyz(lowpass(markers.xyz, markers.rate, cutoff))
    static = None
    static_points = None
    if options.static is not None:
        static = rotate_markers(read_trc(options.static), turn)
        static_names = [n for s in options.points.values() if isinstance(s, StaticCentre)
                        for n in (s.medial, s.lateral)]
        static = fill_gaps(static, names=list(dict.fromkeys(needed + static_names)),
                           edges="trim")
        static_points = joint_points(static, options, static)
    points = joint_points(markers, options, static)
    pitch = foot_pitch(points)
    if static_points is not None:
        pitch = pitch - float(np.mean(foot_pitch(static_points)))
    model, leg = _build_model(options, static_points if static_points is not None else points)
    knee_static = 0.0 if static_points is None else static_knee_flexion(model, static_points)
    ik = solve_ik(model, {f"{k}_center": points[k] for k in ("hip", "knee", "ankle")}, pitch,
                  limit_margin=np.radians(options.limit_margin))
    if ik.flagged.any():
        bad = np.flatnonzero(ik.flagged)
        log.warning("IK flagged %d frames (first at t = %.3f s): %s", bad.size,
                    markers.time[bad[0]], ik.limited_coordinates() or "not converged")
    time = markers.time
    q = ik.q
    qd = differentiate(q, time, method="central5")
    qdd = differentiate(q, time, method="central5", order=2)
    try:
        force, cop, free = _foot_grf(trial.plates, time, points["heel"], points["toe"],
                                     options, grf_cutoff)
    except InputError as exc:   # a plate's own complaint: say which file it came from
        raise InputError(f"{options.grf or trial.source}: {exc}") from None
    has_grf = bool(trial.plates)
    if has_grf and not np.any(force[:, 2] >= options.threshold):
        raise InputError(f"{options.grf or trial.source}: no plate has a contact (vertical "
                         f"force >= {options.threshold:g} N) under the {options.side} foot"
                         f"{_cop_hint(trial.plates, points['heel'], options.threshold)}.")
    contact = (force[:, 2] != 0)[:, None]
    loads = [LoadHistory("foot", np.where(contact, force, 0.0), cop, np.where(contact, free, 0.0))]
    inv: LegInverse = leg_inverse_dynamics(model, q, qd, qdd, loads)
    if has_grf:
        # Events from the unfiltered reaction: low-pass filtering smears the contact edges.
        raw = _foot_grf(trial.plates, time, points["heel"], points["toe"], options, None)
        foot_plate = ForcePlate(time=time, force=raw[0], cop=raw[1], free_moment=raw[2],
                                name=str(options.side))
        events = events_from_plate(foot_plate, options.side, threshold=options.threshold)
    else:
        events = _kinematic_events(time, points, options.side)
    t0 = float(events.heel_strikes[0]) if len(events.heel_strikes) else 0.0
    provenance = {
        "trial": source_name(options.markers), "grf": source_name(options.grf),
        "static": source_name(options.static), "side": str(options.side),
        "mass_kg": options.mass, "height_m": options.height, "model": model.source,
        "marker_cutoff_hz": cutoff, "marker_cutoff": cutoff_note, "grf_cutoff_hz": grf_cutoff,
        "contact_threshold_n": options.threshold,
        "contact_release_n": options.release * options.threshold,
        "joint_limit_margin_deg": options.limit_margin, "time_zero_s": t0,
        "knee_flexion_standing_deg": float(np.degrees(knee_static)),
    }
    return InverseResult(
        time=time - t0, model=model, side=str(options.side), q=q, qd=qd, qdd=qdd, tau=inv.tau,
        hip_force=inv.hip_force, hip_moment=inv.hip_moment, joint_force=inv.joint_force,
        grf=force, cop=cop, free_moment=free, events=events.shifted(t0), ik=ik,
        body_mass=options.mass, has_grf=has_grf, provenance=provenance, leg=leg,
        flagged=flagged_outputs(ik.flagged), knee_static=knee_static)


def subject01_points(side: Side | str = Side.RIGHT) -> dict[str, PointSource]:
    """Point definitions for the bundled subject01 marker set (Gait2354 example)."""
    s = "R" if str(side) == "right" else "L"
    return {
        "hip": HipRegression("R.ASIS", "L.ASIS", "V.Sacral"),
        "knee": StaticCentre(f"{s}.Knee.Med", f"{s}.Knee.Lat",
                             (f"{s}.Thigh.Upper", f"{s}.Thigh.Front", f"{s}.Thigh.Rear")),
        "ankle": StaticCentre(f"{s}.Ankle.Med", f"{s}.Ankle.Lat",
                              (f"{s}.Shank.Upper", f"{s}.Shank.Front", f"{s}.Shank.Rear")),
        "heel": f"{s}.Heel",
        "toe": f"{s}.Toe.Tip",
    }


def bundled_source(table, key: str = "source") -> str:
    """The trial source a problem table names at ``key``: the bundled trial (the default).

    The one check of a problem file's trial source (leg, gait7, scenarios).

    Raises:
        InputError: Naming the file, key and line, and what to write instead.
    """
    source = table.get(key, str, BUNDLED)
    if source != BUNDLED:
        raise table.error(key, f"{source!r} is not a known trial: use \"{BUNDLED}\" (leg "
                               "problems also take inverse_problem = FILE.toml).")
    return source


def bundled_options(side: Side | str = Side.RIGHT) -> InverseOptions:
    """Options of the bundled subject01 trial (what ``problems/inverse_subject01.toml`` says).

    Its contact threshold stays at the 20 N without hysteresis this trial was first run
    with: the forward engines' stored answers (tests/data/engine_reference.npz) start from
    these moments. Its plates read exactly 0 N unloaded; against OpenSim's results the
    default 10 N with hysteresis changes no r or RMS by more than 0.002.
    """
    folder = bundled_path("subject01_walk1")
    info = subject_info("subject01_walk1")
    return InverseOptions(
        markers=folder / "subject01_walk1.trc", grf=folder / "subject01_walk1_grf.mot",
        static=folder / "subject01_static.trc", mass=info["mass"], height=info["height"],
        side=Side(str(side)), points=subject01_points(side), threshold=20.0, release=1.0)


@functools.lru_cache(maxsize=4)
def bundled_inverse(side: str = "right") -> InverseResult:
    """Inverse dynamics of the bundled subject01 trial with default options (cached)."""
    return run_inverse(bundled_options(side))


def with_options(options: InverseOptions, **changes) -> InverseOptions:
    """A copy of ``options`` with some fields changed."""
    return replace(options, **changes)
