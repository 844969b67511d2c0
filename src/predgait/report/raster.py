"""Light raster figures drawn with Pillow: line charts and the frames of stick-figure GIFs.

Matplotlib costs about 0.5 s to import and 0.1-0.3 s to draw a figure, more than the whole
computation of a leg's inverse dynamics. The figures every run of ``predgait inverse``
writes (angles, moments, powers, ground reaction, the stick GIF) are plain line charts,
drawn here with Pillow's ImageDraw in milliseconds: fixed layout (margins in inches, as
:mod:`predgait.report.figures`), ticks at 1, 2, 2.5 or 5 x 10^k, lines anti-aliased by
drawing at twice the size and halving. Figures that need more (stick overlays, legends
outside the axes, many panel layouts) keep Matplotlib.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Pixels per inch of the written images (as :data:`predgait.report.figures.DPI`).
DPI = 110
#: Margins in inches: left, right, bottom, top (tick labels, axis labels, a title).
MARGINS = (0.75, 0.2, 0.55, 0.45)
GRID = "#e4e4e4"
#: Fill of a shaded band (#2a6f97 at 12 % opacity on white).
BAND = "#e5eef2"
TEXT = "#222222"


@dataclass(frozen=True)
class Line:
    """One data series of a panel.

    Attributes:
        x, y: (n,) values; non-finite points leave gaps.
        color: Any Pillow colour (``"#2a6f97"``, ``"grey"``).
        width: Line width, points; 0 draws no line.
        dots: Dot diameter at every point, points (0: none).
        label: Legend entry (None: not in the legend).
    """

    x: np.ndarray
    y: np.ndarray
    color: str = "#1f77b4"
    width: float = 1.5
    dots: float = 0.0
    label: str | None = None


@dataclass(frozen=True)
class Panel:
    """One set of axes: lines, labels, reference lines.

    Attributes:
        lines: The data series, drawn in order.
        title, xlabel, ylabel: Texts (empty: none).
        hlines: y values of thin dark horizontal reference lines (e.g. zero).
        vlines: x values of dotted grey vertical lines (e.g. toe off).
        ylim: (low, high) of the y axis (None: from the data); lines are clipped by
            the caller (see :func:`predgait.report.simulation_plots.deviation_panel`).
        band: (low, high) y range shaded light blue behind the lines (e.g. a tolerance).
    """

    lines: tuple[Line, ...]
    title: str = ""
    xlabel: str = ""
    ylabel: str = ""
    hlines: tuple[float, ...] = ()
    vlines: tuple[float, ...] = ()
    ylim: tuple[float, float] | None = None
    band: tuple[float, float] | None = None


def nice_ticks(low: float, high: float, count: int = 6) -> np.ndarray:
    """About ``count`` round tick values (1, 2, 2.5 or 5 x 10^k apart) within [low, high]."""
    if not np.isfinite(low) or not np.isfinite(high) or high <= low:
        return np.array([low]) if np.isfinite(low) else np.array([])
    raw = (high - low) / max(count - 1, 1)
    power = 10.0 ** np.floor(np.log10(raw))
    step = power * min((m for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * power >= raw),
                       default=10.0)
    ticks = np.arange(np.ceil(low / step - 1e-9), np.floor(high / step + 1e-9) + 1) * step
    return np.where(np.abs(ticks) < 1e-9 * step, 0.0, ticks)


def data_limits(values: list[np.ndarray], *, margin: float = 0.05) -> tuple[float, float]:
    """(low, high) of the finite values widened by ``margin`` of the span each side."""
    finite = [v[np.isfinite(v)] for v in (np.ravel(np.asarray(x, float)) for x in values)]
    finite = [v for v in finite if v.size]
    if not finite:
        return 0.0, 1.0
    low, high = min(v.min() for v in finite), max(v.max() for v in finite)
    span = high - low if high > low else max(abs(high), 1.0)
    return low - margin * span, high + margin * span


def tick_label(value: float) -> str:
    """Shortest decimal text of a tick value (no ``-0``)."""
    text = f"{value:.6g}"
    return "0" if text in ("-0", "0") else text


@functools.lru_cache(maxsize=16)
def font(pixels: int):
    """Pillow's bundled scalable font at ``pixels`` size."""
    from PIL import ImageFont

    return ImageFont.load_default(size=pixels)


