"""The NumPy not-a-knot spline equals SciPy's default CubicSpline (the drivers' interpolant)."""

import numpy as np
import pytest
from scipy.interpolate import CubicSpline as ScipySpline

from predgait.dynamics.drivers import SampledHistory
from predgait.numerics.spline import CubicSpline


@pytest.mark.parametrize("n", [3, 4, 5, 12, 400])
def test_spline_equals_scipy_not_a_knot(n):
    rng = np.random.default_rng(n)
    x = np.cumsum(rng.uniform(0.2, 2.0, n))  # uneven knots
    y = rng.normal(size=(n, 4))
    ours, scipy = CubicSpline(x, y), ScipySpline(x, y, axis=0)
    times = np.concatenate([x, rng.uniform(x[0], x[-1], 200)])
    for t in times:
        assert np.allclose(ours(t), scipy(t), rtol=0, atol=1e-12)
        for order in (1, 2):
            assert np.allclose(ours.derivative(order)(t), scipy.derivative(order)(t),
                               rtol=0, atol=1e-10)


def test_spline_reproduces_a_cubic_exactly():
    x = np.array([0.0, 0.3, 0.5, 1.1, 1.4, 2.0])
    cubic = np.column_stack([2 * x**3 - x**2 + 0.5 * x - 1, -x**3 + 4 * x])
    spline = CubicSpline(x, cubic)  # not-a-knot ends reproduce any cubic
    for t in np.linspace(0.0, 2.0, 37):
        assert np.allclose(spline(t), [2 * t**3 - t**2 + 0.5 * t - 1, -t**3 + 4 * t],
                           rtol=0, atol=1e-12)
        assert np.allclose(spline.derivative(1)(t), [6 * t**2 - 2 * t + 0.5, -3 * t**2 + 4],
                           rtol=0, atol=1e-10)


def test_sampled_history_holds_end_values_outside_its_range():
    time = np.linspace(0.0, 1.0, 11)
    history = SampledHistory(time, np.column_stack([np.sin(time), time**2]))
    assert np.allclose(history(-0.5), [0.0, 0.0])
    assert np.allclose(history(1.5), [np.sin(1.0), 1.0])
    assert np.allclose(history.derivative(1)(2.0), 0.0)
