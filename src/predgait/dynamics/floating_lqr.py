"""Time-varying LQR for a free-floating body: feedback on the joints from the whole state.

The body with its free-flyer root free (all nv velocity rows integrated, e.g. the 35-DOF
whole body on its contact springs) is linearised along a reference motion
(q_ref(t), v_ref(t)) in the tangent space of the configuration::

    dx = (pin.difference(q_ref, q) (nv,), v - v_ref (nv,)),
    d(dx)/dt = A(t) dx + B(t) du,   A = [[0, I], [da/dq, da/dv]],   B = [[0], [M^-1 S^T]],

where a = ABA(q, v, tau_ff + applied forces) are the engine's accelerations
(:class:`~predgait.dynamics.partitioned.PartitionedSystem`, contact forces included),
da/dq and da/dv are central differences (q perturbed on its Lie group with
``pin.integrate``), S selects the actuated joint rows (the root has no actuator), and
M^-1 comes from ``pin.computeMinverse``. The configuration error's rate is taken as the
velocity error (exact at the reference up to the root's adjoint term, which feedback
absorbs). Gains from the finite-horizon Riccati equation stepped in its zero-order-hold
form (:func:`predgait.dynamics.lqr.riccati_gains`), ending on the infinite-horizon
(algebraic Riccati) solution of the last node, so that the gains do not fade to zero at
the end of the window; u = -K(t) dx on the joints (Kirk 1970, ch. 3 and 5; Tedrake,
Underactuated Robotics, "time-varying LQR"). Weights follow Bryson's rule
(:data:`FLOATING_WEIGHTS`).
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.blas_threads import one_blas_thread
from predgait.dynamics.forces import Force
from predgait.dynamics.lqr import BrysonWeights, riccati_gains

#: Bryson's-rule weights of a free-flyer body (:func:`floating_matrices`): the state
#: errors and the joint torque that cost one unit.
#:
#: Every actuated joint has the same torque cost 1 / ``torque_n_m``^2, so a joint alone
#: (I x'' = u, cost x^2 / angle^2 + u^2 / torque^2) gets the stiffness torque / angle
#: (N m/rad) whatever its inertia I, and from the Riccati equation the damping
#: sqrt(2 I torque / angle), i.e. a damping ratio of 0.71 at its natural frequency
#: sqrt(torque / (angle I)) (the double integrator's LQR; Bryson's rule: Franklin, Powell &
#: Emami-Naeini, Feedback Control of Dynamic Systems). The joint rates carry no weight:
#: a rate weight adds a velocity gain torque / rate, which over a foot's 0.005 kg m^2 is
#: a rate torque / (rate I) of ~6000 1/s alone and 10^7 1/s in the coupled body
#: (walking5's re-simulation diverged at its first RK4 step of 1e-4 s); the pelvis (no
#: actuator) keeps its rate weight. The sole points' heights get their own error
#: (:func:`sole_height_weights`): a swing foot that drifts a centimetre low scuffs the
#: floor, one that arrives high and late meets the stance torques in the air (the
#: joints alone weigh that drift only through its few degrees).
FLOATING_WEIGHTS = BrysonWeights(angle_deg=5.0, rate_deg_s=50.0, torque_n_m=25.0,
                                 position_m=0.02, sole_height_m=0.002)


def floating_matrices(weights: BrysonWeights, actuated: int) -> tuple[np.ndarray, np.ndarray]:
    """(Q (2 nv, 2 nv), R (n, n)) for n = ``actuated`` joint rows, SI units.

    nv is taken as 6 + n (a free-flyer root and the actuated joints): root position and
    orientation, every joint angle, the root's linear and angular rates; the joint rates
    carry no weight (see :data:`FLOATING_WEIGHTS`).
    """
    angle, rate = np.radians(weights.angle_deg), np.radians(weights.rate_deg_s)
    nv = 6 + actuated
    inverse_q = np.concatenate([np.full(3, weights.position_m), np.full(nv - 3, angle),
                                np.full(3, weights.root_speed_m_s()), np.full(3, rate)])
    q = np.concatenate([inverse_q**-2.0, np.zeros(actuated)])
    return np.diag(q), weights.torque_cost(actuated)


def sole_height_weights(model, q: np.ndarray, points, height_m: float) -> np.ndarray:
    """State weight (nv, nv) of the sole points' height errors at configuration q.

    dz_i = J_z,i dq (J_z,i: the vertical row of point i's lab-aligned Jacobian, which acts
    on the tangent dq = pin.difference(q_ref, q)); the cost sum_i (dz_i / height_m)^2 is
    dq^T (sum_i J_z,i^T J_z,i / height_m^2) dq.
    """
    pm = model.pin_model
    data = pm.createData()
    pin.computeJointJacobians(pm, data, q)
    pin.updateFramePlacements(pm, data)
    rows = np.array([pin.getFrameJacobian(pm, data, model.frame_id(p),
                                          pin.LOCAL_WORLD_ALIGNED)[2] for p in points])
    return rows.T @ rows / height_m**2


def _accelerations(system, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    tau = system.applied(t, q, v)
    return pin.aba(system.pm, system.data, q, v, tau).copy()


def linearize_floating(system, t: float, q: np.ndarray, v: np.ndarray,
                       actuated: np.ndarray, *, eps: float = 1e-6
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(A (2 nv, 2 nv), B (2 nv, len(actuated))) at (t, q, v) (module docstring).

    ``system``: a PartitionedSystem with every velocity row free (its ``applied`` forces
    are the open-loop ones: feedforward torques, contacts).
    """
    pm, nv = system.pm, system.pm.nv
    a_mat = np.zeros((2 * nv, 2 * nv))
    a_mat[:nv, nv:] = np.eye(nv)
    step = np.zeros(nv)
    for i in range(nv):
        step[i] = eps
        plus = _accelerations(system, t, pin.integrate(pm, q, step), v)
        minus = _accelerations(system, t, pin.integrate(pm, q, -step), v)
        a_mat[nv:, i] = (plus - minus) / (2 * eps)
        plus = _accelerations(system, t, q, v + step)
        minus = _accelerations(system, t, q, v - step)
        a_mat[nv:, nv + i] = (plus - minus) / (2 * eps)
        step[i] = 0.0
    m_inv = pin.computeMinverse(pm, system.data, q)
    m_inv = np.triu(m_inv) + np.triu(m_inv, 1).T
    b_mat = np.zeros((2 * nv, actuated.size))
    b_mat[nv:] = m_inv[:, actuated]
    return a_mat, b_mat


