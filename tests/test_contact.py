"""Contact models: force-penetration curves equal their formulas, zero out of contact,
continuous at contact, numpy and CasADi give the same numbers."""

import casadi as cs
import numpy as np
import pytest

from predgait.dynamics.contact import (
    HuntCrossleyContact,
    ImpactContact,
    MeglanContact,
    adams_step,
    softplus,
)

DEPTH = np.linspace(1e-4, 0.02, 50)


def test_impact_equals_thesis_formula():
    # Thesis 2.3.1: F(x, v) = k x + c (x/d)^2 [3 - 2 x/d] v for x < d, k x + c v beyond.
    model = ImpactContact(stiffness=3e5, exponent=1.0, damping=1500.0, damping_depth=0.01)
    for rate in (0.0, 0.3, -0.05):
        normal, tangential = model.force(DEPTH, rate, 0.0)
        ratio = np.minimum(DEPTH / 0.01, 1.0)
        expected = 3e5 * DEPTH + 1500.0 * ratio**2 * (3 - 2 * ratio) * rate
        np.testing.assert_allclose(normal, np.maximum(expected, 0.0), rtol=1e-12)
        np.testing.assert_array_equal(tangential, 0.0)
    # Exponent e (ADAMS IMPACT k d^e), e.g. the NIH foot's e = 4.
    normal, _ = ImpactContact(stiffness=4.6e10, exponent=4.0, damping=0.0).force(DEPTH, 0.0)
    np.testing.assert_allclose(normal, 4.6e10 * DEPTH**4, rtol=1e-12)


def test_adams_step_is_the_cubic():
    x = np.array([-1.0, 0.0, 0.25, 0.5, 1.0, 2.0])
    np.testing.assert_allclose(adams_step(x, 0.0, 2.0, 1.0, 6.0),
                               [2, 2, 2 + 4 * 0.0625 * 2.5, 4, 6, 6])


def test_meglan_equals_formula():
    model = MeglanContact()
    normal, _ = model.force(DEPTH, 0.2)
    np.testing.assert_allclose(normal, 4.658e10 * DEPTH**4 + 9.719e10 * DEPTH**4 * 0.2,
                               rtol=1e-12)
    # 1 cm static: 465.8 N (the thesis' NIH-foot k = 460 N/cm^4 approximates it).
    assert model.force(0.01, 0.0)[0] == pytest.approx(465.8)


def test_hunt_crossley_equals_formula_in_contact():
    model = HuntCrossleyContact(stiffness=2e7, exponent=1.5, dissipation=0.8, friction=0.7,
                                slip_velocity_scale=0.02)
    depth = DEPTH[DEPTH > 2e-3]
    for rate, slip in ((0.0, 0.0), (0.2, 0.5), (-0.3, -0.1)):
        normal, tangential = model.force(depth, rate, slip)
        expected = 2e7 * depth**1.5 * (1 + 1.5 * 0.8 * rate)
        np.testing.assert_allclose(normal, expected, rtol=1e-6)
        np.testing.assert_allclose(tangential, -0.7 * expected * np.tanh(slip / 0.02),
                                   rtol=1e-6)


@pytest.mark.parametrize("model", [ImpactContact(friction=0.5), MeglanContact(friction=0.5)])
def test_zero_out_of_contact_and_continuous(model):
    above = -np.linspace(1e-6, 0.05, 20)
    for rate in (-1.0, 0.0, 1.0):
        normal, tangential = model.force(above, rate, 0.3)
        np.testing.assert_array_equal(normal, 0.0)
        np.testing.assert_array_equal(tangential, 0.0)
        # Continuous at contact even when hitting the ground at 1 m/s.
        assert model.force(1e-9, rate, 0.3)[0] < 1e-3
    assert model.force(0.005, 0.0, 1.0)[1] == pytest.approx(-0.5 * model.force(0.005, 0)[0])


def test_hunt_crossley_smooth_tail():
    model = HuntCrossleyContact()
    normal, _ = model.force(-10 * model.smoothing, 0.5, 0.0)
    assert 0 < normal < 1e-3 * model.force(1e-3, 0.0)[0]
    assert softplus(np.array([-800.0, 0.0, 800.0]), 1.0) == pytest.approx([0, np.log(2), 800])


def test_casadi_matches_numpy():
    d, r, s = cs.SX.sym("d"), cs.SX.sym("r"), cs.SX.sym("s")
    for model in (ImpactContact(friction=0.4), MeglanContact(friction=0.4),
                  HuntCrossleyContact()):
        fn = cs.Function("f", [d, r, s], list(model.force(d, r, s)))
        for point in ((0.004, 0.1, 0.02), (0.02, -0.2, -0.5), (-0.01, 0.3, 0.1)):
            got = [float(x) for x in fn(*point)]
            want = [float(x) for x in model.force(*(np.float64(p) for p in point))]
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    # Hunt-Crossley is differentiable at contact (gradient exists and is finite).
    hc = HuntCrossleyContact()
    grad = cs.Function("g", [d, r, s], [cs.gradient(hc.force(d, r, s)[0], d)])
    assert np.isfinite(float(grad(0.0, 0.0, 0.0)))


@pytest.mark.parametrize("law", [
    ImpactContact(stiffness=2e5, damping=2e3, damping_depth=1e-3, friction=0.8,
                  slip_transition=0.3),
    MeglanContact(friction=0.6, slip_transition=0.05),
    HuntCrossleyContact()])
@pytest.mark.parametrize("planar", [False, True])
def test_ground_contact_all_points_at_once_equals_point_by_point(law, planar):
    """GroundContact calls the law once for every frame and slip axis (arrays); the same
    law called per point and per axis with scalars gives the same forces."""
    import pinocchio as pin

    from predgait.dynamics.forces import LWA, GroundContact
    from predgait.models.loading3d import load_fullbody

    model = load_fullbody()
    pm, data = model.pin_model, model.pin_model.createData()
    frames = ("heel_contact_r", "toe_contact_r", "heel_contact_l", "toe_contact_l")
    ground = GroundContact(model, frames, law, ground_z=0.0, planar=planar,
                           belt_velocity=0.4)
    rng = np.random.default_rng(5)
    checked = set()
    for _ in range(40):
        q = model.neutral()
        q[7:] = rng.uniform(-0.3, 0.3, model.nv - 6)
        v = rng.uniform(-0.8, 0.8, model.nv)
        pin.framesForwardKinematics(pm, data, q)
        # Sink the lowest point 0..8 mm: points in contact, just above and far above.
        q[2] -= min(data.oMf[model.frame_id(f)].translation[2] for f in frames) + \
            rng.uniform(0.0, 0.008)
        pin.forwardKinematics(pm, data, q, v)
        pin.updateFramePlacements(pm, data)
        expected = np.zeros((4, 3))
        for i, name in enumerate(frames):
            fid = model.frame_id(name)
            z = data.oMf[fid].translation[2]
            vel = pin.getFrameVelocity(pm, data, fid, LWA).linear
            if z > 0.05:
                checked.add("far")
                continue
            checked.add("in" if z < 0 else "above")
            normal, tx = law.force(-z, -vel[2], vel[0] - 0.4)
            expected[i] = float(tx), 0.0 if planar else float(law.force(-z, -vel[2],
                                                                          vel[1])[1]), normal
        np.testing.assert_allclose(ground.forces(data), expected, rtol=1e-13, atol=1e-300)
    assert checked == {"in", "above", "far"}
