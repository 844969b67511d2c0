"""Inverse dynamics speed: 1000 frames of the leg, OpenSim on the same leg, the pipeline.

Run: python benchmarks/bench_inverse.py          (add `pip install opensim` for the
OpenSim rows; without it they are skipped with a note)

1. 1000 random frames of the shipped leg: bare Pinocchio RNEA; predgait's
   ``leg_inverse_dynamics`` (RNEA with the ground reaction, hip-load solve, joint forces);
   the same computation as a CasADi function of the ADAM expressions, mapped over frames
   (serial, 2 threads, JIT).
2. OpenSim 4.6's InverseDynamicsSolver on the same planar foot-shank-thigh, built with the
   OpenSim API from the URDF's masses, centres of mass and inertias (PlanarJoint + two
   PinJoints, Y-up), called per frame from Python: the figure issue 4 asks us to compare
   with. Its generalised forces are printed against Pinocchio's (same model, same states).
3. The bundled subject01 trial (151 frames, 60 Hz) and walking5.c3d (250 Hz) through
   ``run_inverse``, stage by stage, and the writing of the result folder.

Timings are the best of several runs (``time.perf_counter``), in one process, 2 cores.
"""

import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import casadi as cs
import numpy as np
import pinocchio as pin

from predgait.data import fill_gaps, read_trc
from predgait.dynamics.external import Load
from predgait.dynamics.inverse import leg_inverse_dynamics
from predgait.dynamics.inverse_trial import (
    InverseOptions,
    _needed_markers,
    bundled_options,
    foot_pitch,
    joint_points,
    read_trial,
    run_inverse,
)
from predgait.kinematics.planar_ik import solve_ik
from predgait.models.loading import load_model
from predgait.models.symbolic import symbolic_model
from predgait.workflows.inverse_io import write_inverse_outputs

N = 1000
WALKING5 = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_walking5_c3d" / \
    "walking5.c3d"
#: Lab (X forward, Y left, Z up) to OpenSim ground (X forward, Y up, Z right).
LAB_TO_OSIM = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
#: Runs OpenSim in a process of its own: OpenSim's wheel bundles a CasADi library that
#: clashes with the casadi wheel once both are loaded.
OPENSIM_SCRIPT = Path(__file__).resolve().with_name("opensim_leg.py")


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


def opensim_rows(model, q, qd, qdd, reference_tau):
    """Time OpenSim's InverseDynamicsSolver per frame; None if opensim is not installed."""
    if importlib.util.find_spec("opensim") is None:
        print("OpenSim: not installed here ('pip install opensim' adds the comparison)")
        return None
    pm = model.pin_model
    inertias = [pm.inertias[j] for j in range(1, pm.njoints)]
    segments = {
        "mass": [i.mass for i in inertias], "inertia": [i.inertia[1, 1] for i in inertias],
        "com": [LAB_TO_OSIM @ i.lever for i in inertias],
        "offset": [LAB_TO_OSIM @ pm.jointPlacements[j].translation for j in range(1, 4)],
    }
    with tempfile.TemporaryDirectory() as tmp:
        npz = Path(tmp) / "states.npz"
        np.savez(npz, q=q, qd=qd, qdd=qdd, gravity=model.gravity, **segments)
        child = subprocess.run([sys.executable, str(OPENSIM_SCRIPT), str(npz)],
                               capture_output=True, text=True)
        if child.returncode != 0:
            print(f"OpenSim: failed ({child.stderr.strip().splitlines()[-1]})")
            return None
        out = np.load(npz)
        seconds, tau, version = float(out["seconds"]), out["tau"], str(out["version"])
    print(f"{N} frames, OpenSim {version} InverseDynamicsSolver, per frame from Python: "
          f"{seconds * 1e3:7.2f} ms  (same leg, same states: max |tau_OpenSim - tau_Pinocchio| "
          f"= {np.abs(tau - reference_tau).max():.1e} N m)")
    return seconds


