"""``predgait solve`` kind ``passive_decomposition``: problem file -> fit -> result folder.

The trial's inverse dynamics is recomputed with a marker cut-off chosen by Winter's
residual analysis (forces filtered at the same cut-off, Kristianslund et al. 2012):
low-pass filtering removes part of the passive moment in swing, so the usual 6 Hz is not
taken for granted. The fit (:mod:`predgait.problems.decomposition`) is bootstrapped and
assessed (:mod:`predgait.problems.identifiability`), and repeated at other cut-offs
(``[filter] sensitivity_hz``) to show how much the values depend on the filter.
Writes solution.json, passive_moments.sto and active_passive.png.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from predgait.data import write_storage
from predgait.data.events import Side
from predgait.dynamics.inverse_options import InverseOptions
from predgait.dynamics.inverse_trial import run_inverse
from predgait.errors import InputError, SolveFailed
from predgait.problemfile import Table
from predgait.problems.decomposition import (
    Settings,
    bootstrap,
    check_samples,
    fit_decomposition,
)
from predgait.problems.gait_samples import GaitSamples
from predgait.problems.identifiability import (
    assess,
    bootstrap_usable,
    interval_method,
    mark_window_dependent,
)
from predgait.problems.passive_model import PassiveModel
from predgait.report.console import cutoff_lines, parameter_lines
from predgait.report.figures import plots_wanted
from predgait.report.tidy import write_summary
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

METHOD = ("decomposition of the inverse-dynamics moment, tau_ID = tau_active + "
          "tau_passive(theta, theta'; p), with tau_active ~ 0 in the quiet phases (no "
          "simulation); 95 % intervals from a bootstrap over gait cycles (or blocks) "
          "widened to the Fisher-information interval where that is wider")


@dataclass(frozen=True)
class DecompositionSpec:
    """A parsed ``passive_decomposition`` problem file (see problems/passive_decomposition.toml)."""

    source: Path
    inverse_problem: Path | None
    side: Side
    model: PassiveModel
    settings: Settings
    cutoff: float | None            # Hz; None: residual analysis
    sensitivity_hz: tuple[float, ...]
    resampling: Resampling
    noise_repeats: int = 0
    noise_marker_mm: float = 1.0
    noise_force_percent: float = 1.0
    trial: LegTrial | None = None
    windows: tuple[tuple[float, float], ...] = DEFENSIBLE_WINDOWS


def write_passive_moments(path: Path, samples, joints, parts: dict, *, what: str,
                          cutoff_hz: float, extra: dict | None = None) -> None:
    """passive_moments.sto of a passive fit: the one writer (decomposition, shooting, swing).

    Args:
        path: The file.
        samples: :class:`~predgait.problems.gait_samples.GaitSamples` (time, % gait cycle
            and the inverse-dynamics clinical moments).
        joints: Joints of the passive model, in column order.
        parts: column suffix -> joint -> (n,) clinical moment, N m (e.g. "passive").
        what: The header's description.
        cutoff_hz: Marker cut-off of the moments, Hz.
        extra: Further columns after the joints' (e.g. the quiet-phase flags).
    """
    columns = {"percent_gait_cycle": samples.percent}
    for joint in joints:
        columns[f"{joint}_moment_inverse_dynamics"] = samples.moments[joint]
        columns |= {f"{joint}_moment_{suffix}": values[joint] for suffix, values in parts.items()}
    write_storage(path, samples.time, columns | (extra or {}),
                  header={"units": "N m (clinical sign: positive toward knee flexion / "
                                   "ankle dorsiflexion), % gait cycle",
                          "what": what, "marker_cutoff_hz": f"{cutoff_hz:.3g}"})


def parse_decomposition(table: Table) -> DecompositionSpec:
    """DecompositionSpec from a problem file (errors name the file, key and line)."""
    table.check_keys(("kind", "joints", "quiet_phases", "smoothness_weight", "trial", "filter",
                      "uncertainty", "passive", "solver", "window_sensitivity"))
    joints = parse_joints(table)
    checked = parse_phases(table)
    trial = leg_trial(table.table("trial"))
    cutoff, sensitivity = parse_filter(table.table("filter"),
                                       sensitivity=(4.0, 6.0, 8.0, 12.0, 20.0))
    unc = table.table("uncertainty")
    resampling = parse_uncertainty(unc, extra=("noise_repeats", "noise_marker_mm",
                                               "noise_force_percent"))
    solver = table.table("solver")
    solver.check_keys(("max_iter",))
    settings = Settings(quiet_phases=checked,
                        smoothness_weight=table.number("smoothness_weight", 0.01, low=0.0),
                        max_iter=int(solver.number("max_iter", 200, low=1, high=10000)))
    return DecompositionSpec(
        source=table.path, inverse_problem=trial.inverse_problem, side=trial.side,
        model=parse_passive_model(table.table("passive"), joints), settings=settings,
        cutoff=cutoff, sensitivity_hz=sensitivity, resampling=resampling,
        noise_repeats=int(unc.number("noise_repeats", 0, low=0, high=1000)),
        noise_marker_mm=unc.number("noise_marker_mm", 1.0, low=0.0, high=50.0, unit="mm"),
        noise_force_percent=unc.number("noise_force_percent", 1.0, low=0.0, high=50.0,
                                       unit="%"), trial=trial, windows=parse_windows(table))


def _options(spec: DecompositionSpec) -> InverseOptions:
    return (spec.trial or LegTrial(spec.side, spec.inverse_problem)).options()


def bootstrap_summary(boot, seed: int) -> dict | None:
    """solution.json's ``bootstrap`` of a passive fit (None without one).

    What was resampled, and whether the intervals use it (``used``; see
    :func:`~predgait.problems.identifiability.assess`).
    """
    if boot is None:
        return None
    return {"repeats": int(len(boot.values)), "failed": boot.failed, "unit": boot.unit,
            "units": boot.n_units, "seed": seed, "used": bootstrap_usable(boot),
            "intervals": interval_method(boot)}


def residual_cutoff(options: InverseOptions) -> float:
    """Marker cut-off (Hz) by Winter's residual analysis of the markers the trial uses."""
    from predgait.data import fill_gaps, residual_analysis
    from predgait.dynamics.leg_measurements import needed_markers, read_trial

    trial, _ = read_trial(options)
    names = needed_markers(options.points)
    markers = fill_gaps(trial.markers, names=names, max_gap_frames=options.max_gap_frames,
                        edges="trim")
    columns = [markers.names.index(n) for n in names]
    xyz = markers.xyz[:, columns, :].reshape(markers.n_frames, -1)
    return float(residual_analysis(xyz, markers.rate).chosen)


