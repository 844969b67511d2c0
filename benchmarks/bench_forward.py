"""Forward-dynamics speed of the leg, paired in one run (min / median of repeats).

1. The leg's right-hand side (foot still, collapse start) against ``pin.aba`` on the
   same leg and state (goal: at most 3x).
2. 1 s of the driven re-synthesis (bundled subject01, right leg, measured moments and
   hip load, foot prescribed) at h = 1 ms, modified Euler, 10 iterations
   (10 000 right-hand sides; goal: at most 0.1 s of compute).
3. The same leg collapsing for 1 s from the thesis' start (foot still, no moments), with
   an adaptive integrator at accuracy 1e-5: predgait (SciPy RK45, rtol = atol = 1e-5, on
   the engine's right-hand side) against OpenSim 4.6's Manager (Runge-Kutta-Merson,
   accuracy 1e-5) in the Python named by OPENSIM_PYTHON (goal: at most 1x OpenSim's
   time); "peer not available" when it cannot run. Both end states are printed.

Run:  python benchmarks/bench_forward.py
Figures depend on the machine and its load; only ratios measured in the same run are
printed.
"""

from __future__ import annotations

import sys
import tempfile
import timeit
from pathlib import Path

import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import NOT_AVAILABLE, Timing, ratio, run_peer, time_call  # noqa: E402

from predgait.dynamics.drivers import LegDrivers  # noqa: E402
from predgait.dynamics.forward import LegSystem, simulate_leg  # noqa: E402
from predgait.dynamics.integrators import IntegratorOptions, Method  # noqa: E402
from predgait.dynamics.inverse_trial import bundled_inverse  # noqa: E402
from predgait.models.loading import load_model  # noqa: E402

X0 = np.radians([5.0, -10.0, 0.0, 0.0])   # ankle, knee (model coordinates), rates
LAB_TO_OSIM = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def per_call(statement: str, namespace: dict, number: int = 20000, repeat: int = 7
             ) -> np.ndarray:
    """Microseconds per call of ``statement``, one figure per repeat."""
    return np.array(timeit.repeat(statement, number=number, repeat=repeat,
                                  globals=namespace)) / number * 1e6


def right_hand_side(model) -> None:
    system = LegSystem(model, LegDrivers.still())
    q, v, _ = system.full_state(0.0, X0)
    pm, data, tau = model.pin_model, model.pin_model.createData(), np.zeros(model.nq)
    space = {"pin": pin, "pm": pm, "data": data, "q": q, "v": v, "tau": tau,
             "system": system, "x": X0}
    # interleave the two so that both see the same machine load
    rhs, aba = [], []
    for _ in range(3):
        rhs.append(per_call("system(0.0, x)", space, repeat=3))
        aba.append(per_call("pin.aba(pm, data, q, v, tau)", space, repeat=3))
    rhs, aba = np.concatenate(rhs), np.concatenate(aba)
    print(f"1. leg right-hand side: {rhs.min():.2f} / {np.median(rhs):.2f} us (min / median); "
          f"pin.aba on the same leg: {aba.min():.2f} / {np.median(aba):.2f} us; "
          f"ratio {rhs.min() / aba.min():.2f}x (min), {np.median(rhs) / np.median(aba):.2f}x "
          "(median); goal <= 3x")


def resynthesis() -> None:
    inverse = bundled_inverse("right")
    drivers = LegDrivers.from_inverse(inverse)
    options = IntegratorOptions(method=Method.MODIFIED_EULER, step=1e-3, iterations=10)
    sims = []
    timing = time_call(lambda: sims.append(simulate_leg(inverse.model, drivers, (0.0, 1.0),
                                                        options=options)), repeat=5)
    sim = sims[-1]
    print(f"2. driven re-synthesis, 1 s, h = 1 ms, modified Euler x10 ({sim.n_rhs_evaluations} "
          f"right-hand sides, {sim.status}, fall at {sim.time_to_fall}): "
          f"{timing.describe('ms')}; goal <= 100 ms: "
          f"{'met' if timing.best <= 0.1 else 'NOT met'}")


def opensim_collapse(model) -> None:
    options = IntegratorOptions(method=Method.RK45, rtol=1e-5, atol=1e-5, step=0.1)
    sims = []
    ours = time_call(lambda: sims.append(simulate_leg(model, LegDrivers.still(), (0.0, 1.0),
                                                      X0, options=options)), repeat=5)
    pm = model.pin_model
    inertias = [pm.inertias[j] for j in range(1, pm.njoints)]
    with tempfile.TemporaryDirectory() as tmp:
        setup = Path(tmp) / "setup.npz"
        np.savez(setup, gravity=model.gravity, x0=X0, duration=1.0, accuracy=1e-5, repeat=5,
                 mass=[i.mass for i in inertias], inertia=[i.inertia[1, 1] for i in inertias],
                 com=[LAB_TO_OSIM @ i.lever for i in inertias],
                 offset=[LAB_TO_OSIM @ pm.jointPlacements[j].translation for j in range(1, 4)])
        peer = run_peer("opensim_forward_leg.py", str(setup))
    theirs = None if "error" in peer else Timing(tuple(peer["wall"]), tuple(peer["cpu"]))
    end = np.degrees(sims[-1].q[-1, 3:])
    print(f"3. collapse 1 s, adaptive 1e-5: predgait RK45 {ours.describe('ms')} "
          f"({sims[-1].n_rhs_evaluations} right-hand sides; end ankle, knee "
          f"{end[0]:.2f}, {end[1]:.2f} deg)")
    if theirs is None:
        print(f"   OpenSim: {NOT_AVAILABLE} ({peer['error']})")
        return
    their_end = np.degrees(peer["final"])
    print(f"   OpenSim {peer['version']} Manager (RKM): {theirs.describe('ms')} (end ankle, "
          f"knee {their_end[0]:.2f}, {their_end[1]:.2f} deg)")
    print(f"   OpenSim time / predgait time: {ratio(ours, theirs)}; goal >= 1x")


def main() -> None:
    model = load_model("leg")
    right_hand_side(model)
    resynthesis()
    opensim_collapse(model)


if __name__ == "__main__":
    main()
