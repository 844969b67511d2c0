"""Whole-body tracking with contacts and its feedback (issue 18).

Known answers: the symbolic node (one RNEA pass) equals Pinocchio's floating-base rows of
RNEA - J^T f and its contact points; a standing sway simulated by the forward engine
with a known torque history on the engine's contact springs is recovered (torques within
2 % RMS, motion within 0.5 deg). Subject01's whole cycle (its solution re-evaluated by
Pinocchio, near the measured data, with and without feedback):
tests/test_fullbody_tracking_cycle.py.
"""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.dynamics.contact import ImpactContact
from predgait.dynamics.drivers import SampledHistory
from predgait.dynamics.forces import GroundContact, JointFeedback, JointTorques
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.partitioned import PartitionedSystem, simulate_partitioned
from predgait.models.fullbody import SOLE_EDGES
from predgait.models.loading3d import base_transform, load_fullbody
from predgait.problems.fullbody_tracking import (
    POINTS,
    TrackingData,
    contact_inverse_dynamics,
    solve_tracking,
    tracking_nlp,
)
from predgait.problems.fullbody_tracking_stage import node_function, point_feet

REPO = Path(__file__).resolve().parents[1]
PROBLEM = REPO / "problems" / "fullbody_tracking.toml"
CONTACT = ImpactContact(stiffness=2e5, exponent=1.0, damping=2e3, damping_depth=1e-3,
                        friction=0.8, slip_transition=1.0)


@pytest.mark.parametrize("points", [POINTS, SOLE_EDGES], ids=["centre_line", "sole_edges"])
def test_node_function_equals_pinocchio(points):
    model = load_fullbody()
    rng = np.random.default_rng(11)
    node = node_function(model, points)
    count = len(points)
    pm, data = model.pin_model, model.pin_model.createData()
    for _ in range(3):
        q_ref = pin.randomConfiguration(pm, -np.ones(36), np.ones(36))
        q_ref[7:] = rng.uniform(-0.5, 0.5, 29)
        v, a, f = rng.uniform(-2, 2, 35), rng.uniform(-5, 5, 35), rng.uniform(-300, 300, 3 * count)
        eom, xyz, rot, pos, point_vel = (np.asarray(x).ravel() for x in
                                         node(q_ref, np.zeros(35), v, a, f))
        tau = contact_inverse_dynamics(model, q_ref[None], v[None], a[None],
                                       f.reshape(1, count, 3), points)[0]
        np.testing.assert_allclose(eom, tau[:6], atol=1e-8)
        np.testing.assert_allclose(rot.reshape(3, 3, order="F"),
                                   base_transform(q_ref)[:3, :3], atol=1e-12)
        pin.forwardKinematics(pm, data, q_ref, v)
        pin.updateFramePlacements(pm, data)
        for i, name in enumerate(points):
            fid = model.frame_id(name)
            np.testing.assert_allclose(xyz[3 * i: 3 * i + 3],
                                       data.oMf[fid].translation, atol=1e-12)
            vel = pin.getFrameVelocity(pm, data, fid, pin.LOCAL_WORLD_ALIGNED).linear
            np.testing.assert_allclose(point_vel[3 * i: 3 * i + 3], vel, atol=1e-10)