def check_cutoff(source: Path, options: InverseOptions, cutoff: float) -> None:
    """Refuse a marker cut-off at or above the trial's Nyquist frequency (InputError)."""
    from predgait.dynamics.leg_measurements import read_trial

    rate = read_trial(options)[0].markers.rate
    if cutoff >= 0.5 * rate:
        raise InputError(f"{source}: [filter] marker_cutoff = {cutoff:g} Hz is at or above "
                         f"the Nyquist frequency ({0.5 * rate:g} Hz) of the trial's "
                         f"{rate:g} Hz markers; give a lower cut-off or \"residual\".")


def inverse_samples(options: InverseOptions, cutoff: float) -> tuple[GaitSamples, object]:
    """The trial's inverse dynamics with markers and forces filtered at ``cutoff`` Hz."""
    inverse = run_inverse(replace(options, cutoff=cutoff, grf_cutoff=cutoff))
    return GaitSamples.from_inverse(inverse), inverse


def cutoff_sensitivity(spec: DecompositionSpec, options: InverseOptions) -> dict:
    """Fitted values (no bootstrap) with inverse dynamics at each ``sensitivity_hz``."""
    table = {}
    for cutoff in spec.sensitivity_hz:
        try:
            samples, _ = inverse_samples(options, cutoff)
            fit = fit_decomposition(samples, spec.model, spec.settings)
        except (InputError, SolveFailed) as exc:
            table[f"{cutoff:g}"] = {"failed": str(exc)}
            continue
        table[f"{cutoff:g}"] = fitted_values(spec.model, fit.values)
    return table


