"""``predgait solve`` kind ``passive_swing``: passive knee and ankle from the swing angles.

The quiet phases of every gait cycle are simulated under the measured thigh with the
passive model as the only joint moment, and its parameters fitted to the measured ankle
and knee angles (:mod:`predgait.problems.passive_swing`); no inverse-dynamics moment
enters the fit. The moment decomposition on the same trial gives the first guess. The
markers are filtered at ``[filter] marker_cutoff``, by default a third of the marker rate
and at most 30 Hz (:func:`default_cutoff`; 20 Hz at 60 Hz, 30 Hz at 100 Hz and above): the
angles are fitted, not differentiated, and a lower cut-off flattens the fastest swing
motion, the knee's terminal extension into its stop, which biases the knee (known-answer
walk at 100 Hz, 3 cycles, 73-95 %, 60 noise seeds: at 20 Hz knee k, c, theta0 off by
+0.5 to +0.8, -0.5 to -0.7 and +0.6 to +0.8 standard errors on average; at 30 Hz within
0.2; docs/DEVELOPING.md). The fit is repeated at the ``sensitivity_hz`` cut-offs to show
how much the values depend on it.
Writes solution.json, passive_moments.sto and swing_angles.sto.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from predgait.data import write_storage
from predgait.errors import InputError, SolveFailed
from predgait.problemfile import Table
from predgait.problems.decomposition import Settings, fit_decomposition
from predgait.problems.gait_samples import GaitSamples
from predgait.problems.identifiability import assess, mark_window_dependent
from predgait.problems.literature_check import literature_check
from predgait.problems.passive_answer import joint_answer
from predgait.problems.passive_model import PassiveModel
from predgait.problems.passive_moment_rows import MomentRows
from predgait.problems.passive_swing import SwingSettings, Windows, bootstrap_swing, fit_swing
from predgait.report.console import cutoff_lines, parameter_lines
from predgait.report.figures import plots_wanted
from predgait.report.tidy import write_summary
from predgait.workflows.decomposition import (
    bootstrap_summary,
    check_cutoff,
    cycle_words,
    fitted_values,
    inverse_samples,
    residual_cutoff,
    write_passive_moments,
)
from predgait.workflows.output import staged_output
from predgait.workflows.passive_tables import (
    Resampling,
    parse_filter,
    parse_joints,
    parse_passive_model,
    parse_phases,
    parse_uncertainty,
)
from predgait.workflows.passive_windows import (
    DEFENSIBLE_WINDOWS,
    parse_windows,
    window_lines,
    window_sensitivity,
)
from predgait.workflows.trials import LegTrial, leg_trial

METHOD = ("simulation of each quiet phase (muscles quiet, foot off the ground) of every "
          "gait cycle: shank and foot under the measured thigh (hip centre and thigh pitch "
          "prescribed), the passive model the only joint moment (RK4 on the engine's "
          "equations); parameters and each window's initial state fitted to the measured "
          "ankle and knee angles (bounded Gauss-Newton); 95 % intervals from a bootstrap "
          "over gait cycles widened to the Fisher-information interval where that is wider")
WHAT = ("passive joint moments (tissue properties under the quiet-muscle assumption), "
        "identified from the measured angles rather than from the inverse-dynamics moments")
MOMENTS = ("; kind passive_knee_ankle: the quiet samples' inverse-dynamics moments fitted "
           "too, as a second residual weighted by their measured noise (1 / sigma_m^2 per "
           "joint, re-estimated after each pass); intervals from the Fisher information of "
           "both residuals")
#: Fewest quiet swings (gait cycles with a quiet window) a fit accepts.
MIN_SWINGS = 2
#: Highest default marker cut-off of this fit, Hz (module docstring).
MAX_DEFAULT_CUTOFF_HZ = 30.0
#: The default cut-off's share of the marker rate (a third: 20 Hz at 60 Hz).
DEFAULT_CUTOFF_SHARE = 1.0 / 3.0
DEFAULT_CHOICE = ("default: a third of the marker rate, at most "
                  f"{MAX_DEFAULT_CUTOFF_HZ:g} Hz (forces at the same cut-off)")


@dataclass(frozen=True)
class SwingSpec:
    """A parsed ``passive_swing`` problem file (see problems/passive_swing.toml)."""

    source: Path
    trial: LegTrial
    model: PassiveModel
    settings: SwingSettings
    cutoff: float | None            # Hz; None: residual analysis or the default
    sensitivity_hz: tuple[float, ...]
    resampling: Resampling
    windows: tuple[tuple[float, float], ...] = DEFENSIBLE_WINDOWS
    moments: bool = False           # kind passive_knee_ankle: the moments fitted too
    default_cutoff: bool = True     # no marker_cutoff given: :func:`default_cutoff`


def parse_knee_ankle(table: Table) -> SwingSpec:
    """Kind ``passive_knee_ankle`` (problems/passive_knee_ankle.toml), same keys.

    The swing fit with the quiet samples' inverse-dynamics moments as a second residual.
    """
    return replace(parse_swing(table), moments=True)


def parse_swing(table: Table) -> SwingSpec:
    """SwingSpec from a problem file (errors name the file, key and line)."""
    table.check_keys(("kind", "joints", "quiet_phases", "trial", "filter", "simulation",
                      "uncertainty", "passive", "window_sensitivity"))
    joints = parse_joints(table)
    trial = leg_trial(table.table("trial"))
    filt = table.table("filter")
    cutoff, sensitivity = parse_filter(filt, sensitivity=(10.0, 15.0, 25.0))
    sim = table.table("simulation")
    sim.check_keys(("step_s", "max_iter", "initial_angle_span_deg", "initial_rate_span_deg_s"))
    return SwingSpec(
        source=table.path, trial=trial, model=parse_passive_model(table.table("passive"),
                                                                  joints),
        settings=SwingSettings(
            quiet_phases=parse_phases(table) if table.has("quiet_phases")
            else SwingSettings().quiet_phases,
            step_s=sim.number("step_s", 0.01, low=1e-4, high=0.02, unit="s"),
            max_iter=int(sim.number("max_iter", 50, low=1, high=1000)),
            initial_angle_span=np.radians(sim.number("initial_angle_span_deg", 8.6, low=0.1,
                                                     high=45.0, unit="deg")),
            initial_rate_span=np.radians(sim.number("initial_rate_span_deg_s", 172.0,
                                                    low=1.0, high=2000.0, unit="deg/s"))),
        cutoff=cutoff, sensitivity_hz=sensitivity,
        resampling=parse_uncertainty(table.table("uncertainty"), blocks=False),
        windows=parse_windows(table), default_cutoff=not filt.has("marker_cutoff"))


def default_cutoff_hz(rate: float) -> float:
    """The swing fits' default marker cut-off at a marker ``rate`` (Hz), Hz.

    A third of the rate, at most :data:`MAX_DEFAULT_CUTOFF_HZ` (module docstring); below
    the Nyquist frequency.
    """
    return min(MAX_DEFAULT_CUTOFF_HZ, DEFAULT_CUTOFF_SHARE * float(rate))


def default_cutoff(options) -> float:
    """:func:`default_cutoff_hz` at the marker rate of a trial's inverse options, Hz."""
    from predgait.dynamics.leg_measurements import read_trial

    return default_cutoff_hz(read_trial(options)[0].markers.rate)


