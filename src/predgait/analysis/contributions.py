"""Split each free joint acceleration into its causes (thesis Fig. 4.2.12).

With the foot prescribed (:class:`predgait.dynamics.forward.LegSystem`),
a_f = M_ff^-1 (tau_f - h_f - M_fp a_p). Writing h = g(q) + c(q, v) (gravity and the
velocity-product terms) and tau = active + feedback + passive + hip load, each part
times M_ff^-1 is the acceleration it causes; M_ff^-1 is linear, so the parts add up to
the total exactly:

    gravity = -M_ff^-1 g_f                velocity = -M_ff^-1 c_f
    passive = M_ff^-1 tau_passive,f       applied = M_ff^-1 (tau_active,f + tau_fb,f)
    hip     = M_ff^-1 (J_hip^T w_hip)_f   base    = -M_ff^-1 M_fp a_p (foot acceleration)
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

PARTS = ("gravity", "velocity", "passive", "applied", "hip", "base")


def contributions(system, t: float, x: np.ndarray) -> dict[str, np.ndarray]:
    """Acceleration (n_free,) rad/s^2 caused by each part, plus ``total``.

    Args:
        system: A :class:`predgait.dynamics.forward.LegSystem`.
        t: Time, s.
        x: (2 n_free,) state [q_f, v_f].
    """
    q, v, a = system.full_state(t, x)
    a_total = system.accelerations(t, q, v, a)
    forces = system.applied_parts(t, q, v)
    zero = np.zeros(system.pm.nv)
    M = system.mass_matrix(q)
    f, p = system.free, system.pres
    grav = pin.computeGeneralizedGravity(system.pm, system.data, q)
    velocity = pin.nonLinearEffects(system.pm, system.data, q, v) - grav
    Mff = M[np.ix_(f, f)]
    rhs = {"gravity": -grav[f], "velocity": -velocity[f],
           "passive": forces.get("passive", zero)[f],
           "applied": forces.get("active", zero)[f] + forces.get("feedback", zero)[f],
           "hip": forces.get("hip", zero)[f], "base": -M[np.ix_(f, p)] @ a[p]}
    parts = {name: np.linalg.solve(Mff, value) for name, value in rhs.items()}
    parts["total"] = a_total
    return parts


def contribution_history(system, sim) -> dict[str, np.ndarray]:
    """Contributions along a simulation: name -> (n, n_free) rad/s^2."""
    nf = len(system.free)
    rows = [contributions(system, t, np.concatenate([q[system.free], v[system.free]]))
            for t, q, v in zip(sim.t, sim.q, sim.v, strict=True)
            if np.all(np.isfinite(q))]
    return {name: np.array([r[name] for r in rows]).reshape(-1, nf)
            for name in (*PARTS, "total")}