def fitted_values(model: PassiveModel, values: dict) -> dict:
    """The fitted parameters' values (``joint.name`` -> SI) of a fit's ``values``."""
    return {p.key: values[p.key] for p in model.fitted}


def noise_sensitivity(spec: DecompositionSpec, options: InverseOptions, cutoff: float
                      ) -> dict | None:
    """SD of the fitted values over refits with marker and force noise added to the trial.

    A parametric bootstrap of the measurement: Gaussian noise of ``noise_marker_mm`` on
    every marker coordinate and ``noise_force_percent`` of each plate's peak on its force
    while loaded, then the whole inverse dynamics and the fit again. The trial already
    holds its own noise, so this is the spread that noise of that size causes; it is
    reported beside the intervals, not folded into them.
    """
    if spec.noise_repeats < 2:
        return None
    from predgait.dynamics.leg_measurements import read_trial

    trial, turn = read_trial(options)
    rng = np.random.default_rng(spec.resampling.seed + 1)
    options = replace(options, cutoff=cutoff, grf_cutoff=cutoff)
    rows, failed = [], 0
    for _ in range(spec.noise_repeats):
        xyz = trial.markers.xyz
        markers = trial.markers.with_xyz(xyz + rng.normal(0.0, spec.noise_marker_mm / 1e3,
                                                          xyz.shape))
        plates = tuple(replace(plate, force=plate.force + rng.normal(0.0, 1.0, plate.force.shape)
                               * (plate.force[:, 2:3] > options.threshold)
                               * spec.noise_force_percent / 100 * np.abs(plate.force).max(axis=0))
                       for plate in trial.plates)
        try:
            inverse = run_inverse(options, loaded=(replace(trial, markers=markers,
                                                           plates=plates), turn))
            fit = fit_decomposition(GaitSamples.from_inverse(inverse), spec.model,
                                    spec.settings)
        except (InputError, SolveFailed):
            failed += 1
            continue
        rows.append([fit.values[p.key] for p in spec.model.fitted])
    sd = np.std(rows, axis=0, ddof=1) if len(rows) > 1 else np.full(len(spec.model.fitted),
                                                                     np.nan)
    return {"repeats": len(rows), "failed": failed, "marker_noise_mm": spec.noise_marker_mm,
            "force_noise_percent": spec.noise_force_percent if trial.plates else None,
            "sd": {p.key: float(v) for p, v in zip(spec.model.fitted, sd, strict=True)}}


