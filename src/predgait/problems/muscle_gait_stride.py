"""A whole stride from a symmetric half stride, from right heel strike, and its measures.

The second half is the first mirrored (left and right coordinates, speeds, muscles and
contact spheres swapped, lateral positions negated, pelvis_tx advanced by the distance of
the half). The stride is then rolled (it is periodic) to start at the right foot's
first touch-down (vertical force rising through :data:`STANCE_THRESHOLD_N`), so that
every curve is "from right heel strike" in fact.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from predgait.problems.muscle_gait import mirror_rows

#: A foot carrying more than this (N) is in stance.
STANCE_THRESHOLD_N = 20.0
#: Row fields of a :class:`Stride` and how each mirrors.
_FIELDS = ("q", "v", "act", "exc", "u", "force", "grf", "points", "speed")


@dataclass(frozen=True, eq=False)
class Stride:
    """A stride at nodes t[0]..t[-1] (the last row = the first one of the next stride).

    Attributes: t (n,) s; q, v (n, nq) model units; act, exc, force (n, m) muscle
    activations, excitations, tendon forces (N); u (n,) lumbar control; grf, points
    (n, k, 3) contact forces (N) and their points (m); speed (n, k) contact point
    horizontal speeds (m/s); distance (m) and duration (s) of the stride.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    act: np.ndarray
    exc: np.ndarray
    u: np.ndarray
    force: np.ndarray
    grf: np.ndarray
    points: np.ndarray
    speed: np.ndarray
    distance: float
    duration: float

    def foot_fz(self, plant) -> np.ndarray:
        """(n, 2) N vertical force of the right and left foot."""
        names = [s.name for s in plant.spheres]
        right = [i for i, n in enumerate(names) if n.endswith("_r")]
        left = [i for i, n in enumerate(names) if n.endswith("_l")]
        return np.column_stack([self.grf[:, right, 2].sum(axis=1),
                                self.grf[:, left, 2].sum(axis=1)])


def full_stride(plant, gait, contact_speed: np.ndarray, *, tx_row: int = 0) -> Stride:
    """The stride of a half-stride solution (``gait``: MuscleGait) and its contact speeds."""
    p = gait.path
    mq = mirror_rows(plant.model.coordinate_names)
    mm = mirror_rows(plant.muscle_names)
    ms = mirror_rows(tuple(s.name for s in plant.spheres))
    half = {"q": p.q, "v": p.v, "act": p.act, "exc": p.exc, "u": p.u, "force": gait.force,
            "grf": gait.grf, "points": gait.points, "speed": contact_speed}
    distance = float(p.q[-1, tx_row] - p.q[0, tx_row])
    lateral = np.array([1.0, -1.0, 1.0])
    second = {"q": p.q[1:][:, mq], "v": p.v[1:][:, mq], "act": p.act[1:][:, mm],
              "exc": p.exc[1:][:, mm], "u": p.u[1:], "force": gait.force[1:][:, mm],
              "grf": gait.grf[1:][:, ms] * lateral, "points": gait.points[1:][:, ms] * lateral,
              "speed": contact_speed[1:][:, ms]}
    second["q"][:, tx_row] += distance
    second["points"][:, :, 0] += distance
    rows = {k: np.concatenate([half[k], second[k]]) for k in _FIELDS}
    t = np.concatenate([p.t, p.t[1:] + p.duration])
    return Stride(t=t, **rows, distance=2 * distance, duration=2 * p.duration)


def from_right_heel_strike(stride: Stride, plant, *, tx_row: int = 0) -> Stride:
    """The same periodic stride, rolled to start at the right foot's touch-down."""
    fz = stride.foot_fz(plant)[:-1, 0]
    on = fz > STANCE_THRESHOLD_N
    onsets = np.flatnonzero(on & ~np.roll(on, 1))
    if onsets.size == 0 or onsets[0] == 0:
        return stride
    k, n = int(onsets[0]), fz.size
    rows = {}
    for name in _FIELDS:
        body = getattr(stride, name)[:-1]
        rolled = np.concatenate([body[k:], body[:k + 1]])
        rows[name] = rolled.copy()
    rows["q"][n - k:, tx_row] += stride.distance
    rows["points"][n - k:, :, 0] += stride.distance
    start = rows["q"][0, tx_row]           # the stride starts at x = 0, its contacts too
    rows["q"][:, tx_row] -= start
    rows["points"][:, :, 0] -= start
    t = stride.t[:n + 1]
    return replace(stride, t=t, **rows)


def _runs(on: np.ndarray) -> int:
    """Number of runs of True in a periodic boolean sequence."""
    starts = on & ~np.roll(on, 1)
    return int(starts.sum()) if not on.all() else 1


def stance_profile(fz: np.ndarray, body_weight: float) -> dict:
    """Peak, loading peak, mid-stance valley and push-off peak (BW) of one stance.

    The stance (the run above the threshold starting at the first touch-down, wrapping
    around) is cut in thirds: the maxima of the first and last third, the minimum of the
    middle one.
    """
    on = fz > STANCE_THRESHOLD_N
    onsets = np.flatnonzero(on & ~np.roll(on, 1))
    start = int(onsets[0]) if onsets.size else 0
    rolled, flags = np.roll(fz, -start), np.roll(on, -start)
    end = int(np.argmin(flags)) if not flags.all() else flags.size
    stance = rolled[:max(end, 3)]
    thirds = np.array_split(stance, 3)
    return {"peak_bw": float(fz.max() / body_weight),
            "loading_peak_bw": float(thirds[0].max() / body_weight),
            "valley_bw": float(thirds[1].min() / body_weight),
            "push_off_peak_bw": float(thirds[2].max() / body_weight)}


def gait_measures(stride: Stride, plant, slip: np.ndarray, body_weight: float) -> dict:
    """Stride length and time, speed, cadence, stance %, toe-off, GRF profile, slip.

    Args:
        stride: from right heel strike.
        plant: the model (sphere names).
        slip: (k,) m per stride of each sphere.
        body_weight: N.
    """
    fz = stride.foot_fz(plant)[:-1]
    period = stride.duration
    out = {"stride_length_m": stride.distance, "stride_time_s": period,
           "speed_m_s": stride.distance / period, "cadence_steps_min": 120.0 / period}
    names = [s.name for s in plant.spheres]
    for i, side in enumerate(("right", "left")):
        on = fz[:, i] > STANCE_THRESHOLD_N
        own = [c for c, n in enumerate(names) if n.endswith("_r" if i == 0 else "_l")]
        foot = {"stance_percent": float(100.0 * on.mean()), "stance_phases": _runs(on),
                "vertical_grf": stance_profile(fz[:, i], body_weight),
                "slip_m": float(max(slip[c] for c in own)),
                "slip_by_sphere_m": {names[c]: float(slip[c]) for c in own}}
        if i == 0:
            off = np.flatnonzero(on[:-1] & ~on[1:])
            foot["toe_off_percent"] = float(100.0 * (off[0] + 1) / fz.shape[0]) \
                if off.size else None
        out[side] = foot
    return out
