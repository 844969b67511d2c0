"""A predgait planar :class:`~predgait.models.loading.Model` built from an OpenSim model.

Frames. OpenSim is Y up (X forward, Y up, Z right); predgait is X forward, Y left, Z up.
A vector maps as ``p_predgait = P p_opensim = (x, -z, y)`` (P is the rotation of +90 deg
about X), so a rotation about OpenSim's +Z is a rotation about predgait's -Y.

Links. Every OpenSim body becomes a URDF link of the same name whose frame is the
body's *child offset frame* of the joint above it (the PhysicalOffsetFrame the joint
moves), with axes relabelled by P; :meth:`OsimPlanarModel.point_on_body` converts a point
given in the OpenSim body frame to that link (for the 2D gait model every child offset is
the body frame itself). PinJoints become revolute joints about ``0 -1 0`` named after
their coordinate, so every joint value equals OpenSim's; WeldJoints become fixed joints
(their bodies' inertia is merged by Pinocchio and ADAM alike). The PlanarJoint from
ground becomes the loader's planar root: ``base_x = pelvis_tx``, ``base_z = pelvis_ty``,
``base_pitch = -pelvis_tilt`` (:meth:`OsimPlanarModel.q_from_osim`).

Only planar models are accepted: every offset frame may rotate about OpenSim Z only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from predgait.errors import InputError
from predgait.models.loading import Model, model_from_urdf
from predgait.models.osim import Joint, JointKind, OffsetFrame, OsimModel, read_osim

KIND = "osim2d"

#: predgait-from-OpenSim axes: p_predgait = P @ p_opensim.
P = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def _rz(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _num(value: float) -> str:
    text = f"{value:.17g}"
    return "0" if text in ("-0", "0") else text


def _vec(values) -> str:
    return " ".join(_num(float(v)) for v in values)


@dataclass(frozen=True)
class _LinkFrame:
    """Link frame of a body: OpenSim offset (angle about Z, translation) in the body."""

    angle: float
    translation: np.ndarray

    def point(self, location) -> np.ndarray:
        """Point in the body frame (OpenSim) -> point in the link frame (predgait)."""
        return P @ (_rz(self.angle).T @ (np.asarray(location, float) - self.translation))

    def rotation(self) -> np.ndarray:
        """Link-from-body rotation (predgait link axes from OpenSim body axes)."""
        return P @ _rz(self.angle).T


@dataclass(frozen=True, eq=False)
class OsimPlanarModel:
    """An OpenSim planar model and the predgait Model built from it.

    Attributes:
        osim: The model as read.
        model: predgait Model (kind ``osim2d``, planar root, revolute joints).
        osim_coordinates: OpenSim coordinate names in model q order (nq): the planar
            joint's x and y translations and rotation for base_x, base_z, base_pitch,
            then one per model joint.
        signs: q = signs * OpenSim value per entry (+1, except -1 for base_pitch).
    """

    osim: OsimModel
    model: Model
    osim_coordinates: tuple[str, ...]
    signs: np.ndarray = field(repr=False)
    _links: dict = field(repr=False)

    def q_from_osim(self, values) -> np.ndarray:
        """Model coordinates (or speeds, accelerations) from OpenSim values.

        Args:
            values: dict name -> value (or (n,) arrays; other keys are ignored), or an
                array (..., nq) in ``osim_coordinates`` order.

        Returns:
            (nq,) or (n, nq) array.
        """
        if isinstance(values, dict):
            missing = [n for n in self.osim_coordinates if n not in values]
            if missing:
                raise InputError(f"{self.osim.source}: no value for coordinate(s) "
                                 f"{', '.join(missing)}; give all of "
                                 f"{', '.join(self.osim_coordinates)}.")
            values = np.stack([np.asarray(values[n], float) for n in self.osim_coordinates],
                              axis=-1)
        return np.asarray(values, float) * self.signs

    def osim_from_q(self, q) -> dict[str, np.ndarray | float]:
        """OpenSim coordinate values (or speeds) by name from model q ((nq,) or (n, nq))."""
        values = np.asarray(q, float) * self.signs
        return {n: (float(values[..., i]) if values.ndim == 1 else values[..., i])
                for i, n in enumerate(self.osim_coordinates)}

    def default_q(self) -> np.ndarray:
        """(nq,) model q of the coordinates' ``default_value`` (OpenSim's default pose)."""
        return self.q_from_osim({c.name: c.default_value for c in self.osim.coordinates})

    def state_path(self, name: str, quantity: str = "value") -> str:
        """OpenSim state label of a coordinate: ``/jointset/<joint>/<name>/<quantity>``."""
        return f"/jointset/{self.osim.coordinate(name).joint}/{name}/{quantity}"

    def q_from_table(self, columns, *, quantity: str = "value",
                     in_degrees: bool = False) -> np.ndarray:
        """(n, nq) model q (``quantity="value"``) or v (``"speed"``) from table columns.

        Args:
            columns: label -> (n,) values, e.g. ``read_storage(path).columns`` of a Moco
                solution or ``referenceCoordinates.sto``: state labels
                (:meth:`state_path`) or, for values, bare coordinate names.
            quantity: ``value`` (rad, m) or ``speed`` (rad/s, m/s).
            in_degrees: Rotational columns are in degrees (the file's ``inDegrees=yes``).

        Raises:
            InputError: A coordinate has no column (the message names the label).
        """
        rows = {}
        for i, name in enumerate(self.osim_coordinates):
            label = self.state_path(name, quantity)
            if label not in columns and quantity == "value" and name in columns:
                label = name
            if label not in columns:
                raise InputError(f"{self.osim.source}: the table has no column '{label}' "
                                 f"for coordinate {name}; give all of "
                                 f"{', '.join(self.osim_coordinates)}.")
            values = np.asarray(columns[label], float)
            rows[name] = np.deg2rad(values) if in_degrees and i >= 2 else values
        return self.q_from_osim(rows)

    def table_from_q(self, q, *, quantity: str = "value") -> dict[str, np.ndarray]:
        """OpenSim state label -> (n,) values of model q or v ((n, nq)), for an STO file."""
        values = self.osim_from_q(np.atleast_2d(q))
        return {self.state_path(n, quantity): values[n] for n in self.osim_coordinates}

    def body_link(self, body: str) -> str:
        """URDF link (Pinocchio frame) of an OpenSim body; ``ground`` -> ``universe``."""
        if body == "ground":
            return "universe"
        if body not in self._links:
            raise InputError(f"{self.osim.source}: no body '{body}'; bodies: "
                             f"{', '.join(self._links)}.")
        return body

    def point_on_body(self, body: str, location) -> tuple[str, np.ndarray]:
        """Link and link-frame position of a point given in an OpenSim body frame.

        Returns:
            (link name, (3,) position in the link frame, predgait axes, m).
        """
        link = self.body_link(body)
        if body == "ground":
            return link, P @ np.asarray(location, float)
        return link, self._links[body].point(location)

    def rotation_to_link(self, body: str) -> np.ndarray:
        """3x3 rotation taking OpenSim body-frame vectors to the link frame (predgait)."""
        self.body_link(body)
        return P if body == "ground" else self._links[body].rotation()


def _angle(osim: OsimModel, frame: OffsetFrame, joint: Joint) -> float:
    rx, ry, rz = frame.orientation
    if abs(rx) > 1e-12 or abs(ry) > 1e-12:
        raise InputError(f"{osim.source}:{frame.line}: PhysicalOffsetFrame '{frame.name}' of "
                         f"{joint.kind.value} '{joint.name}' rotates about X or Y "
                         f"(orientation {rx:g} {ry:g} {rz:g}); predgait builds planar models "
                         "only: rotate offset frames about Z alone.")
    return rz


def _tree(osim: OsimModel) -> tuple[Joint, list[Joint]]:
    """The planar root joint and the other joints, parents before children."""
    roots = [j for j in osim.joints if j.parent.body == "ground"]
    planar = [j for j in roots if j.kind is JointKind.PLANAR]
    if len(roots) != 1 or len(planar) != 1:
        where = f"{osim.source}:{roots[0].line}: " if roots else f"{osim.source}: "
        raise InputError(f"{where}predgait needs exactly one joint to ground, a PlanarJoint; "
                         f"found {', '.join(f'{j.kind.value} {j.name!r}' for j in roots) or 'none'}"
                         ": connect the other bodies through it.")
    root = planar[0]
    parent_of: dict[str, Joint] = {}
    for j in osim.joints:
        if j.child.body == "ground":
            raise InputError(f"{osim.source}:{j.line}: {j.kind.value} '{j.name}' has ground "
                             "as its child frame; make ground the parent.")
        if j.child.body in parent_of:
            raise InputError(f"{osim.source}:{j.line}: {j.kind.value} '{j.name}': body "
                             f"'{j.child.body}' already has the parent joint "
                             f"'{parent_of[j.child.body].name}'; predgait needs a tree "
                             "(closed loops are not supported).")
        parent_of[j.child.body] = j
    for b in osim.bodies:
        if b.name not in parent_of:
            raise InputError(f"{osim.source}:{b.line}: Body '{b.name}' has no joint to its "
                             "parent; connect it with a PinJoint or WeldJoint.")
    ordered, frontier = [], [root.child.body]
    while frontier:
        body = frontier.pop(0)
        for j in osim.joints:
            if j is not root and j.parent.body == body:
                ordered.append(j)
                frontier.append(j.child.body)
    if len(ordered) != len(osim.joints) - 1:
        loose = {j.name for j in osim.joints} - {j.name for j in ordered} - {root.name}
        raise InputError(f"{osim.source}: joint(s) {', '.join(sorted(loose))} are not "
                         "connected to ground through the PlanarJoint; fix their frames.")
    return root, ordered


def _link_xml(name: str, body, frame: _LinkFrame) -> str:
    ixx, iyy, izz, ixy, ixz, iyz = body.inertia
    inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    rot = frame.rotation()
    i_link = rot @ inertia @ rot.T
    com = frame.point(body.mass_center)
    return (
        f'  <link name="{name}">\n    <inertial>\n'
        f'      <origin xyz="{_vec(com)}" rpy="0 0 0"/>\n'
        f'      <mass value="{_num(body.mass)}"/>\n'
        f'      <inertia ixx="{_num(i_link[0, 0])}" ixy="{_num(i_link[0, 1])}" '
        f'ixz="{_num(i_link[0, 2])}" iyy="{_num(i_link[1, 1])}" iyz="{_num(i_link[1, 2])}" '
        f'izz="{_num(i_link[2, 2])}"/>\n'
        "    </inertial>\n  </link>\n"
    )


def _joint_xml(joint: Joint, links: dict[str, _LinkFrame], osim: OsimModel) -> str:
    parent = links[joint.parent.body]
    xyz = parent.point(joint.parent.translation)
    pitch = -(_angle(osim, joint.parent, joint) - parent.angle)
    origin = f'    <origin xyz="{_vec(xyz)}" rpy="0 {_num(pitch)} 0"/>\n'
    ends = (f'    <parent link="{joint.parent.body}"/>\n'
            f'    <child link="{joint.child.body}"/>\n')
    if joint.kind is JointKind.WELD:
        return f'  <joint name="{joint.name}" type="fixed">\n{ends}{origin}  </joint>\n'
    if joint.kind is not JointKind.PIN:
        raise InputError(f"{osim.source}:{joint.line}: {joint.kind.value} '{joint.name}' "
                         "below the root: predgait supports PinJoint and WeldJoint there; "
                         "replace it.")
    coordinate = joint.coordinates[0]
    if coordinate.locked:
        raise InputError(f"{osim.source}:{coordinate.line}: Coordinate '{coordinate.name}' "
                         "is locked; unlock it, or make the joint a WeldJoint.")
    low, high = coordinate.range
    return (f'  <joint name="{coordinate.name}" type="revolute">\n{ends}{origin}'
            '    <axis xyz="0 -1 0"/>\n'
            f'    <limit lower="{_num(low)}" upper="{_num(high)}" effort="1000" '
            'velocity="50"/>\n  </joint>\n')


def _gravity(osim: OsimModel) -> float:
    gx, gy, gz = osim.gravity
    if abs(gx) > 0 or abs(gz) > 0 or gy > 0:
        raise InputError(f"{osim.source}: gravity ({gx:g}, {gy:g}, {gz:g}) is not along "
                         "OpenSim's -Y; set <gravity> to 0 -g 0.")
    return -gy


def osim_urdf(osim: OsimModel) -> tuple[str, dict[str, _LinkFrame], Joint]:
    """URDF text of a planar OpenSim model, the link frames and the root joint."""
    root, joints = _tree(osim)
    ground = root.parent
    if any(abs(v) > 0 for v in ground.translation + ground.orientation):
        raise InputError(f"{osim.source}:{ground.line}: PlanarJoint '{root.name}': its "
                         "ground frame is offset from ground; set its translation and "
                         "orientation to 0 (predgait's base coordinates are OpenSim's).")
    links = {root.child.body: _LinkFrame(_angle(osim, root.child, root),
                                         np.asarray(root.child.translation, float))}
    for j in joints:
        links[j.child.body] = _LinkFrame(_angle(osim, j.child, j),
                                         np.asarray(j.child.translation, float))
    names = [c.name for j in joints for c in j.coordinates] + \
        [j.name for j in joints if j.kind is JointKind.WELD]
    clash = sorted({n for n in names if names.count(n) > 1})
    if clash:
        raise InputError(f"{osim.source}: name(s) {', '.join(clash)} used by two joints or "
                         "coordinates; rename one.")
    parts = [
        '<?xml version="1.0"?>\n'
        f"<!-- Generated by predgait.models.osim_model from {Path(osim.source).name} "
        f"(OpenSim model '{osim.name}'). Do not edit by hand.\n"
        f"     predgait: kind={KIND} base=planar_xz -->\n"
        f'<robot name="{osim.name}">\n',
        _link_xml(root.child.body, osim.body(root.child.body), links[root.child.body]),
    ]
    for j in joints:
        parts.append(_joint_xml(j, links, osim))
        parts.append(_link_xml(j.child.body, osim.body(j.child.body), links[j.child.body]))
    parts.append("</robot>\n")
    return "".join(parts), links, root


def build_model(osim: OsimModel | str | Path) -> OsimPlanarModel:
    """Build the predgait planar model of an OpenSim model (or of an .osim path).

    Raises:
        InputError: The model is not a planar tree under one PlanarJoint, or has a
            locked coordinate, non-Z offset rotations, or gravity not along -Y.
    """
    if not isinstance(osim, OsimModel):
        osim = read_osim(osim)
    text, links, root = osim_urdf(osim)
    model = model_from_urdf(text, source=osim.source, gravity=_gravity(osim))
    tilt, tx, ty = (c.name for c in root.coordinates)
    names = (tx, ty, tilt, *model.joint_names)
    signs = np.ones(len(names))
    signs[2] = -1.0
    return OsimPlanarModel(osim=osim, model=model, osim_coordinates=names, signs=signs,
                           _links=links)
