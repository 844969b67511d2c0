"""Model edits of a what-if scenario ("surgery", orthosis, cast), applied to parameters.

Segment edits change the anthropometric parameters and the URDF is regenerated from
them (never edited by hand); joint edits change how the joint behaves in simulation
(locked, restricted range, passive element). Each edit is a frozen dataclass; a TOML
``[[edit]]`` table becomes one through :func:`parse_edit`.

Segment frames sit at the distal joint with Z toward the proximal joint (see
:mod:`predgait.models.urdf`); ``com_fraction`` is measured from the proximal end.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, fields, replace

from predgait.models.anthropometry import FootGeometry, LegParameters, Segment, foot_geometry
from predgait.problemfile import Table

SEGMENTS = ("foot", "shank", "thigh")
JOINTS = ("ankle", "knee")


class EditKind(enum.Enum):
    """The kinds of ``[[edit]]`` a scenario file may hold."""

    SCALE_MASS = "scale_mass"
    SCALE_LENGTH = "scale_length"
    MOVE_COM = "move_com"
    ADD_MASS = "add_mass"
    LOCK_JOINT = "lock_joint"
    RANGE_OF_MOTION = "range_of_motion"
    PASSIVE = "passive"


@dataclass(frozen=True)
class ScaleMass:
    """Multiply a segment's mass (and so its inertia) by ``factor``."""

    segment: str
    factor: float


@dataclass(frozen=True)
class ScaleLength:
    """Multiply a segment's length by ``factor`` (inertia scales with length^2)."""

    segment: str
    factor: float


@dataclass(frozen=True)
class MoveCom:
    """Move a segment's COM along its long axis by ``shift`` m toward the proximal end."""

    segment: str
    shift: float


@dataclass(frozen=True)
class AddMass:
    """Attach a point mass (cast, prosthesis part, weight), kg, on the long axis.

    ``position`` is the fraction of the segment length from the proximal end (foot:
    from the heel). Mass, COM and inertia follow by the parallel-axis theorem.
    """

    segment: str
    mass: float
    position: float


@dataclass(frozen=True)
class LockJoint:
    """Arthrodesis: the joint is held at ``angle`` (clinical, rad) during simulation."""

    joint: str
    angle: float


@dataclass(frozen=True)
class RangeOfMotion:
    """Restrict a joint's clinical range to ``lower``..``upper`` rad (stiff stops)."""

    joint: str
    lower: float
    upper: float


@dataclass(frozen=True)
class PassiveEdit:
    """Add a linear spring-damper (thesis 3.3.1-3.3.2) at a joint: k N m/rad, c N m s/rad.

    An ankle spring is a model of an ankle-foot orthosis; a knee spring, a stiffer knee.
    ``theta0`` is the neutral clinical angle, rad.
    """

    joint: str
    k: float
    c: float
    theta0: float


SegmentEdit = ScaleMass | ScaleLength | MoveCom | AddMass
JointEdit = LockJoint | RangeOfMotion | PassiveEdit


def _scaled_foot(params: LegParameters, factor: float) -> FootGeometry:
    geo = params.foot
    return FootGeometry(*(factor * value for value in (geo.heel_x, geo.toe_x, geo.sole_z,
                                                       geo.com_x, geo.com_z)))


def _foot_from(segment: Segment, params: LegParameters) -> FootGeometry:
    geo = params.foot
    return foot_geometry(segment.length, -geo.sole_z, segment.com_fraction)


def apply_segment_edit(params: LegParameters, edit: SegmentEdit) -> LegParameters:
    """Parameters after one segment edit (a new object; the input is unchanged)."""
    seg = params.segments[edit.segment]
    foot = params.foot
    if isinstance(edit, ScaleMass):
        seg = replace(seg, mass=seg.mass * edit.factor, inertia_yy=seg.inertia_yy * edit.factor)
    elif isinstance(edit, ScaleLength):
        seg = replace(seg, length=seg.length * edit.factor,
                      inertia_yy=seg.inertia_yy * edit.factor**2)
        if edit.segment == "foot":
            foot = _scaled_foot(params, edit.factor)
    elif isinstance(edit, MoveCom):
        fraction = seg.com_fraction - edit.shift / seg.length
        seg = replace(seg, com_fraction=fraction)
        if edit.segment == "foot":
            foot = _foot_from(seg, params)
    elif isinstance(edit, AddMass):
        total = seg.mass + edit.mass
        fraction = (seg.mass * seg.com_fraction + edit.mass * edit.position) / total
        d_old = (seg.com_fraction - fraction) * seg.length
        d_new = (edit.position - fraction) * seg.length
        inertia = seg.inertia_yy + seg.mass * d_old**2 + edit.mass * d_new**2
        seg = replace(seg, mass=total, com_fraction=fraction, inertia_yy=inertia)
        if edit.segment == "foot":
            foot = _foot_from(seg, params)
    else:  # pragma: no cover - the union is closed
        raise TypeError(edit)
    segments = dict(params.segments)
    segments[edit.segment] = seg
    return replace(params, segments=segments, foot=foot, source=f"{params.source} + edits")


