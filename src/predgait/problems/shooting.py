"""Stabilising spring-dampers for the re-synthesis, fitted by multiple shooting.

The thesis' question (Fig. 4.2.9): which passive elements, ADDED to the measured
(inverse-dynamics) moments, keep the synthesized motion near the measured one? The
leg (foot prescribed, thigh and shank free, hip load as measured; the engine's
equations, :func:`predgait.problems.collocation.free_dynamics`) is driven by

    tau = tau_ID(t) + tau_passive(theta, theta'; p)

(clinical angles and moments, :mod:`predgait.problems.passive_model`; the knee's
anatomical angle, as in the decomposition fit). The trial is cut into shooting intervals
of one or a few samples, each shorter than the unstable time constant of the driven leg
in stance (1 / lambda ~ 25 ms, lambda ~ 35-39 /s), and each interval is simulated from
the MEASURED state at its start (classical RK4 with ``step_s``). p minimises

    sum_intervals w sum_joints ((theta_sim(end) - theta_measured(end)) / sigma_j)^2
    + sum_priors ((p - mean) / sd)^2,

with w = 1 / m (m intervals per correlation time of the data, 1 / (2 f_c)) and sigma_j
the residual SD of a first pass, so that the objective is twice a negative
log-likelihood and J^T W J (J = d residuals / d p, Gauss-Newton) is the Fisher
information. No continuity is imposed between intervals: with continuity the optimum is
the single-shooting one over the whole trial, whose sensitivities grow like
exp(lambda T) (the ill-conditioned ``knee_fit``); restarting every interval keeps each
sensitivity of order one, so the fit is well conditioned and its intervals mean
something.

What the result is: the spring-damper the re-synthesis needs on top of the measured
moments, i.e. the part of the moments' inconsistency with the model that looks like a
spring-damper. These are stabilising elements, not tissue properties (the measured
moments already contain the tissue's passive moment; see
:mod:`predgait.problems.decomposition` for that). On data that are consistent with the
model the answer is zero.
"""

from __future__ import annotations

import functools
import time as clock
from dataclasses import dataclass, field

import numpy as np

from predgait.dynamics.drivers import LegDrivers
from predgait.errors import InputError, SolveFailed
from predgait.kinematics.clinical import clinical_joint
from predgait.problems.decomposition import Bootstrap, resampling_units
from predgait.problems.gait_samples import GaitSamples
from predgait.problems.passive_model import PassiveModel

#: Rows of the inputs of one RK4 point: base q, v, a (3 each), ankle and knee torque
#: (model sign), hip F_x, F_z, M_y.
INPUT_ROWS = 14
#: Largest shooting interval allowed, s (below 1 / lambda of the driven leg in stance).
MAX_INTERVAL_S = 0.025


@dataclass(frozen=True)
class ShootingSettings:
    """Options of the multiple-shooting fit.

    Attributes:
        interval_s: Longest shooting interval, s (<= 25 ms); each interval spans the
            largest whole number of samples (at least one) that fits.
        step_s: RK4 step inside an interval, s.
        max_iter: Ipopt iterations.
    """

    interval_s: float = 0.02
    step_s: float = 0.01
    max_iter: int = 200


