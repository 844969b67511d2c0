"""Passive knee and ankle fitted to the swing angles by simulation (kind passive_swing).

Known answers: the thigh-driven dynamics against Pinocchio's equations of the leg free in
the plane (tests/passive_walk.py, hand-written forces, independent of the fitting code);
the parameters recovered from the exact simulated motion; and the whole pipeline (markers
with 1 mm noise, plates with 1 % noise, inverse kinematics, the fit) in 20 seeded
repetitions, beside the moment decomposition on the same data. CLI runs on the bundled
subject01 trial and the shared walking5 trial; bad input.
"""

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import passive_walk
from predgait import function_cache
from predgait.problems.decomposition import Settings, bootstrap, fit_decomposition
from predgait.problems.gait_samples import GaitSamples, cycle_phase
from predgait.problems.identifiability import Status, assess
from predgait.problems.passive_model import build_model
from predgait.problems.passive_swing import (
    SwingSettings,
    Windows,
    bootstrap_swing,
    fit_swing,
    residuals_at,
)
from predgait.problems.passive_swing_dynamics import thigh_driven_dynamics, thigh_kinematics

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
LINEAR_FIT = {"knee": ["k", "c", "theta0"], "ankle": ["k", "c", "theta0"]}
SWING = SwingSettings(quiet_phases=((71.0, 95.0),))   # the truth's active is 0 in 70-97 %


@pytest.fixture(scope="module")
def walk():
    """Six gait cycles of the synthetic walk (simulated once for the module)."""
    return passive_walk.simulate(cycles=6, seed=0)


def test_thigh_driven_dynamics_is_the_free_leg_under_its_thigh(walk):
    """In swing (no ground force) the projected ADAM equations give the accelerations of
    the hand-built Pinocchio leg free in the plane, whatever hip load held its thigh."""
    t, q, states, ref, system = walk
    f = thigh_driven_dynamics(ref.model)
    checked = 0
    for i in range(0, len(t), 37):
        if ref.phase(t[i])[1] < 0.62:
            continue
        x = states[i]
        a = system.rhs(t[i], x)[5:]
        s9 = thigh_kinematics(ref.model, x[None, :5], x[None, 5:], a[None])[0]
        tau = sum(system.torques(t[i], x[:5], x[5:], system.reference_loads(t[i])))
        out = np.array(f(np.r_[x[3:5], x[8:10]], s9, tau)).ravel()
        np.testing.assert_allclose(out[2:], a[3:], atol=1e-8 * (1 + np.abs(a).max()))
        np.testing.assert_allclose(out[:2], x[8:10])
        checked += 1
    assert checked > 20


def test_compiled_step_equals_the_in_memory_one(walk, compiled):
    """The RK4 sample step with its sensitivities, compiled through the function cache
    (the module's cache folder: the other fits here load this library)."""
    from predgait.problems.passive_swing_dynamics import step_function

    if function_cache.compiler() is None:
        pytest.skip("no C compiler: the cache is off by design")
    model = build_model(["knee", "ankle"], fit=LINEAR_FIT)
    leg = walk[3].model
    rng = np.random.default_rng(3)
    args = (np.array([0.1, -0.9, 1.0, -3.0]), rng.normal(size=(4, 10)),
            np.tile(np.array([0.2, 0.9, 0.1, 1.0, 0.1, 2.0, 3.0, -1.0, 10.0])[:, None], 3),
            np.full(6, 0.3), 0.05)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(function_cache.SWITCH, "off")
        memory = [np.array(v) for v in step_function(leg, model, 1, 0.01)(*args)]
    compiled_step = step_function(leg, model, 1, 0.01)
    folder = Path(os.environ[function_cache.FOLDER])
    assert list(folder.glob("swing_step-*.so")), "nothing compiled"
    for a, b in zip(memory, compiled_step(*args), strict=True):
        np.testing.assert_allclose(np.array(b), a, rtol=1e-12, atol=1e-12)


@pytest.fixture(scope="module")
def exact(walk):
    """The windows of the exact simulated states and accelerations at 100 Hz."""
    t, q, states, ref, system = walk
    index = np.arange(0, len(t), 5)
    a = np.array([system.rhs(t[i], states[i])[5:] for i in index])
    n = index.size
    inverse = SimpleNamespace(time=t[index], q=q[index], v=states[index, 5:], a=a,
                              tau=np.zeros((n, 5)), hip_force=np.zeros((n, 3)),
                              hip_moment=np.zeros((n, 3)), has_grf=False, knee_static=0.0,
                              model=ref.model)
    percent, cycle, _ = cycle_phase(t[index], ref.strikes[:-1], where="truth")
    samples = GaitSamples(t[index], percent, cycle, {}, {}, {}, correlation_time=0.01)
    return ref.model, Windows.from_inverse(inverse, samples, SWING)


