"""Low-pass cut-offs of a trial: given in Hz, by rule, or chosen by residual analysis.

``--cutoff`` / ``[options] cutoff`` for the markers and ``--grf-cutoff`` / ``grf_cutoff``
for the plates; 0, ``false`` or ``off`` means unfiltered.
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np

from predgait.data.filters import residual_analysis
from predgait.data.trial import ForcePlate, Markers
from predgait.errors import InputError

#: Candidate cut-offs (Hz) of ``--cutoff auto`` stop here (or at 0.4 x the frame rate).
AUTO_CUTOFF_MAX = 25.0


class CutoffRule(StrEnum):
    """Cut-offs that are not a number of Hz."""

    AUTO = "auto"          # markers: Winter's residual analysis (Winter 2009, 3.4.4.4)
    MARKERS = "markers"    # ground reaction: the markers' cut-off (None when they are unfiltered)


#: A low-pass setting: Hz, a rule, or None for no filtering.
Cutoff = float | CutoffRule | None


def parse_cutoff(value, *, field: str, rules: tuple[CutoffRule, ...] = ()) -> Cutoff:
    """A cut-off from the CLI or TOML: Hz; 0, ``false`` or ``off`` = unfiltered; a rule.

    Raises:
        InputError: naming ``field`` when the value is none of these.
    """
    if value is False or (isinstance(value, str) and value.strip().lower() in ("off", "none")):
        return None
    if isinstance(value, str) and value.strip().lower() in [str(r) for r in rules]:
        return CutoffRule(value.strip().lower())
    try:
        hz = float(value)
    except (TypeError, ValueError):
        hz = float("nan")
    if hz == 0:
        return None
    if not np.isfinite(hz) or hz < 0 or isinstance(value, bool):
        words = ", ".join(["a number of Hz", "0 (unfiltered)", *(f"'{r}'" for r in rules)])
        raise InputError(f"{field}: {value!r} is not a cut-off; give {words}.")
    return hz


def marker_cutoff(markers: Markers, cutoff: Cutoff) -> tuple[float | None, str]:
    """The markers' cut-off in Hz (None: unfiltered) and how it was chosen."""
    if cutoff is None:
        return None, "unfiltered"
    if cutoff == CutoffRule.AUTO:
        top = min(AUTO_CUTOFF_MAX, 0.4 * markers.rate)
        analysis = residual_analysis(markers.xyz, markers.rate,
                                     cutoffs=np.arange(0.5, top + 1e-9, 0.5))
        return analysis.chosen, (f"residual analysis (Winter 2009, 3.4.4.4): "
                                 f"{analysis.chosen:.2f} Hz")
    if not 0.5 <= cutoff < 0.5 * markers.rate:
        raise InputError(f"--cutoff {cutoff:g} Hz must lie in 0.5..{0.5 * markers.rate:g} Hz "
                         f"(below the Nyquist frequency of {markers.rate:g} Hz markers); "
                         "give 0 for unfiltered markers.")
    return float(cutoff), f"{float(cutoff):g} Hz"


def plate_cutoff(plates: tuple[ForcePlate, ...], grf_cutoff: Cutoff, markers_hz: float | None
                 ) -> float | None:
    """The ground reactions' cut-off in Hz (None: unfiltered)."""
    hz = markers_hz if grf_cutoff == CutoffRule.MARKERS else grf_cutoff
    for plate in plates:
        if hz is not None and not 0.5 <= hz < 0.5 * plate.rate:
            raise InputError(f"--grf-cutoff {hz:g} Hz must lie in 0.5..{0.5 * plate.rate:g} Hz "
                             f"(below the Nyquist frequency of the {plate.rate:g} Hz plate "
                             f"'{plate.name}'); give 0 for unfiltered forces.")
    return hz
