"""Solvers of the whole-body tracking (issue 27 item 5): FATROP on the NLP's stage form,
Ipopt's start on eigen-clipped node Hessians.

Known answers: at a point whose copies agree and whose velocities follow the trapezoidal
rule, the stage form's objective equals the node-major NLP's and its constraints are the
same numbers (node rows, pelvis collocation, and the joint and velocity collocation as
x_{k+1} - F(x_k, u_k)); its assembled
derivatives equal CasADi's automatic ones; and FATROP reaches Ipopt's optimum (objective,
joint torques) on the engine-simulated standing sway, as does Ipopt started on the
clipped Hessian (positive semi-definite blocks, equal to the input where it already is).
"""

import casadi as cs
import numpy as np
import pytest

from predgait.models.loading3d import load_fullbody
from predgait.problems import fullbody_tracking_fatrop as ft
from predgait.problems.fullbody_tracking import (
    CLIP_MARGIN,
    EigenClip,
    TrackingData,
    solve_tracking,
    tracking_nlp,
)
from predgait.problems.fullbody_tracking_stage import NI
from random_tracking import random_tracking_data


def _random_problem(n=4):
    model = load_fullbody()
    data, rng = random_tracking_data(model, n)
    problem = tracking_nlp(model, data)
    nlp, options, bounds = ft.fatrop_nlp(model, problem, data, problem.weights,
                                         problem.params, *problem.smoothing)
    return model, data, problem, nlp, options, bounds, rng


def test_stage_form_is_the_same_problem():
    _, data, problem, nlp, _, bounds, rng = _random_problem()
    n, lay = data.nodes, ft.StageLayout(len(data.points))
    z = (problem.x0 + rng.normal(0, 0.05, problem.x0.size)).reshape(n, -1)
    h = 1 / 60.0
    for k in range(n - 1):  # the velocity collocation holds (the pelvis rows use F's v)
        z[k + 1, 35:70] = z[k, 35:70] + h / 2 * (z[k, 70:105] + z[k + 1, 70:105])
    z = z.ravel()
    y = ft.to_stage_vector(z.reshape(n, -1), lay)
    np.testing.assert_array_equal(ft.from_stage_vector(y, n, lay).ravel(), z)
    original = cs.Function("o", [problem.nlp["x"]], [problem.nlp["f"], problem.nlp["g"]])
    staged = cs.Function("s", [nlp["x"]], [nlp["f"], nlp["g"]])
    (f0, g0), (f1, g1) = original(z), staged(y)
    assert float(f1) == pytest.approx(float(f0), rel=1e-12)
    g0, g1 = np.asarray(g0).ravel(), np.asarray(g1).ravel()
    ng = lay.ng - 6
    nodes0 = g0[:ng * n].reshape(n, ng)
    intervals0 = g0[ng * n:].reshape(n - 1, NI)
    rows = lay.nx + lay.ng
    for k in range(n - 1):
        stage = g1[k * rows:(k + 1) * rows]
        dyn, path = stage[:lay.nx], stage[lay.nx:]
        np.testing.assert_allclose(path[:ng], nodes0[k], atol=1e-10)
        np.testing.assert_allclose(path[ng:], intervals0[k, 64:], atol=1e-10)
        # x_{k+1} - F: the pose copy, joints, velocities, a and force copies.
        np.testing.assert_allclose(dyn[6:35], intervals0[k, :29], atol=1e-10)
        np.testing.assert_allclose(dyn[35:70], intervals0[k, 29:64], atol=1e-10)
        np.testing.assert_allclose(np.r_[dyn[:6], dyn[70:]], 0.0, atol=1e-12)
    np.testing.assert_allclose(g1[(n - 1) * rows:], nodes0[-1], atol=1e-10)
    assert bounds["lbg"].size == g1.size and bounds["x0"].size == y.size


def test_stage_form_derivatives_equal_automatic_differentiation():
    _, _, _, nlp, options, bounds, rng = _random_problem()
    y, f, g = nlp["x"], nlp["f"], nlp["g"]
    sigma, lam = cs.MX.sym("sigma"), cs.MX.sym("lam", g.size1())
    lag = sigma * f + cs.dot(lam, g)
    auto = cs.Function("auto", [y, sigma, lam], [cs.jacobian(g, y), cs.gradient(f, y),
                                                 cs.gradient(lag, y), cs.hessian(lag, y)[0]])
    point = bounds["x0"] + rng.normal(0, 0.05, bounds["x0"].size)
    weights = rng.normal(size=g.size1())
    jac, grad, grad_lag, hess = (np.asarray(cs.densify(m)) for m in auto(point, 0.7, weights))
    cache = options["cache"]
    np.testing.assert_allclose(cs.densify(cache["nlp_jac_g"](point, [])[1]), jac, atol=1e-9,
                               rtol=1e-9)
    np.testing.assert_allclose(np.asarray(cache["nlp_grad_f"](point, [])).ravel(),
                               grad.ravel(), atol=1e-9, rtol=1e-9)
    out_grad, out_hess = cache["nlp_hess_l"](point, [], 0.7, weights)
    np.testing.assert_allclose(np.asarray(out_grad).ravel(), grad_lag.ravel(), atol=1e-8,
                               rtol=1e-9)
    np.testing.assert_allclose(cs.densify(out_hess), hess, atol=1e-7, rtol=1e-9)


def test_solvers_reach_the_exact_hessians_optimum_on_the_sway():
    from test_fullbody_tracking import CONTACT, feet_data, standing_sway

    model, t, q, v, a, _, forces = standing_sway()
    force, cop, free = feet_data(model, q, forces)
    data = TrackingData(t, q, v, a, np.ones((t.size, 4), bool), force, cop, free,
                        ground_z=0.0, stiffness=CONTACT.stiffness, friction=CONTACT.friction,
                        slip_transition=CONTACT.slip_transition)
    exact = solve_tracking(model, data)
    for other in (solve_tracking(model, data, convex_iterations=9),
                  solve_tracking(model, data, solver="fatrop")):
        assert other.objective == pytest.approx(exact.objective, rel=1e-6)
        assert np.abs(other.tau[:, 6:] - exact.tau[:, 6:]).max() < 1e-2
        assert np.abs(other.tau[:, :6]).max() < 1e-6


def test_eigen_clip():
    rng = np.random.default_rng(5)
    nz, n = 6, 3
    blocks = [rng.normal(size=(nz, nz)) for _ in range(n)]
    blocks = [b + b.T for b in blocks[:2]] + [blocks[2] @ blocks[2].T + np.eye(nz)]
    upper = cs.DM(np.hstack([np.triu(b) for b in blocks]))
    clip = EigenClip(cs.Sparsity.dense(nz, nz * n), nz, n)
    out = np.asarray(clip(upper)).reshape(nz, n, nz)
    for k, b in enumerate(blocks):
        got = out[:, k]
        np.testing.assert_allclose(got, got.T, atol=1e-12)
        assert np.linalg.eigvalsh(got).min() >= CLIP_MARGIN - 1e-9
        values, vectors = np.linalg.eigh(b)
        np.testing.assert_allclose(got, (vectors * np.maximum(values, CLIP_MARGIN)) @ vectors.T,
                                   atol=1e-10)
    np.testing.assert_allclose(out[:, 2], blocks[2], atol=1e-10)  # already definite
