"""Peer script: OpenSim Moco's example2DWalking (tracking, then prediction) on 2D_gait.osim.

Runs in the OpenSim Python only (``$OPENSIM_PYTHON``, ``pip install opensim==4.6``); the
package never imports OpenSim. The problem is the one of opensim-core's
``OpenSim/Examples/Moco/example2DWalking`` (tag 4.6), written again with the Python API:
half a stride, left-right symmetry, average speed 1.2 m/s, effort = 10 x sum of controls
cubed over distance, duration free in [0.4, 0.6] s, 50 mesh intervals, Ipopt tolerances
1e-4, the tracking solution as the prediction's guess.

Usage: ``$OPENSIM_PYTHON benchmarks/peer/moco_2d_walking.py DATA_DIR OUT_DIR
[--stage tracking|prediction|both] [--guess TRACKING.sto]``. Prints one JSON line per stage
with its wall time (s), Ipopt status, iterations and objective.
"""

import argparse
import json
import math
import os
import shutil
import sys
import time

import opensim as osim

FILES = ("2D_gait.osim", "referenceCoordinates.sto", "referenceGRF.sto", "referenceGRF.xml")
DEG = math.pi / 180.0
BOUNDS = {
    "/jointset/groundPelvis/pelvis_tilt/value": (-20 * DEG, -10 * DEG),
    "/jointset/groundPelvis/pelvis_tx/value": (0.0, 1.0),
    "/jointset/groundPelvis/pelvis_ty/value": (0.75, 1.25),
    "/jointset/hip_l/hip_flexion_l/value": (-10 * DEG, 60 * DEG),
    "/jointset/hip_r/hip_flexion_r/value": (-10 * DEG, 60 * DEG),
    "/jointset/knee_l/knee_angle_l/value": (-50 * DEG, 0.0),
    "/jointset/knee_r/knee_angle_r/value": (-50 * DEG, 0.0),
    "/jointset/ankle_l/ankle_angle_l/value": (-15 * DEG, 25 * DEG),
    "/jointset/ankle_r/ankle_angle_r/value": (-15 * DEG, 25 * DEG),
    "/jointset/lumbar/lumbar/value": (0.0, 20 * DEG),
}


def _mirror(name, a, b):
    return name[: -len(a)] + b if name.endswith(a) else name


def add_symmetry(problem, model):
    """Left-right symmetry of coordinates (but pelvis_tx), speeds, lumbar control, activations."""
    goal = osim.MocoPeriodicityGoal("symmetryGoal")
    problem.addGoal(goal)
    for coord in model.getComponentsList():
        if not isinstance(coord, osim.Coordinate) and coord.getConcreteClassName() != "Coordinate":
            continue
        coord = osim.Coordinate.safeDownCast(coord)
        name = coord.getName()
        path = coord.getAbsolutePathString()
        for suffix in ("/value", "/speed"):
            first = path + suffix
            if name.endswith("_r"):
                goal.addStatePair(osim.MocoPeriodicityGoalPair(first, first.replace("_r/", "_l/")))
            elif name.endswith("_l"):
                goal.addStatePair(osim.MocoPeriodicityGoalPair(first, first.replace("_l/", "_r/")))
            elif not name.endswith("_tx"):
                goal.addStatePair(osim.MocoPeriodicityGoalPair(first, first))
    goal.addStatePair(osim.MocoPeriodicityGoalPair("/jointset/groundPelvis/pelvis_tx/speed"))
    goal.addControlPair(osim.MocoPeriodicityGoalPair("/lumbarAct"))
    muscles = model.getMuscles()
    for i in range(muscles.getSize()):
        path = muscles.get(i).getAbsolutePathString() + "/activation"
        if path.endswith("_r/activation"):
            goal.addStatePair(osim.MocoPeriodicityGoalPair(path, path.replace("_r/", "_l/")))
        elif path.endswith("_l/activation"):
            goal.addStatePair(osim.MocoPeriodicityGoalPair(path, path.replace("_l/", "_r/")))


def configure(solver):
    solver.set_num_mesh_intervals(50)
    solver.set_verbosity(2)
    solver.set_optim_solver("ipopt")
    solver.set_optim_convergence_tolerance(1e-4)
    solver.set_optim_constraint_tolerance(1e-4)
    solver.set_optim_max_iterations(1000)


def set_bounds(problem):
    for path, (low, high) in BOUNDS.items():
        problem.setStateInfo(path, [low, high])


