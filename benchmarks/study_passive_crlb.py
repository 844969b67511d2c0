"""Cramér-Rao lower bound of the passive knee and ankle from the swing angles.

Run: python benchmarks/study_passive_crlb.py [--seeds 100]   (~1 min)

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
  with the test's noise. Per seed, the initial states that best fit its data at the true
  parameters are found (3 Gauss-Newton steps: under the measured, noisy thigh, the true
  knee state is not the shank's true state, and starting there the simulated knee drifts
  by ~1 deg); the noise is the fit's residual there minus the residual of the noise-free
  data at the truth (the filter's and inverse kinematics' deterministic error, 0.03 deg,
  is not noise). It holds the angle noise and the response of the simulated shank and
  foot to the noise of the measured thigh motion (prescribed from the same markers), so
  it is neither white nor stationary: each window's full covariance is the Monte Carlo
  mean of e e^T (6 windows a seed pooled, aligned at their start), taken off the
  initial-state directions (:func:`projected_problem`); windows independent.

Printed per parameter: the bound's SD in % of the truth; for comparison, the bound with
the fit's own noise model (independent samples of the residual's SD weighted by 1 / m,
m samples per correlation time 1 / (2 f_c)) and with white noise (m = 1, understates);
the chance that an efficient estimator meets the issue's "within 5 % in 18 of 20"; and
the empirical RMS errors of the angle fit over the test's 20 repetitions (quoted) beside
the RMS of the fit linearised at the truth (one Gauss-Newton step with the fit's weights)
on the same noise samples (all, and the test's 20 seeds). The bound is linearised at the
truth (first order in the noise) and holds for unbiased estimators (priors can beat it).
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
#: The test's repetitions use noise seeds 1000-1019, the first 20 here.
TEST_SEEDS = 20
#: The issue's requirement: within 5 % of the truth in at least 18 of the 20.
TOLERANCE, PASSES = 0.05, 18


def lagged_covariance(errors: list[np.ndarray], lags: int) -> np.ndarray:
    """(lags, 2, 2) C[l, i, j] = E e_i(t) e_j(t + l), biased
    estimator of each zero-mean series, mean over series (positive semi-definite)."""
    out = np.zeros((lags, 2, 2))
    for e in errors:
        n = len(e)
        for lag in range(lags):
            out[lag] += e[:n - lag].T @ e[lag:] / n
    return out / len(errors)


def pooled_covariance(series: list[np.ndarray], length: int) -> tuple[np.ndarray, int]:
    """(2 L, 2 L) mean of e e^T (ankle samples, then knee samples, from the window's
    start) over every sampled window at least L long, and how many there were."""
    usable = np.array([np.concatenate([e[:length, 0], e[:length, 1]]) for e in series
                       if len(e) >= length])
    return usable.T @ usable / len(usable), len(usable)


def projected_problem(jacobian, series, lengths, f):
    """The data of each window projected off its initial-state columns (the nuisance
    parameters' directions), with their Monte Carlo covariance.

    For y = J_p theta + J_n eta + e, the information on theta with eta unknown (the Schur
    complement) equals that of Q^T y, Q an orthonormal basis of the complement of J_n's
    columns. Each window's projected covariance Q^T Sigma Q (Sigma pooled over the
    sampled windows, aligned at their start) is divided by the Hartlap et al. (2007,
    A&A 464, 399) factor (N - p - 1) / N so that its inverse is unbiased (N samples,
    p = 2 L - 4 dimensions).

    Returns:
        (Q^T J_p stacked over windows, block-diagonal covariance, [Q_w per window],
        fewest samples N).
    """
    from scipy.linalg import block_diag

    n = int(np.sum(lengths))
    starts = np.concatenate([[0], np.cumsum(lengths)])
    rows_j, blocks, bases, fewest = [], [], [], None
    for w, length in enumerate(lengths):
        rows = np.concatenate([starts[w] + np.arange(length), n + starts[w] + np.arange(length)])
        nuisance = jacobian[rows, f + 4 * w:f + 4 * w + 4]
        basis = np.linalg.qr(nuisance, mode="complete")[0][:, 4:]
        sigma, count = pooled_covariance(series, int(length))
        p = basis.shape[1]
        if count <= p + 2:
            raise ValueError(f"{count} sampled windows are too few for a {p}-dimensional "
                             "covariance; use more seeds.")
        rows_j.append(basis.T @ jacobian[rows, :f])
        blocks.append(basis.T @ sigma @ basis * count / (count - p - 1))
        bases.append((rows, basis))
        fewest = count if fewest is None else min(fewest, count)
    return np.vstack(rows_j), block_diag(*blocks), bases, fewest


def per_window(vector: np.ndarray, lengths) -> list[np.ndarray]:
    """Split stacked (ankle samples, then knee samples) into (L, 2) series per window."""
    n = int(np.sum(lengths))
    cuts = np.cumsum(lengths)[:-1]
    return [np.column_stack(pair) for pair in zip(np.split(vector[:n], cuts),
                                                   np.split(vector[n:], cuts), strict=True)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    args = parser.parse_args()

    from scipy.stats import binom, norm

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
    fit_noise, angle_noise, stacked, shifts = [], [], [], []
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
        f = len(model.fitted)
        for seed in range(args.seeds):
            noisy = windows_of(inverse_of(f"s{seed}", noise_seed=1000 + seed))
            assert np.array_equal(noisy.first, reference.first)
            true_start = noisy.x0
            # The initial states that fit this seed's data at the true parameters (under
            # its measured thigh the true knee state is not the shank's true state).
            for _ in range(3):
                r_noisy, own = residuals_at(clean.model, noisy, model, truth, swing)
                step = np.linalg.lstsq(own[:, f:], -r_noisy, rcond=None)[0]
                noisy = replace(noisy, x0=noisy.x0 + step.reshape(-1, 4))
            r_noisy, _ = residuals_at(clean.model, noisy, model, truth, swing)
            shifts.append(noisy.x0 - true_start)
            stacked.append(r_noisy - r_clean)
            fit_noise += per_window(stacked[-1], lengths)
            angle_noise += [(a - b)[:n] for a, b, n in zip(noisy.angles, reference.angles,
                                                           lengths, strict=True)]
    m = reference.correlation_samples
    projected, sigma, bases, fewest = projected_problem(jacobian, fit_noise, lengths, f)
    rows = [("CRLB (Monte Carlo cov.)", cramer_rao(projected, sigma, f))]
    for name, series in (("fit residual", fit_noise), ("measured angles", angle_noise)):
        lag_cov = lagged_covariance(series, int(lengths.max()))
        sd = np.sqrt(lag_cov[0].diagonal())
        rho = lag_cov[:, [0, 1], [0, 1]] / lag_cov[0].diagonal()
        print(f"{name} noise: SD ankle {np.degrees(sd[0]):.3f} deg, knee "
              f"{np.degrees(sd[1]):.3f} deg, ankle-knee correlation "
              f"{lag_cov[0, 0, 1] / sd.prod():+.2f}; autocorrelation at lags 0-4: ankle "
              + " ".join(f"{r:+.2f}" for r in rho[:5, 0]) + ", knee "
              + " ".join(f"{r:+.2f}" for r in rho[:5, 1]))
        if name == "fit residual":
            variances = np.repeat(sd ** 2, reference.samples) * m
            rows.append((f"white x m = {m:.1f} (fit)", cramer_rao(jacobian, variances, f)))
            rows.append(("white (m = 1)", cramer_rao(jacobian, variances / m, f)))
            # The fit to first order: one Gauss-Newton step from the truth with its
            # weights, on each seed's noise; its spread over the seeds.
            weighted = jacobian / variances[:, None]
            steps = -np.linalg.solve(weighted.T @ jacobian, weighted.T @ np.array(stacked).T)
            linear_fit = np.sqrt(np.mean(steps[:f] ** 2, axis=1))
            linear_test = np.sqrt(np.mean(steps[:f, :TEST_SEEDS] ** 2, axis=1))
    shift = np.sqrt(np.mean(np.concatenate(shifts) ** 2, axis=0))
    print(f"  window lengths {sorted(set(lengths.tolist()))} samples; Monte Carlo "
          f"covariance from >= {fewest} sampled windows; initial states refitted per seed "
          f"moved by RMS ankle {np.degrees(shift[0]):.2f} deg, knee {np.degrees(shift[1]):.2f} "
          f"deg, rates {np.degrees(shift[2]):.1f}, {np.degrees(shift[3]):.1f} deg/s")
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
          + f" {'linearised fit RMS':>19s} {'(its first 20)':>15s} {'P(18/20 in 5 %)':>16s}"
          + "   empirical RMS (max) %")
    for i, p in enumerate(model.fitted):
        true = truth[p.key]
        cells = " ".join(f"{100 * np.sqrt(b[i, i]) / abs(true):25.2f}%" for _, b in rows)
        rms, worst = EMPIRICAL[p.key]
        empirical = f"{rms:.1f} ({worst:.1f})" if rms is not None else f"2.6-3.1 ({worst:.1f})"
        bound_sd = np.sqrt(rows[0][1][i, i]) / abs(true)
        within = 2 * norm.cdf(TOLERANCE / bound_sd) - 1
        print(f"{p.key:13s} {true:6.2f} {cells} {100 * linear_fit[i] / abs(true):18.2f}% "
              f"{100 * linear_test[i] / abs(true):14.2f}% "
              f"{binom.sf(PASSES - 1, TEST_SEEDS, within):16.3f}   "
              f"{empirical}")
    print("P(18/20 in 5 %): chance that an efficient unbiased estimator (normal, SD = the "
          "bound) is within 5 % in at least 18 of 20 repetitions. Empirical: the angle fit in "
          "tests/test_passive_swing.py, 20 repetitions (ankle: RMS 2.6-3.1 % over its k, c, "
          "theta0).")


if __name__ == "__main__":
    main()
