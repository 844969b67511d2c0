"""Whole-body forward dynamics driven by its 3D inverse dynamics (simulations.forward3d).

Known answers: a synthesized motion with consistent foot wrenches is reproduced by its
own inverse-dynamics moments (ID -> FD round trip, pelvis prescribed and free); with
the translation alone free and no load the centre of mass falls ballistically; on the
real subject01 walk the measured accelerations are recovered at the frames, the
moment-driven body falls at the joint its linearisation says grows fastest, keeping the
pelvis on its measured path keeps the joints in band longer than freeing it, and the
thesis' kinematic experiment (2.4) falls with the pelvis orientation free but not with
only its translation free.
"""

import json
import re
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

from predgait.cli import main
from predgait.data.storage import read_storage
from predgait.dynamics.external import Load, joint_forces
from predgait.dynamics.forces import JointFeedback
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.inverse3d import velocities
from predgait.errors import InputError
from predgait.models.loading3d import load_fullbody
from predgait.simulations.forward3d import (
    FULLBODY_FALL,
    FullbodyDrive,
    GroundMode,
    JointMode,
    Mode,
    PelvisMode,
    build_system,
    feedback_peaks,
    simulate_fullbody,
)
from predgait.workflows.forward3d_run import inverse_for, run_fullbody
from predgait.workflows.simulate import parse_spec

PROBLEM = Path(__file__).resolve().parents[1] / "problems" / "fullbody_resynthesis.toml"
RK4 = IntegratorOptions(method=Method.RK4, step=1e-3)


# ------------------------------------------------------------------ synthetic
def synthetic_drive(model, duration=0.08, rate=1000.0):
    """Smooth walking-like motion at ``rate`` Hz; the pelvis root wrench of RNEA is
    carried by the two feet (shares varying smoothly), so ID has zero pelvis residual."""
    pm, data = model.pin_model, model.pin_model.createData()
    rng = np.random.default_rng(3)
    time = np.arange(0.0, duration + 0.5 / rate, 1.0 / rate)
    amp, phase = rng.uniform(0.05, 0.3, 29), rng.uniform(0, 6, 29)
    q = np.tile(model.neutral(), (time.size, 1))
    q[:, 0] = 0.3 + 1.2 * time
    q[:, 2] = 0.95 + 0.02 * np.sin(12 * time)
    for k, t in enumerate(time):
        rot = pin.rpy.rpyToMatrix(0.03 * np.sin(6 * t), 0.05, 0.1 * np.sin(6 * t))
        q[k, 3:7] = pin.Quaternion(rot).coeffs()
    q[:, 7:] = np.clip(amp * np.sin(2 * np.pi * time[:, None] + phase),
                       pm.lowerPositionLimit[7:], pm.upperPositionLimit[7:])
    v, a = velocities(model, time, q)
    share = 0.5 + 0.3 * np.sin(8 * time)
    wrench = {"r": np.zeros((time.size, 6)), "l": np.zeros((time.size, 6))}
    tau = np.zeros((time.size, pm.nv))
    for k in range(time.size):
        root = pin.rnea(pm, data, q[k], v[k], a[k])[:6].copy()
        pin.framesForwardKinematics(pm, data, q[k])
        world = data.oMi[1].act(pin.Force(root))  # about the lab origin
        wrench["r"][k] = share[k] * world.vector
        wrench["l"][k] = (1 - share[k]) * world.vector
        loads = [Load(f"foot_{s}", w[k, :3], np.zeros(3), w[k, 3:]) for s, w in wrench.items()]
        tau[k] = pin.rnea(pm, data, q[k], v[k], a[k], joint_forces(model, data, loads))
    return FullbodyDrive(model, time, q, v, a, tau, wrench, source="synthetic")


@pytest.fixture(scope="module")
def synthetic():
    return synthetic_drive(load_fullbody())


def test_synthetic_drive_is_consistent(synthetic):
    weight = synthetic.model.total_mass() * 9.81
    assert np.abs(synthetic.tau[:, :6]).max() < 1e-9 * weight  # no pelvis residual
    assert synthetic.foot_wrench["r"][:, 2].min() > 0.2 * weight  # the feet carry the body


