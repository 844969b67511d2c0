"""The batched bounded Gauss-Newton (all frames iterated together) against the frame-by-frame
solver it replaces in the planar IK: same fits, same flags, including frames held on a limit."""

import numpy as np
import pinocchio as pin
import pytest

from predgait.kinematics.bounded_ik import BoundedSolver, SolverOptions
from predgait.kinematics.planar_ik import POINTS, joint_limits, solve_ik
from predgait.models.loading import load_model


def noisy_leg_points(model, q, noise, seed=0):
    """Joint centres of the leg at q (n, 5), lab frame, plus Gaussian noise (m)."""
    pm, data = model.pin_model, model.pin_model.createData()
    rng = np.random.default_rng(seed)
    out = {name: np.zeros((len(q), 3)) for name in POINTS}
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(pm, data, qk)
        for name in out:
            out[name][k] = data.oMf[model.frame_id(name)].translation
    return {name: xyz + rng.normal(0.0, noise, xyz.shape) for name, xyz in out.items()}


def sequential_fit(model, points, pitch):
    """Each frame by BoundedSolver.solve, warm-started from the previous frame."""
    pm, data = model.pin_model, model.pin_model.createData()
    lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    ids = [model.frame_id(n) for n in POINTS]
    frame = {}

    def jacobian(q):
        pin.computeJointJacobians(pm, data, q)
        pin.updateFramePlacements(pm, data)
        rows = [data.oMf[f].translation[[0, 2]] - frame["t"][i] for i, f in enumerate(ids)]
        jac = [pin.getFrameJacobian(pm, data, f, lwa)[[0, 2]] for f in ids]
        pitch_row = np.zeros((1, pm.nv))
        pitch_row[0, 2] = 0.1
        return (np.concatenate([*rows, [0.1 * (q[2] - frame["pitch"])]]),
                np.vstack([*jac, pitch_row]))

    solver = BoundedSolver(pm, *joint_limits(model),
                           SolverOptions(max_iterations=30, tolerance=1e-10,
                                         cost_tolerance=0.0, damping=0.0))
    q = solver.project(np.zeros(pm.nq))
    fits = []
    for k in range(len(pitch)):
        frame["t"] = [points[n][k, [0, 2]] for n in POINTS]
        frame["pitch"] = pitch[k]
        fit = solver.solve(q, lambda x: jacobian(x)[0], jacobian)
        q = fit.q
        fits.append(fit)
    return fits


@pytest.mark.parametrize("noise", [0.0, 0.004])
def test_batched_ik_equals_the_frame_by_frame_solver(noise):
    model = load_model("leg")
    n = 50
    q = np.zeros((n, 5))
    q[:, 0] = np.linspace(0.0, 0.6, n)
    q[:, 1] = 0.02
    q[:, 2] = 0.2 * np.sin(np.linspace(0, 3, n))
    q[:, 3] = 0.15 * np.cos(np.linspace(0, 4, n))
    q[:, 4] = np.radians(np.linspace(-60, 30, n))  # the last frames push past the knee limit
    points = noisy_leg_points(model, q, noise)
    batched = solve_ik(model, points, q[:, 2])
    reference = sequential_fit(model, points, q[:, 2])
    np.testing.assert_allclose(batched.q, [f.q for f in reference], atol=1e-9)
    np.testing.assert_array_equal(batched.flagged,
                                  [not f.converged or f.at_limit.any() for f in reference])
    assert batched.flagged.any() and not batched.flagged.all()
    assert batched.converged.all()


def test_solve_frames_refuses_damping():
    model = load_model("leg")
    solver = BoundedSolver(model.pin_model, *joint_limits(model), SolverOptions(damping=1e-4))
    with pytest.raises(ValueError, match="damping"):
        solver.solve_frames(np.zeros((1, 5)), lambda k, q: (np.zeros(1), np.zeros((1, 5))))
