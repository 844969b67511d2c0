"""Force-plate conditioning: contact threshold, low-pass, resampling to marker times."""

from __future__ import annotations

import dataclasses
from enum import StrEnum

import numpy as np

from predgait.data.filters import lowpass
from predgait.data.frames import parse_enum
from predgait.data.medians import median
from predgait.data.trial import ForcePlate
from predgait.errors import InputError

#: Default vertical-force threshold (N) below which a foot is not in contact.
CONTACT_THRESHOLD = 20.0
#: Suggested release level (fraction of the threshold) of a contact with hysteresis:
#: a contact extends on both sides while the vertical force stays above it, so the small
#: but real forces at heel strike and toe off are kept. 1.0 = no hysteresis.
RELEASE_FRACTION = 0.5


class Resampling(StrEnum):
    """How plate samples are brought to marker frames."""

    AVERAGE = "average"    # mean of the plate samples inside each marker frame (boxcar)
    LOWPASS = "lowpass"    # low-pass below the marker Nyquist frequency, then interpolate


def hold_nearest(values: np.ndarray, valid: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Replace rows where ``valid`` is False with the nearest valid row (or ``fallback``)."""
    if not valid.any():
        return np.broadcast_to(fallback, values.shape).copy()
    index = np.flatnonzero(valid)
    nearest = index[np.clip(np.searchsorted(index, np.arange(len(valid))), 0, len(index) - 1)]
    previous = index[np.clip(np.searchsorted(index, np.arange(len(valid))) - 1, 0, len(index) - 1)]
    rows = np.arange(len(valid))
    pick = np.where(np.abs(rows - previous) <= np.abs(nearest - rows), previous, nearest)
    out = values.copy()
    out[~valid] = values[pick[~valid]]
    return out


def contact_frames(fz: np.ndarray, threshold: float, *, release: float = 1.0) -> np.ndarray:
    """(n,) bool: frames in contact, by a threshold with hysteresis.

    A contact is a run of frames with ``fz >= threshold``, extended backward and forward
    while ``fz > release * threshold`` (a Schmitt trigger run in both directions, so the
    result does not depend on the direction of time).

    Args:
        fz: (n,) N, vertical force.
        threshold: N, level a contact must reach.
        release: fraction of ``threshold`` below which a contact ends (1: no hysteresis).
    """
    fz = np.nan_to_num(np.asarray(fz, dtype=float))
    core = fz >= threshold
    above = fz > release * threshold
    edges = np.flatnonzero(np.diff(np.concatenate([[0], above.astype(int), [0]])))
    contact = np.zeros(fz.size, dtype=bool)
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        if core[start:stop].any():
            contact[start:stop] = True
    return contact


def threshold_plate(plate: ForcePlate, *, threshold: float = CONTACT_THRESHOLD,
                    release: float = 1.0) -> ForcePlate:
    """Zero the force and free moment out of contact; hold the COP where it is undefined.

    Contact frames come from :func:`contact_frames` (threshold with hysteresis); the
    force there is kept as measured. The COP is defined where the vertical force reaches
    ``threshold``; elsewhere it is held at the nearest such COP (or the plate centre, or
    the origin), so it stays finite: out of contact it carries no load, and at the edges
    of a contact the small force acts at the held COP.

    Args:
        plate: plate in the lab frame.
        threshold: N, vertical force (lab Z) a contact must reach.
        release: fraction of ``threshold`` below which a contact ends (1: no hysteresis).
    """
    contact = contact_frames(plate.force[:, 2], threshold, release=release)
    defined = (plate.force[:, 2] >= threshold) & np.isfinite(plate.cop).all(axis=1)
    centre = plate.corners.mean(axis=0) if plate.corners is not None else np.zeros(3)
    cop = hold_nearest(np.where(np.isfinite(plate.cop), plate.cop, 0.0), defined, centre)
    return dataclasses.replace(
        plate,
        force=np.where(contact[:, None], plate.force, 0.0),
        free_moment=np.where(contact[:, None], plate.free_moment, 0.0),
        cop=cop,
    )


def filter_plate(plate: ForcePlate, cutoff: float, *, threshold: float = CONTACT_THRESHOLD,
                 release: float = 1.0, order: int = 2) -> ForcePlate:
    """Low-pass a plate's force, free moment and COP (via Fz * COP), then re-threshold.

    Filtering the moment-like product Fz * COP instead of the COP keeps the COP finite at
    contact edges. Use the markers' cut-off here to keep forces and kinematics consistent.

    Args:
        plate: plate in the lab frame.
        cutoff: Hz, -3 dB of the zero-lag filter.
        threshold: N, contact threshold applied before and after filtering.
        release: its release fraction (see :func:`contact_frames`).
        order: order of each Butterworth pass.
    """
    plate = threshold_plate(plate, threshold=threshold, release=release)
    rate = plate.rate
    fz = plate.force[:, 2]
    force = lowpass(plate.force, rate, cutoff, order=order)
    free = lowpass(plate.free_moment, rate, cutoff, order=order)
    weighted = lowpass(plate.cop * fz[:, None], rate, cutoff, order=order)
    fz_f = force[:, 2]
    safe = np.where(np.abs(fz_f) > 1e-9, fz_f, 1.0)
    cop = np.where((fz_f >= threshold)[:, None], weighted / safe[:, None], plate.cop)
    out = dataclasses.replace(plate, force=force, free_moment=free, cop=cop)
    return threshold_plate(out, threshold=threshold, release=release)


def check_plates_cover(start: float, end: float, plates, *, source: str,
                       markers: str) -> None:
    """Refuse marker times ``start..end`` (s) that a force plate does not cover.

    The same rule as :func:`resample_plate`, checked from a marker file's header before
    the file is read whole (a long trial would take minutes and gigabytes to refuse).

    Args:
        start: First marker time, s.
        end: Last marker time, s.
        plates: The force plates.
        source: The force file (the message starts with it).
        markers: The marker file.
    """
    for plate in plates:
        tol = 0.5 / plate.rate + 1e-9
        if start < plate.time[0] - tol or end > plate.time[-1] + tol:
            raise InputError(
                f"{source}: force plate {plate.name!r} covers t = {plate.time[0]:.4f}.."
                f"{plate.time[-1]:.4f} s but the markers of {markers} run {start:.4f}.."
                f"{end:.4f} s (its header); trim the markers to the plates' span.")


def resample_plate(plate: ForcePlate, time, *, method: Resampling | str = Resampling.AVERAGE,
                   threshold: float = CONTACT_THRESHOLD, release: float = 1.0) -> ForcePlate:
    """Bring plate data to marker times with anti-aliasing, then apply the contact threshold.

    Args:
        plate: plate sampled at its own (higher) rate, lab frame.
        time: (n,) s, marker times (uniform).
        method: "average" (mean of plate samples within +-half a marker frame) or
            "lowpass" (Butterworth at 0.4 x the marker Nyquist, then linear interpolation).
        threshold: N, contact threshold.
        release: its release fraction (see :func:`contact_frames`).

    Returns:
        ForcePlate at ``time``. Marker frames outside the plate's time span are an error.
    """
    method = parse_enum(method, Resampling, field="method")
    time = np.asarray(time, dtype=float)
    if time.size < 2:
        raise InputError("resample_plate needs at least 2 marker times.")
    dt = median(np.diff(time))
    tol = 0.5 / plate.rate + 1e-9
    if time[0] < plate.time[0] - tol or time[-1] > plate.time[-1] + tol:
        raise InputError(
            f"force plate {plate.name!r} covers t = {plate.time[0]:.4f}..{plate.time[-1]:.4f} s "
            f"but marker times run {time[0]:.4f}..{time[-1]:.4f} s; trim the markers."
        )
    plate = threshold_plate(plate, threshold=threshold, release=release)
    fz = plate.force[:, 2]
    signals = np.concatenate([plate.force, plate.free_moment, plate.cop * fz[:, None],
                              fz[:, None], plate.cop], axis=1)
    if method is Resampling.AVERAGE:
        # Shift the bin edges by a hair so that plate samples lying exactly on an edge
        # (600 Hz plates, 60 Hz markers) fall in the same bin whatever the rounding of
        # the time columns: results must not depend on the 9th digit of a time stamp.
        edges = np.concatenate([time - dt / 2, [time[-1] + dt / 2]]) + 1e-6 * dt
        bins = np.digitize(plate.time, edges) - 1
        inside = (bins >= 0) & (bins < time.size)
        counts = np.bincount(bins[inside], minlength=time.size).astype(float)
        sums = np.stack([np.bincount(bins[inside], weights=s[inside], minlength=time.size)
                         for s in signals.T], axis=1)
        empty = counts == 0
        counts[empty] = 1.0
        sampled = sums / counts[:, None]
        if empty.any():  # marker rate above plate rate: interpolate instead
            for c in range(signals.shape[1]):
                sampled[empty, c] = np.interp(time[empty], plate.time, signals[:, c])
    else:
        cutoff = 0.4 * 0.5 / dt
        smooth = lowpass(signals, plate.rate, cutoff) if cutoff < 0.5 * plate.rate else signals
        sampled = np.stack([np.interp(time, plate.time, s) for s in smooth.T], axis=1)
    force, free, weighted, fz_mean, cop_plain = np.split(sampled, [3, 6, 9, 10], axis=1)
    fz_mean = fz_mean[:, 0]
    safe = np.where(np.abs(fz_mean) > 1e-9, fz_mean, 1.0)
    cop = np.where((np.abs(fz_mean) > 1e-9)[:, None], weighted / safe[:, None], cop_plain)
    out = ForcePlate(time=time, force=force, cop=cop, free_moment=free, name=plate.name,
                     corners=plate.corners)
    return threshold_plate(out, threshold=threshold, release=release)