@pytest.mark.parametrize("pelvis", [PelvisMode.PRESCRIBED, PelvisMode.FREE])
def test_round_trip_inverse_to_forward(synthetic, pelvis):
    """The ID moments and the foot wrenches reproduce the motion (0.03 s, RK4 0.5 ms)."""
    fine = IntegratorOptions(method=Method.RK4, step=5e-4)
    run = simulate_fullbody(synthetic, Mode(pelvis=pelvis), (0.01, 0.04), options=fine)
    assert run.status == "completed" and run.t[-1] == pytest.approx(0.04)
    dev = run.deviation
    assert dev["joint_max_deg"] < 1e-3
    assert dev["pelvis_position_max_m"] < 1e-5 and dev["pelvis_angle_max_deg"] < 1e-3
    # Control: the same run without the ground wrench departs at once.
    bare = FullbodyDrive(synthetic.model, synthetic.time, synthetic.q, synthetic.v,
                         synthetic.a, synthetic.tau, {}, source="no ground")
    wrong = simulate_fullbody(bare, Mode(pelvis=pelvis), (0.01, 0.04), options=fine)
    assert wrong.deviation["joint_max_deg"] > 100 * dev["joint_max_deg"]


def test_translation_only_pelvis_centre_of_mass_is_ballistic(synthetic):
    """Orientation and joints prescribed supply moments only: with no ground the centre
    of mass falls freely."""
    model = synthetic.model
    pm, data = model.pin_model, model.pin_model.createData()
    bare = FullbodyDrive(model, synthetic.time, synthetic.q, synthetic.v, synthetic.a,
                         synthetic.tau, {}, source="no ground")
    mode = Mode(pelvis=PelvisMode.TRANSLATION, joints=JointMode.KINEMATIC)
    system, history, _ = build_system(bare, mode)
    assert system.state_names()[:3] == ["pelvis_tx", "pelvis_ty", "pelvis_tz"]
    run = simulate_fullbody(bare, mode, (0.01, 0.07), fall=replace(FULLBODY_FALL, base_drop=1.0))
    q0, v0, _ = history(0.01)
    c0 = pin.centerOfMass(pm, data, q0, v0).copy()
    vc0 = data.vcom[0].copy()
    t = run.t[-1] - 0.01
    expected = c0 + vc0 * t + 0.5 * np.array([0.0, 0.0, -9.81]) * t**2
    np.testing.assert_allclose(pin.centerOfMass(pm, data, run.q[-1]), expected, atol=1e-6)
    # The orientation and joints followed the measured motion exactly.
    np.testing.assert_allclose(run.q[-1, 3:], history(run.t[-1])[0][3:], atol=1e-12)


# ---------------------------------------------------------------- subject01
@pytest.fixture(scope="module")
def subject01():
    inverse = inverse_for(parse_spec(PROBLEM).trial)
    return FullbodyDrive.from_inverse(inverse)


def test_measured_accelerations_recovered_at_the_frames(subject01):
    """Pelvis prescribed, joints driven by the ID moments, measured plate wrenches: at
    every frame the free joints accelerate exactly as measured."""
    system, history, _ = build_system(subject01, Mode())
    for k in range(20, 140, 17):
        t = subject01.time[k]
        q, v, a = history(t)
        a_free, _ = system.solve(t, q, v, a)
        np.testing.assert_allclose(a_free, subject01.a[k, 6:], atol=1e-7)


@pytest.mark.parametrize("pelvis", [PelvisMode.PRESCRIBED, PelvisMode.FREE])
def test_moment_driven_body_falls_where_linearisation_grows_fastest(subject01, pelvis):
    """The stance foot under the measured wrench is unstable with an e-folding time of
    a few ms (2-5 g m^2 foot, ~100 N m at the ankle): the run falls there within 0.1 s."""
    start = subject01.heel_strikes[0]
    k = int(np.searchsorted(subject01.time, start))
    stance = max("rl", key=lambda s: subject01.foot_wrench[s][k, 2])  # the loaded foot
    run = simulate_fullbody(subject01, Mode(pelvis=pelvis), (start, start + 0.3), options=RK4)
    rate, leading = run.growth
    assert rate > 100.0 and leading.startswith(f"ankle_{stance}_")
    assert run.status == "event" and 0.0 < run.time_to_fall < 0.1
    assert run.fall_criterion.startswith(f"joint angle ankle_{stance}_")


