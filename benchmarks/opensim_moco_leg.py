"""OpenSim Moco on predgait's planar leg: knee fit and torque correction (bench_optimisation.py).

Usage: OPENSIM_PYTHON benchmarks/opensim_moco_leg.py PROBLEM.npz

The peers of ``predgait solve problems/knee_fit.toml`` and
``problems/torque_correction.toml`` (problems/fitting.py), stated with OpenSim's components
and solved by Moco's direct collocation (MocoCasADiSolver, Ipopt, Hermite-Simpson, one
thread):

* the leg of opensim_leg.py (PlanarJoint foot, PinJoints at ankle and knee, Y up) from the
  same segments as the URDF; the measured hip load by a PrescribedForce on the thigh at the
  hip centre (force in the ground frame, moment about Z; GCV splines of the samples);
* the foot: predgait prescribes its three coordinates. Moco turns prescribed coordinates
  (``Coordinate.setPrescribedFunction``, as ``ModOpPrescribeCoordinateValues`` does) into
  kinematic constraints with Lagrange multipliers and velocity corrections; on this leg
  Ipopt then lives in its restoration phase (``foot = "prescribed"``, kept to show it).
  The default ``foot = "tracked"`` leaves the foot free, drives each of its coordinates by
  a residual CoordinateActuator (as MocoTrack users do for a pelvis) and tracks it with a
  weight ``base_weight`` times that of the joint angles, so 5 DOF (10 states) against
  predgait's 2 free DOF (4 states);
* ``mode = "knee_fit"``: the measured ankle and knee moments by CoordinateActuators whose
  controls a PrescribedController gives; a SpringGeneralizedForce on each joint of
  ``joints`` (the knee; knee and ankle for the shooting fit's peer: stiffness k, rest length
  theta0, viscosity c, predgait.dynamics.passive's linear element in OpenSim's sign), their
  properties MocoParameters within predgait's bounds (read when the force is computed:
  ``parameters_require_initsystem`` off); objective: the tracking of the angles
  (MocoStateTrackingGoal);
* ``mode = "torque_correction"``: MocoTrack of the measured coordinates with the ankle and
  knee CoordinateActuators optimised, a MocoControlTrackingGoal keeping their controls near
  the measured moments (predgait's effort term; Moco has no term on the rate of a control,
  so predgait's smoothness term has no counterpart);
* initial ankle and knee state fixed to the measured one (as predgait); guess: the
  measured motion and, for the controls, OpenSim's inverse dynamics along it (predgait
  starts from the measured motion too);
* solver settings from the file: Hessian (Moco's exact one is finite differences, ~40 s
  per Ipopt iteration at 10 intervals here, so limited-memory), tolerance, sparsity
  detection, explicit or implicit multibody dynamics, scaling of the variables by bounds.

The study is built and solved ``repeat`` times in this process (the first is cold); writes
back wall and CPU seconds of each (build + solve), Ipopt's status and iteration count, the
fitted parameters, the RMS angle errors (deg), the numbers of mesh points, states and
controls, and the OpenSim version. Ipopt's iteration lines go to stdout, so a caller that
stops the run can tell how far it got. Only numpy and opensim are imported here (OpenSim's
bundled CasADi clashes with the casadi wheel).
"""

import sys
import time

import numpy as np
import opensim as osim
from opensim_leg import ORDER, SIGN, build_leg

osim.Logger.removeFileSink()   # no opensim.log in the working folder
osim.Logger.setLevelString("error")

#: OpenSim names of predgait's (base_x, base_z, base_pitch, ankle, knee), in OpenSim order.
NAMES = ("base_rz", "base_tx", "base_ty", "ankle", "knee")
FOOT_FORCE, JOINT_TORQUE = 100.0, 100.0   # optimal forces (N, N m per unit control)


def path(name):
    joint = "base" if name.startswith("base") else name
    return f"/jointset/{joint}/{name}"


def gcv(t, values, degree):
    """A GCV spline of ``degree`` through the samples (no smoothing)."""
    function = osim.GCVSpline()
    function.setDegree(degree)
    for a, b in zip(t, values, strict=True):
        function.addPoint(float(a), float(b))
    return function


def to_osim(columns):
    """(n, 5) predgait coordinates -> (n, 5) OpenSim coordinates in NAMES order."""
    return np.asarray(columns)[:, ORDER] * SIGN


def table(t, labels, columns):
    out = osim.TimeSeriesTable()
    out.setColumnLabels(list(labels))
    for k, tk in enumerate(t):
        out.appendRow(float(tk), osim.RowVector([float(c[k]) for c in columns]))
    out.addTableMetaDataString("inDegrees", "no")
    return out


def actuator(model, name, force, bound):
    added = osim.CoordinateActuator(name)
    added.setName(f"{name}_actuator")
    added.setOptimalForce(force)
    added.setMinControl(-bound)
    added.setMaxControl(bound)
    model.addForce(added)
    return added


