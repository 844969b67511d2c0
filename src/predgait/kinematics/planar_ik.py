"""Least-squares inverse kinematics of the planar leg onto measured points.

Each frame solves min_q sum_i w_i |p_i(q) - m_i|^2 + w_f (pitch(q) - pitch_m)^2 over the
leg coordinates (ankle position, foot pitch, ankle, knee) within the joint ranges, by
bounded Gauss-Newton steps (:mod:`predgait.kinematics.bounded_ik`, damping 0) with the
Pinocchio frame Jacobians, each frame started from its segment directions
(:func:`initial_guess`), all frames iterated together. The points are the
model's joint-centre frames (``ankle_center``, ``knee_center``, ``hip_center``) in the
sagittal (X, Z) plane; the foot pitch comes from the heel-toe marker line. The result is
hinge-consistent by construction (the thesis' "hinge constraints imposed before the
indirect problem", section 3.3.3); the residuals tell how far the rigid model is from
the measured joint centres.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.kinematics.bounded_ik import BoundedSolver, SolverOptions
from predgait.models.loading import Model, new_data

POINTS = ("ankle_center", "knee_center", "hip_center")


@dataclass(frozen=True)
class IKResult:
    """Leg coordinates per frame and how well they fit.

    Attributes:
        q: (n, nq) coordinates, rad and m.
        residuals: point name -> (n,) distance model-to-measured in the plane, m.
        pitch_residual: (n,) foot pitch error, rad.
        iterations: (n,) Gauss-Newton iterations used.
        converged: (n,) bool.
        at_limit: (n, nv) bool, coordinates held at a joint limit against the data.
        coordinate_names: names of the columns of ``q`` and ``at_limit``.
    """

    q: np.ndarray
    residuals: Mapping[str, np.ndarray]
    pitch_residual: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    at_limit: np.ndarray
    coordinate_names: tuple[str, ...] = ()

    @property
    def flagged(self) -> np.ndarray:
        """(n,) bool: frames that did not converge or end on a joint limit."""
        return ~self.converged | self.at_limit.any(axis=1)

    def limited_coordinates(self) -> dict[str, int]:
        """Coordinate name -> number of frames held at one of its limits."""
        return {name: int(self.at_limit[:, i].sum())
                for i, name in enumerate(self.coordinate_names) if self.at_limit[:, i].any()}

    def rms(self) -> dict[str, float]:
        """RMS residual per point, m."""
        return {name: float(np.sqrt(np.mean(r**2))) for name, r in self.residuals.items()}


def initial_guess(model: Model, points: Mapping[str, np.ndarray], pitch) -> np.ndarray:
    """Coordinates from the segment directions (absolute angles).

    ``points``: name -> (3,) or (n, 3) positions; ``pitch``: scalar or (n,): one frame's
    (nq,) coordinates, or every frame's (n, nq).
    """
    def angle(upper, lower):
        d = np.asarray(upper) - np.asarray(lower)
        return np.arctan2(d[..., 0], d[..., 2])

    shank = angle(points["knee_center"], points["ankle_center"])
    thigh = angle(points["hip_center"], points["knee_center"])
    ankle = np.asarray(points["ankle_center"])
    return np.stack([ankle[..., 0], ankle[..., 2], np.broadcast_to(pitch, shank.shape),
                     shank - pitch, thigh - shank], axis=-1)


def joint_limits(model: Model, *, margin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(nq,) position limits of the leg: the model's joint ranges widened by ``margin`` (rad).

    The base (ankle position, foot pitch) is unbounded.
    """
    pm = model.pin_model
    lower = np.array(pm.lowerPositionLimit, dtype=float)
    upper = np.array(pm.upperPositionLimit, dtype=float)
    lower[:model.n_base], upper[:model.n_base] = -np.inf, np.inf
    return lower - margin, upper + margin