def test_prescribed_pelvis_keeps_joints_in_band_longer(subject01):
    """Ankles kinematic, other joints driven by moments: pelvis prescribed stays within
    5 deg of the measured joint angles longer than pelvis free, which falls."""
    start = subject01.heel_strikes[0]
    runs = {p: simulate_fullbody(subject01, Mode(pelvis=p, kinematic_joints=("ankle",)),
                                 (start, start + 0.4), options=RK4)
            for p in (PelvisMode.PRESCRIBED, PelvisMode.FREE)}
    held, free = runs[PelvisMode.PRESCRIBED], runs[PelvisMode.FREE]
    assert held.deviation["joint_leaves_band_s"] > 1.5 * free.deviation["joint_leaves_band_s"]
    assert free.status == "event" and 0.0 < free.time_to_fall < 0.4
    limits = FULLBODY_FALL  # the run stops at the first limit reached, none is passed
    assert free.deviation["pelvis_angle_max_deg"] <= limits.base_angle_deg + 1e-6
    assert free.deviation["joint_max_deg"] <= limits.joint_deviation_deg + 1e-6
    assert np.abs(held.q[:, 7:] - held.measured[:, 7:])[:, :6].max() > 0  # hips were free
    ankle = [i for i, n in enumerate(subject01.model.joint_names) if n.startswith("ankle")]
    assert np.abs(held.q[:, 7 + np.array(ankle)] - held.measured[:, 7 + np.array(ankle)]).max() \
        < 1e-12


def test_joint_feedback_holds_the_body_only_with_the_pelvis_prescribed(subject01):
    """PD feedback toward the measured angles (kp 100 N m/rad, critically damped per joint)
    stabilises the moment-driven body when the pelvis is prescribed; with the pelvis free
    nothing controls its orientation and the body still falls (thesis: 0.55 s)."""
    start = subject01.heel_strikes[0]
    span = (start, start + 1.0)
    held = simulate_fullbody(subject01, Mode(pelvis=PelvisMode.PRESCRIBED, feedback_kp=100.0),
                             span, options=RK4)
    free = simulate_fullbody(subject01, Mode(pelvis=PelvisMode.FREE, feedback_kp=100.0),
                             span, options=RK4)
    assert held.status == "completed" and held.deviation["joint_max_deg"] < 2.0
    assert free.status == "event" and 0.1 < free.time_to_fall < 1.0


def test_feedback_damping_follows_each_joint_inertia(subject01):
    model = subject01.model
    q = subject01.q[0]
    rows = [6 + model.joint_names.index(n) for n in ("hip_r_y", "ankle_r_z")]
    feedback = JointFeedback.damped(model, rows, lambda t: None, 100.0, 0.5, q)
    inertia = np.diag(pin.crba(model.pin_model, model.pin_model.createData(), q))[rows]
    np.testing.assert_allclose(feedback.kd, np.sqrt(100.0 * inertia))  # 2 * 0.5 * sqrt(kp I)
    assert feedback.kd[0] > 10 * feedback.kd[1]  # thigh vs foot about its long axis


