"""Passive knee and ankle from the measured angles of the quiet phases, by simulation.

The moment decomposition (:mod:`predgait.problems.decomposition`) fits the passive model
to inverse-dynamics moments; in swing the knee's moment is a small difference of large
inertial terms of twice-differentiated markers, so it is noisy. Here the moments are not
used at all. In each quiet phase of each gait cycle (a window: muscles taken as quiet,
foot off the ground) the shank and foot are simulated under the measured thigh,

    M(q) q'' + h(q, q') = S^T tau_passive(theta, theta'; p) + J_T(q)^T w,
    J_T(q) q'' + J_T'(q) q' = s''_measured(t),

(engine's equations of the leg on ADAM's M and h of the same URDF; s = hip centre x, z
and thigh pitch, prescribed as measured; w the hip load that holds them, eliminated by
projecting on the two free joints) and p minimises

    sum_windows sum_samples w sum_joints ((theta_sim - theta_measured) / sigma_j)^2
    + sum_priors ((p - mean) / sd)^2

over the measured (marker-derived) ankle and knee angles. Each window is one shooting
interval from its own initial state (ankle, knee and their rates, estimated with p,
within +-``initial_angle_span`` and +-``initial_rate_span`` of the measured one); the
windows are not joined (muscles act between them). Under a prescribed thigh the shank
and foot swing as a stable pendulum, so a whole quiet phase is one well-conditioned
interval. The solver is the bounded Gauss-Newton of :mod:`predgait.problems.gauss_newton`
(Jacobian by CasADi forward mode through the windows mapped in one call); w = 1 / m
(m samples per correlation time of the filtered angles) and sigma_j the residual SD of the
previous pass (passes until it settles), so J^T W J is the Fisher information; the initial
states are profiled out of it (Schur complement). The rest angles theta0 also get
profile-likelihood intervals (:mod:`predgait.problems.profile_likelihood`). Bootstrap
replicates resample the windows' gait cycles on the Gauss-Newton model at the fit.
"""

from __future__ import annotations

import time as clock
from dataclasses import dataclass, field

import numpy as np

from predgait.blas_threads import one_blas_thread
from predgait.dynamics.drivers import LegDrivers
from predgait.errors import InputError, SolveFailed
from predgait.problems.decomposition import Bootstrap
from predgait.problems.gait_samples import GaitSamples
from predgait.problems.gauss_newton import (
    LeastSquares,
    gauss_newton,
    joint_row_weights,
    prior_rows,
    weighted_step,
)
from predgait.problems.identifiability import BOUND_FRACTION
from predgait.problems.passive_model import PassiveModel
from predgait.problems.passive_moment_rows import with_moments
from predgait.problems.passive_swing_dynamics import (
    INPUT_ROWS,
    thigh_kinematics,
    windows_function,
)
from predgait.problems.profile_likelihood import profile_interval

#: Ground reaction (N, vertical) above which a sample counts as stance (not a window).
CONTACT_N = 20.0
#: Fewest samples in a window.
MIN_WINDOW_SAMPLES = 5
#: Passes of the fit at most, and the relative change of the noise SDs that ends them.
MAX_PASSES = 6
WEIGHT_CHANGE = 0.02


@dataclass(frozen=True)
class SwingSettings:
    """Options of the quiet-phase simulation fit.

    Attributes:
        quiet_phases: [start, end) pairs, % gait cycle, where the muscles are taken as quiet.
        step_s: Longest RK4 step, s (each sample interval is cut into equal steps).
        max_iter: Gauss-Newton iterations per pass.
        initial_angle_span: Each window's initial angles are estimated within +- this of
            the measured ones, rad.
        initial_rate_span: Its initial rates within +- this of the measured ones, rad/s.
    """

    quiet_phases: tuple[tuple[float, float], ...] = ((73.0, 95.0),)
    step_s: float = 0.01
    max_iter: int = 50
    initial_angle_span: float = 0.15
    initial_rate_span: float = 3.0


