"""Linear rotational spring-dampers on a model's coordinates, and their generalised forces.

One element, two origins: a model's own SpringGeneralizedForce (OpenSim, e.g. the passive
toe joint of ``2D_gait_toes.osim``) and a scenario's orthosis (``[[muscle_edit]] kind =
"spring"``). Torque on the OpenSim coordinate q (rad):

    tau = -k (q - q0) - c dq/dt      (N m; OpenSim's SpringGeneralizedForce)

A predgait model coordinate is sign * the OpenSim value (:attr:`OsimPlanarModel.signs`),
so the generalised force on the model coordinate is sign * tau(sign q_model, sign v_model).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class JointSpring:
    """A rotational spring-damper on an OpenSim coordinate, SI units.

    Attributes:
        coordinate: OpenSim coordinate name.
        stiffness: k, N m/rad (>= 0).
        neutral: q0, rad (OpenSim coordinate value of zero torque).
        damping: c, N m s/rad (>= 0).
    """

    coordinate: str
    stiffness: float
    neutral: float
    damping: float = 0.0

    def torque(self, value, speed):
        """Generalised force on the coordinate, N m: -k (q - q0) - c dq/dt (numpy/CasADi)."""
        return -self.stiffness * (value - self.neutral) - self.damping * speed


def spring_forces(springs, coordinates, signs, q, v):
    """(nq,) generalised forces of ``springs`` on model q, v (numpy or CasADi column).

    Args:
        springs: :class:`JointSpring` elements.
        coordinates: the OpenSim coordinate name of each model row.
        signs: model coordinate = sign * OpenSim value, per row.
        q: model coordinates (m, rad).
        v: their rates (m/s, rad/s).
    """
    from predgait.dynamics.muscle_curves import lib

    m = lib(q, v)
    rows = [0.0 * q[0] for _ in range(len(coordinates))]
    for spring in springs:
        row = list(coordinates).index(spring.coordinate)
        sign = float(signs[row])
        rows[row] = rows[row] + sign * spring.torque(sign * q[row], sign * v[row])
    return np.stack(rows) if m is np else m.vertcat(*rows)