def run_decomposition(spec: DecompositionSpec, out: Path, *, force: bool = False) -> dict:
    """Fit, bootstrap, assess, repeat at other cut-offs; write the result folder.

    Raises:
        InputError: Bad trial or phases (nothing written).
        SolveFailed: Ipopt failed on the main fit (nothing written).
    """
    options = _options(spec)
    chosen = spec.cutoff if spec.cutoff is not None else residual_cutoff(options)
    check_cutoff(spec.source, options, chosen)
    samples, inverse = inverse_samples(options, chosen)
    where = f"{spec.source}: quiet_phases"
    check_samples(samples, spec.model, spec.settings, where=where)
    fit = fit_decomposition(samples, spec.model, spec.settings)
    res = spec.resampling
    boot = bootstrap(samples, spec.model, fit, spec.settings, repeats=res.repeats,
                     seed=res.seed, min_cycles=res.min_cycles, block_s=res.block_s) \
        if res.repeats > 1 else None
    reports, correlation = assess(spec.model, fit, boot)
    windows = window_sensitivity(
        lambda phases: (spec.model, fit_decomposition(
            samples, spec.model, replace(spec.settings, quiet_phases=phases))),
        spec.settings.quiet_phases, spec.windows, (spec.model, fit))
    reports = mark_window_dependent(reports, windows)
    sensitivity = cutoff_sensitivity(spec, options)
    noise = noise_sensitivity(spec, options, chosen)
    quiet = fit.quiet
    solution = {
        "status": "solved", "kind": "passive_decomposition", "method": METHOD,
        "what": "passive joint moments (tissue properties under the quiet-muscle assumption), "
                "not stabilising elements of a re-synthesis",
        "ipopt_status": fit.status, "iterations": fit.iterations, "solve_time_s": fit.seconds,
        "parameters": {r.key: r.as_dict() for r in reports},
        "fitted_correlation": {"parameters": [p.key for p in spec.model.fitted],
                               "matrix": np.round(correlation, 4).tolist()},
        "quiet_phase_residual_sd_n_m": fit.noise_sd,
        "quiet_phases_percent": [list(p) for p in spec.settings.quiet_phases],
        "quiet_samples": int(quiet.sum()),
        **samples.cycle_counts(quiet),
        "cycle_timing": samples.timing,
        "bootstrap": bootstrap_summary(boot, spec.resampling.seed),
        "marker_cutoff_hz": chosen,
        "marker_cutoff_choice": "given" if spec.cutoff is not None else
        "Winter's residual analysis of the trial's markers (forces at the same cut-off)",
        "cutoff_sensitivity": sensitivity,
        "window_sensitivity": windows,
        "noise_sensitivity": noise,
        "provenance": {"problem": str(spec.source), "model": inverse.model.source,
                       **inverse.provenance},
    }
    with staged_output(out, force=force, inputs=[spec.source]) as stage:
        solution = write_summary(stage / "solution.json", solution)
        write_passive_moments(stage / "passive_moments.sto", samples, spec.model.joints,
                              {"passive": fit.passive, "active": fit.active},
                              what="inverse-dynamics moment split into passive + active",
                              cutoff_hz=chosen, extra={"quiet_phase": quiet.astype(float)})
        if plots_wanted():
            from predgait.report.decomposition_plots import plot_active_passive

            plot_active_passive(samples, fit, spec.model.joints, spec.settings.quiet_phases,
                                stage / "active_passive.png")
    return solution


def cycle_words(solution: dict) -> str:
    """The cycle counts of a passive fit's solution.json, as printed."""
    return (f"{solution['gait_cycles']} full gait cycle(s) + {solution['partial_cycles']} "
            f"partial; {solution['quiet_swings']} quiet swing(s) in the fit")


def summary_lines(solution: dict) -> list[str]:
    """What the CLI prints: one line per fitted parameter, then the cut-off sensitivity."""
    lines = [f"passive_decomposition: {solution['ipopt_status']} in {solution['iterations']} "
             f"iterations, {solution['solve_time_s']:.3f} s; marker cut-off "
             f"{solution['marker_cutoff_hz']:.3g} Hz",
             "  " + cycle_words(solution) + f", {solution['quiet_samples']} quiet samples"]
    lines += parameter_lines(solution["parameters"])
    noise = solution.get("noise_sensitivity")
    if noise:
        forces = "" if noise["force_noise_percent"] is None else \
            f", {noise['force_noise_percent']:g} % forces"
        lines.append(f"  spread from re-added noise ({noise['marker_noise_mm']:g} mm markers"
                     f"{forces}, {noise['repeats']} refits), SD: "
                     + ", ".join(f"{k} {v:.3g}" for k, v in noise["sd"].items()))
    lines += cutoff_lines(solution["cutoff_sensitivity"])
    lines += window_lines(solution["window_sensitivity"])
    return lines
