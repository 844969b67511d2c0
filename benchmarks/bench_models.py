"""RNEA and ABA time per call on the shipped leg (Python through Pinocchio) and ADAM/CasADi.

Run: python benchmarks/bench_models.py
"""

import time

import numpy as np
import pinocchio as pin

from predgait.models.loading import load_model
from predgait.models.symbolic import symbolic_model


def per_call(function, repeat=20000):
    function()
    best = np.inf
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(repeat):
            function()
        best = min(best, (time.perf_counter() - start) / repeat)
    return best


def main():
    model = load_model("leg")
    pm, data = model.pin_model, model.pin_model.createData()
    rng = np.random.default_rng(0)
    q, v, a = (rng.uniform(-1, 1, model.nq) for _ in range(3))
    tau = pin.rnea(pm, data, q, v, a)
    sym = symbolic_model(model)
    figures = {
        "pinocchio rnea": per_call(lambda: pin.rnea(pm, data, q, v, a)),
        "pinocchio aba": per_call(lambda: pin.aba(pm, data, q, v, tau)),
        "pinocchio crba": per_call(lambda: pin.crba(pm, data, q)),
        "adam/casadi forward_dynamics (numeric call)": per_call(
            lambda: sym.forward_dynamics(q, v, tau), repeat=2000),
    }
    for name, seconds in figures.items():
        print(f"{name:<46} {seconds * 1e6:8.2f} us/call")
    ratio = figures["adam/casadi forward_dynamics (numeric call)"] / figures["pinocchio aba"]
    print(f"ADAM (CasADi VM) / Pinocchio ABA: {ratio:.1f}x")


if __name__ == "__main__":
    main()
