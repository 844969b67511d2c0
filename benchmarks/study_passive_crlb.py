"""Cramér-Rao lower bound of the passive knee and ankle from the swing angles.

Run: python benchmarks/study_passive_crlb.py [--seeds 8]

The measurement setting of the known-answer test (tests/test_passive_swing.py,
``test_known_passive_walk_through_the_real_pipeline``): the synthetic walk of
tests/passive_walk.py (6 cycles), markers with 1 mm noise at 100 Hz, 1 % force noise,
inverse kinematics with a 20 Hz low-pass, quiet windows 71-95 % of each cycle. Unknowns:
knee and ankle k, c, theta0, plus each window's initial state (4 nuisance parameters per
window, profiled out). Data: the marker-derived ankle and knee angles in the windows.

* Jacobian: the fit's own (predgait.problems.passive_swing.residuals_at: CasADi forward
  mode through the simulated windows) at the true parameters, each window started from
  its true state, under the noise-free pipeline's thigh motion.
* Noise: measured, not assumed. The walk is written once noise-free and ``--seeds`` times
  with the test's noise; the noise is the fit's residual at the truth with the noisy
  data minus that with the noise-free data (so the filter's and inverse kinematics'
  deterministic error is not counted). It holds the angle noise and the response of the
  simulated shank and foot to the noise of the measured thigh motion (the thigh is
  prescribed from the same markers), which drifts over a window (not stationary). Each
  window's full (2 L, 2 L) covariance is the Monte Carlo mean of e e^T over every sampled
  window (the 6 windows pooled, aligned at their start; Hartlap et al. 2007 factor so its
  inverse is unbiased); windows independent. This is the bound's covariance.

Printed per parameter: the bound's SD in % of the truth; for comparison, the bound with
(a) the fit's own noise model (independent samples of the residual's SD weighted by
1 / m, m samples per correlation time 1 / (2 f_c)) and (b) the measured angles' noise
alone (stationary, from its lagged auto- and cross-covariance) with the thigh taken as
exactly known; and the empirical RMS errors of the angle fit over the test's 20
repetitions (quoted) beside the RMS of the fit linearised at the truth (one Gauss-Newton
step with the fit's weights) on the same noise samples. The bound is linearised at the
truth (first order in the noise).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

#: Empirical RMS / largest |error| (%) of the angle fit, 20 seeded repetitions, 71-95 %
#: (tests/test_passive_swing.py docstring; python benchmarks/study_passive_coverage.py
#: --method angles --phases 71 95).
EMPIRICAL = {"knee.k": (4.7, 10.5), "knee.c": (12.6, 25.0), "knee.theta0": (5.6, 10.3),
             "ankle.k": (None, 6.0), "ankle.c": (None, 6.0), "ankle.theta0": (None, 6.0)}
QUIET = (71.0, 95.0)
CUTOFF_HZ = 20.0


def lagged_covariance(errors: list[np.ndarray], lags: int) -> np.ndarray:
    """(lags, 2, 2) C[l, i, j] = E e_i(t) e_j(t + l), biased
    estimator of each zero-mean series, mean over series (positive semi-definite)."""
    out = np.zeros((lags, 2, 2))
    for e in errors:
        n = len(e)
        for lag in range(lags):
            out[lag] += e[:n - lag].T @ e[lag:] / n
    return out / len(errors)


def window_covariance(lag_cov: np.ndarray, lengths) -> np.ndarray:
    """Covariance of the stacked angles (every ankle sample window by window, then every
    knee sample) of stationary noise with this lagged covariance; windows independent."""
    blocks = []
    for length in lengths:
        lag = np.arange(length)[None, :] - np.arange(length)[:, None]          # s - t
        blocks.append(np.block([[np.where(lag >= 0, lag_cov[np.abs(lag), i, j],
                                          lag_cov[np.abs(lag), j, i]) for j in range(2)]
                                for i in range(2)]))
    return stack_windows(blocks, lengths)


def monte_carlo_covariance(series: list[np.ndarray], lengths) -> tuple[np.ndarray, int]:
    """Covariance of the stacked angles from zero-mean noise samples, windows independent.

    Each window's (2 L, 2 L) covariance (ankle samples, then knee samples, from the
    window's start; not assumed stationary) is the mean of e e^T over every sampled
    window at least L long, cut to its first L samples, and is divided by the Hartlap et
    al. (2007, A&A 464, 399) factor (N - p - 1) / N so that its inverse is unbiased
    (N samples, p = 2 L). Returns the covariance and the smallest N.
    """
    blocks, fewest = [], None
    for length in lengths:
        usable = [np.concatenate([e[:length, 0], e[:length, 1]]) for e in series
                  if len(e) >= length]
        n, p = len(usable), 2 * length
        if n <= p + 2:
            raise ValueError(f"{n} noise samples are too few for a {p}-dimensional "
                             "covariance; use more seeds.")
        sample = np.array(usable)
        blocks.append(sample.T @ sample / n * n / (n - p - 1))
        fewest = n if fewest is None else min(fewest, n)
    return stack_windows(blocks, lengths), fewest


def stack_windows(blocks, lengths) -> np.ndarray:
    """Per-window (2 L, 2 L) blocks (ankle, then knee) into the fit's row order."""
    starts = np.concatenate([[0], np.cumsum(lengths)])
    n = starts[-1]
    sigma = np.zeros((2 * n, 2 * n))
    for w, (block, length) in enumerate(zip(blocks, lengths, strict=True)):
        rows = np.concatenate([starts[w] + np.arange(length), n + starts[w] + np.arange(length)])
        sigma[np.ix_(rows, rows)] = block
    return sigma