def test_feedback_peaks_are_the_pd_law_along_the_run(synthetic):
    """A run whose right knee lags the measured one by up to 0.02 rad at the measured
    velocities: the PD feedback there peaks at kp * 0.02 = 2 N m, zero elsewhere; the
    measured peak is the inverse-dynamics moment over the run's frames."""
    system, _, _ = build_system(synthetic, Mode(feedback_kp=100.0))
    rows = slice(10, 30)
    q, v = synthetic.q[rows].copy(), synthetic.v[rows]
    j = synthetic.model.joint_names.index("knee_r_y")
    q[:, 7 + j] -= 0.02 * np.linspace(0.0, 1.0, 20)
    feedback, measured = feedback_peaks(system, synthetic,
                                        SimpleNamespace(t=synthetic.time[rows], q=q, v=v))
    assert set(feedback) == set(measured) == set(synthetic.model.joint_names)
    assert feedback["knee_r_y"] == pytest.approx(2.0, rel=1e-9)
    assert max(f for name, f in feedback.items() if name != "knee_r_y") < 1e-9
    assert measured["knee_r_y"] == pytest.approx(np.abs(synthetic.tau[rows, 6 + j]).max())
    plain, _, _ = build_system(synthetic, Mode())
    assert feedback_peaks(plain, synthetic, SimpleNamespace(t=synthetic.time[rows], q=q,
                                                            v=v)) == ({}, {})