@dataclass(frozen=True, eq=False)
class Windows:
    """The quiet-phase windows of a trial, with the measured data they need.

    Attributes:
        first: (w,) index of each window's first sample.
        length: (w,) samples in each window (the arrays are padded to the longest, L).
        cycle: (w,) gait cycle of each window.
        substeps: RK4 steps per sample interval.
        x0: (w, 4) measured state at each window's start (ankle, knee, rates; model
            coordinates, rad, rad/s).
        angles: (w, L, 2) measured ankle and knee angles (model coordinates), rad.
        mask: (w, L) True on real (not padded) samples.
        inputs: (w, 9, (L - 1) (2 substeps + 1)) measured thigh pose, rate and
            acceleration at the RK4 points of each sample interval
            (:func:`~predgait.problems.passive_swing_dynamics.thigh_kinematics`).
        knee_offset: Static-trial knee flexion, rad (anatomical = clinical - offset).
        correlation_samples: Samples per correlation time of the data, m >= 1.
        dt: Sample interval, s.
    """

    first: np.ndarray
    length: np.ndarray
    cycle: np.ndarray
    substeps: int
    x0: np.ndarray
    angles: np.ndarray
    mask: np.ndarray
    inputs: np.ndarray
    knee_offset: float
    correlation_samples: float
    dt: float

    @classmethod
    def from_inverse(cls, inverse, samples: GaitSamples,
                     settings: SwingSettings = SwingSettings(), *,
                     where: str = "quiet_phases") -> Windows:
        """Every run of quiet, valid, unloaded samples of at least 5 samples, per cycle.

        Raises:
            InputError: No such window (naming ``where``).
        """
        # Rounded: the step is a constant of the compiled function (and of its cache key).
        dt = float(np.round(np.median(np.diff(inverse.time)), 12))
        substeps = max(1, int(np.ceil(dt / settings.step_s - 1e-9)))
        q, v = np.asarray(inverse.q), np.asarray(inverse.v)
        ok = samples.in_phases(settings.quiet_phases) & np.isfinite(q).all(axis=1) \
            & np.isfinite(v).all(axis=1) & np.isfinite(np.asarray(inverse.a)).all(axis=1)
        if getattr(inverse, "has_grf", False):
            ok &= ~(np.asarray(inverse.grf)[:, 2] > CONTACT_N)
        runs = []
        for cycle in np.unique(samples.cycle[ok]):
            index = np.flatnonzero(ok & (samples.cycle == cycle))
            for run in np.split(index, np.flatnonzero(np.diff(index) > 1) + 1):
                if run.size >= MIN_WINDOW_SAMPLES:
                    runs.append((int(cycle), run))
        if not runs:
            raise InputError(f"{where}: no quiet phase of at least {MIN_WINDOW_SAMPLES} "
                             "samples off the ground in any gait cycle; widen the phases "
                             "or use a trial with whole swing phases.")
        longest = max(run.size for _, run in runs)
        drivers = LegDrivers.from_inverse(inverse)
        offsets = np.linspace(0.0, dt, 2 * substeps + 1)
        angles = np.zeros((len(runs), longest, 2))
        mask = np.zeros((len(runs), longest), dtype=bool)
        times = np.empty((len(runs), longest - 1, offsets.size))
        for w, (_, run) in enumerate(runs):
            angles[w, :run.size] = q[run, 3:5]
            angles[w, run.size:] = q[run[-1], 3:5]
            mask[w, :run.size] = True
            # Padding after a shorter window: the thigh held at its last sample.
            steps = np.arange(longest - 1)
            times[w] = inverse.time[run[np.minimum(steps, run.size - 1)]][:, None] \
                + np.where(steps < run.size - 1, 1.0, 0.0)[:, None] * offsets
        flat = times.ravel()
        measured = [np.array([f(t) for t in flat]) for f in (
            drivers.reference_q, drivers.reference_qd, drivers.reference_qdd)]
        inputs = thigh_kinematics(inverse.model, *measured).reshape(
            len(runs), -1, INPUT_ROWS).transpose(0, 2, 1)
        first = np.array([run[0] for _, run in runs])
        return cls(first=first, length=np.array([run.size for _, run in runs]),
                   cycle=np.array([c for c, _ in runs]), substeps=substeps,
                   x0=np.column_stack([q[first, 3:5], v[first, 3:5]]), angles=angles,
                   mask=mask, inputs=inputs,
                   knee_offset=float(getattr(inverse, "knee_static", 0.0)),
                   correlation_samples=max(1.0, samples.correlation_time / dt), dt=dt)

    def __len__(self) -> int:
        return int(self.first.size)

    @property
    def samples(self) -> int:
        """Real samples over all windows."""
        return int(self.mask.sum())