def chosen_cutoff(spec: SwingSpec, options) -> tuple[float, str]:
    """(marker cut-off, Hz; how it was chosen): given, the default, or residual analysis."""
    if spec.cutoff is not None:
        return spec.cutoff, "given"
    if spec.default_cutoff:
        return default_cutoff(options), DEFAULT_CHOICE
    return residual_cutoff(options), ("Winter's residual analysis of the trial's markers "
                                      "(forces at the same cut-off)")


def _fit_at(spec: SwingSpec, options, cutoff: float, *, profile: bool = True):
    """Inverse dynamics at ``cutoff``, windows, decomposition start, angle fit."""
    samples, inverse = inverse_samples(options, cutoff)
    return (samples, inverse, *_fit_over(spec, samples, inverse, spec.settings,
                                         profile=profile))


def _fit_over(spec: SwingSpec, samples, inverse, settings: SwingSettings, *,
              profile: bool = True):
    """Windows, decomposition start and angle fit over ``settings.quiet_phases``.

    ``profile``: the rest angles' profile-likelihood intervals too (the main fit only;
    the sensitivity refits report values and Fisher intervals).
    """
    where = f"{spec.source}: quiet_phases"
    windows = Windows.from_inverse(inverse, samples, settings, where=where)
    swings = samples.cycle_counts(windows_mask(samples, windows))["quiet_swings"]
    if swings < MIN_SWINGS:
        raise InputError(f"{where}: {settings.quiet_phases} % gait cycle holds quiet samples "
                         f"off the ground in {swings} gait cycle(s) of "
                         f"{samples.source or 'the trial'}; at least {MIN_SWINGS} quiet swings "
                         "are needed (one swing cannot tell the tissue from that swing's "
                         "noise). Use a longer trial or widen the phases.")
    try:
        start = fit_decomposition(samples, spec.model,
                                  Settings(quiet_phases=settings.quiet_phases)).values
    except (InputError, SolveFailed):
        start = None
    rows = MomentRows.of(samples, windows_mask(samples, windows), spec.model) \
        if spec.moments else None
    fit = fit_swing(inverse.model, windows, spec.model, settings, start=start,
                    where=f"{spec.source}: {_kind(spec)}", moments=rows, profile=profile)
    return windows, fit, start


