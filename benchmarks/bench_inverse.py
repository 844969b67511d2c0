"""Inverse dynamics speed: 1000 frames of the leg, and the whole bundled pipeline.

Run: python benchmarks/bench_inverse.py

Reference (issue 4, OpenSim 4.6 on a 2-core machine like ours): InverseDynamicsSolver
called per frame from Python ~12 ms for 1000 frames; InverseDynamicsTool with file I/O
~26 ms. opensim is not installable from this project's package index, so the ratios are
printed against those quoted figures.
"""

import tempfile
import time

import casadi as cs
import numpy as np

from predgait.dynamics.external import Load
from predgait.dynamics.inverse import leg_inverse_dynamics
from predgait.models.loading import load_model
from predgait.models.symbolic import symbolic_model
from predgait.workflows.inverse import bundled_options, run_inverse
from predgait.workflows.inverse_io import write_inverse_outputs

OPENSIM_SOLVER_1000 = 12e-3
OPENSIM_TOOL = 26e-3


def best_of(function, repeat=5):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def casadi_inverse(model):
    """The same ID as a CasADi function of one frame (ADAM dynamics), for map()."""
    sym = symbolic_model(model)
    q, qd, qdd = (cs.SX.sym(n, model.nq) for n in ("q", "qd", "qdd"))
    force, cop = cs.SX.sym("force", 3), cs.SX.sym("cop", 3)
    hip = sym.frame_position("hip_center")(q)
    rows = cs.vertcat(hip[0], hip[2], q[2] + q[3] + q[4])
    jac_hip = cs.jacobian(rows, q)
    # Ground force at the COP: generalised base forces Fx, Fz and its moment about +Y at
    # the foot origin (x, z) = (q[0], q[1]).
    moment = (cop[2] - q[1]) * force[0] - (cop[0] - q[0]) * force[2]
    ground = cs.vertcat(force[0], force[2], moment, 0, 0)
    rhs = sym.mass_matrix(q) @ qdd + sym.bias_force(q, qd) - ground
    wrench = cs.solve(jac_hip[:, :3].T, rhs[:3])
    tau = rhs[3:] - jac_hip[:, 3:].T @ wrench
    return cs.Function("inverse_dynamics", [q, qd, qdd, force, cop], [tau, wrench],
                       ["q", "qd", "qdd", "force", "cop"], ["tau", "hip"])


def main():
    model = load_model("leg")
    rng = np.random.default_rng(0)
    n = 1000
    q, qd, qdd = (rng.uniform(-0.5, 0.5, (n, model.nq)) for _ in range(3))
    force = np.column_stack([rng.uniform(-50, 50, n), np.zeros(n), rng.uniform(300, 800, n)])
    cop = np.column_stack([q[:, 0] + 0.05, np.zeros(n), np.zeros(n)])
    loads = [[Load("foot", force[k], point=cop[k])] for k in range(n)]
    pin_loop = best_of(lambda: leg_inverse_dynamics(model, q, qd, qdd, loads))
    f = casadi_inverse(model)
    mapped = f.map(n, "thread", 2)
    args = (q.T, qd.T, qdd.T, force.T, cop.T)
    casadi_map = best_of(lambda: mapped(*args))
    serial = f.map(n)
    casadi_serial = best_of(lambda: serial(*args))
    tau_cs = np.array(mapped(*args)[0]).T
    tau_pin = leg_inverse_dynamics(model, q, qd, qdd, loads).tau[:, 3:]
    print(f"1000 frames, Pinocchio loop (RNEA + hip solve + joint forces): {pin_loop * 1e3:7.2f} ms"
          f"  ({OPENSIM_SOLVER_1000 / pin_loop:.2f}x OpenSim solver loop)")
    print(f"1000 frames, CasADi map of the ADAM expression (2 threads):    "
          f"{casadi_map * 1e3:7.2f} ms  ({OPENSIM_SOLVER_1000 / casadi_map:.2f}x OpenSim)")
    print(f"1000 frames, CasADi map, serial:                                "
          f"{casadi_serial * 1e3:7.2f} ms  ({OPENSIM_SOLVER_1000 / casadi_serial:.2f}x OpenSim)")
    try:
        compile_start = time.perf_counter()
        jit = cs.Function("inverse_dynamics_jit", f.sx_in(), f.call(f.sx_in()),
                          {"jit": True, "compiler": "shell", "jit_options": {"flags": ["-O3"]}})
        jit_map = jit.map(n)
        jit_map(*args)
        compile_time = time.perf_counter() - compile_start
        casadi_jit = best_of(lambda: jit_map(*args))
        print(f"1000 frames, CasADi map, JIT-compiled with gcc:                 "
              f"{casadi_jit * 1e3:7.2f} ms  ({OPENSIM_SOLVER_1000 / casadi_jit:.2f}x OpenSim; "
              f"compilation {compile_time:.2f} s)")
    except RuntimeError as exc:
        print(f"JIT unavailable here ({exc})")
    print(f"  max |tau_casadi - tau_pinocchio| = {np.abs(tau_cs - tau_pin).max():.2e} N m")
    options = bundled_options("right")
    pipeline = best_of(lambda: run_inverse(options), repeat=3)
    print(f"bundled trial, run_inverse (read, filter, IK, ID; 151 frames): "
          f"{pipeline * 1e3:7.1f} ms  ({OPENSIM_TOOL / pipeline:.2f}x OpenSim tool)")
    result = run_inverse(options)
    with tempfile.TemporaryDirectory() as tmp:
        counter = iter(range(100))
        writing = best_of(lambda: write_inverse_outputs(result, f"{tmp}/o{next(counter)}"),
                          repeat=2)
    print(f"  writing STO/CSV/JSON and 4 PNG plots: {writing * 1e3:7.1f} ms")


if __name__ == "__main__":
    main()