def test_exact_motion_gives_the_parameters_back(exact, compiled):
    """Exact states and accelerations at 100 Hz (no markers, no filter): within 1.5 %."""
    leg, windows = exact
    assert len(windows) == 6 and windows.substeps == 1
    model = build_model(["knee", "ankle"], fit=LINEAR_FIT)
    fit = fit_swing(leg, windows, model, SWING)      # from the literature defaults
    for key, true in passive_walk.TRUTH.items():
        assert abs(fit.values[key] / true - 1) < 0.015, (key, fit.values[key])
    assert max(fit.noise_sd.values()) < np.radians(0.01)


def test_residuals_at_the_truth_and_their_jacobian(exact, compiled):
    """residuals_at (the Cramér-Rao bound's Jacobian): at the true parameters and states
    the exact windows' residuals vanish, and its SI parameter columns are the central
    differences of the residuals."""
    leg, windows = exact
    model = build_model(["knee", "ankle"], fit=LINEAR_FIT)
    r, jac = residuals_at(leg, windows, model, passive_walk.TRUTH, SWING)
    assert r.shape == (2 * windows.samples,) and jac.shape == (r.size, 6 + 4 * len(windows))
    assert np.sqrt(np.mean(r ** 2)) < np.radians(0.01)
    for i, p in enumerate(model.fitted):
        h = 1e-4 * max(abs(passive_walk.TRUTH[p.key]), 0.1)
        up, down = ({**passive_walk.TRUTH, p.key: passive_walk.TRUTH[p.key] + s * h}
                    for s in (1, -1))
        difference = (residuals_at(leg, windows, model, up, SWING)[0]
                      - residuals_at(leg, windows, model, down, SWING)[0]) / (2 * h)
        np.testing.assert_allclose(jac[:, i], difference, atol=1e-5 * np.abs(difference).max())


def test_a_stop_the_swing_never_reaches_is_not_identifiable(exact, monkeypatch):
    """The knee flexion stop (137 deg) in the fit as well: reported not identifiable."""
    monkeypatch.setenv(function_cache.SWITCH, "off")   # one fit: not worth compiling
    leg, windows = exact
    model = build_model(["knee", "ankle"], fit={**LINEAR_FIT,
                                                "knee": ["k", "c", "theta0", "k_upper"]})
    fit = fit_swing(leg, windows, model, SWING, start=passive_walk.TRUTH)
    reports = {r.key: r for r in assess(model, fit, bootstrap_swing(windows, model, fit,
                                                                     repeats=40))[0]}
    assert reports["knee.k_upper"].status is Status.NOT_IDENTIFIABLE
    assert reports["knee.k_upper"].interval95 is None
    assert "bounds" in reports["knee.k_upper"].reasons[0]
    assert reports["knee.k"].status is Status.IDENTIFIED
    assert abs(reports["knee.k"].value / passive_walk.TRUTH["knee.k"] - 1) < 0.02


