"""3D inverse kinematics: weighted least-squares fit of model marker frames to markers.

Per frame, minimise ``sum_i w_i |p_i(q) - m_i|^2`` over the configuration q (free-flyer
pelvis + 29 Cardan/hinge angles) by Levenberg-Marquardt: with the stacked marker
residual r and the frame Jacobians J (``LOCAL_WORLD_ALIGNED`` linear rows, w.r.t. the
velocity v), solve ``(J^T W J + lambda I) dv = -J^T W r`` with dv bounded so that
``q <- integrate(q, dv)`` stays within the joint limits (the quaternion stays on its
manifold; the one bounded solver of :mod:`predgait.kinematics.bounded_ik`, nothing
clipped after a step). Frames are warm-started from the previous solution; markers
missing in a frame (NaN) are left out of that frame. A frame that hits the iteration cap
without the step or the relative cost decrease falling below its tolerance, or that
ends on a joint limit the markers push against, is flagged and the run goes on. Marker
positions and Jacobians are computed for all markers at once from the joint placements
and ``data.J`` (see ``_Fitter``).

Output coordinates are the model's: the joint coordinates ARE the Cardan X-Y-Z angles
(thesis 2.3.2); :func:`pelvis_cardan` gives the pelvis orientation in the lab the same way.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.errors import InputError
from predgait.kinematics.bounded_ik import BoundedSolver, SolverOptions
from predgait.models.loading import new_data
from predgait.models.loading3d import Model3D


@dataclass(frozen=True)
class IKOptions:
    """Solver settings.

    Attributes:
        max_iterations: per frame (the first frame gets 5x).
        tolerance: stop when |dv| < tolerance (rad or m).
        cost_tolerance: or when a step lowers the cost by less than this fraction: weakly
            observed directions (an arm's axial rotation with the elbow straight) otherwise
            creep for tens of iterations while the fit changes by micrometres.
        damping: Levenberg-Marquardt lambda, m^2 (regularises unobserved directions).
        flag_rms: m; frames whose weighted marker RMS (:attr:`IKResult.weighted_rms`)
            exceeds it are flagged too.
        limit_margin: rad added to both ends of every joint range of the model.
    """

    max_iterations: int = 50
    tolerance: float = 1e-4
    damping: float = 1e-4
    flag_rms: float = 0.05
    cost_tolerance: float = 1e-4
    limit_margin: float = 0.0


@dataclass(frozen=True, eq=False)
class IKResult:
    """Inverse-kinematics solution.

    Attributes:
        time: (n,) s.
        q: (n, nq) configurations.
        marker_frames: model frames fitted, length m.
        marker_names: trial markers they were fitted to.
        residuals: (n, m) m, distance model-measured per marker (NaN if missing).
        rms: (n,) m, RMS marker distance per frame.
        iterations: (n,) iterations used.
        converged: (n,) bool; False for frames flagged (see ``failed_frames``).
        at_limit: (n, nv) bool, velocity coordinates held at a joint limit against the
            markers (such frames are flagged too).
        weights: (m,) the fit's weight of each marker (None: all 1).
    """

    time: np.ndarray
    q: np.ndarray
    marker_frames: tuple[str, ...]
    marker_names: tuple[str, ...]
    residuals: np.ndarray
    rms: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    at_limit: np.ndarray | None = None
    weights: np.ndarray | None = None

    def _weights(self) -> np.ndarray:
        return np.ones(len(self.marker_frames)) if self.weights is None else self.weights

    @property
    def weighted_rms(self) -> np.ndarray:
        """(n,) m: sqrt(sum w r^2 / sum w) over each frame's visible markers (flagging)."""
        return weighted_rms(self.residuals, self._weights())

    def trusted_rms(self, threshold: float = 0.5) -> np.ndarray:
        """(n,) m: RMS over the markers the fit weighs above ``threshold`` (NaN if none)."""
        trusted = self._weights() > threshold
        if not trusted.any():
            return np.full(self.time.size, np.nan)
        with np.errstate(invalid="ignore"):
            return np.sqrt(np.nanmean(self.residuals[:, trusted] ** 2, axis=1))

    @property
    def flagged(self) -> np.ndarray:
        """(n,) bool: frames flagged (not converged, marker RMS too large, on a limit)."""
        return ~self.converged

    @property
    def failed_frames(self) -> np.ndarray:
        """Indices of flagged frames."""
        return np.flatnonzero(~self.converged)


def weighted_rms(residuals: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(n,) sqrt(sum_i w_i r_i^2 / sum_i w_i) over the finite residuals (n, m) of each row."""
    seen = np.isfinite(residuals)
    w = np.where(seen, np.asarray(weights, dtype=float)[None, :], 0.0)
    total = np.where(seen, residuals, 0.0) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt((w * total).sum(axis=1) / w.sum(axis=1))


def pelvis_cardan(q: np.ndarray) -> np.ndarray:
    """Pelvis orientation as Cardan X-Y-Z angles (R = Rx Ry Rz), (n, 3) rad.

    The rotation matrix entries of the quaternion q[3:7] (x, y, z, w) as Eigen's
    ``Quaternion::toRotationMatrix`` forms them, for all frames at once.
    """
    q = np.atleast_2d(q)
    x, y, z, w = q[:, 3], q[:, 4], q[:, 5], q[:, 6]
    tx, ty, tz = 2.0 * x, 2.0 * y, 2.0 * z
    r00 = 1.0 - (ty * y + tz * z)
    r01 = ty * x - tz * w
    r02 = tz * x + ty * w
    r12 = tz * y - tx * w
    r22 = 1.0 - (tx * x + ty * y)
    return np.column_stack([np.arctan2(-r12, r22), np.arcsin(np.clip(r02, -1.0, 1.0)),
                            np.arctan2(-r01, r00)])


def coordinate_columns(q: np.ndarray, joint_names) -> dict[str, np.ndarray]:
    """The whole body's coordinates as storage columns: the one layout of kinematics3d.sto.

    ``pelvis_tx/ty/tz`` (m), the pelvis Cardan X-Y-Z angles ``pelvis_rx/ry/rz`` (deg,
    :func:`pelvis_cardan`) and every joint coordinate (deg), from q (n, 7 + n_joints)
    in Pinocchio's free-flyer layout. Write them with ``in_degrees=True``.
    """
    q = np.atleast_2d(q)
    cols = {f"pelvis_t{a}": q[:, i] for i, a in enumerate("xyz")}
    cols |= {f"pelvis_r{a}": np.degrees(c) for a, c in zip("xyz", pelvis_cardan(q).T,
                                                            strict=True)}
    return cols | {n: np.degrees(q[:, 7 + i]) for i, n in enumerate(joint_names)}


def _limits(model: Model3D, margin: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    pm = model.pin_model
    lower = np.array(pm.lowerPositionLimit, dtype=float) - margin
    upper = np.array(pm.upperPositionLimit, dtype=float) + margin
    lower[:7], upper[:7] = -np.inf, np.inf
    return lower, upper


def initial_pose(model: Model3D, frame_ids, targets: np.ndarray) -> np.ndarray:
    """Neutral posture moved rigidly onto the markers (Kabsch fit of all visible ones)."""
    pm, data = model.pin_model, new_data(model.pin_model)
    q = model.neutral()
    pin.framesForwardKinematics(pm, data, q)
    ok = np.isfinite(targets).all(axis=1)
    if ok.sum() < 3:
        raise InputError("inverse kinematics: fewer than 3 markers visible in the first frame.")
    model_pts = np.array([data.oMf[f].translation for f in frame_ids])[ok]
    pts = targets[ok]
    mc, tc = model_pts.mean(axis=0), pts.mean(axis=0)
    u, _, vt = np.linalg.svd((model_pts - mc).T @ (pts - tc))
    fix = np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))])
    rot = vt.T @ fix @ u.T
    q[:3] = tc - rot @ mc
    q[3:7] = pin.Quaternion(rot).coeffs()
    return q


def _lever_rows() -> tuple[np.ndarray, np.ndarray]:
    """(E (3, 18), C (18,)): a point p's rows [I | -[p]x] (3, 6), flattened, = p @ E + C.

    The linear velocity of a point p riding on a joint is v_O + omega x p = [I | -[p]x]
    (v_O, omega); -[p]x is linear in p, its column k is e_k x p. Every entry of these rows
    is 0, 1 or +-one coordinate of p, exactly.
    """
    eye = np.eye(3)
    e = np.zeros((3, 3, 6))
    for axis in range(3):   # the rows of the unit point e_axis
        e[axis, :, 3:] = np.cross(eye, eye[axis]).T
    return e.reshape(3, 18), np.hstack([eye, np.zeros((3, 3))]).reshape(18)


class _Fitter:
    """One frame's fit; marker positions and Jacobians vectorised over the markers.

    A marker frame rides on a joint's body at a fixed offset, so with the joint
    placements and the world-frame joint Jacobian ``data.J`` (``computeJointJacobians``)
    its position is p = R_j c + t_j and its linear Jacobian is J_lin + J_ang x p on the
    columns supporting joint j (the velocity of a point: v_O + omega x p). The weights,
    the supporting columns and the locked joints scale the Jacobian's rows and columns as
    one (3m, nv) factor; each pose evaluated keeps its points and weighted residual, so an
    accepted step's Jacobian reuses its residual's kinematics.
    """

    def __init__(self, model: Model3D, frame_ids, weights, options: IKOptions, free=None):
        pm = model.pin_model
        self.pm, self.data, self.options = pm, new_data(pm), options
        self.free = np.ones(pm.nv) if free is None else np.asarray(free, dtype=float)
        joint = np.array([pm.frames[f].parentJoint for f in frame_ids])
        joints, self.of_marker = np.unique(joint, return_inverse=True)
        self.joints = [int(j) for j in joints]
        # the placements' elements of data.oMi, which forward kinematics updates in place
        self.placements = [self.data.oMi[j] for j in self.joints]
        self.offset = np.array([pm.frames[f].placement.translation for f in frame_ids])
        m, n_joints = len(frame_ids), len(self.joints)
        # p = [R_j t_j] [c; 1]: every joint's placement times every offset is one product
        # (4 n_joints, m); marker i takes rows 4 j_i + (0, 1, 2) of column i
        self._homogeneous = np.vstack([self.offset.T, np.ones(m)])
        self._take = (4 * self.of_marker[:, None] + np.arange(3)) * m + np.arange(m)[:, None]
        self._rows = 4 * n_joints
        self._lever, self._identity = _lever_rows()
        self.support = np.zeros((len(joint), pm.nv), dtype=bool)
        for i, j in enumerate(joint):
            for s in pm.supports[int(j)][1:]:
                start = pm.joints[s].idx_v
                self.support[i, start:start + pm.joints[s].nv] = True
        self.w = np.repeat(np.sqrt(np.asarray(weights, dtype=float)), 3)
        # weight x supporting column x free coordinate, per Jacobian entry (3m, nv)
        self.scale = (np.repeat(self.support, 3, axis=0) * self.w[:, None]) * self.free
        lower, upper = _limits(model, options.limit_margin)
        self.solver = BoundedSolver(pm, lower, upper, SolverOptions(
            options.max_iterations, options.tolerance, options.cost_tolerance, options.damping))

    def points(self, q, *, jacobians: bool = False) -> np.ndarray:
        """(m, 3) marker-frame positions at q; with ``jacobians`` also data.J is updated."""
        pm, data = self.pm, self.data
        if jacobians:
            pin.computeJointJacobians(pm, data, q)
        else:
            pin.forwardKinematics(pm, data, q)
        placed = np.array([m.homogeneous for m in self.placements])
        return (placed.reshape(self._rows, 4) @ self._homogeneous).take(self._take)

    def jacobian(self, points: np.ndarray) -> np.ndarray:
        """(3m, nv) linear Jacobians of the marker frames (after ``points(jacobians=True)``).

        Each marker's rows [I | -[p]x] (3, 6) times the world-frame joint Jacobian data.J
        (6, nv), all markers as one product; unweighted and on every column (:attr:`scale`
        keeps the supporting ones).
        """
        lever = points @ self._lever + self._identity   # (m, 18)
        return lever.reshape(-1, 6) @ self.data.J

    def residual(self, q, targets):
        return self.points(q) - targets

    def solve(self, q, targets, max_iterations, *, cold=False):
        """Bounded Levenberg-Marquardt (:mod:`predgait.kinematics.bounded_ik`) on one frame."""
        seen = np.isfinite(targets).all(axis=1)
        ok = None if seen.all() else np.repeat(seen, 3)   # None: every marker seen
        w, scale = (self.w, self.scale) if ok is None else (self.w[ok], self.scale[ok])
        flat = targets.ravel() if ok is None else \
            np.where(np.isfinite(targets), targets, 0.0).ravel()[ok]
        last = [None, None, None]   # the last pose evaluated (the array itself), its points
        # and weighted residual; data.J is its

        def evaluate(qq):
            if last[0] is not qq:
                pts = self.points(qq, jacobians=True)
                rows = pts.ravel() if ok is None else pts.ravel()[ok]
                last[:] = qq, pts, w * (rows - flat)
            return last

        def residual(qq):
            return evaluate(qq)[2]

        def jacobian(qq):
            _, pts, r = evaluate(qq)
            jac = self.jacobian(pts)
            return r, (jac if ok is None else jac[ok]) * scale

        solver = self.solver
        fit = solver.solve(solver.project(q), residual, jacobian, max_iterations, cold=cold)
        res = evaluate(fit.q)[1] - targets
        return fit.q, np.linalg.norm(res, axis=1), fit.iterations, fit.converged, fit.at_limit


def solve_ik(model: Model3D, time: np.ndarray, xyz: np.ndarray,
             marker_frames: tuple[str, ...], *, marker_names: tuple[str, ...] | None = None,
             weights: Mapping[str, float] | None = None, q0: np.ndarray | None = None,
             locked: tuple[str, ...] = (), options: IKOptions | None = None) -> IKResult:
    """Fit the model's ``marker_frames`` to measured markers, frame by frame.

    Args:
        model: 3D model.
        time: (n,) s.
        xyz: (n, m, 3) m, lab frame, measured positions of the markers matched to
            ``marker_frames`` (same order); NaN where missing.
        marker_frames: model frame names, length m.
        marker_names: trial marker names (for reporting), defaults to the frame names.
        weights: frame name -> weight (default 1).
        q0: (nq,) start of the first frame; default: neutral posture at the markers.
        locked: joints held at their start value (e.g. the legs at 0 in a static trial).
        options: solver settings.

    Returns:
        IKResult (flagged frames are kept, with ``converged`` False).
    """
    options = options or IKOptions()
    xyz = np.asarray(xyz, dtype=float)
    if xyz.ndim != 3 or xyz.shape[1] != len(marker_frames) or xyz.shape[2] != 3:
        raise InputError(f"inverse kinematics: markers have shape {xyz.shape}; expected "
                         f"(n, {len(marker_frames)}, 3).")
    ids = [model.frame_id(f) for f in marker_frames]
    weights = dict(weights or {})
    unknown = set(weights) - set(marker_frames)
    if unknown:
        raise InputError(f"inverse kinematics: weights for unfitted frames "
                         f"{', '.join(sorted(unknown))}.")
    free = np.ones(model.nv)
    for name in locked:
        free[model.joint_velocity_index(name)] = 0.0
    fitter = _Fitter(model, ids, [weights.get(f, 1.0) for f in marker_frames], options, free)
    n = xyz.shape[0]
    q = initial_pose(model, ids, xyz[0]) if q0 is None else np.array(q0, dtype=float)
    qs = np.empty((n, model.nq))
    residuals = np.full((n, len(ids)), np.nan)
    iterations = np.zeros(n, dtype=int)
    converged = np.zeros(n, dtype=bool)
    at_limit = np.zeros((n, model.nv), dtype=bool)
    for k in range(n):  # the first frame from the rough start (5x the iterations)
        cap = options.max_iterations * (5 if k == 0 else 1)
        q, dist, iterations[k], converged[k], at_limit[k] = fitter.solve(
            q, xyz[k], cap, cold=k == 0 and q0 is None)
        qs[k] = q
        visible = np.isfinite(xyz[k]).all(axis=1)
        residuals[k, visible] = dist[visible]
    rms = np.sqrt(np.nanmean(residuals**2, axis=1))
    marker_weights = np.array([weights.get(f, 1.0) for f in marker_frames], dtype=float)
    # Flag on the error the fit minimises: markers it trusts little (arms at 0.2) do not
    # flag a frame whose trusted markers fit.
    converged &= (weighted_rms(residuals, marker_weights) <= options.flag_rms)
    converged &= ~at_limit.any(axis=1)
    return IKResult(time=np.asarray(time, dtype=float), q=qs, marker_frames=tuple(marker_frames),
                    marker_names=tuple(marker_names or marker_frames), residuals=residuals,
                    rms=rms, iterations=iterations, converged=converged, at_limit=at_limit,
                    weights=marker_weights)


def with_marker_frames(model: Model3D, placements: Mapping[str, tuple[str, np.ndarray]]
                       ) -> Model3D:
    """Copy of ``model`` with marker frames added or moved.

    Args:
        model: the model (not changed).
        placements: frame name -> (parent body frame name, (3,) position in that frame, m).
            An existing frame of that name is moved; a new one is added.
    """
    pm = pin.Model(model.pin_model)
    for name, (parent, xyz) in placements.items():
        parent_frame = pm.frames[model.frame_id(parent)]
        placement = parent_frame.placement * pin.SE3(np.eye(3), np.asarray(xyz, dtype=float))
        if pm.existFrame(name):
            fid = pm.getFrameId(name)
            frame = pm.frames[fid]
            frame.placement = placement
            frame.parentJoint = parent_frame.parentJoint
            pm.frames[fid] = frame
        else:
            pm.addFrame(pin.Frame(name, parent_frame.parentJoint, model.frame_id(parent),
                                  placement, pin.FrameType.OP_FRAME))
    return Model3D(urdf=model.urdf, kind=model.kind, pin_model=pm, gravity=model.gravity,
                   source=f"{model.source}, calibrated marker frames")


def marker_placements(model: Model3D, frames) -> dict[str, tuple[str, np.ndarray]]:
    """Frame name -> (its body, (3,) position in that body's frame, m).

    The model's (e.g. calibrated) marker frames as :func:`with_marker_frames` and a URDF
    take them.
    """
    pm = model.pin_model
    out = {}
    for name in frames:
        body = body_of(model, name)
        rel = pm.frames[model.frame_id(body)].placement.inverse() * \
            pm.frames[model.frame_id(name)].placement
        out[name] = (body, np.array(rel.translation))
    return out


def body_of(model: Model3D, frame: str) -> str:
    """Name of the body (link) frame a frame is attached to (its parent joint's body)."""
    pm = model.pin_model
    joint = pm.frames[model.frame_id(frame)].parentJoint
    for f in pm.frames:
        if f.parentJoint == joint and f.type == pin.FrameType.BODY:
            return f.name
    raise InputError(f"frame {frame!r} has no body.")


def calibrate_markers(model: Model3D, q: np.ndarray, xyz: np.ndarray,
                      frames: tuple[str, ...], segments: Mapping[str, str]) -> Model3D:
    """Move marker frames to the measured markers, averaged over calibration frames.

    Args:
        model: model whose body placement the poses ``q`` describe.
        q: (n, nq) poses (e.g. IK of a static trial or of the first frames).
        xyz: (n, m, 3) m, measured markers, ``frames[i]`` <-> ``xyz[:, i]``.
        frames: frame names to place (existing or new).
        segments: frame -> body frame it rides on (for frames not yet in the model).

    Returns:
        Model with each frame at the mean position of its marker in its body frame.
    """
    pm, data = model.pin_model, new_data(model.pin_model)
    parents = {f: segments.get(f) or body_of(model, f) for f in frames}
    sums = {f: np.zeros(3) for f in frames}
    counts = dict.fromkeys(frames, 0)
    for k in range(q.shape[0]):
        pin.framesForwardKinematics(pm, data, q[k])
        for i, f in enumerate(frames):
            if np.isfinite(xyz[k, i]).all():
                sums[f] += data.oMf[model.frame_id(parents[f])].actInv(xyz[k, i])
                counts[f] += 1
    missing = [f for f in frames if counts[f] == 0]
    if missing:
        raise InputError(f"marker calibration: no frame shows the markers for "
                         f"{', '.join(missing)}.")
    return with_marker_frames(model, {f: (parents[f], sums[f] / counts[f]) for f in frames})
