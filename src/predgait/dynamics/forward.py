"""The leg and the rod: configurations of the one engine (:mod:`.partitioned`).

Leg (thesis 3.3): the foot's base_x, base_z, base_pitch follow the measured motion
(prescribed), ankle and knee are free (or one of them prescribed from the reference);
applied forces: the active joint torques, the passive elements (one sign table,
:class:`~predgait.dynamics.forces.PassiveTorques`), optional PD feedback and the hip
force and moment on ``hip_center``. The multipliers of the prescribed base are the
wrench the ground must apply to the foot for it to follow its prescribed motion: force
(lambda_x, lambda_z) in the lab frame and moment lambda_pitch about +Y at the foot frame
origin (the ankle centre). It is reduced to a force at a centre of pressure on the
ground line (thesis eqs. 3.3.9-3.3.10): the moment about the heel H, M_H = lambda_pitch
+ ((A - H) x F)_y, and with no moment left at the COP on the line z = z_g: COP_x = H_x -
(M_H + (H_z - z_g) F_x) / F_z (thesis: COP_x = M_G/H / F_GZ measured from the heel, the
sign following the moment about +Y used here).

Rod (thesis 3.2.3-3.2.4): nothing prescribed, end loads in the lab or the rod frame.

This replaces the thesis' 21-equation Newton-Euler system (Appendix A) solved by
Gauss-Jordan at each step; tests/test_forward_thesis.py writes those equations out and
checks that both give the same accelerations and ground reaction.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin

from predgait.dynamics.drivers import LegDrivers, is_zero
from predgait.dynamics.external import Load, generalized_load
from predgait.dynamics.falls import FallLimit
from predgait.dynamics.forces import (
    Force,
    FrameLoad,
    JointFeedback,
    JointTorques,
    Kinematics,
    PassiveTorques,
)
from predgait.dynamics.integrators import Event, IntegratorOptions
from predgait.dynamics.partitioned import (
    PartitionedSystem,
    SimulationResult,
    simulate_partitioned,
)
from predgait.errors import InputError, SimulationDiverged
from predgait.models.loading import Model

__all__ = ["LEG_FREE", "LEG_FALL", "ForceFrame", "LegSystem", "FallLimit", "SimulationResult",
           "simulate_leg", "RodForces", "simulate_rod", "rod_system", "reduce_to_cop"]

#: The leg's free coordinates (the foot is prescribed), for the engine and the CasADi
#: problems alike.
LEG_FREE = ("ankle", "knee")
#: The leg's default fall: the shank or thigh 60 deg from upright (problem key
#: segment_angle_deg).
LEG_FALL = FallLimit(segment_angle_deg=60.0)
#: Vertical ground force below which no COP is reported (set to 0), N.
COP_THRESHOLD = 20.0


class ForceFrame(enum.Enum):
    """Frame of the rod's end forces (thesis 3.2.3-3.2.4)."""

    INERTIAL = "inertial"   # lab frame components (X, Z): "inertial-based"
    BODY = "body"           # rod frame components (x across, z along the rod): "body-based"


def reduce_to_cop(force_x, force_z, moment_heel, heel_x, heel_z, *, ground_z=0.0,
                  threshold=COP_THRESHOLD):
    """Centre of pressure on the line z = ground_z (thesis eqs. 3.3.9-3.3.10).

    Args:
        force_x: Ground force on the foot along X, N (array or float).
        force_z: Its Z component, N.
        moment_heel: Its moment about +Y at the heel point, N m.
        heel_x: Heel position X, m.
        heel_z: Heel position Z, m.
        ground_z: Height of the ground line, m.
        threshold: |F_z| below which the COP is undefined and returned as 0, N.

    Returns:
        COP x, m (0 where |F_z| < threshold).
    """
    fz = np.asarray(force_z, dtype=float)
    safe = np.where(np.abs(fz) >= threshold, fz, 1.0)
    cop = heel_x - (moment_heel + (heel_z - ground_z) * np.asarray(force_x)) / safe
    return np.where(np.abs(fz) >= threshold, cop, 0.0)


