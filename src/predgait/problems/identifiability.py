"""Which fitted passive parameters the data identify, and their 95 % intervals.

Two independent views of one fit (:mod:`predgait.problems.decomposition` or
:mod:`predgait.problems.shooting`; any fit with ``values`` and ``information``):

* Fisher information F (Hessian / 2 of the fit's negative log-likelihood objective, in
  effectively independent samples): standard errors sqrt(diag F^-1) and the correlation
  matrix. A parameter is reported **not identifiable** when the data constrain it no
  better than its bounds (1.96 SE >= half the bound range); the report then names the
  parameters it is confounded with (|correlation| >= 0.99). A high correlation alone
  does not condemn a parameter whose own SE is small.
* Profile likelihood, when the fit gives one (``fit.profile``: the swing fits' rest
  angles theta0, :mod:`predgait.problems.profile_likelihood`): it replaces the Fisher
  interval +- 1.96 SE of that parameter (theta0 is a ratio of linear terms; its
  likelihood is skewed).
* Bootstrap over gait cycles (or blocks of samples): half-width
  t_{U-1, 0.975} sqrt(U / (U - 1)) SD_boot (U resampling units; the small-sample
  correction of the bootstrap SE, Davison & Hinkley 1997, sec. 2.3). The reported 95 %
  interval is the estimate +- the wider of this and the Fisher half-width 1.96 SE (with
  few units the bootstrap SD is itself uncertain; the Fisher one alone without a
  bootstrap), clipped to the bounds. The bootstrap
  also flags non-identifiability when its interval spans at least half of the bound
  range.

Statuses mean one thing each (:class:`Status`): **identified** only when the interval
excludes 0 (for the magnitudes k, c, k_lower, ...: 0 is "no element") and both bounds;
**consistent_with_zero** when it reaches 0; **at_bound** when it reaches another bound
(the bound, not the data, then sets one end); **not_identifiable** as above (no interval);
**window_dependent** when the same fit over other defensible quiet windows moves the value
outside this interval (:func:`mark_window_dependent`). A neutral angle theta0 whose spring
k is consistent with zero or not identifiable is not identifiable (with k = 0 it has no
effect). A bootstrap over fewer than :data:`MIN_BOOTSTRAP_UNITS` units is not used: its SD
comes from too few distinct resamples (2 units: 3 of them); the interval is then the
Fisher one alone and the report says so (``interval_method``).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace

import numpy as np

from predgait.problems.decomposition import Bootstrap, Decomposition
from predgait.problems.passive_model import PassiveModel
from predgait.problems.shooting import ShootingFit

#: |correlation| at or above which two parameters are called confounded.
CONFOUNDED = 0.99
#: Fraction of the bound range an interval may span before the parameter is unidentified.
BOUND_FRACTION = 0.5
#: Fewest resampling units (gait cycles, blocks) whose bootstrap SD is used.
MIN_BOOTSTRAP_UNITS = 6


class Status(enum.Enum):
    """Verdict on one parameter (module docstring)."""

    FIXED = "fixed"
    IDENTIFIED = "identified"
    CONSISTENT_WITH_ZERO = "consistent_with_zero"
    AT_BOUND = "at_bound"
    NOT_IDENTIFIABLE = "not_identifiable"
    WINDOW_DEPENDENT = "window_dependent"


@dataclass(frozen=True)
class ParameterReport:
    """One parameter's value, verdict and interval.

    Attributes:
        key: ``joint.name``.
        value: Estimate (or fixed value), SI.
        unit: SI unit.
        status: :class:`Status`.
        interval95: (low, high) or None (fixed, not identifiable).
        fisher_se: Standard error from the Fisher information (None when fixed).
        reasons: Why it is not identifiable (or window-dependent; empty otherwise).
        note: E.g. "consistent with 0 (interval reaches the lower bound)".
        meaning: What the parameter is (``passive_model.MEANINGS``).
        interval_method: How the interval was made (bootstrap and Fisher, Fisher only).
    """

    key: str
    value: float
    unit: str
    status: Status
    interval95: tuple[float, float] | None
    fisher_se: float | None
    reasons: tuple[str, ...] = ()
    note: str = ""
    meaning: str = ""
    interval_method: str = ""

    def as_dict(self) -> dict:
        """JSON-ready."""
        return {"value": self.value, "unit": self.unit, "status": self.status.value,
                "interval95": list(self.interval95) if self.interval95 else None,
                "fisher_standard_error": self.fisher_se, "reasons": list(self.reasons),
                "note": self.note, "meaning": self.meaning,
                "interval_method": self.interval_method}


def _t975(dof: int) -> float:
    from scipy.stats import t

    return float(t.ppf(0.975, max(dof, 1)))


def fisher(information: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors (f,) and correlation matrix (f, f) from the Fisher information."""
    covariance = np.linalg.pinv(information, rcond=1e-12, hermitian=True)
    se = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation = covariance / np.outer(se, se)
    return se, np.nan_to_num(correlation)