def apply_segment_edits(params: LegParameters, edits) -> LegParameters:
    """Apply every segment edit in order; joint edits are left to the simulation."""
    for edit in edits:
        if isinstance(edit, SegmentEdit):
            params = apply_segment_edit(params, edit)
    return params


_KEYS = {
    EditKind.SCALE_MASS: ("segment", "factor"),
    EditKind.SCALE_LENGTH: ("segment", "factor"),
    EditKind.MOVE_COM: ("segment", "shift_m"),
    EditKind.ADD_MASS: ("segment", "mass_kg", "position"),
    EditKind.LOCK_JOINT: ("joint", "angle_deg"),
    EditKind.RANGE_OF_MOTION: ("joint", "lower_deg", "upper_deg"),
    EditKind.PASSIVE: ("joint", "k", "c", "theta0_deg"),
}


def _name(table: Table, key: str, valid: tuple[str, ...]) -> str:
    value = table.get(key, str)
    if value not in valid:
        raise table.error(key, f"'{value}' is not one of: {', '.join(valid)}.")
    return value


def parse_edit(table: Table) -> SegmentEdit | JointEdit:
    """One ``[[edit]]`` table of a scenario file (errors name the file, key and line)."""
    kind = table.choice("kind", EditKind)
    table.check_keys(("kind", *_KEYS[kind]))
    if kind in (EditKind.SCALE_MASS, EditKind.SCALE_LENGTH):
        cls = ScaleMass if kind is EditKind.SCALE_MASS else ScaleLength
        return cls(_name(table, "segment", SEGMENTS), table.number("factor", low=0.2, high=5.0))
    if kind is EditKind.MOVE_COM:
        return MoveCom(_name(table, "segment", SEGMENTS),
                       table.number("shift_m", low=-0.2, high=0.2, unit="m"))
    if kind is EditKind.ADD_MASS:
        return AddMass(_name(table, "segment", SEGMENTS),
                       table.number("mass_kg", low=0.0, high=50.0, unit="kg"),
                       table.number("position", low=0.0, high=1.0))
    joint = _name(table, "joint", JOINTS)
    if kind is EditKind.LOCK_JOINT:
        return LockJoint(joint, math.radians(table.number("angle_deg", low=-90, high=150)))
    if kind is EditKind.RANGE_OF_MOTION:
        lower = table.number("lower_deg", low=-90, high=150, unit="deg")
        upper = table.number("upper_deg", low=-90, high=150, unit="deg")
        if upper <= lower:
            raise table.error("upper_deg", "must be larger than lower_deg.")
        return RangeOfMotion(joint, math.radians(lower), math.radians(upper))
    return PassiveEdit(joint, table.number("k", low=0.0, high=1e5, unit="N m/rad"),
                       table.number("c", 0.0, low=0.0, high=1e4, unit="N m s/rad"),
                       math.radians(table.number("theta0_deg", 0.0, low=-90, high=150)))


_KIND_OF = {ScaleMass: EditKind.SCALE_MASS, ScaleLength: EditKind.SCALE_LENGTH,
            MoveCom: EditKind.MOVE_COM, AddMass: EditKind.ADD_MASS,
            LockJoint: EditKind.LOCK_JOINT, RangeOfMotion: EditKind.RANGE_OF_MOTION,
            PassiveEdit: EditKind.PASSIVE}


def edit_record(edit: SegmentEdit | JointEdit) -> dict:
    """The ``[[edit]]`` table of ``edit``, as in a scenario file (angles in deg).

    ``parse_edit`` of this table gives ``edit`` back; summaries write edits this way.
    """
    kind = _KIND_OF[type(edit)]
    values = [getattr(edit, f.name) for f in fields(edit)]
    record = {"kind": kind.value}
    for key, value in zip(_KEYS[kind], values, strict=True):
        record[key] = math.degrees(value) if key.endswith("_deg") else value
    return record
