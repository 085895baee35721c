"""Draw a report Figure (core.report.document) headless with pyqtgraph: white background,
axes with their units, a legend, PNG at print resolution. (No SVG: pyqtgraph 0.14's SVG
exporter fails on the paths this Qt version writes, and Qt's QSvgGenerator misplaces the
scatter symbols.)

Needs a QApplication (the offscreen platform is enough). The plot widget is shown with
WA_DontShowOnScreen so that its layout is done without a window appearing."""
from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from pyqtgraph.exporters import ImageExporter
from PySide6.QtCore import QRectF, Qt
from PySide6.QtGui import QColor, QFont, QFontMetrics, QImage
from PySide6.QtWidgets import QApplication

from core.report.document import PALETTE, Figure

SCALE = 2.5           # PNG pixels per figure pixel: 900 px wide figures become 2250 px (about 330 dpi printed)
#: printed size / drawn size of a figure (96 dpi px): a 900 px figure is 174 mm wide, the text width
#: of an A4 page with 15 mm margins; the font sizes below are drawn 1 / PRINT_SCALE larger so that
#: on paper the tick labels and legends are 8.5 pt, the axis labels 9 pt and panel titles 9.5 pt.
PRINT_SCALE = 0.73
TICK_PT = 8.5 / PRINT_SCALE
LABEL_PT = 9.0 / PRINT_SCALE
TITLE_PT = 9.5 / PRINT_SCALE
LEGEND_PT = TICK_PT
MAX_TICKS = 25
MATRIX_COLORMAP = "CET-D1"     # blue – white – red, as the Identification page's correlation view
_SYMBOLS = {"o": "o", "t": "t", "s": "s", "+": "+", "x": "x", "": None}


def _color(s: dict, i: int) -> QColor:
    return QColor(PALETTE[s.get("color", i) % len(PALETTE)])


def _style_axes(plot: pg.PlotItem, p: dict) -> None:
    font = QFont()
    font.setPointSizeF(TICK_PT)
    for name in ("left", "bottom"):
        axis = plot.getAxis(name)
        axis.setTickFont(font)
        axis.setPen(pg.mkPen("#5f6368"))
        axis.setTextPen(pg.mkPen("#202124"))
        axis.enableAutoSIPrefix(False)       # the label carries the unit; no "(x0.001)"
    label = {"font-size": f"{LABEL_PT:.1f}pt", "color": "#202124"}
    plot.setLabel("bottom", p["xlabel"], **label)
    plot.setLabel("left", p["ylabel"], **label)
    if p.get("title"):
        plot.setTitle(p["title"], size=f"{TITLE_PT:.1f}pt", color="#202124")
    plot.showGrid(x=True, y=True, alpha=0.18)


def _ticks(plot: pg.PlotItem, ticks: list) -> None:
    step = max(1, math.ceil(len(ticks) / MAX_TICKS))
    pairs = [tuple(t) if isinstance(t, (tuple, list)) else (t, t) for t in ticks]
    plot.getAxis("bottom").setTicks([[(float(v), str(label)) for v, label in pairs[::step]], []])


def log_ticks(values) -> tuple[list[float], list[float]]:
    """Tick values of a log axis spanning `values` (> 0): (labelled, unlabelled). Labels at
    1, 2, 5 × 10^k over two decades or less (1, 2, 3, 5 within one), else at the decades only,
    so that no two labels crowd each other."""
    v = np.asarray([x for x in values if x is not None and np.isfinite(x) and x > 0], dtype=float)
    if len(v) == 0:
        return [], []
    d0, d1 = math.floor(math.log10(v.min())), math.ceil(math.log10(v.max()))
    d1 = max(d1, d0 + 1)
    span = d1 - d0
    labelled = (1, 2, 3, 5) if span <= 1 else (1, 2, 5) if span <= 2 else (1,)
    step = max(1, math.ceil(span / 8))            # at most about 8 decade labels
    major, minor = [], []
    for d in range(d0, d1 + 1):
        for m in range(1, 10):
            value = m * 10.0 ** d
            if m in labelled and (m > 1 or (d - d0) % step == 0):
                major.append(value)
            elif span <= 6:
                minor.append(value)
    return major, minor


