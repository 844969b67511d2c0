"""Trial samples for the passive decomposition, each with its phase of the gait cycle.

Clinical angles, rates and moments, and the % gait cycle and cycle index of each sample.

Phases follow the analysed foot's heel strikes (full cycles between consecutive ones);
with a single heel strike the cycle length comes from the stance time (see
:func:`cycle_phase`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from predgait.errors import InputError

ANGLE_NAMES = {"knee": "knee_flexion", "ankle": "ankle_dorsiflexion"}


@dataclass(frozen=True, eq=False)
class GaitSamples:
    """Clinical angles, rates and moments of a trial, with the gait cycle of each sample.

    Attributes:
        time: (n,) s, uniform.
        percent: (n,) % of the gait cycle (NaN where no cycle can be assigned).
        cycle: (n,) int, gait cycle index (-1 where none).
        angles: joint -> (n,) clinical angle, rad.
        rates: joint -> (n,) rad/s.
        moments: joint -> (n,) inverse-dynamics clinical moment, N m.
        correlation_time: s, time over which samples are correlated (1 / (2 f_c)).
        source: Provenance text.
        timing: How the gait cycles were timed (see :func:`cycle_phase`).
        strikes: Heel strikes of the analysed foot (cycles 1 .. strikes - 1 are full).
    """

    time: np.ndarray
    percent: np.ndarray
    cycle: np.ndarray
    angles: Mapping[str, np.ndarray]
    rates: Mapping[str, np.ndarray]
    moments: Mapping[str, np.ndarray]
    correlation_time: float
    source: str = ""
    timing: str = ""
    strikes: int = 0

    @classmethod
    def from_inverse(cls, inverse) -> GaitSamples:
        """From an :class:`~predgait.dynamics.inverse_trial.InverseResult` (all its cycles).

        The knee flexion is the anatomical one (standing straight in the static trial = 0,
        when there is one), so that the extension stop at 0 means full extension.
        """
        percent, cycle, how = cycle_phase(inverse.time, inverse.events.heel_strikes,
                                          inverse.events.toe_offs,
                                          where=inverse.provenance.get("trial", "the trial"))
        angles, rates = inverse.anatomical_angles(), inverse.clinical_rates()
        moments = inverse.clinical_moments()
        cutoff = inverse.provenance.get("marker_cutoff_hz") or 6.0
        return cls(time=inverse.time, percent=percent, cycle=cycle,
                   angles={j: angles[a] for j, a in ANGLE_NAMES.items()},
                   rates={j: rates[a] for j, a in ANGLE_NAMES.items()},
                   moments={j: moments[f"{a}_moment"] for j, a in ANGLE_NAMES.items()},
                   correlation_time=0.5 / float(cutoff),
                   source=str(inverse.provenance.get("trial", "")), timing=how,
                   strikes=len(inverse.events.heel_strikes))

    @property
    def samples_per_correlation(self) -> float:
        """Samples per correlation time, m >= 1."""
        return max(1.0, self.correlation_time / float(np.median(np.diff(self.time))))

    def cycle_counts(self, quiet: np.ndarray) -> dict[str, int]:
        """Full and partial gait cycles of the trial, and the cycles holding ``quiet`` samples.

        The one count every passive fit prints and writes: ``gait_cycles`` the full
        cycles between consecutive heel strikes, ``partial_cycles`` those before the first
        or after the last, ``quiet_swings`` the cycles (full or partial) with at least one
        sample where ``quiet`` (n,) is True: the independent repeats a fit draws on.
        """
        present = set(np.unique(self.cycle[self.cycle >= 0]).tolist())
        full = present & set(range(1, self.strikes))
        swings = np.unique(self.cycle[np.asarray(quiet) & (self.cycle >= 0)])
        return {"gait_cycles": len(full), "partial_cycles": len(present - full),
                "quiet_swings": int(swings.size)}

    def in_phases(self, phases) -> np.ndarray:
        """(n,) bool: samples whose % gait cycle lies in any [start, end) of ``phases``."""
        pct = np.nan_to_num(self.percent, nan=-1.0)
        inside = np.zeros(len(pct), dtype=bool)
        for start, end in phases:
            inside |= (pct >= start) & (pct < end)
        return inside & (self.cycle >= 0)


#: Stance as a fraction of the gait cycle at normal speed (Perry & Burnfield 2010, ch. 2),
#: used for the cycle length when the trial has one heel strike only.
STANCE_FRACTION = 0.62


def cycle_phase(time, heel_strikes, toe_offs=(), *, where: str
                ) -> tuple[np.ndarray, np.ndarray, str]:
    """% gait cycle and cycle index of each sample, s -> (%, int), and how it was timed.

    Full cycles run between consecutive heel strikes. Samples before the first (after
    the last) heel strike belong to a partial cycle whose length is the mean full cycle.
    With a single heel strike (one plate contact) the cycle length is the stance time
    divided by :data:`STANCE_FRACTION`.

    Raises:
        InputError: No heel strike, or a single one without a following toe-off.
    """
    hs = np.asarray(heel_strikes, dtype=float)
    to = np.asarray(toe_offs, dtype=float)
    if hs.size >= 2:
        period = float(np.mean(np.diff(hs)))
        how = f"{hs.size - 1} full cycle(s) between heel strikes"
    elif hs.size == 1 and np.any(to > hs[0]):
        stance = float(to[to > hs[0]][0] - hs[0])
        period = stance / STANCE_FRACTION
        how = (f"one heel strike: cycle length {period:.3f} s = stance {stance:.3f} s / "
               f"{STANCE_FRACTION}")
    else:
        raise InputError(f"{where}: the decomposition needs the gait cycle: two heel strikes, "
                         f"or a heel strike and the next toe-off of the analysed foot; found "
                         f"{hs.size} heel strike(s).")
    starts = np.concatenate([[hs[0] - period], hs])
    ends = np.concatenate([hs[1:], [hs[-1] + period]]) if hs.size >= 2 else hs + period
    ends = np.concatenate([[hs[0]], ends])
    index = np.clip(np.searchsorted(hs, time, side="right"), 0, len(starts) - 1)
    percent = 100.0 * (time - starts[index]) / (ends[index] - starts[index])
    valid = (percent >= 0.0) & (percent < 100.0)
    return np.where(valid, percent, np.nan), np.where(valid, index, -1), how
