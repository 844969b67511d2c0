"""Readers of the single ``.osim`` elements (bodies, joints, muscles, actuators, contacts).

Each reader takes the parsed :class:`~predgait.models.osim_xml.Node`, checks that it holds
only known properties, fills OpenSim 4.6's defaults for absent ones, refuses impossible
values and returns the frozen dataclass of :mod:`predgait.models.osim`.
"""

from __future__ import annotations

import math
import re

from predgait.models.osim_functions import Constant, read_function_holder
from predgait.models.osim_records import (
    Body,
    ContactHalfSpace,
    ContactSphere,
    Coordinate,
    CoordinateActuator,
    CoordinateSpring,
    Joint,
    JointKind,
    Muscle,
    OffsetFrame,
    PathPoint,
    PointKind,
    SmoothContact,
)
from predgait.models.osim_xml import Node, OsimFile, properties

_BODY_PATH = re.compile(r"/bodyset/([^/]+)")
_ZERO3 = (0.0, 0.0, 0.0)


def body_of(f: OsimFile, node: Node, path: str, bodies: set[str], *,
            owner: Node | None = None) -> str:
    """Body name of a socket path ``/bodyset/NAME`` or ``/ground``."""
    path = path.strip()
    if path == "/ground":
        return "ground"
    match = _BODY_PATH.fullmatch(path)
    if match is None:
        f.fail(node, f"frame '{path}' is not a body", "attach it to a body "
               "(/bodyset/NAME) or /ground", owner=owner)
    if match.group(1) not in bodies:
        f.fail(node, f"frame '{path}': the model has no body '{match.group(1)}'",
               f"use one of {', '.join(sorted(bodies))}", owner=owner)
    return match.group(1)


def coordinate_of(f: OsimFile, node: Node, path: str, coordinates: set[str], *,
                  owner: Node | None = None) -> str:
    """Coordinate name of a socket path ``/jointset/JOINT/NAME`` (or a bare name)."""
    name = path.strip().rsplit("/", 1)[-1]
    if name not in coordinates:
        f.fail(node, f"coordinate '{path.strip()}' does not exist",
               f"use one of {', '.join(sorted(coordinates))}", owner=owner)
    return name


def read_body(f: OsimFile, node: Node) -> Body:
    """A Body; mass must be given, finite and >= 0, the inertia finite."""
    if node.tag != "Body":
        f.unsupported(node)
    wraps = node.find("WrapObjectSet")
    if wraps is not None:
        for obj in f.set_objects(wraps):
            f.unsupported(obj, node)
    props = properties(f, node, {"mass": "float", "mass_center": "vec3", "inertia": "vec6"},
                       elements={"WrapObjectSet"})
    mass = props.get("mass", math.nan)
    if not math.isfinite(mass) or mass < 0:
        f.fail(node, f"mass = {mass!r} kg", "give a finite mass >= 0 in <mass>")
    inertia = props.get("inertia", (0.0,) * 6)
    return Body(name=node.name, mass=mass, mass_center=props.get("mass_center", _ZERO3),
                inertia=inertia, line=node.line)


def _offset_frame(f: OsimFile, node: Node, bodies: set[str]) -> OffsetFrame:
    if node.tag != "PhysicalOffsetFrame":
        f.unsupported(node)
    props = properties(f, node, {"translation": "vec3", "orientation": "vec3",
                                 "socket_parent": "text"}, ignored={"WrapObjectSet"})
    if "socket_parent" not in props:
        f.fail(node, "has no <socket_parent>", "give the body it is fixed to")
    return OffsetFrame(name=node.name, body=body_of(f, node, props["socket_parent"], bodies),
                       translation=props.get("translation", _ZERO3),
                       orientation=props.get("orientation", _ZERO3), line=node.line)


def _coordinate(f: OsimFile, node: Node, joint: str) -> Coordinate:
    if node.tag != "Coordinate":
        f.unsupported(node)
    props = properties(f, node, {"default_value": "float", "default_speed_value": "float",
                                 "range": "pair", "clamped": "bool", "locked": "bool",
                                 "prescribed": "bool"},
                       elements={"prescribed_function"},
                       ignored={"is_free_to_satisfy_constraints", "motion_type"})
    prescribed = node.find("prescribed_function")
    if props.get("prescribed", False) or (prescribed is not None and prescribed.children):
        f.fail(node, "is prescribed", "remove <prescribed> and <prescribed_function>: "
               "predgait computes the motion itself")
    low, high = props.get("range", (-10.0, 10.0))
    if low > high:
        f.fail(node, f"range {low} > {high}", "give <range> as minimum maximum")
    return Coordinate(name=node.name, joint=joint, default_value=props.get("default_value", 0.0),
                      default_speed_value=props.get("default_speed_value", 0.0),
                      range=(low, high), clamped=props.get("clamped", False),
                      locked=props.get("locked", False), line=node.line)