@dataclass(frozen=True, eq=False)
class Intervals:
    """The shooting intervals of a trial, with the measured data they need.

    Attributes:
        start: (n,) sample index where each interval starts.
        stride: Samples per interval.
        length_s: Interval length, s.
        substeps: RK4 steps per interval.
        x0: (n, 4) measured free state at the start (ankle, knee, rates; model coordinates).
        end: (n, 2) measured ankle and knee angles at the end (model coordinates), rad.
        inputs: (n, INPUT_ROWS, 2 substeps + 1) drive at the RK4 points.
        knee_offset: Static-trial knee flexion, rad (anatomical = clinical - offset).
        correlation_intervals: Intervals per correlation time of the data, m >= 1.
    """

    start: np.ndarray
    stride: int
    length_s: float
    substeps: int
    x0: np.ndarray
    end: np.ndarray
    inputs: np.ndarray
    knee_offset: float
    correlation_intervals: float

    @classmethod
    def from_inverse(cls, inverse, samples: GaitSamples,
                     settings: ShootingSettings = ShootingSettings()) -> Intervals:
        """Intervals over every gait cycle of the trial (samples with a cycle index).

        Intervals touching a flagged (NaN) frame are left out.

        Raises:
            InputError: An interval longer than 25 ms would be needed (sampling too
                slow), or fewer intervals than 3 per fitted parameter remain.
        """
        dt = float(np.median(np.diff(inverse.time)))
        if settings.interval_s > MAX_INTERVAL_S + 1e-12:
            raise InputError(f"shooting.interval_s = {settings.interval_s:g} s: keep shooting "
                             f"intervals at most {MAX_INTERVAL_S * 1e3:g} ms (the driven leg's "
                             "unstable time constant).")
        if dt > MAX_INTERVAL_S + 1e-12:
            raise InputError(f"{samples.source or 'the trial'}: samples {dt * 1e3:.1f} ms apart "
                             f"exceed the {MAX_INTERVAL_S * 1e3:g} ms shooting interval; "
                             "resample the trial faster.")
        stride = max(1, int(np.floor(settings.interval_s / dt + 1e-9)))
        length = stride * dt
        substeps = max(1, int(np.ceil(length / settings.step_s - 1e-9)))
        drivers = LegDrivers.from_inverse(inverse)
        q, qd = np.asarray(inverse.q), np.asarray(inverse.qd)
        finite = np.isfinite(q).all(axis=1) & np.isfinite(qd).all(axis=1)
        valid = (samples.cycle >= 0) & finite
        starts = np.array([i for i in range(0, len(inverse.time) - stride, stride)
                           if valid[i:i + stride + 1].all()], dtype=int)
        offsets = np.linspace(0.0, length, 2 * substeps + 1)
        inputs = np.empty((starts.size, INPUT_ROWS, offsets.size))
        for k, i in enumerate(starts):
            for j, dt_j in enumerate(offsets):
                t = inverse.time[i] + dt_j
                hip_f, hip_m = drivers.hip_force(t), drivers.hip_moment(t)
                inputs[k, :, j] = np.concatenate([
                    drivers.prescribed_q(t), drivers.prescribed_qd(t),
                    drivers.prescribed_qdd(t), drivers.joint_torque(t),
                    [hip_f[0], hip_f[2], hip_m[1]]])
        return cls(start=starts, stride=stride, length_s=length, substeps=substeps,
                   x0=np.column_stack([q[starts, 3:5], qd[starts, 3:5]]),
                   end=q[starts + stride, 3:5], inputs=inputs,
                   knee_offset=float(getattr(inverse, "knee_static", 0.0)),
                   correlation_intervals=max(1.0, samples.correlation_time / length))

    def __len__(self) -> int:
        return int(self.start.size)


@dataclass(frozen=True, eq=False)
class ShootingFit:
    """A fitted set of stabilising elements.

    Attributes:
        values: key -> value of every parameter (fitted and fixed), SI.
        z: (f,) fitted parameters scaled to their bounds.
        information: (f, f) Fisher information (Gauss-Newton, SI units).
        noise_sd: joint -> residual SD of the interval-end angles, rad.
        residual: (n, 2) interval-end angle errors with the fit (ankle, knee), rad.
        residual_none: (n, 2) the same without elements (p at zero moment).
        weights: (n,) interval weights used (1 / m).
        inv_var: (2,) 1 / sigma^2 of the ankle and knee residuals, 1/rad^2.
        jacobian: (2 n, f) d residuals / d z at the fit (ankle rows, then knee rows).
        iterations: Gauss-Newton iterations (both passes); seconds: their time.
    """

    values: dict
    z: np.ndarray
    information: np.ndarray
    noise_sd: dict
    residual: np.ndarray
    residual_none: np.ndarray
    weights: np.ndarray
    inv_var: np.ndarray
    jacobian: np.ndarray
    iterations: int
    seconds: float