def tracking():
    track = osim.MocoTrack()
    track.setName("gaitTracking")
    processor = osim.ModelProcessor("2D_gait.osim")
    track.setModel(processor)
    table = osim.TableProcessor("referenceCoordinates.sto")
    table.append(osim.TabOpLowPassFilter(6))
    track.setStatesReference(table)
    track.set_states_global_tracking_weight(1)
    track.set_allow_unused_references(True)
    track.set_track_reference_position_derivatives(True)
    track.set_apply_tracked_states_to_guess(True)
    track.set_initial_time(0.0)
    track.set_final_time(0.470089)  # the filtered table ends at 0.4700893
    study = track.initialize()
    problem = study.updProblem()
    model = processor.process()
    model.initSystem()
    add_symmetry(problem, model)
    osim.MocoControlGoal.safeDownCast(problem.updGoal("control_effort")).setWeight(10)
    contact = osim.MocoContactTrackingGoal("contact", 1)
    contact.setExternalLoadsFile("referenceGRF.xml")
    for group, names in (("Right_GRF", ("contactHeel_r", "contactFront_r")),
                         ("Left_GRF", ("contactHeel_l", "contactFront_l"))):
        vec = osim.StdVectorString()
        for n in names:
            vec.append(n)
        contact.addContactGroup(vec, group)
    contact.setProjection("plane")
    contact.setProjectionVector(osim.Vec3(0, 0, 1))
    problem.addGoal(contact)
    set_bounds(problem)
    configure(osim.MocoCasADiSolver.safeDownCast(study.updSolver()))
    return study, model


def prediction(guess):
    study = osim.MocoStudy()
    study.setName("gaitPrediction")
    problem = study.updProblem()
    processor = osim.ModelProcessor("2D_gait.osim")
    problem.setModelProcessor(processor)
    model = processor.process()
    model.initSystem()
    add_symmetry(problem, model)
    speed = osim.MocoAverageSpeedGoal("speed")
    speed.set_desired_average_speed(1.2)
    problem.addGoal(speed)
    effort = osim.MocoControlGoal("effort", 10)
    effort.setExponent(3)
    effort.setDivideByDisplacement(True)
    problem.addGoal(effort)
    problem.setTimeBounds(0, [0.4, 0.6])
    set_bounds(problem)
    solver = study.initCasADiSolver()
    configure(solver)
    solver.setGuess(guess)
    return study, model


def write_outputs(solution, model, stem):
    solution.write(stem + ".sto")
    full = osim.createPeriodicTrajectory(solution)
    full.write(stem + "_fullcycle.sto")
    right, left = osim.StdVectorString(), osim.StdVectorString()
    for n in ("contactHeel_r", "contactFront_r"):
        right.append(n)
    for n in ("contactHeel_l", "contactFront_l"):
        left.append(n)
    grf = osim.createExternalLoadsTableForGait(model, full, right, left)
    osim.STOFileAdapter.write(grf, stem + "_fullcycle_grf.sto")


def report(stage, solution, seconds):
    print(json.dumps({
        "stage": stage, "wall_s": round(seconds, 2), "status": solution.getStatus(),
        "success": bool(solution.success()), "iterations": solution.getNumIterations(),
        "objective": solution.getObjective(),
    }), flush=True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data")
    parser.add_argument("out")
    parser.add_argument("--stage", choices=("tracking", "prediction", "both"), default="both")
    parser.add_argument("--guess", help="tracking solution (.sto) for --stage prediction")
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    for name in FILES:
        shutil.copy(os.path.join(args.data, name), os.path.join(args.out, name))
    guess_path = os.path.abspath(args.guess) if args.guess else None
    os.chdir(args.out)
    if args.stage in ("tracking", "both"):
        start = time.perf_counter()
        study, model = tracking()
        solution = study.solve()
        report("tracking", solution, time.perf_counter() - start)
        write_outputs(solution, model, "gaitTracking_solution")
        guess = solution
    if args.stage in ("prediction", "both"):
        if args.stage == "prediction":
            guess = osim.MocoTrajectory(guess_path)
        start = time.perf_counter()
        study, model = prediction(guess)
        solution = study.solve()
        report("prediction", solution, time.perf_counter() - start)
        write_outputs(solution.unseal() if not solution.success() else solution, model,
                      "gaitPrediction_solution")
    return 0


if __name__ == "__main__":
    sys.exit(main())