_N_COORDINATES = {JointKind.PLANAR: 3, JointKind.PIN: 1, JointKind.WELD: 0}


def read_joint(f: OsimFile, node: Node, bodies: set[str]) -> Joint:
    """A PlanarJoint, PinJoint or WeldJoint with its offset frames and coordinates."""
    try:
        kind = JointKind(node.tag)
    except ValueError:
        f.unsupported(node)
    props = properties(f, node, {"socket_parent_frame": "text", "socket_child_frame": "text"},
                       elements={"frames", "coordinates"})
    frames_node = node.find("frames")
    frames = {}
    for child in (frames_node.children if frames_node is not None else []):
        frames[child.name] = _offset_frame(f, child, bodies)
    coord_node = node.find("coordinates")
    coordinates = tuple(_coordinate(f, c, node.name)
                        for c in (coord_node.children if coord_node is not None else []))
    if len(coordinates) != _N_COORDINATES[kind]:
        f.fail(node, f"has {len(coordinates)} coordinates", f"a {kind.value} needs "
               f"{_N_COORDINATES[kind]} in <coordinates>")
    ends = []
    for socket in ("socket_parent_frame", "socket_child_frame"):
        path = props.get(socket)
        if path is None:
            f.fail(node, f"has no <{socket}>", "name one of its frames or a body")
        if path in frames:
            ends.append(frames[path])
        elif path.startswith("/"):
            ends.append(OffsetFrame(name=path, body=body_of(f, node, path, bodies, owner=node),
                                    translation=_ZERO3, orientation=_ZERO3, line=node.line))
        else:
            f.fail(node, f"{socket} '{path}' is not one of its frames "
                   f"({', '.join(frames) or 'none'})", "name a PhysicalOffsetFrame in "
                   "<frames> or a body path such as /bodyset/pelvis")
    return Joint(name=node.name, kind=kind, parent=ends[0], child=ends[1],
                 coordinates=coordinates, line=node.line)


def read_sphere(f: OsimFile, node: Node, bodies: set[str]) -> ContactSphere:
    """A ContactSphere (radius > 0)."""
    props = properties(f, node, {"socket_frame": "text", "radius": "float",
                                 "location": "vec3", "orientation": "vec3"})
    radius = props.get("radius", 0.0)
    if not math.isfinite(radius) or radius <= 0:
        f.fail(node, f"radius = {radius!r} m", "give a positive radius")
    return ContactSphere(name=node.name, body=body_of(f, node, props.get("socket_frame", ""),
                                                      bodies),
                         radius=radius, location=props.get("location", _ZERO3),
                         orientation=props.get("orientation", _ZERO3), line=node.line)


def read_half_space(f: OsimFile, node: Node, bodies: set[str]) -> ContactHalfSpace:
    """A ContactHalfSpace."""
    props = properties(f, node, {"socket_frame": "text", "location": "vec3",
                                 "orientation": "vec3"})
    return ContactHalfSpace(name=node.name,
                            body=body_of(f, node, props.get("socket_frame", ""), bodies),
                            location=props.get("location", _ZERO3),
                            orientation=props.get("orientation", _ZERO3), line=node.line)


_CONTACT = {"stiffness": 1.0, "dissipation": 0.0, "static_friction": 0.0,
            "dynamic_friction": 0.0, "viscous_friction": 0.0, "transition_velocity": 0.01,
            "constant_contact_force": 1e-5, "hertz_smoothing": 300.0,
            "hunt_crossley_smoothing": 50.0}


def read_contact(f: OsimFile, node: Node, spheres: set[str],
                 half_spaces: set[str]) -> SmoothContact:
    """A SmoothSphereHalfSpaceForce (defaults of OpenSim 4.6)."""
    kinds = dict.fromkeys(_CONTACT, "float") | {"socket_sphere": "text",
                                                "socket_half_space": "text",
                                                "appliesForce": "bool"}
    props = properties(f, node, kinds, ignored={"derivative_smoothing"})
    ends = []
    for socket, names in (("socket_sphere", spheres), ("socket_half_space", half_spaces)):
        name = props.get(socket, "").rsplit("/", 1)[-1]
        if name not in names:
            f.fail(node, f"{socket} '{props.get(socket, '')}' is not a "
                   f"{'ContactSphere' if socket == 'socket_sphere' else 'ContactHalfSpace'}",
                   f"use one of {', '.join(sorted(names)) or '(none in the model)'}")
        ends.append(name)
    values = {k: props.get(k, v) for k, v in _CONTACT.items()}
    for key in ("stiffness", "dissipation", "static_friction", "dynamic_friction",
                "viscous_friction", "transition_velocity", "hertz_smoothing",
                "hunt_crossley_smoothing"):
        if not math.isfinite(values[key]) or values[key] < 0:
            f.fail(node, f"{key} = {values[key]!r}", "give a finite value >= 0")
    return SmoothContact(name=node.name, sphere=ends[0], half_space=ends[1], **values,
                         applies_force=props.get("appliesForce", True), line=node.line)


