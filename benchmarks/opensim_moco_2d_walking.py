"""OpenSim Moco's predictive 2D walking example, timed (the peer of bench_predict.py).

Usage: MOCO_2D_GAIT_DIR=DIR OPENSIM_PYTHON benchmarks/opensim_moco_2d_walking.py [--write OUT]

``--write OUT`` also writes both solutions into OUT (after the timed work): for each stage
``<stage>_solution.sto`` (the half stride, a MocoTrajectory), ``_fullcycle.sto`` (the
stride, createPeriodicTrajectory) and ``_fullcycle_grf.sto`` (createExternalLoadsTableForGait
of the heel and front spheres); tests/reference/osim2d/moco_prediction/ was made so.

DIR holds the files of opensim-core's OpenSim/Examples/Moco/example2DWalking
(2D_gait.osim, referenceCoordinates.sto, referenceGRF.sto, referenceGRF.xml); they are
not shipped with the opensim wheel nor with predgait. The two problems are set up as
opensim-core's Bindings/Python/examples/Moco/example2DWalking/example2DWalking.py does,
with its own settings:

1. tracking (MocoTrack, half a gait cycle, 0 to 0.470089 s): coordinates (low-pass 6 Hz,
   with their derivatives) weight 1, control effort weight 10, ground reaction forces
   (MocoContactTrackingGoal) weight 1, left/right symmetry (MocoPeriodicityGoal),
   MocoTrack's own solver settings (the example sets none);
2. predictive (MocoStudy): effort (controls cubed, weight 10) divided by the displacement,
   average speed 1.2 m/s, the same symmetry, final time free in [0.4, 0.6] s, CasADi +
   Ipopt, 50 mesh intervals, convergence and constraint tolerance 1e-4, at most 1000
   iterations, started from the tracking solution.

The model has 10 coordinates (planar pelvis, hips, knees, ankles, lumbar), 18
DeGrooteFregly2016 muscles and 4 smooth sphere contacts. Cold: a fresh process, both
problems built from the files; the timed work is each problem's set-up and solve (no file
writing, no visualisation). Moco's CasADi solver uses its default parallelism (all cores).
Reports the end of the tracking stage on stderr (so a run stopped later says where it
was), then one JSON object on stdout: per stage wall and CPU seconds (CPU of all threads),
Ipopt iterations, status, mesh intervals, time points, states, controls, and the model's
coordinates and muscles. Only opensim is imported: its bundled CasADi clashes with the casadi wheel.
"""

import json
import math
import os
import re
import shutil
import sys
import tempfile
import time

import opensim as osim

osim.Logger.removeFileSink()   # no opensim.log in the working folder
osim.Logger.setLevelString("error")

FILES = ("2D_gait.osim", "referenceCoordinates.sto", "referenceGRF.sto", "referenceGRF.xml")
DEG = math.pi / 180
#: The example's bounds (path, lower, upper), radians or metres.
BOUNDS = (("/jointset/groundPelvis/pelvis_tilt/value", -20 * DEG, -10 * DEG),
          ("/jointset/groundPelvis/pelvis_tx/value", 0.0, 1.0),
          ("/jointset/groundPelvis/pelvis_ty/value", 0.75, 1.25),
          ("/jointset/hip_l/hip_flexion_l/value", -10 * DEG, 60 * DEG),
          ("/jointset/hip_r/hip_flexion_r/value", -10 * DEG, 60 * DEG),
          ("/jointset/knee_l/knee_angle_l/value", -50 * DEG, 0.0),
          ("/jointset/knee_r/knee_angle_r/value", -50 * DEG, 0.0),
          ("/jointset/ankle_l/ankle_angle_l/value", -15 * DEG, 25 * DEG),
          ("/jointset/ankle_r/ankle_angle_r/value", -15 * DEG, 25 * DEG),
          ("/jointset/lumbar/lumbar/value", 0.0, 20 * DEG))


def add_symmetry(problem, model):
    """The example's MocoPeriodicityGoal: right/left swapped, pelvis_tx free."""
    goal = osim.MocoPeriodicityGoal("symmetryGoal")
    problem.addGoal(goal)
    names = model.getStateVariableNames()
    for i in range(model.getNumStateVariables()):
        name = names.getitem(i)
        if not (name.startswith("/jointset") or name.endswith("/activation")):
            continue
        if "_r" in name:
            goal.addStatePair(osim.MocoPeriodicityGoalPair(name, re.sub(r"_r", "_l", name)))
        if "_l" in name:
            goal.addStatePair(osim.MocoPeriodicityGoalPair(name, re.sub(r"_l", "_r", name)))
        if (name.startswith("/jointset") and "_r" not in name and "_l" not in name
                and "pelvis_tx/value" not in name and "/activation" not in name):
            goal.addStatePair(osim.MocoPeriodicityGoalPair(name))
    goal.addControlPair(osim.MocoPeriodicityGoalPair("/lumbarAct"))


def set_bounds(problem):
    for path, lower, upper in BOUNDS:
        problem.setStateInfo(path, [lower, upper])


