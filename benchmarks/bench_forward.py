"""Forward-dynamics speed of the leg, paired in one run (min / median of repeats).

1. The leg's right-hand side (foot still, thesis collapse start) against ``pin.aba`` on
   the same leg and state, timed interleaved (goal: at most 3x).
2. 1 s of the driven re-synthesis (bundled subject01, right leg: measured moments and hip
   load, foot prescribed) at h = 1 ms, modified Euler, 10 iterations (10 000 right-hand
   sides; goal: at most 0.1 s of compute).
3. The same leg collapsing for 1 s from the collapse start, adaptive at accuracy 1e-5:
   predgait (SciPy RK45 on the engine's right-hand side) against OpenSim 4.6's Manager
   (Runge-Kutta-Merson, accuracy 1e-5, same leg built with the OpenSim API, foot welded,
   in the Python named by OPENSIM_PYTHON: opensim_leg.py), timed in the same run (goal:
   at most 1x OpenSim's time); "peer not available" when it cannot run.

Run:  python benchmarks/bench_forward.py
Figures depend on the machine and its load; ratios are only printed between figures
measured in the same run.
"""

from __future__ import annotations

import timeit

import numpy as np
import pinocchio as pin
from timing import NOT_AVAILABLE, Row, leg_segments, print_rows, run_peer_npz, time_call

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


def resynthesis(repeat: int = 5) -> str:
    """Item 2: 1 s of the driven re-synthesis, modified Euler h = 1 ms x 10."""
    inverse = bundled_inverse("right")
    drivers = LegDrivers.from_inverse(inverse)
    options = IntegratorOptions(method=Method.MODIFIED_EULER, step=1e-3, iterations=10)
    sims = []
    timing = time_call(lambda: sims.append(simulate_leg(inverse.model, drivers, (0.0, 1.0),
                                                        options=options)), repeat)
    sim = sims[-1]
    return (f"2. driven re-synthesis 1 s, h = 1 ms, modified Euler x10 "
            f"({sim.n_rhs_evaluations} right-hand sides, {sim.status}): "
            f"{timing.describe('ms')}; goal <= 100 ms: "
            f"{'met' if timing.best <= 0.1 else 'NOT met'}")


def opensim_manager(model, repeat: int = 3) -> dict:
    """OpenSim's Manager on 1 s of the same leg from X0, foot welded, accuracy 1e-5."""
    return run_peer_npz("opensim_leg.py", mode="forward", x0=X0, duration=1.0, accuracy=1e-5,
                        repeat=repeat, **leg_segments(model))


def rows(repeat: int) -> list[Row]:
    """Item 3: leg forward 1 s, adaptive 1e-5, SciPy RK45 against the Manager (run_all.py)."""
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
    return [Row("3. leg forward 1 s from the thesis collapse start, adaptive 1e-5 "
                "(goal: OpenSim/predgait >= 1)", ours,
                f"SciPy RK45 on the engine's right-hand side, {sim.n_rhs_evaluations} rhs, "
                f"end error {error:.1e} rad", peer.get("timing"), peer_does)]


def main() -> None:
    model = load_model("leg")
    print(right_hand_side(model))
    print(resynthesis())
    print_rows(rows(5))


if __name__ == "__main__":
    main()