def per_window(vector: np.ndarray, lengths) -> list[np.ndarray]:
    """Split stacked (ankle samples, then knee samples) into (L, 2) series per window."""
    n = int(np.sum(lengths))
    cuts = np.cumsum(lengths)[:-1]
    return [np.column_stack(pair) for pair in zip(np.split(vector[:n], cuts),
                                                   np.split(vector[n:], cuts), strict=True)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=40)
    args = parser.parse_args()

    import passive_walk
    from predgait.dynamics.inverse_trial import run_inverse
    from predgait.problems.gait_samples import GaitSamples
    from predgait.problems.identifiability import cramer_rao
    from predgait.problems.passive_model import build_model
    from predgait.problems.passive_swing import SwingSettings, Windows, residuals_at

    start = time.perf_counter()
    walk = passive_walk.simulate(cycles=6, seed=0)
    every = int(round(1 / (passive_walk.MARKER_RATE * passive_walk.STEP)))
    true_states = walk[2][::every]
    trial = passive_walk.NoiseFreeTrial(simulated=walk)
    swing = SwingSettings(quiet_phases=(QUIET,))
    model = build_model(["knee", "ankle"], fit={"knee": ["k", "c", "theta0"],
                                                "ankle": ["k", "c", "theta0"]})
    truth = passive_walk.TRUTH
    fit_noise, angle_noise, stacked = [], [], []
    with tempfile.TemporaryDirectory() as root:
        def inverse_of(name, **noise):
            folder = Path(root) / name
            folder.mkdir()
            options = trial.write(folder, **noise)
            inverse = run_inverse(replace(options, cutoff=CUTOFF_HZ, grf_cutoff=CUTOFF_HZ))
            assert inverse.time.size == trial.t_m.size   # the same marker samples
            return inverse

        def windows_of(inverse):
            """The windows (phases of the noise-free run), started at the true state."""
            windows = Windows.from_inverse(inverse, samples, swing)
            return replace(windows, x0=true_states[windows.first][:, [3, 4, 8, 9]])

        clean = inverse_of("clean", noise_seed=0, marker_noise=0.0, force_noise=0.0)
        samples = GaitSamples.from_inverse(clean)
        reference = windows_of(clean)
        lengths = reference.length
        r_clean, jacobian = residuals_at(clean.model, reference, model, truth, swing)
        for seed in range(args.seeds):
            noisy = windows_of(inverse_of(f"s{seed}", noise_seed=1000 + seed))
            assert np.array_equal(noisy.first, reference.first)
            r_noisy, _ = residuals_at(clean.model, noisy, model, truth, swing)
            stacked.append(r_noisy - r_clean)
            fit_noise += per_window(stacked[-1], lengths)
            angle_noise += [(a - b)[:n] for a, b, n in zip(noisy.angles, reference.angles,
                                                           lengths, strict=True)]
    f = len(model.fitted)
    m = reference.correlation_samples
    sigma, fewest = monte_carlo_covariance(fit_noise, lengths)
    rows = [("CRLB (Monte Carlo cov.)", cramer_rao(jacobian, sigma, f))]
    for name, series in (("fit residual", fit_noise), ("measured angles", angle_noise)):
        lag_cov = lagged_covariance(series, int(lengths.max()))
        sd = np.sqrt(lag_cov[0].diagonal())
        rho = lag_cov[:, [0, 1], [0, 1]] / lag_cov[0].diagonal()
        print(f"{name} noise at the truth: SD ankle {np.degrees(sd[0]):.3f} deg, knee "
              f"{np.degrees(sd[1]):.3f} deg, ankle-knee correlation "
              f"{lag_cov[0, 0, 1] / sd.prod():+.2f}; autocorrelation at lags 0-4: ankle "
              + " ".join(f"{r:+.2f}" for r in rho[:5, 0]) + ", knee "
              + " ".join(f"{r:+.2f}" for r in rho[:5, 1]))
        if name == "fit residual":
            variances = np.repeat(sd ** 2, reference.samples)
            rows.append((f"white x m = {m:.1f} (fit)", cramer_rao(jacobian, variances * m, f)))
            # The fit to first order: one Gauss-Newton step from the truth with its
            # weights, on each seed's noise; its spread over the seeds.
            weighted = jacobian / (variances * m)[:, None]
            steps = -np.linalg.solve(weighted.T @ jacobian, weighted.T @ np.array(stacked).T)
            linear_fit = np.sqrt(np.mean(steps[:f] ** 2, axis=1))
        else:
            rows.append(("angle noise, thigh exact", cramer_rao(
                jacobian, window_covariance(lag_cov, lengths), f)))
    print(f"  window lengths {sorted(set(lengths.tolist()))} samples; Monte Carlo "
          f"covariance from >= {fewest} sampled windows")
    spread = [np.std(np.concatenate(fit_noise)[:, j]) for j in range(2)]
    positions = trial.positions
    lengths_m = [np.linalg.norm(positions[a] - positions[b], axis=1).mean()
                 for a, b in (("hip_center", "knee_center"), ("knee_center", "ankle_center"))]
    geometric = np.sqrt(2 * sum(1 / s ** 2 for s in lengths_m)) * 1e-3 \
        * np.sqrt(2 * CUTOFF_HZ / passive_walk.MARKER_RATE)
    print(f"  (knee angle noise from the geometry alone: two 1 mm markers per segment, "
          f"thigh {lengths_m[0] * 100:.0f} cm, shank {lengths_m[1] * 100:.0f} cm, ideal "
          f"{CUTOFF_HZ:g} Hz low-pass: {np.degrees(geometric):.3f} deg; pooled residual SD "
          f"{np.degrees(spread[0]):.3f} / {np.degrees(spread[1]):.3f} deg; deterministic "
          f"residual at the truth, noise-free pipeline: RMS "
          f"{np.degrees(np.sqrt(np.mean(r_clean ** 2))):.3f} deg)")
    print(f"Cramér-Rao bound (SD, % of truth), passive fit to the swing angles: 6 cycles, "
          f"{len(reference)} windows {QUIET[0]:g}-{QUIET[1]:g} % ({reference.samples} "
          f"samples per joint), 1 mm markers, 1 % force, {CUTOFF_HZ:g} Hz; noise from "
          f"{args.seeds} seeds; {time.perf_counter() - start:.0f} s")
    print(f"{'parameter':13s} {'truth':>6s} " + " ".join(f"{n:>26s}" for n, _ in rows)
          + f" {'linearised fit RMS':>19s}   empirical RMS (max) %")
    for i, p in enumerate(model.fitted):
        true = truth[p.key]
        cells = " ".join(f"{100 * np.sqrt(b[i, i]) / abs(true):25.2f}%" for _, b in rows)
        rms, worst = EMPIRICAL[p.key]
        empirical = f"{rms:.1f} ({worst:.1f})" if rms is not None else f"2.6-3.1 ({worst:.1f})"
        print(f"{p.key:13s} {true:6.2f} {cells} {100 * linear_fit[i] / abs(true):18.2f}%   "
              f"{empirical}")
    print("Empirical: the angle fit in tests/test_passive_swing.py, 20 repetitions (ankle: "
          "RMS 2.6-3.1 % over its k, c, theta0).")


if __name__ == "__main__":
    main()
