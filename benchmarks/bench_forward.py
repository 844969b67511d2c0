"""Forward-dynamics speed of the leg, paired in one run (min / median of repeats).

1. The leg's right-hand side (foot still, thesis collapse start) against ``pin.aba`` on
   the same leg and state, timed interleaved (goal: at most 3x).
2. 1 s of the driven re-synthesis (bundled subject01, right leg: measured moments and hip
   load, foot prescribed) at h = 1 ms, modified Euler, 10 iterations (10 000 right-hand
   sides; goal: at most 0.1 s of compute), ``simulate_leg`` three ways in the same run:
   the Pinocchio engine (solver cache off), the CasADi steps in CasADi's virtual machine
   and compiled (dynamics/compiled_leg.py, a temporary cache folder). Also the one-time
   costs: building the ADAM dynamics, loading them from the cache, compiling the steps.
   No OpenSim set-up does the same work: "peer not available".
3. The same leg collapsing for 1 s from the collapse start, adaptive, against OpenSim
   4.6's Manager (Runge-Kutta-Merson, accuracy 1e-5, same leg built with the OpenSim API,
   foot welded, in the Python named by OPENSIM_PYTHON: opensim_leg.py; model built once,
   initSystem + Manager timed), in the same run (goal: at most 1x OpenSim's time);
   "peer not available" when it cannot run. Every end error is against the same Radau
   run at 1e-11 in this run. Rows: ``simulate_leg`` with SciPy RK45 at 1e-5, and
   "adaptive, matched end accuracy": ``simulate_leg`` with method "cvodes"
   (dynamics/cvodes_leg.py: CVODES on the leg's CasADi right-hand side) at the loosest
   tolerance of 1e-5 ... 1e-9 whose end error is at or below the Manager's at 1e-5
   (system, CVODES set-up and output recovery in every repeat; the ADAM dynamics
   loaded from the cache, built once per machine, not timed).

Run:  python benchmarks/bench_forward.py
Figures depend on the machine and its load; ratios are only printed between figures
measured in the same run.
"""

from __future__ import annotations

import resource
import tempfile
import time
import timeit

import numpy as np
import pinocchio as pin
from timing import (
    NOT_AVAILABLE,
    Row,
    environment,
    leg_segments,
    print_rows,
    run_peer_npz,
    time_call,
)

from predgait import function_cache
from predgait.dynamics import compiled_leg
from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forward import LegSystem, simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.models.loading import load_model

X0 = np.radians([5.0, -10.0, 0.0, 0.0])   # ankle, knee (model coordinates), rates


def _per_call(statement: str, namespace: dict, number: int = 20000) -> np.ndarray:
    """Microseconds per call of ``statement``, one figure per repeat (3 repeats)."""
    return np.array(timeit.repeat(statement, number=number, repeat=3,
                                  globals=namespace)) / number * 1e6


def right_hand_side(model) -> str:
    """Item 1: leg right-hand side against pin.aba, interleaved."""
    system = LegSystem(model, LegDrivers.still())
    q, v, _ = system.full_state(0.0, X0)
    space = {"pin": pin, "pm": model.pin_model, "data": model.pin_model.createData(),
             "q": q, "v": v, "tau": np.zeros(model.nq), "system": system, "x": X0}
    rhs, aba = [], []
    for _ in range(3):  # interleaved: both see the same machine load
        rhs.append(_per_call("system(0.0, x)", space))
        aba.append(_per_call("pin.aba(pm, data, q, v, tau)", space))
    rhs, aba = np.concatenate(rhs), np.concatenate(aba)
    return (f"1. leg right-hand side {rhs.min():.2f} / {np.median(rhs):.2f} us (min / median), "
            f"pin.aba on the same leg {aba.min():.2f} / {np.median(aba):.2f} us: "
            f"{rhs.min() / aba.min():.2f}x (min), {np.median(rhs) / np.median(aba):.2f}x "
            "(median); goal <= 3x")


def _seconds(function) -> float:
    """CPU seconds of ``function()``, this process and its finished children (gcc)."""
    def cpu():
        child = resource.getrusage(resource.RUSAGE_CHILDREN)
        return time.process_time() + child.ru_utime + child.ru_stime

    start = cpu()
    function()
    return cpu() - start


