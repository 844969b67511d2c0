"""Every writer of a clinical-sign file or plot turns a known positive angle/moment positive.

The leg pose is ankle q = +0.2 rad (dorsiflexion +11.46 deg) and knee q = -0.5 rad (knee
flexion +28.65 deg, the leg's knee turns the other way), the model torques ankle +3 N m
(dorsiflexion moment +3) and knee -7 N m (flexion moment +7): every clinical column of
corrected_moments.sto and every angle/moment curve of the plots must come out positive
with these values. The writers run on stand-in results (no solve), so a sign flipped at
any one writer (a copy of the table, or a minus at a call site) fails here. gait7 (hip
flexion, knee flexion, ankle dorsiflexion positive) and the whole body (flexion,
adduction) likewise.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from predgait.data import read_storage
from predgait.dynamics.integrators import Status
from predgait.kinematics.clinical import (
    clinical_angles,
    clinical_angles_3d,
    clinical_joint,
    clinical_moments,
)

N = 11
T = np.linspace(0.0, 1.0, N)
ANKLE, KNEE = 0.2, -0.5                     # model coordinates, rad
ANKLE_DEG, KNEE_DEG = np.degrees(ANKLE), -np.degrees(KNEE)
TAU = np.tile([3.0, -7.0], (N, 1))          # model torques, N m
FEEDBACK = np.tile([1.0, -2.0], (N, 1))


def leg_q():
    q = np.zeros((N, 5))
    q[:, 3], q[:, 4] = ANKLE, KNEE
    return q


def leg_sim():
    return SimpleNamespace(t=T, q=leg_q(), time_to_fall=None, status=Status.COMPLETED,
                           coordinate_names=("x", "z", "pitch", "ankle", "knee"))


def figures(monkeypatch, *modules):
    """Capture the figures the plot modules save: a list of (file name, figure)."""
    saved = []

    def capture(fig, path):
        saved.append((str(path).rsplit("/", 1)[-1], fig))
        return path

    for module in modules:
        monkeypatch.setattr(module, "save_figure", capture)
    return saved


def curves(ax):
    """y values of an axes' curves and shaded bands (not the 2-point reference lines)."""
    out = [np.asarray(line.get_ydata(), dtype=float) for line in ax.get_lines()
           if len(line.get_ydata()) > 2]
    out += [path.vertices[:, 1] for c in ax.collections for path in c.get_paths()]
    return out


def assert_leg_panels(fig, *, angles_deg=None):
    """Every curve positive; angle panels (titled '... angle' or 'deg') at the known value."""
    checked = 0
    for ax in fig.axes:
        title = ax.get_title().lower()
        for y in curves(ax):
            assert np.all(y > 0), f"{title}: a clinical curve is negative ({y.min():.3g})"
            checked += 1
            if angles_deg and "moment" not in title and "torque" not in title:
                want = angles_deg["ankle"] if "ankle" in title else angles_deg["knee"]
                if ax.get_lines() and len(y) == N:
                    assert np.allclose(y[np.isfinite(y)], want, atol=2.01), title
    assert checked >= 4


def test_the_table_gives_the_clinical_conventions():
    q = leg_q()
    angles = clinical_angles(q)
    assert np.allclose(np.degrees(angles["ankle_dorsiflexion"]), ANKLE_DEG)
    assert np.allclose(np.degrees(angles["knee_flexion"]), KNEE_DEG)
    tau = np.zeros((N, 5))
    tau[:, 3:] = TAU
    moments = clinical_moments(tau, -np.ones(N))
    assert np.allclose(moments["knee_flexion_moment"], 7.0)
    assert np.allclose(moments["ankle_dorsiflexion_moment"], 3.0)
    assert np.allclose(moments["hip_flexion_moment"], 1.0)
    # Whole body, right side: +X is adduction, +Y knee flexion, -Y hip flexion.
    names = ("hip_r_x", "knee_r_y", "hip_r_y", "ankle_r_y", "hip_l_x")
    out = clinical_angles_3d(names, np.array([[0.1, 0.4, -0.3, -0.2, -0.1]]))
    assert all(v[0] > 0 for v in out.values()), out
    assert set(out) == {"hip_adduction_r", "knee_flexion_r", "hip_flexion_r",
                        "ankle_dorsiflexion_r", "hip_adduction_l"}


def torque_feedback_result():
    band = np.stack([TAU * s for s in (0.9, 1.0, 1.1)])
    inverse = SimpleNamespace(time=T, q=leg_q())
    return {"inverse": inverse, "sim": leg_sim(), "open_sim": leg_sim(), "t": T,
            "window": (0.0, 1.0), "band": band, "feedforward": TAU, "feedback": FEEDBACK,
            "measured": TAU,
            "controller": SimpleNamespace(times=T, gains=np.zeros((N, 2, 4)))}


