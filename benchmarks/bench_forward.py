"""Forward-dynamics speed: 1 s of the leg (thesis collapse start, foot still).

Runs (wall time, best of 3):
  * modified Euler, h = 1 ms, 10 iterations (10 000 right-hand sides; target < 0.1 s);
  * adaptive at 1e-5 accuracy: SciPy RK45 and LSODA on the Pinocchio right-hand side,
    and CasADi's CVODES on the ADAM (symbolic) dynamics of the same URDF.
The peer: OpenSim 4.6's Manager (Runge-Kutta-Merson, accuracy 1e-5) on the same leg built
with the OpenSim API, foot welded, in its own process (opensim_leg.py; set OPENSIM_PYTHON),
timed in the same run; without it the ratios print "peer not available".

Run:  .venv/bin/python benchmarks/bench_forward.py
"""

from __future__ import annotations

import time

import numpy as np
from timing import NOT_AVAILABLE, Row, leg_segments, run_peer_npz, time_call

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forward import LegSystem, simulate_leg
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.models.loading import load_model

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


def opensim_manager(model, repeat: int = 3) -> dict:
    """OpenSim's Manager on 1 s of the same leg from X0, foot welded, accuracy 1e-5."""
    return run_peer_npz("opensim_leg.py", mode="forward", x0=X0, duration=1.0, accuracy=1e-5,
                        repeat=repeat, **leg_segments(model))


def versus_opensim(wall: float, peer: dict) -> str:
    """Ratio against the peer measured in this run (> 1: predgait faster)."""
    if "error" in peer:
        return f"OpenSim Manager: {NOT_AVAILABLE}"
    return f"{peer['timing'].best / wall:.2f}x the OpenSim Manager's best (> 1 = faster)"


def rows(repeat: int) -> list[Row]:
    """Leg forward 1 s, adaptive 1e-5: SciPy RK45 against the Manager (for run_all.py)."""
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
        peer_does += f" ({peer['error']})"
    else:
        peer_error = np.abs(peer["xf"][:2] - reference).max()
        peer_does += f", end error {peer_error:.1e} rad"
    return [Row("leg forward 1 s from the thesis collapse start, adaptive 1e-5", ours,
                f"SciPy RK45 on the Pinocchio right-hand side, {sim.n_rhs_evaluations} rhs, "
                f"end error {error:.1e} rad", peer.get("timing"), peer_does)]


def main():
    model = load_model("leg")
    peer = opensim_manager(model)
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
          f"target 100 ms: {'met' if wall < 0.1 else 'NOT met'}; {versus_opensim(wall, peer)})")
    ref = simulate_leg(model, drivers, (0.0, 1.0), X0, options=IntegratorOptions(
        method=Method.RADAU, rtol=1e-11, atol=1e-12, step=0.1)).q[-1, 3:]
    for method in (Method.RK45, Method.LSODA):
        opts = IntegratorOptions(method=method, rtol=1e-5, atol=1e-5, step=0.1)
        wall, sim = best(lambda opts=opts: simulate_leg(model, drivers, (0.0, 1.0), X0,
                                                        options=opts))
        err = np.max(np.abs(sim.q[-1, 3:] - ref))
        print(f"SciPy {method.value} tol 1e-5: {wall * 1e3:.1f} ms, {sim.n_rhs_evaluations} rhs, "
              f"end error {err:.1e} rad; {versus_opensim(wall, peer)}")
    try:
        F = casadi_cvodes(model, 1e-5)
        wall, out = best(lambda: F(x0=X0))
        err = np.max(np.abs(np.array(out["xf"]).ravel()[:2] - ref))
        print(f"CasADi CVODES (ADAM dynamics) tol 1e-5: {wall * 1e3:.2f} ms, end error "
              f"{err:.1e} rad; {versus_opensim(wall, peer)}")
    except Exception as exc:  # noqa: BLE001 - report and go on
        print(f"CasADi CVODES: not run ({exc})")


if __name__ == "__main__":
    main()
