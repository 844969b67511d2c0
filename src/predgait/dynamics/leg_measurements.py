"""A trial's measurements for the planar leg: files, joint points, the leg, the foot GRF.

Steps of :func:`predgait.dynamics.inverse_trial.run_inverse` before the IK: read the
markers and plates into the lab frame (:func:`read_trial`), the hip, knee, ankle, heel and
toe points from markers and joint-centre rules (:func:`joint_points`: Harrington hip
regression, static-trial calibration), the subject's leg model from them, the ground
reaction of the plates that load the analysed foot at the marker times
(:func:`foot_grf`) and gait events from the kinematics when there is no plate.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from predgait.data import (
    Side,
    events_from_kinematics,
    filter_plate,
    read_c3d,
    read_external_loads,
    read_grf_mot,
    read_markers_csv,
    read_trc,
    resample_plate,
)
from predgait.data.bundled import read_winter_table
from predgait.data.events import Events
from predgait.data.frames import FileAxes, Forward, lab_rotation, rotate_trial
from predgait.data.resample import check_plates_cover, hold_nearest
from predgait.data.trc import trc_span
from predgait.data.trial import ForcePlate, Markers, Trial
from predgait.dynamics.external import assign_contacts
from predgait.dynamics.inverse_options import (
    POINT_NAMES,
    HipRegression,
    InverseOptions,
    PointSource,
)
from predgait.errors import InputError
from predgait.kinematics.joint_centres import calibrate_centre, harrington_hip
from predgait.models.anthropometry import LegParameters, leg_from_subject
from predgait.models.loading import Model, load_model, model_from_urdf
from predgait.models.urdf import leg_urdf

#: Largest median horizontal distance (m) of a contact's COP from the foot's heel-toe
#: segment for the contact to load that foot.
NEAR_FOOT = 0.1


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


def needed_markers(points: Mapping[str, PointSource]) -> list[str]:
    """The trial markers the point definitions read, in order, each once."""
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
                                        markers.get(source.sacrum), side=options.side)
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


def leg_model(options: InverseOptions, calibration: dict[str, np.ndarray]
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


def foot_grf(plates: tuple[ForcePlate, ...], time: np.ndarray, heel: np.ndarray,
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


def cop_hint(plates: tuple[ForcePlate, ...], heel: np.ndarray, threshold: float) -> str:
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


def kinematic_events(time: np.ndarray, points: Mapping[str, np.ndarray], side: Side) -> Events:
    """Zeni et al. (2008) events with the hip centre as the pelvis reference."""
    names = ("heel", "toe", "hip")
    xyz = np.stack([points[n] for n in names], axis=1)
    markers = Markers(time=time, names=names, xyz=xyz, rate=1.0 / float(np.median(np.diff(time))),
                      source="joint centres")
    try:
        return events_from_kinematics(markers, side, heel="heel", toe="toe", pelvis=["hip"])
    except InputError:
        return Events(side=side, heel_strikes=np.array([]), toe_offs=np.array([]))


