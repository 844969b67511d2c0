"""Bounded Gauss-Newton for the small passive-element fits (shooting and swing).

The fits (:mod:`predgait.problems.shooting`, :mod:`predgait.problems.passive_swing`)
minimise a weighted sum of squared angle errors plus Gaussian priors on the parameters,

    |sqrt(W) r(z)|^2 + sum_priors ((p - mean) / sd)^2,

over unknowns z scaled to their bounds, z in [0, 1]. Each Gauss-Newton step is the
bounded linear least-squares problem of the linearised residuals
(:func:`predgait.numerics.lsq.bounded_step`), halved until the cost does not rise.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from predgait.numerics.lsq import bounded_step
from predgait.problems.passive_model import PassiveModel


@dataclass(frozen=True, eq=False)
class LeastSquares:
    """A fit's least-squares problem in z: residuals, Jacobian and the priors' rows.

    Attributes:
        model: The passive model (its fitted parameters are the first entries of z).
        compute: z -> (r (n, 2) ankle and knee errors, J (2 n, z.size)), rows of J in the
            order of r raveled column-wise (every ankle row, then every knee row).
    """

    model: PassiveModel
    compute: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    _last: list = field(default_factory=lambda: [None, None], repr=False)  # z, (r, J)

    def evaluate(self, z) -> tuple[np.ndarray, np.ndarray]:
        """(r, J) at z (copies; the last point's values are kept, Gauss-Newton asks twice)."""
        z = np.asarray(z, dtype=float)
        if self._last[0] is None or not np.array_equal(self._last[0], z):
            r, jac = self.compute(z)
            self._last[0], self._last[1] = z.copy(), (np.array(r), np.array(jac))
        r, jac = self._last[1]
        return r.copy(), jac.copy()

    def prior_rows(self, z) -> tuple[np.ndarray, np.ndarray]:
        """The priors' residuals and Jacobian rows over all of z (:func:`prior_rows`)."""
        f = len(self.model.fitted)
        r, jac = prior_rows(self.model, z[:f])
        return r, np.hstack([jac, np.zeros((jac.shape[0], np.size(z) - f))])


def prior_rows(model: PassiveModel, z) -> tuple[np.ndarray, np.ndarray]:
    """Prior residuals ((p - mean) / sd) and their rows of the Jacobian in z."""
    fitted = model.fitted
    rows = [i for i, p in enumerate(fitted) if p.prior is not None]
    r = np.array([(fitted[i].lower + (fitted[i].upper - fitted[i].lower) * z[i]
                   - fitted[i].prior) / fitted[i].prior_sd for i in rows])
    jac = np.zeros((len(rows), len(fitted)))
    for k, i in enumerate(rows):
        jac[k, i] = (fitted[i].upper - fitted[i].lower) / fitted[i].prior_sd
    return r, jac


def weighted_step(jac, r, row_weights, z, prior, *, frozen: int | None = None) -> np.ndarray:
    """Gauss-Newton step dz minimising |sqrt(W)(r + J dz)|^2 + priors, z + dz in [0, 1].

    ``frozen``: index of an unknown held where it is (its step is 0; a profile likelihood).
    """
    root = np.sqrt(row_weights)
    prior_r, prior_j = prior
    a = np.vstack([jac * root[:, None], prior_j])
    free = np.ones(np.size(z), dtype=bool)
    if frozen is not None:
        free[frozen] = False
    step = np.zeros(np.size(z))
    step[free] = bounded_step(a[:, free], np.concatenate([r * root, prior_r]), 0.0,
                              -z[free], 1.0 - z[free])
    return step


def joint_row_weights(weights, inv_var) -> np.ndarray:
    """Row weights of the stacked residual (ankle rows, then knee rows): w / sigma_j^2."""
    return np.concatenate([weights * inv_var[0], weights * inv_var[1]])


def objective(problem: LeastSquares, z, row_weights) -> float:
    """The fit's objective at z: |sqrt(W) r(z)|^2 + priors (-2 log likelihood + const)."""
    r, _ = problem.evaluate(z)
    return _cost(r.ravel(order="F"), row_weights, problem.prior_rows(z))


def _cost(r, row_weights, prior) -> float:
    with np.errstate(over="ignore", invalid="ignore"):   # a diverged trial step: inf, halved
        return float(np.sum(row_weights * r ** 2) + np.sum(prior[0] ** 2))


def gauss_newton(problem: LeastSquares, z, row_weights, max_iter: int, *,
                 frozen: int | None = None) -> tuple[np.ndarray, int, bool]:
    """Bounded Gauss-Newton with step halving: (z, iterations, converged).

    ``problem`` has ``evaluate(z) -> (r (n, 2), J (2 n, f))`` (ankle rows, then knee rows)
    and ``prior_rows(z) -> (r_prior, J_prior)``; z is scaled to [0, 1]. ``frozen``: index
    of an unknown held at its value in ``z``.
    """
    r, jac = problem.evaluate(z)
    r = r.ravel(order="F")
    cost = _cost(r, row_weights, problem.prior_rows(z))
    for iteration in range(1, max_iter + 1):
        step = weighted_step(jac, r, row_weights, z, problem.prior_rows(z), frozen=frozen)
        if np.max(np.abs(step)) < 1e-8:
            return z, iteration, True
        for _ in range(30):
            trial = np.clip(z + step, 0.0, 1.0)
            r_new, jac_new = problem.evaluate(trial)
            r_new = r_new.ravel(order="F")
            cost_new = _cost(r_new, row_weights, problem.prior_rows(trial))
            if cost_new <= cost * (1 + 1e-12):
                break
            step = step / 2
        else:
            return z, iteration, False
        # z is scaled to the bounds: 1e-7 of a bound range is far inside any interval. A
        # relative decrease below 1e-6 of a cost of order its degrees of freedom moves the
        # estimate by well under 1 % of its standard error.
        converged = np.max(np.abs(trial - z)) < 1e-7 or cost - cost_new <= 1e-6 * cost
        z, r, jac, cost = trial, r_new, jac_new, cost_new
        if converged:
            return z, iteration, True
    return z, max_iter, False
