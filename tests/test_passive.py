"""Passive joint elements: signs and values, range-of-motion stops, numpy == CasADi, parsing."""

import casadi as cs
import numpy as np
import pytest

from predgait.dynamics.passive import (
    ExponentialLimits,
    LinearSpringDamper,
    PassiveJoint,
    parse_passive,
    total_passive,
)
from predgait.errors import InputError

DEG = np.pi / 180.0


def test_linear_spring_damper_thesis_equations():
    # Eqs. 3.3.1-3.3.2 with the thesis' k = 10, c = 20 (Fig. 4.2.9c).
    element = LinearSpringDamper(k=10.0, c=20.0, theta0=0.1)
    assert element.moment(0.1, 0.0) == 0.0
    assert element.moment(0.3, 0.0) == pytest.approx(-2.0)  # restoring toward theta0
    assert element.moment(-0.1, 0.0) == pytest.approx(2.0)
    assert element.moment(0.1, 0.5) == pytest.approx(-10.0)  # opposes the motion
    angles = np.array([0.0, 0.1, 0.2])
    np.testing.assert_allclose(element.moment(angles, -angles),
                               -10 * (angles - 0.1) + 20 * angles)


def test_linear_law_is_the_thesis_law_on_relative_angles():
    # theta = theta_distal - theta_proximal; clinical knee flexion is its negative. Flipping
    # angle, rate, theta0 and moment together leaves the law unchanged.
    element = LinearSpringDamper(k=100.0, c=100.0, theta0=0.05)
    theta_d, theta_p, rate_d, rate_p = 0.4, 0.9, 1.5, -0.5
    thesis = -100 * (theta_d - theta_p - 0.05) - 100 * (rate_d - rate_p)
    assert element.moment(theta_d - theta_p, rate_d - rate_p) == pytest.approx(thesis)
    flipped = LinearSpringDamper(k=100.0, c=100.0, theta0=-0.05)
    assert -flipped.moment(theta_p - theta_d, rate_p - rate_d) == pytest.approx(thesis)


def test_knee_limits_small_mid_range_large_and_restoring_outside():
    knee = ExponentialLimits()
    mid = np.radians(np.linspace(10.0, 100.0, 10))
    assert np.max(np.abs(knee.moment(mid, 0.0))) < 0.01  # N m: no effect in gait range
    hyperextended = knee.moment(-10 * DEG, 0.0)
    assert hyperextended > 20.0  # N m, pushes toward flexion
    assert knee.moment(-5 * DEG, 0.0) > 1.0
    deep = knee.moment(150 * DEG, 0.0)
    assert deep < -20.0  # pushes back toward extension
    # Monotonic: stiffer the further past the stop.
    angles = np.radians(np.linspace(-15, 150, 400))
    assert np.all(np.diff(knee.moment(angles, 0.0)) < 0)


def test_knee_defaults_reproduce_anderson_curve():
    theta = np.radians(np.linspace(-12.0, 145.0, 50))
    anderson = 6.09 * np.exp(-33.94 * (theta + 0.13)) - 11.03 * np.exp(-11.33 * (2.40 - theta))
    np.testing.assert_allclose(ExponentialLimits().moment(theta, 0.0), anderson,
                               rtol=2e-3, atol=1e-6)


def test_limit_parameters_are_moments_at_the_limits():
    stops = ExponentialLimits(lower=-0.5, upper=0.5, k_lower=3.0, b_lower=20.0,
                              k_upper=4.0, b_upper=30.0)
    assert stops.moment(-0.5, 0.0) == pytest.approx(3.0 - 4.0 * np.exp(-30.0))
    assert stops.moment(0.5, 0.0) == pytest.approx(3.0 * np.exp(-20.0) - 4.0)
    assert stops.moment(-0.55, 0.0) == pytest.approx(3.0 * np.exp(1.0), rel=1e-6)


def test_limit_damping_acts_only_past_the_limits():
    stops = ExponentialLimits(c_limit=5.0)
    elastic = ExponentialLimits()
    inside = stops.moment(45 * DEG, 2.0) - elastic.moment(45 * DEG, 2.0)
    assert abs(inside) < 1e-6
    at_limit = stops.moment(0.0, 2.0) - elastic.moment(0.0, 2.0)
    assert at_limit == pytest.approx(-5.0 * 2.0 * 0.5, rel=1e-6)  # half on at the stop
    past = stops.moment(-15 * DEG, -2.0) - elastic.moment(-15 * DEG, -2.0)
    assert past == pytest.approx(10.0, rel=1e-3)  # fully on, opposing the rate


