"""predgait.data.medians and report.stick.sample_times give NumPy's exact values.

They replace np.median, np.nanmedian and np.unique on the inverse command's path (those load
numpy.ma); every result here must equal NumPy's bit for bit, NaN where NumPy gives NaN.
"""

import warnings

import numpy as np
import pytest

from predgait.data.medians import finite_median, median
from predgait.report.stick import sample_times

SIZES = (1, 2, 3, 4, 5, 10, 151, 300, 599, 600, 601, 1000)


@pytest.mark.parametrize("n", SIZES)
def test_median_equals_numpy(n):
    rng = np.random.default_rng(n)
    for scale in (1e-3, 1.0, 1e3):
        values = rng.normal(size=n) * scale
        assert median(values) == np.median(values)
        assert median(values.reshape(-1, 1)) == np.median(values)   # of all values
        steps = np.diff(np.cumsum(rng.random(n + 1)))   # sample intervals, as resample uses
        assert median(steps) == np.median(steps)
    values[n // 2] = np.nan
    assert np.isnan(median(values)) and np.isnan(np.median(values))


def test_median_of_nothing_is_nan():
    assert np.isnan(median([]))
    assert median([2.0, 1.0]) == 1.5 and median([3.0, 1.0, 2.0]) == 2.0


@pytest.mark.parametrize("n", SIZES)
def test_finite_median_equals_nanmedian(n):
    rng = np.random.default_rng(100 + n)
    values = rng.normal(size=(n, 3)) * np.array([1e-3, 1.0, 1e3])
    values[rng.random((n, 3)) < 0.25] = np.nan
    values[:, 1] = np.nan if n < 4 else values[:, 1]    # a column with no finite value
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        expected = np.nanmedian(values, axis=0)
    assert np.array_equal(finite_median(values), expected, equal_nan=True)


def test_sample_times_equals_unique():
    rng = np.random.default_rng(0)
    for _ in range(200):
        t = np.cumsum(rng.random(int(rng.integers(2, 400))) * 0.02)
        interval = float(rng.choice([0.001, 0.01, 0.05, 0.3]))
        targets = np.arange(t[0], t[-1] + 1e-9, interval)
        expected = np.unique(np.clip(np.searchsorted(t, targets - 1e-9), 0, len(t) - 1))
        rows = sample_times(t, interval)
        assert np.array_equal(rows, expected) and rows.dtype == expected.dtype
