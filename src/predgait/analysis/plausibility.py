"""Is a result plausible for walking? One way to check it and to record the warnings.

A :class:`Check` is one quantity of a result against a published bound; the checks that
fail become the result's warnings: :func:`record` adds them to its summary (``plausibility``:
every check; ``warnings``: one line per failed check naming the quantity, its value, the
bound and its source) and turns ``completed`` into ``completed with warnings``. Every
workflow (inverse leg and full body, simulate, scenario, solve) and the muscle prediction's
human-likeness checks (:mod:`predgait.analysis.human_likeness`) use these.

Bounds (walking; each with its source):

* joint moments, N m/kg: :data:`MOMENT_BOUNDS` (Winter 2009, Biomechanics and Motor
  Control of Human Movement, 4th ed., ch. 5, and Kadaba et al. 1989, J Orthop Res 7:849:
  normal walking peaks ankle plantarflexor ~1.6, knee ~0.7-1.0, hip ~1.0-1.2 N m/kg;
  the bounds leave ~40 % above the fastest normal walking);
* vertical ground reaction <= 2 BW (Keller et al. 1996, Clin Biomech 11:253: walking
  peaks 1.0-1.5 BW; 2 BW and more is running);
* pelvis residual force <= 5 % of the peak ground reaction (Hicks et al. 2015, J Biomech
  Eng 137:020905, "Is my model good enough?");
* marker RMS error <= 20 mm per trusted marker (IK weight > 0.5) (Hicks et al. 2015; OpenSim's IK
  best practice: RMS under 1-2 cm);
* body mass within 5 % of the mass the plates measure (:mod:`predgait.data.body_weight`;
  5 %: Hicks et al. 2015's bound on a mass change after RRA);
* a feedback torque no larger than the drive it corrects (the subject's measured peak
  joint moment from inverse dynamics): feedback corrects deviations from the measured
  motion (thesis 4.2), it does not walk for the subject;
* a scenario's baseline gait passes its human-likeness checks (a comparison with a gait
  that is not human says little about a person).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

#: Largest |joint moment| (N m/kg) of walking per joint (module docstring).
MOMENT_BOUNDS = {"hip": 2.0, "knee": 1.6, "ankle": 2.2}
MOMENT_SOURCE = ("Winter 2009 ch. 5, Kadaba et al. 1989: normal peaks ankle 1.6, knee <= 1.0, "
                 "hip <= 1.2 N m/kg")
MAX_GRF_BW = 2.0
GRF_SOURCE = "Keller et al. 1996, walking 1.0-1.5 BW"
MAX_RESIDUAL_FRACTION = 0.05
RESIDUAL_SOURCE = "Hicks et al. 2015, residual force < 5 % of the peak external force"
MAX_MARKER_RMS_M = 0.020
MARKER_SOURCE = "Hicks et al. 2015; OpenSim IK best practice, marker RMS < 2 cm"
MAX_MASS_FRACTION = 0.05
MASS_SOURCE = "plates: mean vertical GRF over a step / g; 5 %: Hicks et al. 2015"
FEEDBACK_SOURCE = "the subject's measured peak moment, inverse dynamics; thesis 4.2"
FEEDFORWARD_SOURCE = ("the feedforward torque it corrects (feedback corrects deviations, "
                      "thesis 4.2)")
BASELINE_SOURCE = ("the baseline's human-likeness checks against measured normal gait "
                   "(analysis.human_likeness)")
#: Statuses of a run that ended as planned, which a failed check qualifies.
FINISHED = ("completed", "solved")


@dataclass(frozen=True)
class Check:
    """One check: name, value, bound ("<= x unit" / ">= x unit"), source, passed."""

    name: str
    value: float
    bound: str
    source: str
    passed: bool
    unit: str = ""
    advice: str = ""

    def line(self) -> str:
        """The warning: quantity, value, bound, source (and what to do, if anything)."""
        value = f"{self.value:.3g}" + (f" {self.unit}" if self.unit else "")
        advice = f"; {self.advice}" if self.advice else ""
        return f"{self.name} = {value}, outside {self.bound} ({self.source}){advice}"


def at_most(name: str, value: float, limit: float, *, unit: str, source: str,
            advice: str = "") -> Check:
    """``value <= limit`` (a NaN value passes: nothing to judge)."""
    return Check(name, float(value), f"<= {limit:.3g} {unit}".rstrip(), source,
                 not value > limit, unit, advice)


def joint_moment_checks(peaks: Mapping[str, float]) -> list[Check]:
    """Peak |joint moment| per joint (N m/kg; keys start with hip/knee/ankle)."""
    checks = []
    for key, value in peaks.items():
        joint = next((j for j in MOMENT_BOUNDS if key.startswith(j)), None)
        if joint is not None and value is not None and math.isfinite(value):
            checks.append(at_most(f"peak |{key}|", value, MOMENT_BOUNDS[joint],
                                  unit="N m/kg", source=MOMENT_SOURCE))
    return checks


def grf_check(peak_bw: float, what: str = "peak vertical ground reaction") -> Check:
    """Peak vertical ground reaction in body weights."""
    return at_most(what, peak_bw, MAX_GRF_BW, unit="BW", source=GRF_SOURCE)


def residual_check(max_force: float, peak_external: float) -> Check:
    """Largest pelvis residual force (N) against the peak ground reaction (N)."""
    limit = MAX_RESIDUAL_FRACTION * peak_external
    return Check("peak pelvis residual force", float(max_force),
                 f"<= {limit:.0f} N = 5 % of the peak ground reaction {peak_external:.0f} N",
                 RESIDUAL_SOURCE, not max_force > limit, "N")


def marker_check(rms_m: Mapping[str, float]) -> Check:
    """Per-marker RMS IK error (m) of the trusted markers: the worst one, naming all above."""
    finite = {k: v for k, v in rms_m.items() if v is not None and math.isfinite(v)}
    if not finite:
        return Check("marker RMS error", math.nan, "", MARKER_SOURCE, True, "mm")
    worst = max(finite, key=finite.get)
    above = [k for k, v in sorted(finite.items(), key=lambda kv: -kv[1])
             if v > MAX_MARKER_RMS_M]
    others = [k for k in above if k != worst]
    return at_most(f"marker RMS error of {worst}", 1000 * finite[worst],
                   1000 * MAX_MARKER_RMS_M, unit="mm", source=MARKER_SOURCE,
                   advice=f"also above the bound: {', '.join(others)}" if others else "")


def mass_check(mass: float, plate_mass: float | None) -> Check | None:
    """The given body mass (kg) against the plates' (kg); None when the plates cannot say."""
    if plate_mass is None:
        return None
    off = abs(mass - plate_mass) / plate_mass
    return Check("body mass", mass,
                 f"{plate_mass:.1f} kg +- {100 * MAX_MASS_FRACTION:g} % (the plates' mass)",
                 MASS_SOURCE, off <= MAX_MASS_FRACTION, "kg",
                 "" if off <= MAX_MASS_FRACTION else
                 f"check the mass; the plates' value is --mass {plate_mass:.1f}, or --mass "
                 f"plates (problem file: [trial] mass = {plate_mass:.1f} or \"plates\")")


