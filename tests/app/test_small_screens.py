"""Every page at 1280×720 and 1920×1080, with the explain panel open and closed, once the demo
has filled them with results: the window stays the screen's size, the page fits beside the step
list and the explain panel without scrolling sideways, and no visible control is cut (its size at
least its minimum size hint, a wrapped label as tall as its text needs, no step title elided).

The demo runs once for the session (the autopilot through every page, the `demo_walk` fixture of
tests/app/conftest.py); each test shows the window and hides it again."""
from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QFontMetrics
from PySide6.QtTest import QTest
from PySide6.QtWidgets import (QAbstractButton, QAbstractSpinBox, QApplication, QComboBox, QGroupBox, QLabel,
                               QScrollArea, QSplitter, QSplitterHandle, QTabWidget, QWidget)

from app.pages.steps import Step

pytestmark = pytest.mark.slow               # the demo walk first

SIZES = [(1280, 720), (1920, 1080)]
#: where the 1280×720 screenshots go besides pytest's folder (docs/screenshots/small-screen when
#: they are made for the documentation)
SHOTS_ENV = "ROBOCAL_SMALL_SCREEN_SHOTS"


@pytest.fixture(scope="module")
def demo_window(demo_walk):
    """The main window after the classroom demo ran through every page (the session's demo walk,
    tests/app/demo_walk.py), hidden."""
    assert demo_walk.exit_code == 0, demo_walk.output
    return demo_walk.window


@pytest.fixture
def window(demo_window, qtbot):
    demo_window.show()
    yield demo_window
    demo_window.action_explain.setChecked(True)
    qtbot.waitUntil(lambda: not demo_window.tasks.busy, timeout=60000)     # a page's refresh on entry
    settle(demo_window, 1280, 720)         # each test starts from the small screen, as the first did
    demo_window.hide()


@pytest.fixture(scope="module")
def shots(tmp_path_factory) -> list[Path]:
    folders = [tmp_path_factory.mktemp("small-screen")]
    if os.environ.get(SHOTS_ENV):
        folders.append(Path(os.environ[SHOTS_ENV]))
    return folders


SETTLED_ROUNDS = 2          # rounds of 50 ms after which the layout is still the same: settled
SETTLE_TIMEOUT_S = 5.0


def layout_signature(win) -> tuple:
    """The window's size and every visible scroll area's viewport, content and scroll bars."""
    areas = [a for a in [win.stack.currentWidget()] + win.stack.currentWidget().findChildren(QScrollArea)
             if a.isVisibleTo(win)]
    return (win.size().toTuple(), tuple((a.viewport().size().toTuple(), a.widget().size().toTuple(),
                                         a.horizontalScrollBar().isVisible(), a.verticalScrollBar().isVisible())
                                        for a in areas if a.widget() is not None))


def settle(win, width: int, height: int) -> None:
    """Resize the window and let the layouts settle (a wrapped row's new height travels up, and a
    scroll bar shown meanwhile goes again): until nothing moved for SETTLED_ROUNDS rounds of
    50 ms (150 ms at least), however long a busy machine takes."""
    win.resize(width, height)
    last, same = None, 0
    deadline = time.monotonic() + SETTLE_TIMEOUT_S
    while same < SETTLED_ROUNDS and time.monotonic() < deadline:
        QTest.qWait(50)
        now = layout_signature(win)
        same = same + 1 if now == last else 0
        last = now


def cut_controls(win) -> list[str]:
    """The visible labels, buttons, check boxes, combo and spin boxes smaller than their minimum
    size hint, and the wrapped labels shorter than their text (as 'name[text] size < needed')."""
    cut = []
    controls = (QLabel, QAbstractButton, QComboBox, QAbstractSpinBox)
    for w in win.findChildren(QWidget):
        if not isinstance(w, controls) or not w.isVisibleTo(win) or w.window() is not win:
            continue
        need = w.minimumSizeHint()
        if isinstance(w, QAbstractButton):
            need = need.expandedTo(w.sizeHint())          # its text on one line
        if isinstance(w, QLabel) and w.wordWrap() and w.text():
            need.setHeight(max(need.height(), w.heightForWidth(w.width())))
        if need.isValid() and (w.width() < need.width() or w.height() < need.height()):
            text = w.currentText() if isinstance(w, QComboBox) else getattr(w, "text", lambda: "")()
            cut.append(f"{w.objectName() or type(w).__name__}[{str(text)[:40]!r}] {w.width()}x{w.height()} "
                       f"< {need.width()}x{need.height()}")
    for box in win.findChildren(QGroupBox):                 # a group box's title on one line
        if box.isVisibleTo(win) and box.width() < QFontMetrics(box.font()).horizontalAdvance(box.title()) + 16:
            cut.append(f"group box {box.title()!r} {box.width()} px")
    return cut


def overlapping(page) -> list[str]:
    """Controls a layout or splitter placed over each other or beyond their parent: siblings in one
    layout or splitter that intersect, and children reaching out of their parent (a box squeezed below what its
    rows need). Scroll areas' contents are left alone: they reach beyond their viewport."""
    out = []
    for parent in [page] + page.findChildren(QWidget):
        if not parent.isVisible() or parent.objectName() == "qt_scrollarea_viewport":
            continue
        direct = [k for k in parent.findChildren(QWidget, options=Qt.FindChildOption.FindDirectChildrenOnly)
                  if k.isVisible() and not k.isWindow()]
        if isinstance(parent, QSplitter):
            kids = [k for k in direct if not isinstance(k, QSplitterHandle)]
        elif parent.layout() is not None:
            kids = [k for k in direct if _in_nested_layout(parent.layout(), k)]
        else:
            continue
        for k in kids:
            if not parent.rect().adjusted(-1, -1, 1, 1).contains(k.geometry()):
                out.append(f"{_name(k)} {k.geometry().getRect()} outside {_name(parent)} {parent.rect().getRect()}")
        for i, a in enumerate(kids):
            for b in kids[i + 1:]:
                if a.geometry().intersects(b.geometry()):
                    out.append(f"{_name(a)} {a.geometry().getRect()} over {_name(b)} {b.geometry().getRect()}")
    return out


