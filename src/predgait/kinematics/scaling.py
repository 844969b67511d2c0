"""Scale the whole body's segment lengths to a static trial (measurement-based scaling).

As OpenSim's ScaleTool "measurement-based" scaling (Delp et al. 2007, IEEE Trans Biomed
Eng 54:1940-1950; OpenSim documentation, "How Scaling Works"): a measurement is a list of
pairs of model frames; its scale factor is the mean ratio of the distance between the
matching trial points (mean over the static frames) to the distance between the frames in
the model. The factor multiplies the lengths the measurement scales (masses stay de
Leva's fractions of body mass; COM and radii of gyration follow the lengths,
:func:`predgait.models.fullbody.build_fullbody_urdf`).

Unlike OpenSim's single pass, the model is rebuilt with the new lengths and measured
again until every measurement's mean ratio is 1 (fixed point): distances that include a
constant part (a marker's offset, a joint centre's lateral offset) are then matched
exactly too. Model distances are taken in a given pose (default: standing, arms down),
e.g. the static trial's pose from inverse kinematics.

Trial points: a frame in the marker map's ``[markers]`` stands for its marker; others are
defined in ``[scaling.points]`` as one marker, the mean of several (knee centre = mid-
epicondyles, ankle = mid-malleoli) or a Harrington et al. (2007) hip centre.

Marker-map tables (TOML; see problems/markers_fullbody_subject01.toml)::

    [scaling.points]         # model frame = trial point
    hip_center_r = {harrington = "right", markers = ["R.ASIS", "L.ASIS", "V.Sacral"]}
    knee_center_r = ["R.Knee.Lat", "R.Knee.Med"]
    heel_contact_r = "R.Heel"
    [scaling.measurements]   # name = [model frame, model frame] pair or list of pairs
    thigh_r = [["hip_center_r", "knee_center_r"]]
    trunk = [["hip_center_r", "shoulder_r"], ["hip_center_l", "shoulder_l"]]
    [scaling.groups]         # optional: lengths a measurement scales (default: its name)
    trunk = ["pelvis", "torso", "upper_trunk"]

Lengths are the names of :data:`predgait.models.fullbody.LENGTHS`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.data.trial import Markers
from predgait.errors import InputError
from predgait.kinematics.joint_centres import harrington_hip
from predgait.models.fullbody import CONTACTS, JOINT_CENTRES, LENGTHS, MARKERS, segment_lengths
from predgait.models.loading import new_data
from predgait.models.loading3d import Model3D, fullbody_for_subject
from predgait.problemfile import Table

MODEL_FRAMES = MARKERS + JOINT_CENTRES + CONTACTS
SIDES = ("right", "left")
MAX_ITERATIONS = 50
TOLERANCE = 1e-7  # on |mean ratio - 1| (0.1 um on a 1 m segment)


@dataclass(frozen=True)
class TrialPoint:
    """A point of the static trial: the mean of ``markers``, or a Harrington hip centre.

    Attributes:
        markers: Trial markers; for ``harrington``: right ASIS, left ASIS, then the sacrum
            or the right and left PSIS (their mean).
        harrington: ``"right"``/``"left"`` hip centre, or None (mean of the markers).
    """

    markers: tuple[str, ...]
    harrington: str | None = None

    def locate(self, mean: Mapping[str, np.ndarray]) -> np.ndarray:
        """(3,) position, m, from the markers' mean positions."""
        pts = [mean[m] for m in self.markers]
        if self.harrington is None:
            return np.mean(pts, axis=0)
        return harrington_hip(pts[0], pts[1], np.mean(pts[2:], axis=0), side=self.harrington)


@dataclass(frozen=True)
class Measurement:
    """Frame pairs measuring the lengths in ``lengths`` (names of ``LENGTHS``)."""

    name: str
    pairs: tuple[tuple[str, str], ...]
    lengths: tuple[str, ...]


