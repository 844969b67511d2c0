"""One bounded least-squares solver for inverse kinematics (planar leg and 3D body).

Each frame minimises ``|r(q)|^2`` (weighted marker or joint-centre residuals) over the
configuration q by Levenberg-Marquardt on the tangent space: the increment dv solves

    min |J dv + r|^2 + lambda |dv|^2   subject to   lower - q <= dv <= upper - q

on the coordinates that have joint limits, and ``q <- pin.integrate(q, dv)``. The
bounds sit on the increment, so every iterate lies inside the joint ranges and nothing
is clipped after a step (a clipped Gauss-Newton step is not a descent step and stalls
at the limit without converging). The box-constrained subproblem is solved in closed
form when the free step is feasible, else by bounded-variable least squares
(Stark & Parker 1995, Comput Stat 10:129-141; ``scipy.optimize.lsq_linear``).
With damping 0 (the planar leg: three points and a pitch for five coordinates) the steps
are bounded Gauss-Newton steps, each taken.

A frame is *flagged* when it did not converge or when it ends on a joint limit that
the data push against (the KKT multiplier of the bound is positive): the model cannot
follow the markers there, and the frame's results are not presented as results.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.numerics.lsq import bounded_step

try:   # np.linalg.solve's own LAPACK gufunc without its wrapping (half the time a call)
    from numpy.linalg._umath_linalg import solve1 as _solve1
except ImportError:  # pragma: no cover - a NumPy without it
    _solve1 = None

#: A joint coordinate closer than this to its limit (rad or m) counts as on the limit.
ON_LIMIT = 1e-7
#: Initial Levenberg-Marquardt damping of a cold start, relative to max diag(J^T J)
#: (Madsen et al. 2004: 1e-3 when the start is believed far from the solution).
COLD_DAMPING = 1e-3


@dataclass(frozen=True)
class SolverOptions:
    """Levenberg-Marquardt settings.

    Attributes:
        max_iterations: iterations per frame.
        tolerance: converged when |dv| < tolerance (rad or m).
        cost_tolerance: or when a step lowers the cost by less than this fraction.
        damping: smallest Levenberg-Marquardt lambda (the damping adapts upward); 0
            gives bounded Gauss-Newton (every step taken, for well-posed small fits).
    """

    max_iterations: int = 50
    tolerance: float = 1e-4
    cost_tolerance: float = 1e-4
    damping: float = 1e-4


@dataclass(frozen=True)
class FrameSolution:
    """One frame's fit.

    Attributes:
        q: (nq,) configuration.
        iterations: iterations used.
        converged: step or cost change fell below its tolerance.
        at_limit: (nv,) bool, coordinates held at a joint limit against the data.
    """

    q: np.ndarray
    iterations: int
    converged: bool
    at_limit: np.ndarray


def velocity_bounds(model: pin.Model, lower: np.ndarray, upper: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Map position limits onto the tangent space.

    Returns:
        (q index, lower, upper) per velocity coordinate (nv,): for a one-coordinate
        joint (revolute, prismatic, a planar root's components) the index of its
        position coordinate; -1 (unbounded) for joints whose nq != nv (free flyer).
    """
    index = np.full(model.nv, -1)
    lo, hi = np.full(model.nv, -np.inf), np.full(model.nv, np.inf)
    for joint in model.joints[1:]:
        if joint.nq != joint.nv:
            continue
        for i in range(joint.nv):
            qi, vi = joint.idx_q + i, joint.idx_v + i
            index[vi] = qi
            lo[vi], hi[vi] = lower[qi], upper[qi]
    return index, lo, hi