def read_actuator(f: OsimFile, node: Node, coordinates: set[str]) -> CoordinateActuator:
    """A CoordinateActuator on an existing coordinate."""
    props = properties(f, node, {"coordinate": "text", "optimal_force": "float",
                                 "min_control": "float", "max_control": "float",
                                 "appliesForce": "bool"})
    return CoordinateActuator(
        name=node.name,
        coordinate=coordinate_of(f, node, props.get("coordinate", ""), coordinates),
        optimal_force=props.get("optimal_force", 1.0),
        min_control=props.get("min_control", -math.inf),
        max_control=props.get("max_control", math.inf),
        applies_force=props.get("appliesForce", True), line=node.line)


def read_spring(f: OsimFile, node: Node, coordinates: set[str]) -> CoordinateSpring:
    """A SpringGeneralizedForce on an existing coordinate (OpenSim's defaults: 0)."""
    props = properties(f, node, {"coordinate": "text", "stiffness": "float",
                                 "rest_length": "float", "viscosity": "float",
                                 "appliesForce": "bool"})
    for key in ("stiffness", "viscosity"):
        value = props.get(key, 0.0)
        if not math.isfinite(value) or value < 0:
            f.fail(node, f"{key} = {value!r}", "give a finite value >= 0")
    if not math.isfinite(props.get("rest_length", 0.0)):
        f.fail(node, "rest_length is not finite", "give the coordinate value of zero force")
    return CoordinateSpring(
        name=node.name,
        coordinate=coordinate_of(f, node, props.get("coordinate", ""), coordinates),
        stiffness=props.get("stiffness", 0.0), rest_length=props.get("rest_length", 0.0),
        viscosity=props.get("viscosity", 0.0),
        applies_force=props.get("appliesForce", True), line=node.line)


#: DeGrooteFregly2016Muscle defaults of OpenSim 4.6 (a default-constructed muscle).
MUSCLE_DEFAULTS = {
    "max_isometric_force": 1000.0, "optimal_fiber_length": 0.1,
    "tendon_slack_length": 0.2, "pennation_angle_at_optimal": 0.0,
    "max_contraction_velocity": 10.0, "ignore_tendon_compliance": False,
    "ignore_activation_dynamics": False, "activation_time_constant": 0.015,
    "deactivation_time_constant": 0.06, "default_activation": 0.5,
    "default_normalized_tendon_force": 0.5, "active_force_width_scale": 1.0,
    "fiber_damping": 0.0, "passive_fiber_strain_at_one_norm_force": 0.6,
    "tendon_strain_at_one_norm_force": 0.049, "ignore_passive_fiber_force": False,
    "tendon_compliance_dynamics_mode": "explicit", "activation_dynamics_smoothing": 0.1,
    "min_control": 0.0, "max_control": 1.0, "optimal_force": 1.0, "appliesForce": True,
}
_BOOLS = {"ignore_tendon_compliance", "ignore_activation_dynamics",
          "ignore_passive_fiber_force", "appliesForce"}

#: (property, test, what to give): OpenSim's own checks in extendFinalizeFromProperties.
_MUSCLE_CHECKS = (
    ("max_isometric_force", lambda v: v >= 0, "a force >= 0 N"),
    ("optimal_fiber_length", lambda v: v > 0, "a positive length in m"),
    ("tendon_slack_length", lambda v: v >= 0, "a length >= 0 m"),
    ("pennation_angle_at_optimal", lambda v: 0 <= v < math.pi / 2,
     "an angle in [0, pi/2) rad"),
    ("max_contraction_velocity", lambda v: v > 0, "a positive speed (optimal lengths/s)"),
    ("activation_time_constant", lambda v: v > 0, "a positive time in s"),
    ("deactivation_time_constant", lambda v: v > 0, "a positive time in s"),
    ("active_force_width_scale", lambda v: v >= 1, "a scale >= 1"),
    ("fiber_damping", lambda v: v >= 0, "a damping >= 0"),
    ("passive_fiber_strain_at_one_norm_force", lambda v: v > 0, "a positive strain"),
    ("tendon_strain_at_one_norm_force", lambda v: v > 0, "a positive strain"),
)


