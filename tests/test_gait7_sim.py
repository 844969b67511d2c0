"""gait7 forward simulation on the measured walk (thesis 2.3.1, 2.4; simulations.gait7_*).

Known answers: the IMPACT fit to Meglan has closed forms on [0, D]; a model standing on
four linear IMPACT points sinks m g / (4 k); the mapped motion puts the gait7 joint
centres and feet where the legs' IK put them; on the real trial the simulated vertical
GRF follows the plates and averages body weight; a knee driven by the model's own
inverse-dynamics moment stays on the reference; stiffer knee springs delay the fall.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.cli import main
from predgait.data import read_trc
from predgait.data.frames import rotate_markers
from predgait.dynamics.contact import MeglanContact
from predgait.dynamics.contact_fit import fit_impact_to_meglan
from predgait.dynamics.forces import GroundContact
from predgait.dynamics.gait7_motion import (
    SIDES,
    bundled_gait7_motion,
    frame_positions,
    gait7_model,
)
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.inverse_options import bundled_options
from predgait.dynamics.leg_measurements import read_trial
from predgait.dynamics.partitioned import PartitionedSystem
from predgait.dynamics.passive import LinearSpringDamper, PassiveJoint
from predgait.errors import InputError
from predgait.kinematics.joint_centres import harrington_hip
from predgait.models.gait7 import CONTACT_FRAMES
from predgait.simulations.gait7_sim import (
    GAIT7_FALL,
    KneeMoment,
    grf_comparison,
    initial_height,
    kinematic_run,
    knee_moment_history,
    knee_run,
)
from predgait.workflows.simulate import parse_spec

PROBLEM = Path(__file__).resolve().parents[1] / "problems" / "gait7_contact.toml"
SPAN = (0.62, 1.85)  # s: one right gait cycle of subject01
OPTIONS = IntegratorOptions(method=Method.LSODA)


@pytest.fixture(scope="module")
def model():
    return gait7_model(72.6, 1.8034)


@pytest.fixture(scope="module")
def motion(model):
    return bundled_gait7_motion(model)


@pytest.fixture(scope="module")
def window(motion):
    t = motion.plate_time
    return t[(t >= SPAN[0]) & (t <= SPAN[1])]


@pytest.fixture(scope="module")
def kinematic(model, motion, window):
    return kinematic_run(model, motion, fit_impact_to_meglan().contact, ground_z=-0.0075,
                         t_span=SPAN, options=OPTIONS, t_eval=window)


def test_impact_fit_has_the_least_squares_closed_form():
    """k = a D^3 / 2, c = (175/364) b D^4 (d = D) for F = a x^4 + b x^4 v on [0, D]."""
    meglan, depth = MeglanContact(), 0.01
    fit = fit_impact_to_meglan(meglan, depth=depth)
    assert fit.contact.stiffness == pytest.approx(meglan.a * depth**3 / 2, rel=2e-3)
    assert fit.contact.damping == pytest.approx(175 / 364 * meglan.b * depth**4, rel=2e-3)
    assert fit.contact.damping_depth == depth
    # The fitted curve stays within 20 % (RMS) of Meglan's force at 1 cm (465.8 N) ...
    assert fit.stiffness_rms < 0.2 * meglan.a * depth**4
    # ... and is the least-squares optimum: a 2 % change of k makes the misfit worse.
    x = np.linspace(0.0, depth, 2001)
    for k in (0.98 * fit.contact.stiffness, 1.02 * fit.contact.stiffness):
        assert np.sqrt(np.mean((k * x - meglan.a * x**4) ** 2)) > fit.stiffness_rms


def test_standing_height_sinks_weight_over_four_springs(model):
    """Feet flat at rest: the initial height puts each point m g / (4 k) into the floor."""
    pm = model.pin_model
    contact = fit_impact_to_meglan().contact
    q = np.zeros(pm.nq)
    ground = GroundContact(model, CONTACT_FRAMES, contact, ground_z=0.0, planar=True)
    system = PartitionedSystem(model, [1], lambda t: (q.copy(), np.zeros(pm.nv),
                                                      np.zeros(pm.nv)), [ground])
    z = initial_height(system, 0.0, 1, 0.0)
    data = pm.createData()
    pin.framesForwardKinematics(pm, data, np.r_[0.0, z, np.zeros(pm.nq - 2)])
    depth = -data.oMf[model.frame_id("heel_r")].translation[2]
    weight = model.total_mass() * model.gravity
    assert depth == pytest.approx(weight / (4 * contact.stiffness), rel=1e-6)


def test_mapping_puts_joint_centres_and_feet_where_measured(model, motion):
    """gait7 FK at the mapped coordinates vs the legs' IK frames and the foot markers.

    Bound: the regression segment lengths of gait7 (thigh + shank 0.886 m) differ from the
    static-calibrated legs (right 0.891 m, left 0.880 m) and both hips share one point,
    so centimetres of difference remain; a sign or side error gives decimetres.
    """
    frames = [f"{p}_{s}" for s in "rl" for p in ("knee_center", "ankle_center", "heel", "toe")]
    sim = frame_positions(model, motion.q, frames)
    for frame in frames:
        d = (sim[frame] - motion.points[frame])[:, [0, 2]]
        assert np.sqrt(np.mean(np.sum(d**2, axis=1))) < 0.025, frame
        assert np.max(np.abs(d)) < 0.035, frame
    # Against the raw foot markers: horizontally within 3 cm RMS; vertically the markers
    # sit a constant few cm above the sole points (std < 1.5 cm; measured 0.7-1.1 cm).
    markers = read_trial(bundled_options())[0].markers
    feet = frame_positions(model, motion.q, ["heel_r", "toe_r", "heel_l", "toe_l"])
    for frame, name in (("heel_r", "R.Heel"), ("toe_r", "R.Toe.Tip"), ("heel_l", "L.Heel"),
                        ("toe_l", "L.Toe.Tip")):
        d = feet[frame] - markers.get(name)
        assert np.sqrt(np.mean(d[:, 0] ** 2)) < 0.03, frame
        assert -0.06 < np.mean(d[:, 2]) < 0.0 and np.std(d[:, 2]) < 0.015, frame
    hip = 0.5 * (motion.points["hip_center_r"] + motion.points["hip_center_l"])
    np.testing.assert_allclose(frame_positions(model, motion.q, ["hip_center"])["hip_center"],
                               hip, atol=1e-9)


def test_hat_points_from_the_hip_to_the_shoulders(model, motion):
    """The HAT's centre of mass lies on the hip-to-acromion line (base_pitch sign)."""
    markers = read_trial(bundled_options())[0].markers
    shoulder = 0.5 * (markers.get("R.Acromium") + markers.get("L.Acromium"))
    hip = 0.5 * (motion.points["hip_center_r"] + motion.points["hip_center_l"])
    pm = model.pin_model
    data = pm.createData()
    hat = pm.getJointId("root")
    for k in range(0, len(motion.time), 10):
        pin.forwardKinematics(pm, data, motion.q[k])
        com = data.oMi[hat].act(pm.inertias[hat].lever)
        lean_model = np.arctan2(*(com - hip[k])[[0, 2]])
        lean_markers = np.arctan2(*(shoulder[k] - hip[k])[[0, 2]])
        assert lean_model == pytest.approx(lean_markers, abs=np.radians(1.0))


