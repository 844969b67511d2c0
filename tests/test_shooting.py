"""Stabilising elements by multiple shooting (solve kind passive_shooting).

Known answer: the bundled trial's inverse-dynamics moments with a known spring-damper
(and a knee range-of-motion stop) taken OUT of them, through the engine's own numeric
passive forces (:func:`predgait.dynamics.forces.passive_generalized`, not the fit's
CasADi expressions): the measured motion is then driven by these moments plus exactly
that element, which the fit must return. The trial as measured needs no element: the fit
says so with an interval that reaches zero.
"""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from predgait.cli import main
from predgait.dynamics.forces import passive_generalized
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.dynamics.passive import ExponentialLimits, LinearSpringDamper, PassiveJoint
from predgait.problems.gait_samples import GaitSamples
from predgait.problems.identifiability import Status, assess
from predgait.problems.passive_model import build_model
from predgait.problems.shooting import (
    Intervals,
    ShootingSettings,
    bootstrap_shooting,
    fit_shooting,
)

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
#: Truth on anatomical angles (knee: 0 = straight standing), SI.
TRUTH = {"knee.k": 20.0, "knee.c": 0.5, "knee.theta0": 0.4, "knee.k_lower": 2.0,
         "ankle.k": 30.0, "ankle.c": 0.3, "ankle.theta0": 0.05}
KNEE_B_LOWER = 33.94   # Anderson (1999), fixed setting of the stop


def _model(truth_elements=True):
    return build_model(["knee", "ankle"],
                       elements={"knee": ["linear", "limits"], "ankle": ["linear"]},
                       fit={"knee": ["k", "c", "theta0", "k_lower"],
                            "ankle": ["k", "c", "theta0"]},
                       fixed={"knee": {"k_upper": 0.0}})


@pytest.fixture(scope="module")
def measured():
    inverse = bundled_inverse("right")
    return inverse, GaitSamples.from_inverse(inverse)


def _without_truth(inverse):
    """The trial with the true elements removed from its moments (clinical-angle truth).

    The knee elements are written on the model's hinge angle: anatomical = hinge - static,
    so theta0 and the stop move by the static knee flexion.
    """
    s = inverse.knee_static
    joints = {"knee": PassiveJoint((
        LinearSpringDamper(TRUTH["knee.k"], TRUTH["knee.c"], TRUTH["knee.theta0"] + s),
        ExponentialLimits(lower=s, upper=2.40 + s, k_lower=TRUTH["knee.k_lower"],
                          b_lower=KNEE_B_LOWER, k_upper=0.0))),
        "ankle": PassiveJoint((LinearSpringDamper(TRUTH["ankle.k"], TRUTH["ankle.c"],
                                                  TRUTH["ankle.theta0"]),))}
    passive = passive_generalized(inverse.model, joints, inverse.q, inverse.v)
    return replace(inverse, tau=inverse.tau - passive)


def test_recovers_elements_missing_from_the_moments(measured):
    inverse, samples = measured
    inverse = _without_truth(inverse)
    model = _model()
    intervals = Intervals.from_inverse(inverse, samples, ShootingSettings())
    assert intervals.length_s <= 0.025 and len(intervals) > 100
    fit = fit_shooting(inverse.model, intervals, model)
    # The trial's own inconsistency (0.005 deg per interval) is the noise left: the
    # stiffer terms come back within 2 %; an ankle damping of 0.3 N m s/rad barely moves
    # the shank in 17 ms, and its interval (checked below) is +-35 % wide.
    tolerance = dict.fromkeys(TRUTH, 0.02) | {"knee.k_lower": 0.05, "ankle.c": 0.25}
    for key, truth in TRUTH.items():
        assert fit.values[key] == pytest.approx(truth, rel=tolerance[key]), key
    boot = bootstrap_shooting(intervals, samples, model, fit, repeats=100)
    reports, _ = assess(model, fit, boot)
    for report in reports:
        if report.status is Status.FIXED:
            continue
        assert report.status is Status.IDENTIFIED, report
        low, high = report.interval95
        assert low <= TRUTH[report.key] <= high, report
    # The RK4 step inside the intervals (default 2 per 16.7 ms) does not matter.
    fine = fit_shooting(inverse.model, Intervals.from_inverse(
        inverse, samples, ShootingSettings(step_s=0.0025)), model)
    for key in TRUTH:
        assert fine.values[key] == pytest.approx(fit.values[key], rel=0.01), key
    # The elements explain the drift of the intervals: without them it is far larger.
    rms = np.sqrt(np.mean(fit.residual ** 2, axis=0))
    rms_none = np.sqrt(np.mean(fit.residual_none ** 2, axis=0))
    assert np.all(rms < 0.05 * rms_none)


def test_engine_elements_act_as_in_the_fit(measured):
    """The fitted knee (anatomical angle) on the engine's hinge angle: the same moment."""
    from predgait.problems.shooting import engine_elements

    inverse, samples = measured
    model = _model()
    values = model.values() | TRUTH
    joints = engine_elements(model, values, inverse.knee_static)
    engine = passive_generalized(inverse.model, joints, inverse.q, inverse.v)
    for joint, column, sign in (("knee", 4, -1.0), ("ankle", 3, 1.0)):
        fitted = model.passive_joint(joint, values).moment(samples.angles[joint],
                                                           samples.rates[joint])
        np.testing.assert_allclose(sign * engine[:, column], fitted, atol=1e-9)
    assert abs(inverse.knee_static) > 0.01   # the offset is exercised