def test_assembled_derivatives_equal_automatic_differentiation():
    """The Jacobian, gradient and Hessian assembled from one node and one interval equal
    CasADi's derivatives of the whole NLP's f and g (4 nodes, random point)."""
    import casadi as cs

    from random_tracking import random_tracking_data

    model = load_fullbody()
    data, rng = random_tracking_data(model)
    problem = tracking_nlp(model, data)
    x, f, g = (problem.nlp[k] for k in ("x", "f", "g"))
    sigma, lam = cs.MX.sym("sigma"), cs.MX.sym("lam", g.size1())
    auto = cs.Function("auto", [x, sigma, lam], [cs.jacobian(g, x), cs.gradient(f, x),
                                                 cs.triu(cs.hessian(sigma * f + cs.dot(lam, g),
                                                                    x)[0])])
    point = problem.x0 + rng.normal(0, 0.05, problem.x0.size)
    weights = rng.normal(size=g.size1())
    jac, grad, hess = (np.asarray(cs.densify(m)) for m in auto(point, 0.7, weights))
    d = problem.derivatives
    np.testing.assert_allclose(cs.densify(d["jac_g"](point, [])[1]), jac, atol=1e-9,
                               rtol=1e-9)
    np.testing.assert_allclose(np.asarray(d["grad_f"](point, [])[1]).ravel(), np.ravel(grad),
                               atol=1e-9, rtol=1e-9)
    np.testing.assert_allclose(cs.densify(d["hess_lag"](point, [], 0.7, weights)), hess,
                               atol=1e-7, rtol=1e-9)
    assert np.abs(hess).max() > 1.0 and np.abs(jac).max() > 1.0


def standing_sway(points=POINTS, duration=0.3, settle=0.4, step=2.5e-4):
    """The body standing on its sole springs (``points``), joints held by PD plus known
    sinusoids.

    Returns (time, q, v, a, tau_true (n, 29), point forces (n, P, 3)) sampled every 10 ms
    after ``settle`` s of settling.
    """
    model = load_fullbody()
    pm, data = model.pin_model, model.pin_model.createData()
    q0 = model.neutral()
    for side in "rl":  # a slight squat, feet flat: the knees carry tens of N m
        for joint, angle in (("hip", -0.3), ("knee", 0.6), ("ankle", -0.3)):
            q0[7 + model.joint_names.index(f"{joint}_{side}_y")] = angle
    pin.framesForwardKinematics(pm, data, q0)
    sole = min(data.oMf[model.frame_id(p)].translation[2] for p in points)
    q0[2] = -sole - model.total_mass() * model.gravity / (len(points) * CONTACT.stiffness)
    rows = np.arange(6, 35)
    hold = q0.copy()

    def reference(t):
        return hold, np.zeros(35), np.zeros(35)

    feedback = JointFeedback.damped(model, rows, reference, 300.0, 1.0, q0)
    names = model.joint_names
    amplitude = np.array([15.0 if n.endswith("_y") and n[:3] in ("hip", "kne", "ank")
                          else 0.0 for n in names])
    t_grid = np.linspace(0.0, settle + duration + 0.05, 800)
    ramp = np.clip((t_grid - 0.1) / 0.2, 0, 1)[:, None]
    drive = amplitude * ramp * np.sin(2 * np.pi * 1.5 * t_grid[:, None])
    known = JointTorques(rows, SampledHistory(t_grid, drive))
    ground = GroundContact(model, points, CONTACT, ground_z=0.0)
    system = PartitionedSystem(model, range(35), reference, [known, feedback, ground])
    sim = simulate_partitioned(system, (0.0, settle + duration),
                               system.state(q0, np.zeros(35)),
                               options=IntegratorOptions(method=Method.RK4, step=step),
                               t_eval=np.arange(settle, settle + duration + 1e-9, 0.01))
    tau = np.array([known.history(t) + feedback.torque(t, q, v)
                    for t, q, v in zip(sim.t, sim.q, sim.v, strict=True)])
    forces = []
    for q, v in zip(sim.q, sim.v, strict=True):
        pin.forwardKinematics(pm, data, q, v)
        pin.updateFramePlacements(pm, data)
        forces.append(ground.forces(data))
    return model, sim.t, sim.q, sim.v, sim.a, tau, np.array(forces)


def feet_data(model, q, forces, points=POINTS, plate_z=0.0):
    """Foot force, COP (on z = plate_z) and free moment from point forces."""
    from predgait.workflows.fullbody_tracking import foot_cop_from_points

    return foot_cop_from_points(model, q, forces, points, plate_z)