def test_torque_feedback_moments_file_and_plot(tmp_path, monkeypatch):
    from predgait.report import feedback_plots
    from predgait.workflows import torque_feedback

    saved = figures(monkeypatch, feedback_plots)
    monkeypatch.setattr(torque_feedback, "solve_feedback", lambda spec: torque_feedback_result())
    monkeypatch.setattr(torque_feedback, "_solution", lambda spec, r: {"status": "stand-in"})
    source = tmp_path / "problem.toml"
    source.write_text("kind = 'torque_feedback'\n")
    spec = SimpleNamespace(source=source, trial=SimpleNamespace(inverse_problem=source),
                           threshold_deg=2.0)
    torque_feedback.run_feedback(spec, tmp_path / "out")
    table = read_storage(tmp_path / "out" / "corrected_moments.sto")
    columns = [c for c in table.columns if c.endswith(("_feedforward", "_inverse_dynamics",
                                                       "_total", "_feedback", "_min", "_max"))]
    assert len(columns) == 12
    for name in columns:
        assert np.all(table.column(name) > 0), name
    assert np.allclose(table.column("knee_flexion_moment_inverse_dynamics"), 7.0)
    assert np.allclose(table.column("ankle_dorsiflexion_moment_total"), 4.0)
    [(_, fig)] = saved
    assert_leg_panels(fig, angles_deg={"ankle": ANKLE_DEG, "knee": KNEE_DEG})


def test_solve_moments_file_and_plots(tmp_path, monkeypatch):
    from predgait.report import diagnostics, raster, solve_plots
    from predgait.workflows import solve

    saved = figures(monkeypatch, diagnostics, solve_plots)
    monkeypatch.setattr(raster, "save_chart", lambda *a, **k: None)
    inverse = SimpleNamespace(time=T, q=leg_q(), model=SimpleNamespace(source="leg"),
                              provenance={})
    drivers = SimpleNamespace(joint_torque=lambda t: TAU[0])
    x = np.zeros((N, 4))
    x[:, 0], x[:, 1] = ANKLE, KNEE
    solved = SimpleNamespace(success=True, status="Solve_Succeeded", iterations=1, seconds=0.1,
                             objective=0.0, constraint_violation=0.0,
                             history={"objective": [1.0, 0.5],
                                      "constraint_violation": [1e-3, 1e-9],
                                      "dual_infeasibility": [1e-3, 1e-9]})
    fit = SimpleNamespace(t=T, x=x, torque_change=FEEDBACK, solved=solved, parameters={},
                          confidence95={}, rms_deg={}, diagnostics={}, kind="torque_correction")
    monkeypatch.setattr(solve, "_inverse", lambda spec: inverse)
    monkeypatch.setattr(solve, "LegDrivers", SimpleNamespace(from_inverse=lambda inv: drivers))
    monkeypatch.setattr(solve, "solve_problem", lambda spec, inv, drv: fit)
    monkeypatch.setattr(solve, "resimulations", lambda spec, inv, drv, f: (
        {"with_fit": {"time_to_threshold_s": None}},
        {"baseline_uncorrected": leg_sim(), "with_fit": leg_sim()}))
    source = tmp_path / "problem.toml"
    source.write_text("kind = 'torque_correction'\n")
    spec = SimpleNamespace(source=source, inverse_problem=source, kind=solve.Kind.TORQUE_CORRECTION,
                           window=(0.0, 1.0), threshold_deg=2.0, nodes=N,
                           transcription=SimpleNamespace(value="trapezoidal"))
    solve.run_solve(spec, tmp_path / "out")
    table = read_storage(tmp_path / "out" / "corrected_moments.sto")
    assert np.allclose(table.column("knee_flexion_moment"), 7.0)
    assert np.allclose(table.column("ankle_dorsiflexion_moment"), 3.0)
    assert np.allclose(table.column("knee_flexion_moment_corrected"), 9.0)
    assert np.allclose(table.column("ankle_dorsiflexion_moment_corrected"), 4.0)
    names = {name for name, _ in saved}
    assert {"angles.png", "moments.png", "before_after.png"} <= names
    for name, fig in saved:
        if name != "convergence.png":
            assert_leg_panels(fig, angles_deg={"ankle": ANKLE_DEG, "knee": KNEE_DEG})


