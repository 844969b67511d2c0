"""Forward re-simulation of a predicted gait7 stride by the engine, with feedback.

Every coordinate of gait7 is free (:class:`predgait.dynamics.partitioned.
PartitionedSystem`); the applied forces are the ground contact of the prediction
(:class:`~predgait.dynamics.forces.GroundContact`), the predicted joint torques
(:class:`~predgait.dynamics.forces.JointTorques`, cubic splines through the nodes), the
passive springs of the problem, and a stabilising state feedback on the six joints:

    u = -K(t) (x - x_pred(t)),  x = (q, v) of all 9 coordinates,

a time-varying LQR on the engine's own linearisation along the prediction, the same one
as the whole body's (:mod:`predgait.dynamics.floating_lqr`: A by central differences of
the accelerations, B = [0; M^-1 S] with S the joint rows; here every coordinate is a
plain number, so the tangent-space error is q - q_pred). The weights are this module's
(:data:`GAIT7_WEIGHTS`: tolerated errors per coordinate, one torque scale). The report
is how far the re-simulation stays from the prediction and how much feedback torque that
takes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predgait.dynamics.drivers import SampledHistory
from predgait.dynamics.floating_lqr import FloatingLQR, linearize_floating
from predgait.dynamics.forces import GroundContact, JointTorques, PassiveTorques
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.lqr import BrysonWeights, riccati_gains
from predgait.dynamics.partitioned import PartitionedSystem, SimulationResult, simulate_partitioned
from predgait.errors import SimulationDiverged
from predgait.models.gait7 import CONTACT_FRAMES
from predgait.models.loading import Model
from predgait.problems.predictive import JOINTS

#: Bryson's-rule LQR weights of gait7's re-simulation: tolerated errors (m, deg, m/s,
#: deg/s; base_x, base_z on the position and speed) and torque (N m).
GAIT7_WEIGHTS = BrysonWeights(angle_deg=5.0, rate_deg_s=50.0, torque_n_m=50.0,
                              position_m=0.05, speed_m_s=0.5)


@dataclass(frozen=True, eq=False)
class Resimulation:
    """The engine's run of a predicted stride and how far it stays from it.

    Attributes:
        run: the SimulationResult. feedback: (n, 6) N m feedback torques on JOINTS.
        max_angle_deviation_deg, rms_angle_deviation_deg: over the joints and HAT pitch.
        max_position_deviation_m: HAT (base_x, base_z).
        feedback_rms_n_m, feedforward_rms_n_m: RMS over joints and time.
    """

    run: SimulationResult
    feedback: np.ndarray
    max_angle_deviation_deg: float
    rms_angle_deviation_deg: float
    max_position_deviation_m: float
    feedback_rms_n_m: float
    feedforward_rms_n_m: float

    def summary(self) -> dict:
        """JSON-ready numbers."""
        return {"status": str(self.run.status.value if hasattr(self.run.status, "value")
                                  else self.run.status),
                "end_s": float(self.run.t[-1]), "message": self.run.message,
                "max_angle_deviation_deg": self.max_angle_deviation_deg,
                "rms_angle_deviation_deg": self.rms_angle_deviation_deg,
                "max_position_deviation_m": self.max_position_deviation_m,
                "feedback_rms_n_m": self.feedback_rms_n_m,
                "feedforward_rms_n_m": self.feedforward_rms_n_m}


def resimulate(model: Model, stride: dict[str, np.ndarray], contact, ground_z: float,
               passive: dict, *, weights: BrysonWeights = GAIT7_WEIGHTS,
               options: IntegratorOptions | None = None) -> Resimulation:
    """Run the engine from the stride's first state with its torques plus TVLQR feedback.

    Args:
        model: gait7 (or an edited gait7), the model of the prediction.
        stride: t (s), q, v, tau as :func:`predgait.problems.predictive_check.full_stride`.
        contact: the prediction's contact law.
        ground_z: its floor height, m.
        passive: joint -> PassiveJoint of the problem's springs.
        weights: Bryson's-rule weights of the TVLQR.
        options: integrator; default LSODA (the contact and the feedback make the
            closed loop stiff: eigenvalues of 1e4..1e5 1/s, below any sensible RK4 step).
    """
    t, q, v = stride["t"], stride["q"], stride["v"]
    rows = np.array([model.coordinate_index(j) for j in JOINTS])
    ground = GroundContact(model, CONTACT_FRAMES, contact, ground_z, planar=True)
    drive = JointTorques(rows, SampledHistory(t, stride["tau"], name="predicted torques"))
    forces = [ground, drive]
    if passive:
        forces.append(PassiveTorques.on(model, passive))
    zero = np.zeros(model.nq)

    def nothing_prescribed(_t):
        return zero.copy(), zero.copy(), zero.copy()

    everything = range(model.nq)
    open_loop = PartitionedSystem(model, everything, nothing_prescribed, forces)
    state = SampledHistory(t, np.hstack([q, v]), name="predicted state")

    def reference(tk):
        x = state(tk)
        return x[:model.nq], x[model.nq:]

    linear = [linearize_floating(open_loop, tk, *reference(tk), rows) for tk in t]
    angles = np.full(model.nq, np.radians(weights.angle_deg) ** -2)
    rates = np.full(model.nq, np.radians(weights.rate_deg_s) ** -2)
    for name in ("base_x", "base_z"):
        angles[model.coordinate_index(name)] = weights.position_m ** -2
        rates[model.coordinate_index(name)] = weights.speed_m_s ** -2
    gains = riccati_gains(t, np.array([a for a, _ in linear]), np.array([b for _, b in linear]),
                          np.diag(np.concatenate([angles, rates])),
                          weights.torque_cost(rows.size))
    feedback = FloatingLQR(model, rows, reference, t, gains)
    system = PartitionedSystem(model, everything, nothing_prescribed, [*forces, feedback])
    options = options or IntegratorOptions(method=Method.LSODA, step=float(t[1] - t[0]),
                                           rtol=1e-6, atol=1e-8)
    try:
        run = simulate_partitioned(system, (float(t[0]), float(t[-1])), state(t[0]),
                                   options=options, t_eval=t)
    except SimulationDiverged as exc:
        run = exc.partial
    n = run.t.size
    fb = np.array([feedback.torque(tk, qk, vk) for tk, qk, vk in zip(run.t, run.q, run.v,
                                                                       strict=True)])
    angle_rows = [i for i in range(model.nq) if i not in (model.coordinate_index("base_x"),
                                                           model.coordinate_index("base_z"))]
    err = np.degrees(run.q[:, angle_rows] - q[:n, angle_rows])
    pos = run.q[:, :2] - q[:n, :2]
    return Resimulation(run=run, feedback=fb, max_angle_deviation_deg=float(np.abs(err).max()),
                        rms_angle_deviation_deg=float(np.sqrt(np.mean(err ** 2))),
                        max_position_deviation_m=float(np.abs(pos).max()),
                        feedback_rms_n_m=float(np.sqrt(np.mean(fb ** 2))),
                        feedforward_rms_n_m=float(np.sqrt(np.mean(stride["tau"] ** 2))))
