"""Loop overhead of the fixed-step integrators per rhs call, and the thesis benchmark.

The thesis' setting (4.2): 1 s of the leg at h = 1 ms, modified Euler with 10
iterations = 10,000 evaluations of the dynamics. With a Pinocchio ABA at ~5-10 us per
call the whole run must stay under 0.1 s, so the integrator's own cost per call must be
a small fraction of that. A trivial rhs (returns a preallocated-size new array) isolates
that cost; the ABA run shows the total on the shipped leg model.

Run: python benchmarks/bench_integrators.py
"""

import time

import numpy as np
import pinocchio as pin

from predgait.dynamics.integrators import IntegratorOptions, Method, integrate
from predgait.models.loading import load_model

NX = 10  # 5-DOF leg: q (5) and v (5)


def best_of(function, repeat=7):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def trivial_rhs_cost(rhs, x, calls=100_000):
    start = time.perf_counter()
    for _ in range(calls):
        rhs(0.0, x)
    return (time.perf_counter() - start) / calls


def main():
    a = -np.linspace(0.1, 1.0, NX)

    def rhs(t, x):
        return a * x  # one numpy op: a new array, like a real rhs returns

    x0 = np.ones(NX)
    rhs_alone = min(trivial_rhs_cost(rhs, x0) for _ in range(3))
    print(f"trivial rhs alone: {rhs_alone * 1e6:.2f} us/call (nx = {NX})")
    cases = [("euler", Method.EULER, 1), ("modified_euler k=2", Method.MODIFIED_EULER, 2),
             ("modified_euler k=10", Method.MODIFIED_EULER, 10), ("rk4", Method.RK4, 1)]
    for label, method, iterations in cases:
        options = IntegratorOptions(method=method, step=1e-3, iterations=iterations)
        seconds, result = best_of(lambda o=options: integrate(rhs, (0.0, 1.0), x0, options=o))
        calls = result.n_rhs_evaluations
        overhead = seconds / calls - rhs_alone
        print(f"{label:<22} {calls:6d} rhs calls in {seconds * 1e3:7.2f} ms: "
              f"overhead {overhead * 1e6:5.2f} us per rhs call")

    model = load_model("leg")
    pm, data = model.pin_model, model.pin_model.createData()
    nq = model.nq
    tau = np.zeros(nq)

    def leg(t, x):
        return np.concatenate((x[nq:], pin.aba(pm, data, x[:nq], x[nq:], tau)))

    xl = np.zeros(2 * nq)
    xl[3], xl[4] = np.radians(5.0), np.radians(-10.0)
    aba_alone = min(trivial_rhs_cost(leg, xl, 20_000) for _ in range(3))
    options = IntegratorOptions(method=Method.MODIFIED_EULER, step=1e-3, iterations=10)
    seconds, result = best_of(lambda: integrate(leg, (0.0, 1.0), xl, options=options,
                                                divergence_limit=1e9))
    print(f"leg rhs (pin.aba + concatenate) alone: {aba_alone * 1e6:.2f} us/call")
    print(f"thesis benchmark (leg, 1 s, h = 1 ms, modified Euler k = 10): "
          f"{result.n_rhs_evaluations} calls in {seconds * 1e3:.1f} ms "
          f"(budget 100 ms: {seconds / 0.1:.2f} of it; integrator share "
          f"{1 - aba_alone * result.n_rhs_evaluations / seconds:.0%})")


if __name__ == "__main__":
    main()
