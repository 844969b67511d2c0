"""Forward dynamics with prescribed coordinates, and the leg and rod simulations.

With the generalised coordinates split into free (f) and prescribed (p) ones
(the leg: the foot's base_x, base_z, base_pitch follow measured motion; ankle, knee
free), Pinocchio's mass matrix M (``pin.crba``) and bias forces h (gravity, Coriolis,
centrifugal; ``pin.nonLinearEffects``) give::

    a_f      = M_ff^-1 (tau_f - h_f - M_fp a_p)                       (free accelerations)
    lambda_p = M_pp a_p + M_pf a_f + h_p - tau_p                       (reaction on p)

tau = S^T tau_joints + J^T w (applied joint torques, passive moments, feedback and the
external loads w, e.g. the hip force and moment on ``hip_center``). For the leg,
lambda_p is the wrench the ground must apply to the foot for it to follow its
prescribed motion: force (lambda_x, lambda_z) in the lab frame and moment lambda_pitch
about +Y at the foot frame origin (the ankle centre). It is reduced to a force at a
centre of pressure on the ground line (thesis eqs. 3.3.9-3.3.10): the moment about the
heel H, M_H = lambda_pitch + ((A - H) x F)_y, and with no moment left at the COP on the
line z = z_g: COP_x = H_x - (M_H + (H_z - z_g) F_x) / F_z (thesis: COP_x = M_G/H / F_GZ
measured from the heel, the sign following the moment about +Y used here).

This replaces the thesis' 21-equation Newton-Euler system (Appendix A) solved by
Gauss-Jordan at each step; tests/test_forward_thesis.py writes those equations out and
checks that both give the same accelerations and ground reaction.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from predgait.dynamics.drivers import LegDrivers, PDFeedback
from predgait.dynamics.external import Load, joint_forces
from predgait.dynamics.integrators import (
    Event,
    Integration,
    IntegratorOptions,
    integrate,
)
from predgait.dynamics.passive import PassiveJoint
from predgait.errors import InputError, SimulationDiverged
from predgait.models.loading import Model

__all__ = ["ForceFrame", "LegDrivers", "PDFeedback", "LegSystem", "FallLimit",
           "SimulationResult", "simulate_leg", "RodForces", "simulate_rod",
           "rod_accelerations", "reduce_to_cop"]

#: Clinical sign of each passive joint: model torque = sign * M_clin(sign * q, sign * qd).
_PASSIVE_SIGN = {"ankle": 1.0, "knee": -1.0}
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


@dataclass(frozen=True)
class FallLimit:
    """When the leg has fallen (a terminal event; its time is the time to fall).

    Attributes:
        segment_angle_deg: |absolute pitch| of the shank or thigh above this, deg
            (None: not used).
        hip_height: Height of ``hip_center`` below this, m (None: not used).
    """

    segment_angle_deg: float | None = 60.0
    hip_height: float | None = None


def _solve_small(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve a small SPD system; 1x1 and 2x2 in closed form (np.linalg.solve costs ~9 us)."""
    if rhs.size == 1:
        return rhs / matrix[0, 0]
    if rhs.size == 2:
        (a, b), (c, d) = matrix
        det = a * d - b * c
        return np.array([d * rhs[0] - b * rhs[1], a * rhs[1] - c * rhs[0]]) / det
    return np.linalg.solve(matrix, rhs)


