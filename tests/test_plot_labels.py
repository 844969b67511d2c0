"""Plots state their x axis and clinical signs; convergence plots, GIF and viewer captions."""

import json
from types import SimpleNamespace

import numpy as np

from predgait.models.loading import load_model
from predgait.report.diagnostics import FLOOR, plot_history
from predgait.report.figures import new_figure, save_figure
from predgait.report.plot_labels import gif_caption, label_problems, read_labels
from predgait.report.raster import Line, Panel, save_chart
from predgait.report.simulation_plots import coordinate_panels, deviation_panel
from predgait.report.stick import write_gif
from predgait.report.viewer import plate_arrows, viewer_data, viewer_markup


def test_labels_are_stored_in_both_kinds_of_png(tmp_path):
    t = np.linspace(0.0, 1.0, 11)
    save_chart(tmp_path / "a.png", [Panel((Line(t, t),), title="knee", xlabel="time (s)",
                                          ylabel="deg")], size=(4, 3))
    assert read_labels(tmp_path / "a.png") == (["time (s)"], ["knee", "deg"])
    assert label_problems(*read_labels(tmp_path / "a.png")) == [
        "x axis 'time (s)' does not say from when",
        "'knee' names a joint without its clinical angle"]
    fig, ax = new_figure(figsize=(4, 3))
    ax.plot(t, t)
    ax.set_xlabel("% gait cycle")
    ax.set_title("knee flexion")
    save_figure(fig, tmp_path / "b.png")
    assert read_labels(tmp_path / "b.png") == (["% gait cycle"], ["knee flexion"])
    assert label_problems(*read_labels(tmp_path / "b.png")) == []
    assert label_problems([], []) == ["no x-axis label"]


def test_leg_coordinates_are_plotted_with_clinical_signs():
    """A flexed knee (q_knee = -0.5 rad) is drawn as +28.6 deg of knee flexion."""
    t = np.linspace(0.0, 1.0, 5)
    q = np.column_stack([np.full(5, 0.1), np.full(5, -0.5)])
    ankle, knee = coordinate_panels({"run": (t, q)}, ("ankle", "knee"), kind="leg")
    assert knee.ylabel == "knee flexion (deg)" and ankle.ylabel == "ankle dorsiflexion (deg)"
    assert np.allclose(knee.lines[0].y, np.degrees(0.5))
    assert np.allclose(ankle.lines[0].y, np.degrees(0.1))
    assert knee.xlabel == "time from heel strike (s)"
    # Simulated knee more flexed than measured: a positive deviation.
    panel = deviation_panel(t, q, (t, q + [0.0, 0.05]), ("ankle", "knee"), threshold_deg=5.0)
    assert np.allclose(panel.lines[1].y, np.degrees(0.05)) and panel.lines[1].label == \
        "knee flexion"


def test_convergence_plot_has_two_labelled_axes_floored_at_machine_precision(tmp_path):
    history = {"objective": [0.0, 2.0, 1e-3, 1e-3], "constraint_violation": [1.0, 1e-2, 0.0, 0.0],
               "dual_infeasibility": [0.0, 1e-1, 1e-8, 1e-320]}
    solved = SimpleNamespace(history=history, status="Solve_Succeeded", iterations=3,
                             seconds=0.01)
    top, bottom = plot_history(solved)
    assert top.get_ylabel() == "objective" and bottom.get_ylabel() == "infeasibility"
    assert bottom.get_xlabel() == "Ipopt iteration"
    for ax in (top, bottom):
        assert ax.get_ylim()[0] >= FLOOR / 10, ax.get_ylim()   # not 1e-314
        assert ax.get_legend() is not None
        for line in ax.get_lines():
            assert np.min(line.get_ydata()) >= FLOOR
    assert {t.get_text() for t in bottom.get_legend().get_texts()} == {
        "primal infeasibility (inf_pr)", "dual infeasibility (inf_du)"}
    save_figure(top.figure, tmp_path / "c.png")
    assert label_problems(*read_labels(tmp_path / "c.png")) == []


def test_gif_caption_names_what_is_drawn(tmp_path):
    model = load_model("leg")
    t = np.linspace(0.0, 0.2, 5)
    q = np.zeros((5, model.nq))
    write_gif(tmp_path / "a.gif", model, t, q, label="measured (IK)")
    write_gif(tmp_path / "b.gif", model, t, q, reference_q=q)
    assert gif_caption(tmp_path / "a.gif") == ("Stick figure, sagittal plane (animation): "
                                               "measured (IK) in blue")
    assert gif_caption(tmp_path / "b.gif").endswith("simulated in blue, measured in grey behind")


def test_planar_arrows_start_at_the_cop_in_the_figure_plane():
    """A plate's COP 0.1 m beside the planar leg is drawn in the leg's plane (Y = 0)."""
    model = load_model("leg")
    t = np.linspace(0.0, 0.2, 5)
    force = np.tile([50.0, 30.0, 700.0], (5, 1))
    cop = np.tile([0.12, -0.10, 0.0], (5, 1))
    data = viewer_data(model, t, np.zeros((5, model.nq)), grf=(force, cop))
    [arrow] = data["arrows"]
    assert np.allclose(arrow["origin"], [[0.12, 0.0, 0.0]] * 5)
    assert np.allclose(arrow["vector"], [[0.05, 0.0, 0.7]] * 5)
    assert "arrows: ground reaction at the centre of pressure" in viewer_markup(
        json.dumps(data), "t")
    assert "no ground reaction arrows" in viewer_markup(json.dumps(
        viewer_data(model, t, np.zeros((5, model.nq)))), "t")


