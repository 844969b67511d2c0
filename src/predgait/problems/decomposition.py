"""Passive/active decomposition of measured joint moments, without simulation.

The inverse-dynamics moment is split, tau_ID = tau_active + tau_passive(theta, theta'; p)
(clinical angles and moments, :mod:`predgait.problems.passive_model`). With the muscles
taken as quiet in given phases of the gait cycle (default mid and terminal swing, 73-100 %
after Perry & Burnfield 2010, Gait Analysis, ch. 4), p minimises over every gait cycle of
the trial

    sum_quiet w (tau_ID - tau_passive)^2  +  lambda sum_elsewhere w (tau_a'' (10 ms)^2)^2
    + sum_priors ((p - mean) / sd)^2,

with w = 1 / (sigma^2 m): sigma the quiet-phase residual SD of a first pass (N m) and m
the samples per correlation time of the data (filtered at f_c: 1 / (2 f_c) s), so that
the objective is twice a negative log-likelihood in effectively independent samples and
its Hessian / 2 is the Fisher information. The second term (weight lambda, default
0.01) is a weak smoothness measure of the active moment elsewhere. The problem is small
(a few parameters; the passive moment is linear in its coefficients, so the samples enter
only through weighted Gram statistics, NLP parameters): CasADi + Ipopt with exact
Hessians, one solver per model, reused by the bootstrap (only the weights change).
"""

from __future__ import annotations

import functools
import time as clock
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from predgait.errors import InputError, SolveFailed
from predgait.problems.gait_samples import GaitSamples
from predgait.problems.passive_model import PassiveModel, coefficients, features

#: Time scale of the smoothness measure, s (second differences scaled to it).
SMOOTH_TIME = 0.01


@dataclass(frozen=True)
class Settings:
    """Options of the decomposition fit.

    Attributes:
        quiet_phases: [start, end) pairs in % gait cycle where muscles are taken as quiet.
        smoothness_weight: lambda of the active-moment smoothness term elsewhere (>= 0).
        min_quiet_samples: Fewest quiet samples per joint (and >= 3 per fitted parameter).
        max_iter: Ipopt iterations.
    """

    quiet_phases: tuple[tuple[float, float], ...] = ((73.0, 100.0),)
    smoothness_weight: float = 0.01
    min_quiet_samples: int = 20
    max_iter: int = 200


@dataclass(frozen=True, eq=False)
class Decomposition:
    """A fitted split of the measured moments.

    Attributes:
        values: key (``joint.name``) -> value of every parameter (fitted and fixed), SI.
        z: (f,) fitted parameters scaled to their bounds (0 = lower, 1 = upper).
        information: (f, f) Fisher information of the fitted parameters (SI units).
        noise_sd: joint -> quiet-phase residual SD, N m.
        passive: joint -> (n,) passive moment, N m.
        active: joint -> (n,) active moment tau_ID - passive, N m.
        quiet: (n,) bool, samples in the quiet phases.
        weights: (n, 2 J) sample weights used (quiet, smoothness per joint).
        status: Ipopt's return status; iterations; seconds (solver time).
    """

    values: dict
    z: np.ndarray
    information: np.ndarray
    noise_sd: dict
    passive: dict
    active: dict
    quiet: np.ndarray
    weights: np.ndarray
    status: str
    iterations: int
    seconds: float


def _columns(model: PassiveModel, joint: str) -> tuple[str, ...]:
    return tuple(features(model, joint, np.zeros(1), np.zeros(1)))