class _FramesJacobian:
    """The weighted residuals and Jacobians of many frames at once (``solve_frames``' batch).

    Per frame one ``computeJointJacobians``; the points' positions (p = R_j c + t_j) and
    their LOCAL_WORLD_ALIGNED Jacobians (v - p x omega on the columns supporting joint j,
    as ``getFrameJacobian`` forms them) for all frames and points as array operations.
    """

    def __init__(self, model: Model, ids, weight, sagittal, pitch_row, pitch_weight,
                 foot_pitch):
        pm = model.pin_model
        self.pm, self.data = pm, new_data(pm)
        parents = [pm.frames[f].parentJoint for f in ids]
        joints, self.of_point = np.unique(parents, return_inverse=True)
        self.placements = [self.data.oMi[int(j)] for j in joints]   # updated in place
        self.offset = np.array([pm.frames[f].placement.translation for f in ids])   # (p, 3)
        self.support = np.zeros((len(ids), pm.nv), dtype=bool)
        for i, j in enumerate(parents):
            for s in pm.supports[j][1:]:
                self.support[i, pm.joints[s].idx_v:pm.joints[s].idx_v + pm.joints[s].nv] = True
        self.weight = np.asarray(weight, dtype=float)[None, :, None]
        self.targets = np.stack(sagittal, axis=1)   # (n, p, 2)
        self.pitch_row, self.pitch_weight = pitch_row[0], pitch_weight
        self.foot_pitch = np.asarray(foot_pitch, dtype=float)

    def points(self, qs: np.ndarray, world: np.ndarray | None = None) -> np.ndarray:
        """(n, p, 3) lab positions of the points at the frames' q (n, nq).

        ``world``: (n, 6, nv) to fill with each frame's data.J as well.
        """
        pm, data = self.pm, self.data
        placed = np.empty((len(qs), len(self.placements), 4, 4))
        for i, q in enumerate(qs):
            if world is None:
                pin.forwardKinematics(pm, data, q)
            else:
                pin.computeJointJacobians(pm, data, q)
                world[i] = data.J
            for j, placement in enumerate(self.placements):
                placed[i, j] = placement.homogeneous
        placed = placed[:, self.of_point]   # (n, p, 4, 4)
        rot, c = placed[..., :3, :3], self.offset
        return rot[..., 0] * c[:, 0, None] + rot[..., 1] * c[:, 1, None] \
            + rot[..., 2] * c[:, 2, None] + placed[..., :3, 3]

    def __call__(self, ks: np.ndarray, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pm = self.pm
        n, count = len(ks), len(self.offset)
        world = np.empty((n, 6, pm.nv))
        points = self.points(qs, world)
        lin, ang = world[:, None, :3], world[:, None, 3:]   # (n, 1, 3, nv)
        p = points[..., None]   # (n, p, 3, 1)
        cross = np.stack([p[:, :, 1] * ang[:, :, 2] - p[:, :, 2] * ang[:, :, 1],
                          p[:, :, 2] * ang[:, :, 0] - p[:, :, 0] * ang[:, :, 2],
                          p[:, :, 0] * ang[:, :, 1] - p[:, :, 1] * ang[:, :, 0]], axis=2)
        frame = np.where(self.support[None, :, None, :], lin - cross, 0.0)   # (n, p, 3, nv)
        w = self.weight
        rows = np.empty((n, 2 * count + 1))
        rows[:, :-1] = (w * (points[..., ::2] - self.targets[ks])).reshape(n, -1)
        rows[:, -1] = self.pitch_weight * (qs[:, 2] - self.foot_pitch[ks])
        jac = np.empty((n, 2 * count + 1, pm.nv))
        jac[:, :-1] = (w[..., None] * frame[:, :, ::2]).reshape(n, -1, pm.nv)
        jac[:, -1] = self.pitch_row
        return rows, jac


def solve_ik(model: Model, points: Mapping[str, np.ndarray], foot_pitch: np.ndarray, *,
             weights: Mapping[str, float] | None = None, pitch_weight: float = 0.1,
             tolerance: float = 1e-10, max_iterations: int = 30,
             limit_margin: float = 0.0) -> IKResult:
    """Fit the leg to joint centres (n, 3) and a foot pitch (n,) in every frame.

    The fit is bounded by the model's joint ranges (:mod:`predgait.kinematics.bounded_ik`);
    frames that end on a limit the data push against, or do not converge, are flagged.

    Args:
        model: The leg.
        points: Frame name -> (n, 3) measured position, lab frame, m.
        foot_pitch: (n,) measured foot pitch, rad.
        weights: Per-point weights (default 1).
        pitch_weight: Weight of the pitch residual, m/rad (0.1: 1 deg ~ 1.7 mm).
        tolerance: Step size (norm) at which a frame counts as converged.
        max_iterations: Iterations per frame.
        limit_margin: rad added to both ends of every joint range.
    """
    pm = model.pin_model
    data = new_data(pm)
    names = [n for n in POINTS if n in points]
    weight = np.array([(weights or {}).get(n, 1.0) for n in names])
    ids = [model.frame_id(n) for n in names]
    plane = slice(0, 3, 2)  # the sagittal X, Z rows (a view, not a fancy-index copy)
    sagittal = [np.asarray(points[n])[:, plane] for n in names]  # (n, 2) per point
    lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    pitch_row = np.zeros((1, pm.nv))
    pitch_row[0, 2] = pitch_weight
    jac_rows = np.vstack([np.zeros((2 * len(names), pm.nv)), pitch_row])  # pitch row fixed

    def jacobian(k: int, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residual and its Jacobian of frame k at q."""
        pin.computeJointJacobians(pm, data, q)
        pin.updateFramePlacements(pm, data)
        rows, jac = np.empty(2 * len(names) + 1), jac_rows.copy()
        for i, (w, fid, target) in enumerate(zip(weight, ids, sagittal, strict=True)):
            rows[2 * i: 2 * i + 2] = w * (data.oMf[fid].translation[plane] - target[k])
            jac[2 * i: 2 * i + 2] = w * pin.getFrameJacobian(pm, data, fid, lwa)[plane]
        rows[-1] = pitch_weight * (q[2] - foot_pitch[k])
        return rows, jac

    batch = _FramesJacobian(model, ids, weight, sagittal, pitch_row, pitch_weight, foot_pitch)
    lower, upper = joint_limits(model, margin=limit_margin)
    settings = SolverOptions(max_iterations=max_iterations, tolerance=tolerance,
                             cost_tolerance=0.0, damping=0.0)
    solver = BoundedSolver(pm, lower, upper, settings)
    starts = solver.project(initial_guess(model, {n: points[n] for n in POINTS},
                                          np.asarray(foot_pitch, dtype=float)))
    fits = solver.solve_frames(starts, jacobian, batch)
    out = np.array([fit.q for fit in fits])
    resid = np.linalg.norm(batch.points(out)[..., ::2] - batch.targets, axis=2)
    return IKResult(out, {n: resid[:, i] for i, n in enumerate(names)},
                    out[:, 2] - np.asarray(foot_pitch),
                    np.array([fit.iterations for fit in fits]),
                    np.array([fit.converged for fit in fits]),
                    np.array([fit.at_limit for fit in fits]).reshape(len(fits), pm.nv),
                    tuple(model.coordinate_names))
