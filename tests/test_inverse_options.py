"""Options of ``predgait inverse``: flags over TOML keys, cut-offs off/auto, contact
hysteresis, and the bounded IK that flags what the model cannot follow."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.cli import build_parser
from predgait.cli.inverse import options_from_args
from predgait.data.cutoffs import CutoffRule, parse_cutoff
from predgait.data.resample import contact_frames, threshold_plate
from predgait.data.trial import ForcePlate
from predgait.dynamics.inverse_options import THRESHOLD, bundled_options, with_options
from predgait.dynamics.inverse_trial import run_inverse
from predgait.errors import InputError
from predgait.kinematics.bounded_ik import bounded_step
from predgait.kinematics.planar_ik import solve_ik
from predgait.models.loading import load_model

REPO = Path(__file__).resolve().parents[1]
PROBLEM = REPO / "problems" / "inverse_subject01.toml"


def parsed(*argv):
    return options_from_args(build_parser().parse_args(["inverse", *map(str, argv),
                                                        "--out", "unused"]))


def test_problem_file_alone_gives_its_keys():
    options = parsed(PROBLEM)
    assert (options.cutoff, options.grf_cutoff, options.threshold) == (6.0, 6.0, 20.0)
    assert options.release == 1.0
    assert (options.mass, str(options.side)) == (72.6, "right")


@pytest.mark.parametrize(("flag", "value", "field", "expected"), [
    ("--cutoff", "2", "cutoff", 2.0),
    ("--cutoff", "0", "cutoff", None),
    ("--cutoff", "auto", "cutoff", CutoffRule.AUTO),
    ("--grf-cutoff", "15", "grf_cutoff", 15.0),
    ("--grf-cutoff", "0", "grf_cutoff", None),
    ("--threshold", "5", "threshold", 5.0),
    ("--mass", "60", "mass", 60.0),
    ("--side", "left", "side", "left"),
    ("--limit-margin", "10", "limit_margin", 10.0),
])
def test_each_flag_overrides_its_toml_key(flag, value, field, expected):
    options = parsed(PROBLEM, flag, value)
    got = getattr(options, field)
    assert (str(got) if field == "side" else got) == expected
    untouched = parsed(PROBLEM)
    for other in ("cutoff", "grf_cutoff", "threshold", "mass", "side", "limit_margin"):
        if other != field:
            assert getattr(options, other) == getattr(untouched, other), other


@pytest.mark.parametrize(("key", "value", "field", "expected"), [
    ("options.cutoff", "false", "cutoff", None),
    ("options.cutoff", "0", "cutoff", None),
    ("options.cutoff", '"auto"', "cutoff", CutoffRule.AUTO),
    ("options.grf_cutoff", "0", "grf_cutoff", None),
    ("options.grf_cutoff", "false", "grf_cutoff", None),
    ("options.threshold", "7.5", "threshold", 7.5),
    ("options.release", "0.5", "release", 0.5),
    ("trial.mass", "80", "mass", 80.0),
])
def test_set_changes_a_key(key, value, field, expected):
    assert getattr(parsed(PROBLEM, "--set", f"{key}={value}"), field) == expected


def test_a_flag_wins_over_set_and_file():
    assert parsed(PROBLEM, "--set", "options.cutoff=4", "--cutoff", "3").cutoff == 3.0


@pytest.mark.parametrize("argv", [
    (PROBLEM, "--markers", "hip=A"),
    (PROBLEM, "--cutoff", "fast"),
    (PROBLEM, "--grf-cutoff", "auto"),
    (PROBLEM, "--threshold", "-1"),
    (PROBLEM, "--set", "options.cutoff=\"soon\""),
])
def test_options_that_cannot_apply_are_errors(argv):
    with pytest.raises(InputError):
        parsed(*argv)


def test_grf_cutoff_follows_the_markers_by_default():
    """Default: the same cut-off as the markers (off when they are unfiltered)."""
    assert bundled_options().grf_cutoff == CutoffRule.MARKERS
    result = run_inverse(with_options(bundled_options(), cutoff=None))
    assert result.provenance["marker_cutoff_hz"] is None
    assert result.provenance["grf_cutoff_hz"] is None


def test_cutoff_auto_runs_residual_analysis():
    result = run_inverse(with_options(bundled_options(), cutoff=CutoffRule.AUTO))
    chosen = result.provenance["marker_cutoff_hz"]
    # Winter (2009, 3.4.4.4) finds 6 Hz for walking markers; 60 Hz optical data: 3..10 Hz.
    assert 3.0 < chosen < 10.0
    assert result.provenance["grf_cutoff_hz"] == chosen
    assert "residual analysis" in result.provenance["marker_cutoff"]


def test_parse_cutoff():
    assert parse_cutoff(0, field="x") is None
    assert parse_cutoff(False, field="x") is None
    assert parse_cutoff("off", field="x") is None
    assert parse_cutoff("6", field="x") == 6.0
    assert parse_cutoff("auto", field="x", rules=(CutoffRule.AUTO,)) is CutoffRule.AUTO
    for bad in ("auto", -3, True, "six"):
        with pytest.raises(InputError, match="x"):
            parse_cutoff(bad, field="x")


# Contact threshold with hysteresis -------------------------------------------------------

def test_contact_keeps_real_forces_and_holds_only_the_cop():
    """A contact starts at the threshold and lasts while fz > threshold / 2."""
    t = np.arange(0.0, 1.0, 0.001)
    fz = np.where((t > 0.2) & (t < 0.8), 600 * np.sin(np.pi * (t - 0.2) / 0.6) ** 2, 0.0)
    fz[50:60] = 3.0   # noise below half the threshold: never a contact
    contact = contact_frames(fz, THRESHOLD, release=0.5)
    assert np.array_equal(contact_frames(fz, THRESHOLD, release=1.0), fz >= THRESHOLD)
    assert not contact[50:60].any()
    assert contact[(fz > THRESHOLD / 2) & (t > 0.1)].all()
    assert not contact[fz <= THRESHOLD / 2].any()
    cop = np.column_stack([0.1 + 0.3 * t, np.zeros_like(t), np.zeros_like(t)])
    cop[fz < THRESHOLD, 0] = 5.0     # a plate's COP is garbage where the load is small
    force = np.column_stack([0.1 * fz, np.zeros_like(t), fz])
    plate = ForcePlate(time=t, force=force, cop=cop, free_moment=np.zeros_like(cop), name="p")
    out = threshold_plate(plate, threshold=THRESHOLD, release=0.5)
    np.testing.assert_array_equal(out.force[contact], force[contact])     # forces kept
    assert np.all(out.force[~contact] == 0)
    low = contact & (fz < THRESHOLD)
    assert low.sum() > 4
    assert np.all(np.abs(out.cop[low, 0] - 0.1 - 0.3 * 0.5) < 0.2)       # held, not 5 m
    np.testing.assert_array_equal(out.cop[fz >= THRESHOLD], cop[fz >= THRESHOLD])


def test_threshold_changes_only_the_contact_edges():
    """A lower threshold keeps more of the real force; mid-stance moments are unchanged
    (forces unfiltered here: a filter would spread the edges into the stance)."""
    low = run_inverse(with_options(bundled_options(), threshold=5.0, release=0.5,
                                   grf_cutoff=None))
    high = run_inverse(with_options(bundled_options(), threshold=40.0, grf_cutoff=None))
    kept_low, kept_high = low.grf[:, 2] > 0, high.grf[:, 2] > 0
    assert kept_low.sum() > kept_high.sum()
    assert np.all(kept_low[kept_high])
    mid = low.grf[:, 2] > 300
    for name, value in low.clinical_moments().items():
        np.testing.assert_allclose(value[mid], high.clinical_moments()[name][mid], atol=1e-6)


# Bounded IK ------------------------------------------------------------------------------

def test_bounded_step_solves_the_box_constrained_problem():
    rng = np.random.default_rng(3)
    jac, r = rng.normal(size=(8, 4)), rng.normal(size=8)
    lo, hi = np.full(4, -0.05), np.full(4, 0.05)
    step = bounded_step(jac, r, 1e-6, lo, hi)
    assert np.all(step >= lo - 1e-12) and np.all(step <= hi + 1e-12)

    def cost(dv):
        return np.sum((jac @ dv + r) ** 2) + 1e-6 * dv @ dv

    for _ in range(200):   # no feasible point nearby does better
        other = np.clip(step + rng.normal(0, 0.01, 4), lo, hi)
        assert cost(step) <= cost(other) + 1e-12


def leg_points(model, q):
    pm, data = model.pin_model, model.pin_model.createData()
    out = {n: np.zeros((len(q), 3)) for n in ("ankle_center", "knee_center", "hip_center")}
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(pm, data, qk)
        for n in out:
            out[n][k] = data.oMf[model.frame_id(n)].translation
    return out


def test_ik_beyond_the_knee_range_is_flagged_not_clipped():
    """Knee hyperextension past the model's 20 deg: those frames are flagged; the others fit
    exactly; widening the range by a margin fits them all."""
    model = load_model("leg")
    n = 60
    q = np.zeros((n, 5))
    q[:, 0] = np.linspace(0, 0.5, n)
    q[:, 3] = 0.1
    q[:, 4] = np.radians(np.linspace(-40, 35, n))     # model knee: + is hyperextension
    upper = model.pin_model.upperPositionLimit[4]
    fit = solve_ik(model, leg_points(model, q), q[:, 2])
    np.testing.assert_array_equal(fit.flagged, q[:, 4] > upper)
    assert fit.limited_coordinates() == {"knee": int(fit.flagged.sum())}
    assert np.all(fit.q[:, 4] <= upper + 1e-12)                  # never outside the range
    np.testing.assert_allclose(fit.q[~fit.flagged], q[~fit.flagged], atol=1e-8)
    wide = solve_ik(model, leg_points(model, q), q[:, 2], limit_margin=np.radians(20))
    assert not wide.flagged.any()
    np.testing.assert_allclose(wide.q, q, atol=1e-8)


def test_subject01_has_no_flagged_frame():
    result = run_inverse(bundled_options())
    assert not result.ik.flagged.any()
    assert result.status() == "completed"


def test_cli_reports_flagged_frames_and_fails_when_most_are(tmp_path):
    """A margin so negative it excludes the walking knee: most frames flagged -> exit 3,
    outputs written with NaN there; a smaller violation completes with a count."""
    out = tmp_path / "out"
    # Narrow the model: a leg URDF whose knee range is 0..5 deg flexion.
    urdf = load_model("leg").urdf.replace('lower="-2.62"', 'lower="-0.087"')
    (tmp_path / "narrow.urdf").write_text(urdf)
    run = subprocess.run([sys.executable, "-m", "predgait", "inverse", str(PROBLEM),
                          "--model", str(tmp_path / "narrow.urdf"), "--out", str(out)],
                         capture_output=True, text=True)
    assert run.returncode == 3, run.stderr
    assert "predgait: error: inverse kinematics flagged" in run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"].startswith("completed with ")
    assert summary["flagged_frames_at_joint_limits"]["knee"] > 0.5 * summary["flagged_frames"]
    assert f"completed with {summary['flagged_frames']} flagged frames" in run.stdout
    table = np.genfromtxt(out / "inverse_dynamics.csv", delimiter=",", names=True,
                          skip_header=2, comments=None)
    assert np.isnan(table["knee_flexion_moment"]).sum() >= summary["flagged_frames"]


def test_fullbody_tables_are_nan_at_flagged_frames(tmp_path):
    """3D pipeline: frames the IK flags (and 2 on each side) are NaN in every table."""
    import dataclasses

    from predgait.data import read_storage, read_trc
    from predgait.dynamics.inverse3d_trial import (
        clinical,
        inverse_fullbody,
        read_marker_map,
        read_trial,
    )
    from predgait.workflows.inverse3d import write_outputs

    data = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_subject01_walk1"
    markers, plates = read_trial([data / "subject01_walk1.trc",
                                  data / "subject01_walk1_grf.mot"])
    marker_map = read_marker_map(REPO / "problems" / "markers_fullbody_subject01.toml")
    result = inverse_fullbody(markers, plates, marker_map, mass=72.6, height=1.8034,
                              static=read_trc(data / "subject01_static.trc"))
    assert result.status() == "completed"   # (summary: "with warnings", residual and sternum)
    converged = result.ik.converged.copy()
    converged[40:50] = False
    flagged = dataclasses.replace(result, ik=dataclasses.replace(result.ik, converged=converged))
    angles, moments = clinical(flagged)
    for values in (*angles.values(), *moments.values()):
        assert np.isnan(values[38:52]).all() and np.isfinite(values[:38]).all()
    write_outputs(flagged, tmp_path)
    info = json.loads((tmp_path / "summary.json").read_text())
    assert info["status"].startswith("completed with 10 flagged frames")
    table = read_storage(tmp_path / "inverse_dynamics3d.sto")
    assert np.isnan(table.column("knee_r_y_moment")[38:52]).all()


def test_plates_shorter_than_the_markers_name_the_force_file(tmp_path):
    """A force file that stops before the markers: the message names that file."""
    original = bundled_options().grf
    lines = original.read_text().splitlines()
    body = [line.strip() for line in lines].index("endheader") + 2  # header, column names
    kept = lines[:body] + lines[body:body + 900]          # 900 of 1501 rows: 0..1.5 s
    cut = tmp_path / "cut_grf.mot"
    cut.write_text("\n".join(line.replace("nRows=1501", "nRows=900") for line in kept) + "\n")
    with pytest.raises(InputError) as info:
        run_inverse(with_options(bundled_options(), grf=cut))
    message = str(info.value)
    assert message.startswith(f"{cut}:") and "covers t = " in message
    assert "trim the markers" in message