def test_scenario_plot_and_metrics(tmp_path, monkeypatch):
    from predgait.report import scenario_plots
    from predgait.scenarios import run

    saved = figures(monkeypatch, scenario_plots)
    result = SimpleNamespace(baseline=leg_sim(), edited=leg_sim(), feedback_baseline=FEEDBACK,
                             feedback_edited=FEEDBACK, spec=SimpleNamespace(name="known"))
    scenario_plots.save_scenario_plot(tmp_path, result)
    [(_, fig)] = saved
    assert_leg_panels(fig, angles_deg={"ankle": ANKLE_DEG, "knee": KNEE_DEG})
    sim = SimpleNamespace(t=T, q=leg_q(), v=np.zeros((N, 5)), status=Status.COMPLETED,
                          time_to_fall=None, grf=None)
    drivers = SimpleNamespace(joint_torque=lambda t: TAU[0])
    metrics = run._metrics(sim, sim, FEEDBACK, FEEDBACK, drivers)
    assert metrics["ankle_peak_angle_deg"] == pytest.approx(ANKLE_DEG)
    assert metrics["knee_peak_angle_deg"] == pytest.approx(KNEE_DEG)


def test_gait7_prediction_plot_and_edits(tmp_path, monkeypatch):
    from predgait.models.gait7 import build_gait7_urdf
    from predgait.models.loading import model_from_urdf
    from predgait.report import predict_plots

    model = model_from_urdf(build_gait7_urdf(72.6, 1.8034))
    known = {"hip": 0.3, "knee": 0.6, "ankle": 0.1}    # clinical, rad: all positive
    q = np.zeros((N, model.nq))
    for joint, value in known.items():
        j = clinical_joint(model, f"{joint}_r")
        q[:, model.coordinate_index(f"{joint}_r")] = j.clinical(value)
    saved = figures(monkeypatch, predict_plots)
    monkeypatch.setattr(predict_plots, "plot_stick", lambda *a, **k: None)
    stride = {"t": T, "q": q, "contact": np.ones((N, 4, 2))}
    pred = SimpleNamespace(stride=stride, aligned=stride)
    predict_plots.save_prediction_plots(tmp_path, model, {"known": pred})
    angle_fig = dict(saved)["predicted_angles.png"]
    for ax, joint in zip(angle_fig.axes, ("hip", "knee", "ankle"), strict=True):
        [y] = curves(ax)
        assert np.allclose(y, np.degrees(known[joint])), joint


def test_gait7_table_signs_match_the_geometry():
    """+hip flexion swings the knee forward, +knee flexion puts the ankle behind the knee,
    +ankle dorsiflexion lifts the toe (pose set through the table, read by kinematics)."""
    import pinocchio as pin

    from predgait.models.gait7 import build_gait7_urdf
    from predgait.models.loading import model_from_urdf

    model = model_from_urdf(build_gait7_urdf(72.6, 1.8034))
    data = model.pin_model.createData()

    def frames(joint, clinical_value):
        q = np.zeros(model.nq)
        q[model.coordinate_index(joint)] = clinical_joint(model, joint).clinical(clinical_value)
        pin.framesForwardKinematics(model.pin_model, data, q)
        return {n: data.oMf[model.pin_model.getFrameId(n)].translation.copy()
                for n in ("hip_center", "knee_center_r", "ankle_center_r", "toe_r")}

    hip = frames("hip_r", 0.3)
    assert hip["knee_center_r"][0] > hip["hip_center"][0] + 0.1
    knee = frames("knee_r", 0.5)
    assert knee["ankle_center_r"][0] < knee["knee_center_r"][0] - 0.1
    neutral, ankle = frames("ankle_r", 0.0), frames("ankle_r", 0.3)
    assert ankle["toe_r"][2] > neutral["toe_r"][2] + 0.02


def test_gait7_edits_bound_the_clinical_range():
    from predgait.models.gait7 import build_gait7_urdf
    from predgait.models.loading import model_from_urdf
    from predgait.scenarios.edits import LockJoint, RangeOfMotion
    from predgait.scenarios.predict import joint_constraints

    model = model_from_urdf(build_gait7_urdf(72.6, 1.8034))
    for joint in ("hip", "knee", "ankle"):
        sign = clinical_joint(model, f"{joint}_r")
        bounds, _ = joint_constraints(model, [LockJoint(joint, 0.2)], ("r",))
        assert [sign.clinical(b) for b in bounds[f"{joint}_r"]] == pytest.approx([0.2, 0.2])
        bounds, _ = joint_constraints(model, [RangeOfMotion(joint, 0.1, 0.4)], ("r",))
        clinical = sorted(sign.clinical(b) for b in bounds[f"{joint}_r"])
        assert clinical == pytest.approx([0.1, 0.4])