def tracking():
    """The example's tracking problem; returns (solution, solver, study)."""
    track = osim.MocoTrack()
    track.setName("gaitTracking")
    table = osim.TableProcessor("referenceCoordinates.sto")
    table.append(osim.TabOpLowPassFilter(6))
    processor = osim.ModelProcessor("2D_gait.osim")
    track.setModel(processor)
    track.setStatesReference(table)
    track.set_states_global_tracking_weight(1)
    track.set_allow_unused_references(True)
    track.set_track_reference_position_derivatives(True)
    track.set_apply_tracked_states_to_guess(True)
    track.set_initial_time(0.0)
    track.set_final_time(0.470089)
    study = track.initialize()
    problem = study.updProblem()
    model = processor.process()
    model.initSystem()
    add_symmetry(problem, model)
    osim.MocoControlGoal.safeDownCast(problem.updGoal("control_effort")).setWeight(10)
    contact = osim.MocoContactTrackingGoal("contact", 1)
    contact.setExternalLoadsFile("referenceGRF.xml")
    for side in ("r", "l"):
        forces = osim.StdVectorString()
        forces.append(f"contactHeel_{side}")
        forces.append(f"contactFront_{side}")
        contact.addContactGroup(forces, "Right_GRF" if side == "r" else "Left_GRF")
    contact.setProjection("plane")
    contact.setProjectionVector(osim.Vec3(0, 0, 1))
    problem.addGoal(contact)
    set_bounds(problem)
    solver = osim.MocoCasADiSolver.safeDownCast(study.updSolver())
    return study.solve(), solver, study   # the study owns the solver: keep it alive


def prediction(guess):
    """The example's predictive problem from ``guess``; returns (solution, solver, model, study)."""
    study = osim.MocoStudy()
    study.setName("gaitPrediction")
    problem = study.updProblem()
    processor = osim.ModelProcessor("2D_gait.osim")
    problem.setModelProcessor(processor)
    model = processor.process()
    model.initSystem()
    add_symmetry(problem, model)
    speed = osim.MocoAverageSpeedGoal("speed")
    problem.addGoal(speed)
    speed.set_desired_average_speed(1.2)
    effort = osim.MocoControlGoal("effort", 10)
    problem.addGoal(effort)
    effort.setExponent(3)
    effort.setDivideByDisplacement(True)
    problem.setTimeBounds(0, [0.4, 0.6])
    set_bounds(problem)
    solver = study.initCasADiSolver()
    solver.set_num_mesh_intervals(50)
    solver.set_verbosity(0)
    solver.set_optim_solver("ipopt")
    solver.set_optim_convergence_tolerance(1e-4)
    solver.set_optim_constraint_tolerance(1e-4)
    solver.set_optim_max_iterations(1000)
    solver.setGuess(guess)
    return study.solve(), solver, model, study


def timed(run):
    w0, c0 = time.perf_counter(), time.process_time()
    result = run()
    return result, time.perf_counter() - w0, time.process_time() - c0


def mesh_intervals(solver):
    """The solver's mesh intervals (MocoTrack may set its mesh as a list: then None)."""
    try:
        return solver.get_num_mesh_intervals()
    except RuntimeError:   # "an index must be provided for a property that takes a list"
        return None


def describe(solution, solver, wall, cpu):
    return {"wall": wall, "cpu": cpu, "iterations": solution.getNumIterations(),
            "status": solution.getStatus(), "success": bool(solution.success()),
            "objective": solution.getObjective(),
            "mesh_intervals": mesh_intervals(solver),
            "transcription": solver.get_transcription_scheme(),
            "time_points": solution.getNumTimes(), "states": solution.getNumStates(),
            "controls": solution.getNumControls(), "final_time": solution.getFinalTime()}


def write_solution(solution, model, stem):
    """``stem``.sto, ``stem``_fullcycle.sto and ``stem``_fullcycle_grf.sto of a solution."""
    solution.write(stem + ".sto")
    full = osim.createPeriodicTrajectory(solution)
    full.write(stem + "_fullcycle.sto")
    feet = []
    for side in ("r", "l"):
        names = osim.StdVectorString()
        names.append(f"contactHeel_{side}")
        names.append(f"contactFront_{side}")
        feet.append(names)
    grf = osim.createExternalLoadsTableForGait(model, full, feet[0], feet[1])
    osim.STOFileAdapter.write(grf, stem + "_fullcycle_grf.sto")


def main(folder, write=None):
    work = tempfile.mkdtemp(prefix="moco2d")
    try:
        for name in FILES:
            shutil.copy(os.path.join(folder, name), work)
        os.chdir(work)   # the example's relative paths (and referenceGRF.xml's) resolve here
        # Both studies stay bound until the end: each owns its solver, and a solver whose
        # study was collected crashes describe() (a segfault in _moco.so when the tracking
        # study's name was reused for the prediction's: two runs lost after their solves).
        (track, track_solver, track_study), track_wall, track_cpu = timed(tracking)
        track.unseal()
        print(f"tracking: {track_wall:.1f} s wall, {track.getNumIterations()} iterations, "
              f"{track.getStatus()}; predictive solve started", file=sys.stderr, flush=True)
        (pred, pred_solver, model, pred_study), pred_wall, pred_cpu = timed(
            lambda: prediction(track))
        pred.unseal()
        print(json.dumps({"version": osim.__version__, "coordinates": model.getNumCoordinates(),
                          "muscles": model.getMuscles().getSize(),
                          "tracking": describe(track, track_solver, track_wall, track_cpu),
                          "predictive": describe(pred, pred_solver, pred_wall, pred_cpu)}))
        if write:
            os.makedirs(write, exist_ok=True)
            write_solution(track, model, os.path.join(write, "gaitTracking_solution"))
            write_solution(pred, model, os.path.join(write, "gaitPrediction_solution"))
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    out = None
    if sys.argv[1:2] == ["--write"] and len(sys.argv) == 3:
        out = os.path.abspath(sys.argv[2])
    elif sys.argv[1:]:
        sys.exit("usage: opensim_moco_2d_walking.py [--write OUT]")
    main(os.environ.get("MOCO_2D_GAIT_DIR") or sys.exit("MOCO_2D_GAIT_DIR is not set"), out)
