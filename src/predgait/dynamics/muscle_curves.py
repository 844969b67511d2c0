"""De Groote et al. (2016) muscle curves exactly as OpenSim 4.6 computes them, numpy or CasADi.

Source: De Groote F, Kinney AL, Rao AV, Fregly BJ (2016) Evaluation of direct collocation
optimal control problem formulations for solving the muscle redundancy problem. Ann Biomed Eng
44:2922-2936 (supplementary material, curves and activation dynamics), in the form of OpenSim
4.6's ``DeGrooteFregly2016Muscle`` (opensim-core OpenSim/Actuators/DeGrooteFregly2016Muscle.h,
.cpp), whose constants differ slightly from the supplement so that the curves pass through key
points (all reproduced here, see the constants):

- active force-length: a sum of three Gaussian-like curves with the optimcntrlmuscle
  parameters, b11 adjusted so that f_L(1) = 1; ``active_force_width_scale`` w stretches it
  about 1: f_L evaluated at (l - 1) / w + 1;
- passive force-length: (exp(kPE (l - 1) / e0) - exp(kPE (0.2 - 1) / e0)) /
  (exp(kPE) - exp(kPE (0.2 - 1) / e0)), kPE = 4, e0 the passive fibre strain at one norm
  force: 0 at l = 0.2 (OpenSim's minimum normalized fibre length), 1 at l = 1 + e0;
- force-velocity: d1 log(d2 v + d3 + sqrt((d2 v + d3)^2 + 1)) + d4 on v = fibre velocity /
  (max_contraction_velocity * optimal fibre length), d1 and d4 solved so that f_V(-1) = 0 and
  f_V(0) = 1;
- tendon force-length: c1 exp(kT (l_T - c2)) - c3 with c1 = 0.2, c2 = 1, c3 = 0.2 (0 at zero
  strain) and kT = log((1 + c3) / c1) / (1 + e_T - c2), e_T the tendon strain at one norm
  force (so f_T(1 + e_T) = 1);
- activation dynamics: da/dt = [(f + 1/2) / (tau_a (1/2 + 3a/2)) + (1/2 + 3a/2) (1/2 - f) /
  tau_d] (e - a) with f = tanh(b (e - a)) / 2 and b = ``activation_dynamics_smoothing``
  (OpenSim's default 0.1).

Every function is elementwise and accepts floats, numpy arrays or CasADi SX/MX/DM expressions
(CasADi imported only when one is given); parameters may be floats or arrays that broadcast.
"""

from __future__ import annotations

import math

import numpy as np

from predgait.dynamics.backend import is_casadi

# Active force-length (OpenSim's b11 ... b43; De Groote 2016 supplement notation).
_GAUSSIANS = (
    (0.8150671134243542, 1.055033428970575, 0.162384573599574, 0.063303448465465),
    (0.433004984392647, 0.716775413397760, -0.029947116970696, 0.200356847296188),
    (0.1, 1.0, 0.353553390593274, 0.0),
)
#: Passive force-length exponential shape factor.
KPE = 4.0
#: Tendon force-length constants (OpenSim: c2 = c3 so that f_T(1) = 0).
C1, C2, C3 = 0.200, 1.0, 0.200
#: Force-velocity constants (d1, d4 solved by OpenSim so f_V(-1) = 0, f_V(0) = 1).
D1, D2, D3, D4 = -0.3211346127989808, -8.149, -0.374, 0.8825327733249912
#: OpenSim's bounds of the normalized fibre length (the passive curve is 0 at the lower one).
MIN_NORM_FIBER_LENGTH, MAX_NORM_FIBER_LENGTH = 0.2, 1.8
#: OpenSim's bounds of the normalized tendon force state (compliant tendon).
MIN_NORM_TENDON_FORCE, MAX_NORM_TENDON_FORCE = 0.0, 5.0
#: Default steepness b of the tanh blend of activation and deactivation (OpenSim 4.6's
#: ``activation_dynamics_smoothing`` default).
TANH_STEEPNESS = 0.1


def lib(*values):
    """The math namespace for the values: casadi for CasADi expressions, else numpy."""
    if is_casadi(*values):
        import casadi

        return casadi
    return np


def active_force_length(norm_fiber_length, width_scale=1.0):
    """Active force-length multiplier f_L (OpenSim calcActiveForceLengthMultiplier).

    Args:
        norm_fiber_length: Fibre length / optimal fibre length.
        width_scale: ``active_force_width_scale`` (>= 1; 1: De Groote's curve).

    Returns:
        f_L, dimensionless (1 at norm_fiber_length = 1).
    """
    m = lib(norm_fiber_length, width_scale)
    x = (norm_fiber_length - 1.0) / width_scale + 1.0
    total = 0.0
    for b1, b2, b3, b4 in _GAUSSIANS:
        total = total + b1 * m.exp(-0.5 * (x - b2) ** 2 / (b3 + b4 * x) ** 2)
    return total


