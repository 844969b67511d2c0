"""One answer per joint from a passive fit: parameters, a curve with a band, or what is missing.

A lab reports one of three things for each joint (issue 28), decided from the fit's
verdicts (:mod:`predgait.problems.identifiability`) and its Fisher information F:

* **parameters**: every fitted parameter of the joint identified or consistent with zero;
  the parameters with their intervals, and the curve below.
* **curve**: the parameters trade off (not separately identifiable, or at a bound) but the
  elastic passive moment M(theta) = tau_passive(theta, 0; p) over the observed quiet range
  is determined: its 95 % band, 1.96 sqrt(g^T F^-1 g) (g = dM/dp, the delta method), is
  narrower than half the curve's largest |M| (:data:`CURVE_FRACTION`) and the curve leaves
  zero somewhere.
* **not identifiable**: then "need N more quiet swings": the Fisher information grows in
  proportion to the number of quiet swings S (independent repeats of the same phase), so
  standard errors shrink by sqrt(S / S'); N = S' - S is the fewest extra swings at which
  the first of the two criteria above would hold (every such parameter's 1.96 SE within
  half its bound range, or the curve's band). A parameter that moves between quiet
  windows (``window_dependent``) is not helped by more swings of the same kind: the
  quiet-muscle assumption fails there, and the answer says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from predgait.problems.identifiability import BOUND_FRACTION, ParameterReport, Status
from predgait.problems.passive_model import PassiveModel

#: The curve is determined when its 95 % band is below this fraction of its largest |M|.
CURVE_FRACTION = 0.5
#: Points of the reported curve over the observed range.
CURVE_POINTS = 21
SETTLED = (Status.IDENTIFIED, Status.CONSISTENT_WITH_ZERO)


@dataclass(frozen=True)
class JointAnswer:
    """What the trial says about one joint.

    Attributes:
        joint: ``knee`` or ``ankle``.
        kind: ``parameters``, ``curve``, ``not_identifiable`` or ``window_dependent``.
        text: The sentence a lab reports.
        angle: (CURVE_POINTS,) clinical angles over the observed quiet range, rad.
        moment: (CURVE_POINTS,) elastic passive moment there, N m.
        band: (CURVE_POINTS,) 95 % half-width of the moment, N m.
        swings_needed: Extra quiet swings for an answer (``not_identifiable``), else None.
    """

    joint: str
    kind: str
    text: str
    angle: np.ndarray
    moment: np.ndarray
    band: np.ndarray
    swings_needed: int | None = None

    def as_dict(self) -> dict:
        """JSON-ready (the curve in deg and N m)."""
        return {"answer": self.kind, "text": self.text, "swings_needed": self.swings_needed,
                "curve": {"angle_deg": np.degrees(self.angle).round(3).tolist(),
                          "moment_n_m": self.moment.round(4).tolist(),
                          "band95_n_m": self.band.round(4).tolist()}}


def elastic_curve(model: PassiveModel, values: dict, information: np.ndarray, joint: str,
                  angles) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(angle grid, M(angle), 95 % band) over the range of ``angles`` (rad), N m."""
    grid = np.linspace(np.nanmin(angles), np.nanmax(angles), CURVE_POINTS)
    return (grid, *elastic_moment(model, values, information, joint, grid))


def elastic_moment(model: PassiveModel, values: dict, information: np.ndarray, joint: str,
                   angles) -> tuple[np.ndarray, np.ndarray]:
    """(M(angles), 95 % band) of the joint's elastic passive moment, N m (angles in rad).

    M = tau_passive(theta, 0; p); band 1.96 sqrt(g^T F^-1 g), g = dM/dp by central
    differences over the joint's fitted parameters (the delta method).
    """
    angles = np.asarray(angles, dtype=float)
    fitted = model.fitted

    def curve(vals):
        return np.asarray(model.passive_joint(joint, vals).moment(angles,
                                                                  np.zeros_like(angles)))

    moment = curve(values)
    gradient = np.zeros((angles.size, len(fitted)))
    for i, p in enumerate(fitted):
        if p.joint != joint:
            continue
        h = 1e-6 * (p.upper - p.lower)
        up, down = dict(values), dict(values)
        up[p.key] += h
        down[p.key] -= h
        gradient[:, i] = (curve(up) - curve(down)) / (2 * h)
    covariance = np.linalg.pinv(information, rcond=1e-12, hermitian=True)
    variance = np.einsum("ij,jk,ik->i", gradient, covariance, gradient)
    return moment, 1.96 * np.sqrt(np.clip(variance, 0.0, None))


