"""Crocoddyl (multi-contact DDP) on the whole-body tracking stance, the CasADi/Ipopt peer.

The same work as the stance case of bench_fullbody_tracking.py (issue 18): subject01,
trial time 0.633-0.9 s (one right stance), its 17 marker frames as nodes (h = 1/60 s), the
35-DOF body of ``problems/fullbody_tracking.toml`` (the same Pinocchio model), the pelvis
a free flyer with no residual actuators, the sole points in contact per node as
:func:`predgait.workflows.fullbody_tracking.tracking_data` decides (plate load and measured
height), tracking the IK angles and the plate forces, with the same Bryson scales
(:class:`~predgait.problems.fullbody_tracking.TrackingWeights`).

The problem: crocoddyl_problem.py (formulation and its differences from the CasADi one).

Accuracy, measured the same way for both solvers (:func:`accuracy`): the Pinocchio RNEA
pelvis rows of RNEA(q, v, a) - sum J^T f with the solved a and f; the gaps (dynamics
defects) left between intervals; joint angles RMS from the measured; foot GRF RMS
against the plates (% body weight); COP shift from the plate COP.

Run:  python benchmarks/crocoddyl_stance.py [--repeat N] [--window stance|cycle]
[--solver ipopt|fatrop] solves the CasADi stance here and Crocoddyl in fresh processes of
CROCODDYL_PYTHON (else this Python; ``pip install predgait[crocoddyl]``, see
pyproject.toml), ``--repeat`` cold runs and warm solves each, and prints the table with
the ratios of the two sides' times (both measured in this run); ``--json``: the
Crocoddyl side of this process only.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

from predgait.problems.fullbody_tracking import POINTS, TrackingData

sys.path.insert(0, str(Path(__file__).resolve().parent))
from crocoddyl_problem import (  # noqa: E402
    build_problem,
    contact_residual,
    crocoddyl_model,
    import_crocoddyl,
    solve,
)
from timing import Timing  # noqa: E402

#: Exit status of this script when crocoddyl cannot be imported.
NOT_INSTALLED = 4


def accuracy(model, pm, data: TrackingData, q, v, a, wrenches) -> dict:
    """The comparison's accuracy figures, the same function for both solvers.

    ``a`` and ``wrenches`` (frame id -> (6,) lab wrench about the frame) on nodes
    0..len(a)-1; angles on all nodes.
    """
    m = len(a)
    residual = contact_residual(pm, q[:m], v[:m], a, wrenches)[:, :6]
    # The same with a from central differences of the solved v: what the discretisation
    # (trapezoidal / symplectic Euler at h) leaves of the equations between the nodes.
    h = float(np.mean(np.diff(data.time)))
    central = (v[2:m + 1] - v[:m - 1]) / (2 * h)
    between = contact_residual(pm, q[1:m], v[1:m], central, wrenches[1:m])[:, :3]
    body_weight = model.total_mass() * model.gravity
    pdata = pm.createData()
    feet = np.zeros((m, 2, 3))
    cops = np.full((m, 2, 2), np.nan)
    for k in range(m):
        pin.framesForwardKinematics(pm, pdata, q[k])
        for j, side in enumerate("rl"):
            mine = {f: w for f, w in wrenches[k].items() if pm.frames[f].name.endswith(side)}
            if not mine:
                continue
            force = sum(w[:3] for w in mine.values())
            plate_z = data.cop[k, j, 2]
            moment = sum(w[3:] + np.cross(pdata.oMf[f].translation - [0, 0, plate_z], w[:3])
                         for f, w in mine.items())
            feet[k, j] = force
            if force[2] > 1.0:  # COP on the plate plane from the moment about (0, 0, z)
                cops[k, j] = (-moment[1] / force[2], moment[0] / force[2])
    grf = feet - data.force[:m]
    shift = {}
    for j, side in enumerate("rl"):
        both = (data.force[:m, j, 2] > 20.0) & np.isfinite(cops[:, j, 0])
        if both.any():
            d = np.linalg.norm(cops[both, j] - data.cop[:m][both, j, :2], axis=1)
            shift[side] = {"rms_m": float(np.sqrt(np.mean(d**2))), "max_m": float(d.max())}
    joints = np.degrees(q[:, 7:] - data.q[:, 7:])
    friction = [max(abs(w[0]), abs(w[1])) - data.friction * w[2]
                for node in wrenches for w in node.values()]
    return {
        "pelvis_residual_max_n": float(np.abs(residual[:, :3]).max()),
        "pelvis_residual_max_n_m": float(np.abs(residual[:, 3:]).max()),
        "pelvis_residual_central_rms_n": float(np.sqrt(np.mean(between**2))),
        "joint_rms_deg": float(np.sqrt(np.mean(joints**2))),
        "grf_rms_percent_bw": {f"{s}_{x}": float(100 * np.sqrt(np.mean(grf[:, j, i] ** 2))
                                                 / body_weight)
                               for j, s in enumerate("rl") for i, x in enumerate("xyz")},
        "cop_shift": shift,
        "friction_excess_max_n": float(max(friction)),
        **contact_motion(pm, data, q[:m], v[:m]),
    }


def contact_motion(pm, data: TrackingData, q, v) -> dict:
    """How far the sole points in contact are from the floor (m) and slip on it (m/s)."""
    pdata = pm.createData()
    ids = [pm.getFrameId(p) for p in POINTS]
    depth, slip = [], []
    for k in range(len(q)):
        pin.forwardKinematics(pm, pdata, q[k], v[k])
        pin.updateFramePlacements(pm, pdata)
        for i in np.flatnonzero(data.contact[k]):
            depth.append(pdata.oMf[ids[i]].translation[2] - data.ground_z)
            vel = pin.getFrameVelocity(pm, pdata, ids[i], pin.LOCAL_WORLD_ALIGNED).linear
            slip.append(np.hypot(vel[0] - data.belt_velocity, vel[1]))
    return {"contact_height_max_m": float(np.abs(depth).max()),
            "contact_slip_max_m_per_s": float(max(slip))}


def point_wrenches(pm, forces) -> list:
    """Per node, frame id -> (6,) wrench of point forces (N, 4, 3) on :data:`POINTS`."""
    ids = [pm.getFrameId(p) for p in POINTS]
    return [{i: np.r_[f, 0.0, 0.0, 0.0] for i, f in zip(ids, node, strict=True) if f.any()}
            for node in forces]


def _window(name: str):
    from bench_fullbody_tracking import STANCE

    return STANCE if name == "stance" else None  # None: the first right gait cycle


def run(repeat: int, window: str = "stance") -> dict:
    """Set up the window, build + solve cold, solve warm ``repeat`` times; the figures."""
    from bench_fullbody_tracking import _setup

    started = time.perf_counter()
    import_crocoddyl()
    import_s = time.perf_counter() - started
    spec, drive, data = _setup(_window(window))
    w0, c0 = time.perf_counter(), time.process_time()
    built = build_problem(drive.model, data, spec.weights)
    build_s = time.perf_counter() - w0
    solved = solve(built, max_iter=spec.max_iter)
    cold = (time.perf_counter() - w0, time.process_time() - c0)
    warm = []
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        solved = solve(built, max_iter=spec.max_iter)
        warm.append((time.perf_counter() - w0, time.process_time() - c0))
    figures = accuracy(drive.model, built.model, built.data, solved.q, solved.v, solved.a,
                       solved.wrenches)
    return {"solver": "crocoddyl FDDP", "nodes": data.nodes,
            "iterations": solved.iterations, "converged": solved.converged,
            "gap_max": solved.gap, "import_s": import_s, "build_s": build_s,
            "cold_wall_s": cold[0], "cold_cpu_s": cold[1],
            "warm_wall_s": [w for w, _ in warm], "warm_cpu_s": [c for _, c in warm],
            **figures}


def run_peer(repeat: int, window: str = "stance") -> dict:
    """This script in ``repeat`` fresh processes (CROCODDYL_PYTHON, else this Python).

    Returns:
        The last run's figures with ``cold`` and ``warm`` :class:`Timing` over all runs,
        or ``{"error": reason}`` ("crocoddyl not installed", a crash, a failure).
    """
    python = os.environ.get("CROCODDYL_PYTHON") or sys.executable
    env = dict(os.environ, OMP_NUM_THREADS="1")
    runs = []
    for _ in range(max(repeat, 1)):
        done = subprocess.run([python, __file__, "--json", "--repeat", str(max(repeat, 1)),
                               "--window", window], capture_output=True, text=True, env=env)
        if done.returncode == NOT_INSTALLED:  # the ImportError's message
            return {"error": done.stderr.strip().splitlines()[-1].split(": ", 1)[-1]}
        if done.returncode < 0:
            return {"error": f"crocoddyl crashed (signal {-done.returncode}) in {python}: "
                             "its 3.2 wheels are built against pin 4.0 (pip install "
                             "predgait[crocoddyl], or set CROCODDYL_PYTHON)"}
        if done.returncode != 0:
            return {"error": (done.stderr.strip().splitlines() or ["failed"])[-1]}
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    out = runs[-1]
    out["cold"] = Timing(tuple(r["cold_wall_s"] for r in runs),
                         tuple(r["cold_cpu_s"] for r in runs))
    out["warm"] = Timing(tuple(w for r in runs for w in r["warm_wall_s"]),
                         tuple(c for r in runs for c in r["warm_cpu_s"]))
    return out


def ratios(ours: Timing, peer: Timing) -> str:
    """Ours over the peer's time, min and median, wall (CPU): e.g. "6.7 / 6.9 x wall"."""
    def ratio(a, b):
        return f"{min(a) / min(b):.1f} / {np.median(a) / np.median(b):.1f}"

    return (f"{ratio(ours.wall, peer.wall)} x wall ({ratio(ours.cpu, peer.cpu)} x CPU)")


