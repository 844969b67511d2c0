"""The passive joint model whose parameters a decomposition fit identifies.

Each joint (knee, ankle; clinical angles and moments, see
:mod:`predgait.dynamics.passive`) carries a linear spring-damper (thesis eqs.
3.3.1-3.3.2: k, c, theta0) and/or double-exponential range-of-motion stops
(:class:`~predgait.dynamics.passive.ExponentialLimits`, the form of Riener & Edrich 1999,
J Biomech 32:539-544). Defaults and bounds for the stops are those of Anderson (1999,
PhD thesis, Univ. of Texas at Austin) as used by Falisse et al. (2019, J R Soc Interface
16:20190402): knee 6.09 exp(-33.94 (theta + 0.13)) - 11.03 exp(-11.33 (2.40 - theta)),
ankle 0.18 exp(-12.12 (theta + 0.74)) - 2.03 exp(-38.11 (0.52 - theta)) N m (theta the
clinical knee flexion / ankle dorsiflexion, rad). Each parameter is fitted within bounds
(optionally with a Gaussian prior) or fixed. The stop angles and growth rates b are
settings, never fitted: k_lower exp(-b (theta - lower)) cannot tell k_lower from lower,
and gait barely reaches the stops, so b and k_lower are confounded too. The passive
moment is then linear in (k, k theta0, c, k_lower, k_upper, c_limit) (see
:func:`features`), which keeps the fit small whatever the number of samples.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from predgait.dynamics.passive import ExponentialLimits, LinearSpringDamper, PassiveJoint
from predgait.errors import InputError

JOINTS = ("knee", "ankle")
#: Parameter name -> unit.
UNITS = {"k": "N m/rad", "c": "N m s/rad", "theta0": "rad", "k_lower": "N m",
         "b_lower": "1/rad", "k_upper": "N m", "b_upper": "1/rad", "c_limit": "N m s/rad"}

#: Parameter name -> what it is (printed beside its value; clinical angles: knee flexion,
#: ankle dorsiflexion; the passive moment acts toward the positive angle when positive).
MEANINGS = {
    "k": "linear spring stiffness, moment -k (theta - theta0)",
    "c": "linear damping, moment -c theta'",
    "theta0": "the linear spring's zero (rest angle), in clinical flexion / dorsiflexion",
    "k_lower": "lower stop (knee extension / ankle plantarflexion) moment at its stop angle, "
               "k_lower exp(-b_lower (theta - stop))",
    "b_lower": "growth rate of the lower stop",
    "k_upper": "upper stop (knee flexion / ankle dorsiflexion) moment at its stop angle, "
               "-k_upper exp(-b_upper (stop - theta))",
    "b_upper": "growth rate of the upper stop",
    "c_limit": "damping inside the stops",
}


class Element(enum.Enum):
    """Passive element kinds."""

    LINEAR = "linear"
    LIMITS = "limits"


#: Parameters that shape the stops; fixed settings (see the module docstring).
SHAPE_PARAMETERS = ("b_lower", "b_upper")
ELEMENT_PARAMETERS = {Element.LINEAR: ("k", "c", "theta0"),
                      Element.LIMITS: ("k_lower", "b_lower", "k_upper", "b_upper", "c_limit")}
#: Stop angles (lower, upper), rad, clinical: knee extension stop moved to full extension
#: as in :class:`ExponentialLimits`' defaults; ankle from Anderson (1999).
STOP_ANGLES = {"knee": (0.0, 2.40), "ankle": (-0.74, 0.52)}
#: (joint, name) -> (initial value, lower bound, upper bound, fitted by default).
DEFAULTS = {
    ("knee", "k"): (2.0, 0.0, 200.0, True),
    ("knee", "c"): (0.2, 0.0, 10.0, True),
    ("knee", "theta0"): (0.6, -0.5, 2.0, True),
    ("knee", "k_lower"): (0.0738, 0.0, 20.0, True),
    ("knee", "b_lower"): (33.94, 5.0, 80.0, False),
    ("knee", "k_upper"): (11.03, 0.0, 100.0, False),
    ("knee", "b_upper"): (11.33, 5.0, 80.0, False),
    ("knee", "c_limit"): (0.0, 0.0, 10.0, False),
    ("ankle", "k"): (2.0, 0.0, 400.0, True),
    ("ankle", "c"): (0.05, 0.0, 10.0, True),
    ("ankle", "theta0"): (0.0, -0.6, 0.6, True),
    ("ankle", "k_lower"): (0.18, 0.0, 20.0, False),
    ("ankle", "b_lower"): (12.12, 2.0, 80.0, False),
    ("ankle", "k_upper"): (2.03, 0.0, 50.0, False),
    ("ankle", "b_upper"): (38.11, 5.0, 80.0, False),
    ("ankle", "c_limit"): (0.0, 0.0, 10.0, False),
}


@dataclass(frozen=True)
class Parameter:
    """One passive parameter: fixed at ``value`` or fitted from ``value`` within bounds.

    Attributes:
        joint: ``knee`` or ``ankle``.
        name: One of :data:`UNITS`.
        value: Fixed value, or the initial guess when fitted (SI).
        lower: Lower bound (SI).
        upper: Upper bound (SI), > lower.
        fit: Whether the fit estimates it.
        prior: Mean of a Gaussian prior (SI) or None.
        prior_sd: Its standard deviation (SI) or None.
    """

    joint: str
    name: str
    value: float
    lower: float
    upper: float
    fit: bool = True
    prior: float | None = None
    prior_sd: float | None = None

    @property
    def key(self) -> str:
        """``joint.name``."""
        return f"{self.joint}.{self.name}"

    @property
    def unit(self) -> str:
        """SI unit."""
        return UNITS[self.name]

    @property
    def meaning(self) -> str:
        """What the parameter is (:data:`MEANINGS`)."""
        return MEANINGS[self.name]


@dataclass(frozen=True)
class PassiveModel:
    """Elements and parameters of every joint in the fit (hashable: it keys solver caches).

    Attributes:
        elements: ((joint, (Element, ...)), ...).
        parameters: Every parameter of those elements.
        stops: ((joint, (lower, upper) rad), ...) stop angles of joints with limits.
    """

    elements: tuple[tuple[str, tuple[Element, ...]], ...]
    parameters: tuple[Parameter, ...]
    stops: tuple[tuple[str, tuple[float, float]], ...] = ()

    @property
    def joints(self) -> tuple[str, ...]:
        """Joints in the model."""
        return tuple(joint for joint, _ in self.elements)

    @property
    def fitted(self) -> tuple[Parameter, ...]:
        """The parameters the fit estimates, in the order of its unknowns."""
        return tuple(p for p in self.parameters if p.fit)

    def passive_joint(self, joint: str, values: Mapping[str, object]) -> PassiveJoint:
        """The joint's elements with ``values`` (key -> float or CasADi symbol) filled in."""
        def value(name):
            return values[f"{joint}.{name}"]

        built = []
        for element in dict(self.elements)[joint]:
            if element is Element.LINEAR:
                built.append(LinearSpringDamper(value("k"), value("c"), value("theta0")))
            else:
                lower, upper = dict(self.stops)[joint]
                built.append(ExponentialLimits(lower, upper, value("k_lower"), value("b_lower"),
                                               value("k_upper"), value("b_upper"),
                                               value("c_limit")))
        return PassiveJoint(tuple(built))

    def values(self) -> dict[str, float]:
        """Key -> value (initial or fixed) of every parameter."""
        return {p.key: p.value for p in self.parameters}


