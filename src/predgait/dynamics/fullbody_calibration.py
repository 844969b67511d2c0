"""A subject's full-body calibration: the 35-DOF body built, scaled and its markers placed.

Everything of the whole-body inverse that depends on the subject and not on the walk:
build the body for the mass, height and sex, fit its pose to a static trial (about 20 of
its frames; joint centres from the map's ``[scaling.points]`` pose the legs), scale the
segment lengths to it and refit (map ``[scaling]``), place the marker frames on the
measured markers and level the feet on their landmarks (``[calibration] foot_flat``).
Without a static trial the first 10 frames of the walk showing every mapped marker
stand in for it. :func:`calibrate_fullbody` -> :class:`FullbodyCalibration`, used by
:func:`predgait.dynamics.inverse3d_trial.inverse_fullbody`; a batch worker keeps one per
subject (:mod:`predgait.workflows.batch_trial`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from predgait.data.trial import Markers
from predgait.errors import InputError
from predgait.kinematics.foot_flat import FootFlatMode
from predgait.kinematics.ik3d import (
    IKOptions,
    IKResult,
    body_of,
    calibrate_markers,
    solve_ik,
    with_marker_frames,
)
from predgait.kinematics.scaling import Scaling, scale_fullbody
from predgait.kinematics.static_feet import level_static_feet
from predgait.models.fullbody import CONTACTS, JOINT_CENTRES
from predgait.models.loading3d import Model3D, fullbody_for_subject

if TYPE_CHECKING:
    from predgait.dynamics.inverse3d_trial import MarkerMap

#: Anatomical landmark frames a ``[scaling.points]`` entry may pose in the static trial
#: (epicondyle and malleolus markers fix the thigh and shank axial rotations).
LANDMARKS = ("knee_lat_r", "knee_lat_l", "ankle_lat_r", "ankle_lat_l", *CONTACTS)
LEG_BODIES = ("thigh", "shank", "foot")
#: IK weight of the static joint centres (OpenSim's Gait2354 IK weighs its ASIS 10, most
#: markers 1): they carry the anatomical landmarks the skin markers lack.
JOINT_CENTRE_WEIGHT = 10.0
#: Static-trial frames fitted (about; every n-th frame), and walk frames without one.
STATIC_FRAMES, WALK_FRAMES = 20, 10


@dataclass(frozen=True, eq=False)
class FullbodyCalibration:
    """The subject's calibrated body and how it was calibrated.

    ``model``: body (mass kg, height m, sex) with the map's marker frames placed (and the
    static feet levelled); ``static_fit``: the pose fit of the calibration frames (the
    scaled body's); ``centres``: joint-centre and landmark frames posed there;
    ``description``: the provenance's ``marker_calibration``; ``from_static``: a static
    trial (not the walk's first frames) was used; ``mass`` (kg), ``height`` (m), ``sex``
    and ``options``: what it was built and fitted with.
    """

    model: Model3D
    static_fit: IKResult
    unobserved: tuple[str, ...]
    centres: tuple[str, ...]
    scaling: Scaling | None
    static_feet: dict | None
    description: str
    from_static: bool
    mass: float
    height: float
    sex: str
    options: IKOptions


def static_joint_centres(marker_map: MarkerMap, static: Markers) -> dict[str, np.ndarray]:
    """Model joint-centre and landmark frames -> (n, 3) positions (m) per static frame.

    From the map's ``[scaling.points]`` (epicondyle/malleolus midpoints, Harrington hips);
    empty when the map has no joint centre there.
    """
    if marker_map.scaling is None:
        return {}
    points = {f: p for f, p in marker_map.scaling.points.items()
              if f in JOINT_CENTRES + LANDMARKS and f not in marker_map.frames}
    if not any(f in JOINT_CENTRES for f in points):
        return {}
    missing = sorted({m for p in points.values() for m in p.markers} - set(static.names))
    if missing:
        raise InputError(f"{marker_map.source}: [scaling.points] marker(s) {', '.join(missing)} "
                         f"are not in {static.source or 'the static trial'}.")
    return {f: np.array([p.locate({m: static.xyz[k, static.names.index(m)]
                                   for m in p.markers}) for k in range(static.n_frames)])
            for f, p in points.items()}


def first_complete_frames(markers: Markers, names: list[str], count: int) -> Markers:
    """The first ``count`` frames in which every one of ``names`` is visible."""
    visible = np.isfinite(markers.select(names).xyz).all(axis=(1, 2))
    index = np.flatnonzero(visible)[:count]
    if index.size == 0:
        raise InputError(f"{markers.source}: no frame shows all mapped markers at once, so "
                         "the marker frames cannot be calibrated; give a static trial "
                         "(--static) or map fewer markers.")
    return Markers(markers.time[index], markers.names, markers.xyz[index], markers.rate,
                   markers.source)


def unobserved_joints(model: Model3D, frames) -> tuple[str, ...]:
    """Joints with no fitted frame on their segment or beyond (e.g. arms without markers).

    IK holds them at 0 instead of leaving them undetermined.
    """
    pm = model.pin_model
    seen = set()
    for frame in frames:
        seen.update(pm.supports[pm.frames[model.frame_id(frame)].parentJoint])
    return tuple(pm.names[j] for j in range(2, pm.njoints) if j not in seen)


def _scaled_model(marker_map: MarkerMap, static: Markers | None, q: np.ndarray, *,
                  mass: float, height: float, sex: str) -> tuple[Model3D, Scaling]:
    """Whole body with the map's ``[scaling]`` lengths, its segment markers added."""
    if static is None:
        raise InputError(f"{marker_map.source}: [scaling] measures segments on a static "
                         "trial; give one (--static) or remove the [scaling] table.")
    scaling = scale_fullbody(marker_map.scaling, static, mass=mass, height=height, sex=sex, q=q)
    model = fullbody_for_subject(mass, height, sex, lengths=scaling.lengths)
    model = with_marker_frames(model, {m: (b, np.zeros(3)) for m, b in marker_map.segments.items()})
    return model, scaling


def calibrate_fullbody(marker_map: MarkerMap, *, mass: float, height: float, sex: str = "male",
                       static: Markers | None = None, walk: Markers | None = None,
                       options: IKOptions | None = None) -> FullbodyCalibration:
    """Build and calibrate the subject's body (see the module docstring).

    ``mass`` kg, ``height`` m; ``static``: the static trial, else the ``walk``'s first
    complete frames calibrate the markers.

    Raises:
        InputError: a mapped marker missing from the static trial, no calibration frames.
    """
    options = options or IKOptions()
    model = fullbody_for_subject(mass, height, sex)
    model = with_marker_frames(model, {m: (b, np.zeros(3)) for m, b in marker_map.segments.items()})
    frames, names = marker_map.fitted()
    unobserved = unobserved_joints(model, frames)
    centres = {}
    if static is not None:  # about 20 frames of the static trial, standing upright
        marker_map.check(static.names, static.source or "the static trial")
        step = max(1, static.n_frames // STATIC_FRAMES)
        calib = Markers(static.time[::step], static.names, static.xyz[::step],
                        static.rate / step, static.source)
        centres = static_joint_centres(marker_map, calib)
        if centres:  # joint centres from anatomical markers pose the legs
            locked = unobserved
            description = (f"static trial, posed by the joint centres {', '.join(centres)} "
                           f"(weight {JOINT_CENTRE_WEIGHT:g})")
        else:  # legs and lumbar at 0 (the model's neutral is upright standing)
            locked = tuple(j for j in model.joint_names
                           if not j.startswith(("shoulder", "elbow")))
            description = "static trial, legs and lumbar assumed at 0"
    elif walk is not None:  # the first frames of the walk that show every mapped marker
        calib = first_complete_frames(walk, list(names), WALK_FRAMES)
        locked = unobserved
        description = f"trial frames {calib.time[0]:.3f}..{calib.time[-1]:.3f} s"
    else:
        raise ValueError("calibrate_fullbody: give the static trial or the walk.")
    # With anatomical points, leg markers are placed by calibration, not fitted at the
    # model's generic positions (a thigh cluster is not the model's lateral thigh marker).
    posing = {f: m for f, m in marker_map.frames.items()
              if not (centres and body_of(model, f).startswith(LEG_BODIES))}
    static_frames = tuple(posing) + tuple(centres)
    static_xyz = calib.select(list(posing.values())).xyz
    if centres:
        static_xyz = np.concatenate([static_xyz, np.stack(list(centres.values()), axis=1)],
                                    axis=1)
    static_weights = {f: marker_map.weights.get(f, marker_map.weights.get(m, 1.0))
                      for f, m in posing.items()}
    static_weights |= {f: JOINT_CENTRE_WEIGHT if f in JOINT_CENTRES else 1.0 for f in centres}

    def fit_static(body):
        return solve_ik(body, calib.time, static_xyz, static_frames, weights=static_weights,
                        locked=locked, options=options)

    first = fit_static(model)
    scaling = None
    if marker_map.scaling is not None:  # lengths measured in the static pose, then refit
        model, scaling = _scaled_model(marker_map, static, first.q[first.q.shape[0] // 2],
                                       mass=mass, height=height, sex=sex)
        first = fit_static(model)
    model = calibrate_markers(model, first.q, calib.select(list(names)).xyz, frames,
                              marker_map.segments)
    static_feet = None
    if centres and marker_map.foot_flat is not FootFlatMode.OFF:  # flat in the static trial
        model, static_feet = level_static_feet(model, first.q, centres,
                                               {f: body_of(model, f) for f in frames})
    return FullbodyCalibration(model, first, unobserved, tuple(centres), scaling, static_feet,
                               description, static is not None, float(mass), float(height),
                               sex, options)