def build_model(data):
    """The leg, its hip load, foot and joint actuators, knee spring (knee fit)."""
    model, _ = build_leg(data, float(data["gravity"]))
    joint = model.getJointSet().get("base")
    for i in range(3):
        joint.upd_coordinates(i).setName(NAMES[i])
    for name in ("ankle", "knee"):
        model.getJointSet().get(name).upd_coordinates(0).setName(name)
    t = data["t_dense"]
    base = to_osim(np.column_stack([data["qb_dense"], np.zeros((len(t), 2))]))
    if str(data["foot"]) == "prescribed":
        for i in range(3):
            coordinate = joint.upd_coordinates(i)
            coordinate.setPrescribedFunction(gcv(t, base[:, i], 5))
            coordinate.setDefaultIsPrescribed(True)
    else:
        for name in NAMES[:3]:
            actuator(model, name, FOOT_FORCE, 50.0)
    hip = osim.PrescribedForce("hip_load", model.getBodySet().get("thigh"))
    hip.setPointIsInGlobalFrame(False)
    hip.setForceIsInGlobalFrame(True)
    point = data["hip_point"]
    hip.setPointFunctions(*(osim.Constant(float(v)) for v in point))
    load = data["hip_dense"]   # lab Fx, Fz (N), My (N m) -> OpenSim Fx, Fy, Mz = -My
    hip.setForceFunctions(gcv(t, load[:, 0], 3), gcv(t, load[:, 1], 3), osim.Constant(0.0))
    hip.setTorqueFunctions(osim.Constant(0.0), osim.Constant(0.0), gcv(t, -load[:, 2], 3))
    model.addForce(hip)
    tau = to_osim(np.column_stack([np.zeros((len(t), 3)), data["tau_dense"]]))
    controller = osim.PrescribedController()
    for i, name in ((3, "ankle"), (4, "knee")):
        added = actuator(model, name, JOINT_TORQUE, 20.0)
        if str(data["mode"]) == "knee_fit":
            controller.addActuator(added)
            controller.prescribeControlForActuator(f"{name}_actuator",
                                                   gcv(t, tau[:, i] / JOINT_TORQUE, 3))
    if str(data["mode"]) == "knee_fit":
        model.addController(controller)
        for joint in data["joints"]:
            spring = osim.SpringGeneralizedForce(str(joint))
            spring.setName(f"{joint}_spring")
            spring.setStiffness(float(data["p0"][0]))
            spring.setViscosity(float(data["p0"][1]))
            spring.setRestLength(float(data["p0"][2]))
            model.addForce(spring)
    model.finalizeConnections()
    return model


def inverse_dynamics(model, data):
    """(nodes, 5) generalised forces (OpenSim coordinates) that the model's own forces
    (gravity, hip load, prescribed moments) leave to the actuators along the measured
    motion: the guess of the controls (the foot's come from the ground in the trial)."""
    state = model.initSystem()
    solver = osim.InverseDynamicsSolver(model)
    q, u, udot = (to_osim(data[k]) for k in ("q_nodes", "qd_nodes", "qdd_nodes"))
    out = np.empty(q.shape)
    for k, tk in enumerate(data["t_nodes"]):
        state.setTime(float(tk))
        state.setQ(osim.Vector.createFromMat(q[k]))
        state.setU(osim.Vector.createFromMat(u[k]))
        model.realizeVelocity(state)
        tau = solver.solve(state, osim.Vector.createFromMat(udot[k]))
        out[k] = [tau.get(i) for i in range(5)]
    return out


