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
