"""The whole-body tracking NLP in optimal-control stage form, for FATROP (issue 27).

The same problem as :func:`~predgait.problems.fullbody_tracking.tracking_nlp` (same
constraints, cost and optimum), its unknowns regrouped into stages k = 0..N-1 of states
x_k and controls u_k so that FATROP (CasADi's ``nlpsol("fatrop")``: an interior-point
method with a Riccati recursion over the stages) can use the structure. FATROP needs
dynamics x_{k+1} = F(x_k, u_k), path constraints and cost terms on (x_k, u_k) only, and a
Hessian without entries between stages; the collocation and the smoothing terms couple
neighbouring nodes, hence copies:

- x_k = (z_k, f_{k-1}): the node's unknowns z_k = (dx, v, a, f / FORCE_UNIT) and a copy
  of the previous node's forces (the second difference of the forces; zero at k = 0);
- u_k = (a_{k+1}, dx_{k+1}[0:6], f_{k+1}): the next node's accelerations, pelvis pose
  correction and forces;
- F: the trapezoidal rule of the joints and velocities (linear), the copies;
- path constraints of stage k: the node's (pelvis rows, contact heights, friction) and
  the pelvis position and rotation collocation of interval k (implicit in the pose);
- cost of stage k: the node's terms, and each smoothing row (torque, acceleration
  change, force second difference) on the copies within one stage.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as cs
import numpy as np

from predgait.models.loading3d import Model3D
from predgait.problems.fullbody_tracking_stage import (
    NQ,
    _interval,
    stage_functions,
)


@dataclass(frozen=True, eq=False)
class StageLayout:
    """Sizes of the stage form for P contact points."""

    count: int

    @property
    def nz(self) -> int:
        """Unknowns of one node."""
        return NQ + 3 * self.count

    @property
    def nx(self) -> int:
        """States: the node's unknowns and the previous node's forces."""
        return self.nz + 3 * self.count

    @property
    def nu(self) -> int:
        """Controls: the next node's a (35), pelvis pose correction (6), forces (3 P)."""
        return 41 + 3 * self.count

    @property
    def ng(self) -> int:
        """Path constraints of a stage before the last: the node's and the pelvis collocation."""
        return 6 + 5 * self.count + 6

    def next_node(self, u):
        """(a, pose, f) of the next node from the controls u."""
        return u[:35], u[35:41], u[41:]


@functools.lru_cache(maxsize=4)
def stage_form(model: Model3D, points: tuple[str, ...]) -> dict:
    """SX functions of one stage: ``stage``, ``jacobian``, ``hessian`` and of the last one."""
    base = stage_functions(model, points)
    lay = StageLayout(len(points))
    nz, nx = lay.nz, lay.nx
    w = cs.SX.sym("w", nx + lay.nu)
    p = cs.SX.sym("p", base.nparams)
    wts = cs.SX.sym("wts", 7)
    q0, q1, h = cs.SX.sym("q0", 36), cs.SX.sym("q1", 36), cs.SX.sym("h")
    z, x = w[:nz], w[:nx]
    v, a, f = z[35:70], z[70:105], z[105:]
    a1, pose1, f1 = lay.next_node(w[nx:])
    v1 = v + h / 2 * (a + a1)
    ds1 = q0[7:] + z[6:35] - q1[7:] + h / 2 * (v[6:] + v1[6:])
    z1 = cs.vertcat(pose1, ds1, v1, a1, f1)
    dynamics = cs.vertcat(z1, f)
    g_node, cost = base.node(z, p, wts)
    path = cs.vertcat(g_node, _interval(z, z1, q0, q1, h)[64:70])
    g = cs.vertcat(-dynamics, path)
    sigma, lam = cs.SX.sym("sigma"), cs.SX.sym("lam", g.numel())
    lag = sigma * cost + cs.dot(lam[nx:], path)
    args = [w, p, wts, q0, q1, h]
    out = {
        "stage": cs.Function("fatrop_stage", args, [g, cost]),
        "jacobian": cs.Function("fatrop_stage_jac", args, [cs.jacobian(g, w)]),
        "gradient": cs.Function("fatrop_stage_grad", args, [cs.gradient(cost, w)]),
        "hessian": cs.Function("fatrop_stage_hess", [*args, sigma, lam],
                               [cs.hessian(lag, w)[0]]),
    }
    # The last stage: the node alone (and the previous forces' copy, in no term).
    lam_n = cs.SX.sym("lam", g_node.numel())
    lag_n = sigma * cost + cs.dot(lam_n, g_node)
    out |= {
        "last": cs.Function("fatrop_last", [x, p, wts], [g_node, cost]),
        "last_jacobian": cs.Function("fatrop_last_jac", [x, p, wts],
                                     [cs.jacobian(g_node, x)]),
        "last_gradient": cs.Function("fatrop_last_grad", [x, p, wts],
                                     [cs.gradient(cost, x)]),
        "last_hessian": cs.Function("fatrop_last_hess", [x, p, wts, sigma, lam_n],
                                    [cs.hessian(lag_n, x)[0]]),
    }
    return out