def _interval_function(leg, model: PassiveModel, substeps: int, h: float):
    """CasADi ``shoot(x0, u, z, knee_offset) -> (ankle, knee)`` at the interval end."""
    import casadi as cs

    from predgait.problems.collocation import free_dynamics

    z = cs.SX.sym("z", len(model.fitted))
    values = scaled_values(model, z)
    x0 = cs.SX.sym("x0", 4)
    u = cs.SX.sym("u", INPUT_ROWS, 2 * substeps + 1)
    offset = cs.SX.sym("knee_offset")
    dynamics = free_dynamics(leg)

    def rhs(x, column):
        return dynamics(x, column[0:3], column[3:6], column[6:9],
                        column[9:11] + passive_torques(leg, model, values, x, offset),
                        column[11:14])

    x = rk4_steps(rhs, x0, u, substeps, h)
    return cs.Function("shoot", [x0, u, z, offset], [x[:2]])


def rk4_steps(rhs, x0, u, substeps: int, h: float):
    """``substeps`` classical RK4 steps of length h (s) from x0.

    ``rhs(x, column)`` is the state rate; ``u`` holds the drive at the RK4 points
    (start, midpoint, end of each step: 2 substeps + 1 columns).
    """
    x = x0
    for s in range(substeps):
        a, m, b = u[:, 2 * s], u[:, 2 * s + 1], u[:, 2 * s + 2]
        k1 = rhs(x, a)
        k2 = rhs(x + 0.5 * h * k1, m)
        k3 = rhs(x + 0.5 * h * k2, m)
        k4 = rhs(x + h * k3, b)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def scaled_values(model: PassiveModel, z) -> dict:
    """Key -> value of every parameter, the fitted ones lower + (upper - lower) z_i."""
    values = dict(model.values())
    for i, p in enumerate(model.fitted):
        values[p.key] = p.lower + (p.upper - p.lower) * z[i]
    return values


def passive_torques(leg, model: PassiveModel, values, x, knee_offset):
    """CasADi (2,) ankle, knee torques (model sign) of the passive model at free state x.

    x = (q_ankle, q_knee, v_ankle, v_knee) in model coordinates; the elements act on the
    clinical angles through the one joint-sign table, the knee on its anatomical angle
    (clinical - ``knee_offset``, rad), as in the decomposition fit.
    """
    import casadi as cs

    row = {"ankle": 0, "knee": 1}
    extra = [0, 0]
    for joint in model.joints:
        element = model.passive_joint(joint, values)
        offset = knee_offset if joint == "knee" else 0.0
        extra[row[joint]] = clinical_joint(leg, joint).generalized_force(
            lambda angle, rate, element=element, offset=offset:
            element.moment(angle - offset, rate), x[row[joint]], x[2 + row[joint]])
    return cs.vertcat(*extra)


def _residual_function(leg, model: PassiveModel, n: int, substeps: int, h: float):
    """``residuals(z, data) -> (r (n, 2), d vec(r) / dz (2 n, f))`` for n intervals.

    ``data`` = (vec x0 (4, n), vec u (rows, points n), vec end (2, n), knee offset);
    vec(r) stacks the ankle errors of every interval, then the knee's. Compiled through
    :mod:`predgait.function_cache` when the cache is on (in the background: the run that
    first meets a trial's shape evaluates it in CasADi's virtual machine, ~15x slower).
    """
    from predgait import function_cache

    return _residual_function_built(leg, model, n, substeps, h, function_cache.enabled())


@functools.lru_cache(maxsize=8)
def _residual_function_built(leg, model, n, substeps, h, cached):
    import casadi as cs

    from predgait import function_cache

    shoot = _interval_function(leg, model, substeps, h).map(n)
    z = cs.MX.sym("z", len(model.fitted))
    x0 = cs.MX.sym("x0", 4, n)
    u = cs.MX.sym("u", INPUT_ROWS, (2 * substeps + 1) * n)
    end = cs.MX.sym("end", 2, n)
    offset = cs.MX.sym("offset")
    residual = (shoot(x0, u, cs.repmat(z, 1, n), offset) - end).T
    data = cs.vertcat(cs.vec(x0), cs.vec(u), cs.vec(end), offset)
    function = cs.Function("shooting_residuals", [z, data],
                           [residual, cs.jacobian(cs.vec(residual), z)])
    if not cached:
        return function
    return function_cache.compiled(function, function_cache.key_of([function.serialize()])) \
        or function


