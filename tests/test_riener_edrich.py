"""Riener & Edrich (1999) passive moments and the literature check of the passive fits.

Known answers: the published equations evaluated by hand (angles in degrees, the paper's
ankle angle = plantarflexion, its ankle moment positive toward plantarflexion), then read
in predgait's clinical signs (knee flexion, ankle dorsiflexion positive).
"""

import math

import numpy as np
import pytest

from predgait.dynamics import riener_edrich
from predgait.problems.literature_check import compare, literature_check
from predgait.problems.passive_model import build_model

D = math.radians


@pytest.mark.parametrize("hip, knee, ankle, expected", [
    # e^1.800 - e^-3.971 - 4.820 + e^2.220 = 6.04965 - 0.01886 - 4.820 + 9.20733
    (0.0, 0.0, 0.0, 10.41812),
    # a = -10: e^(1.8 + 0.46 - 1.056 + 0.434) - e^(-3.971 + 0.004 + 1.485 - 0.256) - 4.82
    # + e^(2.22 - 4.5) = 5.14487 - 0.06470 - 4.820 + 0.10228
    (20.0, 30.0, 10.0, 0.36245),
    # a = +20: e^(1.8 - 0.92 - 2.112) - e^(-3.971 - 0.008 + 2.97) - 4.82 + e^(2.22 - 9)
    # = 0.29171 - 0.36459 - 4.820 + 0.00114
    (0.0, 60.0, -20.0, -4.89174),
])
def test_knee_moment_by_hand(hip, knee, ankle, expected):
    assert riener_edrich.knee_moment(D(hip), D(knee), D(ankle)) == pytest.approx(expected,
                                                                                 abs=2e-4)


@pytest.mark.parametrize("knee, ankle, expected", [
    # -(e^2.1016 - e^-7.9763 - 1.792) = -(8.17925 - 0.00034 - 1.792)
    (0.0, 0.0, -6.38690),
    # a = -10: -(e^(2.1016 + 0.843 - 0.528) - e^(-7.9763 - 1.949 + 0.024) - 1.792)
    # = -(11.20770 - 0.00005 - 1.792)
    (30.0, 10.0, -9.41564),
    # a = +20: -(e^(2.1016 - 1.686) - e^(-7.9763 + 3.898) - 1.792) = -(1.51531 - 0.01694
    # - 1.792): plantarflexed 20 deg, the stretched dorsiflexors pull it back up
    (0.0, -20.0, 0.29366),
])
def test_ankle_moment_by_hand(knee, ankle, expected):
    assert riener_edrich.ankle_moment(D(knee), D(ankle)) == pytest.approx(expected, abs=2e-4)


def test_signs_follow_the_biarticular_muscles():
    # Dorsiflexion stretches the calf: a plantarflexion (negative) moment, larger with the
    # knee straight (gastrocnemius) than flexed.
    straight, flexed = riener_edrich.ankle_moment(D(0), D(15)), riener_edrich.ankle_moment(
        D(60), D(15))
    assert straight < flexed < 0
    # Hip flexion stretches the hamstrings: more knee flexion moment.
    assert riener_edrich.knee_moment(D(40), D(20), 0.0) > riener_edrich.knee_moment(
        0.0, D(20), 0.0)
    # Deep knee flexion stretches the quadriceps: an extension (negative) moment.
    assert riener_edrich.knee_moment(0.0, D(100), 0.0) < 0
    with pytest.raises(ValueError, match="knee and the ankle"):
        riener_edrich.passive_moment("hip", 0.0, 0.0, 0.0)


def test_compare_known_answers():
    literature = np.array([-2.0, 1.0, 4.0])
    stats = compare(1.5 * literature, np.full(3, 0.5), literature)
    assert stats["rms_difference_n_m"] == pytest.approx(0.5 * math.sqrt(21 / 3))
    assert stats["rms_identified_n_m"] == pytest.approx(1.5 * math.sqrt(21 / 3))
    assert stats["within_factor_fraction"] == 1.0                   # ratio 1.5 everywhere
    assert stats["inside_band_fraction"] == pytest.approx(1 / 3)   # |0.5 x (-2, 1, 4)| <= 0.5
    mixed = compare(np.array([-5.0, -1.0, 2.0]), np.zeros(3), literature)  # 2.5, -1, 0.5
    assert mixed["within_factor_fraction"] == pytest.approx(1 / 3)
    assert compare(-literature, np.zeros(3), literature)["within_factor_fraction"] == 0.0
    assert compare(literature, np.zeros(3), np.zeros(3))["within_factor_fraction"] == 0.0


def test_literature_check_uses_each_samples_own_angles():
    model = build_model(["knee", "ankle"], fit={"knee": ["k", "theta0"], "ankle": ["k"]})
    values = {**model.values(), "knee.k": 10.0, "knee.theta0": 0.6, "ankle.k": 20.0}
    information = np.diag([4.0, 100.0, 1.0])
    angles = {"hip_flexion": np.radians([10.0, 20.0, np.nan, 30.0]),
              "knee_flexion": np.radians([60.0, 40.0, 30.0, 10.0]),
              "ankle_dorsiflexion": np.radians([-5.0, 0.0, 0.0, 5.0])}
    checks = literature_check(model, values, information, angles)
    keep = [0, 1, 3]                                  # the NaN sample is left out
    hip, knee, ankle = (angles[k][keep] for k in ("hip_flexion", "knee_flexion",
                                                  "ankle_dorsiflexion"))
    assert checks["knee"].literature == pytest.approx(riener_edrich.knee_moment(hip, knee,
                                                                                ankle))
    assert checks["ankle"].literature == pytest.approx(riener_edrich.ankle_moment(knee, ankle))
    assert checks["knee"].identified == pytest.approx(np.asarray(
        model.passive_joint("knee", values).moment(knee, 0 * knee)))
    # The band of the ankle's one fitted parameter k (SE 1 N m/rad): 1.96 |theta|.
    assert checks["ankle"].band == pytest.approx(1.96 * np.abs(ankle), rel=1e-5)
    summary = checks["knee"].as_dict()
    assert summary["quiet_samples"] == 3 and summary["angle_range_deg"] == [10.0, 60.0]
    assert summary["hip_tilt_sensitivity_n_m"] > 0     # the knee depends on the hip
    assert summary["text"].startswith("knee RMS difference")
