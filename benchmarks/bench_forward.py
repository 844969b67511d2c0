"""Forward-dynamics speed: 1 s of the leg (thesis collapse start, foot still).

Runs (wall time, best of 3):
  * modified Euler, h = 1 ms, 10 iterations (10 000 right-hand sides; target < 0.1 s);
  * adaptive at 1e-5 accuracy: SciPy RK45 and LSODA on the Pinocchio right-hand side,
    and CasADi's CVODES on the ADAM (symbolic) dynamics of the same URDF.
OpenSim 4.6's Manager (Runge-Kutta-Merson) takes about 4 ms for this 1 s on a machine
like ours (quoted figure: ``opensim`` is not installable here, so the ratio is printed
against that number, not measured).

Run:  .venv/bin/python benchmarks/bench_forward.py
"""

from __future__ import annotations

import time

import numpy as np

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forward import LegSystem, simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.models.loading import load_model

OPENSIM_MS = 4.0
X0 = np.radians([5.0, -10.0, 0.0, 0.0])


def best(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), out


def casadi_cvodes(model, tol):
    import casadi as cs

    from predgait.models.symbolic import symbolic_model

    sym = symbolic_model(model)
    x = cs.MX.sym("x", 4)
    q = cs.vertcat(0, 0, 0, x[0], x[1])
    v = cs.vertcat(0, 0, 0, x[2], x[3])
    M = sym.mass_matrix(q)
    h = sym.bias_force(q, v)
    a = cs.solve(M[3:5, 3:5], -h[3:5])
    F = cs.integrator("F", "cvodes", {"x": x, "ode": cs.vertcat(x[2], x[3], a)}, 0.0, 1.0,
                      {"abstol": tol, "reltol": tol})
    return F


def main():
    model = load_model("leg")
    drivers = LegDrivers.still()
    system = LegSystem(model, drivers)
    n = 20000
    t = time.perf_counter()
    for _ in range(n):
        system(0.0, X0)
    rhs_us = (time.perf_counter() - t) / n * 1e6
    print(f"right-hand side (Pinocchio CRBA + NLE + hip Jacobian): {rhs_us:.1f} us/call")
    me = IntegratorOptions(method=Method.MODIFIED_EULER, step=1e-3, iterations=10)
    wall, sim = best(lambda: simulate_leg(model, drivers, (0.0, 1.0), X0, options=me))
    print(f"modified Euler h=1 ms x10, 1 s: {wall * 1e3:.1f} ms ({sim.n_rhs_evaluations} rhs; "
          f"target 100 ms: {'met' if wall < 0.1 else 'NOT met'}; "
          f"{wall * 1e3 / OPENSIM_MS:.1f}x the quoted OpenSim 4 ms)")
    ref = simulate_leg(model, drivers, (0.0, 1.0), X0, options=IntegratorOptions(
        method=Method.RADAU, rtol=1e-11, atol=1e-12, step=0.1)).q[-1, 3:]
    for method in (Method.RK45, Method.LSODA):
        opts = IntegratorOptions(method=method, rtol=1e-5, atol=1e-5, step=0.1)
        wall, sim = best(lambda opts=opts: simulate_leg(model, drivers, (0.0, 1.0), X0,
                                                        options=opts))
        err = np.max(np.abs(sim.q[-1, 3:] - ref))
        print(f"SciPy {method.value} tol 1e-5: {wall * 1e3:.1f} ms, {sim.n_rhs_evaluations} rhs, "
              f"end error {err:.1e} rad; {wall * 1e3 / OPENSIM_MS:.2f}x OpenSim (quoted)")
    try:
        F = casadi_cvodes(model, 1e-5)
        wall, out = best(lambda: F(x0=X0))
        err = np.max(np.abs(np.array(out["xf"]).ravel()[:2] - ref))
        print(f"CasADi CVODES (ADAM dynamics) tol 1e-5: {wall * 1e3:.2f} ms, end error "
              f"{err:.1e} rad; {wall * 1e3 / OPENSIM_MS:.2f}x OpenSim (quoted)")
    except Exception as exc:  # noqa: BLE001 - report and go on
        print(f"CasADi CVODES: not run ({exc})")


if __name__ == "__main__":
    main()