def _kind(spec: SwingSpec) -> str:
    return "passive_knee_ankle" if spec.moments else "passive_swing"


def windows_mask(samples: GaitSamples, windows: Windows) -> np.ndarray:
    """(n,) bool: the trial's samples inside the fit's windows."""
    index = (windows.first[:, None] + np.arange(windows.mask.shape[1]))[windows.mask]
    inside = np.zeros(len(samples.time), dtype=bool)
    inside[index] = True
    return inside


def sensitivity(spec: SwingSpec, options) -> dict:
    """Fitted values (no bootstrap) with the markers filtered at each ``sensitivity_hz``."""
    table = {}
    for cutoff in spec.sensitivity_hz:
        try:
            fit = _fit_at(spec, options, cutoff, profile=False)[3]
        except (InputError, SolveFailed) as exc:
            table[f"{cutoff:g}"] = {"failed": str(exc)}
            continue
        table[f"{cutoff:g}"] = fitted_values(spec.model, fit.values)
    return table


def solve_swing(spec: SwingSpec) -> dict:
    """The fit, its bootstrap and assessment, the cut-off sensitivity; what is written.

    Raises:
        InputError: Bad trial, no quiet window, too few samples (nothing written).
        SolveFailed: The fit did not converge (nothing written).
    """
    options = spec.trial.options()
    chosen, choice = chosen_cutoff(spec, options)
    check_cutoff(spec.source, options, chosen)
    samples, inverse, windows, fit, start = _fit_at(spec, options, chosen)
    res = spec.resampling
    # The replicates re-solve the angle residuals' Gauss-Newton model only: with the
    # moments fitted too, the intervals are the Fisher information's of both.
    boot = bootstrap_swing(windows, spec.model, fit, repeats=res.repeats, seed=res.seed) \
        if res.repeats > 1 and not spec.moments else None
    reports, correlation = assess(spec.model, fit, boot)
    over = window_sensitivity(
        lambda phases: (spec.model, _fit_over(
            spec, samples, inverse, replace(spec.settings, quiet_phases=phases),
            profile=False)[1]),
        spec.settings.quiet_phases, spec.windows, (spec.model, fit))
    reports = mark_window_dependent(reports, over)
    inside = windows_mask(samples, windows)
    literature = literature_check(spec.model, fit.values, fit.information, {
        name: angle[inside] for name, angle in inverse.anatomical_angles().items()})
    residual = fit.residual.reshape(len(windows), -1, 2)[windows.mask]
    rms = np.degrees(np.sqrt(np.mean(residual ** 2, axis=0)))
    solution = {
        "status": "solved", "kind": _kind(spec),
        "method": METHOD + (MOMENTS if spec.moments else ""), "what": WHAT,
        "iterations": fit.iterations, "solve_time_s": fit.seconds,
        "parameters": {r.key: r.as_dict() for r in reports},
        "fitted_correlation": {"parameters": [p.key for p in spec.model.fitted],
                               "matrix": np.round(correlation, 4).tolist()},
        "angle_rms_deg": {"ankle": float(rms[0]), "knee": float(rms[1])},
        "angle_noise_sd_deg": {j: float(np.degrees(v)) for j, v in fit.noise_sd.items()},
        "moment_noise_sd_n_m": fit.moment_sd,
        "answers": answers(spec, fit, reports, samples, windows, over),
        "literature_check": {joint: check.as_dict() for joint, check in literature.items()},
        "quiet_phases_percent": [list(p) for p in spec.settings.quiet_phases],
        "windows": len(windows), "quiet_samples": windows.samples,
        **samples.cycle_counts(windows_mask(samples, windows)),
        "rk4_steps_per_sample": windows.substeps,
        "start_from_decomposition": None if start is None else {
            p.key: start[p.key] for p in spec.model.fitted},
        "bootstrap": bootstrap_summary(boot, spec.resampling.seed),
        "marker_cutoff_hz": chosen,
        "marker_cutoff_choice": choice,
        "cutoff_sensitivity": sensitivity(spec, options),
        "window_sensitivity": over,
        "provenance": {"problem": str(spec.source), "model": inverse.model.source,
                       **inverse.provenance},
    }
    return {"solution": solution, "samples": samples, "windows": windows, "fit": fit,
            "time": inverse.time, "literature": literature}