def passive_force_length(norm_fiber_length, strain_at_one=0.6):
    """Passive fibre force-length multiplier f_P (OpenSim calcPassiveForceMultiplier).

    Args:
        norm_fiber_length: Fibre length / optimal fibre length.
        strain_at_one: ``passive_fiber_strain_at_one_norm_force`` e0 (> 0).

    Returns:
        f_P, dimensionless: 0 at 0.2, 1 at 1 + e0 (negative below 0.2).
    """
    m = lib(norm_fiber_length, strain_at_one)
    offset = m.exp(KPE * (MIN_NORM_FIBER_LENGTH - 1.0) / strain_at_one)
    denominator = math.exp(KPE) - offset
    return (m.exp(KPE * (norm_fiber_length - 1.0) / strain_at_one) - offset) / denominator


def force_velocity(norm_fiber_velocity):
    """Force-velocity multiplier f_V (OpenSim calcForceVelocityMultiplier).

    Args:
        norm_fiber_velocity: Fibre velocity / (max contraction velocity * optimal fibre
            length), positive lengthening; OpenSim's domain is [-1, 1].

    Returns:
        f_V, dimensionless: 0 at -1, 1 at 0, 1.794 at 1.
    """
    m = lib(norm_fiber_velocity)
    v = D2 * norm_fiber_velocity + D3
    return D1 * m.log(v + m.sqrt(v**2 + 1.0)) + D4


def force_velocity_inverse(multiplier):
    """Normalized fibre velocity whose f_V is ``multiplier`` (OpenSim's inverse curve)."""
    m = lib(multiplier)
    return (m.sinh((multiplier - D4) / D1) - D3) / D2


def tendon_stiffness_factor(strain_at_one=0.049):
    """Tendon shape factor kT = log((1 + c3) / c1) / (1 + e_T - c2), dimensionless (OpenSim)."""
    m = lib(strain_at_one)
    return m.log((1.0 + C3) / C1) / (1.0 + strain_at_one - C2)


def tendon_force_length(norm_tendon_length, strain_at_one=0.049):
    """Tendon force-length multiplier f_T (OpenSim calcTendonForceMultiplier).

    Args:
        norm_tendon_length: Tendon length / tendon slack length.
        strain_at_one: ``tendon_strain_at_one_norm_force`` e_T (> 0).

    Returns:
        f_T, dimensionless: 0 at 1, 1 at 1 + e_T, -0.2 as the length -> -inf.
    """
    m = lib(norm_tendon_length, strain_at_one)
    k_t = tendon_stiffness_factor(strain_at_one)
    return C1 * m.exp(k_t * (norm_tendon_length - C2)) - C3


def tendon_force_length_inverse(norm_tendon_force, strain_at_one=0.049):
    """Normalized tendon length whose f_T is ``norm_tendon_force`` (OpenSim's inverse curve)."""
    m = lib(norm_tendon_force, strain_at_one)
    k_t = tendon_stiffness_factor(strain_at_one)
    return m.log((norm_tendon_force + C3) / C1) / k_t + C2


def tendon_velocity_from_force_rate(norm_tendon_force_rate, norm_tendon_length,
                                    strain_at_one=0.049):
    """Normalized tendon velocity, 1/s, from d(f_T)/dt.

    d(f_T)/dt / f_T'(l_T): OpenSim's calcTendonForceLengthInverseCurveDerivative.
    """
    m = lib(norm_tendon_force_rate, norm_tendon_length, strain_at_one)
    k_t = tendon_stiffness_factor(strain_at_one)
    return norm_tendon_force_rate / (C1 * k_t * m.exp(k_t * (norm_tendon_length - C2)))


def activation_rate(excitation, activation, activation_time_constant=0.015,
                    deactivation_time_constant=0.060, smoothing=TANH_STEEPNESS):
    """Activation dynamics da/dt, 1/s (OpenSim computeStateVariableDerivatives).

    De Groote et al. (2016, supplement eq. 1-2) with OpenSim's smoothing b
    (``activation_dynamics_smoothing``, default 0.1, the published value):
    f = tanh(b (e - a)) / 2, z = 1/2 + 3a/2,
    da/dt = [(f + 1/2) / (tau_a z) + (1/2 - f) z / tau_d] (e - a).

    OpenSim 4.6 keeps the time constants and b in function-local ``static`` variables, so
    within one process every DeGrooteFregly2016Muscle uses those of the first muscle whose
    derivative was computed; here each muscle uses its own (identical for the 18 muscles
    of 2D_gait.osim: 0.015 s, 0.060 s, 0.1).

    Args:
        excitation: Excitation e, in [0, 1].
        activation: Activation a, in [0, 1].
        activation_time_constant: tau_a, s.
        deactivation_time_constant: tau_d, s.
        smoothing: b, dimensionless (> 0).

    Returns:
        da/dt, 1/s: the sign of e - a.
    """
    m = lib(excitation, activation, activation_time_constant, deactivation_time_constant,
            smoothing)
    factor = 0.5 + 1.5 * activation
    blend = 0.5 * m.tanh(smoothing * (excitation - activation))
    rate = (blend + 0.5) / (activation_time_constant * factor) \
        + (0.5 - blend) * factor / deactivation_time_constant
    return rate * (excitation - activation)