def bootstrap_usable(boot: Bootstrap | None) -> bool:
    """Whether a bootstrap has enough units (:data:`MIN_BOOTSTRAP_UNITS`) to be used."""
    return (boot is not None and len(boot.values) > 1
            and boot.n_units >= MIN_BOOTSTRAP_UNITS)


def interval_method(boot: Bootstrap | None) -> str:
    """How :func:`assess` makes the intervals for this bootstrap (words for the output)."""
    if bootstrap_usable(boot):
        return (f"bootstrap over {boot.n_units} resampled units ({boot.unit}), widened to "
                "the Fisher interval where that is wider")
    if boot is None:
        return "Fisher information only (no bootstrap)"
    return (f"Fisher information only: {boot.n_units} resampled unit(s) ({boot.unit}) with "
            f"quiet samples, fewer than the {MIN_BOOTSTRAP_UNITS} a bootstrap needs")


def assess(model: PassiveModel, fit: Decomposition | ShootingFit, boot: Bootstrap | None
           ) -> tuple[list[ParameterReport], np.ndarray]:
    """Reports for every parameter (fixed ones too) and the fitted ones' correlation."""
    fitted = model.fitted
    se, correlation = fisher(fit.information)
    spread = None
    if bootstrap_usable(boot):
        u = boot.n_units
        spread = (_t975(u - 1) * np.sqrt(u / (u - 1))
                  * np.std(boot.values, axis=0, ddof=1))
    method = interval_method(boot)
    keys = [p.key for p in fitted]
    reports = {p.key: _report(p, fit, keys, se, correlation, spread, method)
               for p in model.parameters}
    weak = (Status.NOT_IDENTIFIABLE, Status.CONSISTENT_WITH_ZERO)
    for p in fitted:
        if p.name == "theta0":
            report = reports[p.key]
            spring = reports.get(f"{p.joint}.k")
            if spring is not None and report.status is not Status.NOT_IDENTIFIABLE \
                    and spring.status in weak:
                report = replace(report, status=Status.NOT_IDENTIFIABLE, interval95=None,
                                 reasons=(f"its spring {spring.key} is consistent with 0 or "
                                          "not identifiable, and with k = 0 theta0 has no "
                                          "effect",), note="")
            reports[p.key] = report
    return list(reports.values()), correlation


def _report(p, fit, keys, se, correlation, spread, method) -> ParameterReport:
    """The verdict on one parameter (module docstring); ``keys`` the fitted keys in order."""
    value = float(fit.values[p.key])
    if not p.fit:
        return ParameterReport(p.key, value, p.unit, Status.FIXED, None, None,
                               meaning=p.meaning)
    i = keys.index(p.key)
    span = p.upper - p.lower
    reasons = []
    if 1.96 * se[i] >= BOUND_FRACTION * span:
        reasons.append(f"the data constrain it no better than its bounds "
                       f"(Fisher 95 % half-width {1.96 * se[i]:.3g} {p.unit} vs bounds "
                       f"[{p.lower:g}, {p.upper:g}])")
    half = 1.96 * se[i] if spread is None else max(spread[i], 1.96 * se[i])
    interval = (max(p.lower, value - half), min(p.upper, value + half))
    profile = getattr(fit, "profile", {}).get(p.key)
    if profile is not None and not reasons:   # the profile's ends, widened to the bootstrap's
        spread_i = 0.0 if spread is None else spread[i]
        interval = (max(p.lower, min(profile[0], value - spread_i)),
                    min(p.upper, max(profile[1], value + spread_i)))
        method += "; this one: profile likelihood (a rest angle: skewed likelihood)"
    if interval[1] - interval[0] >= BOUND_FRACTION * span and not reasons:
        reasons.append(f"its 95 % interval [{interval[0]:.3g}, {interval[1]:.3g}] spans "
                       "half its bounds or more")
    if reasons:   # say which parameter it trades off with, if any
        reasons += [f"confounded with {other} (correlation {correlation[i, k]:+.3f})"
                    for k, other in enumerate(keys)
                    if k != i and abs(correlation[i, k]) >= CONFOUNDED]
    if reasons:
        return ParameterReport(p.key, value, p.unit, Status.NOT_IDENTIFIABLE, None,
                               float(se[i]), tuple(reasons), meaning=p.meaning,
                               interval_method=method)
    status, note = Status.IDENTIFIED, ""
    if p.lower >= 0 and interval[0] <= 0:
        status = Status.CONSISTENT_WITH_ZERO
        note = (f"consistent with 0: the interval reaches the lower bound (at most "
                f"{interval[1]:.3g} {p.unit})")
    elif interval[0] <= p.lower or interval[1] >= p.upper:
        status = Status.AT_BOUND
        bound = p.lower if interval[0] <= p.lower else p.upper
        note = (f"the interval reaches the bound {bound:g} {p.unit}: the bound, not the data, "
                "sets that end; widen it in [passive.<joint>] bounds or fix the parameter")
    return ParameterReport(p.key, value, p.unit, status, interval, float(se[i]), (), note,
                           meaning=p.meaning, interval_method=method)


