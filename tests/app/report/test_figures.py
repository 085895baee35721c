"""Report figures drawn with pyqtgraph: the legend scales with the exported image (it is as
readable as the axis labels at print size), and log axes label only a few uncrowded ticks."""
from __future__ import annotations

import numpy as np
import pyqtgraph as pg
import pytest

from app.report import figures
from app.report.figures import log_ticks, render_png
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
    w = figures._widget(fig)
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