@functools.lru_cache(maxsize=16)
def _problem(model: PassiveModel, max_iter: int):
    """Cached solver and Hessian on the weighted Gram statistics (no sample count in it).

    Per joint the objective is beta^T A beta - 2 g^T beta + s (beta the coefficients of
    :func:`~predgait.problems.passive_model.features`), plus the priors.
    """
    import casadi as cs

    fitted = model.fitted
    z = cs.SX.sym("z", len(fitted))
    values = dict(model.values())
    for i, p in enumerate(fitted):
        values[p.key] = p.lower + (p.upper - p.lower) * z[i]
    statistics, objective = [], 0
    for joint in model.joints:
        names = _columns(model, joint)
        a = cs.SX.sym(f"A_{joint}", len(names), len(names))
        g = cs.SX.sym(f"g_{joint}", len(names))
        s = cs.SX.sym(f"s_{joint}")
        beta = cs.vertcat(*coefficients(joint, values, names))
        objective += cs.bilin(a, beta, beta) - 2 * cs.dot(g, beta) + s
        statistics += [cs.vec(a), g, s]
    for p in fitted:
        if p.prior is not None:
            objective += ((values[p.key] - p.prior) / p.prior_sd) ** 2
    data = cs.vertcat(*statistics)
    # Ipopt sees the objective divided by its value at the start (an NLP parameter): its
    # absolute tolerance then means the same on clean and noisy data. Unscaled, a close
    # fit (residual SD ~0.02 N m, weights 1 / sigma^2) has Hessian entries ~1e10 and
    # Ipopt cannot reach 1e-8 on the gradient in double precision: it stopped with
    # Maximum_Iterations_Exceeded or Search_Direction_Becomes_Too_Small on noise-free
    # trials (issue 28). Ipopt's own gradient-based scaling only scales down large
    # gradients, not a large curvature at a warm start.
    scale = cs.SX.sym("scale")
    nlp = {"x": z, "p": cs.vertcat(data, scale), "f": objective * scale}
    options = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
               "ipopt.max_iter": max_iter, "ipopt.tol": 1e-8}
    solver = cs.nlpsol("passive_decomposition", "ipopt", nlp, options)
    hessian = cs.Function("hessian", [z, data], [cs.hessian(objective, z)[0]])
    value = cs.Function("objective", [z, data], [objective])
    return solver, hessian, value


@dataclass(frozen=True, eq=False)
class _Design:
    """Feature columns of the samples: quiet rows and second differences elsewhere."""

    columns: dict          # joint -> (n, c) feature columns
    second: dict           # joint -> (n - 2, c) their second differences (10 ms scale)
    moment_second: dict    # joint -> (n - 2,) second differences of the moment

    @classmethod
    def of(cls, samples: GaitSamples, model: PassiveModel) -> _Design:
        h = float(np.median(np.diff(samples.time)))
        scale = (SMOOTH_TIME / h) ** 2
        columns, second, moment_second = {}, {}, {}
        for joint in model.joints:
            table = features(model, joint, np.nan_to_num(samples.angles[joint]),
                             np.nan_to_num(samples.rates[joint]))
            phi = np.column_stack(list(table.values()))
            columns[joint] = phi
            second[joint] = (phi[:-2] - 2 * phi[1:-1] + phi[2:]) * scale
            m = np.nan_to_num(samples.moments[joint])
            moment_second[joint] = (m[:-2] - 2 * m[1:-1] + m[2:]) * scale
        return cls(columns, second, moment_second)

    def statistics(self, samples: GaitSamples, model: PassiveModel, weights) -> np.ndarray:
        """Stacked (vec A, g, s) per joint for sample weights (n, 2 J)."""
        out = []
        for j, joint in enumerate(model.joints):
            phi, moment = self.columns[joint], np.nan_to_num(samples.moments[joint])
            wq, ws = weights[:, 2 * j], weights[1:-1, 2 * j + 1]
            d_phi, d_m = self.second[joint], self.moment_second[joint]
            a = (phi * wq[:, None]).T @ phi + (d_phi * ws[:, None]).T @ d_phi
            g = (phi * wq[:, None]).T @ moment + (d_phi * ws[:, None]).T @ d_m
            s = float(np.sum(wq * moment ** 2) + np.sum(ws * d_m ** 2))
            out += [a.ravel(order="F"), g, [s]]
        return np.concatenate(out)