@dataclass(frozen=True)
class ScalingSpec:
    """The ``[scaling]`` table of a marker map."""

    points: dict[str, TrialPoint]
    measurements: tuple[Measurement, ...]
    source: str = ""

    def markers(self) -> list[str]:
        """Trial markers the measurements use."""
        used = {f for m in self.measurements for pair in m.pairs for f in pair}
        return sorted({n for f in used for n in self.points[f].markers})


@dataclass(frozen=True)
class Scaling:
    """Result of :func:`scale_fullbody`.

    Attributes:
        lengths: All segment lengths (names of ``LENGTHS``), m.
        factors: Measurement name -> scale factor of its lengths (vs height-based).
        measured: Measurement name -> mean trial distance, m.
        iterations: Model rebuilds until the fixed point.
    """

    lengths: dict[str, float]
    factors: dict[str, float]
    measured: dict[str, float]
    iterations: int


def _point(table: Table, key: str) -> TrialPoint:
    value = table.data[key]
    if isinstance(value, str):
        return TrialPoint((value,))
    if isinstance(value, list) and value and all(isinstance(v, str) for v in value):
        return TrialPoint(tuple(value))
    if isinstance(value, dict):
        sub = table.table(key)
        sub.check_keys(["harrington", "markers"])
        side = sub.get("harrington", str)
        markers = sub.get("markers", list)
        if side not in SIDES or len(markers) not in (3, 4) or not all(
                isinstance(m, str) for m in markers):
            raise table.error(key, 'write {harrington = "right" or "left", markers = [right '
                                   'ASIS, left ASIS, sacrum] or [..., right PSIS, left PSIS]}.')
        return TrialPoint(tuple(markers), side)
    raise table.error(key, "expected a trial marker, a list of markers (their mean) or "
                           "{harrington = ..., markers = [...]}.")


def _pairs(table: Table, key: str, points: Mapping[str, TrialPoint]) -> tuple:
    value = table.data[key]
    if isinstance(value, list) and len(value) == 2 and all(isinstance(v, str) for v in value):
        value = [value]
    if not isinstance(value, list) or not value or not all(
            isinstance(p, list) and len(p) == 2 and all(isinstance(f, str) for f in p)
            for p in value):
        raise table.error(key, 'expected [model frame, model frame] or a list of such pairs, '
                               'e.g. [["hip_center_r", "knee_center_r"]].')
    for a, b in value:
        for frame in (a, b):
            if frame not in MODEL_FRAMES:
                raise table.error(key, f"model frame {frame!r} unknown; frames: "
                                       f"{', '.join(MODEL_FRAMES)}.")
            if frame not in points:
                raise table.error(key, f"model frame {frame!r} has no trial point; map it in "
                                       "[markers] or [scaling.points].")
        if a == b:
            raise table.error(key, f"pair [{a!r}, {b!r}] measures no distance.")
    return tuple((a, b) for a, b in value)


def read_scaling(table: Table, markers: Mapping[str, str]) -> ScalingSpec:
    """Parse a marker map's ``[scaling]`` table (see module docstring).

    Args:
        table: The ``scaling`` sub-table.
        markers: The map's ``[markers]`` (model frame -> trial marker), default points.

    Raises:
        InputError: naming the file, key and line of an unknown frame, length or a
            malformed entry.
    """
    table.check_keys(["points", "measurements", "groups"])
    pts_table = table.table("points")
    points = {f: TrialPoint((m,)) for f, m in markers.items()}
    for key in pts_table.data:
        if key not in MODEL_FRAMES:
            raise pts_table.error(key, f"not a model frame; frames: {', '.join(MODEL_FRAMES)}.")
        points[key] = _point(pts_table, key)
    meas_table, groups = table.table("measurements", required=True), table.table("groups")
    for key in groups.data:
        if key not in meas_table.data:
            raise groups.error(key, "no measurement of this name in [scaling.measurements].")
    measurements, owner = [], {}
    for key in meas_table.data:
        lengths = groups.get(key, list, [key])
        where = groups if key in groups.data else meas_table
        for name in lengths:
            if not isinstance(name, str) or name not in LENGTHS:
                raise where.error(key, f"{name!r} is not a segment length; lengths: "
                                       f"{', '.join(LENGTHS)} (or name the lengths in "
                                       "[scaling.groups]).")
            if name in owner:
                raise where.error(key, f"length {name!r} is already scaled by "
                                       f"{owner[name]!r}.")
            owner[name] = key
        measurements.append(Measurement(key, _pairs(meas_table, key, points), tuple(lengths)))
    if not measurements:
        raise table.error("measurements", "add at least one measurement.")
    return ScalingSpec(points, tuple(measurements), source=str(table.path))


