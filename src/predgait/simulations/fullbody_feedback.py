"""The whole body re-simulated from a tracking solution: solved torques, contact springs, LQR.

The forward engine (:mod:`predgait.dynamics.partitioned`, every velocity row free: the
pelvis is a free flyer without actuators) integrates the 35-DOF body from the solution's
first state, driven by the solved joint torques (splined between the nodes) on the sole
points' contact law (:class:`~predgait.dynamics.forces.GroundContact`), with or without
the time-varying LQR feedback along the solution (:mod:`predgait.dynamics.floating_lqr`).
A run stops at a fall (:data:`~predgait.simulations.forward3d.FULLBODY_FALL` relative to
the solution's motion). The figures of merit: the time to fall (None: the whole window),
the joint angles' RMS difference from the solution and the ground reactions' from the
plates, at the solution's nodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.dynamics.contact import ImpactContact
from predgait.dynamics.drivers import SampledHistory
from predgait.dynamics.falls import FallLimit
from predgait.dynamics.floating_lqr import FloatingLQR, floating_tvlqr
from predgait.dynamics.forces import GroundContact, JointTorques
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.lqr import BrysonWeights
from predgait.dynamics.motion import MotionHistory
from predgait.dynamics.partitioned import PartitionedSystem, simulate_partitioned
from predgait.errors import SimulationDiverged
from predgait.problems.fullbody_tracking import TrackingData, TrackingSolution, foot_totals
from predgait.simulations.forward3d import FULLBODY_FALL


@dataclass(frozen=True, eq=False)
class FeedbackRun:
    """One re-simulation.

    Attributes:
        t: (n,) s, the solution's nodes reached. q: (n, nq). forces: (n, P, 3) N on the
            solution's points.
        status: completed / event / diverged. time_to_fall: s from the start, or None.
        message: How it ended. seconds: wall time.
    """

    t: np.ndarray
    q: np.ndarray
    forces: np.ndarray
    status: str
    time_to_fall: float | None
    message: str
    seconds: float

    def summary(self, solution: TrackingSolution, data: TrackingData, body_weight: float
                ) -> dict:
        """Status, time to fall, joint RMS from the solution and GRF RMS from the plates."""
        n = self.t.size
        joints = np.degrees(self.q[:, 7:] - solution.q[:n, 7:])
        feet = foot_totals(self.forces, solution.points)
        grf = feet - data.force[:n]
        return {"status": str(self.status), "time_to_fall_s": self.time_to_fall,
                "simulated_s": float(self.t[-1] - self.t[0]) if n else 0.0,
                "message": self.message, "wall_time_s": self.seconds,
                "joint_rms_from_solution_deg": float(np.sqrt(np.mean(joints**2))),
                "grf_rms_from_plates_percent_bw": {
                    f"{side}_{axis}": float(100 * np.sqrt(np.mean(grf[:, j, i] ** 2))
                                            / body_weight)
                    for j, side in enumerate("rl") for i, axis in enumerate("xyz")}}


def body_system(model, solution: TrackingSolution, law: ImpactContact, *,
                ground_z: float, belt_velocity: float, feedback: FloatingLQR | None = None
                ) -> tuple[PartitionedSystem, MotionHistory, GroundContact]:
    """The free body driven by the solved joint torques on the contact law (+ feedback).

    The engine's contact points are the solution's (``solution.points``), so the
    re-simulation stands on the points the solved forces assume.
    """
    history = MotionHistory(model, solution.time, solution.q, solution.v, solution.a)
    torques = JointTorques(np.arange(6, model.nv),
                           SampledHistory(solution.time, solution.tau[:, 6:],
                                          name="solved joint torques"))
    ground = GroundContact(model, solution.points, law, ground_z=ground_z,
                           belt_velocity=belt_velocity)
    forces = [torques, ground] + ([feedback] if feedback is not None else [])
    return PartitionedSystem(model, range(model.nv), history, forces), history, ground


def feedback_gains(system: PartitionedSystem, history: MotionHistory,
                   solution: TrackingSolution, weights: BrysonWeights) -> FloatingLQR:
    """Time-varying LQR along the solution, linearised at its nodes, on its sole points."""
    return floating_tvlqr(system, history, solution.time, np.arange(6, system.pm.nv),
                          weights, points=solution.points)


def _latest_only(history: MotionHistory):
    """The reference q_ref(t), computed once per t (every fall criterion asks each step)."""
    latest = [None, None]

    def reference(t: float) -> np.ndarray:
        if latest[0] != t:
            latest[:] = t, history(t)[0]
        return latest[1]

    return reference


def resimulate(system: PartitionedSystem, history: MotionHistory, ground: GroundContact,
               solution: TrackingSolution, *, step: float,
               fall: FallLimit = FULLBODY_FALL) -> FeedbackRun:
    """Integrate ``system`` (RK4, ``step`` s) from the solution's first state to its end."""
    import time

    start = time.perf_counter()
    t0, t1 = float(solution.time[0]), float(solution.time[-1])
    x0 = system.state(solution.q[0], solution.v[0])
    try:
        run = simulate_partitioned(system, (t0, t1), x0,
                                   options=IntegratorOptions(method=Method.RK4, step=step),
                                   events=fall.events(system, _latest_only(history)),
                                   t_eval=solution.time)
    except SimulationDiverged as exc:
        run = exc.partial
    pm, data = system.pm, system.pm.createData()
    forces = []
    for q, v in zip(run.q, run.v, strict=True):
        pin.forwardKinematics(pm, data, q, v)
        pin.updateFramePlacements(pm, data)
        forces.append(ground.forces(data))
    # The nodes reached (not the time of a fall event).
    keep = np.isclose(run.t[:, None], solution.time[None], atol=1e-9).any(axis=1)
    return FeedbackRun(run.t[keep], run.q[keep], np.array(forces).reshape(len(forces), -1, 3)[keep],
                       str(run.status), run.time_to_fall, run.message,
                       time.perf_counter() - start)
