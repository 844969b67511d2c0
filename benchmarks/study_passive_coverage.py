"""Accuracy and interval coverage of the passive fits through the whole pipeline.

Run: python benchmarks/study_passive_coverage.py [--method moments|angles|both] [--cycles 6]
     [--seeds 20] [--first-seed 0] [--phases START END] [--cutoff residual|default|HZ]

The known-answer walk of tests/passive_walk.py (forward simulation of the leg with a
known nonlinear passive knee and ankle and an active torque that is zero in 70-97 % of
the cycle) is simulated once; each repetition adds its own seeded noise (1 mm on every
marker coordinate, 1 % of the plate's peak on its force while loaded), then runs the
inverse dynamics (marker and force cut-off by residual analysis or as given), the
fit over the quiet phases and a 60-replicate bootstrap: ``moments``, the decomposition of
the inverse-dynamics moments (defaults: 73-88 %, residual-analysis cut-off), or
``angles``, the simulation of the quiet phases fitted to the measured angles (kind
passive_swing; defaults 73-95 %, the swing fits' default cut-off: a third of the marker
rate, at most 30 Hz, i.e. 30 Hz here; started from the decomposition), or ``both``, the
angles and the quiet moments together (kind passive_knee_ankle; Fisher intervals, no
bootstrap). Printed per fitted parameter: the largest and RMS relative error over the
repetitions and how many 95 % intervals cover the truth ("not identifiable" counts as not
covering); per joint, the RMS error of the fitted passive moment along the quiet samples
in % of the true passive moment's RMS there (the issue 28 measure). The repetitions
share the simulated motion and differ in the noise only. Also printed: the errors in
units of their Fisher standard error (mean: the bias the intervals do not contain; SD:
whether the standard errors are right, ~1) and the error of the same pipeline on the
noise-free recording (what filtering, differentiation and sampling cost by themselves).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=6)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=0, help="noise seeds start here")
    parser.add_argument("--method", choices=("moments", "angles", "both"), default="moments")
    parser.add_argument("--phases", type=float, nargs=2, default=None,
                        metavar=("START", "END"), help="quiet phase, % gait cycle")
    parser.add_argument("--cutoff", default=None,
                        help="Hz, residual, or default (the swing fits' default)")
    args = parser.parse_args()
    angles = args.method in ("angles", "both")
    args.phases = args.phases or ((73.0, 95.0) if angles else (73.0, 88.0))
    args.cutoff = args.cutoff or ("default" if angles else "residual")

    import passive_walk
    from predgait.dynamics.inverse_trial import run_inverse
    from predgait.problems.decomposition import Settings, bootstrap, fit_decomposition
    from predgait.problems.gait_samples import GaitSamples
    from predgait.problems.identifiability import assess
    from predgait.problems.passive_model import build_model
    from predgait.problems.passive_moment_rows import MomentRows
    from predgait.problems.passive_swing import (
        SwingSettings,
        Windows,
        bootstrap_swing,
        fit_swing,
    )
    from predgait.workflows.decomposition import residual_cutoff
    from predgait.workflows.passive_swing import default_cutoff, windows_mask

    start = time.perf_counter()
    trial = passive_walk.NoiseFreeTrial(args.cycles, seed=0)
    simulated = time.perf_counter() - start
    model = build_model(["knee", "ankle"], fit={"knee": ["k", "c", "theta0"],
                                                "ankle": ["k", "c", "theta0"]})
    settings = Settings(quiet_phases=(tuple(args.phases),))

    def repetition(folder, seed, **noise):
        """One pass through the pipeline: cut-off, reports, curve errors, (sizes, errors
        over the moment without its stops)."""
        options = trial.write(folder, noise_seed=1000 + seed, **noise)
        cutoff = {"residual": residual_cutoff, "default": default_cutoff}.get(
            args.cutoff, lambda _: float(args.cutoff))(options)
        inverse = run_inverse(replace(options, cutoff=cutoff, grf_cutoff=cutoff))
        samples = GaitSamples.from_inverse(inverse)
        fit = fit_decomposition(samples, model, settings)
        boot = bootstrap(samples, model, fit, settings, repeats=60, seed=seed)
        quiet = samples.in_phases(settings.quiet_phases)
        if angles:
            swing = SwingSettings(quiet_phases=settings.quiet_phases, max_iter=200)
            windows = Windows.from_inverse(inverse, samples, swing)
            quiet = windows_mask(samples, windows)
            rows = MomentRows.of(samples, quiet, model) if args.method == "both" else None
            fit = fit_swing(inverse.model, windows, model, swing, start=fit.values,
                            moments=rows)
            boot = None if rows is not None else \
                bootstrap_swing(windows, model, fit, repeats=60, seed=seed)
        curves, sizes, free = passive_walk.quiet_curve_errors(trial.truth, model, fit.values,
                                                              inverse, quiet)
        reports = {r.key: r for r in assess(model, fit, boot)[0] if r.key in passive_walk.TRUTH}
        return cutoff, reports, curves, (sizes, free)

    errors, z, covered, cutoffs = ({k: [] for k in passive_walk.TRUTH},
                                   {k: [] for k in passive_walk.TRUTH},
                                   dict.fromkeys(passive_walk.TRUTH, 0), [])
    missed = {k: [] for k in passive_walk.TRUTH}
    curve, size, unstopped = ({"knee": [], "ankle": []}, {"knee": [], "ankle": []},
                              {"knee": [], "ankle": []})
    with tempfile.TemporaryDirectory() as root:
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            folder = Path(root) / f"seed{seed}"
            folder.mkdir()
            cutoff, reports, curves, (sizes, free) = repetition(folder, seed)
            cutoffs.append(cutoff)
            for joint in curve:
                curve[joint].append(curves[joint])
                size[joint].append(sizes[joint])
                unstopped[joint].append(free[joint])
            for key, report in reports.items():
                true = passive_walk.TRUTH[key]
                errors[key].append(report.value / true - 1)
                z[key].append((report.value - true) / report.fisher_se)
                interval = report.interval95
                inside = interval is not None and interval[0] <= true <= interval[1]
                covered[key] += inside
                if not inside:
                    missed[key].append(seed)
        # The same pipeline on the noise-free recording: what the processing itself (filter,
        # differentiation, sampling) costs, which no noise-based interval contains.
        clean = Path(root) / "noise_free"
        clean.mkdir()
        _, clean_reports, clean_curve, _ = repetition(clean, 0, marker_noise=0.0,
                                                      force_noise=0.0)
    print(f"passive fit to the {args.method}, known-answer walk ({args.cycles} cycles, "
          f"simulated once in {simulated:.0f} s), {args.seeds} noise seeds, quiet phase "
          f"{args.phases[0]:g}-{args.phases[1]:g} %, cut-off {args.cutoff} "
          f"(chosen {min(cutoffs):.1f}-{max(cutoffs):.1f} Hz); "
          f"{time.perf_counter() - start:.0f} s in all")
    for key, values in errors.items():
        e = 100 * np.abs(values)
        print(f"  {key:13s} mean error {100 * np.mean(values):+6.1f} %, max |error| "
              f"{e.max():5.1f} %, RMS {np.sqrt(np.mean(e ** 2)):5.1f} %, 95 % interval covers "
              f"the truth in {covered[key]} / {args.seeds}; (estimate - truth) / Fisher SE: "
              f"mean {np.mean(z[key]):+.2f}, SD {np.std(z[key], ddof=1):.2f}; noise-free "
              f"error {100 * (clean_reports[key].value / passive_walk.TRUTH[key] - 1):+.1f} %"
              + (f"; missed in seeds {missed[key]}" if missed[key] else ""))
    for joint, values in curve.items():
        e = 100 * np.array(values)
        print(f"  {joint} passive moment along the quiet samples: RMS error {np.mean(e):5.1f} % "
              f"of the truth's RMS ({np.mean(size[joint]):.2f} N m; largest "
              f"{e.max():5.1f} % in seed {args.first_seed + int(np.argmax(e))}; noise-free "
              f"{100 * clean_curve[joint]:.1f} %); over the RMS of the moment without its "
              f"stops (the fitted elements' share): {100 * np.mean(unstopped[joint]):5.1f} %, "
              f"largest {100 * np.max(unstopped[joint]):5.1f} %")


if __name__ == "__main__":
    main()