class LegSystem(PartitionedSystem):
    """The leg's right-hand side x' = f(t, x), x = [q_f, v_f], foot prescribed.

    Args:
        model: The leg.
        drivers: Prescribed motion, torques, hip load and the passive elements that act
            in the run (``drivers.passive``, with their inverse-dynamics offset when the
            drivers came from :meth:`LegDrivers.from_inverse` with them).
        free: Names of the free coordinates (default ankle, knee); the others follow
            ``drivers`` (base coordinates: ``prescribed_*``; joints: ``reference_*``).
        feedback: Optional PD feedback (:class:`~predgait.dynamics.forces.JointFeedback`)
            on joint rows.
    """

    def __init__(self, model: Model, drivers: LegDrivers, *, free=LEG_FREE,
                 feedback: JointFeedback | None = None):
        if model.kind != "leg":
            raise InputError(f"simulate_leg needs the leg model, got '{model.kind}'.")
        rows = [model.coordinate_index(n) for n in free]
        if len(set(rows)) != len(rows) or not rows:
            raise InputError(f"free coordinates {tuple(free)!r} must be distinct and not empty.")
        joints_prescribed = [i for i in range(3, model.nq) if i not in rows]
        if joints_prescribed and drivers.reference_qdd is None:
            raise InputError("prescribing a joint needs drivers with reference_q/qd/qdd.")
        self.drivers, self.feedback = drivers, feedback
        forces = []  # only what acts: a zero constant load needs no Jacobian
        if not is_zero(drivers.joint_torque):
            forces.append(JointTorques(slice(3, 5), drivers.joint_torque))
        if drivers.passive:
            forces.append(PassiveTorques.on(model, drivers.passive,
                                            offset=drivers.passive_offset))
        if feedback is not None:
            forces.append(feedback)
        if not (is_zero(drivers.hip_force) and is_zero(drivers.hip_moment)):
            if drivers.hip_in_thigh_frame:
                forces.append(FrameLoad(model, "hip_center", *hip_on_thigh_axes(model, drivers),
                                        name="hip", body_fixed=True))
            else:
                forces.append(FrameLoad(model, "hip_center", drivers.hip_force,
                                        drivers.hip_moment, name="hip"))
        super().__init__(model, rows, self._motion_function(drivers, joints_prescribed),
                         forces)
        self.nf = self.nvf
        self.hip_frame = model.frame_id("hip_center")
        self.heel_frame = model.frame_id("heel")

    def fast_path(self, options: IntegratorOptions):
        """The CasADi evaluation of fixed-step runs (:mod:`.compiled_leg`), or None.

        None with the cache off (then CasADi is not even imported).
        """
        from predgait import function_cache

        if not function_cache.enabled():
            return None
        if not hasattr(self, "_fast"):
            from predgait.dynamics.compiled_leg import fast_leg

            self._fast = fast_leg(self)
        return self._fast

    @staticmethod
    def _motion_function(drivers: LegDrivers, joints: list[int]):
        last = [None, None]  # (t, q v a stacked) of the latest call: the correctors of a
                             # modified-Euler step ask for the same t again and again

        def motion(t):
            if t == last[0]:
                qva = last[1].copy()
            else:
                qva = np.zeros(15)
                q, v, a = qva[:5], qva[5:10], qva[10:]
                q[:3], v[:3] = drivers.prescribed_q(t), drivers.prescribed_qd(t)
                a[:3] = drivers.prescribed_qdd(t)
                if joints:
                    q[joints], v[joints] = drivers.reference_q(t)[joints], \
                        drivers.reference_qd(t)[joints]
                    a[joints] = drivers.reference_qdd(t)[joints]
                last[0], last[1] = t, qva.copy()
            return qva[:5], qva[5:10], qva[10:]

        return motion

    def ground_reaction(self, t: float, x: np.ndarray, *, ground_z: float = 0.0
                        ) -> tuple[np.ndarray, np.ndarray, float]:
        """Ground reaction (3,) N, COP (3,) m and moment about the heel (N m) at (t, x).

        Only defined when the three base coordinates are prescribed.
        """
        q, v, a = self.full_state(t, x)
        lam = self.solve(t, q, v, a)[1]
        grf, cop, m_heel = self._grf(q[None], lam[None], ground_z)
        return grf[0], cop[0], float(m_heel[0])

    def _grf(self, q: np.ndarray, lam: np.ndarray, ground_z: float):
        """(grf (n, 3), cop (n, 3), moment about the heel (n,)) from q (n, 5), lam (n, 3)."""
        heel = np.empty((len(q), 3))
        for k, qk in enumerate(q):
            pin.framesForwardKinematics(self.pm, self.data, qk)
            heel[k] = self.data.oMf[self.heel_frame].translation
        fx, fz, m_ankle = lam[:, 0], lam[:, 1], lam[:, 2]
        d = q[:, :2] - heel[:, [0, 2]]        # ankle (base origin) - heel
        m_heel = m_ankle + d[:, 1] * fx - d[:, 0] * fz
        zeros = np.zeros(len(q))
        cop = np.column_stack([
            reduce_to_cop(fx, fz, m_heel, heel[:, 0], heel[:, 2], ground_z=ground_z), zeros,
            np.where(np.abs(fz) >= COP_THRESHOLD, ground_z, 0.0)])
        return np.column_stack([fx, zeros, fz]), cop, m_heel


