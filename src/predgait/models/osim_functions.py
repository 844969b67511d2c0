"""OpenSim functions of one coordinate used by MovingPathPoint (as read, not evaluated).

SimmSpline and NaturalCubicSpline hold their knots; Constant its value; LinearFunction
``coefficients = (slope, intercept)`` (OpenSim: ``f(x) = slope * x + intercept``);
MultiplierFunction ``scale * function(x)``. Evaluating them is the muscle-path code's job.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from predgait.models.osim_xml import Node, OsimFile


@dataclass(frozen=True)
class SimmSpline:
    """OpenSim SimmSpline: cubic spline through ``(x, y)`` (x increasing)."""

    x: tuple[float, ...]
    y: tuple[float, ...]


@dataclass(frozen=True)
class NaturalCubicSpline:
    """OpenSim NaturalCubicSpline through ``(x, y)`` (x increasing)."""

    x: tuple[float, ...]
    y: tuple[float, ...]


@dataclass(frozen=True)
class Constant:
    """OpenSim Constant: ``value`` everywhere."""

    value: float


@dataclass(frozen=True)
class LinearFunction:
    """OpenSim LinearFunction: ``slope * x + intercept``."""

    slope: float
    intercept: float


@dataclass(frozen=True)
class MultiplierFunction:
    """OpenSim MultiplierFunction: ``scale * function(x)``."""

    function: Function
    scale: float


Function = SimmSpline | NaturalCubicSpline | Constant | LinearFunction | MultiplierFunction


def read_function_holder(f: OsimFile, holder: Node) -> Function:
    """The one function element inside a property such as ``<x_location>``."""
    inner = [c for c in holder.children]
    if len(inner) != 1:
        f.fail(holder, f"holds {len(inner)} elements", "give exactly one function "
               "(SimmSpline, NaturalCubicSpline, Constant, LinearFunction, MultiplierFunction)")
    return read_function(f, inner[0])


def read_function(f: OsimFile, node: Node) -> Function:
    """A function element; InputError for any other type."""
    tag = node.tag
    if tag in ("SimmSpline", "NaturalCubicSpline"):
        f.check_known(node, {"x", "y"})
        xs = f.floats(node.only_child("x", f), owner=node)
        ys = f.floats(node.only_child("y", f), owner=node)
        if len(xs) != len(ys) or len(xs) < 2:
            f.fail(node, f"{len(xs)} x and {len(ys)} y values", "give as many x as y, at "
                   "least 2")
        if not all(math.isfinite(v) for v in xs + ys) or any(
                b <= a for a, b in zip(xs, xs[1:], strict=False)):
            f.fail(node, "x is not strictly increasing or a value is not finite",
                   "give finite knots with increasing x")
        cls = SimmSpline if tag == "SimmSpline" else NaturalCubicSpline
        return cls(x=xs, y=ys)
    if tag == "Constant":
        f.check_known(node, {"value"})
        value = node.find("value")
        return Constant(value=f.number(value, owner=node) if value is not None else 0.0)
    if tag == "LinearFunction":
        f.check_known(node, {"coefficients"})
        coef = node.find("coefficients")
        slope, intercept = f.vec(coef, 2, owner=node) if coef is not None else (1.0, 0.0)
        return LinearFunction(slope=slope, intercept=intercept)
    if tag == "MultiplierFunction":
        f.check_known(node, {"function", "scale"})
        scale = node.find("scale")
        return MultiplierFunction(function=read_function_holder(f, node.only_child("function", f)),
                                  scale=f.number(scale, owner=node) if scale is not None else 1.0)
    f.unsupported(node)
