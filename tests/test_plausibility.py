"""Plausibility checks (issue 30 item 1): per check a case that triggers it and one that
does not; the status and warning lines they give; the plates' body mass (known answer);
the warnings of the bundled subject01 runs in summary.json, on the console and in the
report headline."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from predgait.analysis import plausibility as pl
from predgait.data.body_weight import plate_body_mass
from predgait.data.trial import ForcePlate

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def _one(check):
    """The warning line of a failed check (and that it failed)."""
    assert not check.passed
    line = check.line()
    assert check.source in line and check.bound in line
    return line


# --------------------------------------------------------------------- each check
def test_joint_moment_within_walking_passes_beyond_warns():
    ok = pl.joint_moment_checks({"hip_flexion_moment": 0.58, "knee_flexion_moment": 0.61,
                                 "ankle_dorsiflexion_moment": 1.71})   # subject01
    assert len(ok) == 3 and all(c.passed for c in ok)
    bad = pl.joint_moment_checks({"ankle_dorsiflexion_moment": 2.32, "pelvis_tilt": 9.0})
    assert len(bad) == 1    # only hip/knee/ankle moments are judged
    line = _one(bad[0])
    assert "ankle_dorsiflexion_moment" in line and "2.32 N m/kg" in line and "<= 2.2" in line
    assert "Winter 2009" in line


def test_grf_within_walking_passes_above_2bw_warns():
    assert pl.grf_check(1.07).passed                  # subject01
    line = _one(pl.grf_check(3.13))                    # predict_gait7 in the issue
    assert "3.13 BW" in line and "<= 2 BW" in line and "Keller" in line
    assert pl.grf_check(float("nan")).passed           # nothing to judge


def test_residual_within_5_percent_passes_above_warns():
    assert pl.residual_check(40.0, 929.0).passed        # limit 46.45 N
    line = _one(pl.residual_check(172.2, 929.0))
    assert "172 N" in line and "<= 46 N" in line and "Hicks" in line


def test_marker_rms_under_20mm_passes_above_warns_naming_the_markers():
    assert pl.marker_check({"RASI": 0.008, "RHEE": 0.0199}).passed
    check = pl.marker_check({"RASI": 0.008, "Sternum": 0.0297, "RELB": 0.021})
    line = _one(check)
    assert "Sternum = 29.7 mm" in line and "also above the bound: RELB" in line
    assert "<= 20 mm" in line
    assert pl.marker_check({}).passed


def test_mass_agreeing_with_plates_passes_disagreeing_warns_with_the_plates_value():
    assert pl.mass_check(72.6, 72.68).passed
    assert pl.mass_check(72.0, None) is None            # plates cannot say
    line = _one(pl.mass_check(72.0, 57.94))
    assert "72 kg" in line and "57.9 kg +- 5 %" in line and "--mass 57.9" in line
    assert pl.mass_check(60.0, 62.9).passed and not pl.mass_check(60.0, 63.3).passed


def test_feedback_below_the_measured_peak_passes_above_warns():
    ok = pl.feedback_checks({"ankle": 60.0, "knee": 20.0}, {"ankle": 124.0, "knee": 44.5})
    assert all(c.passed for c in ok) and len(ok) == 2
    bad = pl.feedback_checks({"ankle": 188.0, "knee": 20.0}, {"ankle": 124.0, "knee": 44.5})
    assert [c.passed for c in bad] == [False, True]
    assert "ankle feedback torque| = 188 N m" in _one(bad[0]) and "<= 124 N m" in bad[0].line()


def test_many_joints_feedback_gives_one_check_naming_the_worst_and_the_others():
    measured = {"knee_r_y": 40.0, "ankle_r_x": 6.8, "hip_r_z": 9.7, "elbow_l": 0.0}
    ok = pl.worst_feedback_check({"knee_r_y": 30.0, "ankle_r_x": 6.0, "elbow_l": 0.0},
                                 measured)
    assert ok.passed and ok.name == "peak |ankle_r_x feedback torque|"   # 6.0 / 6.8 worst
    bad = pl.worst_feedback_check({"knee_r_y": 50.0, "ankle_r_x": 40.1, "hip_r_z": 12.4},
                                  measured, what="feedback torque (free)")
    line = _one(bad)
    assert line.startswith("peak |ankle_r_x feedback torque (free)| = 40.1 N m")
    assert "<= 6.8 N m" in line and line.endswith(
        "also above their measured peaks: hip_r_z, knee_r_y")
    assert pl.worst_feedback_check({"elbow_l": 1.0}, measured).name.startswith(
        "peak |elbow_l")    # any feedback on a joint with no measured moment is the worst
    assert pl.worst_feedback_check({"neck": 3.0}, measured) is None


def test_a_baseline_failing_its_human_likeness_checks_warns():
    assert pl.baseline_check(0, 14).passed
    assert pl.baseline_check(0, 0) is None            # no check was run: nothing to say
    line = _one(pl.baseline_check(3, 14))
    assert line.startswith("baseline gait: failed checks against normal gait = 3, outside "
                           "<= 0 of 14") and line.endswith("(baseline.warnings)")


# ------------------------------------------------------------------ status, lines
@pytest.mark.parametrize(("status", "after"), [
    ("completed", "completed with warnings"),
    ("solved", "solved with warnings"),
    ("completed with 100 flagged frames", "completed with 100 flagged frames and warnings"),
    ("event", "event"),
    ("not converged", "not converged"),
])
def test_record_qualifies_a_finished_status_only(status, after):
    summary = pl.record({"status": status}, [pl.grf_check(3.0), pl.grf_check(1.0), None])
    assert summary["status"] == after
    assert summary["warnings"] == [pl.grf_check(3.0).line()]
    assert [c["passed"] for c in summary["plausibility"]] == [False, True]
    assert pl.warning_lines(summary) == ["  warning: " + pl.grf_check(3.0).line()]


def test_record_without_failures_keeps_completed():
    summary = pl.record({"status": "completed", "warnings": ["earlier"]}, [pl.grf_check(1.0)])
    assert summary["status"] == "completed" and summary["warnings"] == ["earlier"]


# ------------------------------------------------------------ plates' body mass
def _walk(mass: float, *, plates: int = 2, rate: float = 1000.0) -> list[ForcePlate]:
    """Alternating stances (0.6 s, one every 0.5 s, 0.1 s double support) on ``plates``
    plates; total vertical force m (g + a(t)) with a(t) periodic over a step, so its mean
    over any step is m g."""
    t = np.arange(0.0, 3.0, 1.0 / rate)
    total = mass * (9.81 + 2.0 * np.cos(2 * np.pi * (t - 0.25) / 0.5))
    forces = np.zeros((plates, t.size))
    for k in range(7):     # the first and last stances are cut by the recording
        start = -0.3 + 0.5 * k
        s = (t - start) / 0.6
        share = np.clip(s / (0.1 / 0.6), 0, 1) * np.clip((1 - s) / (0.1 / 0.6), 0, 1)
        forces[k % plates] += np.where((s >= 0) & (s <= 1), share, 0.0)
    forces = forces / np.maximum(forces.sum(axis=0), 1e-12) * total
    forces[:, forces.sum(axis=0) < 1e-9] = 0.0
    out = []
    for f in forces:
        force = np.zeros((t.size, 3))
        force[:, 2] = f
        out.append(ForcePlate(time=t, force=force, cop=np.zeros((t.size, 3)),
                              free_moment=np.zeros((t.size, 3)), name=f"plate {len(out) + 1}"))
    return out


def test_plate_mass_recovers_the_mass_of_a_walk():
    result = plate_body_mass(_walk(61.3))
    assert result is not None and len(result.steps) >= 3
    assert result.mass == pytest.approx(61.3, rel=2e-3)
    assert all(b - a == pytest.approx(0.5, abs=2e-3) for a, b in result.windows)


def test_plate_mass_needs_overlapping_stances_on_two_plates():
    assert plate_body_mass(_walk(61.3)[:1]) is None               # one plate
    assert plate_body_mass(_walk(61.3, plates=1)) is None         # both feet on one plate


def test_plate_mass_of_the_bundled_trials():
    from predgait.data import load_subject01, read_c3d

    assert plate_body_mass(load_subject01().plates).mass == pytest.approx(72.6, rel=0.01)
    c3d = DATA / "opensim_walking5_c3d" / "walking5.c3d"
    assert plate_body_mass(read_c3d(c3d).plates).mass == pytest.approx(57.9, abs=0.1)


# ----------------------------------------------------------- in the workflows
def _inverse(tmp_path, capsys, *extra):
    from predgait.cli import main

    out = tmp_path / "out"
    assert main(["inverse", str(REPO / "problems" / "inverse_subject01.toml"), "--out",
                 str(out), "--no-plots", *extra]) == 0
    return out, json.loads((out / "summary.json").read_text()), capsys.readouterr().out


def test_leg_inverse_warns_on_a_wrong_mass_everywhere(tmp_path, capsys):
    from predgait.report.headline import headline
    from predgait.report.html import build_report

    out, summary, stdout = _inverse(tmp_path, capsys, "--mass", "60")
    assert summary["status"] == "completed with warnings"
    [line] = [w for w in summary["warnings"] if "body mass" in w]
    assert "60 kg" in line and "--mass 72.7" in line
    assert f"  warning: {line}" in stdout and "completed with warnings" in stdout
    assert line in headline(out).warnings and headline(out).ok
    assert "warning: body mass = 60 kg" in build_report(out)


def test_leg_inverse_of_subject01_has_no_warning(tmp_path, capsys):
    _, summary, stdout = _inverse(tmp_path, capsys)
    assert summary["status"] == "completed" and summary["warnings"] == []
    assert len(summary["plausibility"]) == 5 and "warning" not in stdout


def test_stiff_knee_scenario_warns_on_its_feedback(tmp_path, capsys):
    from predgait.cli import main

    out = tmp_path / "sc"
    assert main(["scenario", str(REPO / "problems" / "scenario_stiff_knee.toml"), "--out",
                 str(out), "--no-plots"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed with warnings"
    peaks = summary["metrics"]["peaks"]
    assert peaks["feedback_n_m"]["ankle"] > peaks["measured_drive_n_m"]["ankle"]
    assert any(w.startswith("peak |ankle feedback torque|") for w in summary["warnings"])
    assert "warning: peak |ankle feedback torque|" in capsys.readouterr().out


def test_fullbody_marker_check_judges_trusted_markers_only():
    """Down-weighted markers (IK weight < 1, e.g. subject01's arms from a T-pose static
    trial) are not judged; a trusted one above 20 mm is."""
    from types import SimpleNamespace

    from predgait.workflows.inverse3d import inverse3d_checks

    n = 20
    residuals = np.column_stack([np.full(n, 0.008), np.full(n, 0.100), np.full(n, 0.025)])
    result = SimpleNamespace(
        model=SimpleNamespace(total_mass=lambda: 70.0, gravity=9.81), valid=np.ones(n, bool),
        plates=(), plate_mass=None, trusted=("RASI", "STRN"),
        ik=SimpleNamespace(residuals=residuals, marker_names=("RASI", "RELB", "STRN")))
    [check] = [c for c in inverse3d_checks(result, {}, np.zeros(n), np.zeros(n, bool)) if c]
    assert not check.passed and "STRN = 25 mm" in check.line() and "RELB" not in check.line()
    result.trusted = ("RASI",)
    [check] = [c for c in inverse3d_checks(result, {}, np.zeros(n), np.zeros(n, bool)) if c]
    assert check.passed and check.value == pytest.approx(8.0)


def test_mass_plates_weighs_the_subject(tmp_path, capsys):
    """``--mass plates``: subject01's plates give 72.7 kg (its README: 72.6 kg)."""
    _, summary, _ = _inverse(tmp_path, capsys, "--mass", "plates")
    assert summary["provenance"]["mass_kg"] == pytest.approx(72.7, abs=0.05)
    assert summary["provenance"]["mass_from"] == "plates"
    assert not [w for w in summary["warnings"] if "body mass" in w]


def test_mass_plates_without_two_plates_is_refused(tmp_path, capsys):
    from predgait.cli import main

    assert main(["inverse", str(REPO / "problems" / "inverse_winter_a1.toml"), "--mass",
                 "plates", "--out", str(tmp_path / "out")]) == 2
    assert "cannot weigh the subject: give the body mass in kg" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("change", "passed"), [((20.0, 5.0), [True, True]),
                                                ((150.0, 5.0), [False, True])])
def test_torque_correction_larger_than_the_measured_moment_warns(change, passed):
    """A correction of the measured drive (N m) beyond its peak |moment| is implausible."""
    from types import SimpleNamespace

    from predgait.workflows.solve import Kind, solve_checks

    spec = SimpleNamespace(kind=Kind.TORQUE_CORRECTION)
    fit = SimpleNamespace(torque_change=np.array([[0.0, 0.0], change]), parameters={})
    drivers = SimpleNamespace(joint_torque=lambda t: np.array([-124.0 * t, 44.5 * t]))
    checks = solve_checks(spec, fit, drivers, SimpleNamespace(t=np.array([0.0, 1.0])))
    assert [c.passed for c in checks] == passed
    assert checks[0].name == "peak |ankle torque correction|" and checks[0].bound == "<= 124 N m"
