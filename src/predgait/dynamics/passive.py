"""Passive joint elements on CLINICAL angles and moments, for numpy and CasADi alike.

Every element maps a clinical joint angle (rad; hip flexion, knee flexion, ankle
dorsiflexion positive) and its rate (rad/s) to the clinical passive moment (N m,
positive toward the positive angle). Mapping to model joint torques (knee:
tau = -M(-q, -v)) is done once, in the forward-dynamics module. Elements are frozen
dataclasses whose parameters may be floats or CasADi symbols (fitting problems), and
whose ``moment`` accepts numpy arrays or CasADi SX/MX/DM expressions.

Thesis (3.3.3, eqs. 3.3.1-3.3.2): M_passive = -k (theta_d - theta_p - theta_0)
- c (theta_d' - theta_p'), theta_d - theta_p the relative angle of the distal to the
proximal segment. The law keeps its form when angle and moment both change sign, so it
holds on the clinical angle with theta_0 expressed clinically. The thesis (4.2, after
Fig. 4.2.10) named the missing piece: a linear spring resists knee hyperextension no
more than flexion; :class:`ExponentialLimits` adds the asymmetric range-of-motion stops.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from predgait.dynamics.backend import is_casadi
from predgait.errors import InputError


def _exp(x, *like):
    """Exp of a numpy value or a CasADi expression (casadi imported only when needed)."""
    if is_casadi(x, *like):
        import casadi

        return casadi.exp(x)
    return np.exp(x)


@dataclass(frozen=True)
class LinearSpringDamper:
    """Linear torsional spring and damper, thesis eqs. 3.3.1-3.3.2.

    M = -k (theta - theta0) - c theta'.

    Attributes:
        k: Stiffness, N m/rad (>= 0).
        c: Damping, N m s/rad (>= 0).
        theta0: Neutral clinical angle, rad.
    """

    k: Any = 0.0
    c: Any = 0.0
    theta0: Any = 0.0

    def moment(self, angle, rate):
        """Clinical moment, N m, for clinical ``angle`` (rad) and ``rate`` (rad/s)."""
        return -self.k * (angle - self.theta0) - self.c * rate


@dataclass(frozen=True)
class ExponentialLimits:
    """Double-exponential range-of-motion stops, smooth everywhere.

    M = k_lower exp(-b_lower (theta - lower)) - k_upper exp(-b_upper (upper - theta))
        - c_limit theta' [s(b_lower (lower - theta)) + s(b_upper (theta - upper))]

    with s(z) = 1 / (1 + exp(-z)) a logistic switch: the stop damping is half on at a
    limit, fully on past it and negligible inside the range. The elastic form is that
    of Davy & Audu (1987, J Biomech 20:187-201) and Riener & Edrich (1999, J Biomech
    32:539-544, passive elastic moments of hip, knee and ankle): ~0 mid-range, growing
    exponentially and restoring past each limit. k_lower (k_upper) is the moment at the
    limit itself; it grows e-fold per 1/b rad beyond it.

    Defaults are the knee (clinical flexion, rad): the ligament stops of Anderson (1999,
    PhD thesis, Univ. of Texas at Austin, table G.2, eq. 4.4), 6.09 exp(-33.94
    (theta + 0.13)) - 11.03 exp(-11.33 (2.40 - theta)) N m, as also used in the
    predictive simulations of Falisse et al. (2019, J R Soc Interface 16:20190402).
    Rewritten with the extension stop at lower = 0 rad (full extension, so the stop
    opposes hyperextension) the same curve has k_lower = 6.09 exp(-33.94 * 0.13) =
    0.0738 N m: 2.2 N m at 5.7 deg of hyperextension, 66 N m at 11.5 deg. The flexion
    stop (2.40 rad = 137.5 deg) is far beyond gait. These are a generic adult's; fit
    them to a subject (``predgait.problems``) when data allow.

    Attributes:
        lower: Lower limit (clinical angle), rad.
        upper: Upper limit, rad (> lower).
        k_lower: Moment at the lower limit, N m (positive: pushes toward larger angle).
        b_lower: Growth rate past the lower limit, 1/rad.
        k_upper: Moment at the upper limit, N m (pushes toward smaller angle).
        b_upper: Growth rate past the upper limit, 1/rad.
        c_limit: Damping past the limits, N m s/rad (0: none).
    """

    lower: Any = 0.0
    upper: Any = 2.40
    k_lower: Any = 0.0738
    b_lower: Any = 33.94
    k_upper: Any = 11.03
    b_upper: Any = 11.33
    c_limit: Any = 0.0

    def moment(self, angle, rate):
        """Clinical moment, N m, for clinical ``angle`` (rad) and ``rate`` (rad/s)."""
        below = _exp(-self.b_lower * (angle - self.lower), angle, rate)
        above = _exp(-self.b_upper * (self.upper - angle), angle, rate)
        moment = self.k_lower * below - self.k_upper * above
        if is_casadi(self.c_limit) or self.c_limit != 0:
            # s(b (lower - theta)) = below / (1 + below); written so exp never overflows
            # in the middle of the range, where both terms are tiny.
            switch = below / (1 + below) + above / (1 + above)
            moment = moment - self.c_limit * rate * switch
        return moment


Element = LinearSpringDamper | ExponentialLimits


@dataclass(frozen=True)
class PassiveJoint:
    """The passive elements of one joint; their moments add.

    Attributes:
        elements: Elements acting on the joint's clinical angle.
    """

    elements: tuple[Element, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "elements", tuple(self.elements))
        for element in self.elements:
            if not hasattr(element, "moment"):
                raise InputError(f"passive element {element!r} has no moment(angle, rate).")

    def moment(self, angle, rate):
        """Sum of the elements' clinical moments, N m (0 for no elements)."""
        total = 0.0 * angle
        for element in self.elements:
            total = total + element.moment(angle, rate)
        return total


