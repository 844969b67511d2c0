"""The problem-file tables of the passive fits, one parser each.

``joints``, ``quiet_phases``, ``[filter]`` (marker cut-off and its sensitivity),
``[uncertainty]`` (bootstrap) and ``[passive.<joint>]`` (elements, fitted and fixed
parameters, bounds, priors, stop angles), read the same way by every passive kind
(passive_decomposition, passive_shooting, passive_swing, passive_knee_ankle).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predgait.errors import InputError
from predgait.problemfile import Table
from predgait.problems.passive_model import JOINTS, PassiveModel, build_model


@dataclass(frozen=True)
class Resampling:
    """``[uncertainty]`` of the passive fits: bootstrap over gait cycles (or blocks).

    Attributes:
        repeats: Replicates (``bootstrap``; 0 or 1: none). seed: Random seed.
        min_cycles: Fewest gait cycles to resample cycles (else blocks of ``block_s`` s).
    """

    repeats: int = 200
    seed: int = 0
    min_cycles: int = 6
    block_s: float = 0.1


def parse_uncertainty(unc: Table, *, blocks: bool = True, extra: tuple[str, ...] = ()
                      ) -> Resampling:
    """``[uncertainty]`` bootstrap, seed (and min_cycles, block_s with ``blocks``).

    ``extra``: further keys the caller reads itself. The one parser of this table (the
    same defaults and bounds in every passive fit).
    """
    unc.check_keys(("bootstrap", "seed", *(("min_cycles", "block_s") if blocks else ()),
                    *extra))
    default = Resampling()
    return Resampling(
        repeats=int(unc.number("bootstrap", default.repeats, low=0, high=10000)),
        seed=int(unc.number("seed", default.seed, low=0)),
        min_cycles=int(unc.number("min_cycles", default.min_cycles, low=2, high=1000))
        if blocks else default.min_cycles,
        block_s=unc.number("block_s", default.block_s, low=0.01, high=2.0, unit="s")
        if blocks else default.block_s)


def parse_filter(filt: Table, *, default_cutoff: float | str = "residual",
                 sensitivity: tuple[float, ...] | None = None
                 ) -> tuple[float | None, tuple[float, ...]]:
    """``[filter]``: marker_cutoff (:func:`parse_cutoff`) and the sensitivity cut-offs.

    ``sensitivity``: default of the ``sensitivity_hz`` key (Hz); None when the fit has
    no such key (then the second value is empty).
    """
    filt.check_keys(("marker_cutoff", *(("sensitivity_hz",) if sensitivity else ())))
    cutoff = parse_cutoff(filt, default_cutoff)
    if not sensitivity:
        return cutoff, ()
    return cutoff, tuple(filt.numbers("sensitivity_hz", list(sensitivity), low=0.5, high=100,
                                      unit="Hz", increasing=True))


def parse_joints(table: Table) -> tuple[str, ...]:
    """The ``joints`` key (knee, ankle or both)."""
    joints = table.strings("joints", ("knee", "ankle"))
    for joint in joints:
        if joint not in JOINTS:
            raise table.error("joints", f"'{joint}' is not one of: {', '.join(JOINTS)}.")
    if not joints:
        raise table.error("joints", "give at least one joint (knee, ankle).")
    return tuple(joints)


def parse_phases(table: Table) -> tuple[tuple[float, float], ...]:
    """The ``quiet_phases`` key: [start, end] pairs in % gait cycle."""
    phases = table.get("quiet_phases", list, [[73.0, 100.0]])
    checked = []
    for phase in phases:
        if not (isinstance(phase, list) and len(phase) == 2
                and all(isinstance(v, int | float) and not isinstance(v, bool) for v in phase)
                and 0 <= phase[0] < phase[1] <= 100):
            raise table.error("quiet_phases", f"{phase!r}: give [start, end] pairs in % gait "
                                              "cycle with 0 <= start < end <= 100.")
        checked.append((float(phase[0]), float(phase[1])))
    if not checked:
        raise table.error("quiet_phases", "give at least one [start, end] phase.")
    ordered = sorted(checked)
    for (a0, a1), (b0, b1) in zip(ordered, ordered[1:], strict=False):
        if b0 < a1:
            raise table.error("quiet_phases", f"[{a0:g}, {a1:g}] and [{b0:g}, {b1:g}] overlap; "
                                              "give each part of the cycle once.")
    return tuple(checked)


def parse_cutoff(filt: Table, default: float | str = "residual") -> float | None:
    """``marker_cutoff``: Hz, or None for "residual" (Winter's residual analysis)."""
    cutoff = filt.get("marker_cutoff", (str, float), default)
    if isinstance(cutoff, str) and cutoff != "residual":
        raise filt.error("marker_cutoff", f"'{cutoff}': give a cut-off in Hz or \"residual\".")
    if isinstance(cutoff, str):
        return None
    return filt.number("marker_cutoff", default, low=0.5, high=100, unit="Hz")


def parse_passive_model(passive: Table, joints) -> PassiveModel:
    """The ``[passive.<joint>]`` tables: elements, fit, fixed, bounds, priors, stops_deg."""
    passive.check_keys(JOINTS)
    choices = {"elements": {}, "fit": {}, "fixed": {}, "bounds": {}, "priors": {}, "stops": {}}
    for joint in joints:
        sub = passive.table(joint)
        sub.check_keys(("elements", "fit", "fixed", "bounds", "priors", "stops_deg"))
        if sub.has("elements"):
            choices["elements"][joint] = sub.strings("elements")
        if sub.has("fit"):
            choices["fit"][joint] = sub.strings("fit")
        choices["fixed"][joint] = {k: sub.table("fixed").number(k) for k in sub.table("fixed").data}
        for key, length in (("bounds", 2), ("priors", 2)):
            inner = sub.table(key)
            choices[key][joint] = {k: inner.numbers(k, length=length) for k in inner.data}
        if sub.has("stops_deg"):
            lower, upper = sub.numbers("stops_deg", length=2, increasing=True, unit="deg")
            choices["stops"][joint] = (np.radians(lower), np.radians(upper))
    try:
        return build_model(joints, where="passive", **choices)
    except InputError as exc:
        raise InputError(f"{passive.path}: {exc}") from None
