"""Report figures drawn with pyqtgraph: the legend scales with the exported image (it is as
readable as the axis labels at print size), and log axes label only a few uncrowded ticks."""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg
import pytest

from app.report import figures
from app.report.figures import PRINT_SCALE, ColumnNamesAxis, log_ticks, plot_widget, render_png
from core.report.document import Figure, panel, series


def dark_pixels(image, rect, scale: float) -> int:
    """Pixels darker than light grey inside `rect` (figure px) of an image `scale` times as big."""
    n = 0
    for y in range(int(rect.top() * scale), int(rect.bottom() * scale)):
        for x in range(int(rect.left() * scale), int(rect.right() * scale)):
            c = image.pixelColor(x, y)
            n += c.red() + c.green() + c.blue() < 3 * 150
    return n


def test_the_legend_grows_with_the_export_scale(qapp):
    fig = Figure("k", "t", "c", [panel("points", "", "x (mm)", "y (mm)",
                                       [series("first series name", [1, 2, 3], [1, 2, 3], color=0),
                                        series("second series name", [1, 2], [2, 1], color=1)])],
                 size=(600, 300))
    w = figures.plot_widget(fig)
    try:
        legends = [i for i in w.scene().items() if isinstance(i, pg.LegendItem)]
        assert len(legends) == 1
        rect = legends[0].sceneBoundingRect()
        plot_rect = w.getItem(0, 0).getViewBox().sceneBoundingRect()
    finally:
        w.close()
        w.deleteLater()
    assert rect.top() >= plot_rect.bottom()             # below the plot, never over the data
    small, big = render_png(fig, 1.0), render_png(fig, 2.5)
    ink_small, ink_big = dark_pixels(small, rect, 1.0), dark_pixels(big, rect, 2.5)
    assert ink_small > 50
    assert ink_big / ink_small > 4                    # area grows as the scale² (6.25); unscaled text: ~1


@pytest.mark.parametrize("lo, hi, labelled", [
    (18.0, 130.0, [20, 50, 100]),                     # κ from 18 to 130: 1, 2, 5 × 10^k
    (0.01, 8.0, [0.01, 0.1, 1, 10]),                  # three decades: the decades only
    (21.0, 29.0, [20, 30]),                           # within a decade: 1, 2, 3, 5 × 10^k
])
def test_log_ticks_label_few_values(lo, hi, labelled):
    major, minor = log_ticks([lo, (lo + hi) / 2, hi])
    shown = [v for v in major if lo / 1.5 <= v <= hi * 1.5]
    assert np.allclose(shown, labelled)
    assert not set(major) & set(minor)


def test_log_ticks_of_many_decades_stay_under_ten_labels():
    major, minor = log_ticks([1e-6, 1e9])
    assert 4 <= len(major) <= 10 and minor == []
    assert log_ticks([0.0, -1.0, float("nan")]) == ([], [])


def test_a_worker_gets_figures_drawn_on_the_gui_thread(qapp, qtbot):
    import threading

    from PySide6.QtCore import QThread

    from app.report import gui_drawer
    from app.report.gui_drawer import GuiDrawer
    from core.errors import Cancelled

    fig = Figure("k", "t", "c", [panel("points", "", "x (mm)", "y (mm)", [series("a", [1, 2], [1, 2])])],
                 size=(300, 200))
    drawer, gui = GuiDrawer(), QThread.currentThread()
    threads, out = [], {}
    real = gui_drawer.render_png

    def spy(f):
        threads.append(QThread.currentThread())
        return real(f)

    def work():
        out["image"] = drawer.draw(fig)
        try:
            drawer.draw(fig, cancelled=lambda: True)
        except Cancelled:
            out["cancelled"] = True

    gui_drawer.render_png = spy
    try:
        worker = threading.Thread(target=work)
        worker.start()
        qtbot.waitUntil(lambda: not worker.is_alive(), timeout=20000)
    finally:
        gui_drawer.render_png = real
    assert out["image"].width() == int(300 * figures.SCALE) and out.get("cancelled")
    assert threads and all(t is gui for t in threads)


@pytest.mark.parametrize("value, text", [(20.0, "20"), (0.01, "0.01"), (1e6, "10⁶"), (1e-5, "10⁻⁵"),
                                         (2e5, "2×10⁵")])
def test_log_tick_text_is_short(value, text):
    assert figures.tick_text(value) == text


def test_one_notation_per_log_axis():
    assert [figures.tick_text(v, powers=True) for v in (100.0, 1e4)] == ["10²", "10⁴"]


def test_figure_text_prints_at_8_to_9_pt(qapp):
    """Tick labels, legends and axis labels are drawn 1 / PRINT_SCALE larger than printed: on an A4
    page (figures printed at PRINT_SCALE of their drawn size) they read 8.5 and 9 pt."""
    fig = Figure("f", "t", "c", [panel("points", "", "x (mm)", "y (mm)",
                                       [series("a", [0, 1], [0, 1]), series("b", [0, 1], [1, 0])])])
    w = plot_widget(fig)
    try:
        plot = w.getItem(0, 0)
        for name in ("left", "bottom"):
            printed = plot.getAxis(name).style["tickFont"].pointSizeF() * PRINT_SCALE
            assert 8.0 <= printed <= 9.0, (name, printed)
        legend = w.getItem(1, 0)
        label_pt = float(legend.opts["labelTextSize"].removesuffix("pt"))
        assert 8.0 <= label_pt * PRINT_SCALE <= 9.0
    finally:
        w.close()
        w.deleteLater()


def test_the_correlation_matrix_names_its_rows_and_columns(qapp):
    names = ["J1.a", "J1.α", "J5.θ", "base.x"]
    m = np.eye(4)
    m[2, 0] = m[0, 2] = -1.0
    fig = Figure("c", "corr", "", [{**panel("matrix", "", "", "", []), "matrix": m, "labels": names}],
                 size=(500, 470))
    w = plot_widget(fig)
    try:
        plot = w.getItem(0, 0)
        left = plot.getAxis("left")
        assert [t for _, t in left._tickLevels[0]] == names
        bottom = plot.getAxis("bottom")
        assert isinstance(bottom, ColumnNamesAxis) and [t for _, t in bottom._names] == names
        # the upright names need their height below the matrix, and are drawn there
        assert bottom.height() > 30
        below = bottom.sceneBoundingRect()
    finally:
        w.close()
        w.deleteLater()
    assert dark_pixels(render_png(fig), below, figures.SCALE) > 2500      # four numbers alone: about 1900