class Canvas:
    """An RGB image of a figure size in inches, drawn at ``scale`` times the final size.

    Colours are Pillow colour strings, except on a palette canvas (``palette`` given:
    GIF frames), where they are looked up in the palette's list of colours.
    """

    def __init__(self, size: tuple[float, float], *, scale: int = 2,
                 palette: tuple[str, ...] | None = None):
        from PIL import Image, ImageColor, ImageDraw

        self.scale, self.palette = scale, palette
        self.width, self.height = (round(s * DPI * scale) for s in size)
        if palette is None:
            self.image = Image.new("RGB", (self.width, self.height), "white")
        else:
            self.image = Image.new("P", (self.width, self.height), 0)
            rgb = [c for name in palette for c in ImageColor.getrgb(name)[:3]]
            self.image.putpalette(rgb)
        self.draw = ImageDraw.Draw(self.image)
        self._texts: list[tuple] = []   # written at the final size (see text())
        self.x_labels: list[str] = []   # what the plot states (report.plot_labels)
        self.labels: list[str] = []

    def copy(self) -> Canvas:
        """A canvas of the same size and palette holding a copy of this image."""
        from PIL import ImageDraw

        other = object.__new__(Canvas)
        other.scale, other.palette = self.scale, self.palette
        other.width, other.height = self.width, self.height
        other.image = self.image.copy()
        other.draw = ImageDraw.Draw(other.image)
        other._texts = []
        other.x_labels, other.labels = list(self.x_labels), list(self.labels)
        return other

    def ink(self, color: str):
        """The fill value of ``color`` on this canvas."""
        return color if self.palette is None else self.palette.index(color)

    def px(self, points: float) -> float:
        """Points (1/72 inch) to canvas pixels."""
        return points * DPI * self.scale / 72.0

    def text(self, xy, text: str, *, size: float = 10.0, anchor: str = "la",
             color: str = TEXT, vertical: bool = False) -> None:
        """Write ``text`` (``size`` in points) at ``xy``; ``vertical`` turns it 90 degrees.

        On a supersampled canvas the text is written after halving, at the final size
        (FreeType smooths its own glyphs): the same look for a quarter of the pixels.
        """
        if text:
            self._texts.append((xy, text, size, anchor, color, vertical))
            if self.scale == 1:
                self._write_texts(self.image, 1)

    def _write_texts(self, image, scale: int) -> None:
        """Write the pending texts on ``image`` (canvas coordinates divided by ``scale``)."""
        from PIL import Image, ImageDraw

        draw = ImageDraw.Draw(image)
        for (x, y), text, size, anchor, color, vertical in self._texts:
            face = font(max(1, round(self.px(size) / scale)))
            x, y = x / scale, y / scale
            if not vertical:
                draw.text((x, y), text, fill=self.ink(color), font=face, anchor=anchor)
                continue
            left, top, right, bottom = face.getbbox(text)
            mask = Image.new("L", (right - left + 2, bottom - top + 2), 0)
            ImageDraw.Draw(mask).text((1 - left, 1 - top), text, fill=255, font=face)
            mask = mask.rotate(90, expand=True)
            corner = (round(x - mask.width / 2), round(y - mask.height / 2))  # centred
            image.paste(self.ink(color), (*corner, corner[0] + mask.width,
                                          corner[1] + mask.height), mask)
        self._texts.clear()

    def save_png(self, path: str | Path) -> Path:
        """Write the image halved ``scale`` times to its final size, then its texts."""
        path = Path(path)
        from PIL.PngImagePlugin import PngInfo

        from predgait.report.plot_labels import png_text

        image = self.image.reduce(self.scale) if self.scale > 1 else self.image
        self._write_texts(image, self.scale)
        info = PngInfo()
        for key, value in png_text(self.x_labels, self.labels).items():
            info.add_itxt(key, value)
        # Without format=, Pillow loads only its PNG plugin for a .png name (format= loads
        # the BMP, GIF, JPEG and PPM plugins too: start-up time for nothing).
        image.save(path, format=None if path.suffix.lower() == ".png" else "PNG",
                   compress_level=1, pnginfo=info)
        return path


