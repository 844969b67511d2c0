"""Time-varying LQR feedback around a reference motion, for the forward engine.

The free dynamics x' = f(t, x, u) of a :class:`~predgait.dynamics.partitioned.
PartitionedSystem` (x = [q_f, v_f], u = torques on the free rows) are linearised along a
reference x_ref(t) (the measured motion, its prescribed coordinates following it)::

    d(dx)/dt = A(t) dx + B(t) du,   A = [[0, I], [da_f/dq_f, da_f/dv_f]],  B = [[0], [M_ff^-1]]

with the rigid-body part from Pinocchio's analytical RNEA derivatives
(``pin.computeRNEADerivatives``; at the solution a_f, RNEA(q, v, a)_f = tau_f, so
da_f/dx = -M_ff^-1 (dRNEA_f/dx - dtau_f/dx), the same identity as
``pin.computeABADerivatives`` on the free rows) and the state dependence of the applied
forces (e.g. the hip load J(q)^T w) by central differences. The finite-horizon
Riccati equation::

    -dS/dt = Q + A^T S + S A - S B R^-1 B^T S,   S(t1) = 0,

is solved backward in time (as its zero-order-hold discrete equivalent on a fine grid,
A and B interpolated linearly between the linearisation nodes) and the gains
K(t) = R^-1 B^T S(t) give the feedback u = -K(t) (x - x_ref(t)) (Kirk 1970, Optimal
Control Theory, ch. 3 and 5; Tedrake, Underactuated Robotics, ch. "Linear Quadratic
Regulators", finite-horizon / time-varying LQR).
Weights follow Bryson's rule: Q = diag(1/angle^2, 1/rate^2), R = I/torque^2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.dynamics.forces import Force
from predgait.errors import InputError


@dataclass(frozen=True)
class BrysonWeights:
    """Bryson's-rule weights: the error each term is allowed before it costs one unit.

    Q = diag(1 / tolerance^2) over the state rows and R = I / torque_n_m^2 (Bryson & Ho,
    Applied Optimal Control, 1975; Franklin, Powell & Emami-Naeini). The one weight type
    of predgait's LQR controllers: the leg's free joints (:func:`tvlqr`, the defaults),
    a free-flyer body (:data:`predgait.dynamics.floating_lqr.FLOATING_WEIGHTS`) and
    gait7 on its planar root (:data:`predgait.simulations.gait7_predicted.GAIT7_WEIGHTS`).

    Attributes:
        angle_deg: Joint (and root orientation) angle error, deg.
        rate_deg_s: Angular rate error, deg/s.
        torque_n_m: Feedback torque on any joint, N m.
        position_m: Root position error, m (None: a system without a moving root).
        speed_m_s: Root linear speed error, m/s (None: ``position_m`` per 0.1 s).
        sole_height_m: Height error of each sole (contact) point, m (None: not weighed).
    """

    angle_deg: float = 0.5
    rate_deg_s: float = 10.0
    torque_n_m: float = 10.0
    position_m: float | None = None
    speed_m_s: float | None = None
    sole_height_m: float | None = None

    def torque_cost(self, n: int) -> np.ndarray:
        """R (n, n) for n actuated joints, 1/(N m)^2."""
        return np.eye(n) / self.torque_n_m ** 2

    def matrices(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """(Q (2n, 2n), R (n, n)) for n free joints (SI units: rad, rad/s, N m)."""
        q = np.concatenate([np.full(n, np.radians(self.angle_deg) ** -2.0),
                            np.full(n, np.radians(self.rate_deg_s) ** -2.0)])
        return np.diag(q), self.torque_cost(n)

    def root_speed_m_s(self) -> float:
        """The root's linear speed error, m/s (``speed_m_s``, else ``position_m`` / 0.1 s)."""
        return self.position_m / 0.1 if self.speed_m_s is None else self.speed_m_s


