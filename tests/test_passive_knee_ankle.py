"""Kind passive_knee_ankle: the swing angles and the quiet moments fitted together.

Known answer: the forward-simulated walk of tests/passive_walk.py (3 cycles, known
nonlinear passive knee and ankle, muscles off in 70-97 %), 1 mm marker and 1 % force
noise, through the real inverse pipeline; the combined fit must recover the truth with
intervals that cover it, and weight the moments by their measured noise. The CLI on the
bundled subject01 trial must say per joint what it can and cannot identify, and show the
identified curves beside Riener & Edrich (1999) at the trial's own angles.
"""

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import passive_walk
from predgait import function_cache
from predgait.problems.gait_samples import GaitSamples
from predgait.problems.identifiability import Status, assess
from predgait.problems.passive_model import build_model
from predgait.problems.passive_moment_rows import MomentRows
from predgait.problems.passive_swing import SwingSettings, Windows, fit_swing
from predgait.report.plot_labels import label_problems, read_labels
from predgait.workflows.passive_swing import windows_mask

REPO = Path(__file__).resolve().parents[1]
LINEAR_FIT = {"knee": ["k", "c", "theta0"], "ankle": ["k", "c", "theta0"]}
SWING = SwingSettings(quiet_phases=((71.0, 95.0),))   # the truth's active is 0 in 70-97 %


@pytest.fixture(scope="module")
def walk():
    """Three gait cycles of the synthetic walk (simulated once for the module)."""
    return passive_walk.NoiseFreeTrial(simulated=passive_walk.simulate(cycles=3, seed=0))


def test_matching_moments_and_angles_recover_the_truth(tmp_path, walk):
    from predgait.dynamics.inverse_trial import run_inverse

    model = build_model(["knee", "ankle"], fit=LINEAR_FIT)
    options = walk.write(tmp_path, noise_seed=1000)
    inverse = run_inverse(replace(options, cutoff=20.0, grf_cutoff=20.0))
    samples = GaitSamples.from_inverse(inverse)
    windows = Windows.from_inverse(inverse, samples, SWING)
    rows = MomentRows.of(samples, windows_mask(samples, windows), model)
    angles_only = fit_swing(inverse.model, windows, model, SWING, start=passive_walk.TRUTH)
    both = fit_swing(inverse.model, windows, model, SWING, start=passive_walk.TRUTH,
                     moments=rows)
    reports = {r.key: r for r in assess(model, both, None)[0]}
    for key, true in passive_walk.TRUTH.items():
        report = reports[key]
        assert report.status in (Status.IDENTIFIED, Status.CONSISTENT_WITH_ZERO), report
        assert report.interval95[0] <= true <= report.interval95[1], report
    for key in ("knee.k", "knee.theta0", "ankle.k", "ankle.theta0"):
        assert abs(both.values[key] / passive_walk.TRUTH[key] - 1) < 0.1, (key, both.values)
    # The moments weighted by their measured noise: the fit's moment residual SD, between
    # 0.8 and 1.25 times the RMS of the inverse-dynamics moment about the TRUE passive
    # moment in the windows (the active moment is 0 there; the truth on the simulation's
    # clock, which the inverse dynamics restarts at its first heel strike). Measured: knee
    # 6.8 of 6.2 N m (x1.05 the residual's degrees of freedom, and tau_passive taken at
    # the measured angle, where the extension stop's slope turns 0.2 deg into several
    # N m), ankle 0.54 of ~0.5 N m; not the 1 N m start.
    inside = windows_mask(samples, windows)
    clock = samples.time + inverse.provenance["time_zero_s"]
    for joint in ("knee", "ankle"):
        true = np.interp(clock, walk.truth["t"], walk.truth["passive"][joint])
        error = (samples.moments[joint] - true)[inside]
        rms = float(np.sqrt(np.nanmean(error ** 2)))
        assert 0.8 < both.moment_sd[joint] / rms < 1.25, (joint, both.moment_sd, rms)
    # The moments change the answer (they are in the fit, not only beside it).
    assert any(abs(both.values[k] / angles_only.values[k] - 1) > 1e-3
               for k in passive_walk.TRUTH), (both.values, angles_only.values)


