"""Crocoddyl (multi-contact DDP) on the whole-body tracking stance, the CasADi/Ipopt peer.

The same work as the stance case of bench_fullbody_tracking.py (issue 18): subject01,
trial time 0.633-0.9 s (one right stance), its 17 marker frames as nodes (h = 1/60 s), the
35-DOF body of ``problems/fullbody_tracking.toml`` (the same Pinocchio model), the pelvis
a free flyer with no residual actuators, the sole points in contact per node as
:func:`predgait.workflows.fullbody_tracking.tracking_data` decides (plate load and measured
height), tracking the IK angles and the plate forces, with the same Bryson scales
(:class:`~predgait.problems.fullbody_tracking.TrackingWeights`).

Formulation (Crocoddyl 3.2; Mastalli et al. 2020, ICRA, "Crocoddyl: an efficient and
versatile framework for multi-contact optimal control"): state x = (q, v), control u the
29 joint torques (``ActuationModelFloatingBase``); on each interval the rigid-contact
forward dynamics (``DifferentialActionModelContactFwdDynamics``: M a + h = S^T u + J^T f
with J a + Jdot v = -Kp e - Kd J v, Baumgarte) integrated by symplectic Euler over h,
solved by FDDP (Mastalli et al. 2020) from the measured motion. Contacts: a foot with one
point in contact holds that point (``ContactModel3D``, friction cone as a barrier cost);
a foot with heel and toe in contact is held flat (``ContactModel6D`` at the mid-sole: two
3D points on one rigid foot make a rank-deficient contact Jacobian, whose squeeze force
along the heel-toe line is undetermined; wrench cone of a 0.1 m wide sole as a barrier).
Costs: state (pelvis position, pelvis and joint angles, velocities), accelerations,
each foot's force and its moment about the plate COP against the plate (6D: the wrench;
3D: the force), and a small torque regularisation.

Differences from the CasADi problem, forced by the formulations: contacts are rigid and
held where the measured foot is (the point is not at the spring's static depth and
cannot slide, so the friction-law cost has no counterpart); a flat foot can carry a
moment about the heel-toe line (the CasADi points cannot); the initial state is the
measured one (DDP fixes x0; the collocation frees it); friction and COP limits are
penalties, not hard constraints; the last node has no control, hence no forces (force
metrics over nodes 0..N-2, for both solvers). The treadmill: the problem is solved in
the frame of the belt (inertial: same dynamics, forces and angles), where stance stands.

Accuracy, measured the same way for both solvers (:func:`accuracy`): the Pinocchio RNEA
pelvis rows of RNEA(q, v, a) - sum J^T f with the solved a and f; the gaps (dynamics
defects) left between intervals; joint angles RMS from the measured; foot GRF RMS
against the plates (% body weight); COP shift from the plate COP.

Run:  python benchmarks/crocoddyl_stance.py [--repeat N] [--window stance|cycle]
solves the CasADi stance here and Crocoddyl in fresh processes of CROCODDYL_PYTHON (else
this Python; ``pip install predgait[crocoddyl]``, see pyproject.toml), ``--repeat``
cold runs and warm solves each, and prints the table; ``--json``: the Crocoddyl side
of this process only.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from predgait.problems.fullbody_tracking import POINTS, TrackingData, TrackingWeights

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import Timing  # noqa: E402

#: Baumgarte gains (Kp 1/s^2, Kd 1/s) of the rigid contacts: Kd = 1/h removes a contact
#: point's velocity in one step of h = 1/60 s, Kp = (Kd/2)^2 critically damped (a point
#: off the floor at touchdown reaches it over a few nodes, 0.75 of the error a node).
GAINS = (900.0, 60.0)
#: Torque scale of the regularisation, N m (Bryson): small against the stance torques.
TORQUE_N_M = 300.0
#: Weight of the friction / wrench cone barriers relative to the force tracking.
CONE_WEIGHT = 1e4
#: Width of the sole's wrench cone, m (the flat foot's COP stays within it).
SOLE_WIDTH_M = 0.1
#: Exit status of this script when crocoddyl cannot be imported.
NOT_INSTALLED = 4


def import_crocoddyl():
    """The crocoddyl module, or an ImportError that says how to install it."""
    try:
        import crocoddyl
    except ImportError as exc:
        raise ImportError("crocoddyl is not installed: pip install predgait[crocoddyl]"
                          ) from exc
    pin_version = tuple(int(x) for x in pin.__version__.split(".")[:2])
    if crocoddyl.__version__.startswith("3.2.") and pin_version >= (4, 1):
        # Seen: its contact dynamics segfault with pin 4.1.0 (built against pin 4.0).
        raise ImportError(f"crocoddyl {crocoddyl.__version__} wheels are built against pin "
                          f"4.0 and crash with pin {pin.__version__}: pip install "
                          "predgait[crocoddyl] (pin < 4.1)")
    return crocoddyl


def belt_frame(data: TrackingData) -> TrackingData:
    """The data seen from the belt (inertial, moving at belt_velocity u along X).

    Pelvis x - u t, body linear velocity - R^T u, its derivative + w x R^T u; plate COP
    x - u t. Forces, angles and the equations of motion are unchanged.
    """
    u = np.array([data.belt_velocity, 0.0, 0.0])
    elapsed = data.time - data.time[0]
    q, v, a, cop = data.q.copy(), data.v.copy(), data.a.copy(), data.cop.copy()
    q[:, 0] -= u[0] * elapsed
    cop[:, :, 0] -= u[0] * elapsed[:, None]
    for k in range(data.nodes):
        local = pin.Quaternion(q[k, 6], *q[k, 3:6]).toRotationMatrix().T @ u
        v[k, :3] -= local
        a[k, :3] += np.cross(v[k, 3:6], local)
    return replace(data, q=q, v=v, a=a, cop=cop, belt_velocity=0.0)


def crocoddyl_model(model) -> tuple[pin.Model, list[int], list[int]]:
    """Copy of the Pinocchio model for Crocoddyl: (model, point frame ids, sole frame ids).

    The free flyer is named ``root_joint`` (``ActuationModelFloatingBase`` finds the base
    by that name; else it actuates 34 of the 35 velocities); a frame ``sole_r`` /
    ``sole_l`` midway between each foot's heel and toe points, oriented as the foot.
    """
    copy = pin.Model(model.pin_model)
    free = [i for i, j in enumerate(copy.joints) if j.shortname() == "JointModelFreeFlyer"]
    copy.names[free[0]] = "root_joint"
    points = [copy.getFrameId(p) for p in POINTS]
    soles = []
    for side, (heel, toe) in zip("rl", (points[:2], points[2:]), strict=True):
        frame = copy.frames[heel]
        middle = 0.5 * (frame.placement.translation + copy.frames[toe].placement.translation)
        soles.append(copy.addFrame(pin.Frame(f"sole_{side}", frame.parentJoint,
                                             pin.SE3(frame.placement.rotation, middle),
                                             pin.FrameType.OP_FRAME)))
    return copy, points, soles


@dataclass(frozen=True)
class Support:
    """One foot's support at one node: its contact frame and what it carries.

    Attributes:
        frame: Pinocchio frame id (a sole point, or the mid-sole when flat).
        flat: True: 6D (the foot held flat), False: 3D (one point held).
        wrench: (6,) target force and moment about the frame (lab axes), N and N m.
    """

    frame: int
    flat: bool
    wrench: np.ndarray


def supports(pm: pin.Model, points, soles, data: TrackingData) -> list[list[Support]]:
    """Per node, the supports of the loaded feet, with the plate's wrench as target."""
    pdata = pm.createData()
    out = []
    for k in range(data.nodes):
        pin.framesForwardKinematics(pm, pdata, data.q[k])
        node = []
        for foot in (0, 1):
            on = data.contact[k, 2 * foot: 2 * foot + 2]
            if not on.any():
                continue
            flat = bool(on.all())
            frame = soles[foot] if flat else points[2 * foot + int(not on[0])]
            arm = data.cop[k, foot] - pdata.oMf[frame].translation
            force = data.force[k, foot]
            moment = np.cross(arm, force) + np.array([0.0, 0.0, data.free_moment[k, foot]])
            node.append(Support(frame, flat, np.concatenate([force, moment])))
        out.append(node)
    return out


