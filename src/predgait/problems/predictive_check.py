"""Checks of a predicted gait7 cycle with Pinocchio, and gait measures.

:func:`node_residuals` re-evaluates the dynamics at every node with Pinocchio's RNEA and
the engine's own contact force (:class:`predgait.dynamics.forces.GroundContact`) and
passive elements (:func:`predgait.dynamics.forces.passive_generalized`), independent of
the ADAM expressions the optimiser used: the unactuated base rows must vanish and the
joint rows must equal the optimiser's torques. :func:`full_stride` turns a symmetric
half cycle into a stride (the second half mirrored and shifted), :func:`from_heel_strike`
re-phases that periodic stride to start at a foot's own heel strike (what gait plots and
comparisons of two gaits use), and :func:`gait_measures` gives stance phases, step lengths
per side, cadence and the vertical GRF's peaks.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from predgait.data.events import runs_of
from predgait.dynamics.forces import GroundContact, passive_generalized
from predgait.dynamics.passive import LinearSpringDamper, PassiveJoint
from predgait.errors import PredgaitError
from predgait.models.gait7 import CONTACT_FRAMES
from predgait.models.loading import Model
from predgait.problems.predictive import JOINTS, Cycle, PredictedGait, mirror_matrix

#: A foot carrying more than this (N) is in stance.
STANCE_THRESHOLD_N = 20.0


def passive_joints(springs) -> dict[str, PassiveJoint]:
    """The engine's passive elements of the predictive problem's springs."""
    out: dict[str, list] = {}
    for s in springs:
        out.setdefault(s.joint, []).append(LinearSpringDamper(s.k, s.c, s.theta0))
    return {joint: PassiveJoint(tuple(items)) for joint, items in out.items()}


def node_residuals(model: Model, gait: PredictedGait, contact, ground_z: float,
                   springs=()) -> dict:
    """Pinocchio's re-evaluation of the dynamics at every node.

    Returns:
        ``base_residual_n`` (N+1, 3): RNEA - contact on the base rows (N, N, N m), should
        be 0; ``torque_mismatch_n_m`` (N+1, 6): RNEA - contact - passive - tau on the
        joint rows; ``defects`` max |trapezoidal defect| of q (m, rad) and v (m/s, rad/s).
    """
    pm = model.pin_model
    kin, dyn = pm.createData(), pm.createData()
    ground = GroundContact(model, CONTACT_FRAMES, contact, ground_z, planar=True)
    joints = [model.coordinate_index(j) for j in JOINTS]
    passive = passive_generalized(model, passive_joints(springs), gait.q, gait.v)
    base, mismatch = [], []
    for k, (q, v, a) in enumerate(zip(gait.q, gait.v, gait.a, strict=True)):
        pin.forwardKinematics(pm, kin, q, v)
        pin.computeJointJacobians(pm, kin, q)
        pin.updateFramePlacements(pm, kin)
        r = pin.rnea(pm, dyn, q, v, a) - ground(0.0, q, v, kin)
        base.append(r[:3])
        mismatch.append(r[joints] - passive[k, joints] - gait.tau[k])
    h = np.diff(gait.t)[:, None]
    return {"base_residual_n": np.array(base), "torque_mismatch_n_m": np.array(mismatch),
            "defects": {"q": float(np.abs(np.diff(gait.q, axis=0)
                                          - 0.5 * h * (gait.v[1:] + gait.v[:-1])).max()),
                        "v": float(np.abs(np.diff(gait.v, axis=0)
                                          - 0.5 * h * (gait.a[1:] + gait.a[:-1])).max())}}


def full_stride(model: Model, gait: PredictedGait) -> dict[str, np.ndarray]:
    """t, q, v, a, tau, contact over a whole stride (a half cycle mirrored and appended)."""
    out = {"t": gait.t, "q": gait.q, "v": gait.v, "a": gait.a, "tau": gait.tau,
           "contact": gait.contact}
    if gait.cycle is Cycle.FULL:
        return out
    mirror = mirror_matrix(model, Cycle.HALF)
    shift = np.zeros(model.nq)
    shift[model.coordinate_index("base_x")] = gait.speed * gait.duration
    half = len(JOINTS) // 2
    second = {"t": gait.t[1:] + gait.duration, "q": gait.q[1:] @ mirror.T + shift,
              "v": gait.v[1:] @ mirror.T, "a": gait.a[1:] @ mirror.T,
              "tau": np.roll(gait.tau[1:], half, axis=1),
              "contact": np.roll(gait.contact[1:], 2, axis=1)}
    return {k: np.concatenate([out[k], second[k]]) for k in out}


def heel_strikes(stride: dict[str, np.ndarray]) -> dict[str, int]:
    """Node of each foot's touch-down in a periodic stride.

    The first node whose vertical force exceeds STANCE_THRESHOLD_N after one that does
    not, wrapping around; the last node is the next stride's first and is not counted.

    Raises:
        PredgaitError: A foot never leaves or never touches the ground.
    """
    out = {}
    for i, side in enumerate(("right", "left")):
        on = stride["contact"][:-1, 2 * i:2 * i + 2, 1].sum(axis=1) > STANCE_THRESHOLD_N
        onsets = np.flatnonzero(on & ~np.roll(on, 1))
        if onsets.size == 0:
            raise PredgaitError(f"the predicted stride has no {side} heel strike (the foot "
                                "never leaves or never touches the ground): not a gait")
        out[side] = int(onsets[0])
    return out


def from_heel_strike(model: Model, stride: dict[str, np.ndarray],
                     side: str = "right") -> dict[str, np.ndarray]:
    """The periodic ``stride`` re-phased to start at ``side``'s heel strike.

    Time starts at 0 at that heel strike; nodes before it move to the end (one stride
    period later, the base moved forward by the stride length), so the result is the same
    gait seen from the foot's own touch-down, as gait-lab curves are. Adds ``heel_x``
    (n, 2): the lab X of the right and left heel contact points (m), and
    ``heel_strike_index``: the node of each foot's touch-down in the result.
    """
    start = heel_strikes(stride)[side]
    period = stride["t"][-1] - stride["t"][0]
    advance = np.zeros(model.nq)
    advance[model.coordinate_index("base_x")] = (stride["q"][-1] - stride["q"][0])[
        model.coordinate_index("base_x")]
    out = {}
    for key, values in stride.items():
        body = values[:-1]
        rolled = np.concatenate([body[start:], body[:start + 1]])
        if key == "t":
            rolled[len(body) - start:] += period
            rolled = rolled - rolled[0]
        elif key == "q":
            rolled[len(body) - start:] += advance
        out[key] = rolled
    data = model.pin_model.createData()
    frames = [model.frame_id(name) for name in ("heel_r", "heel_l")]
    heel_x = []
    for q in out["q"]:
        pin.framesForwardKinematics(model.pin_model, data, q)
        heel_x.append([data.oMf[f].translation[0] for f in frames])
    out["heel_x"] = np.array(heel_x)
    out["heel_strike_index"] = heel_strikes(out)
    return out


def step_lengths(aligned: dict[str, np.ndarray]) -> dict[str, float]:
    """Right and left step lengths (m) of a stride from :func:`from_heel_strike`.

    A step is named by the foot that lands: the left step runs from the right heel at
    right heel strike to the left heel at left heel strike, the right step from there to
    the right heel at the next right heel strike; the two add up to the stride length.
    """
    left_strike = aligned["heel_strike_index"]["left"]
    right_at_strike = aligned["heel_x"][0, 0]
    left_at_strike = aligned["heel_x"][left_strike, 1]
    right_next = aligned["heel_x"][-1, 0]
    return {"left": float(left_at_strike - right_at_strike),
            "right": float(right_next - left_at_strike)}


def stance_profile(fz: np.ndarray, body_weight: float) -> dict:
    """Loading peak, mid-stance valley and push-off peak of one foot's vertical force.

    The stance (force > STANCE_THRESHOLD_N, the first run after a touch-down, wrapping
    around the stride's end) is cut in thirds: the maxima of the first and last thirds
    and the minimum of the middle one, in body weights. A double bump has both peaks
    above the valley.
    """
    on = fz > STANCE_THRESHOLD_N
    onsets = np.flatnonzero(on & ~np.roll(on, 1))
    if onsets.size == 0:
        return {"loading_peak_bw": 0.0, "valley_bw": 0.0, "push_off_peak_bw": 0.0}
    rolled, flags = np.roll(fz, -onsets[0]), np.roll(on, -onsets[0])
    end = int(np.argmin(flags)) if not flags.all() else flags.size
    stance = rolled[:end]
    thirds = np.array_split(stance, 3) if stance.size >= 3 else [stance] * 3
    return {"loading_peak_bw": float(thirds[0].max() / body_weight),
            "valley_bw": float(thirds[1].min() / body_weight),
            "push_off_peak_bw": float(thirds[2].max() / body_weight)}


def gait_measures(stride: dict[str, np.ndarray], speed: float, body_weight: float,
                  steps: dict[str, float] | None = None) -> dict:
    """Stance phases, step lengths and cadence, vertical GRF peaks of a stride.

    Per foot: ``stance_phases`` (runs of vertical force > STANCE_THRESHOLD_N, counting a
    run that wraps around the cycle end once), ``stance_fraction``, ``peak_fz_n``,
    :func:`stance_profile` (``body_weight`` N) and ``step_length_m`` (from ``steps``,
    :func:`step_lengths`; ``None`` when not given). ``step_length_m`` at the top is the
    mean step (speed * stride time / 2); cadence = 2 steps per stride time (steps/min).
    """
    t = stride["t"]
    period = t[-1] - t[0]
    out = {"stride_time_s": float(period), "speed_m_s": float(speed),
           "step_length_m": float(speed * period / 2), "cadence_steps_min": 120.0 / period}
    for i, side in enumerate(("right", "left")):
        fz = stride["contact"][:, 2 * i:2 * i + 2, 1].sum(axis=1)
        on = fz[:-1] > STANCE_THRESHOLD_N          # last node = first node of next stride
        runs = list(runs_of(on))
        if len(runs) > 1 and on[0] and on[-1]:
            runs = runs[1:]                          # the wrapped run counts once
        out[side] = {"stance_phases": len(runs), "stance_fraction": float(on.mean()),
                     "peak_fz_n": float(fz.max()),
                     "vertical_grf": stance_profile(fz[:-1], body_weight),
                     "step_length_m": None if steps is None else steps[side]}
    return out

