"""Synthetic known answers: filters, residual analysis, derivatives, gap filling, frames."""

import numpy as np
import pytest
from scipy.signal import butter, freqz

from predgait.data import (
    Markers,
    differentiate,
    fill_gaps,
    lowpass,
    moving_average,
    residual_analysis,
    winter_correction,
)
from predgait.data.filters import corrected_cutoff
from predgait.data.frames import OPENSIM_TO_LAB, detect_forward, lab_rotation
from predgait.errors import InputError


def test_winter_correction_value():
    assert winter_correction(2, 2) == pytest.approx(0.802, abs=1e-3)
    assert winter_correction(1, 2) == 1.0


@pytest.mark.parametrize("rate, cutoff", [(60.0, 6.0), (250.0, 10.0), (100.0, 30.0)])
def test_dual_pass_gain_is_minus_3db_at_cutoff(rate, cutoff):
    b, a = butter(2, corrected_cutoff(cutoff, rate), fs=rate)
    _, h = freqz(b, a, worN=[cutoff], fs=rate)
    assert abs(h[0]) ** 2 == pytest.approx(1 / np.sqrt(2), rel=1e-9)
    # the same via the time domain: a sine at the cut-off comes out at 1/sqrt(2)
    t = np.arange(int(40 * rate)) / rate
    x = np.sin(2 * np.pi * cutoff * t)
    y = lowpass(x, rate, cutoff)
    middle = slice(len(t) // 4, 3 * len(t) // 4)  # 20 s: whole periods
    gain = np.sqrt(np.mean(y[middle] ** 2) / np.mean(x[middle] ** 2))
    assert gain == pytest.approx(1 / np.sqrt(2), rel=2e-3)


def test_lowpass_zero_lag_and_nan_error():
    rate = 100.0
    t = np.arange(500) / rate
    x = np.sin(2 * np.pi * 1.0 * t)
    y = lowpass(x, rate, 10.0)
    assert np.max(np.abs(y[50:450] - x[50:450])) < 1e-3  # no phase lag, unit pass-band gain
    x[50] = np.nan
    with pytest.raises(InputError, match="NaN"):
        lowpass(x, rate, 10.0)


def test_moving_average_two_pass_seven_point():
    x = np.zeros(41)
    x[20] = 1.0
    y = moving_average(x, window=7, passes=2)
    # two passes of a 7-point box = triangle of 13 points, area preserved
    assert np.count_nonzero(y) == 13
    assert y.sum() == pytest.approx(1.0)
    assert y[20] == pytest.approx(7 / 49)
    line = np.arange(30.0)
    assert np.allclose(moving_average(line), line)  # linear trends untouched, ends too


def test_residual_analysis_picks_band_of_signal():
    rng = np.random.default_rng(1)
    rate = 200.0
    t = np.arange(1000) / rate
    signal = sum(np.sin(2 * np.pi * f * t + f) / f for f in (0.5, 1.0, 2.0, 3.0, 4.0))
    noisy = signal + rng.normal(0.0, 0.02, t.size)
    result = residual_analysis(noisy, rate)
    assert 4.0 < result.chosen < 12.0
    assert result.intercept == pytest.approx(0.02, rel=0.3)
    filtered = lowpass(noisy, rate, result.chosen)
    assert np.sqrt(np.mean((filtered - signal) ** 2)) < 0.5 * 0.02


@pytest.mark.parametrize("method, expected_order", [("central3", 2), ("central5", 4)])
def test_difference_error_order(method, expected_order):
    errors = []
    for n in (40, 80, 160):
        t = np.linspace(0.0, 2.0, n)
        v = differentiate(np.sin(3 * t), t, method=method)
        errors.append(np.max(np.abs(v - 3 * np.cos(3 * t))))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - expected_order) < 0.3)