def per_frame_rows(model):
    pm = model.pin_model
    data = pm.createData()
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-0.5, 0.5, (N, model.nq)) for _ in range(3))
    force = np.column_stack([rng.uniform(-50, 50, N), np.zeros(N), rng.uniform(300, 800, N)])
    cop = np.column_stack([q[:, 0] + 0.05, np.zeros(N), np.zeros(N)])
    loads = [[Load("foot", force[k], point=cop[k])] for k in range(N)]

    def bare():
        return np.array([pin.rnea(pm, data, q[k], qd[k], qdd[k]) for k in range(N)])

    rows = {"bare Pinocchio RNEA loop (no loads)": best_of(bare)}
    opensim = opensim_rows(model, q, qd, qdd, bare())
    rows["predgait leg_inverse_dynamics (GRF, hip solve, joint forces)"] = best_of(
        lambda: leg_inverse_dynamics(model, q, qd, qdd, loads))
    f = casadi_inverse(model)
    args = (q.T, qd.T, qdd.T, force.T, cop.T)
    serial, threaded = f.map(N), f.map(N, "thread", 2)
    rows["CasADi map of the ADAM expression, serial"] = best_of(lambda: serial(*args))
    rows["CasADi map, 2 threads"] = best_of(lambda: threaded(*args))
    try:
        start = time.perf_counter()
        jit = cs.Function("inverse_dynamics_jit", f.sx_in(), f.call(f.sx_in()),
                          {"jit": True, "compiler": "shell", "jit_options": {"flags": ["-O3"]}})
        jit_map = jit.map(N)
        jit_map(*args)
        compile_time = time.perf_counter() - start
        rows[f"CasADi map, JIT with the C compiler ({compile_time:.2f} s to compile)"] = \
            best_of(lambda: jit_map(*args))
    except RuntimeError as exc:
        print(f"JIT unavailable here ({exc})")
    tau_cs = np.array(serial(*args)[0]).T
    tau_pin = leg_inverse_dynamics(model, q, qd, qdd, loads).tau[:, 3:]
    for label, seconds in rows.items():
        ratio = f"  ({opensim / seconds:5.2f}x OpenSim)" if opensim else ""
        print(f"{N} frames, {label:64s} {seconds * 1e3:7.2f} ms{ratio}")
    print(f"  max |tau_CasADi - tau_Pinocchio| = {np.abs(tau_cs - tau_pin).max():.1e} N m")


def stage_rows(options, label):
    """Time run_inverse and its main stages on one trial."""
    total = best_of(lambda: run_inverse(options), repeat=3)
    result = run_inverse(options)
    trial, _ = read_trial(options)
    markers = fill_gaps(trial.markers, names=_needed_markers(options.points),
                        max_gap_frames=options.max_gap_frames, edges="trim")
    read = best_of(lambda: (read_trial(options),
                            read_trc(options.static) if options.static else None), repeat=3)
    static = read_trc(options.static) if options.static else None
    points = joint_points(markers, options, static)
    centres = best_of(lambda: joint_points(markers, options, static), repeat=3)
    centre_points = {f"{k}_center": points[k] for k in ("hip", "knee", "ankle")}
    ik = best_of(lambda: solve_ik(result.model, centre_points, foot_pitch(points)), repeat=3)
    loads = [[Load("foot", result.grf[k], point=result.cop[k], moment=result.free_moment[k])]
             if result.grf[k, 2] > 0 else [] for k in range(result.time.size)]
    dynamics = best_of(lambda: leg_inverse_dynamics(result.model, result.q, result.qd,
                                                    result.qdd, loads), repeat=3)
    n = result.time.size
    print(f"{label}: run_inverse {total * 1e3:7.1f} ms for {n} frames "
          f"({total / n * 1e6:.0f} us/frame): read files {read * 1e3:.1f} ms, joint centres "
          f"{centres * 1e3:.1f} ms, IK {ik * 1e3:.1f} ms, inverse dynamics "
          f"{dynamics * 1e3:.1f} ms, the rest {(total - read - centres - ik - dynamics) * 1e3:.1f}"
          " ms")
    return result


def main():
    per_frame_rows(load_model("leg"))
    result = stage_rows(bundled_options("right"), "subject01 (TRC + MOT + static TRC)")
    if WALKING5.is_file():
        stage_rows(InverseOptions(markers=WALKING5, mass=72.0, points={
            "hip": "RHJC", "knee": "RKJC", "ankle": "RAJC", "heel": "RCAL", "toe": "RMT2"}),
            "walking5 (C3D, markers 250 Hz, plates 2000 Hz)")
    with tempfile.TemporaryDirectory() as tmp:
        counter = iter(range(100))
        writing = best_of(lambda: write_inverse_outputs(result, f"{tmp}/o{next(counter)}"),
                          repeat=2)
    print(f"writing the result folder (2 STO, 2 CSV, JSON, 4 PNG plots): {writing * 1e3:.0f} ms")


if __name__ == "__main__":
    main()
