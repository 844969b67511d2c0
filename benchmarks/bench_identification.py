"""Speed of the passive decomposition fit, the multiple-shooting fit and the swing-angle fit.

Run: python benchmarks/bench_identification.py [--repeat N]

Problems: problems/passive_decomposition.toml, problems/passive_shooting.toml and
problems/passive_swing.toml.

In process, on the bundled subject01 trial (inverse dynamics done once, outside the
timing): the first fit (builds the CasADi/Ipopt solver), later fits (solver cached), and
one bootstrap replicate; then the cold CLI process of the whole problem file with the
bootstrap and the refits switched off, and with the file as shipped. Size: the
knee and ankle of the planar leg, 7 fitted parameters, every sample of the trial (the
samples enter through Gram statistics, so the NLP has 7 unknowns whatever the length).

Peer of the multiple-shooting fit (when OPENSIM_PYTHON names a Python that imports
opensim, else "peer not available"): OpenSim Moco's MocoParameter fit of the same linear
knee and ankle spring-dampers (SpringGeneralizedForce, 6 parameters) added to the measured
moments, tracking the measured angles over the same trial span with one mesh interval per
shooting interval (benchmarks/opensim_moco_leg.py, moco_peer.py), each run a fresh process
stopped after ``--peer-minutes``. Moco has no multiple shooting: its collocation is one
open-loop trajectory, and it leaves the foot free on tracked residual actuators where
predgait prescribes it. The decomposition fit has no Moco counterpart here (it fits the
samples' moments, no dynamics).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from timing import (  # noqa: E402
    NOT_AVAILABLE,
    REPO,
    Timing,
    environment,
    ratio,
    time_call,
    time_process,
)

from predgait import function_cache  # noqa: E402

PROBLEM = REPO / "problems" / "passive_decomposition.toml"
SHOOTING = REPO / "problems" / "passive_shooting.toml"


def moco_shooting(inverse, intervals, ours: Timing, minutes: float) -> None:
    """Moco's MocoParameter fit of the linear knee and ankle over the same span and grid."""
    from moco_peer import moco_inputs, run_moco

    from predgait.dynamics.drivers import LegDrivers

    drivers = LegDrivers.from_inverse(inverse)
    window = (float(inverse.time[0]), float(inverse.time[-1]))
    runs = run_moco(moco_inputs(inverse, drivers, "knee_fit", len(intervals), window,
                                joints=("knee", "ankle")), 1, minutes)
    size = (f"{window[1] - window[0]:.2f} s, {len(intervals)} Hermite-Simpson intervals, "
            "5 DOF (foot free on tracked residual actuators), 10 states, 6 parameters, "
            "limited-memory Hessian, tol 1e-4")
    print(f"  OpenSim Moco MocoParameter, knee and ankle, {size}: {runs.describe('s')}")
    if runs.facts.get("success"):
        print(f"    {runs.facts['iterations']} iterations; (k, c, theta0) knee, ankle "
              f"{', '.join(f'{v:.4g}' for v in runs.facts['parameters'])}")
    if runs.whole is not None:
        print(f"  ratio Moco whole process / predgait cold CLI: {ratio(ours, runs.whole)}")