def comparison(drive, data: TrackingData, casadi, cold: Timing, warm: Timing,
               repeat: int, window: str = "stance", solver: str = "ipopt",
               convex: int = 0) -> list[str]:
    """The table: CasADi (solved in this run by ``solver``) against Crocoddyl FDDP."""
    peer = run_peer(repeat, window)
    if "error" in peer:
        return [f"Crocoddyl FDDP, {window}: {peer['error']}; no comparison."]
    pm, _, _ = crocoddyl_model(drive.model)
    m = data.nodes - 1
    ours = accuracy(drive.model, pm, data, casadi.q, casadi.v, casadi.a[:m],
                    point_wrenches(pm, casadi.forces[:m]))
    ours |= {"iterations": casadi.iterations, "status": casadi.status, "cold": cold,
             "warm": warm, "gap": "0 (collocation defects are constraints, tol 1e-9)"}
    peer |= {"status": "converged" if peer["converged"] else "NOT converged",
             "gap": f"{peer['gap_max']:.1e} (max |gap| of the shooting intervals)"}

    def fmt(d: dict, key: str) -> str:
        v = d[key]
        if isinstance(v, Timing):
            return v.describe("s")
        if key == "grf_rms_percent_bw":
            return " ".join(f"{k} {x:.2f}" for k, x in v.items())
        if key == "cop_shift":
            return " ".join(f"{k} {x['rms_m'] * 1e3:.0f}/{x['max_m'] * 1e3:.0f} mm"
                            for k, x in v.items())
        return f"{v:.3g}" if isinstance(v, float) else str(v)

    keys = (("cold", "time cold (build + solve), min / median"),
            ("warm", "time warm (solve), min / median"), ("iterations", "iterations"),
            ("status", "status"), ("gap", "dynamics gaps left"),
            ("pelvis_residual_max_n", "RNEA pelvis residual max, N"),
            ("pelvis_residual_max_n_m", "RNEA pelvis residual max, N m"),
            ("pelvis_residual_central_rms_n",
             "same, a by central differences of the solved v, RMS N"),
            ("joint_rms_deg", "joint angles RMS from measured, deg"),
            ("grf_rms_percent_bw", "foot GRF RMS vs plates, % BW"),
            ("cop_shift", "COP shift from plate, RMS/max"),
            ("friction_excess_max_n", "friction pyramid excess max, N"),
            ("contact_height_max_m", "contact point off the floor max, m"),
            ("contact_slip_max_m_per_s", "contact point slip max, m/s"))
    name = {"ipopt": "CasADi/Ipopt", "fatrop": "CasADi/FATROP"}[solver]
    start = (f"; Ipopt's first {convex} iterations on clipped node Hessians "
             "([solver] convex_iterations)" if convex and solver == "ipopt" else "")
    lines = [f"Whole-body tracking, {window} ({data.nodes} nodes, h = "
             f"{np.mean(np.diff(data.time)):.4f} s): {name} vs Crocoddyl FDDP "
             f"(forces over nodes 0..{m - 1}; machine shared, 1 thread each{start})"]
    for key, label in keys:
        lines += [f"  {label}", f"      {name + ':':<15} {fmt(ours, key)}",
                  f"      Crocoddyl FDDP: {fmt(peer, key)}"]
    lines += [f"  {name} / Crocoddyl FDDP, same run, min / median: cold "
              f"{ratios(cold, peer['cold'])}; warm {ratios(warm, peer['warm'])}",
              f"  load average (1, 5, 15 min) at the end: "
              f"{' '.join(f'{x:.1f}' for x in os.getloadavg())}"]
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1, help="cold runs and warm solves")
    parser.add_argument("--json", action="store_true", help="this process only, one JSON line")
    parser.add_argument("--window", choices=("stance", "cycle"), default="stance",
                        help="one stance 0.633-0.9 s (default) or the first right gait cycle")
    parser.add_argument("--solver", choices=("ipopt", "fatrop"), default="ipopt",
                        help="the CasADi side's NLP solver (default ipopt)")
    args = parser.parse_args()
    if args.json:
        try:
            print(json.dumps(run(args.repeat, args.window)))
        except ImportError as exc:
            print(f"crocoddyl_stance: {exc}", file=sys.stderr)
            return NOT_INSTALLED
        return 0
    from bench_fullbody_tracking import _setup, _solve_timings

    spec, drive, data = _setup(_window(args.window))
    cold, warm, solution = _solve_timings(spec, drive, data, args.repeat, args.solver)
    print("\n".join(comparison(drive, data, solution, cold, warm, args.repeat, args.window,
                               args.solver, spec.convex_iterations)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