def _curve_ratio(moment, band) -> float:
    """Band / allowed band (<= 1: the curve is determined)."""
    peak = float(np.max(np.abs(moment)))
    return math.inf if peak <= 0 else float(np.max(band)) / (CURVE_FRACTION * peak)


def joint_answer(model: PassiveModel, values: dict, information: np.ndarray,
                 reports: list[ParameterReport], joint: str, angles, *, swings: int
                 ) -> JointAnswer:
    """The answer for ``joint`` (module docstring).

    ``angles``: the joint's quiet-sample clinical angles, rad; ``swings``: the quiet
    swings the fit used; ``information``: the fit's Fisher information (SI).
    """
    grid, moment, band = elastic_curve(model, values, information, joint, angles)
    mine = [r for r in reports if r.key.startswith(f"{joint}.") and r.status is not
            Status.FIXED]
    span = f"{np.degrees(grid[0]):.0f} to {np.degrees(grid[-1]):.0f} deg"
    at = (f"M = {moment[0]:+.2f} +- {band[0]:.2f} N m at {np.degrees(grid[0]):.0f} deg, "
          f"{moment[-1]:+.2f} +- {band[-1]:.2f} N m at {np.degrees(grid[-1]):.0f} deg")
    moving = [r.key for r in mine if r.status is Status.WINDOW_DEPENDENT]
    if moving:
        return JointAnswer(joint, "window_dependent", (
            f"not identifiable from this trial: {', '.join(moving)} change(s) with the quiet "
            "window, so the muscles are not quiet over all of it; more swings of the same "
            "kind will not settle it (shorten the window to where the muscles are silent, "
            "e.g. from EMG)"), grid, moment, band)
    if all(r.status in SETTLED for r in mine):
        words = "; ".join(f"{r.key} {r.value:.3g} [{r.interval95[0]:.3g}, "
                          f"{r.interval95[1]:.3g}] {r.unit}" for r in mine)
        return JointAnswer(joint, "parameters", f"parameters {words}; elastic curve over "
                           f"{span}: {at}", grid, moment, band)
    ratio = _curve_ratio(moment, band)
    if ratio <= 1.0 and np.any(np.abs(moment) > band):
        return JointAnswer(joint, "curve", (
            f"the parameters are not separately identifiable ("
            f"{', '.join(r.key for r in mine if r.status not in SETTLED)}), but the elastic "
            f"passive moment over the observed {span} is: {at}"), grid, moment, band)
    needed = _swings_needed(model, information, mine, ratio, swings)
    return JointAnswer(joint, "not_identifiable", (
        f"not identifiable from this trial ({swings} quiet swing(s)): need about {needed} "
        f"more quiet swing(s) (Fisher information scaled by the number of swings)"),
        grid, moment, band, needed)


def _swings_needed(model, information, reports, curve_ratio, swings) -> int:
    """Fewest extra swings for the parameters' or the curve's criterion (docstring)."""
    covariance = np.linalg.pinv(information, rcond=1e-12, hermitian=True)
    keys = [p.key for p in model.fitted]
    worst = 0.0
    for r in reports:
        if r.status in SETTLED:
            continue
        p = model.fitted[keys.index(r.key)]
        se = math.sqrt(max(covariance[keys.index(r.key), keys.index(r.key)], 0.0))
        target = BOUND_FRACTION * (p.upper - p.lower) / 1.96
        worst = max(worst, (se / target) ** 2)
    factor = min(worst, curve_ratio ** 2) if worst > 0 else curve_ratio ** 2
    if not math.isfinite(factor):
        factor = worst
    return max(1, math.ceil(swings * max(factor, 1.0)) - swings)