class LegSystem:
    """The leg's right-hand side x' = f(t, x) with prescribed coordinates.

    The state is x = [q_f, v_f] (free coordinates, then their velocities). One
    ``pin.Data`` is reused across calls; each call returns a new array.

    Args:
        model: The leg.
        drivers: Prescribed motion, torques, hip load.
        free: Names of the free coordinates (default ankle, knee); the others follow
            ``drivers`` (base coordinates: ``prescribed_*``; joints: ``reference_*``).
        passive: Joint name ("ankle", "knee", "hip") -> passive elements on the
            clinical angle. The hip's acts on the thigh as a moment (no pelvis).
        feedback: Optional PD feedback on the free joints.
    """

    def __init__(self, model: Model, drivers: LegDrivers, *, free=("ankle", "knee"),
                 passive: Mapping[str, PassiveJoint] | None = None,
                 feedback: PDFeedback | None = None):
        if model.kind != "leg":
            raise InputError(f"simulate_leg needs the leg model, got '{model.kind}'.")
        self.model, self.drivers, self.feedback = model, drivers, feedback
        pm = model.pin_model
        self.pm, self.data = pm, pm.createData()
        self.free = np.array([model.coordinate_index(n) for n in free], dtype=int)
        if len(set(self.free.tolist())) != len(self.free) or len(self.free) == 0:
            raise InputError(f"free coordinates {tuple(free)!r} must be distinct and not empty.")
        self.pres = np.array([i for i in range(pm.nv) if i not in self.free], dtype=int)
        self.passive = dict(passive or {})
        for name in self.passive:
            if name not in ("ankle", "knee", "hip"):
                raise InputError(f"passive elements on '{name}': the leg has ankle, knee, hip.")
        joints_prescribed = [i for i in self.pres if i >= 3]
        if joints_prescribed and drivers.reference_qdd is None:
            raise InputError("prescribing a joint needs drivers with reference_q/qd/qdd.")
        self._joint_pres = joints_prescribed
        self.hip_frame = model.frame_id("hip_center")
        self.heel_frame = model.frame_id("heel")
        self.thigh_joint = pm.getJointId("knee")
        self.q = np.zeros(pm.nq)
        self.v = np.zeros(pm.nv)
        self.a = np.zeros(pm.nv)
        self.nf = len(self.free)
        self._lower = np.tril_indices(pm.nv, -1)
        self._ff, self._fp = np.ix_(self.free, self.free), np.ix_(self.free, self.pres)
        self._pp, self._pf = np.ix_(self.pres, self.pres), np.ix_(self.pres, self.free)

    # -- inputs at time t -------------------------------------------------------------
    def prescribed(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Full-length q, v, a of the prescribed coordinates at t (free entries 0)."""
        d = self.drivers
        q, v, a = np.zeros(self.pm.nq), np.zeros(self.pm.nv), np.zeros(self.pm.nv)
        q[:3], v[:3], a[:3] = d.prescribed_q(t), d.prescribed_qd(t), d.prescribed_qdd(t)
        if self._joint_pres:
            j = self._joint_pres
            q[j], v[j], a[j] = d.reference_q(t)[j], d.reference_qd(t)[j], d.reference_qdd(t)[j]
        return q, v, a

    def full_state(self, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, v, a_prescribed) full vectors for time t and state x."""
        q, v, a = self.prescribed(t)
        q[self.free] = x[: self.nf]
        v[self.free] = x[self.nf:]
        return q, v, a

    def generalized_forces(self, t: float, q: np.ndarray, v: np.ndarray
                           ) -> dict[str, np.ndarray]:
        """Applied generalised forces (nv,) by source: active, passive, feedback, hip.

        Needs the frame Jacobian of ``hip_center`` at q (computed here).
        """
        pm, data, d = self.pm, self.data, self.drivers
        nv = pm.nv
        active = np.zeros(nv)
        active[3:5] = d.joint_torque(t)
        passive = np.zeros(nv)
        J = pin.computeFrameJacobian(pm, data, q, self.hip_frame,
                                     pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        for name, joint in self.passive.items():
            if name == "hip":  # hip flexion = -(thigh pitch); moment on thigh about +Y
                pitch, rate = q[2] + q[3] + q[4], v[2] + v[3] + v[4]
                passive += J[4] * -float(joint.moment(-pitch, -rate))
            else:
                i, s = (3, 1.0) if name == "ankle" else (4, -1.0)
                passive[i] += s * float(joint.moment(s * q[i], s * v[i]))
        feedback = np.zeros(nv)
        if self.feedback is not None:
            feedback[self.free] = self.feedback.torque(t, q[self.free], v[self.free], self.free)
            feedback[:3] = 0.0
        hip = J[:3].T @ d.hip_force(t) + J[3:].T @ d.hip_moment(t)
        return {"active": active, "passive": passive, "feedback": feedback, "hip": hip}

    def solve(self, t: float, q: np.ndarray, v: np.ndarray, a: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """(a_free, lambda_p, M, forces) at time t; ``a`` holds the prescribed accelerations."""
        pm, data = self.pm, self.data
        forces = self.generalized_forces(t, q, v)
        tau = forces["active"] + forces["passive"] + forces["feedback"] + forces["hip"]
        M = pin.crba(pm, data, q)  # upper triangle only: mirror it
        M[self._lower] = M.T[self._lower]
        h = pin.nonLinearEffects(pm, data, q, v)
        f, p = self.free, self.pres
        rhs = tau[f] - h[f] - M[self._fp] @ a[p]
        a_free = _solve_small(M[self._ff], rhs)
        lam = M[self._pp] @ a[p] + M[self._pf] @ a_free + h[p] - tau[p]
        forces["bias"] = h
        return a_free, lam, M, forces

    def __call__(self, t: float, x: np.ndarray) -> np.ndarray:
        """Return x' = [v_f, a_f] at time t."""
        q, v, a = self.full_state(t, x)
        a_free = self.solve(t, q, v, a)[0]
        return np.concatenate([x[self.nf:], a_free])

    def ground_reaction(self, t: float, x: np.ndarray, *, ground_z: float = 0.0
                        ) -> tuple[np.ndarray, np.ndarray, float]:
        """Ground reaction (3,) N, COP (3,) m and moment about the heel (N m) at (t, x).

        Only defined when the three base coordinates are prescribed.
        """
        q, v, a = self.full_state(t, x)
        lam = self.solve(t, q, v, a)[1]
        pin.framesForwardKinematics(self.pm, self.data, q)
        heel = self.data.oMf[self.heel_frame].translation
        fx, fz, m_ankle = lam[0], lam[1], lam[2]
        d = np.array([q[0], q[1]]) - heel[[0, 2]]        # ankle (base origin) - heel
        m_heel = m_ankle + d[1] * fx - d[0] * fz
        cop_x = float(reduce_to_cop(fx, fz, m_heel, heel[0], heel[2], ground_z=ground_z))
        cop = np.array([cop_x, 0.0, ground_z if abs(fz) >= COP_THRESHOLD else 0.0])
        return np.array([fx, 0.0, fz]), cop, float(m_heel)

    def fall_events(self, limit: FallLimit | None) -> list[Event]:
        """Terminal events for a fall (names start with "fall")."""
        if limit is None:
            return []
        events = []
        if limit.segment_angle_deg is not None:
            lim = np.radians(limit.segment_angle_deg)

            def angle(t, x):
                q, _, _ = self.full_state(t, x)
                return max(abs(q[2] + q[3]), abs(q[2] + q[3] + q[4])) - lim

            events.append(Event("fall: segment angle", angle, 1))
        if limit.hip_height is not None:
            data = self.pm.createData()

            def height(t, x):
                q, _, _ = self.full_state(t, x)
                pin.framesForwardKinematics(self.pm, data, q)
                return data.oMf[self.hip_frame].translation[2] - limit.hip_height

            events.append(Event("fall: hip height", height, -1))
        return events


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """A forward simulation (leg or rod).

    Attributes:
        t: (n,) s.
        q: (n, nq) all coordinates (prescribed ones included), m and rad.
        qd: (n, nq) velocities.
        qdd: (n, nq) accelerations.
        coordinate_names: (nq,) names.
        free: Names of the integrated coordinates.
        status: "completed", "event" or "diverged".
        time_to_fall: Time of the fall event, s, or None.
        grf: (n, 3) ground reaction on the foot, N, lab frame (leg; None for the rod).
        cop: (n, 3) its COP on the ground line, m (0 when |F_z| < 20 N).
        partial: True when the run diverged and this is what was computed until then.
        message: One line saying how the run ended.
        options: Integrator options used.
        n_rhs_evaluations: Right-hand-side calls.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    coordinate_names: tuple[str, ...]
    free: tuple[str, ...]
    status: str
    time_to_fall: float | None
    grf: np.ndarray | None
    cop: np.ndarray | None
    partial: bool
    message: str
    options: IntegratorOptions
    n_rhs_evaluations: int
    extra: dict = field(default_factory=dict)


def _leg_result(system: LegSystem, run: Integration, partial: bool, ground_z: float,
                options: IntegratorOptions) -> SimulationResult:
    n, nq = len(run.t), system.pm.nq
    q, qd, qdd = np.zeros((n, nq)), np.zeros((n, nq)), np.zeros((n, nq))
    grf, cop = np.zeros((n, 3)), np.zeros((n, 3))
    base_prescribed = all(i in system.pres for i in range(3))
    for k, (t, x) in enumerate(zip(run.t, run.x, strict=True)):
        qk, vk, ak = system.full_state(t, x)
        if np.all(np.isfinite(x)):
            a_free = system.solve(t, qk, vk, ak)[0]
            ak[system.free] = a_free
            if base_prescribed:
                grf[k], cop[k], _ = system.ground_reaction(t, x, ground_z=ground_z)
        q[k], qd[k], qdd[k] = qk, vk, ak
    fall = run.event_time if (run.event_name or "").startswith("fall") else None
    names = system.model.coordinate_names
    return SimulationResult(
        t=run.t, q=q, qd=qd, qdd=qdd, coordinate_names=names,
        free=tuple(names[i] for i in system.free), status=run.status.value,
        time_to_fall=fall, grf=grf if base_prescribed else None,
        cop=cop if base_prescribed else None, partial=partial, message=run.message,
        options=options, n_rhs_evaluations=run.n_rhs_evaluations)


def _integrate(rhs, t_span, x0, options, events, progress, names, t_eval):
    """(Integration, partial, error): a diverged run returns its partial Integration."""
    try:
        run = integrate(rhs, t_span, x0, options=options, events=events,
                        progress=progress, state_names=names, t_eval=t_eval)
    except SimulationDiverged as exc:
        return exc.partial, True, exc
    return run, False, None


def simulate_leg(model: Model, drivers: LegDrivers, t_span: tuple[float, float], x0=None, *,
                 passive: Mapping[str, PassiveJoint] | None = None,
                 feedback: PDFeedback | None = None, options: IntegratorOptions,
                 events: Sequence[Event] = (), fall: FallLimit | None = None,
                 free: Sequence[str] = ("ankle", "knee"), progress: bool = False,
                 t_eval=None, ground_z: float = 0.0) -> SimulationResult:
    """Simulate the leg with the foot (and any non-free coordinate) prescribed.

    Args:
        model: The leg.
        drivers: Prescribed foot motion, joint torques, hip load (:class:`LegDrivers`).
        t_span: (t0, t1) s, inside ``drivers.time_range`` when it is set.
        x0: (2 n_free,) [q_free, v_free] rad, rad/s; None: the reference motion at t0.
        passive: Joint name -> :class:`PassiveJoint` (clinical angle convention).
        feedback: Optional :class:`PDFeedback` on the free joints.
        options: Integrator options.
        events: Further terminal events g(t, x) on x = [q_free, v_free].
        fall: Fall criterion; its event time is ``time_to_fall``.
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
    system = LegSystem(model, drivers, free=free, passive=passive, feedback=feedback)
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
    names = [*free, *(f"{n}_speed" for n in free)]
    run, partial, error = _integrate(system, (t0, t1), x0, options,
                                     [*system.fall_events(fall), *events], progress, names,
                                     t_eval)
    result = _leg_result(system, run, partial, ground_z, options)
    if error is not None:
        raise SimulationDiverged(str(error), partial=result)
    return result


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


def rod_accelerations(model: Model, data: pin.Data, q, v, loads: Sequence[Load]) -> np.ndarray:
    """Rod accelerations (3,) by Pinocchio ABA with the end loads as external forces."""
    pm = model.pin_model
    pin.framesForwardKinematics(pm, data, q)
    fext = joint_forces(model, data, loads)
    return pin.aba(pm, data, q, v, np.zeros(pm.nv), fext).copy()


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
    if model.kind != "rod":
        raise InputError(f"simulate_rod needs the rod model, got '{model.kind}'.")
    frame = ForceFrame(frame)
    data = model.pin_model.createData()

    def rhs(t, x):
        loads = rod_loads(forces, t, x[2], frame)
        return np.concatenate([x[3:], rod_accelerations(model, data, x[:3], x[3:], loads)])

    names = [*model.coordinate_names, *(f"{n}_speed" for n in model.coordinate_names)]
    run, partial, error = _integrate(rhs, tuple(t_span), x0, options, events, progress, names,
                                     t_eval)
    qdd = np.array([rhs(t, x)[3:] if np.all(np.isfinite(x)) else np.full(3, np.nan)
                    for t, x in zip(run.t, run.x, strict=True)]).reshape(-1, 3)
    result = SimulationResult(
        t=run.t, q=run.x[:, :3], qd=run.x[:, 3:], qdd=qdd,
        coordinate_names=model.coordinate_names, free=model.coordinate_names,
        status=run.status.value, time_to_fall=None, grf=None, cop=None, partial=partial,
        message=run.message, options=options, n_rhs_evaluations=run.n_rhs_evaluations,
        extra={"force_frame": frame.value})
    if error is not None:
        raise SimulationDiverged(str(error), partial=result)
    return result

