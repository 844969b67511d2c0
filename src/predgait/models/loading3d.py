"""Load a 3D predgait URDF (whole body) into Pinocchio with a free-flyer pelvis, and ADAM.

Pinocchio: root joint ``pin.JointModelFreeFlyer()`` named ``root``; q = (x, y, z of the
pelvis origin in the lab, m; quaternion qx, qy, qz, qw of the pelvis orientation) then
the 29 revolute joints; v = (linear velocity of the pelvis origin in the PELVIS frame,
angular velocity in the pelvis frame) then the joint rates (nq = 36, nv = 35).

ADAM (:func:`adam_kindyn`) is built from the same URDF with the joints in Pinocchio's
order and ``Representations.BODY_FIXED_REPRESENTATION``, whose base velocity is the
body-fixed twist (linear, angular), i.e. Pinocchio's free-flyer velocity: mass matrix,
bias force and RNEA agree term by term (``tests/test_fullbody.py``).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from predgait.errors import InputError
from predgait.models import urdf as urdf_info
from predgait.models.fullbody import build_fullbody_urdf
from predgait.models.loading import DEFAULT_SUBJECT, GRAVITY, RigidBodyModel
from predgait.models.urdf_read import build_pinocchio
from predgait.textfile import read_text

ROOT_COORDINATES = ("pelvis_x", "pelvis_y", "pelvis_z", "pelvis_qx", "pelvis_qy",
                    "pelvis_qz", "pelvis_qw")
ROOT_VELOCITIES = ("pelvis_vx", "pelvis_vy", "pelvis_vz", "pelvis_wx", "pelvis_wy",
                   "pelvis_wz")
DEFAULT_SEX = "male"


@dataclass(frozen=True, eq=False)
class Model3D(RigidBodyModel):
    """A 3D model with a free-flyer pelvis.

    nq = nv + 1: the pelvis orientation is a quaternion in q, an angular velocity in v.
    """

    @property
    def nv(self) -> int:
        """Velocity size (6 + joints)."""
        return self.pin_model.nv

    @property
    def velocity_names(self) -> tuple[str, ...]:
        """Names of the nv velocity (and generalised force) entries."""
        return ROOT_VELOCITIES + self.joint_names

    def joint_velocity_index(self, name: str) -> int:
        """Index in v (and tau) of revolute joint ``name``."""
        pm = self.pin_model
        if not pm.existJointName(name):
            raise InputError(f"model '{self.kind}' has no joint '{name}'.")
        return pm.joints[pm.getJointId(name)].idx_v

    def neutral(self) -> np.ndarray:
        """Upright standing configuration with the pelvis at the origin, (nq,)."""
        return pin.neutral(self.pin_model)


def model3d_from_urdf(text: str, *, source: str = "URDF", gravity: float = GRAVITY) -> Model3D:
    """Build a :class:`Model3D` from predgait URDF text with a free-flyer base."""
    info = urdf_info.read_urdf_info(text, source=source)
    if info.base != "free_flyer":
        raise InputError(f"{source}: base '{info.base}' is not a 3D free-flyer model; load it "
                         "with predgait.models.loading.load_model.")
    if not np.isfinite(gravity) or not 0.0 <= gravity <= 30.0:
        raise InputError(f"gravity = {gravity!r} m/s^2 is out of range 0..30.")
    pin_model = build_pinocchio(text, pin.JointModelFreeFlyer(), source=source)
    pin_model.gravity.linear = np.array([0.0, 0.0, -gravity])
    return Model3D(urdf=text, kind=info.kind, pin_model=pin_model, gravity=gravity,
                   source=source)


@functools.lru_cache(maxsize=8)
def _default(gravity: float) -> Model3D:
    text = build_fullbody_urdf(DEFAULT_SUBJECT["mass"], DEFAULT_SUBJECT["height"], DEFAULT_SEX)
    return model3d_from_urdf(text, source="default fullbody", gravity=gravity)


def load_fullbody(source: str | Path = "fullbody", *, gravity: float = GRAVITY) -> Model3D:
    """Load ``"fullbody"`` (subject01: 72.6 kg, 1.8034 m, male) or a 3D URDF path."""
    if str(source) == "fullbody":
        return _default(gravity)
    path = Path(source)
    if not path.is_file():
        raise InputError(f"{path}: model file not found; give a URDF made by "
                         "'predgait model build fullbody', or 'fullbody'.")
    return model3d_from_urdf(read_text(path, what="URDF model"), source=str(path), gravity=gravity)


def fullbody_for_subject(mass: float, height: float, sex: str = DEFAULT_SEX, *,
                         lengths: Mapping[str, float] | None = None,
                         gravity: float = GRAVITY) -> Model3D:
    """Whole body generated for a subject (not cached).

    ``lengths`` (m) as in :func:`predgait.models.fullbody.build_fullbody_urdf`.
    """
    scaled = ", scaled segment lengths" if lengths else ""
    return model3d_from_urdf(build_fullbody_urdf(mass, height, sex, lengths=lengths),
                             source=f"fullbody {mass:g} kg {height:g} m {sex}{scaled}",
                             gravity=gravity)


def adam_kindyn(model: Model3D, *, backend: str = "casadi"):
    """ADAM KinDynComputations (``casadi`` or ``numpy``) in the body-fixed representation."""
    from predgait.models.adam_import import kindyn_class, representations

    gravity = np.array([0.0, 0.0, -model.gravity, 0.0, 0.0, 0.0])
    kindyn = kindyn_class(backend)(model.urdf, list(model.joint_names), gravity=gravity)
    kindyn.set_frame_velocity_representation(representations().BODY_FIXED_REPRESENTATION)
    return kindyn


def base_transform(q: np.ndarray) -> np.ndarray:
    """4x4 world-from-pelvis transform of a configuration (numpy)."""
    return pin.XYZQUATToSE3(np.asarray(q[:7], dtype=float)).homogeneous