def test_leg_scenario_lock_holds_the_clinical_angle():
    from dataclasses import dataclass

    from predgait.scenarios.edits import LockJoint
    from predgait.scenarios.run import _locked

    @dataclass(frozen=True)
    class Reference:
        reference_q: object
        reference_qd: object
        reference_qdd: object

    zero = Reference(*(lambda t: np.zeros(5) for _ in range(3)))
    leg = SimpleNamespace(coordinate_index={"ankle": 3, "knee": 4}.__getitem__)
    held, free = _locked(zero, leg, [LockJoint("knee", np.radians(20.0))])
    assert free == ("ankle",)
    assert clinical_angles(held.reference_q(0.0))["knee_flexion"] == pytest.approx(
        np.radians(20.0))


def test_gait7_knee_plot(tmp_path, monkeypatch):
    from predgait.models.gait7 import build_gait7_urdf
    from predgait.models.loading import model_from_urdf
    from predgait.report import raster
    from predgait.workflows import gait7_run

    model = model_from_urdf(build_gait7_urdf(72.6, 1.8034))
    q = np.zeros((N, model.nq))
    for side in "rl":
        name = f"knee_{side}"
        q[:, model.coordinate_index(name)] = clinical_joint(model, name).clinical(0.6)
    run = SimpleNamespace(run=SimpleNamespace(t=T, q=q), status=Status.COMPLETED)
    charts = []
    monkeypatch.setattr(raster, "save_chart", lambda path, panels, **k: charts.append(panels))
    gait7_run._plot_knees(tmp_path, model, run,
                          [({"name": "driven", "knee_run": {"sides": ["right", "left"]}}, None,
                            run)])
    [[panel]] = charts
    assert panel.ylabel == "knee flexion (deg)" and len(panel.lines) == 4
    for line in panel.lines:
        assert np.allclose(line.y, np.degrees(0.6)), line.label


def test_predicted_scenario_metrics_compare_clinical_angles():
    from predgait.models.gait7 import build_gait7_urdf
    from predgait.models.loading import model_from_urdf
    from predgait.scenarios.predict import predicted_metrics

    model = model_from_urdf(build_gait7_urdf(72.6, 1.8034))
    wave = np.sin(np.linspace(0.0, np.pi, N))

    def prediction(clinical):            # clinical angle of every joint, rad
        q = np.zeros((N, model.nq))
        for side in "rl":
            for joint in ("hip", "knee", "ankle"):
                name = f"{joint}_{side}"
                q[:, model.coordinate_index(name)] = clinical_joint(model, name).clinical(
                    clinical)
        measures = {"step_length_m": 0.7, "cadence_steps_min": 110.0, "speed_m_s": 1.3,
                    **{side: {"stance_fraction": 0.6, "peak_fz_n": 800.0, "step_length_m": 0.7}
                       for side in ("right", "left")}}
        stride = {"t": T, "q": q, "contact": np.zeros((N, 4, 2)), "tau": np.zeros((N, 6))}
        return SimpleNamespace(stride=stride, aligned=stride,
                               gait=SimpleNamespace(terms={"effort": 1.0}), measures=measures,
                               resimulation=None)

    out = predicted_metrics(model, prediction(0.3 * wave), prediction(0.3 * wave + 0.2),
                            ("r",))
    for side in "rl":
        for joint in ("hip", "knee", "ankle"):
            name = f"{joint}_{side}"
            assert out[f"{name}_rms_change_deg"] == pytest.approx(np.degrees(0.2)), name
            assert out[f"{name}_range_deg"] == pytest.approx(np.degrees(0.3)), name


def test_osim2d_signs_follow_the_model_geometry():
    """OpenSim's planar gait model: a clinically positive angle moves the segment the way a
    flexion (hip, knee) or a dorsiflexion (ankle) does, in the built model's kinematics."""
    import pinocchio as pin

    from predgait.models.osim import bundled_2d_gait
    from predgait.models.osim_model import build_model

    built = build_model(bundled_2d_gait())
    model = built.model
    zero = {c.name: 0.0 for c in built.osim.coordinates}

    def point(values, body):
        q = built.q_from_osim(values)
        data = model.pin_model.createData()
        pin.framesForwardKinematics(model.pin_model, data, q)
        return data.oMf[model.frame_id(built.body_link(body))].translation.copy()

    cases = {"hip_flexion_r": ("tibia_r", 0, +1), "knee_angle_r": ("talus_r", 0, -1),
             "ankle_angle_r": ("toes_r", 2, +1)}   # moved body, lab axis, direction
    for coordinate, (body, axis, direction) in cases.items():
        joint = clinical_joint("osim2d", coordinate)
        flexed = dict(zero, **{coordinate: joint.clinical(0.3)})   # clinical +0.3 rad
        move = point(flexed, body)[axis] - point(zero, body)[axis]
        assert direction * move > 0.01, coordinate
