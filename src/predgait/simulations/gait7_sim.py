"""Forward simulation of the planar 7-link model on measured walking (thesis 2.3.1, 2.4).

The thesis experiment: joint angles and the HAT forward position follow the measured
data (splines), the HAT vertical translation is free so that the feet find their own
penetration, each foot touches the floor through two IMPACT elements (heel and ball),
and there is no friction (the HAT is driven forward). The simulated vertical ground
reactions are compared with the force plates (Fig. 2.4.1). Then one or both knees are
driven by a moment history instead of their angle, with a passive torsional spring and
damper (thesis best k = 100 N cm/rad, c = 10 N cm/rad/s), until the model falls.

Runs (both on :class:`~predgait.dynamics.partitioned.PartitionedSystem`):

* :func:`kinematic_run`: free = base_z. Its initial height is where the free vertical
  acceleration equals the measured one (the contacts carry weight plus inertia).
* :func:`knee_run`: free = base_z and the chosen knees. The knee moment is the active
  part of either the kinematic run's own inverse dynamics (``model``: what the
  prescription supplied at the knee, as the thesis did with "the best model") or the
  leg inverse dynamics with the force plates (``measured``), minus the passive moment
  at the reference motion, so the reference still solves the problem and the passive
  elements act on deviations (thesis 3.3.3-3.3.4; :meth:`LegDrivers.from_inverse`).
  A fall is a knee deviating from the kinematic run by more than a limit or the HAT
  dropping below it by more than a limit (terminal events).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from predgait.data.events import Side, runs_of
from predgait.dynamics.drivers import SampledHistory
from predgait.dynamics.falls import FallLimit, worst_joint
from predgait.dynamics.forces import (
    GroundContact,
    JointTorques,
    PassiveTorques,
    passive_generalized,
)
from predgait.dynamics.gait7_motion import SIDES, Gait7Motion
from predgait.dynamics.integrators import IntegratorOptions
from predgait.dynamics.motion import MotionHistory
from predgait.dynamics.partitioned import (
    PartitionedSystem,
    SimulationResult,
    Status,
    simulate_partitioned,
)
from predgait.dynamics.passive import PassiveJoint
from predgait.dynamics.roots import brentq
from predgait.errors import InputError, SimulationDiverged
from predgait.models.gait7 import CONTACT_FRAMES
from predgait.models.loading import Model

FEET = {"right": ("heel_r", "toe_r"), "left": ("heel_l", "toe_l")}


class KneeMoment(enum.Enum):
    """Source of the knee moment history in the knee-driven run."""

    MODEL = "model"
    MEASURED = "measured"


#: Default fall criteria of the knee-driven runs: a driven knee 30 deg from, or the HAT
#: 0.1 m below, the kinematic run (problem keys knee_deviation_deg, hat_drop).
GAIT7_FALL = FallLimit(joint_deviation_deg=30.0, base_drop=0.1)
#: Names of the fall events in gait7's results.
_CAUSES = {"base height": "HAT drop"}


@dataclass(frozen=True, eq=False)
class Gait7Result:
    """A run with its contact forces.

    Attributes:
        run: The :class:`SimulationResult` (t s, q, v, reaction of the prescription).
        forces: (n, 4, 3) N, lab-frame forces at CONTACT_FRAMES at ``run.t``.
        status: COMPLETED, EVENT (a fall) or DIVERGED.
        time_to_fall: s after the start, or None.
        fall_cause: Name of the event, the divergence message, or None.
    """

    run: SimulationResult
    forces: np.ndarray
    status: Status
    time_to_fall: float | None
    fall_cause: str | None

    def foot_fz(self, side: Side) -> np.ndarray:
        """(n,) N, vertical force of one foot (heel + toe)."""
        idx = [CONTACT_FRAMES.index(f) for f in FEET[side]]
        return self.forces[:, idx, 2].sum(axis=1)


def _contact_forces(contact: GroundContact, run: SimulationResult) -> np.ndarray:
    """(n, n_frames, 3) lab-frame contact forces at each finite state of ``run``."""
    out = np.zeros((len(run.t), len(contact.frames), 3))
    data = contact.model.pin_model.createData()
    for k, (q, v) in enumerate(zip(run.q, run.v, strict=True)):
        if np.all(np.isfinite(q)) and np.all(np.isfinite(v)):
            out[k] = contact.forces_at(q, v, data)
    return out


def _simulate(system, contact, t_span, x0, *, options, events=(), t_eval=None,
              progress=False, reference=None) -> Gait7Result:
    try:
        run = simulate_partitioned(system, t_span, x0, options=options, events=events,
                                   t_eval=t_eval, progress=progress)
        status, fall = run.status, run.time_to_fall
        cause = None if run.event is None else run.event.removeprefix("fall: ")
        if cause == "joint deviation" and reference is not None:  # name the knee
            knee = worst_joint(system, run.q[-1], reference(float(run.t[-1])))
            side = {"r": "right", "l": "left"}[knee[-1]]
            cause = f"{side} knee deviation"
        cause = _CAUSES.get(cause, cause)
    except SimulationDiverged as exc:
        run, status, cause = exc.partial, Status.DIVERGED, str(exc)
        fall = float(run.t[-1] - t_span[0])
    return Gait7Result(run, _contact_forces(contact, run), status, fall, cause)


def initial_height(system: PartitionedSystem, t: float, z_row: int, a_target: float
                   ) -> float:
    """base_z (m) at t where the free vertical acceleration equals ``a_target`` (m/s^2).

    Searched between 2 cm above and 10 cm below first contact of the lowest contact
    point (a_free rises monotonically as the feet sink in).
    """
    q, v, a = system.motion(t)
    data = system.data
    system.applied(t, q, v)
    lowest = min(data.oMf[system.model.frame_id(f)].translation[2] for f in CONTACT_FRAMES)
    ground = next(f for f in system.forces if isinstance(f, GroundContact)).ground_z
    top = q[z_row] - (lowest - ground) + 0.02

    def excess(z):
        x = system.state(q, v)
        x[list(system.q_free).index(z_row)] = z
        qq, vv, aa = system.full_state(t, x)
        a_free = system.solve(t, qq, vv, aa)[0]
        return float(a_free[list(system.free).index(z_row)] - a_target)

    if excess(top) > 0 or excess(top - 0.1) < 0:
        raise InputError(f"no HAT height at t = {t:.3f} s gives the measured vertical "
                         "acceleration: check [contact] (too soft?) and [model] ground_z.")
    return brentq(excess, top - 0.1, top, xtol=1e-9)


def kinematic_run(model: Model, motion: Gait7Motion, contact, *, ground_z: float,
                  t_span: tuple[float, float], options: IntegratorOptions, t_eval=None,
                  progress: bool = False) -> Gait7Result:
    """All joints, base_x and base_pitch prescribed; base_z free on the contacts."""
    history = MotionHistory(model, motion.time, motion.q, motion.v, motion.a)
    ground = GroundContact(model, CONTACT_FRAMES, contact, ground_z, planar=True)
    z = model.coordinate_index("base_z")
    system = PartitionedSystem(model, [z], history, [ground])
    q0, v0, a0 = history(t_span[0])
    q0[z] = initial_height(system, t_span[0], z, a0[z])
    return _simulate(system, ground, t_span, system.state(q0, v0), options=options,
                     t_eval=t_eval, progress=progress)


def knee_moment_history(model: Model, motion: Gait7Motion, kinematic: Gait7Result,
                        sides, source: KneeMoment, passive: PassiveJoint
                        ) -> SampledHistory:
    """Active knee moments (N m, gait7 sign) of ``sides``: total minus passive at the reference.

    ``source`` MODEL: the prescription's reaction at the knee rows of the kinematic run;
    MEASURED: the leg inverse dynamics with the force plates (:class:`Gait7Motion`).
    """
    rows = [model.coordinate_index(f"knee_{s[0]}") for s in sides]
    if source is KneeMoment.MODEL:
        run = kinematic.run
        pres = [int(i) for i in range(model.nq) if i != model.coordinate_index("base_z")]
        time, total = run.t, run.reaction[:, [pres.index(r) for r in rows]]
        q, v = run.q, run.v
    else:
        time = motion.time
        total = np.column_stack([motion.knee_moment[s] for s in sides])
        q, v = motion.q, motion.v
    joints = {f"knee_{s[0]}": passive for s in sides}
    active = total - passive_generalized(model, joints, q, v)[:, rows]
    return SampledHistory(time, active, name=f"{source.value} knee moment")


def knee_run(model: Model, motion: Gait7Motion, kinematic: Gait7Result, contact, *,
             ground_z: float, sides, source: KneeMoment, passive: PassiveJoint,
             fall: FallLimit, options: IntegratorOptions, t_eval=None,
             progress: bool = False) -> Gait7Result:
    """As :func:`kinematic_run` with the knees of ``sides`` driven by a moment + passive."""
    sides = tuple(sides)
    if not sides or any(s not in SIDES for s in sides):
        raise InputError(f"knee sides {sides!r}: give one or both of right, left.")
    history = MotionHistory(model, motion.time, motion.q, motion.v, motion.a)
    ground = GroundContact(model, CONTACT_FRAMES, contact, ground_z, planar=True)
    z = model.coordinate_index("base_z")
    rows = [model.coordinate_index(f"knee_{s[0]}") for s in sides]
    drive = JointTorques(np.array(rows), knee_moment_history(model, motion, kinematic, sides,
                                                             source, passive))
    spring = PassiveTorques.on(model, {f"knee_{s[0]}": passive for s in sides})
    system = PartitionedSystem(model, [z, *rows], history, [ground, drive, spring])
    ref = kinematic.run
    reference = SampledHistory(ref.t, ref.q, name="kinematic run")
    events = fall.events(system, reference)
    t0 = float(ref.t[0])
    x0 = system.state(ref.q[0], ref.v[0])
    return _simulate(system, ground, (t0, float(ref.t[-1])), x0, options=options,
                     events=events, t_eval=t_eval, progress=progress, reference=reference)


def grf_comparison(t: np.ndarray, simulated: np.ndarray, measured: np.ndarray) -> dict:
    """RMS difference (N), correlation and per-stance peaks of two vertical GRF series.

    Stances are the measured contacts (> 20 N) inside ``t``; one cut by the ends of the
    window (force above 40 N at its first or last sample) has ``complete = False``.
    """
    rows = []
    for s in runs_of(measured > 20.0):
        edges = max(measured[s.start], measured[s.stop - 1])
        rows.append({"start_s": float(t[s.start]), "end_s": float(t[s.stop - 1]),
                     "complete": bool(edges < 40.0),
                     "peak_measured_n": float(measured[s].max()),
                     "peak_simulated_n": float(simulated[s].max())})
    return {"rms_n": float(np.sqrt(np.mean((simulated - measured) ** 2))),
            "correlation": float(np.corrcoef(simulated, measured)[0, 1]), "stances": rows}
