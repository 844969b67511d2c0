"""Contributions (thesis Fig. 4.2.12), linear stability and deviation measures."""

from __future__ import annotations

import numpy as np
import pytest

from predgait.analysis.contributions import PARTS, contributions
from predgait.analysis.deviation import deviation
from predgait.analysis.stability import linearize
from predgait.dynamics.drivers import LegDrivers, constant
from predgait.dynamics.forward import LegSystem, simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.passive import ExponentialLimits, LinearSpringDamper, PassiveJoint
from predgait.models.loading import load_model

LEG = load_model("leg")


def moving_drivers(rng):
    return LegDrivers(prescribed_q=constant(rng.normal(0, 0.2, 3)),
                      prescribed_qd=constant(rng.normal(0, 1, 3)),
                      prescribed_qdd=constant(rng.normal(0, 3, 3)),
                      joint_torque=constant(rng.normal(0, 30, 2)),
                      hip_force=constant([30.0, 0.0, -400.0]),
                      hip_moment=constant([0.0, 15.0, 0.0]))


def test_contributions_sum_to_total():
    rng = np.random.default_rng(1)
    passive = {"knee": PassiveJoint((LinearSpringDamper(10, 20), ExponentialLimits())),
               "ankle": PassiveJoint((LinearSpringDamper(100, 5),))}
    system = LegSystem(LEG, moving_drivers(rng).with_passive(passive))
    for _ in range(4):
        x = np.concatenate([rng.normal(0, 0.4, 2), rng.normal(0, 2, 2)])
        parts = contributions(system, 0.0, x)
        total = sum(parts[p] for p in PARTS)
        np.testing.assert_allclose(total, parts["total"], rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(parts["total"], system(0.0, x)[2:], rtol=1e-12)
        assert all(np.any(parts[p] != 0) for p in PARTS)


def test_still_leg_at_rest_only_gravity_acts():
    system = LegSystem(LEG, LegDrivers.still())
    parts = contributions(system, 0.0, np.array([0.1, -0.2, 0.0, 0.0]))
    np.testing.assert_allclose(parts["gravity"], parts["total"], atol=1e-12)
    for p in ("velocity", "passive", "applied", "hip", "base"):
        np.testing.assert_allclose(parts[p], 0.0, atol=1e-12)


@pytest.mark.parametrize("with_passive", [False, True])
def test_linearization_matches_finite_differences(with_passive):
    rng = np.random.default_rng(2)
    passive = ({"knee": PassiveJoint((LinearSpringDamper(100, 100), ExponentialLimits())),
                "hip": PassiveJoint((LinearSpringDamper(50, 5),))} if with_passive else None)
    system = LegSystem(LEG, moving_drivers(rng).with_passive(passive))
    x = np.array([0.2, -0.3, 0.5, -1.0])
    lin = linearize(system, 0.0, x)
    eps = 1e-6
    fd = np.column_stack([(system(0.0, x + e) - system(0.0, x - e)) / (2 * eps)
                          for e in np.eye(4) * eps])
    np.testing.assert_allclose(lin.A, fd, rtol=1e-5, atol=1e-4)


def test_upright_leg_is_unstable_and_springs_stabilise_it():
    x = np.radians([5.0, -10.0, 0.0, 0.0])
    free = linearize(LegSystem(LEG, LegDrivers.still()), 0.0, x)
    assert free.unstable.size >= 1 and free.e_folding_time < 0.2
    stiff = {n: PassiveJoint((LinearSpringDamper(2000, 50),)) for n in ("ankle", "knee")}
    held = linearize(LegSystem(LEG, LegDrivers.still(passive=stiff)), 0.0, x)
    assert held.unstable.size == 0


def test_deviation_rms_and_threshold_time():
    x0 = np.radians([5.0, -10.0, 0.0, 0.0])
    sim = simulate_leg(LEG, LegDrivers.still(), (0.0, 0.3), x0,
                       options=IntegratorOptions(method=Method.RK4, step=1e-3))
    same = deviation(sim, sim.t, sim.q, threshold_deg=5.0)
    assert all(v == 0.0 for v in same.rms.values()) and same.time_to_threshold is None
    ref = sim.q.copy()
    ref[:, 4] = ref[0, 4]  # a knee that never moved
    dev = deviation(sim, sim.t, ref, threshold_deg=5.0)
    k = np.argmax(np.abs(sim.q[:, 4] - ref[0, 4]) > np.radians(5))
    assert dev.time_to_threshold == pytest.approx(sim.t[k])
    assert dev.coordinate_at_threshold == "knee"
    assert dev.rms["knee"] == pytest.approx(np.sqrt(np.mean((sim.q[:, 4] - ref[0, 4]) ** 2)))