def test_measured_moments_need_no_element(measured):
    inverse, samples = measured
    model = build_model(["knee", "ankle"], elements={"knee": ["linear"], "ankle": ["linear"]},
                        fit={"knee": ["k", "c", "theta0"], "ankle": ["k", "c", "theta0"]})
    intervals = Intervals.from_inverse(inverse, samples)
    fit = fit_shooting(inverse.model, intervals, model)
    boot = bootstrap_shooting(intervals, samples, model, fit, repeats=100)
    reports = {r.key: r for r in assess(model, fit, boot)[0]}
    for key, most in (("knee.k", 1.0), ("knee.c", 0.1), ("ankle.k", 2.0), ("ankle.c", 0.2)):
        report = reports[key]
        assert report.status is Status.CONSISTENT_WITH_ZERO and report.note.startswith(
            "consistent with 0"), report
        assert report.interval95[0] == 0.0 and report.interval95[1] < most, report
    assert reports["ankle.theta0"].status is Status.NOT_IDENTIFIABLE


def test_linearised_bootstrap_matches_full_refits(measured):
    """A replicate of the Gauss-Newton model equals a full refit on the same resample."""
    inverse, samples = measured
    inverse = _without_truth(inverse)
    model = _model()
    intervals = Intervals.from_inverse(inverse, samples)
    fit = fit_shooting(inverse.model, intervals, model)
    boot = bootstrap_shooting(intervals, samples, model, fit, repeats=1, seed=3)
    from predgait.problems.decomposition import resampling_units

    units, _ = resampling_units(samples)
    of_interval = units[intervals.start]
    labels = np.unique(of_interval)
    counts = np.bincount(np.random.default_rng(3).integers(0, labels.size, labels.size),
                         minlength=labels.size)
    rows = np.repeat(np.arange(len(intervals)), counts[np.searchsorted(labels, of_interval)])
    resampled = replace(intervals, start=intervals.start[rows], x0=intervals.x0[rows],
                        end=intervals.end[rows], inputs=intervals.inputs[rows])
    refit = fit_shooting(inverse.model, resampled, model)
    full = np.array([refit.values[p.key] for p in model.fitted])
    spans = np.array([p.upper - p.lower for p in model.fitted])
    assert np.all(np.abs(boot.values[0] - full) < 1e-3 * spans)


def test_cli_writes_both_fits(tmp_path, assert_tidy_result):
    out = tmp_path / "shoot"
    code = main(["solve", str(PROBLEMS / "passive_shooting_nonlinear.toml"), "--out", str(out),
                 "--set", "uncertainty.bootstrap=20"])
    assert code == 0
    solution = assert_tidy_result(out / "solution.json")
    assert solution["kind"] == "passive_shooting"
    assert "not tissue properties" in solution["what"]
    assert solution["interval_s"] <= 0.025
    check = solution["whole_cycle_resimulation"]
    assert check["threshold_deg"] == 2.0 and check["with_elements"]["end_s"] > 0
    for fit in (solution["parameters"], solution["decomposition"]["parameters"]):
        assert {"knee.k", "knee.k_lower", "ankle.c"} <= set(fit)
        for report in fit.values():
            assert report["status"] in {s.value for s in Status}
            assert (report["interval95"] is None) == (
                report["status"] in ("fixed", "not_identifiable"))
    header = (out / "passive_moments.sto").read_text().split("endheader")[1].split()[0:12]
    assert "knee_moment_stabilising_shooting" in " ".join(header)
    assert (out / "active_passive.png").is_file()


@pytest.mark.parametrize(("override", "words"), [
    ("shooting.interval_s=0.05", "interval_s"),
    ("passive.knee.fixed={k = 1.0}", "both fixed"),
    ("passive.knee.priors={k = [500.0, 5.0]}", "outside the bounds"),
])
def test_bad_input_names_the_key(tmp_path, capsys, override, words):
    out = tmp_path / "bad"
    code = main(["solve", str(PROBLEMS / "passive_shooting.toml"), "--out", str(out),
                 "--set", override])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("predgait: error:") and words in err and "Traceback" not in err
    assert not out.exists()


def test_problem_files_parse():
    from predgait.problemfile import load_problem
    from predgait.workflows.shooting import parse_shooting

    for name in ("passive_shooting.toml", "passive_shooting_nonlinear.toml"):
        spec = parse_shooting(load_problem(PROBLEMS / name))
        assert spec.settings.interval_s <= 0.025
        assert spec.model.fitted


def test_fit_that_does_not_converge_exits_3_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "none"
    code = main(["solve", str(PROBLEMS / "passive_shooting.toml"), "--out", str(out),
                 "--set", "shooting.max_iter=1", "--set", "uncertainty.bootstrap=0"])
    assert code == 3
    assert "did not converge" in capsys.readouterr().err
    assert not out.exists()


def test_compiled_residuals_give_the_same_fit(measured, tmp_path, monkeypatch):
    """The residual function compiled through the function cache: the same fit."""
    from predgait import function_cache

    if function_cache.compiler() is None:
        pytest.skip("no C compiler: the cache is off by design")
    inverse, samples = measured
    model = build_model(["knee", "ankle"], elements={"knee": ["linear"], "ankle": ["linear"]},
                        fit={"knee": ["k", "c", "theta0"], "ankle": ["k", "c", "theta0"]})
    intervals = Intervals.from_inverse(inverse, samples)
    in_memory = fit_shooting(inverse.model, intervals, model)
    monkeypatch.setenv(function_cache.SWITCH, "on")
    monkeypatch.setenv(function_cache.FOLDER, str(tmp_path))
    monkeypatch.setenv(function_cache.WHEN, "now")
    compiled = fit_shooting(inverse.model, intervals, model)
    assert list(tmp_path.glob("shooting_residuals-*.so")), "nothing compiled"
    for key, value in in_memory.values.items():
        assert compiled.values[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    np.testing.assert_allclose(compiled.jacobian, in_memory.jacobian, rtol=1e-9, atol=1e-12)
