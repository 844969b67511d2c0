"""Medians with NumPy's values, without the numpy.ma that np.median imports.

np.median and np.nanmedian import numpy.ma on their first call (~25 ms of CPU, a tenth of
``predgait inverse``'s own start-up); these give the same numbers from a sort: the middle
value, or the mean of the two middle values as ``(a + b) / 2`` like np.mean of two.
"""

from __future__ import annotations

import numpy as np


def _middle(ordered: np.ndarray) -> float:
    """Median of an ascending non-empty vector."""
    half = ordered.size // 2
    if ordered.size % 2:
        return float(ordered[half])
    return float((ordered[half - 1] + ordered[half]) / 2)


def median(values) -> float:
    """np.median of all of ``values``: NaN if any value is NaN or there is none."""
    ordered = np.sort(np.asarray(values, dtype=float), axis=None)  # NaN sorts last
    if not ordered.size or np.isnan(ordered[-1]):
        return float("nan")
    return _middle(ordered)


def finite_median(values) -> np.ndarray:
    """np.nanmedian(values, axis=0) of (n, k) ``values``: per column, NaN if none finite."""
    values = np.asarray(values, dtype=float)
    out = np.full(values.shape[1], np.nan)
    for j, column in enumerate(values.T):
        finite = column[np.isfinite(column)]
        if finite.size:
            out[j] = _middle(np.sort(finite))
    return out
