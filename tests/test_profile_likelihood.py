"""Profile-likelihood intervals of a rest angle: known answers.

A spring's moment M = -k (theta - theta0) is linear in (k, k theta0), so with known noise
the profile-likelihood interval of theta0 is exactly Fieller's interval for the ratio of
two regression coefficients (the likelihood-ratio statistic of a linear constraint in a
linear Gaussian model is its Wald statistic; Fieller 1954, J R Stat Soc B 16:175-185):
{theta0 : (c + theta0 b)^2 <= 3.84 var(c + theta0 b)} for M = b theta + c, b = -k.
"""

import numpy as np
import pytest

from predgait.problems.profile_likelihood import CHI2_95, profile_interval

K_RANGE, THETA_RANGE = (0.0, 40.0), (-0.5, 2.0)   # bounds of the unknowns (z scales them)


class Spring:
    """Residuals (M(theta; k, theta0) - measured) / sigma in the fits' layout."""

    def __init__(self, theta, measured, sigma):
        self.theta, self.measured, self.sigma = theta, measured, sigma

    @staticmethod
    def unscale(z):
        return (K_RANGE[0] + (K_RANGE[1] - K_RANGE[0]) * z[0],
                THETA_RANGE[0] + (THETA_RANGE[1] - THETA_RANGE[0]) * z[1])

    def evaluate(self, z):
        k, theta0 = self.unscale(z)
        r = (-k * (self.theta - theta0) - self.measured) / self.sigma
        jac = np.column_stack([-(self.theta - theta0) * (K_RANGE[1] - K_RANGE[0]),
                               np.full(self.theta.size, k * (THETA_RANGE[1] - THETA_RANGE[0]))])
        rows = np.column_stack([r, np.zeros_like(r)])        # (n, 2): the "ankle" rows only
        return rows, np.vstack([jac / self.sigma, np.zeros_like(jac)])

    def prior_rows(self, z):
        return np.zeros(0), np.zeros((0, np.size(z)))


def _fieller(theta, measured, sigma):
    """theta0 = -c / b of the least-squares line M = b theta + c: estimate and interval."""
    x = np.column_stack([theta, np.ones_like(theta)])
    (b, c), cov = np.linalg.lstsq(x, measured, rcond=None)[0], sigma ** 2 * np.linalg.inv(
        x.T @ x)
    a2 = b * b - CHI2_95 * cov[0, 0]
    a1 = 2 * (b * c - CHI2_95 * cov[0, 1])
    a0 = c * c - CHI2_95 * cov[1, 1]
    roots = np.sort(np.roots([a2, a1, a0]).real)
    return -c / b, -b, roots


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rest_angle_interval_is_fiellers(seed):
    rng = np.random.default_rng(seed)
    theta = np.linspace(0.05, 0.5, 25)      # angles short of the rest angle 0.7 rad
    sigma = 1.5                                           # N m
    measured = -10.0 * (theta - 0.7) + rng.normal(0.0, sigma, theta.size)
    theta0, k, (low, high) = _fieller(theta, measured, sigma)
    problem = Spring(theta, measured, sigma)
    z = np.array([(k - K_RANGE[0]) / (K_RANGE[1] - K_RANGE[0]),
                  (theta0 - THETA_RANGE[0]) / (THETA_RANGE[1] - THETA_RANGE[0])])
    weights = np.ones(2 * theta.size)
    # The Fisher half-width (its symmetric interval) as the first trial distance.
    _, jac = problem.evaluate(z)
    half = 1.96 * np.sqrt(np.linalg.inv(jac.T @ jac)[1, 1])
    z_low, z_high = profile_interval(problem, z, weights, 1, half)
    span = THETA_RANGE[1] - THETA_RANGE[0]
    assert THETA_RANGE[0] + span * z_low == pytest.approx(low, abs=2e-3 * (high - low))
    assert THETA_RANGE[0] + span * z_high == pytest.approx(high, abs=2e-3 * (high - low))
    # Skewed (the rest angle beyond the data): much farther above than below; Fisher's
    # symmetric interval misses that.
    assert (high - theta0) > 1.5 * (theta0 - low)
    assert high - theta0 > 1.2 * half


def test_an_end_beyond_the_bound_is_the_bound():
    theta = np.linspace(0.05, 1.1, 25)
    sigma = 6.0                                           # noisy: wide interval
    measured = -5.0 * theta + np.random.default_rng(1).normal(0.0, sigma, 25)
    theta0, k, (low, _) = _fieller(theta, measured, sigma)
    assert low < THETA_RANGE[0] < theta0                  # Fieller's end is past the bound
    problem = Spring(theta, measured, sigma)
    z = np.array([(k - K_RANGE[0]) / (K_RANGE[1] - K_RANGE[0]),
                  (theta0 - THETA_RANGE[0]) / (THETA_RANGE[1] - THETA_RANGE[0])])
    z_low, _ = profile_interval(problem, z, np.ones(50), 1, 0.05)
    assert z_low == 0.0
