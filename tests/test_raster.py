"""Pillow line charts (report.raster): round ticks, data placed where the axes say, files whole."""

import numpy as np
import pytest
from PIL import Image

from predgait.report.raster import DPI, Axes, Canvas, Line, Panel, nice_ticks, save_chart


@pytest.mark.parametrize("low,high,expected", [
    (0.0, 100.0, [0, 20, 40, 60, 80, 100]),
    (-0.45, 0.65, [-0.25, 0, 0.25, 0.5]),
    (-1.72, 0.12, [-1.5, -1, -0.5, 0]),
    (3.0, 3.0, [3.0]),
])
def test_nice_ticks_are_round_and_inside(low, high, expected):
    np.testing.assert_allclose(nice_ticks(low, high), expected)


def test_a_point_lands_on_its_pixel():
    canvas = Canvas((4.0, 3.0), scale=1)
    axes = Axes(canvas, (50.0, 20.0, 350.0, 280.0), (0.0, 10.0), (-1.0, 1.0))
    x, y = axes.to_px([0.0, 10.0, 5.0], [-1.0, 1.0, 0.0])
    np.testing.assert_allclose(x, [50, 350, 200])
    np.testing.assert_allclose(y, [280, 20, 150])   # y grows upward in data, downward in pixels
    axes.polyline([2.0, 8.0], [0.5, 0.5], color="#ff0000", width=3.0)
    px, py = axes.to_px(5.0, 0.5)
    assert canvas.image.getpixel((round(float(px)), round(float(py)))) == (255, 0, 0)
    assert canvas.image.getpixel((round(float(px)), round(float(py)) + 20)) == (255, 255, 255)


def test_equal_axes_keep_one_scale():
    canvas = Canvas((4.0, 3.0), scale=1)
    axes = Axes(canvas, (0.0, 0.0, 400.0, 100.0), (0.0, 1.0), (0.0, 1.0), equal=True)
    (x0, x1), (y0, y1) = axes.to_px([0.0, 1.0], [0.0, 1.0])
    assert x1 - x0 == pytest.approx(y0 - y1)


def test_chart_file_has_the_figure_size(tmp_path):
    x = np.linspace(0, 100, 51)
    y = np.sin(x / 10)
    y[10:14] = np.nan   # a gap, not a failure
    panels = [Panel((Line(x, y, label="sine"),), title="a", xlabel="%", ylabel="deg",
                    hlines=(0.0,), vlines=(60.0,)),
              Panel((Line(x, 2 * y, width=0.0, dots=3.0),), title="b")]
    path = save_chart(tmp_path / "c.png", panels, size=(9.0, 3.4), title="two panels")
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.size == (round(9.0 * DPI), round(3.4 * DPI))


def test_deviation_panel_clips_to_five_thresholds_and_shades_the_band(tmp_path):
    """A diverging run's deviation is cut at ±5 thresholds; the ±threshold band is shaded
    and the deviation is simulated minus measured, in degrees of the clinical angle."""
    from predgait.report.raster import BAND
    from predgait.report.simulation_plots import deviation_panel

    t = np.linspace(0.0, 1.0, 101)
    measured = np.zeros((101, 2))
    simulated = np.column_stack([np.radians(100.0 * t), np.radians(-2.0 * t)])
    panel = deviation_panel(t, simulated, (t, measured), ("ankle", "knee"), threshold_deg=5.0,
                            time_to_threshold=0.05, time_to_fall=0.9)
    assert panel.ylim[1] == pytest.approx(25.0)
    assert panel.ylim[0] == pytest.approx(-5.0 * 1.05)
    np.testing.assert_allclose(panel.lines[0].y, np.minimum(100.0 * t, 25.0))
    np.testing.assert_allclose(panel.lines[1].y, 2.0 * t)   # q_knee -2t: knee flexion +2t
    assert panel.vlines == (0.05, 0.9) and "0.900 s" in panel.title
    path = save_chart(tmp_path / "d.png", [panel], size=(7.0, 3.8))
    canvas = Canvas((7.0, 3.8), scale=1)
    box = (0.75 * DPI, 0.45 * DPI, canvas.width - 0.2 * DPI, canvas.height - 0.55 * DPI)
    axes = Axes(canvas, box, (0.0, 1.0), panel.ylim)
    px, py = axes.to_px(0.6, 4.0)   # inside the band, away from lines, grid and legend
    with Image.open(path) as image:
        pixel = image.convert("RGB").getpixel((round(float(px)), round(float(py))))
    assert pixel == Image.new("RGB", (1, 1), BAND).getpixel((0, 0))
