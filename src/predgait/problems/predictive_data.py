"""Measured data for the predictive gait7 problem: reference, initial guess, speed, duration.

The measured walk mapped onto gait7 (:mod:`predgait.dynamics.gait7_motion`) is cut
from a right heel strike to the next left one (half cycle) or the next right one (full
cycle) and sampled at the collocation nodes by cubic splines. The bundled trial is
treadmill-like (the stance foot moves backward in the lab): the belt velocity is the
median forward velocity of the loaded feet (:func:`belt_velocity`), and the guess and
reference are the overground equivalent, base_x - belt * (t - start). The HAT height of the
guess is shifted by one constant so that the lowest contact point sits ``sink`` below
the floor at the median node: the marker-based hip height and the model's segment
lengths do not put the feet exactly on the floor, and a guess deep in a stiff contact
starts Ipopt far from feasibility.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predgait.dynamics.drivers import SampledHistory
from predgait.dynamics.gait7_motion import Gait7Motion, frame_positions
from predgait.errors import InputError
from predgait.models.gait7 import CONTACT_FRAMES
from predgait.models.loading import Model
from predgait.problems.predictive import Cycle, Guess, PredictedGait, Reference


@dataclass(frozen=True)
class MeasuredCycle:
    """A measured cycle at the nodes.

    Attributes:
        start: s, trial clock of the first node (a right heel strike).
        duration: s. speed: m/s, mean forward speed of the HAT over the cycle.
        guess, reference: as :class:`Guess` and :class:`Reference` (N+1 rows).
    """

    start: float
    duration: float
    speed: float
    guess: Guess
    reference: Reference


def cycle_window(motion: Gait7Motion, cycle: Cycle, strike: int = 0) -> tuple[float, float]:
    """(start, end) s of the cycle beginning at the ``strike``-th right heel strike."""
    right, left = motion.heel_strikes["right"], motion.heel_strikes["left"]
    if strike >= right.size:
        raise InputError(f"the trial has {right.size} right heel strikes, not {strike + 1}.")
    start = float(right[strike])
    ends = right[right > start + 0.2] if cycle is Cycle.FULL else left[left > start + 0.1]
    if ends.size == 0:
        raise InputError(f"no {'right' if cycle is Cycle.FULL else 'left'} heel strike "
                         f"after {start:.3f} s: the trial does not hold a {cycle.value} cycle.")
    return start, float(ends[0])


def belt_velocity(motion: Gait7Motion, threshold: float = 20.0) -> float:
    """Median X velocity (m/s) of the sole mid-points of feet loaded above ``threshold`` N.

    About 0 over ground, the (negative) belt speed on a treadmill.
    """
    speeds = []
    for side, s in (("right", "r"), ("left", "l")):
        sole = 0.5 * (motion.points[f"heel_{s}"][:, 0] + motion.points[f"toe_{s}"][:, 0])
        loaded = np.interp(motion.time, motion.plate_time, motion.plate_fz[side]) > threshold
        speeds.append(np.gradient(sole, motion.time)[loaded])
    speeds = np.concatenate(speeds)
    return float(np.median(speeds)) if speeds.size else 0.0


def carrying_depth(model: Model, contact, share: float = 0.5) -> float:
    """Depth (m) at which one contact point carries ``share`` of body weight (static).

    The guess's sink: a guess whose feet barely touch (3 mm) starts in free fall and
    Ipopt ends infeasible; at half body weight per point it converges.
    """
    load = share * model.total_mass() * model.gravity
    return float((load / contact.stiffness) ** (1.0 / contact.exponent))


def measured_cycle(model: Model, motion: Gait7Motion, cycle: Cycle, intervals: int, *,
                   ground_z: float, sink: float) -> MeasuredCycle:
    """Reference and guess of the first measured cycle at ``intervals`` + 1 nodes.

    ``sink`` (m): depth of the lowest contact point at the median node (see
    :func:`carrying_depth`).
    """
    start, end = cycle_window(motion, cycle)
    t = np.linspace(start, end, intervals + 1)
    q = SampledHistory(motion.time, motion.q, name="gait7 q")
    v = SampledHistory(motion.time, motion.v, name="gait7 v")
    a = SampledHistory(motion.time, motion.a, name="gait7 a")
    belt = belt_velocity(motion)
    guess_q = np.array([q(tk) for tk in t])
    guess_v = np.array([v(tk) for tk in t])
    x = model.coordinate_index("base_x")
    guess_q[:, x] -= belt * (t - start)
    guess_v[:, x] -= belt
    heights = frame_positions(model, guess_q, CONTACT_FRAMES)
    lowest = np.min([p[:, 2] for p in heights.values()], axis=0)
    guess_q[:, model.coordinate_index("base_z")] += ground_z - sink - np.median(lowest)
    fz = np.column_stack([np.interp(t, motion.plate_time, motion.plate_fz[s])
                          for s in ("right", "left")])
    speed = float((guess_q[-1, x] - guess_q[0, x]) / (end - start))
    return MeasuredCycle(start=start, duration=end - start, speed=speed,
                         guess=Guess(guess_q, guess_v,
                                     np.array([a(tk) for tk in t])),
                         reference=Reference(guess_q.copy(), fz))


def resampled_guess(gait: PredictedGait, intervals: int) -> Guess:
    """A solution linearly resampled onto ``intervals`` + 1 uniform nodes (same cycle)."""
    old = np.linspace(0.0, 1.0, gait.t.size)
    new = np.linspace(0.0, 1.0, intervals + 1)

    def resample(x):
        return np.column_stack([np.interp(new, old, column) for column in x.T])

    return Guess(resample(gait.q), resample(gait.v), resample(gait.a))