def total_passive(joints: Mapping[str, PassiveJoint], angles: Mapping[str, Any],
                  rates: Mapping[str, Any]) -> dict[str, Any]:
    """Clinical passive moment of each joint, N m.

    Args:
        joints: Joint name (e.g. "knee") -> PassiveJoint.
        angles: Joint name -> clinical angle, rad (float, array or CasADi expression).
        rates: Joint name -> clinical angular rate, rad/s.

    Returns:
        Joint name -> clinical moment, for every joint in ``joints``.

    Raises:
        InputError: A joint has no angle or rate.
    """
    moments = {}
    for name, joint in joints.items():
        if name not in angles or name not in rates:
            raise InputError(f"passive elements on {name!r} but no angle/rate for it; "
                             f"angles given for: {', '.join(sorted(angles)) or 'none'}.")
        moments[name] = joint.moment(angles[name], rates[name])
    return moments


_LINEAR_KEYS = {"k": "N m/rad", "c": "N m s/rad", "theta0": "rad", "theta0_deg": "deg"}
_LIMIT_KEYS = {"preset": "", "lower": "rad", "lower_deg": "deg", "upper": "rad",
               "upper_deg": "deg", "k_lower": "N m", "b_lower": "1/rad", "k_upper": "N m",
               "b_upper": "1/rad", "c_limit": "N m s/rad"}
_PRESETS = {"knee": ExponentialLimits()}


