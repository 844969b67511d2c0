"""Values of OpenSim's functions of one coordinate (MovingPathPoint locations), numpy.

Evaluates the records of :mod:`predgait.models.osim_functions` as OpenSim 4.6 does:

- ``SimmSpline`` (and ``NaturalCubicSpline``, whose OpenSim source uses the same algorithm):
  the cubic spline of Forsythe, Malcolm & Moler (1977, Computer Methods for Mathematical
  Computations, ``spline``/``seval``) with end conditions that match the third derivatives
  of the end cubics to divided differences (opensim-core OpenSim/Common/SimmSpline.cpp
  ``calcCoefficients``); outside the knots, linear extrapolation with the end slopes;
- ``Constant``, ``LinearFunction`` (slope x + intercept), ``MultiplierFunction`` (scale f).
"""

from __future__ import annotations

import functools

import numpy as np

from predgait.models import osim_functions as fn

_TINY = 1e-12  # OpenSim's TINY_NUMBER (SimmMacros.h)


@functools.lru_cache(maxsize=256)
def spline_coefficients(x: tuple[float, ...], y: tuple[float, ...]):
    """(b, c, d) with y_k + dx (b_k + dx (c_k + dx d_k)) on [x_k, x_k+1] (OpenSim's SimmSpline)."""
    n = len(x)
    x, y = list(map(float, x)), list(map(float, y))
    b, c, d = [0.0] * n, [0.0] * n, [0.0] * n
    if n == 2:
        slope = (y[1] - y[0]) / max(_TINY, x[1] - x[0])
        return np.array([slope, slope]), np.zeros(2), np.zeros(2)
    nm1, nm2 = n - 1, n - 2
    d[0] = max(_TINY, x[1] - x[0])
    c[1] = (y[1] - y[0]) / d[0]
    for i in range(1, nm1):
        d[i] = max(_TINY, x[i + 1] - x[i])
        b[i] = 2.0 * (d[i - 1] + d[i])
        c[i + 1] = (y[i + 1] - y[i]) / d[i]
        c[i] = c[i + 1] - c[i]
    b[0], b[nm1] = -d[0], -d[nm2]
    c[0] = c[nm1] = 0.0
    if n > 3:
        d31 = max(_TINY, x[3] - x[1])
        d20 = max(_TINY, x[2] - x[0])
        d1 = max(_TINY, x[nm1] - x[n - 3])
        d2 = max(_TINY, x[nm2] - x[n - 4])
        d30 = max(_TINY, x[3] - x[0])
        d3 = max(_TINY, x[nm1] - x[n - 4])
        c[0] = (c[2] / d31 - c[1] / d20) * d[0] * d[0] / d30
        c[nm1] = -(c[nm2] / d1 - c[n - 3] / d2) * d[nm2] * d[nm2] / d3
    for i in range(1, n):
        t = d[i - 1] / b[i - 1]
        b[i] -= t * d[i - 1]
        c[i] -= t * c[i - 1]
    c[nm1] /= b[nm1]
    for i in range(nm2, -1, -1):
        c[i] = (c[i] - d[i] * c[i + 1]) / b[i]
    b[nm1] = (y[nm1] - y[nm2]) / d[nm2] + d[nm2] * (c[nm2] + 2.0 * c[nm1])
    for i in range(nm1):
        b[i] = (y[i + 1] - y[i]) / d[i] - d[i] * (c[i + 1] + 2.0 * c[i])
        d[i] = (c[i + 1] - c[i]) / d[i]
        c[i] *= 3.0
    c[nm1] *= 3.0
    d[nm1] = d[nm2]
    return np.array(b), np.array(c), np.array(d)


def _spline(function, value, derivative: bool):
    knots, ys = np.asarray(function.x), np.asarray(function.y)
    b, c, d = spline_coefficients(tuple(function.x), tuple(function.y))
    k = np.clip(np.searchsorted(knots, value, side="right") - 1, 0, len(knots) - 2)
    dx = value - knots[k]
    below, above = value < knots[0], value > knots[-1]
    if derivative:
        out = b[k] + dx * (2.0 * c[k] + 3.0 * dx * d[k])
        return np.where(below, b[0], np.where(above, b[-1], out))
    out = ys[k] + dx * (b[k] + dx * (c[k] + dx * d[k]))
    return np.where(below, ys[0] + (value - knots[0]) * b[0],
                    np.where(above, ys[-1] + (value - knots[-1]) * b[-1], out))


def evaluate(function, value, *, derivative: bool = False):
    """f(value) (or df/dvalue) of an OpenSim function record, elementwise over ``value``.

    Args:
        function: A record of :mod:`predgait.models.osim_functions`.
        value: Coordinate value(s), rad or m (float or array).
        derivative: Return the first derivative instead.

    Returns:
        An array of the shape of ``value``.
    """
    value = np.asarray(value, dtype=float)
    if isinstance(function, (fn.SimmSpline, fn.NaturalCubicSpline)):
        return _spline(function, value, derivative)
    if isinstance(function, fn.Constant):
        return np.full_like(value, 0.0 if derivative else function.value)
    if isinstance(function, fn.LinearFunction):
        if derivative:
            return np.full_like(value, function.slope)
        return function.slope * value + function.intercept
    if isinstance(function, fn.MultiplierFunction):
        return function.scale * evaluate(function.function, value, derivative=derivative)
    raise TypeError(f"not an OpenSim function record: {function!r}")
