"""The records of an OpenSim model as :func:`predgait.models.osim.read_osim` reads them.

Frozen dataclasses in OpenSim's own frames and units (Y up; rad; m): bodies, joints with
their offset frames and coordinates, DeGrooteFregly2016 muscles with their paths, coordinate
actuators, contact geometry and smooth sphere contacts, and the whole model.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from predgait.errors import InputError
from predgait.models.osim_functions import Function

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
class CoordinateSpring:
    """A SpringGeneralizedForce on a coordinate, OpenSim's sign and units.

    Generalised force ``-stiffness (q - rest_length) - viscosity dq/dt`` (N m with q in rad).
    """

    name: str
    coordinate: str
    stiffness: float
    rest_length: float
    viscosity: float
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
    springs: tuple[CoordinateSpring, ...] = ()

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