@dataclass(frozen=True, eq=False)
class _SwingResiduals:
    """Residuals and Jacobian of the swing fit in z = (p scaled to its bounds, initial states).

    Residuals r (w L, 2): simulated minus measured angles, window by window, sample by
    sample (ankle, knee); Jacobian rows in the order of r raveled column-wise (every
    ankle row, then every knee row), columns (p, then 4 initial-state unknowns per window).
    """

    model: PassiveModel
    windows: Windows
    simulate: object       # CasADi windows function (x0, u, z, offset) -> (X, S)
    span: np.ndarray       # (4,) half-range of the initial-state unknowns

    @classmethod
    def problem(cls, leg, model: PassiveModel, windows: Windows, settings: SwingSettings
                ) -> LeastSquares:
        """The fit's :class:`~predgait.problems.gauss_newton.LeastSquares` problem."""
        longest = windows.angles.shape[1]
        simulate = windows_function(leg, model, len(windows), longest - 1, windows.substeps,
                                    windows.dt / windows.substeps)
        span = np.array([settings.initial_angle_span] * 2 + [settings.initial_rate_span] * 2)
        return LeastSquares(model, cls(model, windows, simulate, span))

    def start(self, z) -> np.ndarray:
        """(w, 4) initial states of the windows at z."""
        f = len(self.model.fitted)
        return self.windows.x0 + self.span * (2 * np.reshape(z[f:], (-1, 4)) - 1)

    def __call__(self, z) -> tuple[np.ndarray, np.ndarray]:
        """(r (w L, 2), J (2 w L, f + 4 w)) at z."""
        windows, f = self.windows, len(self.model.fitted)
        n, longest = windows.angles.shape[:2]
        u = np.concatenate(list(windows.inputs), axis=1)
        states, sens = self.simulate(self.start(z).T, u, z[:f], windows.knee_offset)
        states = np.array(states).reshape(4, n, longest - 1)
        sens = np.array(sens).reshape(4, n, longest - 1, 4 + f)
        start = np.broadcast_to(np.hstack([np.eye(4), np.zeros((4, f))])[:, None, None],
                                (4, n, 1, 4 + f))
        sens = np.concatenate([start, sens], axis=2)                 # (4, w, L, 4 + f)
        angles = np.concatenate([self.start(z).T[:2, :, None], states[:2]], axis=2)
        r = (angles.transpose(1, 2, 0) - windows.angles).reshape(n * longest, 2)
        jac = np.zeros((2 * n * longest, f + 4 * n))
        window = np.repeat(np.arange(n), longest)
        for joint in range(2):
            rows = joint * n * longest + np.arange(n * longest)
            jac[rows, :f] = sens[joint, :, :, 4:].reshape(n * longest, f)
            cols = f + 4 * window[:, None] + np.arange(4)
            jac[rows[:, None], cols] = sens[joint, :, :, :4].reshape(n * longest, 4) \
                * 2 * self.span
        return r, jac


@dataclass(frozen=True, eq=False)
class SwingFit:
    """The passive parameters fitted to the quiet phases' angles.

    Attributes:
        values: key -> value of every parameter (fitted and fixed), SI.
        z: (f + 4 w,) fitted unknowns scaled to their bounds (parameters, initial states).
        information: (f, f) Fisher information of the parameters, initial states profiled
            out (SI units).
        noise_sd: joint -> residual SD of the angles, rad.
        residual: (w L, 2) angle errors with the fit (ankle, knee), rad; 0 on padding.
        weights: (w L,) sample weights (1 / m, 0 on padding).
        inv_var: (2,) 1 / sigma^2 of the ankle and knee residuals, 1/rad^2.
        jacobian: (2 w L, f + 4 w) d residuals / d z at the fit.
        simulated: (w, L, 2) simulated ankle and knee angles (model coordinates), rad.
        iterations: Gauss-Newton iterations (both passes); seconds: their time.
        moment_sd: joint -> moment residual SD, N m, when the moments were fitted too.
        profile: key -> (low, high) profile-likelihood 95 % interval of each identifiable
            rest angle theta0, rad (:mod:`~predgait.problems.profile_likelihood`).
    """

    values: dict
    z: np.ndarray
    information: np.ndarray
    noise_sd: dict
    residual: np.ndarray
    weights: np.ndarray
    inv_var: np.ndarray
    jacobian: np.ndarray
    simulated: np.ndarray
    iterations: int
    seconds: float
    moment_sd: dict | None = None
    profile: dict = field(default_factory=dict)