def _offsets(n: int, lay: StageLayout) -> np.ndarray:
    """Start of each stage's (x_k, u_k) in the stage-form vector."""
    return np.arange(n) * (lay.nx + lay.nu)


def node_positions(n: int, lay: StageLayout) -> np.ndarray:
    """(N, nz) index of each node unknown's own copy (in x_k) in the stage-form vector."""
    return _offsets(n, lay)[:, None] + np.arange(lay.nz)[None]


def _copy_position(j: int, c: int, s: int, n: int, lay: StageLayout) -> int | None:
    """Index of node j's unknown c among stage s's variables, or None (no copy there)."""
    start = s * (lay.nx + lay.nu)
    if j == s:
        return start + c
    if j == s - 1 and c >= NQ:
        return start + lay.nz + c - NQ
    if j == s + 1 and s < n - 1:
        if 70 <= c < NQ:
            return start + lay.nx + c - 70
        if c < 6:
            return start + lay.nx + 35 + c
        if c >= NQ:
            return start + lay.nx + 41 + c - NQ
    return None


def stage_matrix(matrix: cs.DM, n: int, lay: StageLayout, size: int) -> cs.DM:
    """The smoothing rows A (on the node-major vector) on copies within one stage each."""
    rows, cols = matrix.sparsity().get_triplet()
    vals = np.asarray(matrix.nonzeros())
    rows, cols = np.asarray(rows), np.asarray(cols)
    nodes, within = cols // lay.nz, cols % lay.nz
    new_cols = np.empty_like(cols)
    order = np.argsort(rows, kind="stable")
    bounds = np.flatnonzero(np.diff(np.r_[-1, rows[order], matrix.size1()]))
    for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
        idx = order[lo:hi]
        for s in range(nodes[idx].min(), nodes[idx].max() + 1):
            where = [_copy_position(j, c, s, n, lay) for j, c in zip(nodes[idx], within[idx],
                                                                      strict=True)]
            if None not in where:
                new_cols[idx] = where
                break
        else:
            raise ValueError(f"smoothing row {rows[idx[0]]} spans more than one stage")
    return cs.DM.triplet(rows.tolist(), new_cols.tolist(), vals.tolist(), matrix.size1(), size)


def to_stage_vector(z: np.ndarray, lay: StageLayout) -> np.ndarray:
    """The stage-form vector of node-major unknowns z (N, nz), copies filled."""
    n = z.shape[0]
    f = z[:, NQ:]
    parts = []
    for k in range(n):
        parts += [z[k], f[k - 1] if k else np.zeros_like(f[0])]
        if k < n - 1:
            parts += [z[k + 1, 70:NQ], z[k + 1, :6], f[k + 1]]
    return np.concatenate(parts)


def from_stage_vector(y: np.ndarray, n: int, lay: StageLayout) -> np.ndarray:
    """(N, nz) node unknowns (their own copies) of the stage-form vector y."""
    return np.asarray(y).ravel()[node_positions(n, lay)]