def frame_distances(model: Model3D, pairs, q: np.ndarray | None = None) -> np.ndarray:
    """Distances (m) between model frame pairs in configuration ``q`` (default neutral)."""
    pm, data = model.pin_model, new_data(model.pin_model)
    pin.framesForwardKinematics(pm, data, model.neutral() if q is None else q)
    return np.array([np.linalg.norm(data.oMf[model.frame_id(a)].translation
                                    - data.oMf[model.frame_id(b)].translation)
                     for a, b in pairs])


def trial_distances(spec: ScalingSpec, static: Markers) -> dict[str, np.ndarray]:
    """Measurement name -> (n_pairs,) distances, m, between the static trial's points."""
    missing = [m for m in spec.markers() if m not in static.names]
    if missing:
        raise InputError(f"{spec.source}: [scaling] marker(s) {', '.join(missing)} are not in "
                         f"{static.source or 'the static trial'}; fix [scaling.points].")
    mean = {n: np.nanmean(static.get(n), axis=0) for n in spec.markers()}
    empty = [n for n, v in mean.items() if not np.all(np.isfinite(v))]
    if empty:
        raise InputError(f"{static.source}: marker(s) {', '.join(empty)} have no valid frame "
                         "in the static trial.")
    return {m.name: np.array([np.linalg.norm(spec.points[a].locate(mean)
                                             - spec.points[b].locate(mean)) for a, b in m.pairs])
            for m in spec.measurements}


def scale_fullbody(spec: ScalingSpec, static: Markers, *, mass: float, height: float,
                   sex: str = "male", q: np.ndarray | None = None) -> Scaling:
    """Segment lengths of the whole body that match the static trial's measurements.

    Args:
        spec: Points and measurements (:func:`read_scaling`).
        static: Static trial, lab frame, m.
        mass: Body mass, kg.
        height: Standing height, m (the unscaled lengths).
        sex: de Leva column.
        q: (nq,) pose the model distances are taken in (joint angles matter), default
            neutral (standing, arms down).

    Returns:
        Scaling; build the model with ``fullbody_for_subject(..., lengths=s.lengths)``.

    Raises:
        InputError: missing markers, or a measurement whose distances do not follow its
            lengths (the fixed point is not reached).
    """
    target = trial_distances(spec, static)
    base = segment_lengths(height, sex)
    factors = {m.name: 1.0 for m in spec.measurements}
    for iteration in range(1, MAX_ITERATIONS + 1):
        lengths = base | {n: base[n] * factors[m.name] for m in spec.measurements
                          for n in m.lengths}
        model = fullbody_for_subject(mass, height, sex, lengths=lengths)
        distances = iter(frame_distances(model, [p for m in spec.measurements for p in m.pairs],
                                         q))  # one forward kinematics for all pairs
        ratios = {m.name: float(np.mean(target[m.name]
                                        / np.array([next(distances) for _ in m.pairs])))
                  for m in spec.measurements}
        if max(abs(r - 1.0) for r in ratios.values()) < TOLERANCE:
            measured = {k: float(v.mean()) for k, v in target.items()}
            return Scaling(lengths, factors, measured, iteration)
        factors = {k: f * ratios[k] for k, f in factors.items()}
    worst = max(ratios, key=lambda k: abs(ratios[k] - 1.0))
    raise InputError(f"{spec.source}: [scaling.measurements] {worst}: its distances do not "
                     f"follow the lengths it scales (ratio {ratios[worst]:.4f} after "
                     f"{MAX_ITERATIONS} rebuilds); measure across those segments.")