def _weights(samples: GaitSamples, model: PassiveModel, settings: Settings,
             sigma: Mapping[str, float]) -> np.ndarray:
    """(n, 2 J) quiet and smoothness weights, 1 / (sigma^2 m) on the samples they cover.

    A smoothness weight sits on the centre sample of a second difference whose three
    samples lie outside the quiet phases and in one gait cycle.
    """
    quiet = samples.in_phases(settings.quiet_phases)
    valid = samples.cycle >= 0
    same = np.zeros(len(valid), dtype=bool)
    same[1:-1] = (samples.cycle[:-2] == samples.cycle[1:-1]) & \
        (samples.cycle[1:-1] == samples.cycle[2:])
    elsewhere = valid & ~quiet & same
    m = samples.samples_per_correlation
    weights = np.zeros((len(quiet), 2 * len(model.joints)))
    for j, joint in enumerate(model.joints):
        finite = np.isfinite(samples.moments[joint]) & np.isfinite(samples.angles[joint]) \
            & np.isfinite(samples.rates[joint])
        around = finite.copy()
        around[1:-1] = finite[:-2] & finite[1:-1] & finite[2:]
        base = 1.0 / (sigma[joint] ** 2 * m)
        weights[:, 2 * j] = np.where(quiet & finite, base, 0.0)
        weights[:, 2 * j + 1] = np.where(elsewhere & around,
                                         settings.smoothness_weight * base, 0.0)
    return weights


def check_samples(samples: GaitSamples, model: PassiveModel, settings: Settings,
                  *, where: str = "quiet_phases") -> None:
    """Refuse quiet phases that leave too few samples for the fitted parameters.

    Raises:
        InputError: Naming ``where``, the count and what to do.
    """
    quiet = samples.in_phases(settings.quiet_phases)
    for joint in model.joints:
        count = int((quiet & np.isfinite(samples.moments[joint])).sum())
        n_fit = sum(p.fit and p.joint == joint for p in model.parameters)
        need = max(settings.min_quiet_samples, 3 * n_fit)
        if count < need:
            raise InputError(f"{where}: the phases {list(map(list, settings.quiet_phases))} % "
                             f"gait cycle leave {count} {joint} samples in "
                             f"{samples.source or 'the trial'}; "
                             f"at least {need} are needed for {n_fit} fitted parameters. "
                             "Widen the phases or fit fewer parameters.")


def _solve(model, settings, statistics, z0):
    solver, hessian, value = _problem(model, settings.max_iter)
    start = clock.perf_counter()
    f0 = abs(float(value(z0, statistics)))
    scale = 1.0 / f0 if np.isfinite(f0) and f0 > 0 else 1.0
    result = solver(x0=z0, p=np.append(statistics, scale), lbx=0.0, ubx=1.0)
    seconds = clock.perf_counter() - start
    stats = solver.stats()
    z = np.clip(np.array(result["x"]).ravel(), 0.0, 1.0)
    return z, stats, seconds, hessian


def _failed(stats) -> bool:
    return not stats["success"] and stats["return_status"] != "Solved_To_Acceptable_Level"


def _values(model: PassiveModel, z) -> dict:
    values = model.values()
    values.update({p.key: float(p.lower + (p.upper - p.lower) * z[i])
                   for i, p in enumerate(model.fitted)})
    return values


def passive_moments(samples: GaitSamples, model: PassiveModel, values) -> dict:
    """Joint -> (n,) passive clinical moment, N m, of the model with ``values``."""
    return {joint: np.asarray(model.passive_joint(joint, values).moment(
        samples.angles[joint], samples.rates[joint])) for joint in model.joints}


