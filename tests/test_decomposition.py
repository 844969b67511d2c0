"""Passive/active decomposition: known answers, identifiability, bad input, CLI runs.

Moment-level synthetic trials are built here, independently of the fitting code: joint
angles over many gait cycles with per-cycle variation, passive moments written out by
hand (linear spring-damper, thesis eqs. 3.3.1-3.3.2, and the Anderson 1999 exponential
stops as in Falisse et al. 2019), an active pattern that is exactly zero from 70 % of
the cycle on, and correlated noise on the moments. The 20 repetitions through the real
pipeline (tests/passive_walk.py: forward simulation, markers, plates, inverse dynamics)
are in tests/test_passive_swing.py, beside the fit to the angles.
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from predgait.errors import InputError
from predgait.problems.decomposition import Settings, bootstrap, fit_decomposition
from predgait.problems.gait_samples import GaitSamples, cycle_phase
from predgait.problems.identifiability import Status, assess
from predgait.problems.passive_model import build_model
from predgait.workflows.solve import deviation_wording

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
TRUTH = {"knee.k": 10.0, "knee.c": 0.5, "knee.theta0": 0.6,
         "ankle.k": 20.0, "ankle.c": 0.5, "ankle.theta0": 0.05}


def _bump(percent, centre, width):
    d = (percent - centre + 50.0) % 100.0 - 50.0
    return np.exp(-0.5 * (d / width) ** 2)


def synthetic_trial(seed, *, truth=TRUTH, knee_stop=0.0738, cycles=20, rate=100.0,
                    noise=(0.1, 0.05)):
    """Samples of a known split: angles, hand-written passive moments, active, noise."""
    rng = np.random.default_rng(seed)
    periods = 1.1 * (1 + 0.03 * rng.standard_normal(cycles))
    strikes = np.concatenate([[0.0], np.cumsum(periods)])
    t = np.arange(0.0, strikes[-1], 1.0 / rate)
    index = np.clip(np.searchsorted(strikes, t, side="right") - 1, 0, cycles - 1)
    pct = 100.0 * (t - strikes[index]) / periods[index]
    slow = 1 + 0.05 * np.sin(2 * np.pi * t / 3.7 + rng.uniform(0, 6))
    knee = np.radians(3 + 14 * _bump(pct, 15, 7) + 57 * slow * _bump(pct, 72, 11)
                      - 4 * _bump(pct, 96, 3))
    ankle = np.radians(-2 + 10 * _bump(pct, 45, 12) - 17 * slow * _bump(pct, 63, 6)
                       + 3 * _bump(pct, 85, 8))
    knee_rate, ankle_rate = np.gradient(knee, t), np.gradient(ankle, t)
    window = np.clip((70.0 - pct) / 5.0, 0, 1) * np.clip(pct / 2.0, 0, 1)   # 0 from 70 %
    active_knee = window * slow * (30 * _bump(pct, 12, 5) - 15 * _bump(pct, 45, 10))
    active_ankle = window * (-100 * slow * _bump(pct, 48, 8) - 20 * _bump(pct, 20, 10))
    passive_knee = (-truth["knee.k"] * (knee - truth["knee.theta0"])
                    - truth["knee.c"] * knee_rate + knee_stop * np.exp(-33.94 * knee)
                    - 11.03 * np.exp(-11.33 * (2.40 - knee)))
    passive_ankle = (-truth["ankle.k"] * (ankle - truth["ankle.theta0"])
                     - truth["ankle.c"] * ankle_rate + 0.18 * np.exp(-12.12 * (ankle + 0.74))
                     - 2.03 * np.exp(-38.11 * (0.52 - ankle)))

    def correlated(sd):   # AR(1), correlation 0.6 per sample
        e, out = rng.standard_normal(len(t)), np.zeros(len(t))
        for i in range(1, len(t)):
            out[i] = 0.6 * out[i - 1] + 0.8 * e[i]
        return sd * out

    percent, cycle, _ = cycle_phase(t, strikes, where="synthetic")
    return GaitSamples(
        t, percent, cycle, {"knee": knee, "ankle": ankle},
        {"knee": knee_rate, "ankle": ankle_rate},
        {"knee": active_knee + passive_knee + correlated(noise[0]),
         "ankle": active_ankle + passive_ankle + correlated(noise[1])},
        correlation_time=0.03, source="synthetic")


LINEAR_FIT = {"knee": ["k", "c", "theta0"], "ankle": ["k", "c", "theta0"]}


def test_recovers_known_parameters_with_covering_intervals():
    model = build_model(["knee", "ankle"], fit=LINEAR_FIT)
    covered = dict.fromkeys(TRUTH, 0)
    for seed in range(20):
        samples = synthetic_trial(seed)
        fit = fit_decomposition(samples, model)
        boot = bootstrap(samples, model, fit, repeats=60, seed=seed)
        assert boot.unit == "gait cycle" and boot.failed == 0
        reports = {r.key: r for r in assess(model, fit, boot)[0]}
        for key, true in TRUTH.items():
            report = reports[key]
            assert report.status is Status.IDENTIFIED, (seed, key, report.reasons)
            assert abs(report.value / true - 1) < 0.05, (seed, key, report.value)
            low, high = report.interval95
            covered[key] += low <= true <= high
    assert min(covered.values()) >= 18, covered


def test_noise_free_trial_is_solved_not_refused():
    """Exact moments (no noise): the residual SD is ~0, the weights 1 / sigma^2 huge.

    Unscaled, Ipopt stopped with Maximum_Iterations_Exceeded here (issue 28); the fit
    must return the truth."""
    samples = synthetic_trial(0, noise=(0.0, 0.0), cycles=3)
    model = build_model(["knee", "ankle"], fit={"knee": ["k", "c", "theta0", "k_lower"],
                                                "ankle": ["k", "c", "theta0"]})
    fit = fit_decomposition(samples, model, Settings(quiet_phases=((73.0, 100.0),)))
    assert fit.status == "Solve_Succeeded"
    for key in ("knee.k", "knee.c", "knee.theta0"):
        assert abs(fit.values[key] / TRUTH[key] - 1) < 1e-3, (key, fit.values[key])
    assert abs(fit.values["ankle.k"] / TRUTH["ankle.k"] - 1) < 0.01


def test_passive_element_absent_from_data_is_near_zero():
    """No damping and no extension stop in the data: both fitted, both ~0 with intervals."""
    truth = dict(TRUTH, **{"knee.c": 0.0, "ankle.c": 0.0})
    samples = synthetic_trial(3, truth=truth, knee_stop=0.0)
    model = build_model(["knee", "ankle"], fit={"knee": ["k", "c", "theta0", "k_lower"],
                                                "ankle": ["k", "c", "theta0"]})
    fit = fit_decomposition(samples, model)
    reports = {r.key: r for r in assess(model, fit, bootstrap(samples, model, fit,
                                                               repeats=60))[0]}
    for key, largest in (("knee.c", 0.1), ("ankle.c", 0.1), ("knee.k_lower", 2.0)):
        report = reports[key]
        assert report.status is Status.CONSISTENT_WITH_ZERO, report
        assert report.value <= largest / 2
        assert report.interval95[0] == 0.0 and report.interval95[1] < largest
        assert report.note.startswith("consistent with 0")
    assert abs(reports["knee.k"].value / 10.0 - 1) < 0.05


def test_parameter_the_data_cannot_see_is_not_identifiable():
    """The knee flexion stop (137 deg) is never reached in gait; theta0 follows a zero k."""
    samples = synthetic_trial(1, truth=dict(TRUTH, **{"ankle.k": 0.0}))
    model = build_model(["knee", "ankle"], fit={"knee": ["k", "c", "theta0", "k_upper"],
                                                "ankle": ["k", "c", "theta0"]})
    fit = fit_decomposition(samples, model)
    reports = {r.key: r for r in assess(model, fit, bootstrap(samples, model, fit,
                                                               repeats=40))[0]}
    assert reports["knee.k_upper"].status is Status.NOT_IDENTIFIABLE
    assert reports["knee.k_upper"].interval95 is None
    assert "bounds" in reports["knee.k_upper"].reasons[0]
    assert reports["ankle.theta0"].status is Status.NOT_IDENTIFIABLE
    assert reports["ankle.k"].status is Status.CONSISTENT_WITH_ZERO
    assert "consistent with 0" in reports["ankle.k"].note
    assert reports["knee.k"].status is Status.IDENTIFIED


def test_bad_model_and_phase_choices_name_the_key():
    with pytest.raises(InputError, match=r"passive\.knee\.fixed: c is both fixed"):
        build_model(["knee"], fit={"knee": ["k", "c"]}, fixed={"knee": {"c": 0.0}})
    with pytest.raises(InputError, match=r"passive\.knee\.priors\.k: the prior mean 300"):
        build_model(["knee"], bounds={"knee": {"k": (0.0, 200.0)}},
                    priors={"knee": {"k": (300.0, 10.0)}})
    with pytest.raises(InputError, match=r"passive\.knee\.fit: b_lower"):
        build_model(["knee"], fit={"knee": ["k", "b_lower"]})
    samples = synthetic_trial(0, cycles=3)
    model = build_model(["knee"], fit={"knee": ["k", "c", "theta0"]})
    with pytest.raises(InputError, match=r"quiet_phases: the phases \[\[99.0, 100.0\]\]"):
        fit_decomposition(samples, model, Settings(quiet_phases=((99.0, 100.0),)))


def _solve(problem, out, *sets):
    args = [sys.executable, "-m", "predgait", "solve", str(problem), "--out", str(out)]
    for s in sets:
        args += ["--set", s]
    return subprocess.run(args, capture_output=True, text=True, cwd=REPO, timeout=600)


def test_cli_on_the_bundled_trial(tmp_path, assert_tidy_result):
    out = tmp_path / "decomposition"
    run = _solve(REPO / "problems" / "passive_decomposition.toml", out,
                 "uncertainty.bootstrap=40", "filter.sensitivity_hz=[6.0, 20.0]",
                 "uncertainty.noise_repeats=3")
    assert run.returncode == 0, run.stderr
    solution = assert_tidy_result(out / "solution.json")
    noise = solution["noise_sensitivity"]
    assert noise["repeats"] == 3 and noise["force_noise_percent"] == 1.0
    assert all(0.0 <= sd < 1e3 for sd in noise["sd"].values())
    assert noise["sd"]["knee.k"] > 0.0 and "spread from re-added noise" in run.stdout
    assert 4.0 < solution["marker_cutoff_hz"] < 12.0        # residual analysis, 60 Hz TRC
    assert set(solution["cutoff_sensitivity"]) == {"6", "20"}
    # Cycle counts as the console prints them: subject01 has 2 heel strikes (issue 28).
    assert (solution["gait_cycles"], solution["partial_cycles"],
            solution["quiet_swings"]) == (1, 2, 2)
    assert "1 full gait cycle(s) + 2 partial; 2 quiet swing(s)" in run.stdout
    windows = solution["window_sensitivity"]
    assert list(windows) == ["73-100 %", "73-87 %", "73-95 %"]
    assert windows["73-100 %"]["knee.k"] == solution["parameters"]["knee.k"]["value"]
    assert "over 73-87 %: knee.k = " in run.stdout
    # What subject01 can and cannot say: no damping, no ankle neutral angle.
    params = solution["parameters"]
    assert params["knee.c"]["status"] == "consistent_with_zero"
    assert params["ankle.theta0"]["status"] == "not_identifiable"
    assert "rest angle" in params["knee.theta0"]["meaning"] and " deg" in run.stdout
    for key, report in solution["parameters"].items():
        assert report["status"] in {s.value for s in Status}
        if report["status"] == "not_identifiable":
            assert report["interval95"] is None and report["reasons"]
            assert f"{key} = " in run.stdout and "not identifiable" in run.stdout
    table = np.genfromtxt(out / "passive_moments.sto", skip_header=_header_lines(out))
    names = _columns(out)
    col = {n: table[:, i] for i, n in enumerate(names)}
    np.testing.assert_allclose(col["knee_moment_passive"] + col["knee_moment_active"],
                               col["knee_moment_inverse_dynamics"], atol=1e-9)
    assert (out / "active_passive.png").stat().st_size > 10_000


def _header_lines(out):
    lines = (out / "passive_moments.sto").read_text().splitlines()
    return lines.index("endheader") + 2


def _columns(out):
    lines = (out / "passive_moments.sto").read_text().splitlines()
    return lines[lines.index("endheader") + 1].split("\t")


@pytest.mark.skipif(not (DATA / "opensim_walking5_c3d" / "walking5.c3d").is_file(),
                    reason="shared walking5 trial not present")
def test_cli_on_walking5_through_an_inverse_problem(tmp_path):
    problem = tmp_path / "walking5_decomposition.toml"
    text = (REPO / "problems" / "passive_decomposition.toml").read_text()
    problem.write_text(text.replace(
        '# inverse_problem = "inverse_walking5.toml"',
        f'inverse_problem = "{REPO / "problems" / "inverse_walking5.toml"}"'))
    out = tmp_path / "out"
    run = _solve(problem, out, "uncertainty.bootstrap=40", "filter.sensitivity_hz=[6.0]",
                 "uncertainty.noise_repeats=0")
    assert run.returncode == 0, run.stderr
    solution = json.loads((out / "solution.json").read_text())
    assert "walking5.c3d" in solution["provenance"]["trial"]
    assert solution["cycle_timing"].startswith("one heel strike")
    assert solution["bootstrap"]["unit"].startswith("block")
    assert solution["quiet_samples"] > 40


def test_cli_failures_write_nothing(tmp_path):
    problem = REPO / "problems" / "passive_decomposition.toml"
    out = tmp_path / "failed"
    run = _solve(problem, out, "solver.max_iter=1", "filter.sensitivity_hz=[6.0]")
    assert run.returncode == 3 and "solve failed" in run.stderr and not out.exists()
    run = _solve(problem, out, "quiet_phases=[[99.5, 100.0]]")
    assert run.returncode == 2 and not out.exists()
    assert "quiet_phases" in run.stderr and "Traceback" not in run.stderr
    run = _solve(problem, out, "passive.knee.fixed={ c = 0.0 }")
    assert run.returncode == 2 and "passive.knee.fixed: c is both fixed" in run.stderr
    run = _solve(problem, out, "passive.knee.priors={ k = [300.0, 5.0] }")
    assert run.returncode == 2 and not out.exists()
    assert "passive.knee.priors.k: the prior mean 300 N m/rad lies outside" in run.stderr


def test_knee_fit_says_what_it_is_and_prints_no_meaningless_interval(tmp_path):
    """Issue 19: k = 1.62, c = 0 (bound) with 1e-15 intervals were reported as a passive knee."""
    out = tmp_path / "knee"
    run = _solve(REPO / "problems" / "knee_fit.toml", out)
    assert run.returncode == 0, run.stderr
    solution = json.loads((out / "solution.json").read_text())
    assert "not tissue properties" in solution["what"] and "stabilising" in run.stdout
    sensitivity = max(solution["diagnostics"]["sensitivity_deg"].values())
    for name, half in solution["confidence95"].items():
        if sensitivity > 1e4 or (name in ("k", "c") and solution["parameters"][name] <= 1e-4):
            assert half.startswith("not meaningful"), (name, half)
            assert f"{name}: 95 % interval not meaningful" in run.stdout
        else:
            assert isinstance(half, float)
    assert "never" not in run.stdout and "within it from 0.000" not in run.stdout
    for name, result in solution["resimulation_check"].items():
        assert f"re-simulation {name}: {deviation_wording(result, 2.0)}" in run.stdout


def test_resimulation_wording_says_what_happened():
    """Issue 19: "deviation > 2 deg at never, within it from 0.000 s" read as nonsense."""
    def run(left, back, end=1.2, status="completed"):
        return {"time_to_threshold_s": left, "within_threshold_from_s": back, "end_s": end,
                "status": status}

    assert deviation_wording(run(None, 0.0), 2.0) == \
        "stays within 2 deg for the whole window (to 1.200 s)"
    assert deviation_wording(run(0.41, None), 2.0) == \
        "leaves 2 deg at 0.410 s and is not back within it by the end (1.200 s)"
    assert deviation_wording(run(0.41, 0.95), 5.0) == \
        "leaves 5 deg at 0.410 s, back within it from 0.950 s (end 1.200 s)"
    assert deviation_wording(run(None, None, 0.3, "diverged"), 2.0) == \
        "stays within 2 deg until the run stops at 0.300 s (diverged)"


def test_the_synthetic_walk_is_what_inverse_dynamics_inverts():
    """The generator's applied torques equal the inverse dynamics of its exact motion."""
    import passive_walk
    from predgait.dynamics.external import Load
    from predgait.dynamics.inverse import leg_inverse_dynamics

    t, q, states, ref, system = passive_walk.simulate(cycles=1, seed=2)
    t, q, states = t[::10], q[::10], states[::10]
    a = np.array([system.rhs(ti, x)[5:] for ti, x in zip(t, states, strict=True)])
    feet = passive_walk.frame_positions(ref.model, q)
    loads = []
    for ti, heel, toe in zip(t, feet["heel"], feet["toe"], strict=True):
        force, cop, free = ref.ground_reaction(ti, heel, toe)
        loads.append([Load("foot", force, point=cop, moment=free)])
    exact = leg_inverse_dynamics(ref.model, q, states[:, 5:], a, loads)
    applied = np.array([sum(system.torques(ti, x[:5], x[5:], system.reference_loads(ti)))
                        for ti, x in zip(t, states, strict=True)])
    np.testing.assert_allclose(exact.tau[:, 3:], applied, atol=1e-8)
    assert np.abs(applied).max() > 20.0