def build_study(data):
    """MocoTrack's study of the measured coordinates, with the mode's goals and parameters."""
    model = build_model(data)
    t_nodes = data["t_nodes"]
    q_ref = to_osim(data["q_nodes"])
    tracked = NAMES[3:] if str(data["foot"]) == "prescribed" else NAMES
    track = osim.MocoTrack()
    track.setName(str(data["mode"]))
    track.setModel(osim.ModelProcessor(model))
    track.setStatesReference(osim.TableProcessor(table(
        t_nodes, [f"{path(n)}/value" for n in tracked],
        [q_ref[:, NAMES.index(n)] for n in tracked])))
    weights = osim.MocoWeightSet()
    for name in tracked:
        weight = float(data["base_weight"]) if name.startswith("base") else 1.0
        weights.cloneAndAppend(osim.MocoWeight(f"{path(name)}/value", weight))
    track.set_states_weight_set(weights)
    track.set_states_global_tracking_weight(float(data["tracking_weight"]))
    track.set_control_effort_weight(float(data["effort_weight"]))
    track.set_apply_tracked_states_to_guess(False)
    track.set_initial_time(float(t_nodes[0]))
    track.set_final_time(float(t_nodes[-1]))
    track.set_mesh_interval((t_nodes[-1] - t_nodes[0]) / int(data["intervals"]))
    study = track.initialize()
    problem = study.updProblem()
    x0 = to_osim(np.column_stack([np.zeros((1, 3)), data["x0"][None, :2]]))[0]
    v0 = to_osim(np.column_stack([np.zeros((1, 3)), data["x0"][None, 2:]]))[0]
    for i in (3, 4):
        problem.setStateInfo(f"{path(NAMES[i])}/value", [-3.0, 3.0], float(x0[i]))
        problem.setStateInfo(f"{path(NAMES[i])}/speed", [-50.0, 50.0], float(v0[i]))
    measured = to_osim(np.column_stack([np.zeros((len(t_nodes), 3)), data["tau_nodes"]]))
    if str(data["mode"]) == "knee_fit":
        limit = float(data["theta0_max"])
        for joint in data["joints"]:
            for name, prop, lo, hi in (("k", "stiffness", 0.0, data["k_max"]),
                                       ("c", "viscosity", 0.0, data["c_max"]),
                                       ("theta0", "rest_length", -limit, limit)):
                problem.addParameter(osim.MocoParameter(
                    f"{joint}_{name}", f"/forceset/{joint}_spring", prop,
                    osim.MocoBounds(float(lo), float(hi))))
    else:
        goal = osim.MocoControlTrackingGoal("torque_change", float(data["change_weight"]))
        goal.setReference(osim.TableProcessor(table(
            t_nodes, [f"/forceset/{n}_actuator" for n in NAMES[3:]],
            [measured[:, i] / JOINT_TORQUE for i in (3, 4)])))
        problem.addGoal(goal)
        effort = osim.MocoControlGoal.safeDownCast(problem.updGoal("control_effort"))
        for name in NAMES[3:]:   # the change, not the whole moment, is the effort here
            effort.setWeightForControl(f"/forceset/{name}_actuator", 0.0)
    solver = study.initCasADiSolver()   # a solver of this copy of the study
    solver.set_num_mesh_intervals(int(data["intervals"]))
    solver.set_transcription_scheme("hermite-simpson")
    solver.set_multibody_dynamics_mode(str(data["dynamics"]))
    solver.set_scale_variables_using_bounds(bool(data["scale"]))
    solver.set_optim_convergence_tolerance(float(data["tol"]))
    solver.set_optim_constraint_tolerance(float(data["tol"]))
    solver.set_optim_hessian_approximation(str(data["hessian"]))
    solver.set_optim_sparsity_detection(str(data["sparsity"]))
    solver.set_parameters_require_initsystem(False)   # the spring reads its properties
    solver.set_parallel(0)
    solver.set_verbosity(2)   # Ipopt prints its iterations only from verbosity 2
    solver.set_optim_ipopt_print_level(int(data["print_level"]))
    solver.set_optim_max_iterations(int(data["max_iter"]))
    guess = solver.createGuess()
    qd_ref = to_osim(data["qd_nodes"])
    state_names = [f"{path(n)}/{kind}" for n in NAMES for kind in ("value", "speed")]
    state_columns = [c[:, i] for i in range(5) for c in (q_ref, qd_ref)]
    guess.insertStatesTrajectory(table(t_nodes, state_names, state_columns), True)
    optimised = [] if str(data["foot"]) == "prescribed" else [0, 1, 2]
    if str(data["mode"]) == "torque_correction":
        optimised += [3, 4]
    if optimised:
        tau_ref = inverse_dynamics(osim.Model(model), data)
        scale = np.array([FOOT_FORCE] * 3 + [JOINT_TORQUE] * 2)
        guess.insertControlsTrajectory(table(
            t_nodes, [f"/forceset/{NAMES[i]}_actuator" for i in optimised],
            [tau_ref[:, i] / scale[i] for i in optimised]), True)
    solver.setGuess(guess)
    return study


def rms_deg(solution, data):
    """RMS angle errors (ankle, knee) of the solution at the reference times, deg."""
    times = solution.getTimeMat()
    out = []
    for i in (3, 4):
        q = solution.getStateMat(f"{path(NAMES[i])}/value")
        ref = np.interp(times, data["t_nodes"], to_osim(data["q_nodes"])[:, i])
        out.append(float(np.degrees(np.sqrt(np.mean((q - ref) ** 2)))))
    return out


def main(file):
    data = dict(np.load(file))
    wall, cpu = [], []
    for _ in range(int(data["repeat"])):
        w0, c0 = time.perf_counter(), time.process_time()
        study = build_study(data)
        solution = study.solve()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    success = bool(solution.success())
    solution.unseal()
    parameters = (solution.getParametersMat() if str(data["mode"]) == "knee_fit"
                  else np.zeros(0))
    np.savez(file, version=osim.__version__, wall=wall, cpu=cpu, success=success,
             status=solution.getStatus(), iterations=solution.getNumIterations(),
             parameters=parameters, rms_deg=rms_deg(solution, data),
             points=solution.getNumTimes(), states=len(solution.getStateNames()),
             controls=len(solution.getControlNames()))


if __name__ == "__main__":
    main(sys.argv[1])