@pytest.fixture(scope="module", params=[POINTS, SOLE_EDGES], ids=["centre_line", "sole_edges"])
def sway(request):
    """The sway on the centre-line points and on the medial and lateral sole points: the
    engine's springs and the tracking problem agree on either set."""
    points = request.param
    model, t, q, v, a, tau, forces = standing_sway(points)
    force, cop, free = feet_data(model, q, forces, points)
    data = TrackingData(t, q, v, a, np.ones((t.size, len(points)), bool), force, cop, free,
                        ground_z=0.0, stiffness=CONTACT.stiffness, friction=CONTACT.friction,
                        slip_transition=CONTACT.slip_transition, points=points)
    return model, data, tau, forces, solve_tracking(model, data)


def test_sway_is_a_real_test_case(sway):
    _, data, tau, _, _ = sway
    # The knee and ankle torques are tens of N m and vary; the feet carry the weight.
    assert np.ptp(tau, axis=0).max() > 10.0
    assert data.force[:, :, 2].sum(axis=1) == pytest.approx(72.6 * 9.81, rel=0.05)


def test_known_torques_and_motion_recovered(sway):
    model, data, tau, forces, solution = sway
    assert solution.status == "Solve_Succeeded"
    error = solution.tau[:, 6:] - tau
    assert np.sqrt(np.mean(error**2)) < 0.02 * np.sqrt(np.mean(tau**2))
    angles = np.degrees(solution.q[:, 7:] - data.q[:, 7:])
    assert np.abs(angles).max() < 0.5
    feet = solution.foot_forces()
    assert np.abs(feet - data.force).max() < 0.01 * 72.6 * 9.81
    assert np.abs(solution.tau[:, :6]).max() < 1e-6


def test_cli_writes_the_result(tmp_path, capsys, assert_tidy_result):
    from predgait.cli import main
    from predgait.data.storage import read_storage

    out = tmp_path / "tracking"
    code = main(["solve", str(PROBLEM), "--out", str(out), "--set", "window.start=0.633",
                 "--set", "window.end=0.75"])
    assert code == 0, capsys.readouterr()
    for name in ("kinematics3d.sto", "corrected_moments3d.sto", "contact_forces.sto",
                 "feedback_gains.npz", "resimulated_kinematics3d.sto", "tracking.png",
                 "stick.gif"):
        assert (out / name).is_file(), name
    summary = assert_tidy_result(out / "summary.json")
    assert summary["pelvis_residual_max_n"] < 1e-6
    # The given mass, and the plates' check of it (subject01: 72.6 kg given, 72.7 weighed).
    provenance = summary["provenance"]
    assert (provenance["mass_kg"], provenance["mass_from"]) == (pytest.approx(72.6), "given")
    [mass] = [c for c in summary["plausibility"] if c["name"] == "body mass"]
    assert mass["passed"] and provenance["plates_weigh_kg"] == pytest.approx(72.7, abs=0.05)
    assert set(summary["feedback"]) >= {"with_feedback", "without_feedback"}
    floor = summary["floor"]
    assert floor["source"] == "median lowest sole point of the measured motion"
    assert abs(floor["foot_moment_plane_z_m"] - floor["z_m"]) < 1e-3
    assert floor["z_m"] - floor["plates_cop_plane_z_m"] > 0.03
    moments = read_storage(out / "corrected_moments3d.sto")
    assert "knee_r_y_moment" in moments.columns
    assert "pelvis residual" in capsys.readouterr().out
    # Angles come out in their stated unit: the tracked right knee (deg, inDegrees=yes)
    # is the whole-body inverse kinematics' one on the same frames, within a few degrees.
    inverse = tmp_path / "inverse"
    assert main(["inverse", str(REPO / "problems" / "inverse_subject01.toml"), "--model",
                 "fullbody", "--marker-map", str(REPO / "problems" /
                                                 "markers_fullbody_subject01.toml"),
                 "--no-plots", "--out", str(inverse)]) == 0
    measured = read_storage(inverse / "kinematics3d.sto")
    for name in ("kinematics3d.sto", "resimulated_kinematics3d.sto"):
        tracked = read_storage(out / name)
        assert tracked.header["units"].startswith("deg") and tracked.in_degrees, name
        knee = np.interp(tracked.time, measured.time, measured.column("knee_r_y"))
        assert np.max(np.abs(tracked.column("knee_r_y") - knee)) < 5.0, name
        assert np.ptp(knee) > 10.0  # the window moves the knee (radians would not match)