def _data(intervals: Intervals) -> np.ndarray:
    u = np.concatenate(list(intervals.inputs), axis=1)    # (rows, points * n)
    return np.concatenate([intervals.x0.ravel(), u.ravel(order="F"), intervals.end.ravel(),
                           [intervals.knee_offset]])


@dataclass(frozen=True, eq=False)
class _LeastSquares:
    """The weighted least-squares problem in z (scaled parameters) and its priors."""

    model: PassiveModel
    residuals: object      # CasADi function (z, data) -> (r, J)
    data: np.ndarray
    _last: list = field(default_factory=lambda: [None, None])   # z, (r, J) of the last call

    @classmethod
    def of(cls, leg, model: PassiveModel, intervals: Intervals) -> _LeastSquares:
        function = _residual_function(leg, model, len(intervals), intervals.substeps,
                                      intervals.length_s / intervals.substeps)
        return cls(model, function, _data(intervals))

    def evaluate(self, z) -> tuple[np.ndarray, np.ndarray]:
        """(r (n, 2), J (2 n, f)) at z (the last point's values are kept)."""
        z = np.asarray(z, dtype=float)
        if self._last[0] is None or not np.array_equal(self._last[0], z):
            r, jac = self.residuals(z, self.data)
            self._last[0], self._last[1] = z.copy(), (np.array(r), np.array(jac))
        r, jac = self._last[1]
        return r.copy(), jac.copy()

    def prior_rows(self, z) -> tuple[np.ndarray, np.ndarray]:
        """Prior residuals and their Jacobian rows (:func:`prior_rows`)."""
        return prior_rows(self.model, z)


def prior_rows(model: PassiveModel, z) -> tuple[np.ndarray, np.ndarray]:
    """Prior residuals ((p - mean) / sd) and their rows of the Jacobian in z."""
    fitted = model.fitted
    rows = [i for i, p in enumerate(fitted) if p.prior is not None]
    r = np.array([(fitted[i].lower + (fitted[i].upper - fitted[i].lower) * z[i]
                   - fitted[i].prior) / fitted[i].prior_sd for i in rows])
    jac = np.zeros((len(rows), len(fitted)))
    for k, i in enumerate(rows):
        jac[k, i] = (fitted[i].upper - fitted[i].lower) / fitted[i].prior_sd
    return r, jac


def bounded_step(jac, r, row_weights, z, prior) -> np.ndarray:
    """Gauss-Newton step dz minimising |sqrt(W)(r + J dz)|^2 + priors, z + dz in [0, 1]."""
    from scipy.optimize import lsq_linear

    root = np.sqrt(row_weights)
    prior_r, prior_j = prior
    a = np.vstack([jac * root[:, None], prior_j])
    b = -np.concatenate([r * root, prior_r])
    lower, upper = -z, 1.0 - z
    upper = np.maximum(upper, lower + 1e-15)
    return lsq_linear(a, b, bounds=(lower, upper), method="bvls").x


def _cost(r, row_weights, prior) -> float:
    return float(np.sum(row_weights * r ** 2) + np.sum(prior[0] ** 2))


