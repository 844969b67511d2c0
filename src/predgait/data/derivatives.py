"""Numerical derivatives: thesis 3- and 5-point differences, and spline derivatives.

Thesis sec. 3.2.2: "Each coordinate was differentiated using a central difference
technique, with the forward and reverse differences used at the endpoints [Wylie and
Barrett 1982]. The effects of three-point and five-point methods ... were investigated.
The velocities were differentiated again to determine the accelerations."
The end formulas here are the one-sided differences of the same order as the interior
ones (O(h^2) for 3-point, O(h^4) for 5-point), so the error order holds everywhere.
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np

from predgait.data.frames import parse_enum
from predgait.errors import InputError


class Method(StrEnum):
    """Differentiation method."""

    CENTRAL3 = "central3"
    CENTRAL5 = "central5"
    SPLINE = "spline"


_END3 = np.array([-3.0, 4.0, -1.0]) / 2.0
_END5 = (np.array([-25.0, 48.0, -36.0, 16.0, -3.0]) / 12.0,
         np.array([-3.0, -10.0, 18.0, -6.0, 1.0]) / 12.0)


def time_step(time, *, rtol: float = 1e-6) -> float:
    """Uniform step (s) of a time vector; InputError if the steps differ."""
    time = np.asarray(time, dtype=float)
    steps = np.diff(time)
    h = float(np.mean(steps))
    if steps.size == 0 or h <= 0 or np.max(np.abs(steps - h)) > rtol * max(abs(h), 1.0) + 1e-12:
        worst = int(np.argmax(np.abs(steps - h))) if steps.size else 0
        raise InputError(
            f"time steps are not uniform (step {worst + 1} is "
            f"{steps[worst] if steps.size else float('nan'):.6g} s, mean {h:.6g} s): "
            "rebuild the time base with predgait.data.trial.uniform_time or use method='spline'."
        )
    return h


def _first(y: np.ndarray, h: float, method: Method) -> np.ndarray:
    out = np.empty_like(y)
    if method is Method.CENTRAL3:
        out[1:-1] = (y[2:] - y[:-2]) / (2 * h)
        out[0] = np.tensordot(_END3, y[:3], axes=1) / h
        out[-1] = -np.tensordot(_END3, y[::-1][:3], axes=1) / h
    else:
        out[2:-2] = (-y[4:] + 8 * y[3:-1] - 8 * y[1:-3] + y[:-4]) / (12 * h)
        for k, weights in enumerate(_END5):
            out[k] = np.tensordot(weights, y[:5], axes=1) / h
            out[-1 - k] = -np.tensordot(weights, y[::-1][:5], axes=1) / h
    return out


def differentiate(x, time, *, method: Method | str = Method.CENTRAL3, order: int = 1,
                  axis: int = 0) -> np.ndarray:
    """Time derivative of sampled data.

    Args:
        x: samples along ``axis``, e.g. (n,) or (n, m, 3).
        time: (n,) s, or the step h (s) as a float. The difference methods need a uniform
            step (checked); the spline method accepts any increasing times.
        method: "central3" (O(h^2)), "central5" (O(h^4)) or "spline" (quintic
            interpolating spline, differentiated analytically).
        order: 1 (velocity) or 2 (acceleration: the difference applied twice, as the
            thesis did; the spline's second derivative for "spline").
        axis: time axis.

    Returns:
        Derivative, same shape as ``x``, units of x per s**order.
    """
    method = parse_enum(method, Method, field="method")
    if order not in (1, 2):
        raise InputError(f"derivative order {order} must be 1 or 2.")
    y = np.moveaxis(np.asarray(x, dtype=float), axis, 0)
    n = y.shape[0]
    if np.isscalar(time):
        t = np.arange(n) * float(time)
    else:
        t = np.asarray(time, dtype=float)
        if t.shape != (n,):
            raise InputError(f"time has shape {t.shape}; expected ({n},).")
    needed = {Method.CENTRAL3: 3, Method.CENTRAL5: 5, Method.SPLINE: 6}[method]
    if n < needed:
        raise InputError(f"{n} samples are too few for method {method.value!r} ({needed}+).")
    if method is Method.SPLINE:
        if np.any(np.diff(t) <= 0):
            raise InputError("time must be strictly increasing for spline derivatives.")
        from scipy.interpolate import make_interp_spline  # heavy: only for spline derivatives

        spline = make_interp_spline(t, y, k=5, axis=0)
        out = spline.derivative(order)(t)
    else:
        h = time_step(t)
        out = y
        for _ in range(order):
            out = _first(out, h, method)
    return np.moveaxis(out, 0, axis)