def test_simulated_vertical_grf_follows_the_plates(model, motion, window, kinematic):
    """Thesis 2.4: "a noisy facsimile". Measured here: r = 0.73 (right), 0.63 (left).

    Bound r > 0.5 per foot: stance/swing alternation must come out right (swapping the
    feet gives r < 0); the force is noisy (toe drag in swing, early contact), as in the
    thesis. Over the cycle the total vertical force averages body weight (momentum
    balance; the plates give 714.5 N for 712.2 N).
    """
    assert kinematic.status == "completed"
    rows = np.searchsorted(motion.plate_time, kinematic.run.t)
    for side in SIDES:
        measured = motion.plate_fz[side][rows]
        assert grf_comparison(window, kinematic.foot_fz(side), measured)["correlation"] > 0.5
        other = motion.plate_fz["left" if side == "right" else "right"][rows]
        assert np.corrcoef(kinematic.foot_fz(side), other)[0, 1] < 0.0
    weight = model.total_mass() * model.gravity
    total = kinematic.foot_fz("right") + kinematic.foot_fz("left")
    assert np.mean(total) == pytest.approx(weight, rel=0.01)
    z = model.coordinate_index("base_z")
    dz = kinematic.run.q[:, z] - np.interp(kinematic.run.t, motion.time, motion.q[:, z])
    assert np.std(dz) < 0.01  # HAT height follows the measured hip within 1 cm RMS


