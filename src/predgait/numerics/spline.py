"""Cubic interpolating spline with not-a-knot ends, in NumPy (no SciPy import).

The same spline as :class:`scipy.interpolate.CubicSpline` with its default "not-a-knot"
ends (de Boor, A Practical Guide to Splines, 1978, ch. IV; the same linear system as
SciPy's): the knot slopes s solve a tridiagonal system, here by the Thomas algorithm
over the knots (vectorised over the columns), and each interval is the cubic Hermite
polynomial of its end values and slopes. Three samples give the parabola through them.
Importing ``scipy.interpolate`` costs about 0.7 s of CPU on every simulation; this
module costs nothing to import and evaluates one time in a few microseconds.
"""

from __future__ import annotations

from bisect import bisect_right

import numpy as np


def _knot_slopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Slopes (n, k) at the knots of the not-a-knot cubic spline through (x, y), n >= 3."""
    dx = np.diff(x)[:, None]
    slope = np.diff(y, axis=0) / dx
    n = x.size
    if n == 3:  # both not-a-knot conditions coincide: the parabola through the 3 points
        a = np.array([[1.0, 1.0, 0.0],
                      [dx[1, 0], 2.0 * (dx[0, 0] + dx[1, 0]), dx[0, 0]],
                      [0.0, 1.0, 1.0]])
        b = np.stack([2.0 * slope[0], 3.0 * (dx[0] * slope[1] + dx[1] * slope[0]),
                      2.0 * slope[1]])
        return np.linalg.solve(a, b)
    lower, diag, upper = np.zeros(n), np.zeros(n), np.zeros(n)
    rhs = np.empty((n, y.shape[1]))
    diag[1:-1] = 2.0 * (dx[:-1, 0] + dx[1:, 0])
    upper[1:-1] = dx[:-1, 0]
    lower[1:-1] = dx[1:, 0]
    rhs[1:-1] = 3.0 * (dx[1:] * slope[:-1] + dx[:-1] * slope[1:])
    d = x[2] - x[0]  # not-a-knot at the start
    diag[0], upper[0] = dx[1, 0], d
    rhs[0] = ((dx[0] + 2.0 * d) * dx[1] * slope[0] + dx[0] ** 2 * slope[1]) / d
    d = x[-1] - x[-3]  # and at the end
    diag[-1], lower[-1] = dx[-2, 0], d
    rhs[-1] = (dx[-1] ** 2 * slope[-2] + (2.0 * d + dx[-1]) * dx[-2] * slope[-1]) / d
    for i in range(1, n):  # Thomas algorithm: forward elimination ...
        factor = lower[i] / diag[i - 1]
        diag[i] -= factor * upper[i - 1]
        rhs[i] -= factor * rhs[i - 1]
    s = np.empty_like(rhs)
    s[-1] = rhs[-1] / diag[-1]
    for i in range(n - 2, -1, -1):  # ... and back substitution
        s[i] = (rhs[i] - upper[i] * s[i + 1]) / diag[i]
    return s


class CubicSpline:
    """Not-a-knot cubic spline through sampled columns (SciPy's default CubicSpline).

    Calling it at t returns the (k,) interpolated row; outside the knots the end
    intervals' polynomials are extended (callers clamp t).

    Args:
        x: (n,) strictly increasing knots, n >= 3.
        y: (n, k) samples.
    """

    def __init__(self, x, y):
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        y = y.reshape(x.size, -1)
        s = _knot_slopes(x, y)
        dx = np.diff(x)[:, None]
        slope = np.diff(y, axis=0) / dx
        t = (s[:-1] + s[1:] - 2.0 * slope) / dx
        # (n - 1, 4, k): per interval, the coefficients of dt^3, dt^2, dt, 1
        self._coefficients = np.stack([t / dx, (slope - s[:-1]) / dx - t, s[:-1], y[:-1]],
                                      axis=1)
        self._knots = x.tolist()
        self._last = x.size - 2

    def _interval(self, t: float) -> tuple[int, float]:
        i = min(max(bisect_right(self._knots, t) - 1, 0), self._last)
        return i, t - self._knots[i]

    def __call__(self, t: float) -> np.ndarray:
        """(k,) value at t."""
        i, dt = self._interval(t)
        c3, c2, c1, c0 = self._coefficients[i]
        return ((c3 * dt + c2) * dt + c1) * dt + c0

    def values(self, times: np.ndarray) -> np.ndarray:
        """(m, k) values at the (m,) ``times`` at once (the same polynomials as calling)."""
        times = np.asarray(times, dtype=float)
        i = np.clip(np.searchsorted(self._knots, times, side="right") - 1, 0, self._last)
        dt = (times - np.asarray(self._knots)[i])[:, None]
        c3, c2, c1, c0 = np.moveaxis(self._coefficients[i], 1, 0)
        return ((c3 * dt + c2) * dt + c1) * dt + c0

    def derivative(self, order: int = 1):
        """The time derivative of the given order (1 or 2): a function t -> (k,)."""
        def evaluate(t):
            i, dt = self._interval(t)
            c3, c2, c1, _ = self._coefficients[i]
            if order == 1:
                return (3.0 * c3 * dt + 2.0 * c2) * dt + c1
            return 6.0 * c3 * dt + 2.0 * c2

        if order not in (1, 2):
            raise ValueError(f"derivative order {order} is not 1 or 2.")
        return evaluate
