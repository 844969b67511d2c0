"""Read OpenSim ``.osim`` models (the elements of OpenSim's planar gait models).

:func:`read_osim` turns an OpenSim 4 model file into frozen dataclasses, everything in
OpenSim's own frames and units as read (Y up; angles rad; lengths m): bodies, PlanarJoint /
PinJoint / WeldJoint with their offset frames and coordinates, DeGrooteFregly2016Muscle
(every property, OpenSim 4.6's defaults where the file leaves one out) with its
GeometryPath of PathPoint / ConditionalPathPoint / MovingPathPoint (functions SimmSpline,
NaturalCubicSpline, Constant, LinearFunction, MultiplierFunction), CoordinateActuator,
ContactSphere, ContactHalfSpace and SmoothSphereHalfSpaceForce. Display-only elements
(geometry, appearance, empty wrap sets) are skipped. Anything else, and any impossible
value, is refused with one :class:`~predgait.errors.InputError` naming the file, the line,
the element type and name, and what to do. The XML is read with expat, which gives the
line of every element (:mod:`predgait.models.osim_xml`).

Defaults are those OpenSim 4.6 prints for a default-constructed object (e.g. muscle
``default_activation`` 0.5, ``fiber_damping`` 0, ``passive_fiber_strain_at_one_norm_force``
0.6; coordinate range -10..10; gravity (0, -9.80665, 0)). The Moco example's
``derivative_smoothing`` (an old name OpenSim 4.6 no longer reads) is ignored as OpenSim
ignores it: ``constant_contact_force`` keeps its default 1e-5.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

from predgait.errors import InputError
from predgait.models.osim_functions import Function
from predgait.models.osim_xml import Node, OsimFile

Vec3 = tuple[float, float, float]


class JointKind(Enum):
    """Joint types the reader knows (OpenSim element names)."""

    PLANAR = "PlanarJoint"
    PIN = "PinJoint"
    WELD = "WeldJoint"


class PointKind(Enum):
    """Path point types (OpenSim element names)."""

    FIXED = "PathPoint"
    CONDITIONAL = "ConditionalPathPoint"
    MOVING = "MovingPathPoint"


@dataclass(frozen=True)
class Body:
    """A rigid body and its line in the file.

    Mass kg, mass centre m (body frame), inertia about the mass centre kg m^2
    (``Ixx Iyy Izz Ixy Ixz Iyz`` in the body frame).
    """

    name: str
    mass: float
    mass_center: Vec3
    inertia: tuple[float, float, float, float, float, float]
    line: int


@dataclass(frozen=True)
class OffsetFrame:
    """A joint's PhysicalOffsetFrame on ``body`` (a body name or ``ground``).

    Translation m, orientation as body-fixed X-Y-Z rotations, rad.
    """

    name: str
    body: str
    translation: Vec3
    orientation: Vec3
    line: int


@dataclass(frozen=True)
class Coordinate:
    """A joint coordinate (rad or m): default value and speed, range, flags."""

    name: str
    joint: str
    default_value: float
    default_speed_value: float
    range: tuple[float, float]
    clamped: bool
    locked: bool
    line: int


@dataclass(frozen=True)
class Joint:
    """A joint between a parent and a child frame.

    PinJoint turns about the frames' Z; PlanarJoint rotates about Z and translates along
    the parent frame's X and Y (coordinates: rotation, x, y); WeldJoint holds them fixed.
    """

    name: str
    kind: JointKind
    parent: OffsetFrame
    child: OffsetFrame
    coordinates: tuple[Coordinate, ...]
    line: int


@dataclass(frozen=True)
class PathPoint:
    """One point of a GeometryPath on ``body``.

    FIXED and CONDITIONAL points sit at ``location`` (m, body frame); a CONDITIONAL one
    counts only while ``coordinate`` lies in ``range`` (inclusive). A MOVING point's
    x, y, z are ``functions[i](value of function_coordinates[i])``; its ``location`` is
    the file's legacy value, which OpenSim 4.6 ignores.
    """

    name: str
    kind: PointKind
    body: str
    location: Vec3
    line: int
    coordinate: str | None = None
    range: tuple[float, float] | None = None
    functions: tuple[Function, Function, Function] | None = None
    function_coordinates: tuple[str, str, str] | None = None


@dataclass(frozen=True)
class Muscle:
    """A DeGrooteFregly2016Muscle (De Groote et al. 2016, Ann Biomed Eng 44:2922).

    Forces N, lengths m, angles rad, velocity in optimal fibre lengths per second, time
    constants s; ``path`` in file order.
    """

    name: str
    path: tuple[PathPoint, ...]
    max_isometric_force: float
    optimal_fiber_length: float
    tendon_slack_length: float
    pennation_angle_at_optimal: float
    max_contraction_velocity: float
    ignore_tendon_compliance: bool
    ignore_activation_dynamics: bool
    activation_time_constant: float
    deactivation_time_constant: float
    default_activation: float
    default_normalized_tendon_force: float
    active_force_width_scale: float
    fiber_damping: float
    passive_fiber_strain_at_one_norm_force: float
    tendon_strain_at_one_norm_force: float
    ignore_passive_fiber_force: bool
    tendon_compliance_dynamics_mode: str
    activation_dynamics_smoothing: float
    min_control: float
    max_control: float
    optimal_force: float
    applies_force: bool
    line: int


@dataclass(frozen=True)
class CoordinateActuator:
    """Generalised force ``optimal_force * control`` on a coordinate (N m or N)."""

    name: str
    coordinate: str
    optimal_force: float
    min_control: float
    max_control: float
    applies_force: bool
    line: int


@dataclass(frozen=True)
class ContactSphere:
    """Contact sphere of ``radius`` (m) centred at ``location`` on ``body``."""

    name: str
    body: str
    radius: float
    location: Vec3
    orientation: Vec3
    line: int


@dataclass(frozen=True)
class ContactHalfSpace:
    """Half-space x > 0 of the frame at ``location``/``orientation`` on ``body``.

    Simbody's HalfSpace: the body fills x > 0, its outward normal is the frame's -X.
    """

    name: str
    body: str
    location: Vec3
    orientation: Vec3
    line: int


@dataclass(frozen=True)
class SmoothContact:
    """A SmoothSphereHalfSpaceForce between ``sphere`` and ``half_space`` (names).

    Stiffness N/m^2, dissipation s/m, friction coefficients, transition velocity m/s,
    constant contact force N, smoothing constants (Serrancoli et al. 2019).
    """

    name: str
    sphere: str
    half_space: str
    stiffness: float
    dissipation: float
    static_friction: float
    dynamic_friction: float
    viscous_friction: float
    transition_velocity: float
    constant_contact_force: float
    hertz_smoothing: float
    hunt_crossley_smoothing: float
    applies_force: bool
    line: int


@dataclass(frozen=True)
class OsimModel:
    """An OpenSim model as read (OpenSim frames, SI units)."""

    name: str
    source: str
    gravity: Vec3
    bodies: tuple[Body, ...]
    joints: tuple[Joint, ...]
    muscles: tuple[Muscle, ...]
    actuators: tuple[CoordinateActuator, ...]
    spheres: tuple[ContactSphere, ...]
    half_spaces: tuple[ContactHalfSpace, ...]
    contacts: tuple[SmoothContact, ...]

    @property
    def coordinates(self) -> tuple[Coordinate, ...]:
        """All coordinates, joints in file order."""
        return tuple(c for j in self.joints for c in j.coordinates)

    def body(self, name: str) -> Body:
        """The body called ``name`` (InputError if none)."""
        return _named(self.bodies, name, "body", self.source)

    def joint(self, name: str) -> Joint:
        """The joint called ``name``."""
        return _named(self.joints, name, "joint", self.source)

    def coordinate(self, name: str) -> Coordinate:
        """The coordinate called ``name``."""
        return _named(self.coordinates, name, "coordinate", self.source)

    def muscle(self, name: str) -> Muscle:
        """The muscle called ``name``."""
        return _named(self.muscles, name, "muscle", self.source)

    def total_mass(self) -> float:
        """Sum of the body masses, kg."""
        return float(sum(b.mass for b in self.bodies))


def _named(items, name: str, what: str, source: str):
    for item in items:
        if item.name == name:
            return item
    raise InputError(f"{source}: no {what} '{name}'; it has "
                     f"{', '.join(i.name for i in items)}.")


#: First OpenSimDocument Version of the OpenSim 4 format (joints in a JointSet).
FIRST_VERSION = 30500

#: Model children skipped (display, metadata) or read only when empty.
_MODEL_SKIP = {"credits", "publications", "ModelVisualPreferences", "assembly_accuracy",
               "defaults", "Ground"}
_EMPTY_SETS = {"ControllerSet", "ConstraintSet", "MarkerSet", "ProbeSet", "ComponentSet"}
_FORCE_TAGS = {"DeGrooteFregly2016Muscle", "CoordinateActuator", "SmoothSphereHalfSpaceForce"}


def read_osim(path: str | Path) -> OsimModel:
    """Read an OpenSim 4 ``.osim`` model (see the module docstring for what it holds).

    Raises:
        InputError: Unreadable XML, an element the reader does not know, a missing body,
            frame or coordinate, or an impossible value; one message with file, line,
            element and name.
    """
    f = OsimFile.parse(path)
    version = f.root.attrib.get("Version", "")
    if not version.isdigit() or int(version) < FIRST_VERSION:
        raise InputError(f"{path}:{f.root.line}: OpenSimDocument Version '{version}' is older "
                         f"than OpenSim 4's format ({FIRST_VERSION}); open the model in "
                         "OpenSim 4 and save it again to convert it.")
    model = f.root.only_child("Model", f)
    f.check_known(f.root, {"Model"})
    forces: list[Node] = []
    geometry: list[Node] = []
    body_nodes: list[Node] = []
    joint_nodes: list[Node] = []
    gravity = (0.0, -9.80665, 0.0)
    for child in model.children:
        tag = child.tag
        if tag in _MODEL_SKIP:
            continue
        if tag == "gravity":
            gravity = f.vec(child, 3)
        elif tag in ("length_units", "force_units"):
            want = "meters" if tag == "length_units" else "N"
            if child.text.strip() != want:
                f.fail(child, f"{tag} is '{child.text.strip()}'",
                       f"convert the model to {want} (predgait reads SI units)")
        elif tag == "components":
            forces += child.children
        elif tag in ("ForceSet", "BodySet", "JointSet", "ContactGeometrySet"):
            objects = f.set_objects(child)
            {"ForceSet": forces, "BodySet": body_nodes, "JointSet": joint_nodes,
             "ContactGeometrySet": geometry}[tag].extend(objects)
        elif tag in _EMPTY_SETS:
            for obj in f.set_objects(child):
                f.unsupported(obj)
        else:
            f.unsupported(child)
    from predgait.models import osim_elements as el  # it imports this module's classes

    bodies = tuple(el.read_body(f, n) for n in body_nodes)
    f.check_unique(body_nodes, "Body")
    names = {b.name for b in bodies} | {"ground"}
    joints = tuple(el.read_joint(f, n, names) for n in joint_nodes)
    f.check_unique(joint_nodes, "Joint")
    f.check_unique([c for n in joint_nodes for k in n.children if k.tag == "coordinates"
                    for c in k.children], "Coordinate")
    f.check_unique(geometry, "contact geometry")
    coordinates = {c.name for j in joints for c in j.coordinates}
    spheres, half_spaces = [], []
    for n in geometry:
        if n.tag == "ContactSphere":
            spheres.append(el.read_sphere(f, n, names))
        elif n.tag == "ContactHalfSpace":
            half_spaces.append(el.read_half_space(f, n, names))
        else:
            f.unsupported(n)
    muscles, actuators, contacts = [], [], []
    for n in forces:
        if n.tag == "DeGrooteFregly2016Muscle":
            muscles.append(el.read_muscle(f, n, names, coordinates))
        elif n.tag == "CoordinateActuator":
            actuators.append(el.read_actuator(f, n, coordinates))
        elif n.tag == "SmoothSphereHalfSpaceForce":
            contacts.append(el.read_contact(f, n, {g.name for g in spheres},
                                            {g.name for g in half_spaces}))
        else:
            f.unsupported(n)
    f.check_unique([n for n in forces if n.tag in _FORCE_TAGS], "force")
    if not all(math.isfinite(g) for g in gravity):
        f.fail(model, "gravity is not finite", "give three numbers in m/s^2")
    return OsimModel(name=model.attrib.get("name", Path(path).stem), source=str(path),
                     gravity=gravity, bodies=bodies, joints=joints, muscles=tuple(muscles),
                     actuators=tuple(actuators), spheres=tuple(spheres),
                     half_spaces=tuple(half_spaces), contacts=tuple(contacts))


def bundled_2d_gait_path() -> Path:
    """Path of the bundled ``2D_gait.osim`` (Moco example2DWalking, OpenSim 4.6)."""
    from predgait.data.bundled import bundled_path

    return bundled_path("moco_2d_walking/2D_gait.osim")


def bundled_2d_gait() -> OsimModel:
    """The bundled ``2D_gait.osim`` read by :func:`read_osim`."""
    return read_osim(bundled_2d_gait_path())