def test_floor_is_the_plate_surface_and_walking_sits_as_static_standing(model, motion,
                                                                         kinematic):
    """ground_z = the plates' COP height; the HAT offset in walking matches standing.

    Standing feet flat on that floor (static trial), gait7's hip is lower than the
    subject's (Harrington) hip centre: regression thigh + shank + ankle height 0.956 m
    vs 0.989 m measured, plus the m g / (4 k) sink. Walking on the same floor, the mean
    HAT offset from the measured hip must be that offset within 1.5 cm (single support
    doubles the load per point: about 0.8 cm more sink).
    """
    options = bundled_options()
    trial, turn = read_trial(options)
    cop_z = np.concatenate([p.cop[p.force[:, 2] > 20.0, 2] for p in trial.plates])
    ground_z = parse_spec(PROBLEM).ground_z
    assert ground_z == pytest.approx(np.median(cop_z), abs=1e-4)
    static = rotate_markers(read_trc(options.static), turn)
    pelvis = [static.get(n) for n in ("R.ASIS", "L.ASIS", "V.Sacral")]
    hip_z = np.mean([harrington_hip(*pelvis, side=s)[:, 2].mean() for s in SIDES])
    pm = model.pin_model
    q = np.zeros(pm.nq)
    ground = GroundContact(model, CONTACT_FRAMES, fit_impact_to_meglan().contact,
                           ground_z=ground_z, planar=True)
    system = PartitionedSystem(model, [1], lambda t: (q.copy(), np.zeros(pm.nv),
                                                      np.zeros(pm.nv)), [ground])
    standing = initial_height(system, 0.0, 1, 0.0) - hip_z
    assert -0.06 < standing < -0.02
    z = model.coordinate_index("base_z")
    walking = np.mean(kinematic.run.q[:, z]
                      - np.interp(kinematic.run.t, motion.time, motion.q[:, z]))
    assert walking == pytest.approx(standing, abs=0.015)


def test_swing_knee_moment_equals_leg_inverse_dynamics(model, motion, kinematic):
    """Where neither the plate nor the model's foot has contact, the knee moment is the
    shank and foot inertia alone: gait7's own (the prescription's reaction) and the leg
    inverse dynamics must agree (measured: r = 0.96 / 0.99, RMS 1.0 / 1.3 N m against
    3.5 N m RMS; a sign error in the mapping gives r < 0, other inertias a few N m).
    """
    rows = np.searchsorted(motion.plate_time, kinematic.run.t)
    for side in SIDES:
        free = (motion.plate_fz[side][rows] < 1.0) & (kinematic.foot_fz(side) == 0.0)
        assert free.sum() > 60  # at least 0.1 s of swing at 600 Hz
        own, leg = (knee_moment_history(model, motion, kinematic, (side,), source,
                                        PassiveJoint()) for source in KneeMoment)
        a = np.array([own(t)[0] for t in kinematic.run.t[free]])
        b = np.array([leg(t)[0] for t in kinematic.run.t[free]])
        assert np.corrcoef(a, b)[0, 1] > 0.9
        assert np.sqrt(np.mean((a - b) ** 2)) < 2.0


