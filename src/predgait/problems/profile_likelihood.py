"""Profile-likelihood 95 % intervals for the passive fits' rest angles theta0.

The elastic moment is linear in k, k theta0, c, ... (:mod:`~predgait.problems.passive_model`),
so a spring's rest angle theta0 = (k theta0) / k is a ratio of two estimated quantities and
its likelihood is skewed: the Fisher interval (+-1.96 SE, symmetric) misplaces it. On the
known-answer walk (3 cycles, 1 mm / 1 %, 100 noise seeds; docs/DEVELOPING.md) the knee's
profile interval reaches 1.23 Fisher half-widths below the estimate and 0.81 above.

The profile interval of an unknown p is {p : min over the other unknowns of C - C_min <=
3.84} (chi^2_1 at 95 %; Venzon & Moolgavkar 1988, Appl Stat 37:87-94), C the fit's
weighted least-squares objective (-2 log likelihood up to a constant, with the noise
weights of its Fisher information; :func:`~predgait.problems.gauss_newton.objective`).
Each end is found from the Fisher half-width by a safeguarded secant on sqrt(C - C_min)
(linear in the distance for a quadratic objective); every point is a Gauss-Newton refit
with p held (warm-started from the last point inside). An end that the bound reaches
first is the bound.
"""

from __future__ import annotations

import numpy as np

from predgait.problems.gauss_newton import LeastSquares, gauss_newton, objective

#: chi^2 with 1 degree of freedom, 95 % quantile.
CHI2_95 = 3.841458820694124
#: Refits per end at most (safeguarded secant on sqrt(rise), which is linear in the
#: distance for a quadratic objective: 2-4 refits end within TOLERANCE).
MAX_REFITS = 12
#: An end is accepted where the rise is within this fraction of ``level``.
TOLERANCE = 0.002
#: Gauss-Newton iterations per profile point.
MAX_ITER = 100


def profile_interval(problem: LeastSquares, z, row_weights, index: int, half_width: float,
                     *, level: float = CHI2_95) -> tuple[float, float]:
    """(low, high) of unknown ``index`` in z units (scaled to its bounds, [0, 1]).

    Args:
        problem: The fit's least-squares problem.
        z: The fitted unknowns (the minimum of the objective with ``row_weights``).
        row_weights: The residual rows' weights (those of the Fisher information).
        index: Which unknown.
        half_width: Its Fisher 95 % half-width, z units (> 0): the first trial distance.
        level: Objective rise that ends the interval (default chi^2_1 at 95 %).
    """
    z = np.asarray(z, dtype=float)
    floor = objective(problem, z, row_weights)
    return tuple(float(z[index] + sign * _end(problem, z, row_weights, index, sign,
                                              half_width, floor, level))
                 for sign in (-1.0, 1.0))


def _end(problem, z, row_weights, index, sign, half_width, floor, level) -> float:
    """Distance from z[index] to where the profile rises by ``level`` (or to the bound)."""
    room = z[index] if sign < 0 else 1.0 - z[index]
    inside, outside = 0.0, None          # rise < level at inside, >= level at outside
    start, distance = z.copy(), min(max(half_width, 1e-9), room)
    for _ in range(MAX_REFITS):
        trial = start.copy()
        trial[index] = z[index] + sign * distance
        held, _, _ = gauss_newton(problem, trial, row_weights, MAX_ITER, frozen=index)
        rise = objective(problem, held, row_weights) - floor
        if abs(rise - level) <= TOLERANCE * level:
            return distance
        if rise < level:
            inside, start = distance, held
            if distance >= room:
                return room               # the bound comes first
        else:
            outside = distance
        guess = distance * np.sqrt(level / rise) if rise > 0 else 2.0 * distance
        if outside is None:               # not bracketed yet: go on outward, to the bound
            distance = min(max(guess, 1.5 * distance), room)
        else:
            distance = guess if inside < guess < outside else 0.5 * (inside + outside)
    return inside if outside is None else 0.5 * (inside + outside)
