"""Foot-ground contact models: force from penetration, penetration rate and slip velocity.

Conventions (every model): ``penetration`` d (m) is the depth of the contact point below
the ground (d > 0 in contact; d = -height), ``penetration_rate`` d_dot (m/s) its time
derivative (> 0 while sinking in), ``slip_velocity`` v_t (m/s) the signed tangential
velocity of the contact point along one ground axis. ``force`` returns the normal force
(N, >= 0, pushing the foot up) and the tangential force (N, along the same axis as
v_t, opposing it). Apply per axis for 3D slip.

Models:
    * :class:`ImpactContact`: ADAMS IMPACT (thesis 2.3.1): F = k d^e + STEP(d, 0, 0,
      d_max, c_max) d_dot with the ADAMS cubic STEP(x, x0, h0, x1, h1) = h0 + (h1 - h0)
      u^2 (3 - 2u), u = (x - x0) / (x1 - x0) clipped to [0, 1]; e = 1 gives the thesis'
      F = k x + c (x/d)^2 [3 - 2 x/d] v. Damping ramps in, so no force jump at impact.
    * :class:`MeglanContact`: Meglan (1991, Ph.D. dissertation, Ohio State University)
      fit to Valiant's (1990) heel-pad data as quoted in the thesis, section 2.3.1:
      F(x, v) = a x^4 + b x^4 v, a = 4.658E10 N/m^4, b = 9.719E10 N s/m^5.
    * :class:`HuntCrossleyContact`: Hunt & Crossley (1975) J Appl Mech 42:440-445,
      F = k d^n (1 + 3/2 c d_dot), with d replaced by a softplus of d (smooth at contact)
      and the damping factor by a smooth max with 0; friction F_t = -mu F tanh(v_t / v_s)
      (regularised Coulomb). Smooth: use it inside optimisation (CasADi).

ImpactContact and MeglanContact clip the normal force at 0 (no ground adhesion when the
foot lifts faster than the spring relaxes); their friction, if ``friction > 0``, is
Coulomb with the ADAMS STEP over +-``slip_transition``. All models take numpy arrays or
CasADi expressions; the ADAMS-style ones are only piecewise smooth.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as cs
import numpy as np

from predgait.dynamics.backend import is_casadi


def _ops(*values):
    if is_casadi(*values):
        return cs.fmax, cs.fmin, cs.if_else, cs.tanh, cs.sqrt, cs.exp, cs.log1p, cs.fabs
    return (np.maximum, np.minimum, np.where, np.tanh, np.sqrt, np.exp, np.log1p, np.abs)


def _power(x, exponent):
    return x**exponent


def adams_step(x, x0: float, h0: float, x1: float, h1: float):
    """ADAMS cubic STEP: h0 for x <= x0, h1 for x >= x1, C1 cubic in between."""
    fmax, fmin, *_ = _ops(x)
    u = fmin(fmax((x - x0) / (x1 - x0), 0.0), 1.0)
    return h0 + (h1 - h0) * u * u * (3.0 - 2.0 * u)


def softplus(x, width: float):
    """Smooth max(x, 0): width * log(1 + exp(x / width)), overflow-safe."""
    fmax, _, _, _, _, exp, log1p, fabs = _ops(x)
    z = x / width
    return width * (fmax(z, 0.0) + log1p(exp(-fabs(z))))


def _coulomb_step(normal, slip, mu: float, transition: float):
    return -mu * normal * adams_step(slip, -transition, -1.0, transition, 1.0)


@dataclass(frozen=True)
class ImpactContact:
    """ADAMS IMPACT spring-damper with step-ramped damping (thesis 2.3.1).

    Attributes:
        stiffness: k, N/m^exponent.
        exponent: e (1: the thesis' linear spring).
        damping: c_max, N s/m, reached at penetration ``damping_depth``.
        damping_depth: d_max, m.
        friction: Coulomb coefficient mu (0: no tangential force, as in the thesis).
        slip_transition: m/s, slip speed over which friction ramps to mu N.
    """

    stiffness: float = 2.0e5
    exponent: float = 1.0
    damping: float = 2.0e3
    damping_depth: float = 0.01
    friction: float = 0.0
    slip_transition: float = 0.01

    def force(self, penetration, penetration_rate, slip_velocity=0.0):
        """Normal and tangential force, N (see module docstring)."""
        fmax, _, where, *_ = _ops(penetration, penetration_rate, slip_velocity)
        depth = fmax(penetration, 0.0)
        damping = adams_step(depth, 0.0, 0.0, self.damping_depth, self.damping)
        normal = fmax(self.stiffness * _power(depth, self.exponent)
                      + damping * penetration_rate, 0.0)
        normal = where(penetration > 0, normal, 0.0)
        tangential = _coulomb_step(normal, slip_velocity, self.friction, self.slip_transition)
        return normal, tangential


@dataclass(frozen=True)
class MeglanContact:
    """Meglan (1991) heel-pad model F = a x^4 + b x^4 v (thesis 2.3.1).

    Attributes:
        a: N/m^4 (4.658E10).
        b: N s/m^5 (9.719E10).
        friction: Coulomb coefficient (0: none).
        slip_transition: m/s.
    """

    a: float = 4.658e10
    b: float = 9.719e10
    friction: float = 0.0
    slip_transition: float = 0.01

    def force(self, penetration, penetration_rate, slip_velocity=0.0):
        """Normal and tangential force, N."""
        fmax, *_ = _ops(penetration, penetration_rate, slip_velocity)
        depth4 = fmax(penetration, 0.0) ** 4
        normal = fmax(self.a * depth4 + self.b * depth4 * penetration_rate, 0.0)
        tangential = _coulomb_step(normal, slip_velocity, self.friction, self.slip_transition)
        return normal, tangential


@dataclass(frozen=True)
class HuntCrossleyContact:
    """Smooth Hunt-Crossley contact with regularised Coulomb friction (for optimisation).

    Attributes:
        stiffness: k, N/m^n.
        exponent: n (1.5: Hertzian sphere).
        dissipation: c, s/m.
        friction: mu.
        slip_velocity_scale: v_s, m/s (tanh regularisation).
        smoothing: m, softplus width on the penetration (force ~ 0 for d < -5 widths).
        damping_smoothing: smooth-max width on the factor 1 + 3/2 c d_dot.
    """

    stiffness: float = 5.0e7
    exponent: float = 1.5
    dissipation: float = 1.0
    friction: float = 0.8
    slip_velocity_scale: float = 0.05
    smoothing: float = 1.0e-4
    damping_smoothing: float = 1.0e-3

    def force(self, penetration, penetration_rate, slip_velocity=0.0):
        """Normal and tangential force, N (smooth in all arguments)."""
        _, _, _, tanh, sqrt, *_ = _ops(penetration, penetration_rate, slip_velocity)
        # + 1e-30 m: far above the floor the softplus underflows to exactly 0, where
        # depth**n has an infinite second derivative (NaN in an exact Hessian)
        depth = softplus(penetration, self.smoothing) + 1e-30
        factor = 1.0 + 1.5 * self.dissipation * penetration_rate
        factor = 0.5 * (factor + sqrt(factor * factor + self.damping_smoothing**2))
        normal = self.stiffness * depth**self.exponent * factor
        tangential = -self.friction * normal * tanh(slip_velocity / self.slip_velocity_scale)
        return normal, tangential
