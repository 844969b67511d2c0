"""3D inverse dynamics: synthesized motion with consistent contact forces gives zero pelvis
residuals; plates go to the foot under their COP; bad plates are refused."""

import numpy as np
import pinocchio as pin
import pytest

from predgait.data.trial import ForcePlate
from predgait.dynamics.inverse3d import (
    assign_plates,
    inverse_dynamics_3d,
    sole_points,
    velocities,
)
from predgait.errors import InputError
from predgait.models.loading3d import load_fullbody


def motion(model, n=40, seed=2):
    rng = np.random.default_rng(seed)
    pm = model.pin_model
    time = np.arange(n) / 100
    amp, phase = rng.uniform(0.05, 0.3, 29), rng.uniform(0, 6, 29)
    qs = []
    for t in time:
        q = model.neutral()
        q[:3] = [0.3 + 1.2 * t, 0.02 * np.sin(6 * t), 0.95 + 0.02 * np.sin(12 * t)]
        q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.03 * np.sin(6 * t), 0.05,
                                                    0.1 * np.sin(6 * t))).coeffs()
        q[7:] = np.clip(amp * np.sin(2 * np.pi * t + phase), pm.lowerPositionLimit[7:],
                        pm.upperPositionLimit[7:])
        qs.append(q)
    qs = np.array(qs)
    v, a = velocities(model, time, qs)
    return time, qs, v, a


def consistent_plates(model, time, q, v, a, right_share):
    """Two plates, one under each foot, carrying exactly the pelvis root wrench."""
    pm, data = model.pin_model, model.pin_model.createData()
    soles = sole_points(model, q)
    n = time.size
    plates = {s: (np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))) for s in "rl"}
    for k in range(n):
        tau = pin.rnea(pm, data, q[k], v[k], a[k])
        pin.forwardKinematics(pm, data, q[k])
        world = data.oMi[1].act(pin.Force(tau[:6]))  # about the lab origin
        for side, share in (("r", right_share[k]), ("l", 1 - right_share[k])):
            force, cop = share * world.linear, soles[side][k]
            plates[side][0][k] = force
            plates[side][1][k] = cop
            plates[side][2][k] = share * world.angular - np.cross(cop, force)
    return [ForcePlate(time, *plates[s], name=f"plate_{s}") for s in "rl"]


def test_consistent_contact_gives_zero_pelvis_residual():
    model = load_fullbody()
    time, q, v, a = motion(model)
    share = np.repeat([1.0, 0.5, 0.0], [14, 12, 14])  # right stance, double, left
    plates = consistent_plates(model, time, q, v, a, share)
    for plate in plates:  # vertical load must be positive to count as contact
        assert (plate.force[:, 2] >= 0).all()
    sides, stances = assign_plates(model, q, plates)
    assert [(s.plate, s.side) for s in stances] == [("plate_r", "r"), ("plate_l", "l")]
    result = inverse_dynamics_3d(model, q, v, a, plates, sides)
    scale = 72.6 * 9.81
    assert np.abs(result.residual_force).max() < 1e-9 * scale
    assert np.abs(result.residual_moment).max() < 1e-9 * scale
    # Joint moments are those of RNEA with the loads (non-trivial: the stance hip).
    hip = result.joint_moments["hip_r_y"]
    assert np.abs(hip).max() > 1.0
    # Without the plates the residual is the whole body's weight (and more).
    bare = inverse_dynamics_3d(model, q, v, a)
    assert np.abs(bare.residual_force[:, 2]).min() > 0.5 * scale


def test_plate_far_from_feet_is_refused():
    model = load_fullbody()
    time, q, v, a = motion(model, n=10)
    plate = ForcePlate(time, np.tile([0, 0, 500.0], (10, 1)), np.tile([3.0, 2.0, 0], (10, 1)),
                       np.zeros((10, 3)), name="2")
    with pytest.raises(InputError, match="plate '2' is loaded from t = 0.000"):
        assign_plates(model, q, [plate])
    with pytest.raises(InputError, match="resample"):
        assign_plates(model, q[:5], [plate])


def test_velocities_of_uniform_motion():
    model = load_fullbody()
    time = np.linspace(0, 0.5, 26)
    q = np.tile(model.neutral(), (26, 1))
    q[:, 0] = 1.3 * time  # walking forward at 1.3 m/s
    q[:, 7 + model.joint_names.index("knee_r_y")] = 0.4 * time**2
    v, a = velocities(model, time, q)
    np.testing.assert_allclose(v[:, 0], 1.3, atol=1e-12)
    knee = 6 + model.joint_names.index("knee_r_y")
    np.testing.assert_allclose(a[2:-2, knee], 0.8, atol=1e-9)