def fit_swing(leg, windows: Windows, model: PassiveModel,
              settings: SwingSettings = SwingSettings(), *, start=None,
              where: str = "passive_swing", moments=None, profile: bool = True) -> SwingFit:
    """Fit the passive model to the quiet phases' angles (module docstring).

    Passes of Gauss-Newton, each with the noise weights (sigma_j, and sigma_m of the
    moments) re-estimated from the last one's residuals, until they change by less than
    :data:`WEIGHT_CHANGE` (at least 2, at most :data:`MAX_PASSES`): the estimate, its
    Fisher information and the profile intervals then share one objective.

    Args:
        leg: The leg model (:class:`predgait.models.loading.Model`).
        windows: From :meth:`Windows.from_inverse`.
        model: Elements, fitted and fixed parameters, bounds, priors.
        settings: Step, iterations, initial-state ranges.
        start: Optional key -> first guess of fitted parameters (e.g. the moment
            decomposition's values; Gauss-Newton from far away needs many step halvings).
        where: Prefix of error messages.
        moments: Optional :class:`~predgait.problems.passive_moment_rows.MomentRows`: the
            quiet samples' inverse-dynamics moments as a second residual (their SD
            re-estimated after each pass, as the angles'); the Fisher information then
            holds both.
        profile: Also the profile-likelihood intervals of the rest angles (False: the
            sensitivity refits, which report values only).

    Raises:
        InputError: Fewer than 3 independent samples per unknown.
        SolveFailed: Gauss-Newton did not converge.
    """
    fitted = model.fitted
    n, f = len(windows), len(fitted)
    m = windows.correlation_samples
    independent = 2 * windows.samples / m
    need = 4 * n + 3 * f
    if independent < need:
        raise InputError(f"{where}: {windows.samples} quiet samples in {n} window(s) "
                         f"({independent:.0f} independent angle values) are too few for "
                         f"{f} parameters and {4 * n} initial states (need {need}: 3 per "
                         "parameter beyond the initial states); "
                         "widen the quiet phases, use a longer trial or fit fewer parameters.")
    base = _SwingResiduals.problem(leg, model, windows, settings)
    problem = base if moments is None else with_moments(base, moments)
    weights = windows.mask.ravel() / m
    guess = [min(max((start or {}).get(p.key, p.value), p.lower), p.upper) for p in fitted]
    z = np.concatenate([[(g - p.lower) / (p.upper - p.lower) for g, p in zip(guess, fitted,
                                                                            strict=True)],
                        np.full(4 * n, 0.5)])
    inv_var = np.array([1.0, 1.0]) / np.radians(0.1) ** 2
    dof = max(windows.samples / m - (f + 4 * n) / 2, 1.0)
    start, iterations = clock.perf_counter(), 0
    for step in range(MAX_PASSES):
        with one_blas_thread():   # small least-squares steps: BLAS threads only cost here
            z, used, converged = gauss_newton(problem, z, joint_row_weights(weights, inv_var),
                                              settings.max_iter)
        iterations += used
        if not converged:
            raise SolveFailed(f"{where}: Gauss-Newton did not converge in "
                              f"{settings.max_iter} iterations; no result is reported. "
                              "Check the bounds or fit fewer parameters.", best=None)
        r, jac = problem.evaluate(z)
        r = r * windows.mask.ravel()[:, None]
        sd = np.maximum(np.sqrt(np.sum(r ** 2, axis=0) / m / dof), np.radians(1e-6))
        change = np.abs(np.sqrt(inv_var) * sd - 1)           # old sigma / new sigma - 1
        inv_var = 1.0 / sd ** 2
        if moments is not None:
            old = moments.sigma
            moments = moments.with_noise_of(z[:f])
            problem = with_moments(base, moments)
            change = np.append(change, [abs(moments.sigma[j] / old[j] - 1) for j in old])
        if step >= 1 and np.max(change) < WEIGHT_CHANGE:
            break
    seconds = clock.perf_counter() - start
    rows = joint_row_weights(weights, inv_var)
    _, prior_j = problem.prior_rows(z)
    full = (jac * rows[:, None]).T @ jac + prior_j.T @ prior_j
    spans = np.array([p.upper - p.lower for p in fitted])
    profiled = full[:f, :f] - full[:f, f:] @ np.linalg.pinv(full[f:, f:], hermitian=True) \
        @ full[f:, :f]
    intervals = {}
    if profile:
        half = 1.96 * np.sqrt(np.clip(np.diag(np.linalg.pinv(profiled, hermitian=True)),
                                      0.0, None))
        with one_blas_thread():
            for i, p in enumerate(fitted):
                if p.name == "theta0" and half[i] < BOUND_FRACTION:   # identifiable
                    low, high = profile_interval(problem, z, rows, i, half[i])
                    intervals[p.key] = (p.lower + spans[i] * low, p.lower + spans[i] * high)
    values = model.values()
    values.update({p.key: float(p.lower + span * z[i])
                   for i, (p, span) in enumerate(zip(fitted, spans, strict=True))})
    simulated = (r + np.concatenate(list(windows.angles), axis=0)).reshape(windows.angles.shape)
    return SwingFit(values=values, z=z, information=profiled / np.outer(spans, spans),
                    noise_sd={"ankle": float(sd[0]), "knee": float(sd[1])}, residual=r,
                    weights=weights, inv_var=inv_var, jacobian=jac, simulated=simulated,
                    iterations=iterations, seconds=seconds,
                    moment_sd=None if moments is None else dict(moments.sigma),
                    profile=intervals)