def shooting(repeat: int, peer_minutes: float = 10.0) -> None:
    """Multiple-shooting fit: in process (first and cached), one replicate, cold CLI.

    Size: the leg with the foot prescribed (2 free DOF), one shooting interval per
    sample of the trial (60 Hz: 150 intervals of 16.7 ms, 2 RK4 steps each), 6 fitted
    parameters (linear knee and ankle).
    """
    import tempfile

    from predgait.dynamics.inverse_trial import bundled_inverse
    from predgait.problemfile import load_problem
    from predgait.problems.gait_samples import GaitSamples
    from predgait.problems.shooting import Intervals, bootstrap_shooting, fit_shooting
    from predgait.workflows.shooting import parse_shooting

    spec = parse_shooting(load_problem(SHOOTING))
    inverse = bundled_inverse(spec.trial.side)
    samples = GaitSamples.from_inverse(inverse)
    intervals = Intervals.from_inverse(inverse, samples, spec.settings)

    def fit():
        return fit_shooting(inverse.model, intervals, spec.model, spec.settings)

    with environment({function_cache.SWITCH: "off"}):      # CasADi's virtual machine
        start = time.perf_counter()
        result = fit()
        first = time.perf_counter() - start
        in_vm = time_call(fit, repeat)
    with tempfile.TemporaryDirectory() as cache, environment({
            function_cache.SWITCH: "on", function_cache.FOLDER: cache,
            function_cache.WHEN: "now"}):
        start = time.perf_counter()
        fit()                                               # compiles, in the foreground
        compiling = time.perf_counter() - start
        compiled = time_call(fit, repeat)
    replicate = time_call(lambda: bootstrap_shooting(intervals, samples, spec.model, result,
                                                     repeats=1), repeat)
    print(f"multiple-shooting fit, bundled subject01 right leg: {len(intervals)} intervals of "
          f"{intervals.length_s * 1e3:.1f} ms, {intervals.substeps} RK4 steps each, "
          f"{len(spec.model.fitted)} fitted parameters, {result.iterations} Gauss-Newton "
          "iterations (2 passes)")
    print(f"  in process, first fit in CasADi's virtual machine (builds the functions): "
          f"{first * 1e3:.0f} ms")
    print(f"  in process, fit in the virtual machine (a trial shape met for the first time: "
          f"its library compiles in the background), min / median of {repeat}: "
          f"{in_vm.describe('ms')}")
    print(f"  one-time compilation of the residual function (gcc, foreground here): "
          f"{compiling:.1f} s")
    print(f"  in process, fit compiled (every later run of that shape), min / median of "
          f"{repeat}: {compiled.describe('ms')}")
    print(f"  in process, one bootstrap replicate: {replicate.describe('ms')}")
    with tempfile.TemporaryDirectory() as folder:
        argv = [sys.executable, "-m", "predgait", "solve", str(SHOOTING), "--out",
                f"{folder}/out", "--force", "--no-plots", "--set", "uncertainty.bootstrap=0",
                "--set", "filter.marker_cutoff=6.0"]
        cold = time_process(argv, max(1, repeat // 2))
    print(f"  cold CLI (6 Hz, no bootstrap; the decomposition beside it included), "
          f"{max(1, repeat // 2)} runs: {cold.describe('s')}")
    moco_shooting(inverse, intervals, cold, peer_minutes)


def swing(repeat: int) -> None:
    """Swing-angle fit (kind passive_swing): in process, in the VM and compiled.

    Size: the shank and foot under the measured thigh (2 free DOF), one window per gait
    cycle with a quiet swing (subject01: 2 windows, 60 Hz, 20 Hz markers), one RK4 step
    per sample with forward sensitivities, 6 passive parameters + 4 initial states per
    window; started from the literature defaults.
    """
    import tempfile
    from dataclasses import replace

    from predgait.dynamics.inverse_trial import run_inverse
    from predgait.problemfile import load_problem
    from predgait.problems.gait_samples import GaitSamples
    from predgait.problems.passive_swing import Windows, fit_swing
    from predgait.workflows.passive_swing import parse_swing

    spec = parse_swing(load_problem(REPO / "problems" / "passive_swing.toml"))
    inverse = run_inverse(replace(spec.trial.options(), cutoff=spec.cutoff,
                                  grf_cutoff=spec.cutoff))
    windows = Windows.from_inverse(inverse, GaitSamples.from_inverse(inverse), spec.settings)

    def fit():
        return fit_swing(inverse.model, windows, spec.model, spec.settings)

    with environment({function_cache.SWITCH: "off"}):
        result = fit()
        in_vm = time_call(fit, repeat)
    with tempfile.TemporaryDirectory() as cache, environment({
            function_cache.SWITCH: "on", function_cache.FOLDER: cache,
            function_cache.WHEN: "now"}):
        start = time.perf_counter()
        fit()
        compiling = time.perf_counter() - start
        compiled = time_call(fit, repeat)
    print(f"swing-angle fit, bundled subject01 right leg: {len(windows)} windows, "
          f"{windows.samples} samples, {len(spec.model.fitted)} parameters + "
          f"{4 * len(windows)} initial states, {result.iterations} Gauss-Newton iterations "
          "(2 passes)")
    print(f"  in process, fit in CasADi's virtual machine, min / median of {repeat}: "
          f"{in_vm.describe('ms')}")
    print(f"  one-time compilation of the RK4 sample step (gcc, foreground here): "
          f"{compiling:.1f} s")
    print(f"  in process, fit compiled, min / median of {repeat}: {compiled.describe('ms')}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--peer-minutes", type=float, default=10.0,
                        help="stop the Moco run after this many minutes (default 10)")
    args = parser.parse_args()
    import tempfile

    from predgait.dynamics.inverse_trial import bundled_inverse
    from predgait.problemfile import load_problem
    from predgait.problems import decomposition
    from predgait.problems.decomposition import bootstrap, fit_decomposition
    from predgait.problems.gait_samples import GaitSamples
    from predgait.workflows.decomposition import parse_decomposition

    spec = parse_decomposition(load_problem(PROBLEM))
    samples = GaitSamples.from_inverse(bundled_inverse(spec.side))
    n_fit = len(spec.model.fitted)
    start = time.perf_counter()
    fit = fit_decomposition(samples, spec.model, spec.settings)
    first = time.perf_counter() - start
    later = time_call(lambda: fit_decomposition(samples, spec.model, spec.settings),
                      args.repeat)
    replicate = time_call(lambda: bootstrap(samples, spec.model, fit, spec.settings,
                                            repeats=1), args.repeat)
    print(f"passive decomposition, bundled subject01 right leg: {len(samples.time)} samples, "
          f"{int(fit.quiet.sum())} quiet, {n_fit} fitted parameters (knee + ankle), "
          f"{fit.iterations} Ipopt iterations (second pass)")
    print(f"  in process, first fit (builds the solver): {first * 1e3:.1f} ms")
    print(f"  in process, fit (2 passes, solver cached), min / median of {args.repeat}: "
          f"{later.describe('ms')}")
    print(f"  in process, one bootstrap replicate: {replicate.describe('ms')}")
    cached = decomposition._problem.cache_info()
    print(f"  solver cache: {cached.currsize} model(s) built")
    with tempfile.TemporaryDirectory() as folder:
        def cli(*sets):
            argv = [sys.executable, "-m", "predgait", "solve", str(PROBLEM), "--out",
                    f"{folder}/out", "--force"]
            for s in sets:
                argv += ["--set", s]
            return argv

        repeat = max(1, args.repeat // 2)
        bare = time_process(cli("uncertainty.bootstrap=0", "uncertainty.noise_repeats=0",
                                "filter.sensitivity_hz=[]", "filter.marker_cutoff=6.0"),
                            repeat)
        full = time_process(cli(), repeat)
    print(f"  cold CLI, one inverse dynamics and fit (6 Hz, no bootstrap, no refits), "
          f"{repeat} runs: {bare.describe('s')}")
    print(f"  cold CLI as shipped (residual analysis, 200 bootstrap refits, 5 cut-off and 10 "
          f"noise refits each with its inverse dynamics), {repeat} runs: "
          f"{full.describe('s')}")
    print(f"  OpenSim Moco: no counterpart of the decomposition (it fits the samples' "
          f"moments, no dynamics): {NOT_AVAILABLE}")
    shooting(args.repeat, args.peer_minutes)
    swing(args.repeat)


if __name__ == "__main__":
    main()