def gauss_newton(problem, z, row_weights, max_iter: int) -> tuple[np.ndarray, int, bool]:
    """Bounded Gauss-Newton with step halving: (z, iterations, converged).

    ``problem`` has ``evaluate(z) -> (r (n, 2), J (2 n, f))`` (ankle rows, then knee rows)
    and ``prior_rows(z) -> (r_prior, J_prior)``; z is scaled to [0, 1].
    """
    r, jac = problem.evaluate(z)
    r = r.ravel(order="F")
    cost = _cost(r, row_weights, problem.prior_rows(z))
    for iteration in range(1, max_iter + 1):
        step = bounded_step(jac, r, row_weights, z, problem.prior_rows(z))
        if np.max(np.abs(step)) < 1e-8:
            return z, iteration, True
        for _ in range(30):
            trial = np.clip(z + step, 0.0, 1.0)
            r_new, jac_new = problem.evaluate(trial)
            r_new = r_new.ravel(order="F")
            cost_new = _cost(r_new, row_weights, problem.prior_rows(trial))
            if cost_new <= cost * (1 + 1e-12):
                break
            step = step / 2
        else:
            return z, iteration, False
        # z is scaled to the bounds: 1e-7 of a bound range is far inside any interval. A
        # relative decrease below 1e-6 of a cost of order its degrees of freedom moves the
        # estimate by well under 1 % of its standard error.
        converged = np.max(np.abs(trial - z)) < 1e-7 or cost - cost_new <= 1e-6 * cost
        z, r, jac, cost = trial, r_new, jac_new, cost_new
        if converged:
            return z, iteration, True
    return z, max_iter, False


def _values(model: PassiveModel, z) -> dict:
    values = model.values()
    values.update({p.key: float(p.lower + (p.upper - p.lower) * z[i])
                   for i, p in enumerate(model.fitted)})
    return values


def check_intervals(intervals: Intervals, model: PassiveModel, *, where: str) -> None:
    """Refuse a trial that leaves fewer than 3 independent intervals per fitted parameter."""
    independent = len(intervals) / intervals.correlation_intervals
    need = 3 * len(model.fitted)
    if independent < need:
        raise InputError(f"{where}: {len(intervals)} shooting intervals "
                         f"({independent:.1f} independent ones) are too few for "
                         f"{len(model.fitted)} fitted parameters (need {need}); use a longer "
                         "trial or fit fewer parameters.")


def joint_row_weights(weights, inv_var) -> np.ndarray:
    """Row weights of the stacked residual (ankle rows, then knee rows): w / sigma_j^2."""
    return np.concatenate([weights * inv_var[0], weights * inv_var[1]])


def fit_shooting(leg, intervals: Intervals, model: PassiveModel,
                 settings: ShootingSettings = ShootingSettings(), *,
                 where: str = "shooting") -> ShootingFit:
    """Fit the stabilising elements (module docstring); two passes to set sigma.

    The problem is a small nonlinear least-squares problem (a few parameters, two
    residuals per interval, their Jacobian by CasADi's forward mode through the mapped
    interval integrator), solved by bounded Gauss-Newton (each step a bounded linear
    least-squares problem, BVLS) with step halving.

    Args:
        leg: The leg model (:class:`predgait.models.loading.Model`).
        intervals: From :meth:`Intervals.from_inverse`.
        model: Elements, fitted and fixed parameters, bounds, priors.
        settings: Interval, step, iterations.
        where: Prefix of error messages.

    Raises:
        InputError: Too few intervals (:func:`check_intervals`).
        SolveFailed: Gauss-Newton did not converge.
    """
    check_intervals(intervals, model, where=where)
    fitted = model.fitted
    problem = _LeastSquares.of(leg, model, intervals)
    m = intervals.correlation_intervals
    weights = np.full(len(intervals), 1.0 / m)
    z = np.array([(p.value - p.lower) / (p.upper - p.lower) for p in fitted])
    inv_var = np.array([1.0, 1.0]) / np.radians(0.01) ** 2
    dof = max(len(intervals) / m - len(fitted), 1.0)
    start, iterations = clock.perf_counter(), 0
    for _ in range(2):
        z, used, converged = gauss_newton(problem, z, joint_row_weights(weights, inv_var),
                                           settings.max_iter)
        iterations += used
        if not converged:
            raise SolveFailed(f"{where}: Gauss-Newton did not converge in "
                              f"{settings.max_iter} iterations; no result is reported. "
                              "Check the bounds or fit fewer parameters.", best=None)
        r, jac = problem.evaluate(z)
        sd = np.maximum(np.sqrt(np.sum(r ** 2, axis=0) / m / dof), np.radians(1e-6))
        inv_var = 1.0 / sd ** 2
    seconds = clock.perf_counter() - start
    spans = np.array([p.upper - p.lower for p in fitted])
    row_weights = joint_row_weights(weights, inv_var)
    _, prior_j = problem.prior_rows(z)
    information = ((jac * row_weights[:, None]).T @ jac + prior_j.T @ prior_j) \
        / np.outer(spans, spans)
    return ShootingFit(values=_values(model, z), z=z, information=information,
                       noise_sd={"ankle": float(sd[0]), "knee": float(sd[1])}, residual=r,
                       residual_none=_no_elements(leg, model, intervals),
                       weights=weights, inv_var=inv_var, jacobian=jac, iterations=iterations,
                       seconds=seconds)


