"""Read OpenSim ``.osim`` models (the elements of OpenSim's planar gait models).

:func:`read_osim` turns an OpenSim 4 model file into frozen dataclasses, everything in
OpenSim's own frames and units as read (Y up; angles rad; lengths m): bodies, PlanarJoint /
PinJoint / WeldJoint with their offset frames and coordinates, DeGrooteFregly2016Muscle
(every property, OpenSim 4.6's defaults where the file leaves one out) with its
GeometryPath of PathPoint / ConditionalPathPoint / MovingPathPoint (functions SimmSpline,
NaturalCubicSpline, Constant, LinearFunction, MultiplierFunction), CoordinateActuator,
SpringGeneralizedForce (a linear spring-damper on a coordinate, e.g. a passive toe joint),
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
from pathlib import Path

from predgait.errors import InputError
from predgait.models.osim_records import (
    Body,
    ContactHalfSpace,
    ContactSphere,
    Coordinate,
    CoordinateActuator,
    Joint,
    JointKind,
    Muscle,
    OffsetFrame,
    OsimModel,
    PathPoint,
    PointKind,
    SmoothContact,
    Vec3,
)
from predgait.models.osim_xml import Node, OsimFile

#: The records (osim_records) are part of this module's interface.
__all__ = [
    "Body", "ContactHalfSpace", "ContactSphere", "Coordinate", "CoordinateActuator",
    "Joint", "JointKind", "Muscle", "OffsetFrame", "OsimModel", "PathPoint", "PointKind",
    "SmoothContact", "Vec3", "bundled_2d_gait", "bundled_2d_gait_path", "read_osim",
]

#: First OpenSimDocument Version of the OpenSim 4 format (joints in a JointSet).
FIRST_VERSION = 30500

#: Model children skipped (display, metadata) or read only when empty.
_MODEL_SKIP = {"credits", "publications", "ModelVisualPreferences", "assembly_accuracy",
               "defaults", "Ground"}
_EMPTY_SETS = {"ControllerSet", "ConstraintSet", "MarkerSet", "ProbeSet", "ComponentSet"}
_FORCE_TAGS = {"DeGrooteFregly2016Muscle", "CoordinateActuator", "SmoothSphereHalfSpaceForce",
               "SpringGeneralizedForce"}


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
    from predgait.models import osim_elements as el

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
    muscles, actuators, contacts, springs = [], [], [], []
    for n in forces:
        if n.tag == "DeGrooteFregly2016Muscle":
            muscles.append(el.read_muscle(f, n, names, coordinates))
        elif n.tag == "CoordinateActuator":
            actuators.append(el.read_actuator(f, n, coordinates))
        elif n.tag == "SmoothSphereHalfSpaceForce":
            contacts.append(el.read_contact(f, n, {g.name for g in spheres},
                                            {g.name for g in half_spaces}))
        elif n.tag == "SpringGeneralizedForce":
            springs.append(el.read_spring(f, n, coordinates))
        else:
            f.unsupported(n)
    f.check_unique([n for n in forces if n.tag in _FORCE_TAGS], "force")
    if not all(math.isfinite(g) for g in gravity):
        f.fail(model, "gravity is not finite", "give three numbers in m/s^2")
    return OsimModel(name=model.attrib.get("name", Path(path).stem), source=str(path),
                     gravity=gravity, bodies=bodies, joints=joints, muscles=tuple(muscles),
                     actuators=tuple(actuators), spheres=tuple(spheres),
                     half_spaces=tuple(half_spaces), contacts=tuple(contacts),
                     springs=tuple(springs))


def bundled_2d_gait_path() -> Path:
    """Path of the bundled ``2D_gait.osim`` (Moco example2DWalking, OpenSim 4.6)."""
    from importlib import resources

    return Path(str(resources.files("predgait.datasets") / "moco_2d_walking" / "2D_gait.osim"))


def bundled_2d_gait() -> OsimModel:
    """The bundled ``2D_gait.osim`` read by :func:`read_osim`."""
    return read_osim(bundled_2d_gait_path())