def build_model(joints, *, elements=None, fit=None, fixed=None, bounds=None, priors=None,
                stops=None, where: str = "passive") -> PassiveModel:
    """A :class:`PassiveModel` from literature defaults and the user's choices.

    Args:
        joints: Joints to model (subset of :data:`JOINTS`).
        elements: joint -> element names (default both ``linear`` and ``limits``).
        fit: joint -> names to fit (default: those marked fitted in :data:`DEFAULTS`).
        fixed: joint -> {name: value} fixed values (SI).
        bounds: joint -> {name: (lower, upper)} (SI).
        priors: joint -> {name: (mean, sd)} Gaussian priors (SI).
        stops: joint -> (lower, upper) stop angles, rad.
        where: Prefix for messages, e.g. ``"problem.toml: passive"``.

    Raises:
        InputError: Naming ``where.joint.key`` for unknown joints, elements or parameters,
            a parameter both fixed and fitted, bounds that exclude the value or the prior.
    """
    elements, fit, fixed = elements or {}, fit or {}, fixed or {}
    bounds, priors, stops = bounds or {}, priors or {}, stops or {}
    element_table, parameters, stop_table = [], [], []
    for joint in joints:
        if joint not in JOINTS:
            raise InputError(f"{where}: joint '{joint}' is not one of: {', '.join(JOINTS)}.")
        here = f"{where}.{joint}"
        kinds = _elements(elements.get(joint, ("linear", "limits")), f"{here}.elements")
        names = [n for kind in kinds for n in ELEMENT_PARAMETERS[kind]]
        for key, given in (("fit", fit.get(joint, ())), ("fixed", fixed.get(joint, {})),
                           ("bounds", bounds.get(joint, {})), ("priors", priors.get(joint, {}))):
            for name in given:
                if name not in names:
                    raise InputError(f"{here}.{key}: '{name}' is not a parameter of its "
                                     f"elements ({', '.join(names)}).")
        shape = set(fit.get(joint, ())) & set(SHAPE_PARAMETERS)
        if shape:
            raise InputError(f"{here}.fit: {', '.join(sorted(shape))} (growth rate of a "
                             "range-of-motion stop) is a setting, not fitted; give it in "
                             f"{here}.fixed and fit k_lower/k_upper instead.")
        both = set(fit.get(joint, ())) & set(fixed.get(joint, {}))
        if both:
            raise InputError(f"{here}.fixed: {', '.join(sorted(both))} is both fixed and in "
                             f"{here}.fit; remove it from one of them.")
        for name in names:
            parameters.append(_parameter(joint, name, fit.get(joint), fixed.get(joint, {}),
                                         bounds.get(joint, {}), priors.get(joint, {}), here))
        element_table.append((joint, kinds))
        if Element.LIMITS in kinds:
            lower, upper = stops.get(joint, STOP_ANGLES[joint])
            if not upper > lower:
                raise InputError(f"{here}.stops_deg: the upper stop must exceed the lower.")
            stop_table.append((joint, (float(lower), float(upper))))
    return PassiveModel(tuple(element_table), tuple(parameters), tuple(stop_table))


