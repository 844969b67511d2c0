"""Inverse dynamics speed: the leg's ID on 1000 frames and `predgait inverse` as a process.

Run: python benchmarks/bench_inverse.py [--repeat N]
(OpenSim rows: set OPENSIM_PYTHON to a Python with `pip install opensim`, and GAIT2354_DIR to
opensim-models' Pipelines/Gait2354_Simbody files, see opensim_subject01.py; otherwise they
print "peer not available".)

1. 1000 random frames of the shipped leg (5 DOF, ground reaction at a COP): predgait's
   ``leg_inverse_dynamics`` as ``run_inverse`` calls it (batched, one LoadHistory) against
   OpenSim 4.6's InverseDynamicsSolver on the same planar foot-shank-thigh built with the
   OpenSim API (opensim_leg.py), called per frame from Python, in the peer's process; plus,
   without a peer, the bare Pinocchio RNEA loop and the same ID as a CasADi function mapped
   over frames (serial, JIT: benchmark only, not the product path).
2. Whole processes: `predgait inverse problems/inverse_subject01.toml` (read TRC, MOT and
   static TRC, joint centres, planar IK, 6 Hz filters, ID of the right leg on 151 frames,
   STO/CSV/JSON and PNG plots) against OpenSim's InverseDynamicsTool (Python start, import
   opensim, load the 23-DOF Gait2354 model, ID on the shipped IK motion 0.4-1.6 s, 73
   frames, write the .sto) and its InverseKinematicsTool + InverseDynamicsTool.
3. The stages of ``run_inverse`` on subject01 (no peer).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
from timing import (
    REPO,
    Row,
    gait2354_folder,
    leg_segments,
    opensim_python,
    print_rows,
    run_peer_npz,
    time_call,
    time_process,
)

from predgait.dynamics.inverse import LoadHistory, leg_inverse_dynamics
from predgait.models.loading import load_model

N = 1000


def casadi_inverse(model):
    """The same ID as a CasADi function of one frame (ADAM dynamics), for map()."""
    import casadi as cs

    from predgait.models.symbolic import symbolic_model

    sym = symbolic_model(model)
    q, v, a = (cs.SX.sym(n, model.nq) for n in ("q", "qd", "qdd"))
    force, cop = cs.SX.sym("force", 3), cs.SX.sym("cop", 3)
    hip = sym.frame_position("hip_center")(q)
    rows = cs.vertcat(hip[0], hip[2], q[2] + q[3] + q[4])
    jac_hip = cs.jacobian(rows, q)
    # Ground force at the COP: generalised base forces Fx, Fz and its moment about +Y at
    # the foot origin (x, z) = (q[0], q[1]).
    moment = (cop[2] - q[1]) * force[0] - (cop[0] - q[0]) * force[2]
    ground = cs.vertcat(force[0], force[2], moment, 0, 0)
    rhs = sym.mass_matrix(q) @ a + sym.bias_force(q, v) - ground
    wrench = cs.solve(jac_hip[:, :3].T, rhs[:3])
    tau = rhs[3:] - jac_hip[:, 3:].T @ wrench
    return cs.Function("inverse_dynamics", [q, v, a, force, cop], [tau, wrench],
                       ["q", "qd", "qdd", "force", "cop"], ["tau", "hip"])


def random_frames(model):
    rng = np.random.default_rng(0)
    q, v, a = (rng.uniform(-0.5, 0.5, (N, model.nq)) for _ in range(3))
    force = np.column_stack([rng.uniform(-50, 50, N), np.zeros(N), rng.uniform(300, 800, N)])
    cop = np.column_stack([q[:, 0] + 0.05, np.zeros(N), np.zeros(N)])
    return q, v, a, force, cop


def leg_id_rows(repeat: int) -> list[Row]:
    """Leg ID of 1000 frames: the product path against OpenSim's solver loop."""
    model = load_model("leg")
    pm, data = model.pin_model, model.pin_model.createData()
    q, v, a, force, cop = random_frames(model)
    loads = [LoadHistory("foot", force, cop)]
    ours = time_call(lambda: leg_inverse_dynamics(model, q, v, a, loads), repeat,
                     warmup=True)
    # OpenSim gets the states without the ground reaction (its solver takes no loads here);
    # the equality check below uses the same states through bare RNEA.
    peer = run_peer_npz("opensim_leg.py", mode="inverse", q=q, qd=v, qdd=a, repeat=repeat,
                        **leg_segments(model))
    what_peer = "InverseDynamicsSolver per frame from Python, same leg and states"
    if "error" not in peer:
        bare = np.array([pin.rnea(pm, data, q[k], v[k], a[k]) for k in range(N)])
        what_peer += (f", OpenSim {peer['version']}; max |tau_OpenSim - tau_Pinocchio| = "
                      f"{np.abs(peer['tau'] - bare).max():.1e} N m")
    else:
        what_peer += f" ({peer['error']})"
    rows = [Row(f"leg ID, {N} frames (5 DOF, ground reaction, hip solve, joint forces)",
                ours, "leg_inverse_dynamics, batched, the path run_inverse uses",
                peer.get("timing"), what_peer)]
    bare = time_call(lambda: [pin.rnea(pm, data, q[k], v[k], a[k]) for k in range(N)],
                     repeat)
    rows.append(Row(f"bare Pinocchio RNEA loop, {N} frames, no loads", bare,
                    "pin.rnea per frame from Python"))
    rows.extend(casadi_rows(model, q, v, a, force, cop, loads, repeat))
    return rows


