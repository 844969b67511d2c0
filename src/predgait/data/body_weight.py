"""The body mass the force plates measure during walking.

Over one step taken at the same phase of the gait cycle at both ends, the vertical
momentum of the body returns to its value, so the mean total vertical ground reaction
equals the body weight (Newton's second law on the centre of mass; Winter 2009,
Biomechanics and Motor Control of Human Movement, 4th ed., ch. 5). The phase used here is
each stance's loading peak (the first peak of its vertical force, near the other foot's
toe-off): between the loading peaks of two overlapping stances on different plates the whole
body weight stands on the plates (one foot alone, then both, then the other alone).
subject01 (two plates, four stances): 72.5-72.8 kg (its README: 72.6 kg); walking5.c3d
(two plates, one stance each): 57.9 kg.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from predgait.data.events import runs_of
from predgait.data.trial import ForcePlate
from predgait.errors import InputError

if TYPE_CHECKING:
    from predgait.problemfile import Table

#: Vertical force (N) above which a plate is in contact for this estimate.
CONTACT_N = 50.0
#: Shortest stance (s) used: a walking stance lasts 0.5-0.8 s.
MIN_STANCE_S = 0.3


@dataclass(frozen=True)
class PlateMass:
    """Body mass from the plates: ``mass`` kg (mean of the steps), per step, the windows."""

    mass: float
    steps: tuple[float, ...]
    windows: tuple[tuple[float, float], ...]


def _stances(time: np.ndarray, fz: np.ndarray) -> list[tuple[float, float, int]]:
    """(start s, end s, loading-peak index) of each whole stance on one plate."""
    out = []
    for run in runs_of(fz > CONTACT_N):
        a, b = run.start, run.stop
        if a == 0 or b == fz.size or time[b - 1] - time[a] < MIN_STANCE_S:
            continue   # cut by the recording, or not a stance
        peak = a + int(np.argmax(fz[a:(a + b) // 2]))
        out.append((float(time[a]), float(time[b - 1]), peak))
    return out


def plate_body_mass(plates: Sequence[ForcePlate], *, gravity: float = 9.81
                    ) -> PlateMass | None:
    """The body mass the plates measure (module docstring), or None.

    None without two overlapping stances on different plates (one plate, running,
    standing, no contact).

    Args:
        plates: Ground reactions on the feet, lab frame (Z up), N.
        gravity: m/s^2.
    """
    plates = [p for p in plates if p.time.size > 2]
    if len(plates) < 2:
        return None
    time = plates[0].time
    fz = [np.interp(time, p.time, p.force[:, 2]) for p in plates]
    total = np.sum(fz, axis=0)
    stances = sorted((s, p) for p, f in enumerate(fz) for s in _stances(time, f))
    steps, windows = [], []
    pairs = zip(stances, stances[1:], strict=False)
    for ((_, end, peak), plate), ((start, _, next_peak), other) in pairs:
        if plate == other or start >= end or next_peak <= peak:
            continue
        w = slice(peak, next_peak + 1)
        duration = time[next_peak] - time[peak]
        steps.append(float(np.trapezoid(total[w], time[w]) / duration / gravity))
        windows.append((float(time[peak]), float(time[next_peak])))
    if not steps:
        return None
    return PlateMass(float(np.mean(steps)), tuple(steps), tuple(windows))


#: The value of ``--mass`` / ``[trial] mass`` that weighs the subject on the plates.
PLATES = "plates"


def resolve_mass(mass: float | str, plates: Sequence[ForcePlate], *, source: str,
                 gravity: float = 9.81) -> float:
    """``mass`` in kg, or for ``"plates"`` the plates' (:func:`plate_body_mass`, 0.1 kg).

    Raises:
        InputError: ``"plates"`` and the plates cannot weigh the subject.
    """
    if mass != PLATES:
        return float(mass)
    weighed = plate_body_mass(plates, gravity=gravity)
    if weighed is None:
        raise InputError(f"{source}: mass = \"plates\" needs two overlapping stances on "
                         "different plates (one foot on each); these plates cannot weigh the "
                         "subject: give the body mass in kg.")
    return round(weighed.mass, 1)


def parse_mass(table: Table, key: str = "mass") -> float | str:
    """A problem file's body mass: kg (20-300), or "plates" (weighed on the plates).

    Raises:
        InputError: Not a number of kg in range nor "plates" (names the file and key).
    """
    if table.get(key, (int, float, str)) == PLATES:
        return PLATES
    if isinstance(table.data[key], str):
        raise table.error(key, "give the body mass in kg, or \"plates\" to weigh the "
                               "subject on the force plates.")
    return table.number(key, low=20, high=300, unit="kg")