def resynthesis_rows(repeat: int = 5) -> list[Row]:
    """Item 2: 1 s of the driven re-synthesis, modified Euler h = 1 ms x 10, three ways."""
    inverse = bundled_inverse("right")
    drivers = LegDrivers.from_inverse(inverse)
    options = IntegratorOptions(method=Method.MODIFIED_EULER, step=1e-3, iterations=10)
    sims = []

    def run():
        sims.append(simulate_leg(inverse.model, drivers, (0.0, 1.0), options=options))

    work = ("2. driven re-synthesis 1 s, h = 1 ms, modified Euler x10 (10 000 right-hand "
            "sides; goal <= 100 ms)")
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        cache = {function_cache.FOLDER: folder, function_cache.SWITCH: "on",
                 function_cache.WHEN: "now"}
        with environment({function_cache.SWITCH: "off"}):
            pinocchio = time_call(run, repeat, warmup=True)
        rows.append(Row(f"{work}: Pinocchio engine", pinocchio,
                        f"simulate_leg, cache off, {sims[-1].status}", None,
                        "no same-work OpenSim set-up"))
        reference = sims[-1].q
        with environment(cache):
            compiled_leg.leg_dynamics.cache_clear()
            build = _seconds(lambda: compiled_leg.leg_dynamics(inverse.model))
            compiled_leg.leg_dynamics.cache_clear()
            load = _seconds(lambda: compiled_leg.leg_dynamics(inverse.model))
            compiler, found = function_cache.compiler, function_cache.compiler()
            function_cache.compiler = lambda: None   # the virtual machine only
            try:
                compiled_leg._STEPS.clear()
                vm = time_call(run, repeat, warmup=True)
            finally:
                function_cache.compiler = compiler
            rows.append(Row(f"{work}: CasADi steps, virtual machine", vm,
                            f"max |q - Pinocchio's| {np.abs(sims[-1].q - reference).max():.1e}"
                            f"; one-time per machine: ADAM build {build:.2f} s CPU, later "
                            f"processes load it from the cache in {load * 1e3:.1f} ms", None,
                            "no same-work OpenSim set-up"))
            if found:
                compiled_leg._STEPS.clear()
                first = _seconds(run)  # compiles the steps in the foreground, once
                compiled = time_call(run, repeat)
                rows.append(Row(f"{work}: CasADi steps, compiled", compiled,
                                f"max |q - Pinocchio's| "
                                f"{np.abs(sims[-1].q - reference).max():.1e}; first run, "
                                f"compiling with gcc -O1, {first:.2f} s CPU with gcc's (in "
                                "the background by default)", None, "no same-work OpenSim set-up"))
        compiled_leg.leg_dynamics.cache_clear()
        compiled_leg._STEPS.clear()
    return rows


def opensim_manager(model, repeat: int = 3) -> dict:
    """OpenSim's Manager on 1 s of the same leg from X0, foot welded, accuracy 1e-5."""
    return run_peer_npz("opensim_leg.py", mode="forward", x0=X0, duration=1.0, accuracy=1e-5,
                        repeat=repeat, **leg_segments(model))


def matched_accuracy(model, drivers, reference, peer, peer_does, repeat) -> Row:
    """Item 3, CVODES at the loosest tolerance whose end error <= the Manager's."""
    target = (np.abs(peer["xf"][:2] - reference).max() if "error" not in peer else None)
    with tempfile.TemporaryDirectory() as folder, environment(
            {function_cache.FOLDER: folder, function_cache.SWITCH: "on"}):
        compiled_leg.leg_dynamics(model)   # once per machine (the model build, not timed)

        def run(tolerance):
            return simulate_leg(model, drivers, (0.0, 1.0), X0, options=IntegratorOptions(
                method=Method.CVODES, rtol=tolerance, atol=tolerance, step=0.1))

        errors = {}
        for tolerance in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9):
            sim = run(tolerance)
            errors[tolerance] = np.abs(sim.q[-1, 3:] - reference).max()
            if target is None or errors[tolerance] <= target:
                break
        timing = time_call(lambda: run(tolerance), repeat)
        compiled_leg.leg_dynamics.cache_clear()
    tried = ", ".join(f"{t:g}: {e:.1e}" for t, e in errors.items())
    matched = (f"end error {errors[tolerance]:.1e} rad <= the Manager's {target:.1e}"
               if target is not None and errors[tolerance] <= target else
               "no tolerance tried matched the Manager's error" if target is not None else
               f"{NOT_AVAILABLE}: no Manager error to match")
    return Row("3. leg forward 1 s from the thesis collapse start, adaptive, matched end "
               "accuracy (goal: OpenSim/predgait >= 1)", timing,
               f"simulate_leg, method cvodes, tolerance {tolerance:g}, "
               f"{sim.n_rhs_evaluations} rhs, {matched} (end errors by tolerance: {tried})",
               peer.get("timing"), peer_does + " (the same peer run as the row above)")


def rows(repeat: int) -> list[Row]:
    """Items 2 and 3 (for run_all.py)."""
    model = load_model("leg")
    drivers = LegDrivers.still()
    reference = simulate_leg(model, drivers, (0.0, 1.0), X0, options=IntegratorOptions(
        method=Method.RADAU, rtol=1e-11, atol=1e-12, step=0.1)).q[-1, 3:]
    opts = IntegratorOptions(method=Method.RK45, rtol=1e-5, atol=1e-5, step=0.1)
    ours = time_call(lambda: simulate_leg(model, drivers, (0.0, 1.0), X0, options=opts),
                     repeat)
    sim = simulate_leg(model, drivers, (0.0, 1.0), X0, options=opts)
    error = np.abs(sim.q[-1, 3:] - reference).max()
    peer = opensim_manager(model, repeat)
    peer_does = "Manager, Runge-Kutta-Merson accuracy 1e-5, same leg, foot welded"
    if "error" in peer:
        peer_does += f" ({NOT_AVAILABLE}: {peer['error']})"
    else:
        peer_does += f", end error {np.abs(peer['xf'][:2] - reference).max():.1e} rad"
    work = "3. leg forward 1 s from the thesis collapse start, adaptive"
    out = [Row(f"{work} 1e-5 (goal: OpenSim/predgait >= 1)", ours,
               f"SciPy RK45 on the engine's right-hand side (simulate_leg), "
               f"{sim.n_rhs_evaluations} rhs, end error {error:.1e} rad", peer.get("timing"),
               peer_does)]
    out.append(matched_accuracy(model, drivers, reference, peer, peer_does, repeat))
    return [*resynthesis_rows(repeat), *out]


def main() -> None:
    model = load_model("leg")
    print(right_hand_side(model))
    print_rows(rows(5))


if __name__ == "__main__":
    main()