def casadi_rows(model, q, v, a, force, cop, loads, repeat) -> list[Row]:
    """The ID as a mapped CasADi function (serial and JIT-compiled): benchmark only."""
    import casadi as cs

    f = casadi_inverse(model)
    args = (q.T, v.T, a.T, force.T, cop.T)
    serial = f.map(N)
    rows = [Row(f"leg ID, {N} frames, CasADi map of the ADAM expression (benchmark only)",
                time_call(lambda: serial(*args), repeat), "serial map, SX virtual machine")]
    tau = leg_inverse_dynamics(model, q, v, a, loads).tau[:, 3:]
    check = np.abs(np.array(serial(*args)[0]).T - tau).max()
    try:
        start = time.perf_counter()
        jit = cs.Function("inverse_dynamics_jit", f.sx_in(), f.call(f.sx_in()),
                          {"jit": True, "compiler": "shell",
                           "jit_options": {"flags": ["-O3"]}}).map(N)
        compile_time = time.perf_counter() - start
        rows.append(Row(f"leg ID, {N} frames, CasADi map JIT-compiled (benchmark only)",
                        time_call(lambda: jit(*args), repeat, warmup=True),
                        f"compiled with -O3 in {compile_time:.1f} s, not counted; "
                        f"max |tau_CasADi - tau_predgait| = {check:.1e} N m"))
    except RuntimeError as exc:
        print(f"JIT unavailable here ({exc})")
    return rows


def whole_process_rows(repeat: int) -> list[Row]:
    """`predgait inverse` against OpenSim's tools, each as whole processes."""
    problem = REPO / "problems" / "inverse_subject01.toml"
    command = [sys.executable, "-m", "predgait", "inverse", str(problem), "--force"]
    with tempfile.TemporaryDirectory() as tmp:
        ours = time_process([*command, "--out", f"{tmp}/out"], repeat)
        bare = time_process([*command, "--out", f"{tmp}/bare", "--no-plots"], repeat)
    does = ("read TRC+MOT+static, joint centres, planar IK, filters, ID of one leg "
            "(5 DOF, 151 frames), STO/CSV/JSON and PNG plots")
    folder, python = gait2354_folder(), opensim_python()
    script = str(Path(__file__).with_name("opensim_subject01.py"))
    rows = []
    for tools, name, label in (
            ("id", "the ID tool", "ID tool on the shipped IK motion (23 DOF, 73 frames)"),
            ("ik,id", "the IK + ID tools", "IK tool then ID tool (23 DOF, 76 frames)")):
        peer = None
        if folder and python:
            peer = time_process([python, script, folder, "--tools", tools, "--repeat", "1"],
                                repeat)
        rows.append(Row(f"predgait inverse subject01 vs OpenSim {name}, whole processes",
                        ours, does, peer,
                        f"Python + import opensim + {label}, writes .sto", unit="s"))
        if tools == "id":
            rows.append(Row("predgait inverse subject01 --no-plots vs OpenSim the ID tool, "
                            "whole processes (goal: <= 1x)", bare,
                            does.replace(" and PNG plots", ", no plots"), peer,
                            f"Python + import opensim + {label}, writes .sto", unit="s"))
    return rows


def breakdown_rows(repeat: int) -> list[Row]:
    """Where the whole `predgait inverse` process goes: imports, compute, files (no peer)."""
    from predgait.dynamics.inverse_options import bundled_options
    from predgait.dynamics.inverse_trial import run_inverse
    from predgait.workflows.inverse_io import write_inverse_outputs

    imports = time_process([sys.executable, "-c", "import predgait.cli.inverse, "
                            "predgait.dynamics.inverse_trial, predgait.workflows.inverse_io"],
                           repeat)
    options = bundled_options("right")
    compute = time_call(lambda: run_inverse(options), repeat)
    result = run_inverse(options)
    with tempfile.TemporaryDirectory() as tmp:
        counter = iter(range(1000))
        files = time_call(lambda: write_inverse_outputs(result, f"{tmp}/o{next(counter)}"),
                          repeat)
    return [Row("  of which: imports (a process importing the inverse command's modules)",
                imports, "Python start + imports", unit="s"),
            Row("  of which: run_inverse on subject01 (read, IK, filters, ID)", compute,
                "in process, 151 frames", unit="s"),
            Row("  of which: writing the result folder (tables, JSON, PNG plots)", files,
                "in process", unit="s")]


def stage_rows() -> None:
    """Print the stages of run_inverse on subject01 (no peer)."""
    from predgait.dynamics.inverse_options import bundled_options
    from predgait.dynamics.inverse_trial import run_inverse

    options = bundled_options("right")
    total = time_call(lambda: run_inverse(options), 3)
    result = run_inverse(options)
    contact = (result.grf[:, 2] > 0)[:, None]
    loads = [LoadHistory("foot", np.where(contact, result.grf, 0.0), result.cop,
                         np.where(contact, result.free_moment, 0.0))]
    dynamics = time_call(lambda: leg_inverse_dynamics(result.model, result.q, result.v,
                                                      result.a, loads), 5)
    print(f"run_inverse on subject01 ({result.time.size} frames): {total.describe()}; "
          f"of which inverse dynamics {dynamics.describe()}")


def rows(repeat: int) -> list[Row]:
    """Every compared row of this benchmark (for run_all.py)."""
    return whole_process_rows(repeat) + breakdown_rows(repeat) + leg_id_rows(repeat)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    repeat = parser.parse_args().repeat
    print(f"min / median of {repeat} repeats, wall (CPU)")
    print_rows(rows(repeat))
    stage_rows()


if __name__ == "__main__":
    main()