def _in_nested_layout(layout, widget) -> bool:
    for i in range(layout.count()):
        item = layout.itemAt(i)
        if item.widget() is widget:
            return True
        if item.layout() is not None and _in_nested_layout(item.layout(), widget):
            return True
    return False


def _name(w) -> str:
    text = w.text() if isinstance(w, (QLabel, QAbstractButton)) else ""
    return f"{w.objectName() or type(w).__name__}{f'[{text[:24]!r}]' if text else ''}"


def elided_steps(win) -> list[str]:
    """The step list's titles its delegate would cut short (badge 28 px, gaps 8 + 10 + 6 px)."""
    sl = win.step_list
    metrics = QFontMetrics(sl.font())
    out = []
    for i in range(sl.count()):
        title = sl.item(i).text().split("\n")[0]
        room = sl.visualItemRect(sl.item(i)).width() - 8 - 6 - 28 - 10
        if metrics.horizontalAdvance(title) > room:
            out.append(title)
    return out


def sideways(win) -> list[str]:
    """Scroll areas of the current page showing a horizontal scroll bar."""
    scroll = win.stack.currentWidget()
    areas = [scroll] + scroll.findChildren(QScrollArea)
    return [f"{a.objectName() or type(a.parent()).__name__}: {a.widget().minimumSizeHint().width()} px wide in "
            f"{a.viewport().width()} px" for a in areas if a.isVisibleTo(win) and a.horizontalScrollBar().isVisible()]


@pytest.mark.parametrize("step", list(Step), ids=[s.slug for s in Step])
def test_every_page_fits_small_and_large_screens(window, step, shots):
    win = window
    win.go_to(step)
    problems = []
    for explain in (True, False):
        win.action_explain.setChecked(explain)
        for width, height in SIZES:
            settle(win, width, height)
            where = f"{step.slug} at {width}x{height}, explain {'open' if explain else 'closed'}"
            if win.width() > width or win.height() > height:
                problems.append(f"{where}: the window grew to {win.width()}x{win.height()}")
            assert win.explain_dock.isVisible() == explain
            page = win.current_page()
            tabs = [t for t in page.findChildren(QTabWidget) if t.isVisibleTo(win)]
            for tab_widget in tabs or [None]:
                for index in range(tab_widget.count()) if tab_widget is not None else [None]:
                    if tab_widget is not None:
                        tab_widget.setCurrentIndex(index)
                        QTest.qWait(50)
                    tab = f" tab {tab_widget.tabText(index)!r}" if tab_widget is not None else ""
                    problems += [f"{where}{tab}: cut {c}" for c in cut_controls(win)]
                    problems += [f"{where}{tab}: scrolls sideways ({s})" for s in sideways(win)]
                    problems += [f"{where}{tab}: overlap {o}" for o in overlapping(page)]
            problems += [f"{where}: step title elided {t!r}" for t in elided_steps(win)]
            if tabs:
                for t in tabs:
                    t.setCurrentIndex(0)
            if width == 1280 and explain:
                QApplication.processEvents()
                image = win.grab()
                assert image.width() == 1280 and image.height() == 720
                for folder in shots:
                    folder.mkdir(parents=True, exist_ok=True)
                    assert image.save(str(folder / f"{step.number:02d}-{step.slug}.png"))
    assert not problems, "\n".join(problems)


def test_closing_the_explain_panel_gives_its_room_to_the_page(window):
    win = window
    win.go_to(Step.IDENTIFICATION)
    settle(win, 1280, 720)
    with_panel = win.stack.width()
    dock = win.explain_dock.width()
    assert 250 <= dock <= 320                       # narrow beside a small screen's page
    win.action_explain.setChecked(False)
    settle(win, 1280, 720)
    assert win.size().width() == 1280 and win.stack.width() >= with_panel + dock - 10
    win.action_explain.setChecked(True)
    settle(win, 1920, 1080)
    assert win.explain_dock.width() > 400           # room again on a large screen


def test_the_simulated_change_is_shown_whole_on_a_small_screen(window):
    """The Check page's "Simulate a change (virtual lab)" box at 1280×720 beside the explain panel:
    its title, its note (every line), the change chosen and its joint and size boxes uncut."""
    win = window
    page = win.go_to(Step.CHECK)
    settle(win, 1280, 720)
    box = page.controls.change_box
    page.controls.choose_change("joint", 0.4, joint=3)
    QApplication.processEvents()
    assert box.isVisibleTo(win)
    assert cut_controls(win) == []
    metrics = QFontMetrics(box.font())
    assert box.width() >= metrics.horizontalAdvance("Simulate a change (virtual lab)") + 16
    note = next(label for label in box.findChildren(QLabel) if label.wordWrap())
    assert note.height() >= note.heightForWidth(note.width()) and note.width() >= 200
    assert page.controls.joint_spin.width() >= page.controls.joint_spin.minimumSizeHint().width()
    assert page.controls.size_spin.width() >= page.controls.size_spin.sizeHint().width()
    page.controls.choose_change("", 1.5)
