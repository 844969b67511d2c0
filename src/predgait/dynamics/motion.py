"""Prescribed motion of a model: sampled coordinates as splines, t -> (q, v, a).

The input the forward engine (:mod:`predgait.dynamics.partitioned`) follows for its
prescribed coordinates (gait7's joints and HAT, the whole body's pelvis and joints), and
a reference motion for feedback and fall limits.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from predgait.dynamics.drivers import SampledHistory
from predgait.errors import InputError
from predgait.models.loading import RigidBodyModel


class MotionHistory:
    """Sampled motion of every coordinate as splines: t -> (q (nq,), v (nv,), a (nv,)).

    Joint angles and the root position are cubic splines of the samples; a free-flyer
    orientation is splined as the rotation vector log3(R_0^T R) relative to the first
    sample and mapped back with exp3 (fine for the small pelvis rotations of walking).
    v and a are splines of the given velocity and acceleration samples (e.g. those
    :func:`predgait.dynamics.inverse3d.velocities` fed to inverse dynamics), so a
    prescribed coordinate moves exactly as inverse dynamics assumed at the samples.

    Args:
        model: The model (decides whether rows 3:7 are a quaternion).
        time: (n,) s. q: (n, nq). v, a: (n, nv).
    """

    def __init__(self, model: RigidBodyModel, time, q, v, a):
        pm = model.pin_model
        q, v, a = (np.asarray(x, dtype=float) for x in (q, v, a))
        if q.shape[1:] != (pm.nq,) or v.shape[1:] != (pm.nv,) or a.shape[1:] != (pm.nv,):
            raise InputError(f"motion history: expected q (n, {pm.nq}), v and a (n, {pm.nv}); "
                             f"got {q.shape}, {v.shape}, {a.shape}.")
        self.free_flyer = pm.nq != pm.nv
        self.time_range = (float(time[0]), float(time[-1]))
        if self.free_flyer:
            self._r0 = pin.Quaternion(q[0, 6], *q[0, 3:6]).normalized().toRotationMatrix()
            logs = np.array([pin.log3(self._r0.T @ pin.Quaternion(r[6], *r[3:6])
                                      .normalized().toRotationMatrix()) for r in q])
            samples = np.hstack([q[:, :3], logs, q[:, 7:]])
        else:
            samples = q
        self._q = SampledHistory(time, samples, name="prescribed coordinates")
        self._v = SampledHistory(time, v, name="prescribed velocities")
        self._a = SampledHistory(time, a, name="prescribed accelerations")

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, v, a) at t (s), new arrays."""
        row = self._q(t)
        if self.free_flyer:
            quat = pin.Quaternion(self._r0 @ pin.exp3(row[3:6])).coeffs()
            q = np.concatenate([row[:3], quat, row[6:]])
        else:
            q = row.copy()
        return q, self._v(t).copy(), self._a(t).copy()
