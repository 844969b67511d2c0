"""Deviation of a synthesized motion from the measured one (thesis 4.2, Figs. 4.2.8-4.2.10)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from predgait.errors import InputError


@dataclass(frozen=True)
class Deviation:
    """Synthesized minus measured coordinates.

    Attributes:
        names: Coordinates compared.
        t: (n,) s, the simulation times inside the reference's time range.
        error: (n, k) synthesized - measured, rad (or m).
        rms: Name -> RMS of the error over ``t``, rad (or m).
        threshold_deg: Threshold of ``time_to_threshold``, deg.
        time_to_threshold: First time (s) any |error| exceeds the threshold, or None.
        coordinate_at_threshold: The coordinate that crossed first, or None.
    """

    names: tuple[str, ...]
    t: np.ndarray
    error: np.ndarray
    rms: dict[str, float]
    threshold_deg: float
    time_to_threshold: float | None
    coordinate_at_threshold: str | None


def deviation(sim, reference_t, reference_q, *, threshold_deg: float = 5.0,
              coordinates: Sequence[str] | None = None) -> Deviation:
    """RMS per coordinate and the time until the deviation passes ``threshold_deg``.

    Args:
        sim: A :class:`predgait.dynamics.forward.SimulationResult`.
        reference_t: (m,) measured times, s.
        reference_q: (m, nq) measured coordinates in the model's order.
        threshold_deg: Deviation threshold, deg (angles; lengths are not thresholded).
        coordinates: Names to compare (default: the simulation's free coordinates).

    Returns:
        The :class:`Deviation` (reference linearly interpolated at the simulation times).
    """
    names = tuple(coordinates or sim.free)
    reference_t = np.asarray(reference_t, dtype=float)
    reference_q = np.asarray(reference_q, dtype=float)
    if reference_q.shape != (reference_t.size, len(sim.coordinate_names)):
        raise InputError(f"reference_q has shape {reference_q.shape}; expected "
                         f"({reference_t.size}, {len(sim.coordinate_names)}).")
    idx = [sim.coordinate_names.index(n) for n in names]
    inside = (sim.t >= reference_t[0] - 1e-12) & (sim.t <= reference_t[-1] + 1e-12)
    t = sim.t[inside]
    ref = np.column_stack([np.interp(t, reference_t, reference_q[:, i]) for i in idx])
    err = sim.q[inside][:, idx] - ref
    rms = {n: float(np.sqrt(np.mean(err[:, j] ** 2))) if t.size else float("nan")
           for j, n in enumerate(names)}
    angular = np.array([not n.startswith(("base_x", "base_z")) for n in names])
    over = np.abs(err[:, angular]) > np.radians(threshold_deg)
    t_hit, who = None, None
    if over.any():
        k = int(np.argmax(over.any(axis=1)))
        t_hit = float(t[k])
        who = np.array(names)[angular][int(np.argmax(over[k]))]
    return Deviation(names=names, t=t, error=err, rms=rms, threshold_deg=threshold_deg,
                     time_to_threshold=t_hit, coordinate_at_threshold=who)