def _no_elements(leg, model, intervals) -> np.ndarray:
    """Interval-end errors with every element switched off (coefficients zero)."""
    from dataclasses import replace

    off = {"k": 0.0, "c": 0.0, "k_lower": 0.0, "k_upper": 0.0, "c_limit": 0.0}
    parameters = tuple(replace(p, value=off.get(p.name, p.value), fit=False,
                               lower=min(p.lower, off.get(p.name, p.value)))
                       for p in model.parameters)
    return _LeastSquares.of(leg, replace(model, parameters=parameters),
                            intervals).evaluate(np.zeros(0))[0]


def engine_elements(model: PassiveModel, values, knee_offset: float) -> dict:
    """Joint -> PassiveJoint of ``values`` on the engine's (hinge) clinical angles.

    The fit writes the knee on its anatomical angle (hinge angle - ``knee_offset``, rad):
    the neutral angle and the stops move by the offset, so the elements act on the
    simulated leg exactly as in the fit.
    """
    from dataclasses import replace

    from predgait.dynamics.passive import ExponentialLimits, LinearSpringDamper, PassiveJoint

    out = {}
    for joint in model.joints:
        shift = knee_offset if joint == "knee" else 0.0
        elements = []
        for element in model.passive_joint(joint, values).elements:
            if isinstance(element, LinearSpringDamper):
                elements.append(replace(element, theta0=element.theta0 + shift))
            elif isinstance(element, ExponentialLimits):
                elements.append(replace(element, lower=element.lower + shift,
                                        upper=element.upper + shift))
        out[joint] = PassiveJoint(tuple(elements))
    return out


def bootstrap_shooting(intervals: Intervals, samples: GaitSamples, model: PassiveModel,
                       fit: ShootingFit, *, repeats: int = 200, seed: int = 0,
                       min_cycles: int = 6, block_s: float = 0.1) -> Bootstrap:
    """Refits on resampled gait cycles (or blocks of ``block_s`` s) of the intervals.

    Each replicate minimises the fit's Gauss-Newton model at the full fit,
    |sqrt(W_b) (r + J dz)|^2 + priors within the bounds (W_b the resampled interval
    weights): over intervals this short the residuals are close to linear in the
    parameters (checked against full refits in the tests), and one replicate then costs
    a bounded linear least-squares solve instead of a nonlinear fit.
    """
    units, kind = resampling_units(samples, min_cycles=min_cycles, block_s=block_s)
    of_interval = units[intervals.start]
    labels = np.unique(of_interval[of_interval >= 0])
    position = np.clip(np.searchsorted(labels, of_interval), 0, max(labels.size - 1, 0))
    rng = np.random.default_rng(seed)
    r = fit.residual.ravel(order="F")
    prior = prior_rows(model, fit.z)
    lower = np.array([p.lower for p in model.fitted])
    span = np.array([p.upper - p.lower for p in model.fitted])
    rows = []
    for _ in range(repeats):
        counts = np.bincount(rng.integers(0, labels.size, labels.size), minlength=labels.size)
        weights = fit.weights * np.where(of_interval >= 0, counts[position], 0)
        step = bounded_step(fit.jacobian, r, joint_row_weights(weights, fit.inv_var), fit.z,
                             prior)
        rows.append(lower + span * np.clip(fit.z + step, 0.0, 1.0))
    return Bootstrap(np.array(rows).reshape(-1, len(model.fitted)), kind, int(labels.size), 0)