def _applied_jacobians(system, t, q, v, step=1e-6):
    """d(applied generalised force)/d(q_f, v_f) (nv, nf) each, by central differences."""
    free = system.free
    dq, dv = np.zeros((system.pm.nv, free.size)), np.zeros((system.pm.nv, free.size))
    if not system.forces:
        return dq, dv
    q_rows = system.q_free
    for j in range(free.size):
        for state, out, rows in ((q, dq, q_rows), (v, dv, free)):
            plus, minus = state.copy(), state.copy()
            plus[rows[j]] += step
            minus[rows[j]] -= step
            if state is q:
                f_plus, f_minus = system.applied(t, plus, v), system.applied(t, minus, v)
            else:
                f_plus, f_minus = system.applied(t, q, plus), system.applied(t, q, minus)
            out[:, j] = (f_plus - f_minus) / (2.0 * step)
    return dq, dv


def linearize(system, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A (2n, 2n), B (2n, n)) of ``system``'s free dynamics at (t, x), n free joints.

    ``system`` is a :class:`~predgait.dynamics.partitioned.PartitionedSystem` whose free
    rows are 1-DOF joints (q_f and v_f the same size); B maps torques on the free rows.
    Multi-DOF free joints are refused: Pinocchio 4.1's RNEA derivatives with respect to
    the planar composite root's coordinates disagree with finite differences of
    ``pin.rnea`` (its 1-DOF rows are exact).

    Raises:
        InputError: A free row belongs to a joint with more than one DOF.
    """
    pm = system.pm
    multi = [pm.names[j] for j in range(1, pm.njoints)
             if pm.joints[j].nv > 1 and set(range(pm.joints[j].idx_v,
                                                  pm.joints[j].idx_v + pm.joints[j].nv))
             & set(system.free.tolist())]
    if multi:
        raise InputError(f"LQR linearisation needs 1-DOF free joints; {', '.join(multi)} "
                         "has several: prescribe it.")
    q, v, a = system.full_state(t, x)
    dq_force, dv_force = _applied_jacobians(system, t, q, v)
    a[system.free] = system.accelerations(t, q, v, a)
    data = pm.createData()
    pin.computeRNEADerivatives(pm, data, q, v, a)
    f = system.free
    mass = np.triu(data.M) + np.triu(data.M, 1).T
    m_inv = np.linalg.inv(mass[np.ix_(f, f)])
    n = f.size
    a_mat = np.zeros((2 * n, 2 * n))
    a_mat[:n, n:] = np.eye(n)
    a_mat[n:, :n] = -m_inv @ (data.dtau_dq[np.ix_(f, f)] - dq_force[f])
    a_mat[n:, n:] = -m_inv @ (data.dtau_dv[np.ix_(f, f)] - dv_force[f])
    b_mat = np.zeros((2 * n, n))
    b_mat[n:] = m_inv
    return a_mat, b_mat


def riccati_gains(times: np.ndarray, a_mats: np.ndarray, b_mats: np.ndarray, q: np.ndarray,
                  r: np.ndarray, *, substeps: int = 5,
                  terminal: np.ndarray | None = None) -> np.ndarray:
    """Gains K (m, n, 2n) on ``times`` (m,) from the backward finite-horizon Riccati equation.

    A and B (m, 2n, 2n), (m, 2n, n), and Q if given per node (m, 2n, 2n), are interpolated
    linearly between the nodes; S(t1) =
    ``terminal`` (default 0, no terminal cost: then end the grid a few unstable time
    constants after the window of interest so that the gains there have converged; or
    give the algebraic Riccati solution of the last node, the infinite-horizon cost).
    The continuous equation is stiff (closed-loop rates of hundreds per second), so it is
    stepped as its sampled-data (zero-order-hold) equivalent, ``substeps`` steps per
    interval: A_d = exp(A h), B_d = int_0^h exp(A s) ds B, and the discrete Riccati
    recursion S <- Q h + A_d^T S A_d - A_d^T S B_d (R h + B_d^T S B_d)^-1 B_d^T S A_d,
    which is unconditionally stable and tends to the continuous one as h -> 0.
    """
    from scipy.linalg import expm

    nx, nu = b_mats.shape[1:]
    m = times.size
    s = np.zeros((nx, nx)) if terminal is None else np.array(terminal, dtype=float)
    gains = np.empty((m, nu, nx))
    gains[-1] = np.linalg.solve(r, b_mats[-1].T @ s)
    block = np.zeros((nx + nu, nx + nu))
    for k in range(m - 1, 0, -1):
        h = (times[k] - times[k - 1]) / substeps
        for i in range(substeps):
            w = (i + 0.5) / substeps                  # from node k back toward k - 1
            block[:nx, :nx] = (1 - w) * a_mats[k] + w * a_mats[k - 1]
            block[:nx, nx:] = (1 - w) * b_mats[k] + w * b_mats[k - 1]
            q_h = (q if q.ndim == 2 else (1 - w) * q[k] + w * q[k - 1]) * h
            step = expm(block * h)
            a_d, b_d = step[:nx, :nx], step[:nx, nx:]
            sb = s @ b_d
            gain = np.linalg.solve(r * h + b_d.T @ sb, sb.T @ a_d)
            s = q_h + a_d.T @ s @ a_d - (a_d.T @ sb) @ gain
            s = 0.5 * (s + s.T)
        gains[k - 1] = np.linalg.solve(r, b_mats[k - 1].T @ s)
    return gains


@dataclass(frozen=True, eq=False)
class TimeVaryingLQR(Force):
    """u = -K(t) (x - x_ref(t)) on the free joint rows; K linear between grid nodes.

    Attributes:
        rows: Velocity rows of the free 1-DOF joints (n,); their q rows are the same
            (no free-flyer root).
        reference: t -> (q_ref (nq,), v_ref (nv,)) (e.g. :meth:`LegDrivers.reference`).
        times: (m,) s grid of the gains. gains: (m, n, 2n), N m/rad and N m s/rad.
    """

    rows: np.ndarray
    reference: object
    times: np.ndarray
    gains: np.ndarray
    name: str = "feedback"

    def gain(self, t: float) -> np.ndarray:
        """K(t) (n, 2n), held at the ends."""
        k = int(np.clip(np.searchsorted(self.times, t) - 1, 0, self.times.size - 2))
        w = float(np.clip((t - self.times[k]) / (self.times[k + 1] - self.times[k]), 0, 1))
        return (1 - w) * self.gains[k] + w * self.gains[k + 1]

    def torque(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Feedback torques (n,) at t."""
        q_ref, v_ref = self.reference(t)[:2]
        error = np.concatenate([q[self.rows] - q_ref[self.rows], v[self.rows] - v_ref[self.rows]])
        return -self.gain(t) @ error

    def add(self, tau, t, q, v, data) -> None:
        """Add the feedback torques at t."""
        tau[self.rows] += self.torque(t, q, v)


def tvlqr(system, reference, times: np.ndarray, weights: BrysonWeights = BrysonWeights()
          ) -> TimeVaryingLQR:
    """Time-varying LQR of ``system``'s free joints along ``reference`` on ``times``.

    Args:
        system: The open-loop system (feedforward forces only), no free-flyer root.
        reference: t -> (q_ref (nq,), v_ref (nv,)); the prescribed rows follow ``system``.
        times: (m,) s increasing grid (m >= 2) of the linearisation and the gains.
        weights: Q and R by Bryson's rule.
    """
    times = np.asarray(times, dtype=float)
    linear = [linearize(system, t, system.state(*reference(t)[:2])) for t in times]
    a_mats = np.array([a for a, _ in linear])
    b_mats = np.array([b for _, b in linear])
    q, r = weights.matrices(system.free.size)
    return TimeVaryingLQR(system.free.copy(), reference, times,
                          riccati_gains(times, a_mats, b_mats, q, r))