def test_plate_arrows_sample_each_plate_at_the_viewer_times():
    time = np.array([0.0, 0.1, 0.2, 0.3])
    plate = SimpleNamespace(name="1", force=np.arange(12.0).reshape(4, 3),
                            cop=-np.arange(12.0).reshape(4, 3))
    [(name, (force, cop))] = plate_arrows([plate], time, [0.1, 0.3]).items()
    assert name == "plate 1"
    assert np.array_equal(force, [[3, 4, 5], [9, 10, 11]]) and np.array_equal(cop, -force)


def test_whole_body_tracking_plot_in_clinical_signs(tmp_path):
    """hip_r_y = -0.3 rad (flexion, Y sign -1) is drawn as +17.2 deg of hip flexion."""
    from predgait.report.fullbody_tracking_plots import PANELS, plot_tracking

    names = ("pelvis_dummy", *PANELS)
    n = 4
    q = np.zeros((n, 7 + len(names)))
    q[:, 7 + names.index("hip_r_y")] = -0.3
    q[:, 7 + names.index("knee_r_y")] = 0.5
    data = SimpleNamespace(time=np.linspace(0.0, 0.3, n), q=q, force=np.zeros((n, 2, 3)))
    solution = SimpleNamespace(q=q, foot_forces=lambda: np.zeros((n, 2, 3)))
    model = SimpleNamespace(kind="fullbody", joint_names=names)
    fig = plot_tracking(model, data, solution)
    hip, knee = fig.axes[0], fig.axes[1]
    assert hip.get_ylabel() == "hip flexion r (deg)"
    assert np.allclose(hip.get_lines()[0].get_ydata(), np.degrees(0.3))
    assert np.allclose(knee.get_lines()[0].get_ydata(), np.degrees(0.5))
    save_figure(fig, tmp_path / "t.png")
    assert label_problems(*read_labels(tmp_path / "t.png")) == []


def test_collapse_plots_state_the_time_zero_and_clinical_angles(tmp_path):
    """The collapse test (thesis 4.2): the knee folds, drawn as growing knee flexion."""
    from pathlib import Path

    from predgait.cli import main
    from predgait.report.plot_labels import read_labels

    problem = Path(__file__).resolve().parents[1] / "problems" / "collapse.toml"
    assert main(["simulate", str(problem), "--out", str(tmp_path / "c")]) == 0
    for png in sorted((tmp_path / "c").glob("*.png")):
        assert label_problems(*read_labels(png)) == [], png.name
    x_axis, labels = read_labels(tmp_path / "c" / "angles.png")
    assert x_axis == ["time from the start of the run (s)"]
    assert labels == ["ankle dorsiflexion (deg)", "knee flexion (deg)"]


def test_whole_body_tracking_viewer_draws_each_foot_at_its_centre_of_pressure(tmp_path):
    """Right heel 600 N, right toe 200 N: one right-foot arrow of 800 N from the point a
    quarter of the way from the heel to the toe; an unloaded left foot draws nothing."""
    import pinocchio as pin

    from predgait.models.loading3d import load_fullbody
    from predgait.problems.fullbody_tracking_stage import POINTS
    from predgait.report.fullbody_tracking_plots import save_tracking_plots

    model = load_fullbody()
    n = 3
    q = np.tile(model.neutral(), (n, 1))
    forces = np.zeros((n, len(POINTS), 3))
    forces[:, POINTS.index("heel_contact_r"), 2] = 600.0
    forces[:, POINTS.index("toe_contact_r"), 2] = 200.0
    data = SimpleNamespace(time=np.linspace(0.0, 0.2, n), q=q, force=np.zeros((n, 2, 3)))
    solution = SimpleNamespace(time=data.time, q=q, forces=forces, points=POINTS,
                               foot_forces=lambda: np.zeros((n, 2, 3)))
    save_tracking_plots(tmp_path, model, data, solution)
    arrows = {a["name"]: a for a in json.loads((tmp_path / "viewer.json").read_text())
              ["arrows"]}
    assert set(arrows) == {"ground reaction, right foot", "ground reaction, left foot"}
    pin_data = model.pin_model.createData()
    pin.framesForwardKinematics(model.pin_model, pin_data, q[0])
    heel, toe = (pin_data.oMf[model.frame_id(f"{p}_contact_r")].translation
                 for p in ("heel", "toe"))
    right = arrows["ground reaction, right foot"]
    assert np.allclose(right["origin"], [0.75 * heel + 0.25 * toe] * n, atol=1e-4)
    assert np.allclose(right["vector"], [[0.0, 0.0, 0.8]] * n)
    assert all(o[0] is None for o in arrows["ground reaction, left foot"]["origin"])