@dataclass(frozen=True, eq=False)
class FloatingLQR(Force):
    """u = -K(t) dx on the actuated rows; K linear between the grid nodes.

    Attributes:
        model: The model (its Pinocchio model gives ``pin.difference``).
        rows: Actuated velocity rows (n,).
        reference: t -> (q_ref (nq,), v_ref (nv,), ...).
        times: (m,) s. gains: (m, n, 2 nv), N m per rad (or m) and per rad/s.
        fastest_rate: The largest |real part| of the closed-loop linearisation's
            eigenvalues at the nodes, 1/s (RK4 is stable for steps below 2.78 / it).
    """

    model: object
    rows: np.ndarray
    reference: object
    times: np.ndarray
    gains: np.ndarray
    fastest_rate: float = float("nan")
    name: str = "feedback"

    def gain(self, t: float) -> np.ndarray:
        """K(t) (n, 2 nv), held at the ends."""
        times = self.times
        k = min(max(bisect.bisect_left(times, t) - 1, 0), times.size - 2)
        w = min(max((t - times[k]) / (times[k + 1] - times[k]), 0.0), 1.0)
        return (1 - w) * self.gains[k] + w * self.gains[k + 1]

    def error(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """State error dx (2 nv,) from the reference at t."""
        q_ref, v_ref = self.reference(t)[:2]
        return np.concatenate([pin.difference(self.model.pin_model, q_ref, q), v - v_ref])

    def torque(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Feedback torques (n,) at t (no state: the reference and K are read per call)."""
        return -self.gain(t) @ self.error(t, q, v)

    def add(self, tau, t, q, v, data) -> None:
        """Add the feedback torques at t."""
        tau[self.rows] += self.torque(t, q, v)


def floating_tvlqr(system, reference, times: np.ndarray, actuated,
                   weights: BrysonWeights = FLOATING_WEIGHTS, *, points=(),
                   substeps: int = 2) -> FloatingLQR:
    """Time-varying LQR of a free-floating ``system`` along ``reference`` on ``times``.

    Args:
        system: PartitionedSystem, all rows free, open-loop forces only.
        reference: t -> (q_ref, v_ref, ...).
        times: (m,) s increasing grid of the linearisation and the gains.
        actuated: Velocity rows that receive feedback torques.
        weights: Q and R by Bryson's rule.
        points: Sole (contact) frames whose height errors cost (``sole_height_m``).
        substeps: Zero-order-hold Riccati steps per grid interval.
    """
    from scipy.linalg import solve_continuous_are

    times = np.asarray(times, dtype=float)
    actuated = np.asarray(actuated, dtype=int)
    linear = [linearize_floating(system, t, *reference(t)[:2], actuated) for t in times]
    a_mats = np.array([a for a, _ in linear])
    b_mats = np.array([b for _, b in linear])
    q, r = floating_matrices(weights, actuated.size)
    nv = system.pm.nv
    q = np.repeat(q[None], times.size, axis=0)
    if len(points):
        for k, t in enumerate(times):
            q[k, :nv, :nv] += sole_height_weights(system.model, reference(t)[0], points,
                                                  weights.sole_height_m)
    with one_blas_thread():  # ~100 x 100 exponentials: threads only cost here
        final = solve_continuous_are(a_mats[-1], b_mats[-1], q[-1], r)
        gains = riccati_gains(times, a_mats, b_mats, q, r, substeps=substeps,
                              terminal=final)
    fastest = max(np.abs(np.linalg.eigvals(a - b @ k).real).max()
                  for a, b, k in zip(a_mats, b_mats, gains, strict=True))
    return FloatingLQR(system.model, actuated, reference, times, gains, float(fastest))
