"""The verdicts of a passive fit: one status per meaning (issue 28).

Known answers built by hand: a fit is only values and a Fisher information here, so each
status follows from numbers chosen to land on one side of its rule.
"""

from types import SimpleNamespace

import numpy as np

from predgait.problems.decomposition import Bootstrap
from predgait.problems.gait_samples import GaitSamples, cycle_phase
from predgait.problems.identifiability import (
    MIN_BOOTSTRAP_UNITS,
    Status,
    assess,
    mark_window_dependent,
)
from predgait.problems.passive_model import build_model

MODEL = build_model(["knee"], elements={"knee": ["linear"]},
                    fit={"knee": ["k", "c", "theta0"]})   # bounds k [0, 200], c [0, 10],
#                                                         theta0 [-0.5, 2.0]


def _fit(values, se):
    """A fit with these values (SI) and independent standard errors (SI)."""
    full = MODEL.values() | values
    keys = [p.key for p in MODEL.fitted]
    return SimpleNamespace(values=full,
                           information=np.diag([1 / se[k] ** 2 for k in keys]))


def _reports(values, se, boot=None):
    return {r.key: r for r in assess(MODEL, _fit(values, se), boot)[0]}


def test_each_status_means_one_thing():
    reports = _reports({"knee.k": 12.0, "knee.c": 0.3, "knee.theta0": -0.45},
                       {"knee.k": 2.0, "knee.c": 0.2, "knee.theta0": 0.05})
    k, c, theta0 = reports["knee.k"], reports["knee.c"], reports["knee.theta0"]
    assert k.status is Status.IDENTIFIED                 # [8.1, 15.9]: clear of 0 and bounds
    assert k.interval95 == (12.0 - 1.96 * 2.0, 12.0 + 1.96 * 2.0)
    assert c.status is Status.CONSISTENT_WITH_ZERO       # 0.3 - 0.39 < 0
    assert c.interval95[0] == 0.0 and "consistent with 0" in c.note
    assert theta0.status is Status.AT_BOUND              # -0.45 - 0.098 < -0.5
    assert theta0.interval95[0] == -0.5 and "bound -0.5" in theta0.note
    assert "rest angle" in theta0.meaning and theta0.unit == "rad"
    assert {r.as_dict()["status"] for r in reports.values()} == {
        "identified", "consistent_with_zero", "at_bound"}


def test_a_neutral_angle_of_a_spring_consistent_with_zero_is_not_identifiable():
    reports = _reports({"knee.k": 1.0, "knee.c": 2.0, "knee.theta0": 0.6},
                       {"knee.k": 1.0, "knee.c": 0.2, "knee.theta0": 0.05})
    assert reports["knee.k"].status is Status.CONSISTENT_WITH_ZERO
    assert reports["knee.c"].status is Status.IDENTIFIED
    assert reports["knee.theta0"].status is Status.NOT_IDENTIFIABLE
    assert reports["knee.theta0"].interval95 is None


def test_wide_fisher_interval_is_not_identifiable():
    reports = _reports({"knee.k": 50.0, "knee.c": 2.0, "knee.theta0": 0.6},
                       {"knee.k": 60.0, "knee.c": 0.2, "knee.theta0": 0.05})
    assert reports["knee.k"].status is Status.NOT_IDENTIFIABLE
    assert reports["knee.k"].as_dict()["status"] == "not_identifiable"


def _boot(units, sd=5.0, seed=0):
    rng = np.random.default_rng(seed)
    values = np.column_stack([12.0 + sd * rng.standard_normal(200), np.full(200, 2.0),
                              np.full(200, 0.6)])
    return Bootstrap(values, "gait cycle", units, 0)


def test_a_bootstrap_of_too_few_units_is_not_used():
    values = {"knee.k": 12.0, "knee.c": 2.0, "knee.theta0": 0.6}
    se = {"knee.k": 1.0, "knee.c": 0.2, "knee.theta0": 0.05}
    few = _reports(values, se, _boot(MIN_BOOTSTRAP_UNITS - 1))["knee.k"]
    enough = _reports(values, se, _boot(MIN_BOOTSTRAP_UNITS))["knee.k"]
    assert few.interval95 == (12.0 - 1.96, 12.0 + 1.96)         # Fisher only
    assert few.interval_method.startswith("Fisher information only: 5 resampled")
    assert enough.interval95[1] - 12.0 > 2.5 * 5.0               # the bootstrap's SD used
    assert enough.interval_method.startswith("bootstrap over 6 resampled units")


