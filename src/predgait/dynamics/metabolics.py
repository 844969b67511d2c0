"""Metabolic-cost proxy from muscle states: Bhargava et al. (2004), smoothed as OpenSim 4.6.

Bhargava LJ, Pandy MG, Anderson FC (2004) A phenomenological model for estimating metabolic
energy consumption in muscle contraction. J Biomech 37:81-88, in the form of OpenSim 4.6's
``Bhargava2004SmoothedMuscleMetabolics`` with ``use_smoothing`` true and ``smoothing_type``
``tanh`` (opensim-core OpenSim/Actuators/Bhargava2004SmoothedMuscleMetabolics.cpp; the
smoothing is Falisse et al.'s, 2019 J R Soc Interface 16:20190402). Per muscle, W:

- muscle mass m = F_max / sigma * rho * l_opt (sigma = specific tension 0.25 MPa,
  rho = 1059.7 kg/m^3);
- slow- and fast-twitch recruitment from the excitation u and the slow-twitch ratio r:
  u_s = r sin(pi u / 2), u_f = (1 - r)(1 - cos(pi u / 2));
- activation heat A = m (40 u_s + 133 u_f) (decay function 1, Anderson & Pandy 1999);
- maintenance heat M = m g(l~) (74 u_s + 111 u_f), g the piecewise-linear curve through
  (0, 0.5), (0.5, 0.5), (1, 1), (1.5, 0), (10, 0) of the normalized fibre length l~;
- shortening heat S = -alpha (v + 1e-16), v the fibre velocity (m/s, < 0 shortening),
  alpha = 0.25 F on shortening, 0 on lengthening, F = active + passive fibre force (or, with
  ``force_dependent_shortening``, 0.16 F_iso + 0.18 F shortening, 0.157 F lengthening,
  F_iso = a f_L F_max);
- mechanical work W = -F_active v (negative work included, as OpenSim's default);
- total power non-negative: S -= s(A + M + S + W) where s(x) blends 0 (x >= 0) to x (x < 0);
- heat A + M + S at least 1 W/kg (m W), blended; muscle rate = heat + W;
- whole body: sum over muscles + basal ``basal_coefficient * body_mass**basal_exponent``
  (1.2 W/kg; set the coefficient to 0 to leave basal out).

Every "if" is OpenSim's tanh blend ``left + (right - left) (1/2 + tanh(k c) / 2)`` with
k = 10 (velocity, power and heat-rate smoothing; in units of m/s or W, so for a muscle of
0.06 kg the 1 W/kg floor blends to only 0.77 of its value at zero heat, as in OpenSim),
so the rates are smooth in the states and
fit an optimiser. Inputs are a rigid-tendon :class:`~predgait.dynamics.muscles.MuscleState`
(``active_fiber_force``, ``passive_fiber_force`` + ``damping_force`` = OpenSim's
getPassiveFiberForce, ``norm_fiber_length``, ``fiber_velocity``) with the excitations and
activations, numpy (muscles in rows, samples in columns) or CasADi columns.

The muscle mass follows the edited parameters: a weakness edit (F_max scaled) or a shorter
optimal fibre length makes a lighter muscle with proportionally less heat per excitation,
as OpenSim computes it when the muscle mass is not given.

Slow-twitch ratios: OpenSim's default 0.5 for every muscle unless a table is given;
:data:`SLOW_TWITCH_LITERATURE` holds per-muscle values (Uchida et al. 2016 PLoS ONE
11:e0150378, from Johnson et al. 1973; the 2D model's lumped muscles as plain means of the
muscles they lump).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from predgait.dynamics.muscle_curves import lib
from predgait.errors import InputError

#: Slow-twitch fibre ratios of the 2D gait model's muscles (side suffix dropped): Uchida
#: et al. 2016 (Johnson et al. 1973); hamstrings = mean of semimembranosus 0.4925,
#: semitendinosus 0.425, biceps femoris long head 0.5425; vasti = mean of medialis 0.503,
#: intermedius 0.543, lateralis 0.455; gastrocnemius = mean of medial 0.566, lateral 0.507.
SLOW_TWITCH_LITERATURE = {
    "hamstrings": (0.4925 + 0.425 + 0.5425) / 3, "bifemsh": 0.529, "glut_max": 0.55,
    "iliopsoas": 0.50, "rect_fem": 0.3865, "vasti": (0.503 + 0.543 + 0.455) / 3,
    "gastroc": (0.566 + 0.507) / 2, "soleus": 0.803, "tib_ant": 0.70,
}
#: OpenSim's small velocity offset (avoids 0/0 in its Huber variant), m/s.
VELOCITY_EPS = 1e-16


@dataclass(frozen=True)
class BhargavaOptions:
    """Properties of OpenSim 4.6's Bhargava2004SmoothedMuscleMetabolics (its defaults).

    Attributes:
        specific_tension: sigma, Pa.
        density: rho, kg/m^3.
        slow_twitch: Muscle name (or name without ``_r``/``_l``) -> slow-twitch ratio;
            None: 0.5 for every muscle (OpenSim's default).
        activation_constants: Slow-, fast-twitch activation heat constants, W/kg.
        maintenance_constants: Slow-, fast-twitch maintenance heat constants, W/kg.
        basal_coefficient: W/kg^basal_exponent (0: no basal rate).
        basal_exponent: Exponent of the body mass.
        muscle_effort_scaling: Multiplies activation, excitation and active fibre force.
        force_dependent_shortening: Use the force-dependent shortening constant.
        include_negative_mechanical_work: Count negative work (else blended to 0).
        forbid_negative_total_power: Raise the shortening heat so no muscle's rate is < 0.
        enforce_minimum_heat_rate: Heat rate of each muscle at least 1 W/kg.
        velocity_smoothing, power_smoothing, heat_rate_smoothing: tanh steepness k.
    """

    specific_tension: float = 0.25e6
    density: float = 1059.7
    slow_twitch: Mapping[str, float] | None = None
    activation_constants: tuple[float, float] = (40.0, 133.0)
    maintenance_constants: tuple[float, float] = (74.0, 111.0)
    basal_coefficient: float = 1.2
    basal_exponent: float = 1.0
    muscle_effort_scaling: float = 1.0
    force_dependent_shortening: bool = False
    include_negative_mechanical_work: bool = True
    forbid_negative_total_power: bool = True
    enforce_minimum_heat_rate: bool = True
    velocity_smoothing: float = 10.0
    power_smoothing: float = 10.0
    heat_rate_smoothing: float = 10.0


@dataclass(frozen=True)
class MetabolicRates:
    """Metabolic rates, W, per muscle (rows; samples in columns) and the basal rate.

    Attributes:
        activation, maintenance, shortening, mechanical_work: The terms per muscle (the
            shortening heat after the non-negative-power correction, as OpenSim reports).
        muscle: Each muscle's total (heat, at least its minimum, + work).
        basal: Basal rate of the whole body, W.
    """

    activation: Any
    maintenance: Any
    shortening: Any
    mechanical_work: Any
    muscle: Any
    basal: float

    @property
    def total(self):
        """Whole-body rate, W: sum over the muscles + basal (OpenSim getTotalMetabolicRate)."""
        m = lib(self.muscle)
        if m is np:
            return np.sum(self.muscle, axis=0) + self.basal
        return m.sum1(self.muscle) + self.basal


def muscle_masses(muscles, options: BhargavaOptions = BhargavaOptions()) -> np.ndarray:
    """(n_muscles,) muscle masses F_max / sigma * rho * l_opt, kg (OpenSim setMuscleMass)."""
    return np.array([m.max_isometric_force / options.specific_tension * options.density
                     * m.optimal_fiber_length for m in muscles.muscles])


def slow_twitch_ratios(muscles, table: Mapping[str, float] | None = None) -> np.ndarray:
    """(n_muscles,) slow-twitch ratios: ``table`` by full name or name without the side.

    Raises:
        InputError: A muscle missing from the table, or a ratio outside [0, 1].
    """
    if table is None:
        return np.full(len(muscles), 0.5)
    out = []
    for name in muscles.names:
        base = name[:-2] if name[-2:] in ("_r", "_l") else name
        value = table.get(name, table.get(base))
        if value is None or not 0.0 <= float(value) <= 1.0:
            raise InputError(f"slow-twitch ratio of muscle {name!r}: {value!r}; give a value "
                             "in [0, 1] for every muscle (by name or name without _r/_l).")
        out.append(float(value))
    return np.array(out)


def _blend(condition, left, right, k):
    """OpenSim's tanh conditional: ``left`` for condition << 0, ``right`` for >> 0."""
    m = lib(condition, left, right)
    return left + (right - left) * (0.5 + 0.5 * m.tanh(k * condition))


def _fiber_length_dependence(norm_length):
    """Maintenance heat's piecewise-linear curve (0, .5) (.5, .5) (1, 1) (1.5, 0) (10, 0)."""
    m = lib(norm_length)
    lo = m.fmin(m.fmax(norm_length, 0.5), 1.0)
    hi = m.fmin(m.fmax(norm_length, 1.0), 1.5)
    return 0.5 + (lo - 0.5) - 2.0 * (hi - 1.0)


def metabolic_rates(muscles, state, excitation, activation, *, body_mass: float,
                    options: BhargavaOptions = BhargavaOptions()) -> MetabolicRates:
    """Bhargava et al. (2004) rates as OpenSim 4.6's smoothed metabolics computes them.

    Args:
        muscles: The :class:`~predgait.dynamics.muscles.MuscleSet`.
        state: Its :class:`~predgait.dynamics.muscles.MuscleState` (e.g. ``rigid_tendon``).
        excitation: Excitations (controls), shaped as the state's arrays.
        activation: Activations, same shape.
        body_mass: Whole-body mass for the basal rate, kg.
        options: The component's properties.

    Returns:
        :class:`MetabolicRates`, W.
    """
    from predgait.dynamics.muscles import _column

    like = state.fiber_velocity
    m = lib(like, excitation, activation)
    mass = _column(muscle_masses(muscles, options), like)
    ratio = _column(slow_twitch_ratios(muscles, options.slow_twitch), like)
    scale = options.muscle_effort_scaling
    u = scale * excitation
    a = scale * activation
    slow = ratio * m.sin(0.5 * math.pi * u)
    fast = (1.0 - ratio) * (1.0 - m.cos(0.5 * math.pi * u))
    activation_heat = mass * (options.activation_constants[0] * slow
                              + options.activation_constants[1] * fast)
    maintenance_heat = mass * _fiber_length_dependence(state.norm_fiber_length) * (
        options.maintenance_constants[0] * slow + options.maintenance_constants[1] * fast)
    active = scale * state.active_fiber_force
    total_force = active + state.passive_fiber_force + state.damping_force
    v = state.fiber_velocity + VELOCITY_EPS
    k_v = options.velocity_smoothing
    if options.force_dependent_shortening:
        f_iso = a * state.active_force_length * muscles.parameter("max_isometric_force", like)
        alpha = _blend(v, 0.16 * f_iso + 0.18 * total_force, 0.157 * total_force, k_v)
    else:
        alpha = _blend(v, 0.25 * total_force, 0.0 * total_force, k_v)
    shortening_heat = -alpha * v
    work = -active * state.fiber_velocity
    if not options.include_negative_mechanical_work:
        work = _blend(v, work, 0.0 * work, k_v)
    if options.forbid_negative_total_power:
        before = activation_heat + maintenance_heat + shortening_heat + work
        shortening_heat = shortening_heat - _blend(-before, 0.0 * before, before,
                                                   options.power_smoothing)
    heat = activation_heat + maintenance_heat + shortening_heat
    if options.enforce_minimum_heat_rate:
        heat = _blend(mass - heat, heat, 1.0 * mass + 0.0 * heat, options.heat_rate_smoothing)
    basal = options.basal_coefficient * body_mass ** options.basal_exponent
    return MetabolicRates(activation_heat, maintenance_heat, shortening_heat, work,
                          heat + work, float(basal))


def stride_rates(muscles, paths, q, v, excitation, activation, *, body_mass: float,
                 options: BhargavaOptions = BhargavaOptions()) -> MetabolicRates:
    """Rates along a trajectory of a rigid-tendon model.

    Args:
        muscles: :class:`~predgait.dynamics.muscles.MuscleSet`.
        paths: Smooth paths (:func:`predgait.dynamics.muscle_paths.smooth_paths`) on the
            coordinate vector of ``q``.
        q: (N, n) coordinates at the nodes, in ``paths``' order.
        v: (N, n) their rates.
        excitation: (N, n_muscles) excitations.
        activation: (N, n_muscles) activations.
        body_mass: kg.
        options: :class:`BhargavaOptions`.

    Returns:
        :class:`MetabolicRates` with (n_muscles, N) arrays; ``total`` is (N,).
    """
    q, v = np.asarray(q, float).T, np.asarray(v, float).T
    length = paths.lengths(q)
    speed = paths.lengthening_speeds(q, v)
    act = np.asarray(activation, float).T
    state = muscles.rigid_tendon(length, speed, act)
    return metabolic_rates(muscles, state, np.asarray(excitation, float).T, act,
                           body_mass=body_mass, options=options)


def stride_cost_of_transport(stride, muscles, paths, *, body_mass: float,
                             options: BhargavaOptions = BhargavaOptions()
                             ) -> tuple[float, MetabolicRates]:
    """Cost of transport of a stride (or half stride), J/kg/m, and the rates along it.

    Args:
        stride: Anything with ``t`` (N,) s, ``q``, ``v`` (N, n) in ``paths``' coordinate
            order, ``act``, ``exc`` (N, n_muscles) and ``distance`` m, e.g. the muscle-driven
            prediction's :class:`~predgait.problems.muscle_gait_stride.Stride`.
        muscles: :class:`~predgait.dynamics.muscles.MuscleSet` (the scenario's, if edited).
        paths: Smooth paths on model q (``smooth_paths(built, on_model_q=True)``).
        body_mass: kg (rates are divided by it; basal rate from it).
        options: :class:`BhargavaOptions`.

    Returns:
        (integral of the whole-body rate over the stride / (body_mass * distance), rates).
    """
    rates = stride_rates(muscles, paths, stride.q, stride.v, stride.exc, stride.act,
                         body_mass=body_mass, options=options)
    return cost_of_transport(stride.t, rates.total, mass=body_mass,
                             distance=float(stride.distance)), rates


def cost_of_transport(time, total_rate, *, mass: float, distance: float) -> float:
    """Metabolic cost of transport, J/kg/m: trapezoidal integral of the rate / (m d).

    Args:
        time: (N,) s, increasing (e.g. the collocation nodes of a stride).
        total_rate: (N,) whole-body rate, W (:attr:`MetabolicRates.total`).
        mass: Body mass, kg (> 0).
        distance: Distance travelled over ``time``, m (> 0; e.g. the pelvis displacement).

    Raises:
        InputError: Non-positive mass or distance, or mismatched arrays.
    """
    time, rate = np.asarray(time, float), np.asarray(total_rate, float)
    if time.shape != rate.shape or time.ndim != 1 or time.size < 2:
        raise InputError(f"cost of transport: time {time.shape} and rate {rate.shape} must "
                         "be two (N,) arrays with N >= 2.")
    if not (mass > 0 and distance > 0):
        raise InputError(f"cost of transport: mass {mass!r} kg and distance {distance!r} m "
                         "must be > 0 (a stride that does not move has no cost of transport).")
    energy = float(np.sum(0.5 * (rate[1:] + rate[:-1]) * np.diff(time)))
    return energy / (mass * distance)
