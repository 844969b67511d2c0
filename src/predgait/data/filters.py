"""Low-pass filters: zero-lag Butterworth (Winter-corrected), moving average, residual analysis.

References:
    Winter DA (2009) Biomechanics and Motor Control of Human Movement, 4th ed., Wiley:
    sec. 3.4.4.3 (cut-off correction for multiple passes), sec. 3.4.4.4 (residual analysis).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predgait.data.butterworth import butter_lowpass, filtfilt
from predgait.errors import InputError


def winter_correction(n_passes: int = 2, order: int = 2) -> float:
    """Winter's correction factor C of the cut-off for a filter applied ``n_passes`` times.

    ``C = (2**(1/n_passes) - 1)**(1/(2*order))``; for a 2nd-order filter run twice
    (forward and backward) C = 0.802 (Winter 2009, sec. 3.4.4.3).
    """
    return (2.0 ** (1.0 / n_passes) - 1.0) ** (1.0 / (2.0 * order))


def corrected_cutoff(cutoff: float, rate: float, *, order: int = 2) -> float:
    """Design cut-off (Hz) of each pass so the dual-pass response is -3 dB at ``cutoff``.

    The correction is applied to the pre-warped frequency, as in Winter's recursive
    filter (omega_c = tan(pi f_c / f_s) / C), so the combined gain is exactly 1/sqrt(2)
    at ``cutoff``.
    """
    if not 0 < cutoff < rate / 2:
        raise InputError(
            f"cut-off {cutoff!r} Hz must be between 0 and the Nyquist frequency {rate / 2:g} Hz."
        )
    warped = np.tan(np.pi * cutoff / rate) / winter_correction(2, order)
    return float(np.arctan(warped) * rate / np.pi)


def lowpass(x, rate: float, cutoff: float, *, order: int = 2, axis: int = 0) -> np.ndarray:
    """Zero-lag Butterworth low-pass (forward-backward, Winter-corrected cut-off).

    Args:
        x: samples along ``axis``, e.g. (n,) or (n, m, 3).
        rate: Hz, sample rate.
        cutoff: Hz, -3 dB frequency of the combined (dual-pass) response.
        order: order of each pass (2 -> 4th-order zero-lag filter).
        axis: time axis.

    Returns:
        Filtered array, same shape as ``x``.

    Raises:
        InputError: NaNs in ``x`` (fill gaps first) or too few samples.
    """
    x = np.asarray(x, dtype=float)
    if np.isnan(x).any():
        frames = np.flatnonzero(np.isnan(np.moveaxis(x, axis, 0)).reshape(x.shape[axis], -1)
                                .any(axis=1))
        raise InputError(
            f"cannot low-pass a signal with NaNs (frames {frames[0] + 1}..{frames[-1] + 1}, "
            f"{frames.size} frames): fill gaps or trim the trial first."
        )
    b, a = butter_lowpass(order, corrected_cutoff(cutoff, rate, order=order), rate)
    padlen = 3 * max(len(a), len(b))
    if x.shape[axis] <= padlen:
        raise InputError(f"a signal of {x.shape[axis]} samples is too short to filter "
                         f"(needs more than {padlen}).")
    return filtfilt(b, a, x, axis=axis, padlen=padlen)


def moving_average(x, *, window: int = 7, passes: int = 2, axis: int = 0) -> np.ndarray:
    """Rectangular moving average (straight averaging), as in thesis Fig. 4.1.3 (2 x 7 points).

    Near the ends the window shrinks symmetrically so no samples are invented.

    Args:
        x: samples along ``axis``.
        window: odd number of points.
        passes: times the window is applied.
        axis: time axis.
    """
    if window < 1 or window % 2 == 0:
        raise InputError(f"moving-average window {window} must be an odd positive integer.")
    y = np.moveaxis(np.asarray(x, dtype=float), axis, 0)
    n, half = y.shape[0], window // 2
    for _ in range(passes):
        cumulative = np.concatenate([np.zeros((1, *y.shape[1:])), np.cumsum(y, axis=0)])
        i = np.arange(n)
        reach = np.minimum(np.minimum(i, n - 1 - i), half)
        lo, hi = i - reach, i + reach + 1
        shape = (n,) + (1,) * (y.ndim - 1)
        y = (cumulative[hi] - cumulative[lo]) / (hi - lo).reshape(shape)
    return np.moveaxis(y, 0, axis)


@dataclass(frozen=True, eq=False)
class ResidualAnalysis:
    """Result of Winter's residual analysis.

    Attributes:
        cutoffs: (k,) Hz, candidate cut-offs.
        residuals: (k,) RMS difference between raw and filtered signal (signal units).
        chosen: Hz, cut-off where the residual equals the noise intercept.
        intercept: residual of the straight noise line extrapolated to 0 Hz.
        slope: slope of that line (units/Hz).
        fit_from: Hz, lowest cut-off used in the line fit.
    """

    cutoffs: np.ndarray
    residuals: np.ndarray
    chosen: float
    intercept: float
    slope: float
    fit_from: float


def residual_analysis(x, rate: float, *, cutoffs=None, fit_from: float | None = None,
                      order: int = 2, axis: int = 0) -> ResidualAnalysis:
    """Choose a low-pass cut-off by Winter's residual analysis (Winter 2009, sec. 3.4.4.4).

    For each candidate cut-off the RMS residual between raw and filtered data is computed
    (pooled over all channels). At high cut-offs the residual is pure noise and falls on
    a straight line; its intercept at 0 Hz estimates the noise RMS, and the cut-off where
    the residual curve comes down to that value balances signal distortion and noise.

    Args:
        x: raw samples along ``axis`` (no NaNs).
        rate: Hz.
        cutoffs: Hz, candidates; default 0.5 Hz steps from 0.5 Hz to 0.4 * rate.
        fit_from: Hz, start of the straight-line fit; default half of the top cut-off.
        order: order of each Butterworth pass.
        axis: time axis.

    Returns:
        :class:`ResidualAnalysis` with the chosen cut-off and the residual curve.
    """
    x = np.asarray(x, dtype=float)
    if cutoffs is None:
        cutoffs = np.arange(0.5, 0.4 * rate + 1e-9, 0.5)
    cutoffs = np.asarray(cutoffs, dtype=float)
    residuals = np.array([
        np.sqrt(np.mean((x - lowpass(x, rate, fc, order=order, axis=axis)) ** 2))
        for fc in cutoffs
    ])
    fit_from = 0.5 * cutoffs[-1] if fit_from is None else fit_from
    tail = cutoffs >= fit_from
    if tail.sum() < 2:
        raise InputError(f"residual analysis: fewer than 2 cut-offs above fit_from={fit_from} Hz.")
    slope, intercept = np.polyfit(cutoffs[tail], residuals[tail], 1)
    below = np.flatnonzero(residuals <= intercept)
    if below.size == 0:
        chosen = float(cutoffs[-1])
    elif below[0] == 0:
        chosen = float(cutoffs[0])
    else:
        i = below[0]
        f0, f1, r0, r1 = cutoffs[i - 1], cutoffs[i], residuals[i - 1], residuals[i]
        chosen = float(f0 + (r0 - intercept) * (f1 - f0) / (r0 - r1))
    return ResidualAnalysis(cutoffs, residuals, chosen, float(intercept), float(slope),
                            float(fit_from))
