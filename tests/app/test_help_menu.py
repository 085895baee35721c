"""The Help menu: each guide opened as an HTML page in the browser, the keyboard shortcuts."""
from __future__ import annotations

from pathlib import Path

import pytest
from PySide6.QtCore import QObject, Slot
from PySide6.QtGui import QDesktopServices
from PySide6.QtWidgets import QMessageBox

from app.help_menu import GUIDES, docs_dir, guide_html
from app.main_window import MainWindow
from app.state import WizardState


class Browser(QObject):
    """Takes the URLs Qt would hand to the web browser (QDesktopServices' own hook)."""

    def __init__(self):
        super().__init__()
        self.opened: list[str] = []

    @Slot("QUrl")
    def open(self, url):
        self.opened.append(url.toLocalFile())


@pytest.fixture
def browser():
    b = Browser()
    QDesktopServices.setUrlHandler("file", b, "open")
    yield b
    QDesktopServices.unsetUrlHandler("file")


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    win = MainWindow(WizardState())
    qtbot.addWidget(win)
    yield win
    win.close()


@pytest.mark.parametrize("name", [n for _, n in GUIDES])
def test_every_guide_becomes_a_page_whose_images_resolve_in_docs(name):
    source = docs_dir() / name
    first_heading = next(line for line in source.read_text(encoding="utf-8").splitlines() if line.startswith("#"))
    html = guide_html(source)
    assert first_heading.lstrip("# ").split("`")[0].strip()[:20] in html
    assert f'<base href="file://{docs_dir()}/">' in html


def test_the_help_menu_opens_the_guides_in_the_browser(window, browser, tmp_path):
    help_menu = next(a.menu() for a in window.menuBar().actions() if a.text() == "&Help")
    texts = [a.text() for a in help_menu.actions() if not a.isSeparator()]
    assert texts == ["&User guide", "&Teaching guide", "&File formats", "Robot serial &protocol",
                     "&Keyboard shortcuts", "&About RoboCal"]
    for action in help_menu.actions()[:4]:
        action.trigger()
    assert [Path(p).name for p in browser.opened] == ["user-guide.html", "teaching-guide.html", "file-formats.html",
                                                      "robot-protocol.html"]
    for page in map(Path, browser.opened):
        assert page.is_relative_to(tmp_path / "cache") and page.stat().st_size > 1000


def test_the_shortcuts_dialog_lists_the_stop_key(window, qtbot):
    help_menu = next(a.menu() for a in window.menuBar().actions() if a.text() == "&Help")
    next(a for a in help_menu.actions() if a.objectName() == "keyboardShortcuts").trigger()
    box = window.findChild(QMessageBox, "shortcutsDialog")
    qtbot.waitUntil(box.isVisible)
    text = box.text()
    assert "Stop robot" in text and "Esc" in text and "Explain" in text and "F1" in text
    box.close()