def test_second_derivative_and_spline():
    t = np.linspace(0.0, 2.0, 201)
    x = np.sin(3 * t)
    for method, tol in (("central5", 1e-3), ("spline", 1e-4)):
        a = differentiate(x, t, method=method, order=2)
        assert np.max(np.abs(a[5:-5] + 9 * x[5:-5])) < tol
    # spline accepts non-uniform times; differences refuse them
    jitter = t + np.r_[0, np.random.default_rng(0).uniform(-1e-3, 1e-3, 199), 0]
    v = differentiate(np.sin(3 * jitter), jitter, method="spline")
    assert np.max(np.abs(v - 3 * np.cos(3 * jitter))) < 1e-4
    with pytest.raises(InputError, match="not uniform"):
        differentiate(np.sin(3 * jitter), jitter, method="central3")


def test_differentiate_along_axis_of_marker_array():
    t = np.arange(100) / 50.0
    xyz = np.stack([np.outer(t, [1.0, 2.0, 3.0])] * 4, axis=1)  # (n, 4, 3) linear motion
    v = differentiate(xyz, t, method="central5")
    assert v.shape == xyz.shape
    assert np.allclose(v[:, 2], [1.0, 2.0, 3.0])


def _markers(xyz, rate=100.0):
    n = xyz.shape[0]
    return Markers(np.arange(n) / rate, tuple(f"M{i}" for i in range(xyz.shape[1])), xyz, rate,
                   source="synthetic.trc")


def test_fill_gaps_smooth_curve():
    t = np.arange(200) / 100.0
    truth = np.stack([np.sin(t), np.cos(t), t**2], axis=1)[:, None, :]
    xyz = truth.copy()
    xyz[90:98] = np.nan
    filled = fill_gaps(_markers(xyz), max_gap_frames=10)
    assert not np.isnan(filled.xyz).any()
    assert np.max(np.abs(filled.xyz - truth)) < 1e-5


def test_fill_gaps_too_long_names_marker_and_frames():
    xyz = np.ones((200, 2, 3))
    xyz[50:80, 1] = np.nan
    with pytest.raises(InputError) as err:
        fill_gaps(_markers(xyz), max_gap_seconds=0.1)
    message = str(err.value)
    assert "'M1'" in message and "51..80" in message and "0.500..0.790 s" in message


def test_fill_gaps_edges_trim_and_error():
    xyz = np.ones((100, 2, 3))
    xyz[:5, 0] = np.nan
    xyz[-3:, 1] = np.nan
    trimmed = fill_gaps(_markers(xyz), edges="trim")
    assert trimmed.n_frames == 92 and trimmed.time[0] == pytest.approx(0.05)
    kept = fill_gaps(_markers(xyz))
    assert np.isnan(kept.xyz[:5, 0]).all()
    with pytest.raises(InputError, match="edge"):
        fill_gaps(_markers(xyz), edges="error")


def test_frames_are_proper_rotations():
    assert np.allclose(OPENSIM_TO_LAB @ OPENSIM_TO_LAB.T, np.eye(3))
    assert np.linalg.det(OPENSIM_TO_LAB) == pytest.approx(1.0)
    # OpenSim X forward, Y up, Z right -> lab X forward, Z up, Y left
    assert np.allclose(OPENSIM_TO_LAB @ [0, 1, 0], [0, 0, 1])
    assert np.allclose(OPENSIM_TO_LAB @ [0, 0, 1], [0, -1, 0])
    for forward in ("+x", "-x", "+y", "-y"):
        for axes in ("opensim", "z_up"):
            r = lab_rotation(axes, forward)
            assert np.allclose(r @ r.T, np.eye(3)) and np.linalg.det(r) == pytest.approx(1.0)


@pytest.mark.parametrize("direction, expected", [((1, 0), "+x"), ((-1, 0), "-x"),
                                                 ((0, 1), "+y"), ((0, -1), "-y"),
                                                 ((0.1, 0.05), "+x")])
def test_detect_forward_from_centroid(direction, expected):
    t = np.linspace(0, 3, 301)
    xyz = np.zeros((301, 3, 3))
    xyz[:, :, 0] = direction[0] * t[:, None] + np.arange(3)
    xyz[:, :, 1] = direction[1] * t[:, None]
    xyz[:100, 0] = np.nan  # markers entering the volume do not fake travel
    assert detect_forward(xyz).value == expected
    r = lab_rotation("z_up", expected)
    if expected != "+x" or direction[0] == 1:
        assert (r @ [*direction, 0])[0] > 0.9 * np.hypot(*direction)