def read_muscle(f: OsimFile, node: Node, bodies: set[str], coordinates: set[str]) -> Muscle:
    """A DeGrooteFregly2016Muscle with its GeometryPath."""
    kinds = {k: ("bool" if k in _BOOLS else "text" if isinstance(v, str) else "float")
             for k, v in MUSCLE_DEFAULTS.items()}
    props = properties(f, node, kinds, elements={"GeometryPath"})
    values = {k: props.get(k, v) for k, v in MUSCLE_DEFAULTS.items()}
    for key, ok, what in _MUSCLE_CHECKS:
        if not (math.isfinite(values[key]) and ok(values[key])):
            child = node.find(key) or node
            f.fail(child, f"{key} = {values[key]!r}", f"give {what}", owner=node)
    if values["tendon_compliance_dynamics_mode"] not in ("explicit", "implicit"):
        f.fail(node.find("tendon_compliance_dynamics_mode"), "is neither explicit nor "
               "implicit", "write explicit or implicit", owner=node)
    path = node.find("GeometryPath")
    if path is None:
        f.fail(node, "has no <GeometryPath>", "give its path points")
    points = _path(f, path, node, bodies, coordinates)
    values["applies_force"] = values.pop("appliesForce")
    return Muscle(name=node.name, path=points, **values, line=node.line)


def _path(f: OsimFile, path: Node, muscle: Node, bodies: set[str],
          coordinates: set[str]) -> tuple[PathPoint, ...]:
    f.check_known(path, {"PathPointSet", "PathWrapSet"})
    wraps = path.find("PathWrapSet")
    if wraps is not None:
        for obj in f.set_objects(wraps):
            f.unsupported(obj, muscle)
    point_set = path.find("PathPointSet")
    nodes = f.set_objects(point_set) if point_set is not None else []
    points = tuple(_point(f, n, bodies, coordinates) for n in nodes)
    if len(points) < 2:
        f.fail(muscle, f"its path has {len(points)} points", "give at least two path points")
    return points


def _point(f: OsimFile, node: Node, bodies: set[str], coordinates: set[str]) -> PathPoint:
    try:
        kind = PointKind(node.tag)
    except ValueError:
        f.unsupported(node)
    common = {"socket_parent_frame": "text", "location": "vec3"}
    if kind is PointKind.FIXED:
        props = properties(f, node, common)
    elif kind is PointKind.CONDITIONAL:
        props = properties(f, node, common | {"range": "pair", "socket_coordinate": "text",
                                              "coordinate": "text"})
    else:
        axes = [f"{a}_location" for a in "xyz"]
        sockets = [f"socket_{a}_coordinate" for a in "xyz"]
        props = properties(f, node, common | dict.fromkeys(sockets, "text")
                           | dict.fromkeys([f"{a}_coordinate" for a in "xyz"], "text"),
                           elements=axes)
    body = body_of(f, node, props.get("socket_parent_frame", ""), bodies)
    point = {"name": node.name, "kind": kind, "body": body,
             "location": props.get("location", _ZERO3), "line": node.line}
    if kind is PointKind.CONDITIONAL:
        path = props.get("socket_coordinate", props.get("coordinate"))
        if path is None:
            f.fail(node, "has no <socket_coordinate>", "name the coordinate it depends on")
        low, high = props.get("range", (0.0, 0.0))
        if low > high:
            f.fail(node, f"range {low} > {high}", "give <range> as minimum maximum")
        point |= {"coordinate": coordinate_of(f, node, path, coordinates),
                  "range": (low, high)}
    elif kind is PointKind.MOVING:
        functions, names = [], []
        for axis in "xyz":
            holder = node.find(f"{axis}_location")
            functions.append(read_function_holder(f, holder) if holder is not None
                             else Constant(0.0))
            path = props.get(f"socket_{axis}_coordinate", props.get(f"{axis}_coordinate"))
            if path is None and not isinstance(functions[-1], Constant):
                f.fail(node, f"has no <socket_{axis}_coordinate>",
                       f"name the coordinate its {axis}_location depends on")
            names.append(coordinate_of(f, node, path, coordinates) if path else None)
        point |= {"functions": tuple(functions), "function_coordinates": tuple(names)}
    return PathPoint(**point)
