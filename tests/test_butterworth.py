"""The numpy Butterworth design and zero-phase filter equal SciPy's butter and filtfilt."""

import numpy as np
import pytest
from scipy import signal

from predgait.data.butterworth import butter_lowpass, filtfilt


@pytest.mark.parametrize("order", [1, 2, 3, 4, 6])
@pytest.mark.parametrize("cutoff, rate", [(6.0, 60.0), (6.0, 2000.0), (15.0, 100.0),
                                          (40.0, 100.0)])
def test_design_equals_scipy(order, cutoff, rate):
    b, a = butter_lowpass(order, cutoff, rate)
    b_ref, a_ref = signal.butter(order, cutoff, fs=rate)
    np.testing.assert_allclose(b, b_ref, rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(a, a_ref, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("n", [16, 63, 64, 65, 151, 1000, 5003])
@pytest.mark.parametrize("order", [2, 4])
def test_filtfilt_equals_scipy(n, order):
    rng = np.random.default_rng(n + order)
    x = np.cumsum(rng.normal(size=(n, 4, 3)), axis=0) + 50.0  # drifting, offset signals
    b, a = signal.butter(order, 6.0, fs=250.0)
    padlen = 3 * (order + 1)
    ours = filtfilt(b, a, x, axis=0, padlen=padlen)
    ref = signal.filtfilt(b, a, x, axis=0, padlen=padlen)
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-9 * np.abs(ref).max())


def test_filtfilt_along_another_axis():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(3, 400))
    b, a = signal.butter(2, 0.1)
    np.testing.assert_allclose(filtfilt(b, a, x, axis=1, padlen=9),
                               signal.filtfilt(b, a, x, axis=1, padlen=9), atol=1e-12)


def test_filtfilt_of_a_strided_view():
    """Non-contiguous input (a column selection of a 3-D array), as residual analysis uses."""
    rng = np.random.default_rng(2)
    x = np.cumsum(rng.normal(size=(106, 8, 3)), axis=0)[:, :, [0, 2]]
    b, a = signal.butter(2, 0.2)
    np.testing.assert_allclose(filtfilt(b, a, x, axis=0, padlen=9),
                               signal.filtfilt(b, a, x, axis=0, padlen=9), atol=1e-10)
