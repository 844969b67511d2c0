"""The batched leg inverse dynamics equals RNEA with Pinocchio force objects frame by frame."""

import numpy as np
import pinocchio as pin
import pytest

from predgait.dynamics.external import Load, joint_forces
from predgait.dynamics.inverse import LoadHistory, leg_inverse_dynamics
from predgait.models.loading import generate_urdf, load_model, model_from_urdf


def reference_loop(model, q, v, a, loads):
    """Per frame: RNEA with the loads as external forces, hip solve from the base rows, a
    second RNEA with the hip load for the joint forces (the original implementation)."""
    pm = model.pin_model
    data = pm.createData()
    n = len(q)
    tau, hip = np.zeros((n, pm.nv)), np.zeros((n, 3))
    forces = {name: np.zeros((n, 3)) for name in ("ankle", "knee")}
    ankle, knee = pm.getJointId("ankle"), pm.getJointId("knee")
    for k in range(n):
        pin.computeJointJacobians(pm, data, q[k])
        pin.updateFramePlacements(pm, data)
        rhs = pin.rnea(pm, data, q[k], v[k], a[k], joint_forces(model, data, loads[k]))
        jac = pin.getFrameJacobian(pm, data, model.frame_id("hip_center"),
                                   pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[[0, 2, 4], :]
        hip[k] = np.linalg.solve(jac[:, :3].T, rhs[:3])
        tau[k] = rhs - jac.T @ hip[k]
        hip_load = Load("hip_center", np.array([hip[k, 0], 0.0, hip[k, 1]]),
                        moment=np.array([0.0, hip[k, 2], 0.0]))
        pin.rnea(pm, data, q[k], v[k], a[k], joint_forces(model, data, [*loads[k], hip_load]))
        forces["ankle"][k] = -data.oMi[ankle].act(data.f[ankle]).linear
        forces["knee"][k] = -data.oMi[knee].act(data.f[knee]).linear
    return tau, hip, forces


def random_frames(model, n, seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-0.8, 0.8, (n, model.nq))
    v, a = rng.uniform(-3, 3, (n, model.nq)), rng.uniform(-20, 20, (n, model.nq))
    force = np.column_stack([rng.uniform(-150, 150, n), rng.uniform(-20, 20, n),
                             rng.uniform(0, 900, n)])
    cop = np.column_stack([q[:, 0] + rng.uniform(-0.05, 0.2, n), rng.uniform(-0.02, 0.02, n),
                           rng.uniform(-0.01, 0.01, n)])
    free = np.column_stack([np.zeros(n), np.zeros(n), rng.uniform(-5, 5, n)])
    swing = rng.uniform(size=n) < 0.3            # unloaded frames: no load, COP undefined
    force[swing], free[swing], cop[swing] = 0.0, 0.0, np.nan
    return q, v, a, force, cop, free, swing


@pytest.mark.parametrize("kind", ["bundled leg", "custom leg"])
def test_batched_equals_the_per_frame_force_loop(kind):
    model = load_model("leg") if kind == "bundled leg" else model_from_urdf(
        generate_urdf("leg", mass=55.0, height=1.62), source="custom")
    q, v, a, force, cop, free, swing = random_frames(model, 300, seed=7)
    per_frame = [[] if swing[k] else [Load("foot", force[k], point=cop[k], moment=free[k])]
                 for k in range(len(q))]
    tau, hip, forces = reference_loop(model, q, v, a, per_frame)
    for loads in (per_frame, [LoadHistory("foot", force, cop, free)]):
        fast = leg_inverse_dynamics(model, q, v, a, loads)
        assert np.isfinite(fast.tau).all()
        np.testing.assert_allclose(fast.tau, tau, rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.hip_force[:, [0, 2]], hip[:, :2], rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.hip_moment[:, 1], hip[:, 2], rtol=0, atol=1e-9)
        for name in ("ankle", "knee"):
            np.testing.assert_allclose(fast.joint_force[name], forces[name], rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.tau[:, :3], 0.0, atol=1e-9)


def test_loads_above_the_foot_enter_the_joint_forces_of_their_subtree():
    """A push on the shank and two loads on the foot in one frame, against the loop."""
    model = load_model("leg")
    q, v, a, force, cop, free, swing = random_frames(model, 40, seed=3)
    rng = np.random.default_rng(5)
    cop[swing] = rng.uniform(-0.2, 0.2, (swing.sum(), 3))  # a point for the second foot load
    loads = [[Load("foot", force[k], point=cop[k], moment=free[k]),
              Load("foot", rng.uniform(-30, 30, 3), point=cop[k] + [0.1, 0.0, 0.0]),
              Load("ankle_center", rng.uniform(-80, 80, 3), point=rng.uniform(-0.3, 0.3, 3))]
             for k in range(len(q))]
    tau, hip, forces = reference_loop(model, q, v, a, loads)
    fast = leg_inverse_dynamics(model, q, v, a, loads)
    assert np.isfinite(fast.tau).all() and np.isfinite(tau).all()
    np.testing.assert_allclose(fast.tau, tau, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.hip_force[:, [0, 2]], hip[:, :2], rtol=0, atol=1e-9)
    for name in ("ankle", "knee"):
        np.testing.assert_allclose(fast.joint_force[name], forces[name], rtol=0, atol=1e-9)
    # The shank load changes the ankle joint force (it is in the ankle's subtree).
    without = leg_inverse_dynamics(model, q, v, a, [frame[:2] for frame in loads])
    assert np.abs(without.joint_force["ankle"] - fast.joint_force["ankle"]).max() > 1.0
