"""The Cramér-Rao bound (predgait.problems.identifiability.cramer_rao) on known answers.

Linear Gaussian model y = J theta + e: the bound is sigma^2 (J^T J)^-1 exactly (white
noise), the leading block of (J^T Sigma^-1 J)^-1 with nuisance columns, and the
generalised least-squares estimator attains it (its Monte Carlo spread equals it) while
ordinary least squares on correlated noise does worse and the white-noise formula
understates it.
"""

import numpy as np
import pytest

from predgait.problems.identifiability import cramer_rao


def _design(n=60, seed=0):
    t = np.linspace(0.0, 1.0, n)
    rng = np.random.default_rng(seed)
    interest = np.column_stack([np.sin(2 * np.pi * t), t ** 2])
    nuisance = np.column_stack([np.ones(n), t]) + 0.01 * rng.normal(size=(n, 2))
    return np.hstack([interest, nuisance])


def _ar1(n, sd, rho):
    lag = np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    return sd ** 2 * rho ** lag


def test_white_noise_gives_sigma2_inverse_normal_matrix():
    jac = _design()
    sigma = 0.3
    expected = sigma ** 2 * np.linalg.inv(jac.T @ jac)
    np.testing.assert_allclose(cramer_rao(jac, np.full(len(jac), sigma ** 2), 4), expected,
                               rtol=1e-10)
    # Nuisance columns are profiled out: the leading block of the full inverse, which is
    # no smaller than the bound with the nuisance parameters known.
    profiled = cramer_rao(jac, sigma ** 2 * np.eye(len(jac)), 2)
    np.testing.assert_allclose(profiled, expected[:2, :2], rtol=1e-10)
    known = sigma ** 2 * np.linalg.inv(jac[:, :2].T @ jac[:, :2])
    assert np.all(np.diag(profiled) >= np.diag(known))


def test_generalised_least_squares_attains_the_bound_on_correlated_noise():
    jac = _design()
    n, reps = len(jac), 4000
    covariance = _ar1(n, 0.2, 0.8)
    bound = np.diag(cramer_rao(jac, covariance, 2))
    rng = np.random.default_rng(1)
    noise = rng.normal(size=(reps, n)) @ np.linalg.cholesky(covariance).T
    inverse = np.linalg.inv(covariance)
    gls = np.linalg.solve(jac.T @ inverse @ jac, jac.T @ inverse @ noise.T)[:2]
    ols = np.linalg.lstsq(jac, noise.T, rcond=None)[0][:2]
    # Variance estimates from 4000 repetitions: relative SE sqrt(2 / 4000) = 2.2 %.
    np.testing.assert_allclose(np.var(gls, axis=1), bound, rtol=0.08)
    assert np.all(np.var(ols, axis=1) > 1.1 * bound)
    white = np.diag(cramer_rao(jac, np.full(n, covariance[0, 0]), 2))
    assert np.all(white < 0.5 * bound)    # white noise of the same variance understates


def test_bad_shapes_and_singular_information_are_refused():
    jac = _design()
    with pytest.raises(ValueError, match="do not agree"):
        cramer_rao(jac, np.ones(len(jac) - 1), 2)
    with pytest.raises(ValueError, match="singular"):
        cramer_rao(np.hstack([jac, jac[:, :1]]), np.ones(len(jac)), 2)


def test_projecting_off_the_nuisance_directions_gives_the_same_bound():
    """The information on theta with the nuisance unknown (Schur complement) equals that
    of the data projected on the complement of the nuisance columns (used by
    benchmarks/study_passive_crlb.py, whose noise is sampled on that complement)."""
    jac = _design()
    covariance = _ar1(len(jac), 0.2, 0.8)
    basis = np.linalg.qr(jac[:, 2:], mode="complete")[0][:, 2:]
    np.testing.assert_allclose(
        cramer_rao(basis.T @ jac[:, :2], basis.T @ covariance @ basis, 2),
        cramer_rao(jac, covariance, 2), rtol=1e-8)