def hip_on_thigh_axes(model: Model, drivers: LegDrivers):
    """The hip load held in the thigh frame: (force, moment) functions of t.

    Their values are the load's components on the axes of frame ``hip_center`` (on the
    thigh) at the measured motion, N and N m: R(q_ref(t))^T (f, m)(t).

    Raises:
        InputError: The drivers carry no reference motion.
    """
    if drivers.reference_q is None:
        raise InputError("a hip load fixed in the thigh frame needs drivers with a "
                         "reference motion (from inverse dynamics).")
    data = model.pin_model.createData()
    frame = model.frame_id("hip_center")
    last = [None, None]   # t, R^T of the latest call

    def transposed(t):
        if t != last[0]:
            pin.framesForwardKinematics(model.pin_model, data, drivers.reference_q(t))
            last[0], last[1] = t, data.oMf[frame].rotation.T.copy()
        return last[1]

    return (lambda t: transposed(t) @ drivers.hip_force(t),
            lambda t: transposed(t) @ drivers.hip_moment(t))


def simulate_leg(model: Model, drivers: LegDrivers, t_span: tuple[float, float], x0=None, *,
                 feedback: JointFeedback | None = None, options: IntegratorOptions,
                 events: Sequence[Event] = (), fall: FallLimit | None = None,
                 free: Sequence[str] = LEG_FREE, progress: bool = False,
                 t_eval=None, ground_z: float = 0.0) -> SimulationResult:
    """Simulate the leg with the foot (and any non-free coordinate) prescribed.

    Args:
        model: The leg.
        drivers: Prescribed foot motion, joint torques, hip load and passive elements
            (:class:`LegDrivers`; ``drivers.passive`` is the one place they are given).
        t_span: (t0, t1) s, inside ``drivers.time_range`` when it is set.
        x0: (2 n_free,) [q_free, v_free] rad, rad/s; None: the reference motion at t0.
        feedback: Optional PD feedback on joint rows (:class:`JointFeedback`).
        options: Integrator options.
        events: Further terminal events g(t, x) on x = [q_free, v_free].
        fall: Fall criterion; its event gives ``time_to_fall`` (s after t0).
        free: Free coordinate names.
        progress: Show a progress bar.
        t_eval: Optional output times, s.
        ground_z: Height of the ground line for the COP, m.

    Returns:
        The :class:`SimulationResult` (with GRF and COP when the foot is prescribed).

    Raises:
        SimulationDiverged: NaN or blow-up; ``.partial`` is the SimulationResult so far
            (``partial=True``) and the message names the time and coordinate.
        InputError: Bad time span, state or options.
    """
    system = LegSystem(model, drivers, free=free, feedback=feedback)
    t0, t1 = (float(v) for v in t_span)
    if drivers.time_range is not None:
        lo, hi = drivers.time_range
        if t0 < lo - 1e-9 or t1 > hi + 1e-9:
            raise InputError(f"time span {t0:g}..{t1:g} s is outside the driving data "
                             f"{lo:g}..{hi:g} s; shorten it.")
    if x0 is None:
        if drivers.reference_q is None:
            raise InputError("give x0: the drivers carry no reference motion.")
        x0 = np.concatenate([drivers.reference_q(t0)[system.free],
                             drivers.reference_qd(t0)[system.free]])
    x0 = np.asarray(x0, dtype=float).reshape(-1)
    if x0.size != 2 * system.nf:
        raise InputError(f"x0 has {x0.size} values; the leg with free "
                         f"{', '.join(free)} needs {2 * system.nf} (angles, then rates).")
    try:
        sim = simulate_partitioned(system, (t0, t1), x0, options=options,
                                   events=[*(fall.events(system) if fall else ()), *events],
                                   progress=progress, t_eval=t_eval)
        error = None
    except SimulationDiverged as exc:
        sim, error = exc.partial, exc
    sim = _with_ground_reaction(system, sim, ground_z)
    if error is not None:
        raise SimulationDiverged(str(error), partial=sim)
    return sim


