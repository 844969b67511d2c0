"""OpenSim Moco on predgait's planar leg: the knee spring-damper fit (peer of bench_optimisation.py).

Usage: OPENSIM_PYTHON benchmarks/opensim_moco_leg.py PROBLEM.npz

The same problem as ``predgait solve problems/knee_fit.toml`` (problems/fitting.py,
``fit_knee``), stated with OpenSim's components and solved by Moco's direct collocation
(MocoCasADiSolver, Ipopt, exact Hessian as predgait):

* the leg of opensim_leg.py (PlanarJoint foot, PinJoints at ankle and knee, Y up);
* the foot's three coordinates prescribed from the measured motion (quintic GCV splines
  of the samples in the file, as ``ModOpPrescribeCoordinateValues`` does);
* the measured ankle and knee moments applied by CoordinateActuators whose controls a
  PrescribedController gives (cubic splines), the measured hip load by a PrescribedForce
  on the thigh at the hip centre (force in the ground frame, moment about Z);
* a SpringGeneralizedForce on the knee (stiffness k, rest length theta0, viscosity c: the
  linear spring-damper of predgait.dynamics.passive in OpenSim's knee sign), its three
  properties the MocoParameters, with predgait's bounds;
* objective: MocoStateTrackingGoal on the ankle and knee angles (the mean squared error
  of predgait's objective up to a constant factor); initial ankle and knee state fixed to
  the measured one; fixed time window; ``intervals`` mesh intervals, ``scheme``
  (hermite-simpson or trapezoidal).

The study (model built and initialised inside, as a first solve in a process) is solved
``repeat`` times; writes back wall and CPU seconds, the fitted k, c, theta0, Ipopt's
iteration count, the numbers of mesh points, states and coordinates, and the OpenSim
version. Only numpy and opensim are imported here (OpenSim's bundled CasADi clashes with
the casadi wheel).
"""

import sys
import time

import numpy as np
import opensim as osim
from opensim_leg import SIGN, build_leg

osim.Logger.removeFileSink()   # no opensim.log in the working folder
osim.Logger.setLevelString("error")

BASE = ("base_coord_0", "base_coord_1", "base_coord_2")   # PlanarJoint rz, tx, ty


def gcv(t, values, degree):
    """A GCV spline of ``degree`` through the samples (no smoothing)."""
    function = osim.GCVSpline()
    function.setDegree(degree)
    for a, b in zip(t, values, strict=True):
        function.addPoint(float(a), float(b))
    return function