def test_passive_joint_sums_elements():
    linear = LinearSpringDamper(k=10.0, c=20.0)
    limits = ExponentialLimits(c_limit=1.0)
    joint = PassiveJoint((linear, limits))
    angle, rate = np.array([-0.1, 0.3, 1.0]), np.array([0.5, -1.0, 2.0])
    np.testing.assert_allclose(joint.moment(angle, rate),
                               linear.moment(angle, rate) + limits.moment(angle, rate))
    np.testing.assert_array_equal(PassiveJoint().moment(angle, rate), 0.0)
    assert PassiveJoint([linear]).elements == (linear,)
    with pytest.raises(InputError):
        PassiveJoint(("spring",))


def test_total_passive():
    joints = {"knee": PassiveJoint((LinearSpringDamper(k=10.0),)),
              "ankle": PassiveJoint((LinearSpringDamper(c=2.0),))}
    moments = total_passive(joints, {"knee": 0.2, "ankle": 0.0}, {"knee": 0.0, "ankle": 1.0})
    assert moments == {"knee": pytest.approx(-2.0), "ankle": pytest.approx(-2.0)}
    with pytest.raises(InputError, match="'ankle'"):
        total_passive(joints, {"knee": 0.2}, {"knee": 0.0})


@pytest.mark.parametrize("symbol", [cs.SX.sym, cs.MX.sym], ids=["SX", "MX"])
def test_casadi_equals_numpy(symbol):
    joint = PassiveJoint((LinearSpringDamper(k=10.0, c=20.0, theta0=0.1),
                          ExponentialLimits(c_limit=3.0)))
    angle, rate = symbol("angle"), symbol("rate")
    function = cs.Function("passive", [angle, rate], [joint.moment(angle, rate)])
    rng = np.random.default_rng(7)
    angles, rates = rng.uniform(-0.3, 2.6, 50), rng.uniform(-5.0, 5.0, 50)
    symbolic = np.array([float(function(a, r)) for a, r in zip(angles, rates, strict=True)])
    np.testing.assert_allclose(symbolic, joint.moment(angles, rates), rtol=1e-12, atol=1e-12)


def test_casadi_parameters_for_fitting():
    # Fitting problems make k, c (and stop parameters) decision variables.
    k, c, angle = cs.SX.sym("k"), cs.SX.sym("c"), cs.SX.sym("angle")
    joint = PassiveJoint((LinearSpringDamper(k=k, c=c), ExponentialLimits(c_limit=c)))
    function = cs.Function("m", [k, c, angle], [joint.moment(angle, 1.0)])
    numeric = PassiveJoint((LinearSpringDamper(k=10.0, c=2.0), ExponentialLimits(c_limit=2.0)))
    assert float(function(10.0, 2.0, -0.05)) == pytest.approx(numeric.moment(-0.05, 1.0))


def test_parse_passive_builds_elements():
    joint = parse_passive({"k": 10, "c": 20.0, "theta0_deg": 5.0,
                           "limits": {"preset": "knee", "c_limit": 1.0}}, where="passive.knee")
    linear, limits = joint.elements
    assert linear == LinearSpringDamper(k=10.0, c=20.0, theta0=np.radians(5.0))
    assert limits == ExponentialLimits(c_limit=1.0)
    custom = parse_passive({"limits": {"lower_deg": -20, "upper_deg": 30, "k_lower": 1,
                                       "b_lower": 10, "k_upper": 2, "b_upper": 10}},
                           where="passive.ankle")
    assert custom.elements == (ExponentialLimits(np.radians(-20.0), np.radians(30.0),
                                                 1.0, 10.0, 2.0, 10.0),)
    assert parse_passive({}, where="passive.hip").elements == ()


@pytest.mark.parametrize("table, match", [
    ({"kk": 10}, r"passive\.knee\.kk: unknown key"),
    ({"k": "10"}, r"passive\.knee\.k: expected a number"),
    ({"c": True}, r"passive\.knee\.c: expected a number"),
    ({"k": -1.0}, r"passive\.knee\.k = -1"),
    ({"theta0": 0.1, "theta0_deg": 5}, r"passive\.knee: give theta0"),
    ({"limits": {"preset": "elbow"}}, r"passive\.knee\.limits\.preset: 'elbow'"),
    ({"limits": {"preset": "knee", "stiff": 1}}, r"passive\.knee\.limits\.stiff: unknown"),
    ({"limits": {"lower": 0.0, "upper": 1.0}}, r"passive\.knee\.limits\.k_lower: missing"),
    ({"limits": {"preset": "knee", "upper_deg": -5}}, r"passive\.knee\.limits: upper"),
    ({"limits": {"preset": "knee", "b_upper": "x"}}, r"passive\.knee\.limits\.b_upper"),
    ({"limits": 3}, r"passive\.knee\.limits: expected a table"),
])
def test_parse_errors_name_the_key(table, match):
    with pytest.raises(InputError, match=match):
        parse_passive(table, where="passive.knee")