def _with_ground_reaction(system: LegSystem, sim: SimulationResult, ground_z: float
                          ) -> SimulationResult:
    """The result with the foot's ground reaction and COP (when the foot is prescribed)."""
    if not all(i in system.pres for i in range(3)):
        return sim
    n = len(sim.t)
    grf, cop = np.zeros((n, 3)), np.zeros((n, 3))
    finite = np.all(np.isfinite(sim.q), axis=1)
    grf[finite], cop[finite], _ = system._grf(sim.q[finite], sim.reaction[finite], ground_z)
    return replace(sim, grf=grf, cop=cop)


# ----------------------------------------------------------------------------- rod
@dataclass(frozen=True)
class RodForces:
    """End loads on the rod (thesis Figs. 3.2.4-3.2.5), callables of time t (s).

    Attributes:
        top_force: t -> (2,) force at the top (end A), N: (X, Z) lab components for
            ``ForceFrame.INERTIAL``, (x, z) rod components (x across, z along the rod
            toward the top) for ``ForceFrame.BODY``.
        top_moment: t -> float, moment about +Y at the top, N m.
        bottom_force: t -> (2,) force at the bottom (end B), same frame as the top's.
    """

    top_force: Callable[[float], np.ndarray]
    top_moment: Callable[[float], float]
    bottom_force: Callable[[float], np.ndarray]


def _to_world(force2, pitch, frame: ForceFrame) -> np.ndarray:
    fx, fz = float(force2[0]), float(force2[1])
    if frame is ForceFrame.BODY:  # rod x axis = (cos, -sin), z axis = (sin, cos)
        c, s = np.cos(pitch), np.sin(pitch)
        fx, fz = fx * c + fz * s, -fx * s + fz * c
    return np.array([fx, 0.0, fz])


def rod_loads(forces: RodForces, t: float, pitch: float, frame: ForceFrame) -> list[Load]:
    """The rod's end loads at time t as world-frame :class:`Load` objects."""
    return [Load("top", _to_world(forces.top_force(t), pitch, frame),
                 moment=np.array([0.0, float(forces.top_moment(t)), 0.0])),
            Load("bottom", _to_world(forces.bottom_force(t), pitch, frame))]


@dataclass(frozen=True, eq=False)
class RodEndLoads(Force):
    """The rod's end loads as an applied force (frame components turn with the rod)."""

    model: Model
    forces: RodForces
    frame: ForceFrame
    name: str = "load"
    needs = Kinematics.JACOBIANS

    def add(self, tau, t, q, v, data) -> None:
        """Add J^T w of both end loads at t."""
        tau += generalized_load(self.model, data, rod_loads(self.forces, t, q[2], self.frame))


def rod_system(model: Model, forces: RodForces, frame: ForceFrame) -> PartitionedSystem:
    """The free rod (x, z, theta all free) driven by its end loads in ``frame``."""
    if model.kind != "rod":
        raise InputError(f"simulate_rod needs the rod model, got '{model.kind}'.")
    nv = model.pin_model.nv

    def motion(t):
        return np.zeros(nv), np.zeros(nv), np.zeros(nv)

    return PartitionedSystem(model, range(nv), motion,
                             [RodEndLoads(model, forces, ForceFrame(frame))])


def simulate_rod(model: Model, forces: RodForces, t_span, x0, *, frame: ForceFrame,
                 options: IntegratorOptions, events: Sequence[Event] = (),
                 progress: bool = False, t_eval=None) -> SimulationResult:
    """Simulate the free rod (x, z, theta all free) driven by its end forces.

    Args:
        model: The rod (``load_model("rod")``).
        forces: End loads (:class:`RodForces`) in ``frame``.
        t_span: (t0, t1) s.
        x0: (6,) [x, z, theta, x', z', theta'] (COM m, rad; rates).
        frame: INERTIAL (lab components) or BODY (rod components), thesis 3.2.3-3.2.4.
        options: Integrator options.
        events: Terminal events on x.
        progress: Progress bar.
        t_eval: Optional output times, s.
    """
    frame = ForceFrame(frame)
    system = rod_system(model, forces, frame)
    try:
        sim = simulate_partitioned(system, tuple(t_span), np.asarray(x0, dtype=float),
                                   options=options, events=events, progress=progress,
                                   t_eval=t_eval)
    except SimulationDiverged as exc:
        partial = replace(exc.partial, extra={"force_frame": frame.value})
        raise SimulationDiverged(str(exc), partial=partial) from None
    return replace(sim, extra={"force_frame": frame.value})
