"""Linear stability of the driven leg about a state (thesis 4.2, "future work").

x = [q_f, v_f], x' = f(t, x) with the foot prescribed. The Jacobian
A = [[0, I], [da_f/dq_f, da_f/dv_f]] is assembled from Pinocchio's analytical RNEA
derivatives (``pin.computeRNEADerivatives``): at the solved accelerations,
M_ff da_f = dtau_f - dRNEA_f (the prescribed coordinates held on their trajectory),
where tau is every applied generalised force (active, passive, feedback, hip load),
whose derivatives are taken by central differences (they are cheap and include the
passive elements' laws and the configuration dependence of J_hip^T w). When nothing is
prescribed, this equals ``pin.computeABADerivatives``. Eigenvalues with a positive real
part are the unstable modes: their e-folding time 1/Re(lambda) explains how fast a
driven leg leaves its measured path.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin


@dataclass(frozen=True)
class Linearization:
    """Linearised leg dynamics at (t, x).

    Attributes:
        t: Time, s.
        x: (2 nf,) state.
        A: (2 nf, 2 nf) Jacobian of f, 1/s and 1/s^2 blocks.
        eigenvalues: (2 nf,) complex, 1/s, sorted by decreasing real part.
        eigenvectors: (2 nf, 2 nf) columns.
    """

    t: float
    x: np.ndarray
    A: np.ndarray
    eigenvalues: np.ndarray
    eigenvectors: np.ndarray

    @property
    def unstable(self) -> np.ndarray:
        """Eigenvalues with real part > 1e-9, 1/s."""
        return self.eigenvalues[self.eigenvalues.real > 1e-9]

    @property
    def e_folding_time(self) -> float | None:
        """1 / largest positive real part, s (None when stable)."""
        re = self.eigenvalues.real.max()
        return float(1.0 / re) if re > 1e-9 else None


def linearize(system, t: float, x: np.ndarray, *, eps: float = 1e-6) -> Linearization:
    """Jacobian and eigenvalues of the leg's right-hand side at (t, x).

    Args:
        system: A :class:`predgait.dynamics.partitioned.PartitionedSystem` without a
            free-flyer root (e.g. the leg's :class:`~predgait.dynamics.forward.LegSystem`).
        t: Time, s.
        x: (2 nf,) state [q_f, v_f].
        eps: Central-difference step for the applied forces' derivatives.
    """
    pm, f = system.pm, system.free
    nf = len(f)
    q, v, a = system.full_state(t, np.asarray(x, dtype=float))
    a_free = system.accelerations(t, q, v, a)
    M = system.mass_matrix(q)
    a = a.copy()
    a[f] = a_free
    data = pm.createData()
    dq, dv, _ = pin.computeRNEADerivatives(pm, data, q, v, a)
    dtau_q, dtau_v = np.zeros((pm.nv, nf)), np.zeros((pm.nv, nf))
    for j, i in enumerate(f):
        e = np.zeros(pm.nv)
        e[i] = eps
        dtau_q[:, j] = (system.applied(t, q + e, v) - system.applied(t, q - e, v)) / (2 * eps)
        dtau_v[:, j] = (system.applied(t, q, v + e) - system.applied(t, q, v - e)) / (2 * eps)
    Mff = M[np.ix_(f, f)]
    da_dq = np.linalg.solve(Mff, dtau_q[f] - dq[np.ix_(f, f)])
    da_dv = np.linalg.solve(Mff, dtau_v[f] - dv[np.ix_(f, f)])
    A = np.block([[np.zeros((nf, nf)), np.eye(nf)], [da_dq, da_dv]])
    w, vecs = np.linalg.eig(A)
    order = np.argsort(-w.real)
    return Linearization(t=float(t), x=np.array(x, dtype=float), A=A, eigenvalues=w[order],
                         eigenvectors=vecs[:, order])