def test_a_value_that_moves_outside_its_interval_between_windows_is_window_dependent():
    reports = assess(MODEL, _fit({"knee.k": 12.0, "knee.c": 2.0, "knee.theta0": 0.6},
                                 {"knee.k": 2.0, "knee.c": 0.2, "knee.theta0": 0.05}),
                     None)[0]
    windows = {"73-87 %": {"knee.k": 17.0, "knee.c": 2.1, "knee.theta0": 0.6},
               "73-95 %": {"knee.k": 13.0, "knee.c": 1.9, "knee.theta0": 0.61},
               "73-100 %": {"failed": "too few samples"}}
    marked = {r.key: r for r in mark_window_dependent(reports, windows)}
    assert marked["knee.k"].status is Status.WINDOW_DEPENDENT
    assert "73-87 %: 17" in marked["knee.k"].reasons[0]
    assert marked["knee.k"].interval95 is not None
    assert marked["knee.c"].status is Status.IDENTIFIED
    assert marked["knee.theta0"].status is Status.IDENTIFIED


def test_cycle_counts_name_full_partial_and_quiet_swings():
    strikes = np.array([0.5, 1.6, 2.7])                  # 2 full cycles, 2 partial
    t = np.arange(0.0, 3.5, 0.01)
    percent, cycle, how = cycle_phase(t, strikes, where="test")
    zeros = {"knee": np.zeros_like(t)}
    samples = GaitSamples(t, percent, cycle, zeros, zeros, zeros, 0.03, strikes=3)
    assert how.startswith("2 full cycle")
    counts = samples.cycle_counts(samples.in_phases(((73.0, 100.0),)))
    # swing of the partial first cycle (t < 0.5 s is 55-100 %) and of both full cycles;
    # the last partial cycle ends at 73 % (0.8 s of 1.1 s).
    assert counts == {"gait_cycles": 2, "partial_cycles": 2, "quiet_swings": 3}


def _answer(values, se, swings=2):
    from predgait.problems.passive_answer import joint_answer

    fit = _fit(values, se)
    reports = assess(MODEL, fit, None)[0]
    angles = np.radians(np.linspace(10.0, 60.0, 50))
    return joint_answer(MODEL, fit.values, fit.information, reports, "knee", angles,
                        swings=swings)


def test_one_answer_per_joint_parameters_curve_or_swings_needed():
    # All settled: the parameters.
    answer = _answer({"knee.k": 12.0, "knee.c": 0.3, "knee.theta0": 0.6},
                     {"knee.k": 2.0, "knee.c": 0.2, "knee.theta0": 0.05})
    assert answer.kind == "parameters" and "knee.k 12 [8.08, 15.9]" in answer.text
    # The elastic curve -k (theta - theta0) at 10 deg, by hand; its band by the delta
    # method: 1.96 sqrt((theta - theta0)^2 se_k^2 + k^2 se_theta0^2).
    d = np.radians(10.0) - 0.6
    assert np.isclose(answer.moment[0], -12.0 * d)
    assert np.isclose(answer.band[0], 1.96 * np.hypot(d * 2.0, 12.0 * 0.05))
    # theta0 at its bound but a narrow curve: the curve.
    answer = _answer({"knee.k": 12.0, "knee.c": 0.3, "knee.theta0": 1.95},
                     {"knee.k": 0.5, "knee.c": 0.2, "knee.theta0": 0.04})
    assert answer.kind == "curve" and "knee.theta0" in answer.text
    # k constrained no better than its bounds (SE 60 vs 0.5 * 200 / 1.96 = 51): the
    # information must grow (60 / 51.02)^2 = 1.383 times; the curve's band (>> 0.5 |M|)
    # asks for more. 2 swings -> ceil(2 * 1.383) - 2 = 1 more.
    answer = _answer({"knee.k": 50.0, "knee.c": 0.3, "knee.theta0": 0.6},
                     {"knee.k": 60.0, "knee.c": 0.2, "knee.theta0": 0.05})
    assert answer.kind == "not_identifiable" and answer.swings_needed == 1
    assert "need about 1 more quiet swing" in answer.text
    answer = _answer({"knee.k": 50.0, "knee.c": 0.3, "knee.theta0": 0.6},
                     {"knee.k": 150.0, "knee.c": 0.2, "knee.theta0": 0.05}, swings=3)
    assert answer.swings_needed == int(np.ceil(3 * (150.0 / (0.5 * 200 / 1.96)) ** 2)) - 3


def test_a_window_that_cannot_identify_the_parameter_is_named_with_its_verdict():
    reports = assess(MODEL, _fit({"knee.k": 12.0, "knee.c": 2.0, "knee.theta0": 0.6},
                                 {"knee.k": 2.0, "knee.c": 0.2, "knee.theta0": 0.05}),
                     None)[0]
    windows = {"73-87 %": {"knee.k": 21.0, "knee.c": 2.1, "knee.theta0": 0.6,
                           "statuses": {"knee.k": "consistent_with_zero",
                                        "knee.c": "identified", "knee.theta0": "identified"}}}
    marked = {r.key: r for r in mark_window_dependent(reports, windows)}
    assert marked["knee.k"].status is Status.WINDOW_DEPENDENT
    assert "73-87 %: 21 N m/rad, consistent_with_zero there" in marked["knee.k"].reasons[0]
    assert marked["knee.c"].status is Status.IDENTIFIED
