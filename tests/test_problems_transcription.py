"""Collocation pieces: ADAM vs Pinocchio derivatives, order of the transcriptions, bad input.

Known answers: Pinocchio's analytical ABA derivatives (``pin.computeABADerivatives``) for
the ADAM forward dynamics and its CasADi Jacobians; the local truncation error of the
trapezoidal rule (O(h^3) per step) and of Hermite-Simpson (O(h^5) per interval) on a
smooth trajectory integrated finely with Pinocchio.
"""

import functools
from dataclasses import replace

import casadi as cs
import numpy as np
import pinocchio as pin
import pytest

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forward import simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.errors import InputError
from predgait.models.loading import load_model
from predgait.models.symbolic import symbolic_model
from predgait.problems.collocation import LegCollocation, NodeData, Transcription, free_dynamics
from predgait.problems.fitting import fit_knee


@pytest.fixture(scope="module")
def leg():
    return load_model("leg")


def test_adam_forward_dynamics_and_jacobians_equal_pinocchio_aba_derivatives(leg):
    sym = symbolic_model(leg)
    q, v, tau = (cs.SX.sym(n, leg.nq) for n in ("q", "v", "tau"))
    a = sym.forward_dynamics(q, v, tau)
    jacobians = cs.Function("aba_jacobians", [q, v, tau],
                            [a, cs.jacobian(a, q), cs.jacobian(a, v),
                             cs.jacobian(a, tau)])
    data = leg.pin_model.createData()
    rng = np.random.default_rng(6)
    for _ in range(5):
        qn, vn, taun = rng.normal(0, 0.5, leg.nq), rng.normal(0, 1, leg.nq), \
            rng.normal(0, 20, leg.nq)
        acc, da_dq, da_dv, da_dtau = (np.array(m) for m in jacobians(qn, vn, taun))
        pin.computeABADerivatives(leg.pin_model, data, qn, vn, taun)
        np.testing.assert_allclose(acc.ravel(), data.ddq, rtol=1e-8, atol=1e-8)
        # Joint columns (ankle, knee) against Pinocchio's analytical derivatives. For the
        # composite root (PX-PZ-RY) pin 4.1 differentiates in the joint's local frame
        # (translation rates rotating with the pitch), not the plain partial derivative,
        # so every column is also checked against central differences of pin.aba.
        pin.computeABADerivatives(leg.pin_model, data, qn, vn, taun)
        np.testing.assert_allclose(da_dq[:, 3:], data.ddq_dq[:, 3:], rtol=1e-7, atol=1e-7)
        np.testing.assert_allclose(da_dv[:, 3:], data.ddq_dv[:, 3:], rtol=1e-7, atol=1e-7)
        minv = np.triu(data.Minv) + np.triu(data.Minv, 1).T  # Pinocchio fills the upper part
        np.testing.assert_allclose(da_dtau[:, 3:], minv[:, 3:], rtol=1e-7, atol=1e-9)
        for derivative, step in ((da_dq, "q"), (da_dv, "v"), (da_dtau, "tau")):
            np.testing.assert_allclose(derivative, _central(leg, data, qn, vn, taun, step),
                                       rtol=1e-5, atol=1e-5)


def _central(leg, data, q, v, tau, which, eps=1e-6):
    """Central differences of pin.aba with respect to q, v or tau."""
    columns = []
    for e in np.eye(leg.nq) * eps:
        args_plus = {"q": q, "v": v, "tau": tau}
        args_minus = dict(args_plus)
        args_plus[which], args_minus[which] = args_plus[which] + e, args_minus[which] - e
        plus = pin.aba(leg.pin_model, data, args_plus["q"], args_plus["v"], args_plus["tau"])
        minus = pin.aba(leg.pin_model, data, args_minus["q"], args_minus["v"],
                        args_minus["tau"])
        columns.append((plus - minus) / (2 * eps))
    return np.column_stack(columns)


