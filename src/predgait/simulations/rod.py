"""The thesis rod experiment (3.2, Figs. 4.1.9-4.1.10) on a synthetic trial.

A "measured" rod motion is made up (the bottom end B slides on the force plate, the
rod swings about the vertical), with a made-up plate force on B carrying most of the
weight. The top force and moment (end A) follow from inverse dynamics by Pinocchio
(RNEA; J_A^T w_A = M a + h - J_B^T F_B, the thesis' eqs. 3.2.23-3.2.25), sampled at
the camera rate (60 Hz) as in the thesis. The forces are then given either in the lab
frame ("inertial-based") or the rod frame ("body-based", rotated by the measured angle)
and drive :func:`predgait.dynamics.forward.simulate_rod` from the measured initial
state. In exact arithmetic both reproduce the motion; sampling, interpolation and
integration errors make them deviate, and how the deviation grows is the experiment.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.dynamics.drivers import SampledHistory
from predgait.dynamics.forward import ForceFrame, RodForces
from predgait.models.loading import Model


@dataclass(frozen=True)
class RodTrial:
    """Synthetic rod trial sampled at ``rate``.

    Attributes:
        time: (n,) s.
        q: (n, 3) COM x, z (m) and pitch (rad); v, a likewise.
        top_force: (n, 2) lab X, Z force at the top, N.
        top_moment: (n,) N m about +Y.
        bottom_force: (n, 2) lab X, Z plate force on the bottom, N.
    """

    time: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    top_force: np.ndarray
    top_moment: np.ndarray
    bottom_force: np.ndarray

    def forces(self, frame: ForceFrame) -> RodForces:
        """End loads interpolated by cubic splines, expressed in ``frame``."""
        top, bottom = self.top_force, self.bottom_force
        if frame is ForceFrame.BODY:  # components on the rod axes at the measured angle
            c, s = np.cos(self.q[:, 2]), np.sin(self.q[:, 2])
            top = np.column_stack([top[:, 0] * c - top[:, 1] * s, top[:, 0] * s + top[:, 1] * c])
            bottom = np.column_stack([bottom[:, 0] * c - bottom[:, 1] * s,
                                      bottom[:, 0] * s + bottom[:, 1] * c])
        h = SampledHistory(self.time, np.column_stack([top, self.top_moment, bottom]),
                           name=f"rod forces ({frame.value})")
        return RodForces(top_force=lambda t: h(t)[0:2], top_moment=lambda t: h(t)[2],
                         bottom_force=lambda t: h(t)[3:5])


def _motion(t, d_b):
    """COM q, v, a (n, 3): bottom sliding x_b(t) on z = 0, angle theta(t)."""
    w1, w2 = 2 * np.pi * 0.8, 2 * np.pi * 0.5
    th, thd, thdd = (0.25 * np.sin(w1 * t), 0.25 * w1 * np.cos(w1 * t),
                     -0.25 * w1 ** 2 * np.sin(w1 * t))
    xb, xbd, xbdd = (0.08 * np.sin(w2 * t), 0.08 * w2 * np.cos(w2 * t),
                     -0.08 * w2 ** 2 * np.sin(w2 * t))
    s, c = np.sin(th), np.cos(th)
    x = xb + d_b * s
    z = d_b * c
    xd = xbd + d_b * c * thd
    zd = -d_b * s * thd
    xdd = xbdd + d_b * (c * thdd - s * thd ** 2)
    zdd = -d_b * (s * thdd + c * thd ** 2)
    return (np.column_stack([x, z, th]), np.column_stack([xd, zd, thd]),
            np.column_stack([xdd, zdd, thdd]))


def synthetic_rod_trial(model: Model, *, duration: float = 1.0, rate: float = 60.0,
                        noise: float = 0.0, seed: int = 0) -> RodTrial:
    """The synthetic trial: motion, plate force, top loads by inverse dynamics.

    Args:
        model: The rod.
        duration: s.
        rate: Sampling rate of the "measurements", Hz.
        noise: Standard deviation of Gaussian noise added to the top loads, N (N m).
        seed: RNG seed of the noise.
    """
    pm = model.pin_model
    data = pm.createData()
    d_b = -pm.frames[model.frame_id("bottom")].placement.translation[2]
    time = np.arange(0.0, duration + 0.5 / rate, 1.0 / rate)
    q, v, a = _motion(time, d_b)
    weight = pm.inertias[1].mass * model.gravity
    bottom = np.column_stack([0.1 * weight * np.sin(2 * np.pi * 0.5 * time),
                              weight * (0.7 + 0.1 * np.cos(2 * np.pi * 0.8 * time))])
    top, moment = np.zeros((time.size, 2)), np.zeros(time.size)
    top_id, bottom_id = model.frame_id("top"), model.frame_id("bottom")
    for k in range(time.size):
        tau = pin.rnea(pm, data, q[k], v[k], a[k]).copy()
        pin.computeJointJacobians(pm, data, q[k])
        pin.updateFramePlacements(pm, data)
        jb = pin.getFrameJacobian(pm, data, bottom_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        ja = pin.getFrameJacobian(pm, data, top_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        residual = tau - jb[[0, 2]].T @ bottom[k]
        w = np.linalg.solve(ja[[0, 2, 4]].T, residual)
        top[k], moment[k] = w[:2], w[2]
    if noise > 0:
        rng = np.random.default_rng(seed)
        top = top + rng.normal(0.0, noise, top.shape)
        moment = moment + rng.normal(0.0, noise, moment.shape)
    return RodTrial(time=time, q=q, v=v, a=a, top_force=top, top_moment=moment,
                    bottom_force=bottom)
