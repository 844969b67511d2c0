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

import time as clock
from dataclasses import dataclass

import numpy as np

from predgait.dynamics.drivers import LegDrivers
from predgait.errors import InputError, SolveFailed
from predgait.problems.decomposition import Bootstrap, resampling_units
from predgait.problems.gait_samples import GaitSamples
from predgait.problems.gauss_newton import (
    LeastSquares,
    gauss_newton,
    joint_row_weights,
    prior_rows,
    weighted_step,
)
from predgait.problems.passive_model import PassiveModel
from predgait.problems.shooting_dynamics import INPUT_ROWS, residual_function

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
        q, v = np.asarray(inverse.q), np.asarray(inverse.v)
        finite = np.isfinite(q).all(axis=1) & np.isfinite(v).all(axis=1)
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
                   x0=np.column_stack([q[starts, 3:5], v[starts, 3:5]]),
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


def _data(intervals: Intervals) -> np.ndarray:
    u = np.concatenate(list(intervals.inputs), axis=1)    # (rows, points * n)
    return np.concatenate([intervals.x0.ravel(), u.ravel(order="F"), intervals.end.ravel(),
                           [intervals.knee_offset]])


def _problem(leg, model: PassiveModel, intervals: Intervals) -> LeastSquares:
    """The fit's least-squares problem in z (scaled parameters) and its priors."""
    function = residual_function(leg, model, len(intervals), intervals.substeps,
                                 intervals.length_s / intervals.substeps)
    data = _data(intervals)
    return LeastSquares(model, lambda z: function(z, data))


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
    problem = _problem(leg, model, intervals)
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
    return _problem(leg, replace(model, parameters=parameters), intervals).evaluate(np.zeros(0))[0]


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
        step = weighted_step(fit.jacobian, r, joint_row_weights(weights, fit.inv_var), fit.z,
                             prior)
        rows.append(lower + span * np.clip(fit.z + step, 0.0, 1.0))
    return Bootstrap(np.array(rows).reshape(-1, len(model.fitted)), kind, int(labels.size), 0)