def fatrop_nlp(model: Model3D, problem, data, weights_vector: np.ndarray, params: np.ndarray,
               matrix: cs.DM, rhs: np.ndarray) -> tuple[dict, dict, dict]:
    """The stage form of a :class:`~predgait.problems.fullbody_tracking.TrackingNLP`.

    ``problem``: that NLP (bounds, initial guess, node-major); ``weights_vector``,
    ``params``, (``matrix``, ``rhs``): its cost weights, node parameters and smoothing
    rows. Returns (nlp, nlpsol options with the structure and the derivative functions
    in the cache, bounds and x0 as arrays).
    """
    n = data.nodes
    lay = StageLayout(len(data.points))
    fn = stage_form(model, tuple(data.points))
    nw = lay.nx + lay.nu
    size = nw * (n - 1) + lay.nx
    h = float(np.mean(np.diff(data.time)))
    qs = data.q.T
    y, no_p = cs.MX.sym("y", size), cs.MX.sym("p", 0)
    ws = cs.reshape(y[:nw * (n - 1)], nw, n - 1)
    xl = y[nw * (n - 1):]
    args = (ws, params[:, :-1], weights_vector, qs[:, :-1], qs[:, 1:], h)
    last_args = (xl, params[:, -1], weights_vector)
    g_st, cost_st = fn["stage"].map(n - 1)(*args)
    g_last, cost_last = fn["last"](*last_args)
    # Gap-closing rows x_{k+1} - F(x_k, u_k): the identity on the next stage's states.
    rows_k = lay.nx + lay.ng
    next_x = cs.horzcat(ws[:lay.nx, 1:], xl)
    identity_rows = (np.arange(n - 1)[:, None] * rows_k + np.arange(lay.nx)[None]).ravel()
    identity_cols = (np.arange(1, n)[:, None] * nw + np.arange(lay.nx)[None]).ravel()
    n_g = rows_k * (n - 1) + g_last.numel()
    ident = cs.DM.triplet(identity_rows.tolist(), identity_cols.tolist(),
                          [1.0] * identity_rows.size, n_g, size)
    g_dyn = g_st[:lay.nx, :] + next_x
    g = cs.vertcat(cs.vec(cs.vertcat(g_dyn, g_st[lay.nx:, :])), g_last)
    # Smoothing rows on copies within a stage.
    a_new = stage_matrix(matrix, n, lay, size)
    residual = a_new @ y - rhs
    smooth = cs.sumsqr(residual)
    f = (cs.sum2(cost_st) + cost_last) / n + smooth
    jac = cs.diagcat(*cs.horzsplit(fn["jacobian"].map(n - 1)(*args), nw),
                     fn["last_jacobian"](*last_args)) + ident
    grad = cs.vertcat(cs.vec(fn["gradient"].map(n - 1)(*args)),
                      fn["last_gradient"](*last_args)) / n + 2 * a_new.T @ residual
    sigma, lam = cs.MX.sym("sigma"), cs.MX.sym("lam", n_g)
    lam_st = cs.reshape(lam[:rows_k * (n - 1)], rows_k, n - 1)
    blocks = fn["hessian"].map(n - 1)(*args, sigma / n, lam_st)
    hess = cs.diagcat(*cs.horzsplit(blocks, nw),
                      fn["last_hessian"](*last_args, sigma / n, lam[rows_k * (n - 1):]))
    hess += sigma * (2 * a_new.T @ a_new)
    grad_lag = sigma * grad + jac.T @ lam
    cache = {
        "nlp_grad_f": cs.Function("nlp_grad_f", [y, no_p], [grad], ["x", "p"], ["grad_f_x"]),
        "nlp_jac_g": cs.Function("nlp_jac_g", [y, no_p], [g, jac], ["x", "p"],
                                 ["g", "jac_g_x"]),
        "nlp_hess_l": cs.Function("nlp_hess_l", [y, no_p, sigma, lam], [grad_lag, hess],
                                  ["x", "p", "lam_f", "lam_g"],
                                  ["grad_gamma_x", "hess_gamma_x_x"]),
    }
    options = {"structure_detection": "manual", "N": n - 1, "nx": [lay.nx] * n,
               "nu": [lay.nu] * (n - 1) + [0], "ng": [lay.ng] * (n - 1) + [lay.ng - 6],
               "cache": cache}
    # Bounds: the node's own copies carry the NLP's; f_{-1} = 0; the other copies free.
    lbx, ubx = np.full(size, -np.inf), np.full(size, np.inf)
    pos = node_positions(n, lay).ravel()
    lbx[pos], ubx[pos] = problem.lbx, problem.ubx
    prev0 = np.arange(lay.nz, lay.nx)
    lbx[prev0] = ubx[prev0] = 0.0
    ng_node = lay.ng - 6
    lbg_node = problem.lbg[:ng_node * n].reshape(n, ng_node)
    ubg_node = problem.ubg[:ng_node * n].reshape(n, ng_node)
    lbg, ubg = [], []
    for k in range(n):
        if k < n - 1:
            lbg += [np.zeros(lay.nx), lbg_node[k], np.zeros(6)]
            ubg += [np.zeros(lay.nx), ubg_node[k], np.zeros(6)]
        else:
            lbg.append(lbg_node[k])
            ubg.append(ubg_node[k])
    z0 = problem.x0.reshape(n, lay.nz)
    bounds = {"x0": to_stage_vector(z0, lay), "lbx": lbx, "ubx": ubx,
              "lbg": np.concatenate(lbg), "ubg": np.concatenate(ubg)}
    return {"x": y, "f": f, "g": g}, options, bounds