def mark_window_dependent(reports: list[ParameterReport], windows: dict[str, dict]
                          ) -> list[ParameterReport]:
    """Reports whose value moves outside their interval between quiet windows.

    Args:
        reports: The main fit's reports.
        windows: Window label (e.g. "73-87 %") -> fitted values (``joint.name`` -> SI) of
            the same fit over that window (other entries ignored), or ``{"failed": why}``.

    Returns:
        The reports, with every one that has an interval and a window value outside it
        turned :attr:`Status.WINDOW_DEPENDENT` (the interval kept, the windows named).
        A window's own verdict (``statuses``: key -> status value), when given, is named
        beside its value: a window that cannot identify the parameter still counts (the
        answer then rests on which samples the user calls quiet: issue 28).
    """
    out = []
    for report in reports:
        if report.interval95 is None or report.status is Status.FIXED:
            out.append(report)
            continue
        low, high = report.interval95
        outside = [f"{label}: {values[report.key]:.4g} {report.unit}"
                   f"{_there(values, report.key)}"
                   for label, values in windows.items()
                   if isinstance(values.get(report.key), float | int)
                   and not low <= values[report.key] <= high]
        if outside:
            report = replace(report, status=Status.WINDOW_DEPENDENT, reasons=(
                f"over other quiet windows it moves outside its 95 % interval "
                f"[{low:.4g}, {high:.4g}] {report.unit} ({'; '.join(outside)})",))
        out.append(report)
    return out


def _there(values: dict, key: str) -> str:
    """", not_identifiable there" (a window's own verdict, when not identified)."""
    status = values.get("statuses", {}).get(key, Status.IDENTIFIED.value)
    return "" if status == Status.IDENTIFIED.value else f", {status} there"


def cramer_rao(jacobian: np.ndarray, covariance: np.ndarray, parameters: int) -> np.ndarray:
    """Cramér-Rao lower bound on the covariance of the first ``parameters`` unknowns.

    For data y = g(theta) + e, e ~ N(0, Sigma), the Fisher information is
    F = J^T Sigma^-1 J (J = dg/dtheta at the truth), and any unbiased estimator has
    cov >= F^-1 (Kay 1993, Fundamentals of Statistical Signal Processing I, eq. 3.31).
    The remaining columns (e.g. initial states) are nuisance parameters: the bound is
    the leading block of F^-1, i.e. the inverse of the Schur complement (they are
    profiled out, not held at the truth).

    Args:
        jacobian: (n, f + k) d data / d unknowns at the truth, parameters first.
        covariance: (n, n) noise covariance of the data (correlated noise allowed), or
            (n,) variances of independent noise.
        parameters: f, how many leading columns are the parameters of interest.

    Returns:
        (f, f) the bound's covariance; sqrt of its diagonal are the bound's SDs.

    Raises:
        ValueError: Shapes disagree, the covariance is not positive definite, or the
            Jacobian's columns are linearly dependent (F singular: no finite bound).
    """
    jacobian = np.asarray(jacobian, dtype=float)
    covariance = np.asarray(covariance, dtype=float)
    if covariance.ndim == 1:
        covariance = np.diag(covariance)
    n = jacobian.shape[0]
    if covariance.shape != (n, n) or not 0 < parameters <= jacobian.shape[1]:
        raise ValueError(f"cramer_rao: Jacobian {jacobian.shape}, covariance "
                         f"{covariance.shape}, {parameters} parameters do not agree.")
    from scipy.linalg import cho_factor, cho_solve, solve_triangular

    factor = np.linalg.cholesky(covariance)                     # raises if not PD
    whitened = solve_triangular(factor, jacobian, lower=True)   # Sigma^-1/2 J
    information = whitened.T @ whitened
    if np.linalg.matrix_rank(whitened) < jacobian.shape[1]:
        raise ValueError("cramer_rao: singular Fisher information (dependent columns); "
                         "no finite bound.")
    bound = cho_solve(cho_factor(information), np.eye(jacobian.shape[1]))
    return bound[:parameters, :parameters]