def _normal(jac: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(J^T J, -J^T r): the normal equations of the linearised least squares."""
    return jac.T @ jac, -jac.T @ r


def _singular(*_) -> None:
    raise np.linalg.LinAlgError("Singular matrix")


def _solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a^-1 b for square float64 ``a`` and vector ``b``, as ``np.linalg.solve``.

    Its gufunc (LAPACK's gesv), numbers and singular-matrix error, without its argument
    checks.
    """
    if _solve1 is None:  # pragma: no cover
        return np.linalg.solve(a, b)
    with np.errstate(call=_singular, invalid="call", over="ignore", divide="ignore",
                     under="ignore"):
        return _solve1(a, b)


def _norm(x: np.ndarray) -> float:
    """Euclidean norm of a vector (sqrt(x . x), as np.linalg.norm computes it)."""
    return math.sqrt(x @ x)


def _as_slice(index: np.ndarray) -> np.ndarray | slice:
    """``index`` as a slice when it is a run of consecutive indices (the same selection)."""
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return slice(int(index[0]), int(index[0]) + index.size)
    return index


class BoundedSolver:
    """Bounded Levenberg-Marquardt for one model (see module docstring).

    Args:
        model: Pinocchio model (its ``integrate`` moves q along dv).
        lower, upper: (nq,) position limits; +-inf where unbounded.
        options: solver settings.
    """

    def __init__(self, model: pin.Model, lower: np.ndarray, upper: np.ndarray,
                 options: SolverOptions):
        self.model, self.options = model, options
        self.index, self.vlo, self.vhi = velocity_bounds(model, lower, upper)
        self.bounded = self.index >= 0
        self._v = np.flatnonzero(self.bounded)           # bounded velocity coordinates
        self._q = self.index[self._v]                    # their position coordinates
        self._lo, self._hi = self.vlo[self._v], self.vhi[self._v]
        self._v, self._q = _as_slice(self._v), _as_slice(self._q)   # views where they can
        self._identity = np.eye(model.nv)

    def project(self, q: np.ndarray) -> np.ndarray:
        """A start point inside the limits (only for a first guess, never after a step).

        ``q``: (nq,) or (n, nq), one start per row.
        """
        q = np.array(q, dtype=float)
        qi = self.index[self.bounded]
        q[..., qi] = np.clip(q[..., qi], self.vlo[self.bounded], self.vhi[self.bounded])
        return q

    def _step(self, jac: np.ndarray, r: np.ndarray, damping: float, q: np.ndarray,
              normal: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """The bounded increment at q (closed form when the free step stays inside).

        ``normal``: (J^T J, -J^T r) of this ``jac`` and ``r`` when already formed (the
        damped steps tried at one point share them; the same numbers as forming them here).
        """
        if damping > 0:
            hessian, gradient = normal if normal is not None else _normal(jac, r)
            step = _solve(hessian + damping * self._identity, gradient)   # J^T J + damping I
        else:
            step = np.linalg.lstsq(jac, -r, rcond=None)[0]
        moved = q[self._q] + step[self._v]
        if not ((moved < self._lo) | (moved > self._hi)).any():
            return step
        return bounded_step(jac, r, damping, *self._increment_bounds(q))

    def _increment_bounds(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = np.full(self.model.nv, -np.inf), np.full(self.model.nv, np.inf)
        qi = q[self.index[self.bounded]]
        lo[self.bounded] = self.vlo[self.bounded] - qi
        hi[self.bounded] = self.vhi[self.bounded] - qi
        return lo, hi

    def solve(self, q: np.ndarray, residual: Callable[[np.ndarray], np.ndarray],
              jacobian: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
              max_iterations: int | None = None, *, cold: bool = False) -> FrameSolution:
        """Fit one frame from the feasible start ``q``.

        Args:
            q: (nq,) start inside the limits (the previous frame, or :meth:`project`).
            residual: q -> (m,) weighted residual.
            jacobian: q -> ((m,) residual, (m, nv) its Jacobian w.r.t. the velocity).
            max_iterations: overrides the options' cap.
            cold: ``q`` is a rough guess, far from the fit (the first frame): the damping
                starts at :data:`COLD_DAMPING` times the largest diagonal entry of J^T J
                (Madsen, Nielsen & Tingleff 2004, Methods for non-linear least squares
                problems, eq. 3.14) and adapts down from there, instead of a nearly
                Gauss-Newton first step that overshoots to a joint limit.
        """
        opts = self.options
        cap = max_iterations or opts.max_iterations
        r, jac = jacobian(q)
        lam = opts.damping
        if cold and lam > 0:
            lam = max(lam, COLD_DAMPING * float(np.max(np.sum(jac * jac, axis=0))))
        cost = float(r @ r)
        converged, it = False, 0
        model, integrate = self.model, pin.integrate
        for it in range(1, cap + 1):  # noqa: B007 - the count is kept
            if opts.damping == 0:   # Gauss-Newton: every (bounded) step is taken
                step = self._step(jac, r, 0.0, q)
                q = pin.integrate(self.model, q, step)
                if np.linalg.norm(step) < opts.tolerance:
                    converged = True
                    break
                r, jac = jacobian(q)
                continue
            normal = _normal(jac, r)   # shared by the damped steps tried at q
            for _ in range(12):
                step = self._step(jac, r, lam, q, normal)
                trial = integrate(model, q, step)
                r_new = residual(trial)
                cost_new = float(r_new @ r_new)
                if cost_new <= cost:
                    lam = max(lam / 3.0, opts.damping)
                    break
                lam *= 4.0
            else:  # no step lowers the cost: at the minimum to rounding
                converged = bool(_norm(step) < 1e3 * opts.tolerance)
                break
            previous = cost
            q, cost = trial, cost_new
            if (_norm(step) < opts.tolerance
                    or previous - cost <= opts.cost_tolerance * previous):
                converged = True
                break
            r, jac = jacobian(q)
        at_limit = np.zeros(self.model.nv, dtype=bool)
        near = (q[self._q] - self._lo < ON_LIMIT) | (self._hi - q[self._q] < ON_LIMIT)
        if near.any():   # only then the gradient tells whether the data push outward
            r, jac = jacobian(q)
            at_limit = self.limits_held(q, jac.T @ r)
        return FrameSolution(q, it, converged, at_limit)

    def solve_frames(self, q: np.ndarray,
                     jacobian: Callable[[int, np.ndarray], tuple[np.ndarray, np.ndarray]],
                     batch: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
                     | None = None) -> list[FrameSolution]:
        """Bounded Gauss-Newton (damping 0) on independent frames, iterated together.

        Each frame takes the steps :meth:`solve` takes with damping 0 from its own start;
        the free steps of all frames still iterating are solved as one batch of normal
        equations (J^T J dv = -J^T r), a step that would leave the joint ranges by the
        bounded subproblem of that frame.

        Args:
            q: (n, nq) feasible starts, one per frame.
            jacobian: (frame index, q) -> ((m,) residual, (m, nv) its Jacobian).
            batch: optional, the same for many frames at once: (frame indices (k,),
                q (k, nq)) -> ((k, m) residuals, (k, m, nv) Jacobians).
        """
        if self.options.damping != 0:
            raise ValueError("solve_frames is Gauss-Newton: SolverOptions.damping must be 0")
        q = np.array(q, dtype=float)
        n = len(q)
        iterations = np.zeros(n, dtype=int)
        converged = np.zeros(n, dtype=bool)
        active = np.arange(n)
        for it in range(1, self.options.max_iterations + 1):
            if not active.size:
                break
            if batch is not None:
                r, jac = batch(active, q[active])
            else:
                pairs = [jacobian(k, q[k]) for k in active]
                r = np.stack([pair[0] for pair in pairs])
                jac = np.stack([pair[1] for pair in pairs])
            jac_t = np.swapaxes(jac, 1, 2)
            step = -np.linalg.solve(jac_t @ jac, (jac_t @ r[:, :, None]))[:, :, 0]
            moved = q[active][:, self._q] + step[:, self._v]
            for i in np.flatnonzero(((moved < self._lo) | (moved > self._hi)).any(axis=1)):
                step[i] = bounded_step(jac[i], r[i], 0.0, *self._increment_bounds(q[active[i]]))
            for i, k in enumerate(active):
                q[k] = pin.integrate(self.model, q[k], step[i])
            iterations[active] = it
            done = np.linalg.norm(step, axis=1) < self.options.tolerance
            converged[active[done]] = True
            active = active[~done]
        out = []
        for k in range(n):
            at_limit = np.zeros(self.model.nv, dtype=bool)
            near = (q[k, self._q] - self._lo < ON_LIMIT) | (self._hi - q[k, self._q] < ON_LIMIT)
            if near.any():
                r, jac = jacobian(k, q[k])
                at_limit = self.limits_held(q[k], jac.T @ r)
            out.append(FrameSolution(q[k], int(iterations[k]), bool(converged[k]), at_limit))
        return out

    def limits_held(self, q: np.ndarray, gradient: np.ndarray) -> np.ndarray:
        """(nv,) coordinates on a limit whose cost gradient points out of the range."""
        lo, hi = self._increment_bounds(q)
        scale = 1e-9 * max(1.0, float(np.abs(gradient).max()))
        return ((lo > -ON_LIMIT) & (gradient > scale)) | ((hi < ON_LIMIT) & (gradient < -scale))


def frames_near(flags: np.ndarray, reach: int) -> np.ndarray:
    """(n,) bool: frames within ``reach`` frames of a flagged one (inclusive)."""
    flags = np.asarray(flags, dtype=bool)
    out = flags.copy()
    for shift in range(1, reach + 1):
        out[shift:] |= flags[:-shift]
        out[:-shift] |= flags[shift:]
    return out
