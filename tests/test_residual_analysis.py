"""Winter's residual analysis pinned by a known answer (data/filters.py residual_analysis)."""

import numpy as np
import pytest

from predgait.data.filters import residual_analysis

RATE = 100.0                       # Hz
FREQUENCIES = np.arange(1.0, 11.0)  # Hz: the signal's band is 1..10 Hz
AMPLITUDES = 1.0 / FREQUENCIES     # a 1/f spectrum, as in gait marker trajectories
SIGMA = 0.02                       # white-noise standard deviation (signal units)


def gain(f, cutoff):
    """Amplitude response of :func:`predgait.data.filters.lowpass` at ``f`` (Hz).

    Each pass is the bilinear-transform 2nd-order Butterworth, power gain
    1 / (1 + (w / W)**4) with w = tan(pi f / fs) and the pre-warped, Winter-corrected
    W = tan(pi fc / fs) / C, C**4 = sqrt(2) - 1 (Winter 2009, 3.4.4.3). Forward plus
    backward the amplitude response is that power gain: 1 / (1 + (sqrt(2) - 1)
    (w / w_c)**4), w_c = tan(pi fc / fs): exactly 1/sqrt(2) at fc.
    """
    w, wc = np.tan(np.pi * f / RATE), np.tan(np.pi * cutoff / RATE)
    return 1.0 / (1.0 + (np.sqrt(2.0) - 1.0) * (w / wc) ** 4)


def expected_residual(cutoff):
    """RMS residual x - lowpass(x) expected for the sinusoids + white noise (long record).

    A sinusoid of amplitude A at f leaves A (1 - G(f)) / sqrt(2) RMS; white noise of
    variance sigma**2, spread evenly over 0..fs/2, leaves sigma**2 times the mean of
    (1 - G)**2 over that band; the parts are uncorrelated, so their powers add.
    """
    sines = np.sum(AMPLITUDES**2 / 2 * (1.0 - gain(FREQUENCIES, cutoff)) ** 2)
    f = np.linspace(0.0, RATE / 2, 20001)
    noise = SIGMA**2 * np.trapezoid((1.0 - gain(f, cutoff)) ** 2, f) / (RATE / 2)
    return np.sqrt(sines + noise)


def analytic_cutoff(fit_fraction=0.5):
    """The cut-off Winter's construction picks on the expected residual curve R(fc).

    Winter (2009, sec. 3.4.4.4): above the signal's band R(fc) is noise only and falls
    on a straight line; fit that line over the top cut-offs (from half the highest
    candidate, 20..40 Hz here), extrapolate it to 0 Hz: the intercept a estimates the
    noise RMS (~sigma; a line through sqrt(mean (1 - G)**2) which is ~1 at 0 Hz). The
    chosen cut-off is where R comes down to a, between candidates by linear
    interpolation. On R of :func:`expected_residual` (no noise realisation) this gives
    12.92 Hz; a line fitted from 0.2 of the top (8 Hz, inside the signal's roll-off) is
    steeper, its intercept ~0.036, and the crossing drops to 9.94 Hz.
    """
    cutoffs = np.arange(0.5, 0.4 * RATE + 1e-9, 0.5)
    residual = np.array([expected_residual(fc) for fc in cutoffs])
    tail = cutoffs >= fit_fraction * cutoffs[-1]
    _, intercept = np.polyfit(cutoffs[tail], residual[tail], 1)
    i = np.flatnonzero(residual <= intercept)[0]
    f0, f1, r0, r1 = cutoffs[i - 1], cutoffs[i], residual[i - 1], residual[i]
    return f0 + (r0 - intercept) * (f1 - f0) / (r0 - r1), intercept


def test_chosen_cutoff_is_the_analytic_one():
    rng = np.random.default_rng(1)
    t = np.arange(6000) / RATE                        # 60 s, whole periods of every sine
    phases = rng.uniform(0.0, 2 * np.pi, FREQUENCIES.size)
    x = sum(a * np.sin(2 * np.pi * f * t + p)
            for a, f, p in zip(AMPLITUDES, FREQUENCIES, phases, strict=True))
    x = x + SIGMA * rng.standard_normal(t.size)
    want, intercept = analytic_cutoff()
    assert want == pytest.approx(12.92, abs=0.01)
    assert analytic_cutoff(0.2)[0] < want - 2.0       # the rule matters
    result = residual_analysis(x, RATE)
    assert result.fit_from == pytest.approx(20.0)
    assert result.chosen == pytest.approx(want, abs=0.5)
    assert result.intercept == pytest.approx(intercept, rel=0.02)
    assert result.intercept == pytest.approx(SIGMA, rel=0.05)