def _references(pm, data, plan) -> list[dict]:
    """Per node, where each support frame is held: on the floor at its mean measured x, y.

    The mean over the run of consecutive nodes the frame supports (one footfall). A flat
    foot: heel and toe level (the measured roll and heading at the run's middle node, no
    pitch), as the CasADi problem puts every point in contact on the floor.
    """
    pdata = pm.createData()
    runs: list[tuple[int, list, list]] = []  # (frame, nodes, placements)
    current: dict[int, tuple] = {}
    for k, node in enumerate(plan):
        pin.framesForwardKinematics(pm, pdata, data.q[k])
        current = {s.frame: current.get(s.frame) or (s.frame, [], []) for s in node}
        for frame, run in current.items():
            if not run[1]:
                runs.append(run)
            run[1].append(k)
            run[2].append(pdata.oMf[frame].copy())
    refs: list[dict] = [{} for _ in plan]
    for frame, nodes, poses in runs:
        mean = np.mean([p.translation for p in poses], axis=0)
        roll, _, yaw = pin.rpy.matrixToRpy(poses[len(poses) // 2].rotation)
        held = pin.SE3(pin.rpy.rpyToMatrix(roll, 0.0, yaw),
                       np.array([*mean[:2], data.ground_z]))
        for k in nodes:
            refs[k][frame] = held
    return refs


def contact_residual(pm: pin.Model, q, v, a, wrenches) -> np.ndarray:
    """(N, 35) RNEA(q, v, a) - sum J^T w; ``wrenches[k]`` maps frame id -> (6,) lab wrench."""
    pdata = pm.createData()
    out = np.empty((len(q), pm.nv))
    for k in range(len(q)):
        tau = pin.rnea(pm, pdata, q[k], v[k], a[k]).copy()
        pin.computeJointJacobians(pm, pdata, q[k])
        pin.updateFramePlacements(pm, pdata)
        for frame, wrench in wrenches[k].items():
            jac = pin.getFrameJacobian(pm, pdata, frame, pin.LOCAL_WORLD_ALIGNED)
            tau -= jac.T @ wrench
        out[k] = tau
    return out


@dataclass(frozen=True)
class Built:
    """A shooting problem, its warm start (the measured motion) and its data."""

    problem: object
    xs: list
    us: list
    data: TrackingData
    model: pin.Model
    plan: list


def build_problem(model, data: TrackingData, weights: TrackingWeights) -> Built:
    """The shooting problem of the module docstring on ``data`` (lab frame)."""
    croc = import_crocoddyl()
    data = belt_frame(data)
    n, h = data.nodes, float(np.mean(np.diff(data.time)))
    pm, points, soles = crocoddyl_model(model)
    plan = supports(pm, points, soles, data)
    refs = _references(pm, data, plan)
    body_weight = model.total_mass() * model.gravity
    state = croc.StateMultibody(pm)
    actuation = croc.ActuationModelFloatingBase(state)
    nu, w = actuation.nu, weights
    force_w = 1.0 / (w.force_bw * body_weight) ** 2
    moment_w = 1.0 / (w.moment_bw_m * body_weight) ** 2
    state_w = np.concatenate([np.full(3, 1 / w.position_m**2),
                              np.full(32, 1 / np.radians(w.angle_deg) ** 2),
                              np.full(35, 1 / w.velocity_rad_s**2)])
    box = np.array([np.linalg.norm(pm.frames[points[1]].placement.translation
                                   - pm.frames[points[0]].placement.translation),
                    SOLE_WIDTH_M])
    frame, gains = pin.LOCAL_WORLD_ALIGNED, np.array(GAINS)
    models = []
    for k in range(n):
        running = k < n - 1
        contacts, costs = croc.ContactModelMultiple(state, nu), croc.CostModelSum(state, nu)
        xref = np.concatenate([data.q[k], data.v[k]])
        costs.addCost("state", croc.CostModelResidual(
            state, croc.ActivationModelWeightedQuad(state_w),
            croc.ResidualModelState(state, xref, nu)), 1.0 / n)
        if running:
            costs.addCost("acceleration", croc.CostModelResidual(
                state, croc.ResidualModelJointAcceleration(state, data.a[k], nu)),
                1.0 / (n * w.acceleration_rad_s2**2))
            costs.addCost("torque", croc.CostModelResidual(
                state, croc.ResidualModelControl(state, nu)), 1.0 / (n * TORQUE_N_M**2))
        for s in plan[k]:
            name, ref = pm.frames[s.frame].name, refs[k][s.frame]
            if s.flat:
                contact = croc.ContactModel6D(state, s.frame, ref, frame, nu, gains)
                rotation = pin.rpy.rpyToMatrix(0, 0, pin.rpy.matrixToRpy(ref.rotation)[2])
                cone = croc.ResidualModelContactWrenchCone(
                    state, s.frame, croc.WrenchCone(rotation, data.friction, box, 4, False),
                    nu)
                target = croc.ResidualModelContactForce(state, s.frame, pin.Force(s.wrench),
                                                        6, nu)
                activation = croc.ActivationModelWeightedQuad(
                    np.array([force_w] * 3 + [moment_w] * 3))
            else:
                contact = croc.ContactModel3D(state, s.frame, ref.translation, frame, nu,
                                              gains)
                cone = croc.ResidualModelContactFrictionCone(
                    state, s.frame, croc.FrictionCone(np.eye(3), data.friction, 4, False), nu)
                target = croc.ResidualModelContactForce(
                    state, s.frame, pin.Force(s.wrench[:3], np.zeros(3)), 3, nu)
                activation = croc.ActivationModelWeightedQuad(np.full(3, force_w))
            contacts.addContact(name, contact)
            if running:
                costs.addCost(f"{name}_force", croc.CostModelResidual(
                    state, activation, target), 1.0 / n)
                bounds = croc.ActivationBounds(cone.reference.lb, cone.reference.ub)
                costs.addCost(f"{name}_cone", croc.CostModelResidual(
                    state, croc.ActivationModelQuadraticBarrier(bounds), cone),
                    CONE_WEIGHT * force_w / n)
        dynamics = croc.DifferentialActionModelContactFwdDynamics(
            state, actuation, contacts, costs, 0.0, True)
        models.append(croc.IntegratedActionModelEuler(dynamics, h if running else 0.0))
    problem = croc.ShootingProblem(np.concatenate([data.q[0], data.v[0]]), models[:-1],
                                   models[-1])
    problem.nthreads = 1  # as Ipopt: one core (the machine's 2 are shared)
    xs = [np.concatenate([q, v]) for q, v in zip(data.q, data.v, strict=True)]
    tau = contact_residual(pm, data.q, data.v, data.a,
                           [{s.frame: s.wrench if s.flat else np.r_[s.wrench[:3], 0, 0, 0]
                             for s in node} for node in plan])
    return Built(problem, xs, [t[6:] for t in tau[:-1]], data, pm, plan)


@dataclass(frozen=True)
class Solved:
    """A Crocoddyl solve (belt frame): motion, per-node lab wrenches, solver figures."""

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    wrenches: list
    iterations: int
    converged: bool
    gap: float
    seconds: float


def solve(built: Built, *, max_iter: int = 200) -> Solved:
    """FDDP from the measured motion; accelerations and contact wrenches of nodes 0..N-2."""
    croc = import_crocoddyl()
    ddp = croc.SolverFDDP(built.problem)
    start = time.perf_counter()
    converged = ddp.solve(built.xs, built.us, max_iter, False)
    seconds = time.perf_counter() - start
    xs = np.array(ddp.xs)
    a, wrenches = [], []
    for run in built.problem.runningDatas:
        diff = run.differential
        a.append(np.array(diff.xout))
        wrenches.append({c.frame: np.array(c.f.vector) for c in
                         diff.multibody.contacts.contacts.todict().values()})
    gap = max(float(np.abs(f).max()) for f in ddp.fs)
    return Solved(xs[:, :36], xs[:, 36:], np.array(a), wrenches, int(ddp.iter),
                  bool(converged), gap, seconds)


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


def comparison(drive, data: TrackingData, casadi, cold: Timing, warm: Timing,
               repeat: int, window: str = "stance") -> list[str]:
    """The table: CasADi/Ipopt (solved in this run) against Crocoddyl FDDP."""
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
    lines = [f"Whole-body tracking, {window} ({data.nodes} nodes, h = "
             f"{np.mean(np.diff(data.time)):.4f} s): CasADi/Ipopt vs Crocoddyl FDDP "
             f"(forces over nodes 0..{m - 1}; machine shared, 1 thread each)"]
    for key, label in keys:
        lines += [f"  {label}", f"      CasADi/Ipopt:   {fmt(ours, key)}",
                  f"      Crocoddyl FDDP: {fmt(peer, key)}"]
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1, help="cold runs and warm solves")
    parser.add_argument("--json", action="store_true", help="this process only, one JSON line")
    parser.add_argument("--window", choices=("stance", "cycle"), default="stance",
                        help="one stance 0.633-0.9 s (default) or the first right gait cycle")
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
    cold, warm, solution = _solve_timings(spec, drive, data, args.repeat)
    print("\n".join(comparison(drive, data, solution, cold, warm, args.repeat, args.window)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
