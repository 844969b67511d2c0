"""The whole-body tracking problem in Crocoddyl: the peer of the CasADi/Ipopt problem.

Used by crocoddyl_stance.py (issue 18): the same nodes, model, contact phases and Bryson
scales (:class:`~predgait.problems.fullbody_tracking.TrackingWeights`) as
:mod:`predgait.problems.fullbody_tracking`. Crocoddyl is imported lazily
(:func:`import_crocoddyl`): ``pip install predgait[crocoddyl]``.

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
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin

from predgait.problems.fullbody_tracking import POINTS, TrackingData, TrackingWeights

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