def build_problem(data):
    """The leg with its prescribed foot, measured loads and knee spring; its study."""
    model, _ = build_leg(data, float(data["gravity"]))
    t = data["t_dense"]
    # predgait (base_x, base_z, base_pitch) -> OpenSim (rz, tx, ty): ORDER [2, 0, 1].
    base = data["qb_dense"]
    osim_base = {"base_coord_0": SIGN[0] * base[:, 2], "base_coord_1": SIGN[1] * base[:, 0],
                 "base_coord_2": SIGN[2] * base[:, 1]}
    joint = model.getJointSet().get("base")
    for i, name in enumerate(BASE):
        coordinate = joint.get_coordinates(i)
        coordinate.setName(name)
        coordinate.setPrescribedFunction(gcv(t, osim_base[name], 5))
        coordinate.setDefaultIsPrescribed(True)
    controller = osim.PrescribedController()
    for i, name in ((3, "ankle"), (4, "knee")):
        coordinate = model.getJointSet().get(name).get_coordinates(0)
        coordinate.setName(name)
        actuator = osim.CoordinateActuator(name)
        actuator.setName(f"{name}_moment")
        actuator.setOptimalForce(1.0)
        actuator.setMinControl(-1e4)
        actuator.setMaxControl(1e4)
        model.addForce(actuator)
        controller.addActuator(actuator)
        controller.prescribeControlForActuator(
            f"{name}_moment", gcv(t, SIGN[i] * data["tau_dense"][:, i - 3], 3))
    model.addController(controller)
    hip = osim.PrescribedForce("hip_load", model.getBodySet().get("thigh"))
    hip.setPointIsInGlobalFrame(False)
    hip.setForceIsInGlobalFrame(True)
    point = data["hip_point"]
    hip.setPointFunctions(osim.Constant(point[0]), osim.Constant(point[1]),
                          osim.Constant(point[2]))
    load = data["hip_dense"]   # lab Fx, Fz (N), My (N m) -> OpenSim Fx, Fy, Mz = -My
    hip.setForceFunctions(gcv(t, load[:, 0], 3), gcv(t, load[:, 1], 3), osim.Constant(0.0))
    hip.setTorqueFunctions(osim.Constant(0.0), osim.Constant(0.0), gcv(t, -load[:, 2], 3))
    model.addForce(hip)
    spring = osim.SpringGeneralizedForce("knee")
    spring.setName("knee_spring")
    spring.setStiffness(10.0)
    spring.setViscosity(1.0)
    spring.setRestLength(0.0)
    model.addForce(spring)
    model.finalizeConnections()

    study = osim.MocoStudy()
    problem = study.updProblem()
    problem.setModelAsCopy(model)
    t0, t1 = float(data["window"][0]), float(data["window"][1])
    problem.setTimeBounds(t0, t1)
    x0 = data["x0"]
    for k, name in enumerate(("ankle", "knee")):
        path = f"/jointset/{name}/{name}"
        problem.setStateInfo(f"{path}/value", [-3.0, 3.0], float(SIGN[3 + k] * x0[k]))
        problem.setStateInfo(f"{path}/speed", [-50.0, 50.0], float(SIGN[3 + k] * x0[2 + k]))
    limit = float(data["theta0_max"])
    problem.addParameter(osim.MocoParameter("k", "/forceset/knee_spring", "stiffness",
                                            osim.MocoBounds(0.0, float(data["k_max"]))))
    problem.addParameter(osim.MocoParameter("c", "/forceset/knee_spring", "viscosity",
                                            osim.MocoBounds(0.0, float(data["c_max"]))))
    problem.addParameter(osim.MocoParameter("theta0", "/forceset/knee_spring", "rest_length",
                                            osim.MocoBounds(-limit, limit)))
    reference = osim.TimeSeriesTable()
    reference.setColumnLabels(["/jointset/ankle/ankle/value", "/jointset/knee/knee/value"])
    for tk, row in zip(data["t_nodes"], data["x_ref"]):
        reference.appendRow(float(tk), osim.RowVector([float(SIGN[3] * row[0]),
                                                       float(SIGN[4] * row[1])]))
    reference.addTableMetaDataString("inDegrees", "no")
    tracking = osim.MocoStateTrackingGoal("tracking")
    tracking.setReference(osim.TableProcessor(reference))
    problem.addGoal(tracking)
    solver = study.initCasADiSolver()
    solver.set_num_mesh_intervals(int(data["intervals"]))
    solver.set_transcription_scheme(str(data["scheme"]))
    solver.set_optim_convergence_tolerance(1e-8)
    solver.set_optim_constraint_tolerance(1e-8)
    solver.set_optim_hessian_approximation(str(data["hessian"]))
    solver.set_parallel(0)
    solver.set_verbosity(0)
    solver.set_optim_max_iterations(500)
    return study


def main(path):
    data = dict(np.load(path))
    wall, cpu = [], []
    for _ in range(int(data["repeat"])):
        w0, c0 = time.perf_counter(), time.process_time()
        study = build_problem(data)
        solution = study.solve()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    if not solution.success():
        raise SystemExit(f"Moco: {solution.getStatus()}")
    parameters = solution.getParameters().to_numpy()
    states = solution.getStatesTrajectory().to_numpy()
    np.savez(path, version=osim.__version__, wall=wall, cpu=cpu, parameters=parameters,
             iterations=solution.getNumIterations(), points=solution.getNumTimes(),
             states=len(solution.getStateNames()),
             coordinates=len(solution.getStateNames()) // 2, final=states[-1])


if __name__ == "__main__":
    main(sys.argv[1])
