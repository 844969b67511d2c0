"""Exact derivatives of the muscle gait NLP, assembled node by node by the chain rule.

The objective f and constraints g of :class:`~predgait.problems.muscle_gait.MuscleGaitProblem`
depend on the decision vector w directly (defects, periodicity, effort) and through the
node dynamics Y_k = N(z_k) (:func:`~predgait.problems.muscle_gait_dynamics.node_function`)
at each grid point, whose inputs z_k = D_k w are linear in w. CasADi's exact Hessian of
the whole inlined SX graph re-derives the node at every grid point: ~20 s CPU to build at
50 intervals, most of a scenario's time. Here the node's Jacobian and the Hessian of
mu^T N are derived once (~0.5 s) and mapped over the grid points, and the chain rule joins
them with the derivatives of the outer expressions O(w, Y) (cheap, sparse):

    grad f = f_w + (J D)^T f_Y,        jac g = g_w + g_Y J D,
    hess L = O_ww + O_wY J D + (O_wY J D)^T + (J D)^T O_YY J D + D^T diag_k(H_k) D,

with L = lam_f f + lam_g^T g = O(w, Y(w)), J = diag_k(dN/dz (z_k)), mu_k = dO/dY_k and
H_k = d^2 (mu_k^T N) / dz^2 at z_k. The same derivatives as CasADi's own to round-off
(``tests/test_muscle_gait_derivatives.py``); Ipopt gets them through nlpsol's
``grad_f``, ``jac_g`` and ``hess_lag`` options.
"""

from __future__ import annotations

import casadi as cs


def node_functions(node: cs.Function, used: tuple[int, ...], rows: list[int],
                   curved: list[int], in_objective: list[int]) -> dict[str, cs.Function]:
    """The node's ``used`` outputs and their derivatives, on its stacked inputs z.

    y stacks the ``used`` outputs; ``rows``: the entries of y the NLP depends on (the
    others, e.g. the horizontal contact forces, would only add 0 x their curvature, NaN
    where that is not finite); ``curved``: positions in ``rows`` where the outer
    expressions are nonlinear; ``in_objective``: positions in ``rows`` the objective
    uses. Functions: ``value(z) -> y``, ``jacobian(z) -> dy[rows]/dz``,
    ``curved_jacobian(z) -> dy[rows][curved]/dz``, ``vjp(z, s) ->
    (dy[rows][in_objective]/dz)^T s``, ``hessian(z, mu) -> d^2(mu^T y[rows])/dz^2``.
    """
    parts = [cs.SX.sym(f"in{i}", node.sparsity_in(i)) for i in range(node.n_in())]
    z = cs.vertcat(*(cs.vec(part) for part in parts))
    outputs = node(*parts)
    y = cs.vertcat(*(cs.vec(outputs[i]) for i in used))
    kept = y[rows]
    seed, seed_f = cs.SX.sym("seed", len(rows)), cs.SX.sym("seed", len(in_objective))
    return {"value": cs.Function("node_value", [z], [y]),
            "jacobian": cs.Function("node_jacobian", [z], [cs.jacobian(kept, z)]),
            "curved_jacobian": cs.Function("node_curved_jacobian", [z],
                                           [cs.jacobian(kept[curved], z)]),
            "vjp": cs.Function("node_vjp", [z, seed_f],
                               [cs.jtimes(kept[in_objective], z, seed_f, True)]),
            "hessian": cs.Function("node_hessian", [z, seed],
                                   [cs.hessian(cs.dot(seed, kept), z)[0]])}


def _entries(sparsity: cs.Sparsity, offset: int = 0) -> set[int]:
    """Column indices (minus ``offset``) holding a structural nonzero."""
    return {int(j) - offset for j in sparsity.get_col() if j >= offset}