def bootstrap_swing(windows: Windows, model: PassiveModel, fit: SwingFit, *,
                    repeats: int = 200, seed: int = 0) -> Bootstrap:
    """Replicates on resampled gait cycles (all windows of a cycle together).

    Each replicate minimises the fit's Gauss-Newton model at the full fit with the
    resampled cycle weights, |sqrt(W_b) (r + J dz)|^2 + priors, within the bounds; the
    initial states of cycles left out are dropped from it.
    """
    labels, position = np.unique(windows.cycle, return_inverse=True)
    f = len(model.fitted)
    rng = np.random.default_rng(seed)
    prior_r, prior_j = prior_rows(model, fit.z[:f])
    lower = np.array([p.lower for p in model.fitted])
    span = np.array([p.upper - p.lower for p in model.fitted])
    rows = []
    with one_blas_thread():
        for _ in range(repeats):
            rows.append(_replicate(windows, fit, rng, labels, position, (prior_r, prior_j),
                                   f) * span + lower)
    return Bootstrap(np.array(rows).reshape(-1, f), "gait cycle", int(labels.size), 0)


def _replicate(windows, fit, rng, labels, position, prior, f) -> np.ndarray:
    """One replicate's parameters scaled to their bounds (:func:`bootstrap_swing`)."""
    longest = windows.angles.shape[1]
    prior_r, prior_j = prior
    counts = np.bincount(rng.integers(0, labels.size, labels.size),
                         minlength=labels.size)[position]              # per window
    weights = fit.weights * np.repeat(counts, longest)
    keep = np.concatenate([np.arange(f), f + np.flatnonzero(np.repeat(counts > 0, 4))])
    prior = (prior_r, np.hstack([prior_j, np.zeros((prior_j.shape[0], keep.size - f))]))
    step = weighted_step(fit.jacobian[:, keep], fit.residual.ravel(order="F"),
                        joint_row_weights(weights, fit.inv_var), fit.z[keep], prior)
    return np.clip(fit.z[:f] + step[:f], 0.0, 1.0)



def residuals_at(leg, windows: Windows, model: PassiveModel, values: dict,
                 settings: SwingSettings = SwingSettings()) -> tuple[np.ndarray, np.ndarray]:
    """The fit's residuals and Jacobian at given parameters, windows started at ``x0``.

    The fit's own least-squares problem (:class:`_SwingResiduals`; Jacobian by CasADi
    forward mode) with each window started from ``windows.x0`` (for the Cramér-Rao bound,
    :func:`predgait.problems.identifiability.cramer_rao`: pass windows whose ``x0`` is
    the true state).

    Returns:
        r (2 n,): simulated minus measured angles on the n real samples, every ankle
        angle window by window, then every knee angle, rad; J (2 n, f + 4 w): d r / d
        (fitted parameters in ``model.fitted`` order, per SI unit; then per window its
        initial ankle, knee, ankle rate, knee rate, per rad, rad/s).
    """
    fitted = model.fitted
    problem = _SwingResiduals.problem(leg, model, windows, settings)
    lower = np.array([p.lower for p in fitted])
    spans = np.array([p.upper - p.lower for p in fitted])
    z = np.concatenate([(np.array([values[p.key] for p in fitted]) - lower) / spans,
                        np.full(4 * len(windows), 0.5)])
    r, jac = problem.evaluate(z)
    scale = np.concatenate([spans, np.tile(2 * problem.compute.span, len(windows))])
    real = np.tile(windows.mask.ravel(), 2)
    return r.ravel(order="F")[real], jac[real] / scale
