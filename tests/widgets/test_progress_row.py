"""ProgressRow: the bar with the worker's message, Cancel enabled only while busy, and the row
scrolled into sight when work starts while its scrolling box shows something else."""
from __future__ import annotations

from PySide6.QtWidgets import QApplication, QLabel, QScrollArea, QVBoxLayout, QWidget

from widgets.progress_row import ProgressRow


def test_message_fraction_and_cancel(qtbot):
    row = ProgressRow()
    qtbot.addWidget(row)
    row.set_progress(0.25, "rendering 50 % of the pairs")
    assert row.bar.value() == 250 and row.bar.format() == "rendering 50 %% of the pairs  %p%"
    assert not row.cancel_button.isEnabled()
    row.set_busy(True)
    with qtbot.waitSignal(row.cancelRequested, timeout=1000):
        row.cancel_button.click()
    row.reset()
    assert row.bar.value() == 0 and row.bar.format() == "%p%"


def test_a_row_that_becomes_busy_below_the_visible_part_scrolls_into_sight(qtbot):
    box = QScrollArea()
    box.setWidgetResizable(True)
    content = QWidget()
    layout = QVBoxLayout(content)
    tall = QLabel("the pairs")
    tall.setMinimumHeight(900)
    row = ProgressRow()
    layout.addWidget(tall)
    layout.addWidget(row)
    box.setWidget(content)
    box.resize(400, 200)
    qtbot.addWidget(box)
    box.show()
    qtbot.waitExposed(box)
    bar = box.verticalScrollBar()
    assert bar.value() == 0 and row.visibleRegion().isEmpty()
    row.set_busy(True)
    qtbot.waitUntil(lambda: not row.visibleRegion().isEmpty(), timeout=2000)
    assert bar.value() > 0
    bar.setValue(0)                       # the technician scrolls back up while the work runs
    row.set_busy(True)                    # still busy: the box stays where it was put
    QApplication.processEvents()          # (a scroll would have been queued for now)
    assert bar.value() == 0