def test_free_dynamics_jacobians_equal_finite_differences(leg):
    f = free_dynamics(leg)
    inputs = f.sx_in()
    out = f(*inputs)
    jac = cs.Function("j", inputs, [cs.jacobian(out, cs.vertcat(*inputs))])
    rng = np.random.default_rng(7)
    args = [np.array([0.1, -0.3, 0.5, -1.0]), np.array([0.2, 0.05, 0.1]),
            rng.normal(0, 0.3, 3), rng.normal(0, 2, 3), np.array([5.0, -20.0]),
            np.array([30.0, -400.0, 10.0])]
    flat = np.concatenate(args)
    sizes = np.cumsum([len(a) for a in args])[:-1]

    def value(z):
        return np.array(f(*np.split(z, sizes))).ravel()

    eps = 1e-6
    numeric = np.column_stack([(value(flat + e) - value(flat - e)) / (2 * eps)
                               for e in np.eye(flat.size) * eps])
    np.testing.assert_allclose(np.array(jac(*args)), numeric, rtol=1e-5, atol=1e-5)


def _smooth_drivers():
    """Foot still, smooth analytic torques and hip load: a C-infinity trajectory."""
    still = LegDrivers.still()

    def torque(t):
        return np.array([4.0 * np.sin(7.0 * t), -6.0 + 5.0 * np.cos(5.0 * t)])

    def hip_force(t):
        return np.array([10.0 * np.sin(3.0 * t), 0.0, -300.0 + 40.0 * np.sin(4.0 * t)])

    return replace(still, joint_torque=torque, hip_force=hip_force)


@functools.lru_cache(maxsize=4)
def _smooth_nodes(leg, n, t1=0.2):
    drivers = _smooth_drivers()
    t = np.linspace(0.0, t1, n + 1)
    x0 = np.array([0.05, -0.1, 0.0, 0.0])
    sim = simulate_leg(leg, drivers, (0.0, t1), x0,
                       options=IntegratorOptions(method=Method.RK4, step=2e-5), t_eval=t)
    assert sim.status == "completed"
    zeros = np.zeros((n + 1, 3))
    hip = np.array([drivers.hip_force(tk) for tk in t])
    return NodeData(t=t, qb=zeros, vb=zeros, ab=zeros,
                    tau=np.array([drivers.joint_torque(tk) for tk in t]),
                    hip=np.column_stack([hip[:, 0], hip[:, 2], np.zeros(n + 1)]),
                    x_ref=np.column_stack([sim.q[:, 3:], sim.v[:, 3:]]))


def _largest_defect(leg, nodes, transcription):
    n = len(nodes.t) - 1
    col = LegCollocation(leg, n, float(nodes.t[1] - nodes.t[0]), 0, transcription)
    defects = cs.Function("defects", [col.w, cs.vec(col.data)], [col.defects(col.xdot(0))])
    value = np.array(defects(nodes.x_ref.ravel(), col.data_values(nodes))).ravel()
    return np.abs(value[:-4]).max()  # the last 4: initial state, exactly zero here


@pytest.mark.parametrize("transcription, order", [(Transcription.TRAPEZOIDAL, 3),
                                                  (Transcription.HERMITE_SIMPSON, 4)],
                         ids=["trapezoidal", "hermite_simpson"])
def test_defects_of_the_exact_motion_shrink_with_the_local_order(leg, transcription, order):
    # Local error per step: trapezoidal O(h^3); Hermite-Simpson O(h^4), set by its
    # midpoint (cubic Hermite interpolation) defect; its Simpson defect is O(h^5).
    coarse = _largest_defect(leg, _smooth_nodes(leg, 40), transcription)
    fine = _largest_defect(leg, _smooth_nodes(leg, 80), transcription)
    ratio = coarse / fine
    assert 2 ** (order - 0.7) < ratio < 2 ** (order + 0.7), ratio


def test_hermite_simpson_needs_an_even_grid_and_bounds_must_hold_the_guess(leg):
    with pytest.raises(InputError, match="even number"):
        LegCollocation(leg, 21, 0.01, 0, Transcription.HERMITE_SIMPSON)
    nodes = _smooth_nodes(leg, 20)
    with pytest.raises(InputError, match="outside its bounds"):
        fit_knee(leg, nodes, k0=50.0, k_max=10.0)