class Axes:
    """A rectangle of a canvas with data limits: frame, ticks, grid and polylines."""

    def __init__(self, canvas: Canvas, box: tuple[float, float, float, float],
                 xlim: tuple[float, float], ylim: tuple[float, float], *, equal: bool = False):
        self.canvas, self.box = canvas, box
        x0, y0, x1, y1 = box
        if equal:  # one data unit as long on both axes: widen the tighter range
            per_px = max((xlim[1] - xlim[0]) / (x1 - x0), (ylim[1] - ylim[0]) / (y1 - y0))
            xc, yc = sum(xlim) / 2, sum(ylim) / 2
            xlim = (xc - per_px * (x1 - x0) / 2, xc + per_px * (x1 - x0) / 2)
            ylim = (yc - per_px * (y1 - y0) / 2, yc + per_px * (y1 - y0) / 2)
        self.xlim, self.ylim = xlim, ylim

    def on(self, canvas: Canvas) -> Axes:
        """The same axes (box and limits) on another canvas of the same size."""
        return Axes(canvas, self.box, self.xlim, self.ylim)

    def to_px(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Data to canvas pixels (y up)."""
        x0, y0, x1, y1 = self.box
        px = x0 + (np.asarray(x, float) - self.xlim[0]) / (self.xlim[1] - self.xlim[0]) * (x1 - x0)
        py = y1 - (np.asarray(y, float) - self.ylim[0]) / (self.ylim[1] - self.ylim[0]) * (y1 - y0)
        return px, py

    def frame(self, *, title: str = "", xlabel: str = "", ylabel: str = "",
              grid: bool = True) -> None:
        """Grid, box, ticks with labels, axis labels and the title."""
        c, (x0, y0, x1, y1) = self.canvas, self.box
        c.x_labels.append(xlabel)
        c.labels += [title, ylabel]
        tick, pad = c.px(3.5), c.px(2.0)
        xticks = nice_ticks(*self.xlim)
        yticks = nice_ticks(*self.ylim)
        px, _ = self.to_px(xticks, np.zeros_like(xticks))
        _, py = self.to_px(np.zeros_like(yticks), yticks)
        for x in px:
            if grid:
                c.draw.line([(x, y0), (x, y1)], fill=c.ink(GRID), width=max(1, round(c.px(0.8))))
            c.draw.line([(x, y1), (x, y1 + tick)], fill=c.ink(TEXT), width=max(1, round(c.px(0.8))))
        for y in py:
            if grid:
                c.draw.line([(x0, y), (x1, y)], fill=c.ink(GRID), width=max(1, round(c.px(0.8))))
            c.draw.line([(x0 - tick, y), (x0, y)], fill=c.ink(TEXT), width=max(1, round(c.px(0.8))))
        c.draw.rectangle([x0, y0, x1, y1], outline=c.ink(TEXT), width=max(1, round(c.px(0.8))))
        for x, value in zip(px, xticks, strict=True):
            c.text((x, y1 + tick + pad), tick_label(value), anchor="ma")
        widest = 0.0
        for y, value in zip(py, yticks, strict=True):
            label = tick_label(value)
            widest = max(widest, c.draw.textlength(label, font=font(round(c.px(10.0)))))
            c.text((x0 - tick - pad, y), label, anchor="rm")
        c.text(((x0 + x1) / 2, y1 + tick + pad + c.px(13.0)), xlabel, anchor="ma")
        c.text((x0 - tick - 2 * pad - widest - c.px(7.0), (y0 + y1) / 2), ylabel,
               vertical=True)
        c.text(((x0 + x1) / 2, y0 - c.px(4.0)), title, size=12.0, anchor="md")

    def polyline(self, x, y, *, color: str, width: float = 1.5, dots: float = 0.0,
                 dotted: bool = False) -> None:
        """Connected points (gaps at non-finite values), ``width`` and ``dots`` in points."""
        c = self.canvas
        px, py = self.to_px(x, y)
        finite = np.isfinite(px) & np.isfinite(py)
        ink, line_px = c.ink(color), max(1, round(c.px(width)))
        if width > 0:
            edges = np.flatnonzero(np.diff(np.concatenate([[0], finite.astype(int), [0]])))
            for start, stop in zip(edges[::2], edges[1::2], strict=True):
                points = list(zip(px[start:stop].tolist(), py[start:stop].tolist(), strict=True))
                if dotted:
                    for a, b in zip(points[:-1], points[1:], strict=True):
                        _dotted(c, a, b, ink, line_px)
                elif len(points) > 1:
                    c.draw.line(points, fill=ink, width=line_px)
        if dots > 0:
            r = c.px(dots) / 2
            for xi, yi in zip(px[finite].tolist(), py[finite].tolist(), strict=True):
                c.draw.ellipse([xi - r, yi - r, xi + r, yi + r], fill=ink)

    def legend(self, entries: list[tuple[str, str]]) -> None:
        """(label, colour) entries in the upper right corner of the axes."""
        c, (_, y0, x1, _) = self.canvas, self.box
        face = font(round(c.px(9.0)))
        longest = max(c.draw.textlength(label, font=face) for label, _ in entries)
        step, sample = c.px(13.0), c.px(18.0)
        left = x1 - c.px(6.0) - longest - sample - c.px(6.0)
        c.draw.rectangle([left - c.px(4.0), y0 + c.px(4.0), x1 - c.px(4.0),
                          y0 + c.px(8.0) + step * len(entries)], fill=c.ink("white"),
                         outline=c.ink(GRID))
        for k, (label, color) in enumerate(entries):
            y = y0 + c.px(6.0) + step * (k + 0.5)
            c.draw.line([(left, y), (left + sample, y)], fill=c.ink(color),
                        width=round(c.px(1.5)))
            c.text((left + sample + c.px(4.0), y), label, size=9.0, anchor="lm")


def _dotted(canvas: Canvas, a, b, ink, width: int) -> None:
    """A dotted segment from a to b (dots ``width`` long, gaps twice that)."""
    length = float(np.hypot(b[0] - a[0], b[1] - a[1]))
    period = 3.0 * width
    for s in np.arange(0.0, length, period):
        e = min(s + width, length)
        canvas.draw.line([(a[0] + (b[0] - a[0]) * s / length, a[1] + (b[1] - a[1]) * s / length),
                          (a[0] + (b[0] - a[0]) * e / length, a[1] + (b[1] - a[1]) * e / length)],
                         fill=ink, width=width)


def save_chart(path: str | Path, panels: list[Panel], *, size: tuple[float, float],
               title: str = "", columns: int | None = None, wspace: float = 0.3,
               hspace: float = 0.45) -> Path:
    """Panels in a grid (row by row) as one PNG.

    Args:
        path: Output .png.
        panels: Left to right, then top to bottom.
        size: Figure width, height in inches.
        title: Figure title above the panels.
        columns: Panels per row (default: all in one row).
        wspace: Gap between columns, a fraction of the panel width.
        hspace: Gap between rows, a fraction of the panel height.

    Returns:
        ``path``.
    """
    canvas = Canvas(size)
    s = DPI * canvas.scale
    left, right, bottom, top = (m * s for m in MARGINS)
    top += 0.3 * s if title else 0.0
    columns = columns or len(panels)
    rows = -(-len(panels) // columns)
    width = (canvas.width - left - right) / (columns + wspace * (columns - 1))
    height = (canvas.height - top - bottom) / (rows + hspace * (rows - 1))
    for k, panel in enumerate(panels):
        x0 = left + (k % columns) * width * (1 + wspace)
        y0 = top + (k // columns) * height * (1 + hspace)
        xs = [line.x for line in panel.lines] + [np.asarray(panel.vlines, float)]
        ys = [line.y for line in panel.lines] + [np.asarray(panel.hlines, float)]
        ys += [np.asarray(panel.band, float)] if panel.band else []
        axes = Axes(canvas, (x0, y0, x0 + width, y0 + height), data_limits(xs, margin=0.02),
                    panel.ylim or data_limits(ys))
        if panel.band:
            _, top_px = axes.to_px(0.0, max(panel.band))
            _, bottom_px = axes.to_px(0.0, min(panel.band))
            canvas.draw.rectangle([x0, max(top_px, y0), x0 + width, min(bottom_px, y0 + height)],
                                  fill=canvas.ink(BAND))
        axes.frame(title=panel.title, xlabel=panel.xlabel, ylabel=panel.ylabel)
        for y in panel.hlines:
            axes.polyline(axes.xlim, (y, y), color="#4d4d4d", width=0.6)
        for x in panel.vlines:
            axes.polyline((x, x), axes.ylim, color="#999999", width=1.0, dotted=True)
        for line in panel.lines:
            axes.polyline(line.x, line.y, color=line.color, width=line.width, dots=line.dots)
        labelled = [(line.label, line.color) for line in panel.lines if line.label]
        if panel.band and labelled:
            low, high = panel.band
            text = f"±{high:g}" if low == -high else f"{low:g}..{high:g}"
            labelled.append((text, "#a9c5d5"))
        if labelled:
            axes.legend(labelled)
    canvas.text((canvas.width / 2, canvas.px(6.0)), title, size=13.0, anchor="ma")
    return canvas.save_png(path)