def test_known_answer_curves_and_coverage_over_20_noise_seeds(walk, tmp_path, compiled):
    """Issue 28 item 4 through the front's own path (problems/passive_knee_ankle.toml: its
    model, quiet phases 73-95 %, default cut-off, decomposition start, angles and moments
    together, Fisher and profile intervals) on the 3-cycle walk with 1 mm / 1 % noise, 20
    noise seeds (as benchmarks/study_passive_coverage.py --method both --cycles 3 --seeds
    20 --phases 73 95). Every seed's passive moment along the quiet samples' true motion
    within 15 % RMS at knee and ankle (measured: knee <= 5.2 %, ankle <= 8.8 %), and every
    parameter's 95 % interval covering the truth in >= 18 of 20 seeds (measured: 18-19).
    At the former 20 Hz default knee k, c and theta0 were biased by +0.7 to +0.8 standard
    errors (noise-free +4.6 / -14.6 / +6.5 %: the filter flattens the knee's terminal
    extension into its stop; at 30 Hz +1.1 / -5.0 / +2.2 %)."""
    from predgait.problemfile import load_problem
    from predgait.workflows.decomposition import inverse_samples
    from predgait.workflows.passive_swing import _fit_over, chosen_cutoff, parse_knee_ankle

    spec = parse_knee_ankle(load_problem(REPO / "problems" / "passive_knee_ankle.toml"))
    assert spec.settings.quiet_phases == ((73.0, 95.0),) and spec.default_cutoff

    def front(name, **noise):
        """The front's fit of one recording; its curve errors and its reports."""
        folder = tmp_path / name
        folder.mkdir()
        options = walk.write(folder, **noise)
        cutoff = chosen_cutoff(spec, options)[0]
        assert cutoff == 30.0                             # 100 Hz markers
        samples, inverse = inverse_samples(options, cutoff)
        windows, fit, _ = _fit_over(spec, samples, inverse, spec.settings)
        errors = passive_walk.quiet_curve_errors(walk.truth, spec.model, fit.values, inverse,
                                                 windows_mask(samples, windows))[0]
        return errors, {r.key: r for r in assess(spec.model, fit, None)[0]}

    worst, covered = {"knee": 0.0, "ankle": 0.0}, dict.fromkeys(passive_walk.TRUTH, 0)
    for seed in range(20):
        errors, reports = front(f"seed{seed}", noise_seed=1000 + seed)
        worst = {joint: max(worst[joint], errors[joint]) for joint in worst}
        for key, true in passive_walk.TRUTH.items():
            interval = reports[key].interval95
            covered[key] += interval is not None and interval[0] <= true <= interval[1]
    assert max(worst.values()) < 0.15, worst
    assert min(covered.values()) >= 18, covered
    # What the processing alone costs (noise-free recording): knee k, c, theta0 +1.1, -5.0,
    # +2.2 % at the default 30 Hz (+4.6, -14.6, +6.5 % at 20 Hz).
    _, reports = front("noise_free", noise_seed=0, marker_noise=0.0, force_noise=0.0)
    bias = {k: reports[k].value / passive_walk.TRUTH[k] - 1
            for k in ("knee.k", "knee.c", "knee.theta0")}
    assert max(abs(bias["knee.k"]), abs(bias["knee.theta0"])) < 0.03 \
        and abs(bias["knee.c"]) < 0.08, bias


def test_cli_on_the_bundled_trial_gives_one_answer_per_joint(tmp_path):
    out = tmp_path / "ka"
    args = [sys.executable, "-m", "predgait", "solve",
            str(REPO / "problems" / "passive_knee_ankle.toml"), "--out", str(out),
            "--set", "filter.sensitivity_hz=[]"]
    env = {**os.environ, function_cache.SWITCH: "off"}
    run = subprocess.run(args, capture_output=True, text=True, cwd=REPO, timeout=600, env=env)
    assert run.returncode == 0, run.stderr
    solution = json.loads((out / "solution.json").read_text())
    assert solution["kind"] == "passive_knee_ankle" and solution["quiet_swings"] == 2
    assert set(solution["moment_noise_sd_n_m"]) == {"knee", "ankle"}
    assert list(solution["window_sensitivity"]) == ["73-95 %", "73-87 %", "73-100 %"]
    for joint in ("knee", "ankle"):
        answer = solution["answers"][joint]
        assert answer["answer"] in ("parameters", "curve", "not_identifiable",
                                    "window_dependent")
        assert f"  {joint}: {answer['text']}" in run.stdout
        assert len(answer["curve"]["angle_deg"]) == len(answer["curve"]["band95_n_m"]) == 21
        mine = {k: r for k, r in solution["parameters"].items()
                if k.startswith(joint) and r["status"] != "fixed"}
        # subject01 (2 quiet swings): no joint gives parameters that are all identified.
        assert answer["answer"] != "parameters"
        if answer["answer"] == "window_dependent":
            assert any(r["status"] == "window_dependent" for r in mine.values())
        # Item 5: the identified curve beside Riener & Edrich 1999 at the fit's own quiet
        # samples (the range of the answer's curve), in solution.json and on the console.
        check = solution["literature_check"][joint]
        assert check["quiet_samples"] == solution["quiet_samples"]
        assert check["angle_range_deg"] == pytest.approx(
            [answer["curve"]["angle_deg"][0], answer["curve"]["angle_deg"][-1]], abs=0.01)
        assert 0 < check["rms_difference_n_m"] <= (check["rms_identified_n_m"]
                                                   + check["rms_literature_n_m"])
        assert 0.0 <= check["within_factor_fraction"] <= 1.0
        assert check["text"] in run.stdout
    # The relaxed leg's knee at these angles (5-65 deg flexion in swing, hip ~20 deg) and
    # ankle near neutral with the knee extending: a few N m (Riener & Edrich 1999).
    assert 1.0 < solution["literature_check"]["knee"]["rms_literature_n_m"] < 15.0
    assert 1.0 < solution["literature_check"]["ankle"]["rms_literature_n_m"] < 15.0
    assert "beside Riener & Edrich 1999" in run.stdout
    assert not label_problems(*read_labels(out / "passive_literature.png"))


@pytest.mark.parametrize("override, words", [
    ("quiet_phases=[[73.0, 90.0], [85.0, 95.0]]", "overlap"),
    ("quiet_phases=[[73.0, 101.0]]", "0 <= start < end <= 100"),
    ("filter.marker_cutoff=40.0", "Nyquist frequency (30 Hz)"),
    ("window_sensitivity=[[90.0, 80.0]]", "window_sensitivity"),
])
def test_bad_input_one_message_nothing_written(tmp_path, override, words):
    out = tmp_path / "bad"
    args = [sys.executable, "-m", "predgait", "solve",
            str(REPO / "problems" / "passive_knee_ankle.toml"), "--out", str(out),
            "--set", override, "--set", "filter.sensitivity_hz=[]"]
    run = subprocess.run(args, capture_output=True, text=True, cwd=REPO, timeout=300)
    assert run.returncode == 2, run.stderr
    assert run.stderr.startswith("predgait: error:") and words in run.stderr, run.stderr
    assert "Traceback" not in run.stderr and not out.exists()