def test_known_passive_walk_through_the_real_pipeline(tmp_path, walk, compiled):
    """Forward-simulated walk -> 1 mm markers, 1 % forces -> inverse kinematics and
    dynamics -> both fits, in 20 repetitions with their own seeded noise (the walk is
    simulated once; as in benchmarks/study_passive_coverage.py).

    The moment decomposition (residual-analysis cut-off ~10 Hz, quiet phase 73-88 %):
    ankle RMS errors 3-5 % (largest 12 %); the knee's swing moment, a difference of large
    inertial terms of double-differentiated markers, gives knee RMS errors of 17-34 %.

    The angle fit (markers at 20 Hz, quiet phase 71-95 %), measured over the 20
    repetitions (benchmarks/study_passive_coverage.py --method angles --phases 71 95):
    knee k RMS 4.7 % (largest 10.5 %), theta0 5.6 % (10.3 %), c 12.6 % (25 %; the swing
    loads the knee's damper little), ankle 2.6-3.1 % (6 %); every interval covers the
    truth. The issue's "within 5 % in every repetition" is NOT reached for the knee (nor
    for all ankle repetitions); what is checked: no 95 % interval misses the truth more
    than 2 times in 20, nothing is called not identifiable, the error bounds below, and
    the knee spring at least 3 times as accurate as from the moments. The window matters:
    ending it at 96 % (1 % before the muscles switch back on) biases the knee (k +9 %,
    c -24 % on average), 73-95 % gives k 7.5 %, c 28 % RMS.
    """
    noise_free = passive_walk.NoiseFreeTrial(simulated=walk)
    model = build_model(["knee", "ankle"], fit=LINEAR_FIT)
    decomposition = Settings(quiet_phases=((73.0, 88.0),))
    keys = list(passive_walk.TRUTH)
    errors = {m: {k: [] for k in keys} for m in ("moments", "angles")}
    missed = {m: dict.fromkeys(keys, 0) for m in ("moments", "angles")}
    abstained = {m: dict.fromkeys(keys, 0) for m in ("moments", "angles")}

    def record(method, reports):
        for report in reports:
            true = passive_walk.TRUTH.get(report.key)
            if true is None:
                continue
            errors[method][report.key].append(report.value / true - 1)
            if report.status is Status.NOT_IDENTIFIABLE:
                abstained[method][report.key] += 1
            elif not report.interval95[0] <= true <= report.interval95[1]:
                missed[method][report.key] += 1

    from predgait.dynamics.inverse_trial import run_inverse
    from predgait.workflows.decomposition import residual_cutoff

    for repetition in range(20):
        folder = tmp_path / f"r{repetition}"
        folder.mkdir()
        options = noise_free.write(folder, noise_seed=1000 + repetition)
        cutoff = residual_cutoff(options)
        assert 6.0 < cutoff < 20.0
        samples = GaitSamples.from_inverse(run_inverse(replace(options, cutoff=cutoff,
                                                               grf_cutoff=cutoff)))
        split = fit_decomposition(samples, model, decomposition)
        boot = bootstrap(samples, model, split, decomposition, repeats=60, seed=repetition)
        record("moments", assess(model, split, boot)[0])

        inverse = run_inverse(replace(options, cutoff=20.0, grf_cutoff=20.0))
        windows = Windows.from_inverse(inverse, GaitSamples.from_inverse(inverse), SWING)
        fit = fit_swing(inverse.model, windows, model, SWING, start=split.values)
        boot = bootstrap_swing(windows, model, fit, repeats=60, seed=repetition)
        record("angles", assess(model, fit, boot)[0])

    rms = {m: {k: float(np.sqrt(np.mean(np.square(e)))) for k, e in errors[m].items()}
           for m in errors}
    worst = {m: {k: float(np.max(np.abs(e))) for k, e in errors[m].items()} for m in errors}
    for key in keys:
        assert missed["moments"][key] <= 2, (key, missed, abstained)
        assert missed["angles"][key] <= 2, (key, missed, abstained)
        assert abstained["angles"][key] == 0, (key, abstained)
        if key.startswith("ankle"):
            assert abstained["moments"][key] == 0, (key, abstained)
            assert rms["moments"][key] < 0.06 and worst["moments"][key] < 0.15, (key, rms)
            assert rms["angles"][key] < 0.045 and worst["angles"][key] < 0.09, (key, rms)
        else:
            assert abstained["moments"][key] <= 4, (key, abstained)
    assert rms["angles"]["knee.k"] < 0.065 and worst["angles"]["knee.k"] < 0.15, rms
    assert rms["angles"]["knee.theta0"] < 0.08 and worst["angles"]["knee.theta0"] < 0.15, rms
    assert rms["angles"]["knee.c"] < 0.18 and worst["angles"]["knee.c"] < 0.35, rms
    assert rms["angles"]["knee.k"] < rms["moments"]["knee.k"] / 3, rms


def _solve(problem, out, *sets):
    args = [sys.executable, "-m", "predgait", "solve", str(problem), "--out", str(out)]
    for s in sets:
        args += ["--set", s]
    env = {**os.environ, function_cache.SWITCH: "off"}   # as every test: no compiling
    return subprocess.run(args, capture_output=True, text=True, cwd=REPO, timeout=600, env=env)


