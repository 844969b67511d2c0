"""Inputs of forward synthesis: time histories of prescribed motion, torques and loads.

Measured histories (from inverse dynamics, a file or a function) are interpolated with
cubic splines with "not-a-knot" ends (:class:`predgait.numerics.spline.CubicSpline`,
SciPy's default CubicSpline in NumPy), which pass through every sample and are C2, so a
variable integration step can ask for inputs between the measured frames. The thesis
(3.3.4) used Newton's divided difference formula for the same purpose; a spline avoids the
oscillation of high-degree divided-difference polynomials and has the same accuracy near
the samples.

Outside the sampled time range the histories are held constant at the end values
(no extrapolation); simulations check their time span against ``time_range``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from predgait.errors import InputError
from predgait.numerics.spline import CubicSpline

TimeFunction = Callable[[float], np.ndarray]


class SampledHistory:
    """Cubic-spline interpolation of sampled columns, memoised on the last time.

    Calling it returns the (k,) interpolated row at time t (s). Integrators evaluate
    the inputs several times at one time (the modified-Euler correctors), so the last
    row is cached. Returned arrays must not be modified by callers.

    Args:
        time: (n,) increasing sample times, s (n >= 2).
        values: (n, k) samples.
        name: Name for messages.
    """

    def __init__(self, time, values, *, name: str = "history"):
        time = np.asarray(time, dtype=float).reshape(-1)
        values = np.asarray(values, dtype=float)
        values = values.reshape(time.size, -1) if values.ndim != 2 else values
        if time.size < 2 or np.any(np.diff(time) <= 0):
            raise InputError(f"{name}: needs at least 2 samples at increasing times.")
        if values.shape[0] != time.size or not np.all(np.isfinite(values)):
            raise InputError(f"{name}: expected {time.size} finite rows of samples, got "
                             f"shape {values.shape} (NaN/Inf present or wrong length).")
        self.name = name
        self.t0, self.t1 = float(time[0]), float(time[-1])
        self._spline = CubicSpline(time, values) if time.size > 2 else None
        self._time, self._values = time, values
        self._last_t = None
        self._last = None
        self._sampled = None  # (times, rows) of the latest sample()

    @property
    def time(self) -> np.ndarray:
        """(n,) sample times, s (not to be modified)."""
        return self._time

    @property
    def values(self) -> np.ndarray:
        """(n, k) samples (not to be modified)."""
        return self._values

    def __call__(self, t: float) -> np.ndarray:
        """Interpolated (k,) row at t (s), held at the end values outside the range."""
        if t == self._last_t:
            return self._last
        tc = min(max(t, self.t0), self.t1)
        if self._spline is None:
            row = np.array([np.interp(tc, self._time, col) for col in self._values.T])
        else:
            row = self._spline(tc)
        self._last_t, self._last = t, row
        return row

    def sample(self, times: np.ndarray) -> np.ndarray:
        """(m, k) rows at the (m,) ``times`` at once (as calling at each; the last kept)."""
        if self._sampled is not None and self._sampled[0] is times:
            return self._sampled[1]
        clipped = np.clip(np.asarray(times, dtype=float), self.t0, self.t1)
        if self._spline is None:
            rows = np.column_stack([np.interp(clipped, self._time, c) for c in self._values.T])
        else:
            rows = self._spline.values(clipped)
        self._sampled = (times, rows)
        return rows

    def derivative(self, order: int = 1) -> Callable[[float], np.ndarray]:
        """Time derivative of the spline, t -> (k,) (zero outside the range)."""
        if self._spline is None:
            slope = np.diff(self._values, axis=0)[0] / (self.t1 - self.t0)
            return lambda t: slope.copy() if order == 1 else np.zeros_like(slope)
        spline = self._spline.derivative(order)

        def evaluate(t):
            if t < self.t0 or t > self.t1:
                return np.zeros(self._values.shape[1])
            return spline(t)

        return evaluate


class Columns:
    """Some columns of a history: t -> (k,); ``sample(times)`` -> (m, k).

    Attributes:
        history: the :class:`SampledHistory`. columns: the slice of its columns.
    """

    def __init__(self, history: SampledHistory, columns: slice):
        self.history, self.columns = history, columns

    def __call__(self, t: float) -> np.ndarray:
        """The (k,) columns at t (s)."""
        return self.history(t)[self.columns]

    def sample(self, times: np.ndarray) -> np.ndarray:
        """The (m, k) columns at the (m,) ``times``."""
        return self.history.sample(times)[:, self.columns]


def sample(function: TimeFunction, times: np.ndarray) -> np.ndarray:
    """(m, k) values of a time function at the (m,) ``times``: at once when it can."""
    if hasattr(function, "sample"):
        return function.sample(times)
    if isinstance(function, Constant):
        return np.broadcast_to(function.value, (len(times), function.value.size))
    return np.array([function(t) for t in times], dtype=float).reshape(len(times), -1)


class Constant:
    """A time function returning a fixed (copied) array; ``value`` is that array."""

    def __init__(self, value):
        self.value = np.array(value, dtype=float)

    def __call__(self, t: float) -> np.ndarray:
        """The value (the same array at every t; callers must not modify it)."""
        return self.value


def constant(value) -> Constant:
    """A time function returning a fixed (copied) array."""
    return Constant(value)


def is_zero(function) -> bool:
    """True when ``function`` is a :class:`Constant` equal to zero (nothing to apply)."""
    return isinstance(function, Constant) and not function.value.any()


@dataclass(frozen=True)
class LegDrivers:
    """What drives the leg: prescribed foot motion, joint torques, hip load.

    All fields are callables of time t (s). Build them from inverse-dynamics results
    with :meth:`from_inverse`, or hold them constant with :meth:`still`.

    Attributes:
        prescribed_q: t -> (3,) foot base coordinates base_x, base_z (m), base_pitch (rad).
        prescribed_qd: t -> (3,) their rates.
        prescribed_qdd: t -> (3,) their accelerations.
        joint_torque: t -> (2,) active ankle and knee torques, N m, MODEL sign (the
            torque about +Y on the distal segment; knee flexion moment = -tau_knee).
        hip_force: t -> (3,) N, lab frame, pelvis on thigh at ``hip_center``.
        hip_moment: t -> (3,) N m, lab frame (only Y acts in the plane).
        reference_q: Optional t -> (5,) measured coordinates (initial state, feedback,
            deviation).
        reference_qd: Optional t -> (5,) measured velocities.
        reference_qdd: Optional t -> (5,) measured accelerations (needed when a joint
            coordinate is prescribed rather than free).
        time_range: (t0, t1) s where the histories are sampled, or None (any time).
        passive: Joint name ("ankle", "knee", "hip") -> PassiveJoint: the passive
            elements acting in the run (clinical angles; the one place they are given).
        passive_offset: Optional t -> (5,) generalised passive force of ``passive`` at
            the measured motion, subtracted in the run (set by :meth:`from_inverse`: the
            inverse-dynamics moments already contain the elements).
        hip_in_thigh_frame: The hip force and moment held fixed in the thigh frame
            (thesis 3.3.3 and Appendix A: forces at a segment's proximal joint expressed
            in its own coordinate system): their components on the thigh's axes at the
            measured motion, turning with the simulated thigh. False: fixed in the lab.
    """

    prescribed_q: TimeFunction
    prescribed_qd: TimeFunction
    prescribed_qdd: TimeFunction
    joint_torque: TimeFunction
    hip_force: TimeFunction
    hip_moment: TimeFunction
    reference_q: TimeFunction | None = None
    reference_qd: TimeFunction | None = None
    reference_qdd: TimeFunction | None = None
    time_range: tuple[float, float] | None = None
    passive: Mapping = field(default_factory=dict)
    passive_offset: TimeFunction | None = None
    hip_in_thigh_frame: bool = False

    @classmethod
    def still(cls, base=(0.0, 0.0, 0.0), *, joint_torque=(0.0, 0.0),
              hip_force=(0.0, 0.0, 0.0), hip_moment=(0.0, 0.0, 0.0),
              passive: Mapping | None = None) -> LegDrivers:
        """Foot held still at ``base``; constant torques and hip load (default zero).

        The thesis' collapse test (4.2): foot fixed, no moments, no forces; ``passive``
        elements act on the joints.
        """
        zero = constant(np.zeros(3))
        return cls(prescribed_q=constant(base), prescribed_qd=zero, prescribed_qdd=zero,
                   joint_torque=constant(joint_torque), hip_force=constant(hip_force),
                   hip_moment=constant(hip_moment), passive=dict(passive or {}))

    def with_passive(self, passive: Mapping | None) -> LegDrivers:
        """These drivers with passive elements ADDED to the drive (torques unchanged).

        A what-if: the elements act on the whole motion, not only on its deviation from
        the measured one (compare :meth:`from_inverse` with ``passive``).
        """
        return replace(self, passive=dict(passive or {}), passive_offset=None)

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(reference_q(t), reference_qd(t)): the feedback reference."""
        return self.reference_q(t), self.reference_qd(t)

    @classmethod
    def from_samples(cls, time, q, v, a, tau, hip_force, hip_moment) -> LegDrivers:
        """Drivers interpolating sampled histories (all arrays with n rows).

        Args:
            time: (n,) s.
            q: (n, 5) leg coordinates (m, rad); the base columns are prescribed, the
                joint columns are the reference motion.
            v: (n, 5) velocities.
            a: (n, 5) accelerations.
            tau: (n, 5) generalised forces; columns 3:5 are the ankle, knee torques.
            hip_force: (n, 3) N.
            hip_moment: (n, 3) N m.
        """
        q, v, a, tau = (np.asarray(x, dtype=float) for x in (q, v, a, tau))
        stacked = np.column_stack([q, v, a, tau[:, 3:5], hip_force, hip_moment])
        history = SampledHistory(time, stacked, name="leg drivers")
        return cls(prescribed_q=Columns(history, slice(0, 3)),
                   prescribed_qd=Columns(history, slice(5, 8)),
                   prescribed_qdd=Columns(history, slice(10, 13)),
                   joint_torque=Columns(history, slice(15, 17)),
                   hip_force=Columns(history, slice(17, 20)),
                   hip_moment=Columns(history, slice(20, 23)),
                   reference_q=Columns(history, slice(0, 5)),
                   reference_qd=Columns(history, slice(5, 10)),
                   reference_qdd=Columns(history, slice(10, 15)),
                   time_range=(history.t0, history.t1))

    @classmethod
    def from_inverse(cls, result, *, torque_offsets=None, passive=None) -> LegDrivers:
        """Drivers from a :class:`predgait.dynamics.inverse_trial.InverseResult`.

        Prescribed foot motion = IK base coordinates (q, v and the inverse-dynamics
        a, so forward and inverse use the same accelerations); torques = RNEA ankle
        and knee torques (+ ``torque_offsets`` (n, 2) or (2,) N m, model sign); hip
        load = the solved hip force and moment; reference = IK coordinates.

        With ``passive`` (joint name -> PassiveJoint), the elements act in the run and
        their generalised force at the measured state (the one sign table,
        :func:`predgait.dynamics.forces.passive_generalized`) is subtracted (thesis
        3.3.3-3.3.4: the same passive elements in the indirect and forward problems;
        the moments of inverse dynamics are active plus passive), so the measured motion
        still solves the forward problem and the elements only act on deviations from
        it. The elements are given here once; the simulation reads them from the drivers.
        """
        from predgait.dynamics.forces import passive_generalized

        tau = np.array(result.tau, dtype=float)
        if torque_offsets is not None:
            tau[:, 3:5] += np.broadcast_to(np.asarray(torque_offsets, dtype=float),
                                           tau[:, 3:5].shape)
        drivers = cls.from_samples(result.time, result.q, result.v, result.a, tau,
                                   result.hip_force, result.hip_moment)
        if not passive:
            return drivers
        offset = SampledHistory(result.time, passive_generalized(
            result.model, passive, np.asarray(result.q), np.asarray(result.v)),
            name="passive moments at the measured motion")
        return replace(drivers, passive=dict(passive), passive_offset=offset)

    def with_torque_change(self, t: np.ndarray, change: np.ndarray) -> LegDrivers:
        """These drivers with a torque change added to the joint torques.

        Args:
            t: (m,) s grid of the change (e.g. a torque-correction solution).
            change: (m, 2) N m ankle and knee torque changes (model sign), linear
                between grid points and held beyond them.
        """
        t = np.asarray(t, dtype=float)
        change = np.asarray(change, dtype=float)
        base = self.joint_torque

        def joint_torque(time):
            return base(time) + np.array([np.interp(time, t, change[:, 0]),
                                          np.interp(time, t, change[:, 1])])

        return replace(self, joint_torque=joint_torque)