def feedback_checks(feedback: Mapping[str, float], measured: Mapping[str, float], *,
                    what: str = "feedback torque") -> list[Check]:
    """Peak |feedback torque| per joint (N m) against the peak |measured moment| (N m).

    ``what`` names the added torque (a feedback, a torque correction, a fitted spring).
    """
    return [at_most(f"peak |{joint} {what}|", value, measured[joint], unit="N m",
                    source=FEEDBACK_SOURCE)
            for joint, value in feedback.items()
            if joint in measured and value is not None and math.isfinite(value)]


def worst_feedback_check(feedback: Mapping[str, float], measured: Mapping[str, float], *,
                         what: str = "feedback torque") -> Check | None:
    """One feedback check for many joints (the whole body), as :func:`marker_check`.

    The joint whose peak |feedback| (N m) is the largest multiple of its peak |measured
    moment| (N m) against that bound; the other joints above theirs are named in its
    advice. None when no joint has both values.
    """
    pairs = {j: (v, measured[j]) for j, v in feedback.items()
             if j in measured and v is not None and math.isfinite(v)}
    if not pairs:
        return None

    def ratio(joint: str) -> float:
        value, bound = pairs[joint]
        return value / bound if bound > 0 else math.inf if value > 0 else 0.0

    worst = max(pairs, key=ratio)
    above = [j for j in sorted(pairs, key=ratio, reverse=True)
             if j != worst and pairs[j][0] > pairs[j][1]]
    return at_most(f"peak |{worst} {what}|", pairs[worst][0], pairs[worst][1], unit="N m",
                   source=FEEDBACK_SOURCE,
                   advice=f"also above their measured peaks: {', '.join(above)}" if above
                   else "")


def baseline_check(failed: int, total: int) -> Check | None:
    """A comparison's baseline gait against normal gait (None when no check was run).

    ``failed`` of its ``total`` human-likeness checks failed; any fails it. A scenario's
    predicted changes are those of its baseline: from a gait that is not human they say
    little about a person.
    """
    if not total:
        return None
    return Check("baseline gait: failed checks against normal gait", float(failed),
                 f"<= 0 of {total}", BASELINE_SOURCE, failed == 0,
                 advice="" if failed == 0 else "the predicted changes are those of a gait "
                 "that is not yet human (baseline.warnings)")


def record(summary: dict, checks: Iterable[Check | None], *, key: str = "plausibility"
           ) -> dict:
    """Add the checks to a summary (in place, returned): ``key``, ``warnings``, status.

    ``warnings`` gets one line per failed check (after any it holds); a ``completed``
    (``solved``) status becomes ``completed with warnings`` (``solved with warnings``),
    ``completed with N flagged frames`` gets ``and warnings``; other statuses (not
    converged, event, diverged) are kept.
    """
    checks = [c for c in checks if c is not None]
    failed = [c.line() for c in checks if not c.passed]
    summary[key] = [{**vars(c)} for c in checks]
    summary["warnings"] = [*summary.get("warnings", []), *failed]
    status = str(summary.get("status", ""))
    if failed and status in FINISHED:
        summary["status"] = f"{status} with warnings"
    elif failed and status.startswith(FINISHED) and "warnings" not in status:
        summary["status"] = f"{status} and warnings"
    return summary


def warning_lines(summary: dict) -> list[str]:
    """The summary's warnings as console lines (``  warning: ...``)."""
    return [f"  warning: {w}" for w in summary.get("warnings", []) if isinstance(w, str)]
