"""Brent's root finder equals scipy.optimize.brentq (same iterates, same root)."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq as scipy_brentq

from predgait.dynamics.roots import brentq

FUNCTIONS = [
    lambda x: x**3 - 2 * x - 5,                 # Newton's classic: root 2.0945514815...
    lambda x: math.cos(x) - x,
    lambda x: math.exp(x) - 10.0,
    lambda x: (x - 0.3) ** 5,                   # flat root: many bisections
    lambda x: math.atan(50 * (x - 0.123)),
    lambda x: 1e-9 * (x - 0.7),                 # tiny values
]


@pytest.mark.parametrize("k", range(len(FUNCTIONS)))
def test_brentq_equals_scipy(k):
    f = FUNCTIONS[k]
    rng = np.random.default_rng(k)
    for _ in range(20):
        a, b = -0.5 + rng.uniform(-1.0, 0.2), 3.0 + rng.uniform(0.0, 2.0)
        if f(a) * f(b) > 0:
            continue
        for xtol in (1e-14, 2e-12, 1e-6):
            assert _outcome(brentq, f, a, b, xtol) == _outcome(scipy_brentq, f, a, b, xtol)


def _outcome(solver, f, a, b, xtol):
    """The root, or "no convergence" (both give up on the flat root at xtol 1e-14)."""
    try:
        return solver(f, a, b, xtol=xtol, rtol=4 * np.finfo(float).eps)
    except RuntimeError:
        return "no convergence"


def test_brentq_known_root_and_bad_bracket():
    assert brentq(lambda x: x * x - 2.0, 0.0, 2.0, xtol=1e-15) == pytest.approx(math.sqrt(2),
                                                                             abs=1e-14)
    with pytest.raises(ValueError):
        brentq(lambda x: x * x + 1.0, -1.0, 1.0)
