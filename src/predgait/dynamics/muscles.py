"""Muscle-tendon dynamics of OpenSim 4.6's DeGrooteFregly2016Muscle, numpy or CasADi.

A :class:`MuscleSet` holds the frozen :class:`MuscleParameters` of the model's muscles (read from
an .osim file by :meth:`MuscleSet.from_osim`, edited by scenarios with :meth:`MuscleSet.edited`)
and computes, vectorised over the muscles (rows) and any number of samples (columns), what
OpenSim's ``calcMuscleLengthInfoHelper`` / ``calcFiberVelocityInfoHelper`` /
``calcMuscleDynamicsInfoHelper`` compute (curves: :mod:`predgait.dynamics.muscle_curves`):

- rigid tendon (``ignore_tendon_compliance``, what 2D_gait.osim uses): tendon length = slack
  length; fibre length and velocity from the muscle-tendon length and lengthening speed
  (:meth:`MuscleSet.rigid_tendon`);
- compliant tendon in De Groote et al.'s (2016) implicit form (formulation 3): the normalized
  tendon force f_T is a state, its derivative a control, and the muscle-tendon equilibrium
  residual (F_max f_T - F_fibre cos(alpha)) / F_max (OpenSim 4.6's ``calcEquilibriumResidual``,
  normalized by the max isometric force) a path constraint (:meth:`MuscleSet.compliant_tendon`);
- pennation by the constant-height model: fibre width w = l_opt sin(alpha_opt), fibre length
  sqrt(l_along_tendon^2 + w^2), cos(alpha) = l_along_tendon / l_fibre;
- fibre force F_max (a f_L f_V + f_P + fiber_damping * v_norm), along the tendon times
  cos(alpha);
- activation dynamics (:meth:`MuscleSet.activation_rate`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from predgait.dynamics import muscle_curves as curves
from predgait.dynamics.backend import is_casadi
from predgait.errors import InputError


@dataclass(frozen=True)
class MuscleParameters:
    """One DeGrooteFregly2016Muscle's properties, with OpenSim 4.6's defaults.

    Attributes:
        name: Muscle name.
        max_isometric_force: F_max, N (> 0).
        optimal_fiber_length: l_opt, m (> 0).
        tendon_slack_length: l_s, m (> 0).
        pennation_angle_at_optimal: alpha_opt, rad, in [0, pi/2).
        max_contraction_velocity: v_max, optimal fibre lengths per second (> 0).
        activation_time_constant: tau_a, s (> 0).
        deactivation_time_constant: tau_d, s (> 0).
        activation_dynamics_smoothing: b of the tanh blend (> 0).
        active_force_width_scale: Width scale of f_L (>= 1).
        fiber_damping: Linear fibre damping, F_max per normalized fibre velocity (>= 0).
        passive_fiber_strain_at_one_norm_force: e0 of f_P (> 0).
        tendon_strain_at_one_norm_force: e_T of f_T (> 0).
        ignore_passive_fiber_force: f_P = 0.
        ignore_tendon_compliance: Rigid tendon.
        ignore_activation_dynamics: Activation = excitation.
        applies_force: False: the muscle exerts no force (OpenSim ``appliesForce``).
        default_activation: Initial activation.
        default_normalized_tendon_force: Initial f_T (compliant tendon).
        min_control: Lower bound of the excitation.
        max_control: Upper bound of the excitation.
        where: Where the muscle was defined (file, line), for messages.
    """

    name: str
    max_isometric_force: float
    optimal_fiber_length: float
    tendon_slack_length: float
    pennation_angle_at_optimal: float = 0.0
    max_contraction_velocity: float = 10.0
    activation_time_constant: float = 0.015
    deactivation_time_constant: float = 0.060
    activation_dynamics_smoothing: float = 0.1
    active_force_width_scale: float = 1.0
    fiber_damping: float = 0.0
    passive_fiber_strain_at_one_norm_force: float = 0.6
    tendon_strain_at_one_norm_force: float = 0.049
    ignore_passive_fiber_force: bool = False
    ignore_tendon_compliance: bool = False
    ignore_activation_dynamics: bool = False
    applies_force: bool = True
    default_activation: float = 0.5
    default_normalized_tendon_force: float = 0.5
    min_control: float = 0.0
    max_control: float = 1.0
    where: str = ""

    def __post_init__(self):
        positive = ("max_isometric_force", "optimal_fiber_length", "tendon_slack_length",
                    "max_contraction_velocity", "activation_time_constant",
                    "deactivation_time_constant", "activation_dynamics_smoothing",
                    "passive_fiber_strain_at_one_norm_force",
                    "tendon_strain_at_one_norm_force")
        for key in positive:
            self._check(key, lambda v: v > 0, "must be > 0")
        self._check("fiber_damping", lambda v: v >= 0, "must be >= 0")
        self._check("active_force_width_scale", lambda v: v >= 1, "must be >= 1")
        self._check("pennation_angle_at_optimal", lambda v: 0 <= v < math.pi / 2,
                    "must be in [0, pi/2) rad")

    def _check(self, key: str, ok, rule: str) -> None:
        value = getattr(self, key)
        try:
            good = math.isfinite(float(value)) and ok(float(value))
        except (TypeError, ValueError):
            good = False
        if not good:
            place = f"{self.where}: " if self.where else ""
            raise InputError(f"{place}muscle {self.name!r}: {key} = {value!r} {rule}; "
                             f"correct the muscle's {key}.")

    @property
    def fiber_width(self) -> float:
        """Constant fibre width (height) l_opt sin(alpha_opt), m."""
        return self.optimal_fiber_length * math.sin(self.pennation_angle_at_optimal)


@dataclass(frozen=True)
class MuscleState:
    """What a muscle set computes at a state; arrays (n_muscles, ...) or CasADi columns.

    Attributes:
        tendon_force: Force along the tendon, N (the muscle's actuation).
        fiber_force: Total fibre force, N.
        active_fiber_force: F_max a f_L f_V, N.
        passive_fiber_force: Elastic F_max f_P, N.
        damping_force: F_max * fiber_damping * v_norm, N.
        fiber_length: m.
        norm_fiber_length: Fibre length / l_opt.
        fiber_velocity: m/s (positive lengthening).
        norm_fiber_velocity: Fibre velocity / (v_max l_opt).
        cos_pennation: cos(alpha).
        active_force_length: f_L.
        passive_force_length: f_P.
        force_velocity: f_V.
        norm_tendon_length: Tendon length / slack length (1 for a rigid tendon).
        residual: Equilibrium residual (F_max f_T - F_fibre cos(alpha)) / F_max,
            dimensionless (compliant; 0 rigid), as OpenSim 4.6's calcEquilibriumResidual.
    """

    tendon_force: Any
    fiber_force: Any
    active_fiber_force: Any
    passive_fiber_force: Any
    damping_force: Any
    fiber_length: Any
    norm_fiber_length: Any
    fiber_velocity: Any
    norm_fiber_velocity: Any
    cos_pennation: Any
    active_force_length: Any
    passive_force_length: Any
    force_velocity: Any
    norm_tendon_length: Any
    residual: Any


_FLAGS = tuple(f.name for f in fields(MuscleParameters) if f.type == "bool")
_NUMBERS = tuple(f.name for f in fields(MuscleParameters)
                 if f.name not in ("name", "where") and f.name not in _FLAGS)


@dataclass(frozen=True)
class MuscleSet:
    """The model's muscles, in order; computations are vectorised over them.

    Attributes:
        muscles: One :class:`MuscleParameters` per muscle.
    """

    muscles: tuple[MuscleParameters, ...]

    def __post_init__(self):
        object.__setattr__(self, "muscles", tuple(self.muscles))
        names = [m.name for m in self.muscles]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise InputError(f"muscles named twice: {', '.join(twice)}; names must be unique.")

    @classmethod
    def from_osim(cls, osim) -> MuscleSet:
        """The DeGrooteFregly2016Muscles of a model read by :func:`predgait.models.osim.read_osim`.

        Properties absent from the file carry OpenSim's defaults (the reader's records).
        """
        names = {f.name for f in fields(MuscleParameters)} - {"where"}
        muscles = []
        for record in osim.muscles:
            values = {key: getattr(record, key) for key in names if hasattr(record, key)}
            line = getattr(record, "line", None)
            where = f"{osim.source}" + (f", line {line}" if line else "")
            muscles.append(MuscleParameters(**values, where=where))
        return cls(tuple(muscles))

    @property
    def names(self) -> tuple[str, ...]:
        """Muscle names, in order."""
        return tuple(m.name for m in self.muscles)

    def __len__(self) -> int:
        return len(self.muscles)

    def index(self, name: str, *, where: str = "") -> int:
        """Row of a muscle; InputError naming ``where`` and the choices if there is none."""
        if name not in self.names:
            place = f"{where}: " if where else ""
            raise InputError(f"{place}no muscle named {name!r}; the model's muscles: "
                             f"{', '.join(self.names)}.")
        return self.names.index(name)

    def edited(self, names: str | Iterable[str], *, where: str = "", **changes) -> MuscleSet:
        """A copy with some muscles' parameters changed (scenario edits).

        Each keyword is a :class:`MuscleParameters` field set to a new value (e.g.
        ``tendon_slack_length=0.30``), or a numeric field with ``_scale`` appended, multiplying
        it (e.g. ``max_isometric_force_scale=0.5`` for weakness,
        ``tendon_slack_length_scale=1.1`` for a lengthening).

        Args:
            names: Muscle name or names to edit.
            where: Location of the edit for messages (file, key).
            **changes: Field -> value, or field_scale -> factor.

        Raises:
            InputError: Unknown muscle or field, or an edited value OpenSim rejects.
        """
        names = (names,) if isinstance(names, str) else tuple(names)
        rows = {self.index(name, where=where) for name in names}
        settable = set(_NUMBERS) | set(_FLAGS)
        for key in changes:
            base = key.removesuffix("_scale")
            if key not in settable and not (key.endswith("_scale") and base in _NUMBERS):
                place = f"{where}: " if where else ""
                raise InputError(f"{place}unknown muscle parameter {key!r}; choose from "
                                 f"{', '.join(sorted(settable))} (or one with _scale).")
        muscles = list(self.muscles)
        for row in rows:
            values = {}
            for key, value in changes.items():
                if key in settable:
                    values[key] = value
                else:
                    base = key.removesuffix("_scale")
                    values[base] = getattr(muscles[row], base) * value
            muscles[row] = replace(muscles[row], **values,
                                   where=where or muscles[row].where)
        return MuscleSet(tuple(muscles))

    def parameter(self, key: str, like=None):
        """A parameter of all muscles as a column.

        numpy (n, 1, ...) to broadcast with ``like``'s trailing axes, or a CasADi DM column
        if ``like`` is CasADi. Boolean parameters come as 0.0/1.0.
        """
        return _column([float(getattr(m, key)) for m in self.muscles], like)

    def _curves_at(self, fiber_length_along_tendon, fiber_velocity_along_tendon, activation,
                   norm_tendon_length, tendon_force, compliant: bool) -> MuscleState:
        """Fibre kinematics, the curves and forces (OpenSim's three helpers after the tendon)."""
        like = _like(fiber_length_along_tendon, fiber_velocity_along_tendon, activation)
        m = curves.lib(like)
        p = lambda key: self.parameter(key, like)  # noqa: E731
        width = _column([muscle.fiber_width for muscle in self.muscles], like)
        fiber_length = m.sqrt(fiber_length_along_tendon**2 + width**2)
        norm_length = fiber_length / p("optimal_fiber_length")
        cos_pennation = fiber_length_along_tendon / fiber_length
        fiber_velocity = fiber_velocity_along_tendon * cos_pennation
        norm_velocity = fiber_velocity / (p("max_contraction_velocity") * p("optimal_fiber_length"))
        f_l = curves.active_force_length(norm_length, p("active_force_width_scale"))
        keep = 1.0 - p("ignore_passive_fiber_force")
        f_p = keep * curves.passive_force_length(norm_length,
                                                 p("passive_fiber_strain_at_one_norm_force"))
        f_v = curves.force_velocity(norm_velocity)
        f_max = p("max_isometric_force")
        active = f_max * (activation * f_l * f_v)
        passive = f_max * f_p
        damping = f_max * p("fiber_damping") * norm_velocity
        fiber_force = active + passive + damping
        along = fiber_force * cos_pennation
        if compliant:
            force = f_max * tendon_force
            residual = tendon_force - along / f_max
        else:
            force, residual = along, 0.0 * along
        force = force * p("applies_force")
        return MuscleState(force, fiber_force, active, passive, damping, fiber_length,
                           norm_length, fiber_velocity, norm_velocity, cos_pennation, f_l, f_p,
                           f_v, norm_tendon_length, residual)

    def rigid_tendon(self, length, speed, activation) -> MuscleState:
        """Rigid-tendon muscle state (OpenSim with ``ignore_tendon_compliance``).

        Args:
            length: Muscle-tendon lengths, m, (n_muscles,) or (n_muscles, n_samples), or a
                CasADi column.
            speed: Lengthening speeds, m/s, same shape.
            activation: Activations, same shape.

        Returns:
            The :class:`MuscleState`; ``tendon_force`` (N) is what acts on the skeleton.
        """
        like = _like(length, speed, activation)
        along = length - self.parameter("tendon_slack_length", like)
        one = 1.0 + 0.0 * along
        return self._curves_at(along, speed, activation, one, None, compliant=False)

    def compliant_tendon(self, length, speed, activation, norm_tendon_force,
                         norm_tendon_force_rate) -> MuscleState:
        """Compliant tendon in the implicit form (OpenSim's ``calcEquilibriumResidual``).

        Args:
            length: Muscle-tendon lengths, m (as :meth:`rigid_tendon`).
            speed: Lengthening speeds, m/s.
            activation: Activations.
            norm_tendon_force: State f_T (OpenSim bounds it to [0, 5]).
            norm_tendon_force_rate: Control d(f_T)/dt, 1/s.

        Returns:
            The :class:`MuscleState`: ``tendon_force`` = F_max f_T and ``residual``
            (normalized by F_max), which a solution must drive to zero.
        """
        like = _like(length, speed, activation, norm_tendon_force, norm_tendon_force_rate)
        strain = self.parameter("tendon_strain_at_one_norm_force", like)
        slack = self.parameter("tendon_slack_length", like)
        norm_tendon_length = curves.tendon_force_length_inverse(norm_tendon_force, strain)
        tendon_speed = slack * curves.tendon_velocity_from_force_rate(
            norm_tendon_force_rate, norm_tendon_length, strain)
        along = length - slack * norm_tendon_length
        return self._curves_at(along, speed - tendon_speed, activation, norm_tendon_length,
                               norm_tendon_force, compliant=True)

    def activation_rate(self, excitation, activation):
        """da/dt, 1/s, of every muscle (:func:`muscle_curves.activation_rate`)."""
        like = _like(excitation, activation)
        return curves.activation_rate(
            excitation, activation, self.parameter("activation_time_constant", like),
            self.parameter("deactivation_time_constant", like),
            self.parameter("activation_dynamics_smoothing", like))


def _column(values, like=None):
    """Per-muscle values shaped to broadcast with ``like`` (numpy), or a CasADi DM column."""
    values = np.asarray(values, dtype=float)
    if like is not None and is_casadi(like):
        import casadi

        return casadi.DM(values)
    ndim = np.ndim(like) if like is not None else 1
    return values.reshape((-1,) + (1,) * max(ndim - 1, 0))


def _like(*values):
    """The value that decides the parameters' form: a CasADi one if any, else the widest."""
    for value in values:
        if is_casadi(value):
            return value
    return max(values, key=np.ndim)