def fit_decomposition(samples: GaitSamples, model: PassiveModel,
                      settings: Settings = Settings()) -> Decomposition:
    """Fit the passive parameters (module docstring); two passes to set sigma per joint.

    Raises:
        InputError: Too few quiet samples (:func:`check_samples`).
        SolveFailed: Ipopt did not converge.
    """
    check_samples(samples, model, settings)
    fitted = model.fitted
    design = _Design.of(samples, model)
    m = samples.samples_per_correlation
    z = np.array([(p.value - p.lower) / (p.upper - p.lower) for p in fitted])
    sigma = dict.fromkeys(model.joints, 1.0)
    total = 0.0
    for _ in range(2):
        weights = _weights(samples, model, settings, sigma)
        statistics = design.statistics(samples, model, weights)
        z, stats, seconds, hessian = _solve(model, settings, statistics, z)
        total += seconds
        if _failed(stats):
            raise SolveFailed(f"passive decomposition: Ipopt stopped with "
                              f"'{stats['return_status']}' after {stats['iter_count']} "
                              "iterations; no result is reported. Check the bounds and "
                              "the quiet phases.", best=None)
        values = _values(model, z)
        passive = passive_moments(samples, model, values)
        for j, joint in enumerate(model.joints):
            use = weights[:, 2 * j] > 0
            n_fit = sum(p.joint == joint for p in fitted)
            residual = samples.moments[joint][use] - passive[joint][use]
            dof = max(use.sum() / m - n_fit, 1.0)
            sigma[joint] = max(float(np.sqrt(np.sum(residual ** 2) / m / dof)), 1e-3)
    spans = np.array([p.upper - p.lower for p in fitted])
    information = 0.5 * np.array(hessian(z, statistics)) / np.outer(spans, spans)
    return Decomposition(
        values=values, z=z, information=information, noise_sd=sigma, passive=passive,
        active={j: samples.moments[j] - passive[j] for j in model.joints},
        quiet=samples.in_phases(settings.quiet_phases), weights=weights,
        status=stats["return_status"], iterations=int(stats["iter_count"]), seconds=total)


@dataclass(frozen=True, eq=False)
class Bootstrap:
    """Bootstrap replicates of the fitted parameters.

    Attributes:
        values: (B, f) fitted parameter values (SI), one row per replicate.
        unit: ``gait cycle`` or ``block of S s``: what was resampled.
        n_units: Number of resampling units that hold quiet samples (the ones that carry
            information on the parameters; it sets the small-sample correction).
        failed: Replicates where Ipopt failed (left out).
    """

    values: np.ndarray
    unit: str
    n_units: int
    failed: int


def resampling_units(samples: GaitSamples, *, min_cycles: int = 6, block_s: float = 0.1
                     ) -> tuple[np.ndarray, str]:
    """(n,) unit index per sample (-1: none) and its description.

    Gait cycles when the trial has at least ``min_cycles`` with quiet samples, otherwise
    consecutive blocks of ``block_s`` s (a moving-block bootstrap: blocks longer than the
    correlation time keep the residuals' correlation).
    """
    cycles = np.unique(samples.cycle[samples.cycle >= 0])
    if cycles.size >= min_cycles:
        return samples.cycle.copy(), "gait cycle"
    block = np.floor((samples.time - samples.time[0]) / block_s).astype(int)
    return np.where(samples.cycle >= 0, block, -1), f"block of {block_s:g} s"


def bootstrap(samples: GaitSamples, model: PassiveModel, fit: Decomposition,
              settings: Settings = Settings(), *, repeats: int = 200, seed: int = 0,
              min_cycles: int = 6, block_s: float = 0.1) -> Bootstrap:
    """Refit on resampled gait cycles (or blocks), warm-started at ``fit``.

    Units that hold no quiet sample are still resampled (they carry the smoothness term).
    """
    units, kind = resampling_units(samples, min_cycles=min_cycles, block_s=block_s)
    labels = np.unique(units[units >= 0])
    position = np.searchsorted(labels, units)
    rng = np.random.default_rng(seed)
    design = _Design.of(samples, model)
    fitted = model.fitted
    lower = np.array([p.lower for p in fitted])
    span = np.array([p.upper - p.lower for p in fitted])
    rows, failed = [], 0
    for _ in range(repeats):
        counts = np.bincount(rng.integers(0, labels.size, labels.size), minlength=labels.size)
        multiplicity = np.where(units >= 0, counts[np.clip(position, 0, labels.size - 1)], 0)
        statistics = design.statistics(samples, model, fit.weights * multiplicity[:, None])
        z, stats, *_ = _solve(model, settings, statistics, fit.z)
        if _failed(stats):
            failed += 1
            continue
        rows.append(lower + span * z)
    informative = np.unique(units[(units >= 0) & fit.quiet])
    return Bootstrap(np.array(rows).reshape(-1, len(fitted)), kind, int(informative.size),
                     failed)