def _elements(names, where) -> tuple[Element, ...]:
    kinds = []
    for name in names:
        try:
            kinds.append(Element(name))
        except ValueError:
            raise InputError(f"{where}: '{name}' is not one of: "
                             f"{', '.join(e.value for e in Element)}.") from None
    if not kinds:
        raise InputError(f"{where}: give at least one element.")
    return tuple(dict.fromkeys(kinds))


def _parameter(joint, name, fit, fixed, bounds, priors, where) -> Parameter:
    value, lower, upper, fitted = DEFAULTS[(joint, name)]
    fitted = (name in fit) if fit is not None else fitted
    if name in fixed:
        value, fitted = float(fixed[name]), False
    if name in bounds:
        lower, upper = map(float, bounds[name])
        if not upper > lower:
            raise InputError(f"{where}.bounds.{name}: [{lower:g}, {upper:g}] {UNITS[name]} "
                             "is empty; give [lower, upper] with lower < upper.")
    prior, prior_sd = (None, None)
    if name in priors:
        prior, prior_sd = map(float, priors[name])
        if not prior_sd > 0:
            raise InputError(f"{where}.priors.{name}: the standard deviation must be > 0.")
        if not lower <= prior <= upper:
            raise InputError(f"{where}.priors.{name}: the prior mean {prior:g} {UNITS[name]} "
                             f"lies outside the bounds [{lower:g}, {upper:g}]; widen "
                             f"{where}.bounds.{name} or move the prior.")
        if fitted:
            value = prior
    if fitted:
        value = min(max(value, lower), upper)
    elif not (math.isfinite(value) and lower <= value <= upper) and name in fixed:
        raise InputError(f"{where}.fixed.{name} = {value:g} {UNITS[name]} lies outside "
                         f"[{lower:g}, {upper:g}]; change it or {where}.bounds.{name}.")
    return Parameter(joint, name, float(value), float(lower), float(upper), fitted, prior,
                     prior_sd)


def features(model: PassiveModel, joint: str, angle, rate) -> dict[str, np.ndarray]:
    """Columns of the joint's passive moment, linear in its coefficients.

    passive = sum_name coefficient(name) * column(name) with coefficients k, k_theta0,
    c (linear element) and k_lower, k_upper, c_limit (stops), each column the element's
    own moment (:mod:`predgait.dynamics.passive`) at unit coefficient.

    Args:
        model: The passive model (its stop angles and fixed growth rates).
        joint: Joint name.
        angle: (n,) clinical angle, rad.
        rate: (n,) rad/s.

    Returns:
        coefficient name -> (n,) column, N m per unit coefficient.
    """
    values = model.values()
    columns = {}
    for element in dict(model.elements)[joint]:
        if element is Element.LINEAR:
            columns["k"] = LinearSpringDamper(1.0, 0.0, 0.0).moment(angle, rate)
            columns["k_theta0"] = LinearSpringDamper(1.0, 0.0, 1.0).moment(angle, rate) \
                - columns["k"]
            columns["c"] = LinearSpringDamper(0.0, 1.0, 0.0).moment(angle, rate)
        else:
            lower, upper = dict(model.stops)[joint]
            b_lower, b_upper = values[f"{joint}.b_lower"], values[f"{joint}.b_upper"]
            for name, unit in (("k_lower", (1, 0, 0)), ("k_upper", (0, 1, 0)),
                               ("c_limit", (0, 0, 1))):
                columns[name] = ExponentialLimits(lower, upper, unit[0], b_lower, unit[1],
                                                  b_upper, unit[2]).moment(angle, rate)
    return columns


def coefficients(joint: str, values: Mapping[str, object], names) -> list:
    """The coefficients of :func:`features` from parameter values (floats or symbols)."""
    def value(name):
        return values[f"{joint}.{name}"]

    table = {"k": lambda: value("k"), "k_theta0": lambda: value("k") * value("theta0"),
             "c": lambda: value("c"), "k_lower": lambda: value("k_lower"),
             "k_upper": lambda: value("k_upper"), "c_limit": lambda: value("c_limit")}
    return [table[name]() for name in names]
