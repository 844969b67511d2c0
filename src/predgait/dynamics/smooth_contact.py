"""Simbody's SmoothSphereHalfSpaceForce: a sphere on the floor, for NumPy and CasADi alike.

The smooth Hunt-Crossley contact of Serrancoli et al. (2019, IEEE Trans Neural Syst Rehabil
Eng 27(8):1597-1605) as Simbody implements it (``Simbody/src/SmoothSphereHalfSpaceForce.cpp``,
``SmoothSphereHalfSpaceForceImpl::calcForce``, authors A. Falisse and G. Serrancoli; OpenSim's
``SmoothSphereHalfSpaceForce`` passes its properties straight to it), used by Moco's
example2DWalking and Falisse et al. (2019, J R Soc Interface 16:20190402).

In predgait's lab frame (floor z = 0, outward normal +Z, X forward, Y left) with the sphere
centre c (m), radius R, its centre velocity v and its body's angular velocity w:

    indentation      d  = R - c_z                                (m, > 0 in the floor)
    contact point    p  = c - (R - d/2) z          (midway between the two surfaces)
    its velocity     vp = v + w x (p - c)           (a point of the sphere's body)
    normal speed     vn = -vp_z                     (> 0 while sinking in)
    slip             vt = (vp_x, vp_y, 0),  s = sqrt(|vt|^2 + cf)

    k    = E^(2/3) / 2                                      (E: ``stiffness``, N/m^2)
    F_H  = (4/3) k sqrt(R k) (d^2 + cf)^(3/4) [1/2 + tanh(b_d d) / 2]       (Hertz)
    F_HC = F_H (1 + (3/2) c vn) [1/2 + tanh(b_v (vn + 2 / (3 c))) / 2]  (Hunt-Crossley)
    mu   = min(s / v_t, 1) [mu_d + 2 (mu_s - mu_d) / (1 + (s / v_t)^2)] + mu_v s
    force on the sphere = F_HC z - mu F_HC vt / s

with c ``dissipation`` (s/m), cf ``constant_contact_force`` (the same constant keeps both
square roots away from zero), b_d ``hertz_smoothing`` (1/m), b_v ``hunt_crossley_smoothing``
(s/m), mu_s, mu_d static and dynamic friction, mu_v ``viscous_friction`` (s/m), v_t
``transition_velocity`` (m/s). Names are the .osim property names.

What follows from Simbody's form (checked against OpenSim 4.6 in tests/test_smooth_contact.py,
table tests/reference/osim2d/contact_force.csv):

* The force does not vanish above the floor: at 1 cm height the Moco example's heel sphere
  still carries 0.72 N (the tanh tail times the cf floor), 3e-10 N at 5 cm.
* Lifting off faster than 2 / (3 c) (1/3 m/s for c = 2 s/m) makes 1 + 3/2 c vn negative, and
  its tanh switch is not exactly 0: a small pull (-2.6 N in the table).
* The friction coefficient's ``min(s / v_t, 1)`` has a kink at slip = transition velocity
  (continuous, slope jump), as in Simbody.
* The slip is that of the contact point, not of the centre: a foot rolling at 5 rad/s on
  the 35 mm heel sphere slips 0.17 m/s more or less than its centre moves, comparable to
  the 0.2 m/s transition velocity; pass ``angular_velocity`` to match OpenSim (along Moco's
  example2DWalking tracking gait, the centre's slip instead is off by up to 101 N, of a
  480 N heel force peak; tests/reference/osim2d/gait_contact.csv).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from predgait.dynamics.backend import is_casadi
from predgait.errors import InputError


def _ops(*values):
    """(tanh, sqrt, fmin, stack) of numpy or CasADi, whichever the values need."""
    if is_casadi(*values):
        import casadi

        return casadi.tanh, casadi.sqrt, casadi.fmin, lambda parts: casadi.vertcat(*parts)
    return np.tanh, np.sqrt, np.minimum, lambda parts: np.stack(np.broadcast_arrays(*parts), -1)


def _parts(vector, like):
    """The x, y, z components of a (3,) / (..., 3) array or a CasADi 3-vector."""
    if is_casadi(vector, *like):
        return vector[0], vector[1], vector[2]
    array = np.asarray(vector, dtype=float)
    if array.shape[-1:] != (3,):
        raise ValueError(f"expected a 3-vector (..., 3), got shape {array.shape}")
    return array[..., 0], array[..., 1], array[..., 2]


@dataclass(frozen=True)
class SmoothSphereContact:
    """One SmoothSphereHalfSpaceForce: a sphere of ``radius`` on the floor z = 0.

    Field names and defaults are those of OpenSim 4.6's SmoothSphereHalfSpaceForce
    properties (a default-constructed element); every field may be a float or a CasADi
    symbol (parameter studies). Units: radius m, stiffness N/m^2, dissipation s/m,
    viscous_friction s/m, transition_velocity m/s, hertz_smoothing 1/m,
    hunt_crossley_smoothing s/m; constant_contact_force as Simbody uses it (added to d^2
    in m^2 and to the squared slip in m^2/s^2).
    """

    radius: Any
    stiffness: Any = 1.0
    dissipation: Any = 0.0
    static_friction: Any = 0.0
    dynamic_friction: Any = 0.0
    viscous_friction: Any = 0.0
    transition_velocity: Any = 0.01
    constant_contact_force: Any = 1e-5
    hertz_smoothing: Any = 300.0
    hunt_crossley_smoothing: Any = 50.0

    def __post_init__(self):
        positive = ("radius", "stiffness", "transition_velocity", "constant_contact_force")
        for field in fields(self):
            value = getattr(self, field.name)
            if is_casadi(value):
                continue
            bad = not math.isfinite(float(value)) or float(value) < 0.0 or (
                field.name in positive and float(value) == 0.0)
            if bad:
                need = "> 0" if field.name in positive else ">= 0"
                raise InputError(
                    f"smooth sphere contact: {field.name} = {value!r} is not finite and "
                    f"{need}; give {field.name} {need} (SmoothSphereHalfSpaceForce property, "
                    "or the ContactSphere's radius)")

    @classmethod
    def from_osim(cls, record, radius: float) -> SmoothSphereContact:
        """The law of a SmoothSphereHalfSpaceForce record and its sphere's radius (m).

        Args:
            record: any object with the .osim property names as attributes (the reader's
                ``predgait.models.osim.SmoothContact``).
            radius: the ContactSphere's radius, m.
        """
        names = [f.name for f in fields(cls) if f.name != "radius"]
        return cls(radius=radius, **{name: getattr(record, name) for name in names})

    def normal_force(self, indentation, rate):
        """Smoothed Hunt-Crossley normal force F_HC (N, along the floor normal).

        Args:
            indentation: d = R - height of the centre, m (> 0 in the floor).
            rate: normal speed vn = d' (m/s, > 0 while sinking in).
        """
        tanh, sqrt, _, _ = _ops(indentation, rate, *self._values())
        k = 0.5 * self.stiffness ** (2.0 / 3.0)
        hertz = (4.0 / 3.0) * k * sqrt(self.radius * k) * (
            indentation * indentation + self.constant_contact_force) ** 0.75
        hertz = hertz * (0.5 + 0.5 * tanh(self.hertz_smoothing * indentation))
        c = self.dissipation
        if not is_casadi(c) and float(c) == 0.0:
            return hertz                       # Simbody: tanh(+inf) = 1
        switch = 0.5 + 0.5 * tanh(self.hunt_crossley_smoothing * (rate + 2.0 / (3.0 * c)))
        return hertz * (1.0 + 1.5 * c * rate) * switch

    def friction_coefficient(self, slip):
        """mu(s): the tangential force per unit normal force at smoothed slip ``s`` (m/s)."""
        _, _, fmin, _ = _ops(slip, *self._values())
        ratio = slip / self.transition_velocity
        return fmin(ratio, 1.0) * (
            self.dynamic_friction
            + 2.0 * (self.static_friction - self.dynamic_friction) / (1.0 + ratio * ratio)
        ) + self.viscous_friction * slip

    def force_and_point(self, center, velocity, *, angular_velocity=None):
        """Force on the sphere (N, lab frame) and the point where it acts (m, lab frame).

        Args:
            center: sphere centre, (3,) or (..., 3) array, or a CasADi 3-vector, m.
            velocity: the centre's velocity, m/s (same shape).
            angular_velocity: the sphere body's angular velocity, rad/s (default zero; a
                planar model turning about +Y: (0, pitch rate, 0)); the slip and normal
                speed are those of the contact point, as in Simbody.

        Returns:
            (force, point): numpy arrays of the input's shape, or CasADi 3x1 columns.
        """
        like = [center, velocity, angular_velocity, *self._values()]
        _, sqrt, _, stack = _ops(*like)
        cx, cy, cz = _parts(center, like)
        vx, vy, vz = _parts(velocity, like)
        indentation = self.radius - cz
        drop = self.radius - 0.5 * indentation    # |p - c|, along -z
        if angular_velocity is not None:
            wx, wy, _ = _parts(angular_velocity, like)
            # w x (0, 0, -drop) = (-wy drop, wx drop, 0)
            vx, vy = vx - wy * drop, vy + wx * drop
        normal = self.normal_force(indentation, -vz)
        slip = sqrt(vx * vx + vy * vy + self.constant_contact_force)
        tangential = normal * self.friction_coefficient(slip) / slip
        force = stack([-tangential * vx, -tangential * vy, normal])
        point = stack([cx, cy, cz - drop])
        return force, point

    def _values(self) -> list:
        return [getattr(self, f.name) for f in fields(self)]


def _floor_normal(orientation) -> np.ndarray:
    """Outward normal (the frame's -X) of a ContactHalfSpace, in its body's frame.

    ``orientation``: OpenSim's body-fixed X-Y-Z Euler angles (rad).
    """
    a, b, c = (float(x) for x in orientation)
    rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
    return rx @ ry @ rz @ np.array([-1.0, 0.0, 0.0])


def contacts_from_osim(osim) -> tuple[SmoothSphereContact, ...]:
    """One law per SmoothSphereHalfSpaceForce of a read model (``osim.contacts`` order).

    Args:
        osim: :class:`predgait.models.osim.OsimModel` (``contacts``, ``spheres``,
            ``half_spaces`` and ``source``).

    Raises:
        InputError: a half-space that is not the level floor through the ground origin
            (on ``ground``, outward normal OpenSim +Y = predgait +Z), the only floor this
            law knows; a zero stiffness, transition velocity, constant contact force or
            radius (Simbody would divide by zero).
    """
    spheres = {s.name: s for s in osim.spheres}
    floors = {h.name: h for h in osim.half_spaces}
    laws = []
    for contact in osim.contacts:
        floor = floors[contact.half_space]
        normal = _floor_normal(floor.orientation)
        level = np.allclose(normal, [0.0, 1.0, 0.0], atol=1e-9)
        through_origin = abs(float(np.dot(normal, floor.location))) < 1e-12
        if floor.body != "ground" or not level or not through_origin:
            raise InputError(
                f"{osim.source}: line {floor.line}: ContactHalfSpace '{floor.name}' (used by "
                f"SmoothSphereHalfSpaceForce '{contact.name}') is on '{floor.body}' with "
                f"outward normal {np.round(normal, 6).tolist()} through location "
                f"{list(floor.location)}; predgait's smooth contact needs the floor y = 0 of "
                "ground: socket_frame /ground, location 0 0 0, orientation 0 0 -1.5707963")
        try:
            law = SmoothSphereContact.from_osim(contact, spheres[contact.sphere].radius)
        except InputError as error:
            raise InputError(f"{osim.source}: line {contact.line}: SmoothSphereHalfSpaceForce "
                             f"'{contact.name}': {error}") from None
        laws.append(law)
    return tuple(laws)
