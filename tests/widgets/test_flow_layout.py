"""FlowLayout: a row of controls that wraps onto more lines on a narrow window (its minimum width
is its widest item's, its height follows its width), groups kept on one line, hidden items
taking no room; hold_height_for_width keeps wrapped rows visible where only a minimum is asked."""
from __future__ import annotations

from PySide6.QtWidgets import QApplication, QCheckBox, QLabel, QPushButton, QSpinBox, QSplitter, QVBoxLayout, QWidget

from widgets.flow_layout import FlowLayout
from widgets.wrapping_box import hold_height_for_width


def flow_box():
    box = QWidget()
    flow = FlowLayout(spacing=8, line_spacing=6)
    box.setLayout(flow)
    buttons = [QPushButton(f"Button number {i}") for i in range(4)]
    for b in buttons:
        flow.addWidget(b)
    group = flow.add_group(QCheckBox("Robust (Huber), k ="), QSpinBox())
    return box, flow, buttons, group


def test_one_line_when_wide_and_more_lines_when_narrow(qtbot):
    box, flow, buttons, group = flow_box()
    qtbot.addWidget(box)
    line = max(w.sizeHint().height() for w in buttons + [group])
    assert flow.heightForWidth(flow.sizeHint().width()) == line
    widest = max(w.sizeHint().width() for w in buttons + [group])
    assert flow.minimumSize().width() == widest
    assert flow.heightForWidth(widest) == sum(w.sizeHint().height() for w in buttons + [group]) + 6 * 4

    box.resize(2 * buttons[0].sizeHint().width() + 8 + 2, 400)
    box.show()
    QApplication.processEvents()
    tops = [b.geometry().top() for b in buttons]
    assert tops[0] == tops[1] < tops[2] == tops[3] < group.geometry().top()      # two per line, then the group
    assert buttons[1].geometry().left() == buttons[0].geometry().right() + 1 + 8
    for w in buttons + [group]:
        assert w.size() == w.sizeHint() and box.rect().contains(w.geometry())


def test_hidden_items_take_no_room(qtbot):
    box, flow, buttons, group = flow_box()
    qtbot.addWidget(box)
    full = flow.sizeHint().width()
    buttons[1].hide()
    assert flow.sizeHint().width() == full - buttons[1].sizeHint().width() - 8


def test_a_splitter_pane_keeps_the_height_of_its_wrapped_rows(qtbot):
    pane = hold_height_for_width(QWidget())
    column = QVBoxLayout(pane)
    label = QLabel("A long explanation that wraps onto several lines when the pane is narrow. " * 4)
    label.setWordWrap(True)
    column.addWidget(label)
    splitter = QSplitter()
    splitter.setOrientation(splitter.orientation().Vertical)
    splitter.addWidget(pane)
    splitter.addWidget(QWidget())
    qtbot.addWidget(splitter)
    splitter.resize(260, 300)
    splitter.setSizes([10, 290])                  # asked smaller than its text
    splitter.show()
    QApplication.processEvents()
    splitter.setSizes([10, 290])
    QApplication.processEvents()
    assert label.height() >= label.heightForWidth(label.width()) > 3 * label.fontMetrics().height()