def nlp_derivatives(w: cs.SX, p: cs.SX, z: cs.SX, y: cs.SX, f: cs.SX, g: cs.SX,
                    node: cs.Function, used: tuple[int, ...]) -> dict[str, cs.Function]:
    """The nlpsol options ``grad_f``, ``jac_g``, ``hess_lag`` of f(w, p, Y), g(w, p, Y).

    Args:
        w: the NLP's decision vector (SX symbol).
        p: its parameters (SX symbol).
        z: (nz, K) the node inputs at the K grid points, linear expressions of w.
        y: (ny, K) SX symbols standing for the node's ``used`` outputs at the grid points.
        f: the objective, an expression of (w, p, y).
        g: the constraints, expressions of (w, p, y).
        node: the node Function.
        used: indices of its outputs stacked in ``y``.
    """
    nz, count = z.shape
    ny, nw = y.shape[0], w.shape[0]
    d = cs.evalf(cs.jacobian(cs.vec(z), w))       # z = D w: a constant selection/scaling
    rows = sorted({j % ny for j in _entries(cs.jacobian(cs.vertcat(f, g), cs.vec(y))
                                            .sparsity())})
    nr = len(rows)
    ys = cs.vec(y[rows, :])                       # entry k * nr + i: row rows[i], point k
    lam_f, lam_g = cs.SX.sym("lam_f"), cs.SX.sym("lam_g", g.shape[0])
    outer = lam_f * f + cs.dot(lam_g, g)
    second = cs.hessian(outer, cs.vertcat(w, ys))[0]
    curved = sorted({j % nr for j in _entries(second.sparsity(), nw)})
    pick = [k * nr + i for k in range(count) for i in curved]   # entries of ys, curved
    in_objective = sorted({j % nr for j in _entries(cs.jacobian(f, ys).sparsity())})
    fns = node_functions(node, used, rows, curved, in_objective)
    objective = cs.Function("outer_objective", [w, p, cs.vec(y)], [
        f, cs.jacobian(f, w),
        cs.gradient(f, ys)[[k * nr + i for k in range(count) for i in in_objective]]])
    constraints = cs.Function("outer_constraints", [w, p, cs.vec(y)],
                              [g, cs.jacobian(g, w), cs.jacobian(g, ys)])
    curvature = cs.Function("outer_second", [w, p, cs.vec(y), lam_f, lam_g],
                            [second[:nw, :nw], second[:nw, nw:][:, pick],
                             second[nw:, nw:][pick, pick], cs.gradient(outer, ys)])

    x, par = cs.MX.sym("x", w.sparsity()), cs.MX.sym("p", p.sparsity())
    lf, lg = cs.MX.sym("lam_f"), cs.MX.sym("lam_g", g.shape[0])
    zk = cs.reshape(cs.mtimes(d, x), nz, count)
    ym = cs.vec(fns["value"].map(count)(zk))
    fv, f_w, f_y = objective(x, par, ym)
    gv, g_w, g_y = constraints(x, par, ym)
    o_ww, o_wy, o_yy, mu = curvature(x, par, ym, lf, lg)

    def through_nodes(name: str, *seeds) -> list:
        return cs.horzsplit(fns[name].map(count)(zk, *seeds), nz)

    jd = cs.mtimes(cs.diagcat(*through_nodes("jacobian")), d)           # dY[rows]/dw
    jd_curved = cs.mtimes(cs.diagcat(*through_nodes("curved_jacobian")), d)
    grad = f_w.T
    if in_objective:
        seeds = cs.reshape(f_y, len(in_objective), count)
        grad += cs.mtimes(d.T, cs.vec(fns["vjp"].map(count)(zk, seeds)))
    cross = cs.mtimes(o_wy, jd_curved)
    hess = (o_ww + cross + cross.T + cs.mtimes([jd_curved.T, o_yy, jd_curved])
            + cs.mtimes([d.T, cs.diagcat(*through_nodes("hessian", cs.reshape(mu, nr,
                                                                                count))), d]))
    return {
        # dense: nlpsol copies the gradient into a dense vector
        "grad_f": cs.Function("nlp_grad_f", [x, par], [fv, cs.densify(grad)],
                              ["x", "p"], ["f", "grad_f_x"]),
        "jac_g": cs.Function("nlp_jac_g", [x, par], [gv, g_w + cs.mtimes(g_y, jd)],
                             ["x", "p"], ["g", "jac_g_x"]),
        "hess_lag": cs.Function("nlp_hess_l", [x, par, lf, lg], [cs.triu(hess)],
                                ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]),
    }
