"""Load a predgait URDF into Pinocchio with its planar base.

The URDF holds revolute joints only (ADAM 0.5 fails on prismatic joints). The base
segment (the rod, the leg's foot) gets its sagittal-plane motion here, as a Pinocchio
composite root joint PX-PZ-RY: generalised coordinates ``base_x``, ``base_z`` (m, lab
frame, of the base link origin) and ``base_pitch`` (rad, about +Y), whose velocities
are the plain time derivatives. The same URDF gives the ADAM model in
:mod:`predgait.models.symbolic`; a test keeps both equal.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from predgait.errors import InputError
from predgait.models import anthropometry, urdf
from predgait.models.urdf_read import build_pinocchio
from predgait.textfile import read_text

#: Standard gravity used by both Pinocchio and ADAM unless a problem file says otherwise.
GRAVITY = 9.81

DEFAULT_SUBJECT = anthropometry.DEFAULT_SUBJECT

BASE_COORDINATES = ("base_x", "base_z", "base_pitch")


def new_data(pin_model: pin.Model) -> pin.Data:
    """A fresh Pinocchio ``Data`` of ``pin_model``, as ``pin_model.createData()`` gives.

    Constructed directly (``pin.Data(model)``): the ``createData`` binding of Pinocchio 4.1
    costs about 2 ms on the 35-DOF body (185 frames), the constructor 0.06 ms, and a batch
    trial makes several.
    """
    return pin.Data(pin_model)


@dataclass(frozen=True, eq=False)
class RigidBodyModel:
    """A predgait model: the URDF text and its Pinocchio model (planar or 3D base).

    Attributes:
        urdf: URDF text (the single source of geometry and inertia).
        kind: ``rod``, ``leg``, ``gait7`` or ``fullbody``.
        pin_model: Pinocchio model with the root joint added by the loader.
        gravity: Magnitude of gravity along -Z, m/s^2.
        source: Where the URDF came from (path or generator description).
    """

    urdf: str
    kind: str
    pin_model: pin.Model = field(repr=False)
    gravity: float
    source: str

    @property
    def nq(self) -> int:
        """Number of generalised coordinates."""
        return self.pin_model.nq

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Names of the URDF (revolute) joints, in coordinate order."""
        return tuple(self.pin_model.names[2:])

    def frame_names(self) -> list[str]:
        """All frame names but the universe."""
        return [f.name for f in self.pin_model.frames if f.name != "universe"]

    def frame_id(self, name: str) -> int:
        """Pinocchio frame index of a named frame or link, with a clear error."""
        if not self.pin_model.existFrame(name):
            raise InputError(f"model '{self.kind}' has no frame '{name}'; it has "
                             f"{', '.join(sorted(set(self.frame_names())))}.")
        return self.pin_model.getFrameId(name)

    def total_mass(self) -> float:
        """Total mass, kg."""
        return float(sum(inertia.mass for inertia in self.pin_model.inertias))


@dataclass(frozen=True, eq=False)
class Model(RigidBodyModel):
    """A planar model (rod, leg, gait7): nq = nv, base coordinates x, z, pitch."""

    @property
    def coordinate_names(self) -> tuple[str, ...]:
        """Names of the generalised coordinates: the base ones, then the joints."""
        return BASE_COORDINATES + self.joint_names

    @property
    def n_base(self) -> int:
        """Number of base coordinates (3: x, z, pitch)."""
        return len(BASE_COORDINATES)

    def coordinate_index(self, name: str) -> int:
        """Index of a generalised coordinate, with a clear error for unknown names."""
        try:
            return self.coordinate_names.index(name)
        except ValueError:
            raise InputError(f"model '{self.kind}' has no coordinate '{name}'; it has "
                             f"{', '.join(self.coordinate_names)}.") from None


def planar_root_joint() -> pin.JointModelComposite:
    """Composite PX-PZ-RY root joint: sagittal-plane motion of the base link."""
    joint = pin.JointModelComposite(3)
    joint.addJoint(pin.JointModelPX())
    joint.addJoint(pin.JointModelPZ())
    joint.addJoint(pin.JointModelRY())
    return joint


def model_from_urdf(text: str, *, source: str = "URDF", gravity: float = GRAVITY) -> Model:
    """Build a :class:`Model` from predgait URDF text."""
    info = urdf.read_urdf_info(text, source=source)
    if info.base != "planar_xz":
        raise InputError(f"{source}: base '{info.base}' is not supported; expected planar_xz.")
    if not np.isfinite(gravity) or not 0.0 <= gravity <= 30.0:
        raise InputError(f"gravity = {gravity!r} m/s^2 is out of range 0..30.")
    pin_model = build_pinocchio(text, planar_root_joint(), source=source)
    pin_model.gravity.linear = np.array([0.0, 0.0, -gravity])
    return Model(urdf=text, kind=info.kind, pin_model=pin_model, gravity=gravity, source=source)


def generate_urdf(kind: str, *, mass: float | None = None, height: float | None = None,
                  length: float | None = None, segments: str | Path | None = None) -> str:
    """URDF text of a model kind from anthropometry or a segment table.

    Args:
        kind: ``rod`` or ``leg``.
        mass: Body mass (leg) or rod mass, kg. Defaults: the bundled subject / the
            thesis rod.
        height: Standing height for the leg, m.
        length: Rod length, m.
        segments: CSV of segment parameters for the leg (overrides mass/height).
    """
    if kind == "rod":
        rod = anthropometry.rod_segment(
            anthropometry.ROD_MASS_KG if mass is None else mass,
            anthropometry.ROD_LENGTH_M if length is None else length,
        )
        return urdf.rod_urdf(rod)
    if kind == "leg":
        if segments is not None:
            return urdf.leg_urdf(anthropometry.leg_from_csv(segments))
        params = anthropometry.leg_from_subject(
            DEFAULT_SUBJECT["mass"] if mass is None else mass,
            DEFAULT_SUBJECT["height"] if height is None else height,
        )
        return urdf.leg_urdf(params)
    raise InputError(f"unknown model kind '{kind}'; choose rod or leg.")


@functools.lru_cache(maxsize=16)
def _default_model(kind: str, gravity: float) -> Model:
    return model_from_urdf(generate_urdf(kind), source=f"default {kind}", gravity=gravity)


def load_model(source: str | Path, *, gravity: float = GRAVITY) -> Model:
    """Load a model: ``"rod"``/``"leg"`` (defaults) or the path of a predgait URDF."""
    if str(source) in ("rod", "leg"):
        return _default_model(str(source), gravity)
    path = Path(source)
    if not path.is_file():
        raise InputError(f"{path}: model file not found; give a URDF made by "
                         "'predgait model build', or 'leg' / 'rod'.")
    return model_from_urdf(read_text(path, what="URDF model"), source=str(path), gravity=gravity)