def test_cli_feedback_beyond_the_measured_moment_warns(tmp_path, capsys):
    """subject01, 0.5 s, kp 100 N m/rad: with the pelvis prescribed every joint's feedback
    stays below its measured peak moment; with the pelvis free the right ankle's
    inversion feedback reaches ~40 N m against ~7 N m measured (the body drifts off the
    measured motion): one warning for that variant, status "completed with warnings"."""
    text = PROBLEM.read_text().split("\n[[variants]]")[0]
    text = text.replace('marker_map = "markers_fullbody_subject01.toml"',
                        f'marker_map = "{PROBLEM.parent / "markers_fullbody_subject01.toml"}"')
    for name, pelvis in (("held", "prescribed"), ("free", "free")):
        text += (f'\n[[variants]]\nname = "{name}"\npelvis = "{pelvis}"\njoints = "moments"\n'
                 'ground = "measured"\nfeedback_kp = 100.0\n')
    problem = tmp_path / "pd.toml"
    problem.write_text(text)
    out = tmp_path / "pd"
    assert main(["simulate", str(problem), "--out", str(out), "--no-plots",
                 "--set", "simulation.duration=0.5"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    held, free = summary["plausibility"]
    assert held["passed"] and not free["passed"]
    assert held["name"].endswith("feedback torque (held)|")
    assert free["name"] == "peak |ankle_r_x feedback torque (free)|"
    row = summary["runs"][1]
    assert free["value"] == pytest.approx(row["peak_feedback_n_m"]["ankle_r_x"])
    assert free["value"] > 2 * row["peak_measured_moment_n_m"]["ankle_r_x"]
    assert summary["status"] == "completed with warnings"
    [free_line] = summary["warnings"]
    assert "also above their measured peaks: " in free_line
    assert f"  warning: {free_line}" in capsys.readouterr().out


def test_thesis_kinematic_body_on_contacts(subject01):
    """Thesis 2.4: joints kinematic on foot contacts; orientation free falls (Android:
    0.55 s; here 0.4-1.1 s depending on contact law, floor and start), only the
    translation free does not fall."""
    start = subject01.heel_strikes[0]
    runs = {p: simulate_fullbody(subject01, Mode(pelvis=p, joints=JointMode.KINEMATIC,
                                                 ground=GroundMode.CONTACT),
                                 (start, start + 1.5), options=RK4)
            for p in (PelvisMode.TRANSLATION, PelvisMode.FREE)}
    free, held = runs[PelvisMode.FREE], runs[PelvisMode.TRANSLATION]
    assert free.status == "event" and 0.1 < free.time_to_fall < 1.5
    assert free.fall_criterion.startswith("pelvis")
    assert held.status == "completed" and held.t[-1] == pytest.approx(start + 1.5)
    assert held.belt_velocity == pytest.approx(-1.12, abs=0.1)  # treadmill-like trial
    assert abs(held.ground_z) < 0.05


# ---------------------------------------------------------------- problem file and CLI
def test_unknown_mode_value_names_the_key():
    with pytest.raises(InputError, match=r"variants\.1\.pelvis.*'floating' is not one of: "
                                         r"prescribed, translation, free"):
        parse_spec(PROBLEM, ["variants.1.pelvis=floating"])
    with pytest.raises(InputError, match=r"variants\.0\.joints"):
        parse_spec(PROBLEM, ["variants.0.joints=torque"])
    with pytest.raises(InputError, match=r"variants\.8\.step.*outside 1e-06\.\.0\.1"):
        parse_spec(PROBLEM, ["variants.8.step=0"])
    steps = [m.step for m in parse_spec(PROBLEM).variants]
    # Only the bodies on contacts: translating 0.5 ms, free 0.1 ms (their friction ramps).
    assert steps[7:] == [5e-4, 1e-4] and steps[:7] == [None] * 7


def test_missing_file_and_frame_name_their_key(tmp_path):
    with pytest.raises(InputError, match=r"trial\.marker_map.*nowhere\.toml not found"):
        parse_spec(PROBLEM, ["trial.marker_map=nowhere.toml"])
    with pytest.raises(InputError, match=r"contact\.frames: the model has no frame 'heel'"):
        run_fullbody(parse_spec(PROBLEM, ["contact.frames=[\"heel\"]"]), tmp_path)
    assert not list(tmp_path.iterdir())


def test_nothing_free_and_unknown_joint_are_refused(synthetic):
    with pytest.raises(InputError, match="nothing to simulate"):
        build_system(synthetic, Mode(joints=JointMode.KINEMATIC))
    with pytest.raises(InputError, match="kinematic joint 'ankel'"):
        build_system(synthetic, Mode(kinematic_joints=("ankel",)))


def test_cli_writes_states_summary_and_plot(tmp_path, capsys, assert_tidy_result):
    out = tmp_path / "fullbody"
    code = main(["simulate", str(PROBLEM), "--out", str(out),
                 "--set", "simulation.duration=0.3"])
    assert code == 0
    summary = assert_tidy_result(out / "summary.json")
    assert summary["kind"] == "fullbody" and len(summary["runs"]) == 9
    first = summary["runs"][0]
    assert summary["runs"][8]["step_s"] == 1e-4 and first["step_s"] is None
    assert first["status"] == "event" and first["deviation"]["joint_leaves_band_s"] is not None
    assert (out / "fullbody.png").stat().st_size > 10_000
    assert (out / "stick.gif").read_bytes()[:6] == b"GIF89a"
    viewer = json.loads((out / "viewer.json").read_text())   # the measured plates' arrows
    assert {a["name"] for a in viewer["arrows"]} == {"ground reaction, measured plate 0",
                                                     "ground reaction, measured plate 1"}
    assert len(viewer["arrows"][0]["origin"]) == len(viewer["time"])
    sto = read_storage(out / "states_pelvis_free_moments.sto")
    assert {"pelvis_tz", "pelvis_ry", "knee_r_y"} <= set(sto.columns)
    # In the stated unit (deg): the run starts on the measured right knee (the whole-body
    # inverse kinematics of the same trial, kinematics3d.sto in its stated deg).
    assert sto.header["units"].startswith("deg") and sto.in_degrees
    inverse = tmp_path / "inverse"
    assert main(["inverse", str(PROBLEM.parent / "inverse_subject01.toml"), "--model",
                 "fullbody", "--marker-map", str(PROBLEM.parent /
                                                 "markers_fullbody_subject01.toml"),
                 "--no-plots", "--out", str(inverse)]) == 0
    measured = read_storage(inverse / "kinematics3d.sto")
    start = np.interp(sto.time[0], measured.time, measured.column("knee_r_y"))
    assert sto.column("knee_r_y")[0] == pytest.approx(start, abs=2.0)
    assert np.nanmax(measured.column("knee_r_y")) > 50.0   # swing peak: degrees
    assert len(list(out.glob("states_*.sto"))) == 9
    assert re.search(r"\n  pelvis free, moments +event ", capsys.readouterr().out)


def test_cli_bad_value_writes_nothing(tmp_path, capsys):
    out = tmp_path / "bad"
    code = main(["simulate", str(PROBLEM), "--out", str(out), "--set", "fall.joint_deg=-4"])
    assert code == 2 and not out.exists()
    err = capsys.readouterr().err
    assert "fall.joint_deg" in err and "Traceback" not in err