def run_swing(spec: SwingSpec, out: Path, *, force: bool = False) -> dict:
    """Solve (:func:`solve_swing`) and write the result folder; returns solution.json."""
    result = solve_swing(spec)
    samples, windows, fit = result["samples"], result["windows"], result["fit"]
    passive = {joint: np.asarray(spec.model.passive_joint(joint, fit.values).moment(
        samples.angles[joint], samples.rates[joint])) for joint in spec.model.joints}
    active = {joint: samples.moments[joint] - passive[joint] for joint in spec.model.joints}
    index = (windows.first[:, None] + np.arange(windows.mask.shape[1]))[windows.mask]
    angles = {"window": np.repeat(np.arange(len(windows)), windows.length).astype(float)}
    for i, joint in enumerate(("ankle", "knee")):
        angles[f"{joint}_measured_deg"] = np.degrees(windows.angles[..., i][windows.mask])
        angles[f"{joint}_simulated_deg"] = np.degrees(fit.simulated[..., i][windows.mask])
    with staged_output(out, force=force, inputs=[spec.source, spec.trial.inverse_problem]) \
            as stage:
        solution = write_summary(stage / "solution.json", result["solution"])
        write_passive_moments(stage / "passive_moments.sto", samples, spec.model.joints,
                              {"passive": passive, "active": active},
                              what="passive moment of the fitted model along the measured "
                                   "motion; active = inverse dynamics - passive",
                              cutoff_hz=solution["marker_cutoff_hz"])
        write_storage(stage / "swing_angles.sto", result["time"][index], angles, in_degrees=True,
                      header={"units": "deg, model coordinates (knee: -flexion)",
                              "what": "measured and simulated angles in the quiet-phase "
                                      "windows of the fit"})
        if plots_wanted() and result["literature"]:
            from predgait.report.passive_plots import plot_literature

            plot_literature(result["literature"], stage / "passive_literature.png")
    return solution


def answers(spec: SwingSpec, fit, reports, samples, windows, over: dict) -> dict:
    """Joint -> its one answer (:func:`~predgait.problems.passive_answer.joint_answer`).

    ``over``: the window sensitivity; when no other window could be fitted, the answer
    says that it was not checked against the choice of window.
    """
    inside = windows_mask(samples, windows)
    swings = samples.cycle_counts(inside)["quiet_swings"]
    out = {joint: joint_answer(spec.model, fit.values, fit.information, reports, joint,
                               samples.angles[joint][inside], swings=swings).as_dict()
           for joint in spec.model.joints}
    others = list(over.values())[1:]
    if others and all("failed" in values for values in others):
        for answer in out.values():
            answer["text"] += ("; not checked against the choice of quiet window (the fits "
                               "over the other windows failed: see window sensitivity)")
    return out


def summary_lines(solution: dict) -> list[str]:
    """What the CLI prints: one answer per joint, each fitted parameter, the sensitivities."""
    rms = solution["angle_rms_deg"]
    lines = [f"{solution['kind']}: Gauss-Newton in {solution['iterations']} iterations, "
             f"{solution['solve_time_s']:.3f} s; {solution['windows']} quiet-phase windows "
             f"({solution['quiet_samples']} samples); marker cut-off "
             f"{solution['marker_cutoff_hz']:.3g} Hz",
             "  " + cycle_words(solution),
             f"  angle RMS error of the simulated windows: ankle {rms['ankle']:.3f} deg, "
             f"knee {rms['knee']:.3f} deg"]
    if solution.get("moment_noise_sd_n_m"):
        lines.append("  moment residual SD (the moments' weight): " + ", ".join(
            f"{j} {v:.3g} N m" for j, v in solution["moment_noise_sd_n_m"].items()))
    lines += [f"  {joint}: {answer['text']}" for joint, answer in solution["answers"].items()]
    if solution.get("literature_check"):
        lines.append("  beside Riener & Edrich 1999 (passive moments of the relaxed leg, at this "
                     "trial's quiet-sample angles): " + "; ".join(
                         check["text"] for check in solution["literature_check"].values()))
    lines += parameter_lines(solution["parameters"])
    lines += cutoff_lines(solution["cutoff_sensitivity"])
    lines += window_lines(solution["window_sensitivity"])
    return lines