_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def tick_text(value: float, powers: bool = False) -> str:
    """A log axis label: plain below 10⁴ and from 0.001 (unless `powers`), else a power of ten
    (10⁵, 2×10⁻⁴)."""
    if not powers and 1e-3 <= value < 1e4:
        return f"{value:.10g}"
    k = math.floor(math.log10(value) + 1e-9)
    m = round(value / 10.0 ** k)
    return ("" if m == 1 else f"{m}×") + "10" + str(k).translate(_SUPERSCRIPT)


def _log_ticks(plot: pg.PlotItem, values) -> None:
    major, minor = log_ticks(values)
    if major:
        powers = not all(1e-3 <= v < 1e4 for v in major)          # one notation on an axis
        plot.getAxis("left").setTicks([[(math.log10(v), tick_text(v, powers)) for v in major],
                                       [(math.log10(v), "") for v in minor]])


def _legend(entries: list, width: float) -> pg.LegendItem:
    """A legend for below a panel `width` px wide: as many columns as the names fit. Unlike
    pyqtgraph's default legend it scales with the exported image."""
    font = QFont()
    font.setPointSizeF(LEGEND_PT)
    metrics = QFontMetrics(font)
    widest = max(metrics.horizontalAdvance(name) for _, name in entries) + 50      # sample + spacing
    legend = pg.LegendItem(labelTextColor="#202124", labelTextSize=f"{LEGEND_PT:.1f}pt", horSpacing=18,
                           colCount=max(1, min(len(entries), int(width // widest))))
    legend.setFlag(legend.GraphicsItemFlag.ItemIgnoresTransformations, False)
    for item, name in entries:
        legend.addItem(item, name)
    return legend


def _draw_points(plot: pg.PlotItem, p: dict) -> list:
    log_y = p.get("log_y")
    if log_y:
        plot.setLogMode(x=False, y=True)
    xs_all, entries = [], []
    for i, s in enumerate(p["series"]):
        color = _color(s, i)
        x = np.asarray(s.get("x", []), dtype=float)
        y = np.asarray(s.get("y", []), dtype=float)
        xs_all.append(x)
        if s.get("bars"):
            width = 0.4 if len(x) < 2 else 0.4 * float(np.min(np.diff(np.unique(x))) if len(np.unique(x)) > 1 else 1)
            item = pg.BarGraphItem(x=x, height=y, width=width * 2 / max(len(p["series"]), 1) * 0.9,
                                   brush=color, pen=pg.mkPen(color.darker(130)))
            plot.addItem(item)
            entries.append((item, s["name"]))
            continue
        if log_y:
            keep = np.isfinite(y) & (y > 0)
            x, y = x[keep], y[keep]
        symbol = _SYMBOLS.get(s.get("symbol", "o"), "o")
        pen = pg.mkPen(color, width=2) if s.get("line") else None
        item = pg.PlotDataItem(x, y, pen=pen, symbol=symbol, symbolSize=7 if symbol in ("o", "t", "s") else 12,
                               symbolBrush=color, symbolPen=pg.mkPen(color.darker(140), width=1.5 if symbol in
                                                                    ("+", "x") else 0.5),
                               name=s["name"])
        plot.addItem(item)
        entries.append((item, s["name"]))
    for value, label in p.get("hlines", []):
        line = pg.InfiniteLine(pos=math.log10(value) if log_y and value > 0 else value, angle=0,
                               pen=pg.mkPen("#b00020", width=2, style=Qt.PenStyle.DashLine),
                               label=label, labelOpts={"position": 0.01, "color": "#b00020", "anchors": [(0, 1), (0, 1)]})
        font = QFont()
        font.setPointSizeF(TICK_PT)
        line.label.setFont(font)
        plot.addItem(line)
    ys = [v for s in p["series"] for v in s.get("y", []) if np.isfinite(v)] + [v for v, _ in p.get("hlines", [])]
    if p.get("hlines") and not log_y and not p.get("equal_aspect") and max(ys) > 0:
        plot.setYRange(min(0.0, min(ys)), max(ys) * 1.15, padding=0)     # room for the lines' labels
    if p.get("x_ticks"):
        _ticks(plot, p["x_ticks"])
    if p.get("equal_aspect"):
        plot.getViewBox().setAspectLocked(True)
    if log_y:
        _log_ticks(plot, [y for s in p["series"] for y in s.get("y", [])] + [v for v, _ in p.get("hlines", [])])
    return entries


def _draw_histogram(plot: pg.PlotItem, p: dict) -> list:
    values = [np.asarray(s.get("values", []), dtype=float) for s in p["series"]]
    allv = np.concatenate([v[np.isfinite(v)] for v in values]) if values else np.zeros(0)
    if len(allv) == 0:
        return []
    lo, hi = float(allv.min()), float(allv.max())
    if hi <= lo:
        lo, hi = lo - 0.5, hi + 0.5
    edges = np.linspace(min(lo, 0.0) if lo >= 0 and lo < 0.2 * hi else lo, hi, p.get("bins", 20) + 1)
    entries = []
    for i, (s, v) in enumerate(zip(p["series"], values)):
        counts, _ = np.histogram(v[np.isfinite(v)], edges)
        color = _color(s, i)
        fill = QColor(color)
        fill.setAlpha(90)
        item = pg.PlotDataItem(edges, counts, stepMode="center", fillLevel=0, brush=fill,
                               pen=pg.mkPen(color, width=2))
        plot.addItem(item)
        entries.append((item, f"{s['name']} ({len(v)})"))
    return entries


def _draw_image(plot: pg.PlotItem, p: dict) -> list:
    img = pg.ImageItem(np.asarray(p["image"]), axisOrder="row-major")
    plot.addItem(img)
    plot.getViewBox().invertY(True)
    return _draw_points(plot, {**p, "equal_aspect": True})


class ColumnNamesAxis(pg.AxisItem):
    """A bottom axis whose labels stand upright (read bottom to top, ending at the axis): long
    names under narrow matrix columns. `names`: (value, text) pairs in view coordinates."""

    def __init__(self, names: list[tuple[float, str]], font: QFont):
        super().__init__("bottom")
        self._names, self._font = names, font
        self.setStyle(showValues=False)
        widest = max((QFontMetrics(font).horizontalAdvance(t) for _, t in names), default=0)
        self.setHeight(widest + 14)

    def paint(self, p, *args):
        super().paint(p, *args)
        lo, hi = self.range
        if hi == lo:
            return
        bounds = self.mapRectFromParent(self.geometry())
        metrics = QFontMetrics(self._font)
        p.setFont(self._font)
        p.setPen(self.textPen())
        for value, text in self._names:
            x = bounds.left() + (value - lo) / (hi - lo) * bounds.width()
            p.save()
            p.translate(x, 8)
            p.rotate(-90)
            w = metrics.horizontalAdvance(text)
            p.drawText(QRectF(-w - 2, -metrics.height() / 2, w + 2, metrics.height()),
                       int(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter), text)
            p.restore()


def _draw_matrix(plot: pg.PlotItem, p: dict) -> list:
    """A correlation-like matrix: blue (−1), white (0), red (+1); the rows and columns named by
    the panel's "labels" (the parameters), else numbered from 1."""
    m = np.asarray(p["matrix"], dtype=float)
    img = pg.ImageItem(np.nan_to_num(m, nan=0.0), axisOrder="row-major")
    img.setRect(0.5, 0.5, m.shape[1], m.shape[0])
    img.setLevels((-1.0, 1.0))
    plot.addItem(img)
    plot.getViewBox().invertY(True)
    plot.getViewBox().setAspectLocked(True)
    plot.getViewBox().setRange(xRange=(0.5, m.shape[1] + 0.5), yRange=(0.5, m.shape[0] + 0.5), padding=0)
    bar = pg.ColorBarItem(values=(-1.0, 1.0), colorMap=pg.colormap.get(MATRIX_COLORMAP), interactive=False,
                          width=14)
    bar.setImageItem(img, insert_in=plot)
    axis = bar.getAxis("right")
    axis.setTextPen(pg.mkPen("#202124"))
    axis.setTickFont(plot.getAxis("left").style["tickFont"])
    labels = p.get("labels")
    if labels:
        ticks = [(float(i + 1), str(name)) for i, name in enumerate(labels)]
        plot.getAxis("left").setTicks([ticks, []])
        plot.getAxis("left").setStyle(hideOverlappingLabels=False)
        bottom = ColumnNamesAxis(ticks, plot.getAxis("left").style["tickFont"])
        bottom.setPen(pg.mkPen("#5f6368"))
        bottom.setTextPen(pg.mkPen("#202124"))
        plot.setAxisItems({"bottom": bottom})
    else:
        step = max(1, math.ceil(len(m) / MAX_TICKS))
        ticks = [(float(i), str(i)) for i in range(1, len(m) + 1, step)]
        for name in ("bottom", "left"):
            plot.getAxis(name).setTicks([ticks, []])
    plot.showGrid(x=False, y=False)
    return []


_DRAW = {"points": _draw_points, "histogram": _draw_histogram, "image": _draw_image, "matrix": _draw_matrix}


def plot_widget(fig: Figure) -> pg.GraphicsLayoutWidget:
    """The figure laid out in a plot widget that is never shown on screen (close it after use)."""
    w = pg.GraphicsLayoutWidget()
    w.setAttribute(Qt.WidgetAttribute.WA_DontShowOnScreen, True)
    w.setBackground("w")
    w.resize(*fig.size)
    legends = []
    for i, p in enumerate(fig.panels):
        plot = w.addPlot(row=0, col=i, enableMenu=False)
        _style_axes(plot, p)
        entries = _DRAW[p["kind"]](plot, p)
        if p["kind"] == "histogram":
            top = max(1.0, plot.getViewBox().childrenBounds()[1][1] or 1.0)
            plot.setYRange(0, top * 1.08, padding=0)
            step = max(1, math.ceil(top / 6))                  # counts: whole-number ticks
            plot.getAxis("left").setTickSpacing(step, step)
        if p["kind"] == "points" and len(entries) == 1 and len(fig.panels) == 1:
            entries = []                          # one series: the axis labels and the caption name it
        legends.append(entries)
    looks = [([name for _, name in entries], [(s["name"], s.get("color", i), s.get("symbol"))
                                                for i, s in enumerate(p["series"])])
             for entries, p in zip(legends, fig.panels)]
    if len(legends) > 1 and looks[0][0] and all(look == looks[0] for look in looks):
        # every panel shows the same series: one legend across the figure
        w.addItem(_legend(legends[0], fig.size[0]), row=1, col=0, colspan=len(legends))
    else:
        for i, entries in enumerate(legends):
            if entries:
                w.addItem(_legend(entries, fig.size[0] / len(fig.panels)), row=1, col=i)
    w.show()
    QApplication.processEvents()
    return w


def render_png(fig: Figure, scale: float = SCALE) -> QImage:
    """The figure as an image `scale` times its size."""
    w = plot_widget(fig)
    try:
        exporter = ImageExporter(w.scene())
        exporter.parameters()["width"] = int(fig.size[0] * scale)
        exporter.parameters()["antialias"] = True
        image = exporter.export(toBytes=True)
    finally:
        w.close()
        w.deleteLater()
    return image