def test_cli_bad_window_names_the_key(tmp_path, capsys):
    from predgait.cli import main

    code = main(["solve", str(PROBLEM), "--out", str(tmp_path / "x"), "--set",
                 "window.start=0.9", "--set", "window.end=0.6"])
    err = capsys.readouterr().err
    assert code == 2 and "window.end" in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()


def test_contact_frames_are_sole_points_that_name_their_foot():
    from predgait.errors import InputError
    from predgait.problemfile import load_problem
    from predgait.workflows.fullbody_tracking import parse_tracking

    with pytest.raises(InputError, match=r"contact\.frames.*'nose', 'sternum': not a sole "
                                         r"point.*heel_contact_r.*toe_lateral_contact_l"):
        parse_tracking(load_problem(PROBLEM, ['contact.frames=["heel_contact_r", "nose", '
                                              '"sternum"]']))
    with pytest.raises(InputError, match=r"_r or _l"):
        point_feet(("heel_contact_r", "toe"))
    spec = parse_tracking(load_problem(PROBLEM, [f"contact.frames={list(SOLE_EDGES)}"
                                                 .replace("'", '"')]))
    assert spec.contact.frames == SOLE_EDGES


def test_fade_nodes_is_read_and_checked():
    from predgait.errors import InputError
    from predgait.problemfile import load_problem
    from predgait.workflows.fullbody_tracking import parse_tracking

    assert parse_tracking(load_problem(PROBLEM, ["window.fade_nodes=4"])).fade_nodes == 4
    with pytest.raises(InputError, match=r"window\.fade_nodes"):
        parse_tracking(load_problem(PROBLEM, ["window.fade_nodes=-1"]))


def test_trial_mass_is_kg_or_plates(tmp_path, capsys):
    """``[trial] mass``: kg or "plates" (the inverse's parser); anything else is one line."""
    from predgait.cli import main
    from predgait.problemfile import load_problem
    from predgait.workflows.fullbody_tracking import parse_tracking

    walking5 = REPO / "problems" / "fullbody_tracking_walking5.toml"
    for value, mass in (("60.5", 60.5), ('"plates"', "plates")):
        assert parse_tracking(load_problem(walking5, [f"trial.mass={value}"])).trial.mass == mass
    for value in ('"heavy"', "5"):
        code = main(["solve", str(walking5), "--out", str(tmp_path / "x"), "--set",
                     f"trial.mass={value}"])
        err = capsys.readouterr().err
        assert code == 2 and "trial.mass" in err and "Traceback" not in err, err
        assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()


def test_solver_settings_are_read_and_checked():
    from predgait.errors import InputError
    from predgait.problemfile import load_problem
    from predgait.workflows.fullbody_tracking import parse_tracking

    spec = parse_tracking(load_problem(PROBLEM, ["solver.convex_iterations=4",
                                                 'solver.name="fatrop"']))
    assert (spec.convex_iterations, spec.solver) == (4, "fatrop")
    assert parse_tracking(load_problem(PROBLEM)).solver == "ipopt"
    with pytest.raises(InputError, match=r"solver\.name"):
        parse_tracking(load_problem(PROBLEM, ['solver.name="snopt"']))
    with pytest.raises(InputError, match=r"solver\.convex_iterations"):
        parse_tracking(load_problem(PROBLEM, ["solver.convex_iterations=-1"]))