def _knee(model, motion, kinematic, source, k, c):
    passive = PassiveJoint((LinearSpringDamper(k=k, c=c),))
    return knee_run(model, motion, kinematic, fit_impact_to_meglan().contact,
                    ground_z=-0.0075, sides=("left",), source=source, passive=passive,
                    fall=GAIT7_FALL, options=OPTIONS, t_eval=kinematic.run.t)


def test_knee_driven_by_the_models_own_moment_stays_on_the_reference(model, motion,
                                                                      kinematic):
    run = _knee(model, motion, kinematic, KneeMoment.MODEL, 1.0, 0.1)
    assert run.status == "completed"
    knee = model.coordinate_index("knee_l")
    assert np.max(np.abs(run.run.q[:, knee] - kinematic.run.q[:, knee])) < np.radians(1.0)


def test_stiffer_knee_spring_delays_the_fall_with_measured_moments(model, motion, kinematic):
    """Thesis 2.4: falls when the knee spring is not stiff enough."""
    falls = [_knee(model, motion, kinematic, KneeMoment.MEASURED, k, 0.1 * k)
             for k in (0.0, 10.0)]
    assert all(r.status == "event" and r.fall_cause == "left knee deviation" for r in falls)
    assert falls[0].time_to_fall < falls[1].time_to_fall
    assert _knee(model, motion, kinematic, KneeMoment.MEASURED, 1000.0, 10.0).status == \
        "completed"


@pytest.mark.parametrize(("setting", "key"), [
    ("contact.model=coulomb", "contact.model"),
    ("knee.sides=['middle']", "knee.sides"),
    ("knee.moment=guess", "knee.moment"),
    ("contact.stiffness=1e4", "contact.stiffness"),
    ("trial.source=other", "trial.source"),
])
def test_bad_input_names_the_key(setting, key):
    with pytest.raises(InputError, match=key.replace(".", r"\.")):
        parse_spec(PROBLEM, [setting])


def test_cli_writes_the_result_folder(tmp_path, capsys, assert_tidy_result):
    out = tmp_path / "gait7"
    assert main(["simulate", str(PROBLEM), "--out", str(out)]) == 0
    for name in ("states.sto", "states_knee.sto", "grf.sto", "grf.csv", "grf.png",
                 "knee.png", "stick.png", "stick.gif", "summary.json"):
        assert (out / name).is_file(), name
    summary = assert_tidy_result(out / "summary.json")
    assert summary["kind"] == "gait7" and summary["grf"]["right"]["correlation"] > 0.5
    # Angles in the stated unit (rad): one gait cycle of the kinematic run reaches the
    # right knee's swing peak, 55-70 deg flexion in normal gait (Kadaba 1990).
    from predgait.data.storage import read_storage

    states = read_storage(out / "states.sto")
    assert states.header["units"].startswith("m, rad") and not states.in_degrees
    assert 50.0 < np.degrees(np.nanmax(states.column("knee_r"))) < 75.0
    # OpenSim's 2D gait coordinates (issue 31): degrees, knee_angle negative in flexion
    motion = read_storage(out / "motion.mot")
    assert motion.in_degrees and motion.header["units"].startswith("deg")
    np.testing.assert_allclose(motion.column("knee_angle_r"),
                               -np.degrees(states.column("knee_r")), atol=1e-6)
    assert 50.0 < -np.min(motion.column("knee_angle_r")) < 75.0
    names = [r["name"] for r in summary["runs"]]
    assert names[0] == "main" and "meglan" in names
    assert "GRF r R/L" in capsys.readouterr().out
    assert main(["simulate", str(PROBLEM), "--out", str(out), "--set",
                 "contact.model=coulomb"]) == 2
    assert "contact.model" in capsys.readouterr().err
