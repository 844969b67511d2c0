"""``predgait solve`` kind ``passive_shooting``: stabilising elements beside the decomposition.

The thesis' question (Fig. 4.2.9), posed so that its answer means something: which
spring-dampers, added to the measured moments, keep the re-synthesized motion near the
measured one over shooting intervals shorter than the driven leg's unstable time
constant (:mod:`predgait.problems.shooting`). The same passive model is also fitted by
the decomposition of the measured moments (:mod:`predgait.problems.decomposition`) on
the same inverse dynamics, and both are reported side by side: the decomposition says how
much of the moment is passive (tissue, under the quiet-muscle assumption), the shooting
fit how much spring-damper the re-synthesis needs on top of the measured moments.
Writes solution.json, passive_moments.sto and active_passive.png.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from predgait.problemfile import Table
from predgait.problems.decomposition import Settings, bootstrap, fit_decomposition
from predgait.problems.identifiability import assess
from predgait.problems.passive_model import PassiveModel
from predgait.problems.shooting import (
    MAX_INTERVAL_S,
    Intervals,
    ShootingSettings,
    bootstrap_shooting,
    engine_elements,
    fit_shooting,
)
from predgait.report.console import parameter_lines
from predgait.report.figures import plots_wanted
from predgait.report.tidy import write_summary
from predgait.workflows.decomposition import (
    METHOD as DECOMPOSITION_METHOD,
)
from predgait.workflows.decomposition import (
    bootstrap_summary,
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
from predgait.workflows.trials import LegTrial, leg_trial

METHOD = ("multiple shooting: the leg (foot prescribed) driven by the inverse-dynamics "
          "moments plus the elements, simulated (RK4) over intervals shorter than the "
          "unstable time constant, each from the measured state; the elements minimise the "
          "interval-end angle errors (bounded Gauss-Newton); 95 % intervals from a "
          "bootstrap over gait cycles (or blocks) widened to the Fisher-information "
          "interval where that is wider")
WHAT = ("stabilising elements added to the measured moments so that the re-synthesized "
        "motion stays near the measured one (thesis Fig. 4.2.9), not tissue properties: "
        "the measured moments already contain the tissue's passive moment (see "
        "'decomposition' for that)")


@dataclass(frozen=True)
class ShootingSpec:
    """A parsed ``passive_shooting`` problem file (see problems/passive_shooting.toml)."""

    source: Path
    trial: LegTrial
    model: PassiveModel
    settings: ShootingSettings
    decomposition: Settings
    cutoff: float | None            # Hz; None: residual analysis
    resampling: Resampling


def parse_shooting(table: Table) -> ShootingSpec:
    """ShootingSpec from a problem file (errors name the file, key and line)."""
    table.check_keys(("kind", "joints", "trial", "filter", "shooting", "decomposition",
                      "uncertainty", "passive"))
    joints = parse_joints(table)
    trial = leg_trial(table.table("trial"))
    cutoff, _ = parse_filter(table.table("filter"))
    shooting = table.table("shooting")
    shooting.check_keys(("interval_s", "step_s", "max_iter"))
    beside = table.table("decomposition")
    beside.check_keys(("quiet_phases", "smoothness_weight"))
    return ShootingSpec(
        source=table.path, trial=trial, model=parse_passive_model(table.table("passive"),
                                                                  joints),
        settings=ShootingSettings(
            interval_s=shooting.number("interval_s", 0.02, low=1e-3, high=MAX_INTERVAL_S,
                                       unit="s"),
            step_s=shooting.number("step_s", 0.01, low=1e-4, high=0.01, unit="s"),
            max_iter=int(shooting.number("max_iter", 50, low=1, high=1000))),
        decomposition=Settings(quiet_phases=parse_phases(beside),
                               smoothness_weight=beside.number("smoothness_weight", 0.01,
                                                               low=0.0)),
        cutoff=cutoff, resampling=parse_uncertainty(table.table("uncertainty")))


def _rms_deg(residual: np.ndarray) -> dict:
    rms = np.degrees(np.sqrt(np.mean(residual ** 2, axis=0)))
    return {"ankle": float(rms[0]), "knee": float(rms[1])}


def _assessed(model, fit, boot) -> tuple[dict, dict]:
    reports, correlation = assess(model, fit, boot)
    return ({r.key: r.as_dict() for r in reports},
            {"parameters": [p.key for p in model.fitted],
             "matrix": np.round(correlation, 4).tolist()})


#: Deviation (deg) and RK4 step (s) of the whole-cycle re-simulation check.
CHECK_THRESHOLD_DEG, CHECK_STEP = 2.0, 5e-4


def whole_cycle_check(inverse, elements) -> dict:
    """Re-simulate the first gait cycle with and without the fitted elements.

    The fit holds each short interval; over a whole cycle the driven leg's instability
    still acts. The report says for how long each run stays within 2 deg of the measured
    motion (Pinocchio, RK4), i.e. whether the elements alone hold the re-synthesis (for
    a stabilising feedback see kind ``torque_feedback``).
    """
    from predgait.dynamics.drivers import LegDrivers
    from predgait.workflows.solve import resimulate

    window = inverse.first_cycle() or (float(inverse.time[0]), float(inverse.time[-1]))
    drivers = LegDrivers.from_inverse(inverse)
    out = {"window_s": list(window), "threshold_deg": CHECK_THRESHOLD_DEG}
    for name, passive in (("without_elements", None), ("with_elements", elements)):
        _, out[name] = resimulate(inverse, drivers, window, step=CHECK_STEP,
                                  threshold_deg=CHECK_THRESHOLD_DEG, passive=passive)
    return out


def solve_shooting(spec: ShootingSpec) -> dict:
    """Both fits on the same inverse dynamics: what :func:`run_shooting` writes.

    Raises:
        InputError: Bad trial, too few intervals or quiet samples (nothing written).
        SolveFailed: A fit did not converge (nothing written).
    """
    options = spec.trial.options()
    chosen = spec.cutoff if spec.cutoff is not None else residual_cutoff(options)
    samples, inverse = inverse_samples(options, chosen)
    intervals = Intervals.from_inverse(inverse, samples, spec.settings)
    fit = fit_shooting(inverse.model, intervals, spec.model, spec.settings,
                       where=f"{spec.source}: shooting")
    res = spec.resampling
    boot = bootstrap_shooting(intervals, samples, spec.model, fit, repeats=res.repeats,
                              seed=res.seed, min_cycles=res.min_cycles,
                              block_s=res.block_s) if res.repeats > 1 else None
    parameters, correlation = _assessed(spec.model, fit, boot)
    split = fit_decomposition(samples, spec.model, spec.decomposition)
    split_boot = bootstrap(samples, spec.model, split, spec.decomposition,
                           repeats=res.repeats, seed=res.seed, min_cycles=res.min_cycles,
                           block_s=res.block_s) if res.repeats > 1 else None
    split_parameters, _ = _assessed(spec.model, split, split_boot)
    stabilising = {joint: np.asarray(spec.model.passive_joint(joint, fit.values).moment(
        samples.angles[joint], samples.rates[joint])) for joint in spec.model.joints}
    check = whole_cycle_check(inverse, engine_elements(spec.model, fit.values,
                                                       intervals.knee_offset))
    solution = {
        "status": "solved", "kind": "passive_shooting", "method": METHOD, "what": WHAT,
        "iterations": fit.iterations, "solve_time_s": fit.seconds,
        "parameters": parameters, "fitted_correlation": correlation,
        "shooting_intervals": len(intervals), "interval_s": intervals.length_s,
        "rk4_steps_per_interval": intervals.substeps,
        "interval_end_rms_deg": {"with_elements": _rms_deg(fit.residual),
                                 "without_elements": _rms_deg(fit.residual_none)},
        **samples.cycle_counts(split.quiet),
        "whole_cycle_resimulation": check,
        "bootstrap": bootstrap_summary(boot, spec.resampling.seed),
        "marker_cutoff_hz": chosen,
        "marker_cutoff_choice": "given" if spec.cutoff is not None else
        "Winter's residual analysis of the trial's markers (forces at the same cut-off)",
        "decomposition": {
            "what": "passive joint moments (tissue properties under the quiet-muscle "
                    "assumption)", "method": DECOMPOSITION_METHOD,
            "ipopt_status": split.status, "parameters": split_parameters,
            "quiet_phases_percent": [list(p) for p in spec.decomposition.quiet_phases],
            "quiet_phase_residual_sd_n_m": split.noise_sd,
            "bootstrap": bootstrap_summary(split_boot, spec.resampling.seed)},
        "provenance": {"problem": str(spec.source), "model": inverse.model.source,
                       **inverse.provenance},
    }
    return {"solution": solution, "samples": samples, "split": split,
            "stabilising": stabilising}


def run_shooting(spec: ShootingSpec, out: Path, *, force: bool = False) -> dict:
    """Solve (:func:`solve_shooting`) and write the result folder; returns solution.json."""
    result = solve_shooting(spec)
    samples, split, stabilising = result["samples"], result["split"], result["stabilising"]
    with staged_output(out, force=force,
                       inputs=[spec.source, spec.trial.inverse_problem]) as stage:
        solution = write_summary(stage / "solution.json", result["solution"])
        write_passive_moments(
            stage / "passive_moments.sto", samples, spec.model.joints,
            {"passive_decomposition": split.passive, "active_decomposition": split.active,
             "stabilising_shooting": stabilising},
            what="inverse-dynamics moment split into passive + active (decomposition) and "
                 "the stabilising elements' moment along the measured motion (multiple "
                 "shooting)", cutoff_hz=solution["marker_cutoff_hz"])
        if plots_wanted():
            from predgait.report.decomposition_plots import plot_active_passive

            plot_active_passive(samples, split, spec.model.joints,
                                spec.decomposition.quiet_phases, stage / "active_passive.png",
                                stabilising=stabilising)
    return solution


def summary_lines(solution: dict) -> list[str]:
    """What the CLI prints: both fits, parameter by parameter."""
    rms = solution["interval_end_rms_deg"]
    lines = [f"passive_shooting: Gauss-Newton in {solution['iterations']} iterations, "
             f"{solution['solve_time_s']:.3f} s; {solution['shooting_intervals']} intervals of "
             f"{solution['interval_s'] * 1e3:.1f} ms; marker cut-off "
             f"{solution['marker_cutoff_hz']:.3g} Hz",
             "  stabilising elements (multiple shooting; not tissue properties):"]
    lines += parameter_lines(solution["parameters"], indent="    ")
    lines.append("    interval-end RMS error with / without them: " + ", ".join(
        f"{j} {rms['with_elements'][j]:.4f} / {rms['without_elements'][j]:.4f} deg"
        for j in ("ankle", "knee")))
    check = solution["whole_cycle_resimulation"]

    def held(run):
        when = run["time_to_threshold_s"]
        return f"leaves {check['threshold_deg']:g} deg at {when:.3f} s" if when is not None \
            else f"stays within {check['threshold_deg']:g} deg"

    lines.append(f"    whole first cycle re-synthesized: with them {held(check['with_elements'])}"
                 f", without {held(check['without_elements'])}")
    lines.append("  passive moments (decomposition, quiet phases "
                 f"{solution['decomposition']['quiet_phases_percent']} %):")
    lines += parameter_lines(solution["decomposition"]["parameters"], indent="    ")
    return lines