def parse_passive(table: Mapping[str, Any], *, where: str) -> PassiveJoint:
    """Build a joint's passive elements from a TOML-like table.

    Keys (all optional): ``k`` (N m/rad), ``c`` (N m s/rad), ``theta0`` (rad) or
    ``theta0_deg`` (deg) for the linear spring-damper (present when any is given), and
    ``limits``, a table for :class:`ExponentialLimits` with ``preset = "knee"`` and/or
    ``lower``/``lower_deg``, ``upper``/``upper_deg``, ``k_lower``, ``b_lower``,
    ``k_upper``, ``b_upper``, ``c_limit``. Without a preset all six limit parameters
    are required; with one, given keys override it. Example::

        [passive.knee]
        k = 10.0
        c = 20.0
        theta0_deg = 0.0
        limits = { preset = "knee", c_limit = 1.0 }

    Args:
        table: The mapping read from the file.
        where: Its location for messages, e.g. "problem.toml: passive.knee".

    Returns:
        The :class:`PassiveJoint`.

    Raises:
        InputError: Naming ``where.key`` for unknown keys, wrong types or bad values.
    """
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: expected a table of passive elements, got {table!r}.")
    _check_keys(table, set(_LINEAR_KEYS) | {"limits"}, where)
    elements = []
    values = {key: _number(table, key, where) for key in _LINEAR_KEYS if key in table}
    if values:
        theta0 = _angle(values, "theta0", where, default=0.0)
        for key in ("k", "c"):
            if values.get(key, 0.0) < 0:
                raise InputError(f"{where}.{key} = {values[key]:g} {_LINEAR_KEYS[key]} is "
                                 "negative; passive elements cannot add energy.")
        elements.append(LinearSpringDamper(k=values.get("k", 0.0), c=values.get("c", 0.0),
                                           theta0=theta0))
    if "limits" in table:
        elements.append(_parse_limits(table["limits"], f"{where}.limits"))
    return PassiveJoint(tuple(elements))


def _parse_limits(table, where) -> ExponentialLimits:
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: expected a table such as {{ preset = \"knee\" }}, "
                         f"got {table!r}.")
    _check_keys(table, set(_LIMIT_KEYS), where)
    preset = table.get("preset")
    if preset is not None and preset not in _PRESETS:
        raise InputError(f"{where}.preset: {preset!r} is not one of: {', '.join(_PRESETS)}.")
    values = {key: _number(table, key, where) for key in _LIMIT_KEYS
              if key in table and key != "preset"}
    base = _PRESETS.get(preset)
    fields = {}
    for name in ("lower", "upper"):
        value = _angle(values, name, where, default=None if base is None else getattr(base, name))
        fields[name] = value
    for name in ("k_lower", "b_lower", "k_upper", "b_upper", "c_limit"):
        default = 0.0 if name == "c_limit" else None
        default = getattr(base, name) if base is not None else default
        if name not in values and default is None:
            raise InputError(f"{where}.{name}: missing ({_LIMIT_KEYS[name]}); give it or "
                             f"use a preset ({', '.join(_PRESETS)}).")
        fields[name] = values.get(name, default)
        if fields[name] < 0:
            raise InputError(f"{where}.{name} = {fields[name]:g} {_LIMIT_KEYS[name]} must "
                             "not be negative.")
    if fields["upper"] <= fields["lower"]:
        raise InputError(f"{where}: upper limit {math.degrees(fields['upper']):g} deg must "
                         f"exceed the lower {math.degrees(fields['lower']):g} deg.")
    return ExponentialLimits(**fields)


def _check_keys(table, allowed, where):
    for key in table:
        if key not in allowed:
            raise InputError(f"{where}.{key}: unknown key; allowed: "
                             f"{', '.join(sorted(allowed))}.")


def _number(table, key, where) -> float:
    value = table[key]
    if key == "preset":
        return value
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{where}.{key}: expected a number ({_both_units(key)}), "
                         f"got {value!r}.")
    if not math.isfinite(value):
        raise InputError(f"{where}.{key}: {value!r} is not finite.")
    return float(value)


def _both_units(key):
    return (_LINEAR_KEYS | _LIMIT_KEYS).get(key, "")


def _angle(values, name, where, *, default):
    """An angle given in rad (``name``) or deg (``name_deg``), never both, in rad."""
    if name in values and f"{name}_deg" in values:
        raise InputError(f"{where}: give {name} (rad) or {name}_deg (deg), not both.")
    if f"{name}_deg" in values:
        return math.radians(values[f"{name}_deg"])
    if name in values:
        return values[name]
    if default is None:
        raise InputError(f"{where}.{name}: missing; give {name} (rad) or {name}_deg (deg).")
    return default
