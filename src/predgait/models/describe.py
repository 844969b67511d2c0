"""Human-readable tables of a model's segments, joints and frames."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.models.loading import Model


@dataclass(frozen=True)
class SegmentRow:
    """One segment: mass kg, length m, COM m (in the segment frame), Iyy kg m^2 at COM."""

    name: str
    mass: float
    length: float
    com: np.ndarray
    inertia_yy: float


@dataclass(frozen=True)
class JointRow:
    """One joint: name, parent and child segment, axis, limits in rad."""

    name: str
    parent: str
    child: str
    axis: str
    lower: float
    upper: float


def _is_segment(model: Model, frame: pin.Frame) -> bool:
    """A segment's body frame follows a moving joint; marker frames follow fixed joints."""
    parent = model.pin_model.frames[frame.parentFrame]
    return frame.type == pin.FrameType.BODY and parent.type == pin.FrameType.JOINT


def segment_rows(model: Model) -> list[SegmentRow]:
    """Segments with their inertial parameters and length.

    The length of a segment is the largest distance between points fixed to it: its
    frame origin, the frames attached to it and the origins of its child joints.
    """
    pm = model.pin_model
    rows = []
    for frame in pm.frames:
        if not _is_segment(model, frame):
            continue
        inertia = pm.inertias[frame.parentJoint]
        points = [np.zeros(3)]
        points += [f.placement.translation for f in pm.frames
                   if f.parentJoint == frame.parentJoint and f.type == pin.FrameType.BODY]
        points += [pm.jointPlacements[j].translation for j in range(1, pm.njoints)
                   if pm.parents[j] == frame.parentJoint]
        length = max(np.linalg.norm(a - b) for a in points for b in points)
        rows.append(SegmentRow(frame.name, inertia.mass, float(length),
                               inertia.lever.copy(), float(inertia.inertia[1, 1])))
    return rows


def joint_rows(model: Model) -> list[JointRow]:
    """The root joint and the revolute joints with limits."""
    pm = model.pin_model
    body_of = {f.parentJoint: f.name for f in pm.frames if _is_segment(model, f)}
    rows = [JointRow("root", "world", body_of[1], "x, z, pitch about +Y", -np.inf, np.inf)]
    for j in range(2, pm.njoints):
        idx = pm.joints[j].idx_q
        rows.append(JointRow(pm.names[j], body_of[pm.parents[j]], body_of[j], "+Y",
                             float(pm.lowerPositionLimit[idx]),
                             float(pm.upperPositionLimit[idx])))
    return rows


def format_model(model: Model) -> str:
    """The text ``predgait model show`` prints."""
    lines = [f"model: {model.kind} ({model.source})",
             f"total mass: {model.total_mass():.3f} kg; gravity {model.gravity:g} m/s^2; "
             f"coordinates: {', '.join(model.coordinate_names)}", "",
             f"{'segment':<10}{'mass kg':>10}{'length m':>10}{'COM x m':>10}{'COM z m':>10}"
             f"{'Iyy(COM) kg m^2':>17}"]
    for row in segment_rows(model):
        lines.append(f"{row.name:<10}{row.mass:>10.4f}{row.length:>10.4f}{row.com[0]:>10.4f}"
                     f"{row.com[2]:>10.4f}{row.inertia_yy:>17.6f}")
    lines += ["", f"{'joint':<8}{'parent':<8}{'child':<8}{'axis':<22}{'lower deg':>10}"
                  f"{'upper deg':>10}"]
    for row in joint_rows(model):
        lo = "-" if np.isinf(row.lower) else f"{np.degrees(row.lower):.1f}"
        hi = "-" if np.isinf(row.upper) else f"{np.degrees(row.upper):.1f}"
        lines.append(f"{row.name:<8}{row.parent:<8}{row.child:<8}{row.axis:<22}{lo:>10}{hi:>10}")
    frames = [f for f in model.pin_model.frames
              if f.type == pin.FrameType.BODY and not _is_segment(model, f)]
    if frames:
        lines += ["", "frames (position in the segment frame, m):"]
        names = {f.parentJoint: f.name for f in model.pin_model.frames if _is_segment(model, f)}
        for f in frames:
            x, _, z = f.placement.translation
            lines.append(f"  {f.name:<14} on {names[f.parentJoint]:<6} x={x:+.4f} z={z:+.4f}")
    lines.append("COM and frames are in the segment frame: origin at its distal joint "
                 "(foot: ankle; rod: COM), Z along the segment.")
    return "\n".join(lines)
