"""Gait events: heel strike and toe off from force plates or from kinematics.

Kinematic detection follows Zeni, Richards & Higginson (2008), Gait & Posture 27:710-714:
heel strike at the maxima of the heel's forward position relative to the pelvis, toe off
at the minima of the toe's forward position relative to the pelvis (lab X forward).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from predgait.data.frames import parse_enum
from predgait.data.resample import CONTACT_THRESHOLD
from predgait.data.trial import ForcePlate, Markers
from predgait.errors import InputError


class Side(StrEnum):
    """Body side."""

    RIGHT = "right"
    LEFT = "left"


@dataclass(frozen=True, eq=False)
class Events:
    """Gait events of one side.

    Attributes:
        side: the foot.
        heel_strikes: (h,) s, increasing.
        toe_offs: (o,) s, increasing.
    """

    side: Side
    heel_strikes: np.ndarray
    toe_offs: np.ndarray

    def shifted(self, t0: float) -> Events:
        """Events with time zero moved to ``t0`` (s)."""
        return dataclasses.replace(self, heel_strikes=self.heel_strikes - t0,
                                   toe_offs=self.toe_offs - t0)

    def cycles(self) -> list[tuple[float, float]]:
        """Consecutive heel strikes (start, end) of full gait cycles, s."""
        hs = self.heel_strikes
        return [(float(a), float(b)) for a, b in zip(hs[:-1], hs[1:], strict=True)]


def runs_of(mask: np.ndarray) -> list[slice]:
    """Runs of consecutive True samples of a boolean array (e.g. a plate contact), as slices.

    The one run detector: contacts (force above a threshold), stances, flagged frames.
    """
    edges = np.flatnonzero(np.diff(np.concatenate([[0], np.asarray(mask).astype(int), [0]])))
    return [slice(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _crossings(time: np.ndarray, signal: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray]:
    """Times of upward and downward crossings of ``level``, linearly interpolated."""
    above = signal >= level
    change = np.flatnonzero(np.diff(above.astype(int)))
    t = time[change] + (level - signal[change]) * (time[change + 1] - time[change]) / (
        signal[change + 1] - signal[change])
    rising = above[change + 1]
    return t[rising], t[~rising]


def events_from_plate(plate: ForcePlate, side: Side | str, *,
                      threshold: float = CONTACT_THRESHOLD, min_duration: float = 0.05) -> Events:
    """Heel strikes and toe offs from a plate's vertical-force threshold crossings.

    A contact that is already under way at the start of the record gives no heel strike;
    one still under way at the end gives no toe off.

    Args:
        plate: plate (or per-foot GRF) in the lab frame.
        side: the foot on this plate.
        threshold: N, vertical-force level.
        min_duration: s; contacts or swings shorter than this are ignored as noise.
    """
    side = parse_enum(side, Side, field="side")
    up, down = _crossings(plate.time, plate.force[:, 2], threshold)
    changes = sorted([(t, True) for t in up] + [(t, False) for t in down])
    kept: list[tuple[float, bool]] = []
    for t, rising in changes:
        if kept and t - kept[-1][0] < min_duration:
            kept.pop()
            continue
        kept.append((t, rising))
    strikes = np.array([t for t, r in kept if r])
    return Events(side, strikes, np.array([t for t, r in kept if not r]))


def events_from_kinematics(markers: Markers, side: Side | str, *, heel: str, toe: str,
                           pelvis: Sequence[str], min_interval: float = 0.5) -> Events:
    """Zeni et al. (2008) events from lab-frame markers (X forward).

    Args:
        markers: filtered, gap-free markers, lab frame.
        side: foot whose events are wanted.
        heel: heel marker of that foot.
        toe: toe marker of that foot.
        pelvis: pelvis markers whose mean is the reference (e.g. both ASIS and sacrum).
        min_interval: s, smallest time between two events of the same kind.
    """
    side = parse_enum(side, Side, field="side")
    origin = np.mean([markers.get(n)[:, 0] for n in pelvis], axis=0)
    heel_x = markers.get(heel)[:, 0] - origin
    toe_x = markers.get(toe)[:, 0] - origin
    if np.isnan(heel_x).any() or np.isnan(toe_x).any():
        raise InputError(f"{markers.source}: markers {heel}, {toe} or {list(pelvis)} have gaps; "
                         "fill them before detecting events.")
    from scipy.signal import find_peaks  # heavy: imported by the commands that detect events

    distance = max(1, int(round(min_interval * markers.rate)))

    def peaks(signal):
        span = np.ptp(signal)
        index, _ = find_peaks(signal, distance=distance, prominence=0.2 * span)
        return markers.time[index]

    return Events(side, peaks(heel_x), peaks(-toe_x))


def detect_events(source: ForcePlate | Markers, side: Side | str, *,
                  threshold: float = CONTACT_THRESHOLD, heel: str | None = None,
                  toe: str | None = None, pelvis: Sequence[str] = ()) -> Events:
    """Gait events from a force plate (threshold) or, without one, from markers (Zeni).

    Args:
        source: a ForcePlate of that foot, or Markers.
        side: the foot.
        threshold: N, for plates.
        heel: heel marker name, for markers.
        toe: toe marker name, for markers.
        pelvis: pelvis marker names, for markers.
    """
    if isinstance(source, ForcePlate):
        return events_from_plate(source, side, threshold=threshold)
    if heel is None or toe is None or not pelvis:
        raise InputError("detect_events from markers needs heel=, toe= and pelvis= marker names.")
    return events_from_kinematics(source, side, heel=heel, toe=toe, pelvis=pelvis)