def test_cli_on_the_bundled_trial(tmp_path, assert_tidy_result):
    out = tmp_path / "swing"
    run = _solve(REPO / "problems" / "passive_swing.toml", out, "uncertainty.bootstrap=40",
                 "filter.sensitivity_hz=[25.0]")
    assert run.returncode == 0, run.stderr
    solution = assert_tidy_result(out / "solution.json")
    assert solution["kind"] == "passive_swing" and solution["marker_cutoff_hz"] == 20.0
    assert solution["windows"] >= 2 and solution["bootstrap"]["unit"] == "gait cycle"
    assert max(solution["angle_rms_deg"].values()) < 1.0
    assert set(solution["cutoff_sensitivity"]) == {"25"}
    for key, report in solution["parameters"].items():
        if report["status"] == "not_identifiable":
            assert report["interval95"] is None and f"{key} = " in run.stdout
    names = (out / "swing_angles.sto").read_text().splitlines()
    header = names[names.index("endheader") + 1].split("\t")
    table = np.genfromtxt(out / "swing_angles.sto", skip_header=names.index("endheader") + 2)
    col = {n: table[:, i] for i, n in enumerate(header)}
    assert len(table) == solution["quiet_samples"]
    error = col["knee_simulated_deg"] - col["knee_measured_deg"]
    assert np.sqrt(np.mean(error ** 2)) == pytest.approx(solution["angle_rms_deg"]["knee"],
                                                         rel=5e-6)   # JSON: 6 digits
    # The header's unit is the values' one: the late-swing knee (model coordinate, -flexion)
    # comes from ~60 deg flexion to near straight (Kadaba 1990), in degrees.
    from predgait.data import read_storage

    stored = read_storage(out / "swing_angles.sto")
    assert stored.header["units"].startswith("deg") and stored.in_degrees
    knee = -stored.column("knee_measured_deg")
    assert -10.0 < knee.min() < 20.0 and 40.0 < knee.max() < 75.0


@pytest.mark.skipif(not (DATA / "opensim_walking5_c3d" / "walking5.c3d").is_file(),
                    reason="shared walking5 trial not present")
def test_cli_on_walking5_through_an_inverse_problem(tmp_path):
    out = tmp_path / "w5"
    run = _solve(REPO / "problems" / "passive_swing.toml", out,
                 'trial.inverse_problem="inverse_walking5.toml"', "uncertainty.bootstrap=20",
                 "filter.sensitivity_hz=[]", "window_sensitivity=[]")
    assert run.returncode == 0, run.stderr
    solution = json.loads((out / "solution.json").read_text())
    assert "walking5.c3d" in solution["provenance"]["trial"]
    assert solution["quiet_samples"] > 50 and solution["angle_rms_deg"]["knee"] < 1.0


@pytest.mark.parametrize("override, words", [
    ("quiet_phases=[[20.0, 30.0]]", "no quiet phase of at least 5 samples off the ground"),
    ('filter.marker_cutoff="low"', "marker_cutoff"),
    ("simulation.step_s=0.5", "step_s"),
])
def test_bad_input_names_the_key(tmp_path, override, words):
    out = tmp_path / "bad"
    run = _solve(REPO / "problems" / "passive_swing.toml", out, override,
                 "uncertainty.bootstrap=0", "filter.sensitivity_hz=[]")
    assert run.returncode == 2, run.stderr
    assert words in run.stderr and "Traceback" not in run.stderr and not out.exists()


def test_fit_that_does_not_converge_exits_3_and_writes_nothing(tmp_path):
    out = tmp_path / "failed"
    run = _solve(REPO / "problems" / "passive_swing.toml", out, "simulation.max_iter=1",
                 "uncertainty.bootstrap=0", "filter.sensitivity_hz=[]")
    assert run.returncode == 3 and "solve failed" in run.stderr, run.stderr
    assert "Gauss-Newton did not converge" in run.stderr and not out.exists()


def test_marker_cutoff_defaults_to_a_third_of_the_marker_rate(tmp_path):
    """Without [filter] marker_cutoff the problem is read (issue 28: it was refused) and the
    cut-off is a third of the marker rate, at most 30 Hz: 20 Hz on subject01's 60 Hz."""
    from predgait.problemfile import load_problem
    from predgait.workflows.passive_swing import chosen_cutoff, default_cutoff_hz, parse_swing

    assert [default_cutoff_hz(rate) for rate in (60.0, 90.0, 100.0, 250.0)] == \
        pytest.approx([20.0, 30.0, 30.0, 30.0])
    spec = parse_swing(load_problem(REPO / "problems" / "passive_swing.toml"))
    assert spec.cutoff is None and spec.default_cutoff
    assert chosen_cutoff(spec, spec.trial.options())[0] == pytest.approx(20.0)
    problem = tmp_path / "swing.toml"
    problem.write_text((REPO / "problems" / "passive_swing.toml").read_text().replace(
        "# marker_cutoff = 20.0", 'marker_cutoff = "residual"'))
    spec = parse_swing(load_problem(problem))
    assert spec.cutoff is None and not spec.default_cutoff
