"""Smoothing terms of the whole-body tracking cost (issue 27).

Known answers: the linearised joint torque equals Pinocchio's RNEA - J^T f at the
reference and predicts it at a nearby point to second order; the acceleration-change term
charges the trapezoidal rule's period-2h mode (which changes no state) exactly
(2A / scale)^2 per interval and nothing for the measured accelerations; a heel that lifts
off while its toe stays down may carry only a fading share of the weight before it goes.
"""

import numpy as np
import pytest

from predgait.models.loading3d import load_fullbody
from predgait.problems.fullbody_tracking import (
    POINTS,
    TrackingData,
    contact_inverse_dynamics,
    corrected_configuration,
)
from predgait.problems.fullbody_tracking_smooth import (
    fade_limits,
    smoothing_terms,
    torque_linearisation,
)


@pytest.fixture(scope="module")
def model():
    return load_fullbody()


def _state(model, rng):
    q = model.neutral()
    q[7:] += rng.uniform(-0.4, 0.4, 29)
    q[3:7] = rng.normal(size=4)
    q[3:7] /= np.linalg.norm(q[3:7])
    return q, rng.normal(size=35), rng.normal(0, 5, 35), rng.normal(0, 200, (4, 3))


def test_torque_linearisation_is_first_order_exact(model):
    rng = np.random.default_rng(5)
    q, v, a, f = _state(model, rng)
    tau, jac = torque_linearisation(model, q, v, a, f, POINTS)
    np.testing.assert_allclose(tau, contact_inverse_dynamics(model, q[None], v[None],
                                                             a[None], f[None])[0, 6:])
    # Each block alone (configuration, velocity, acceleration, force).
    for block, scale in ((slice(0, 35), 1e-3), (slice(35, 70), 1e-3),
                         (slice(70, 105), 1e-3), (slice(105, 117), 1.0)):
        dz = np.zeros(117)
        dz[block] = scale * rng.normal(size=dz[block].size)
        moved = contact_inverse_dynamics(
            model, corrected_configuration(q, dz[:35])[None], (v + dz[35:70])[None],
            (a + dz[70:105])[None], (f + dz[105:].reshape(4, 3))[None])[0, 6:]
        first = jac @ dz
        assert np.linalg.norm(first) > 1e-4                  # the block moves the torques
        # Remainder O(scale^2): a wrong column (sign, frame, block) leaves O(scale).
        assert np.linalg.norm(moved - tau - first) < 1e-2 * np.linalg.norm(first), block


def _sway_like(model, n=6):
    q = np.tile(model.neutral(), (n, 1))
    t = np.arange(n) / 60.0
    a = np.tile(np.linspace(0, 1, 35), (n, 1)) * (1 + t[:, None])
    return TrackingData(t, q, np.zeros((n, 35)), a, np.ones((n, 4), bool),
                        np.zeros((n, 2, 3)), np.zeros((n, 2, 3)), np.zeros((n, 2)), 0.0)


def test_acceleration_change_charges_the_alternating_mode(model):
    data = _sway_like(model)
    n, nz = data.nodes, 117
    x = np.hstack([np.zeros((n, 35)), data.v, data.a, np.zeros((n, 12))])
    matrix, rhs = smoothing_terms(model, data, x.ravel(), nz, 100.0, 10.0, 20.0, 70.0)

    def cost(z):
        r = np.asarray(matrix @ z.ravel()).ravel() - rhs
        return float(r @ r)

    assert cost(x) == pytest.approx(0.0, abs=1e-12)     # measured accelerations: free
    wiggle = x.copy()
    wiggle[:, 70:105] += 3.0 * (-1.0) ** np.arange(n)[:, None]
    # mean over the n - 1 intervals of sum over 35 rows of (2 * 3 / 20)^2
    assert cost(wiggle) == pytest.approx(35 * (6.0 / 20.0) ** 2, rel=1e-9)
    ramp = x.copy()                                      # a steady loading: free
    ramp[:, 107] += np.arange(n) * 0.5
    assert cost(ramp) == pytest.approx(0.0, abs=1e-12)


def test_a_heel_that_lifts_off_under_a_loaded_toe_fades(model):
    n = 14
    contact = np.zeros((n, 4), bool)
    contact[0:10, 0] = True      # right heel until node 9
    contact[4:14, 1] = True      # right toe from node 4: the foot stays down
    contact[2:8, 2:4] = True     # left foot lands and lifts off whole
    data = TrackingData(np.arange(n) / 60.0, np.tile(model.neutral(), (n, 1)),
                        np.zeros((n, 35)), np.zeros((n, 35)), contact, np.zeros((n, 2, 3)),
                        np.zeros((n, 2, 3)), np.zeros((n, 2)), 0.0, fade_nodes=3)
    limits = fade_limits(data, 700.0) / (1.5 * 700.0)
    np.testing.assert_allclose(limits[7:10, 0], [0.75, 0.5, 0.25])   # heel-off
    np.testing.assert_allclose(limits[4:7, 1], [0.25, 0.5, 0.75])    # toe landing
    assert np.isinf(limits[:7, 0]).all() and np.isinf(limits[7:, 1]).all()
    assert np.isinf(limits[:, 2:]).all()                             # whole-foot switches
