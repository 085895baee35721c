"""The Help menu: the guides shipped with RoboCal opened in the web browser, the keyboard
shortcuts, About.

The guides are the Markdown files of docs/ (beside resources/ in the source tree and in the
desktop bundle). Qt turns each into an HTML page (QTextDocument's Markdown reader) written
into the user's cache folder with a <base> that points back at docs/, so its screenshots
show, and the browser opens it.
"""
from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QStandardPaths, Qt, QUrl
from PySide6.QtGui import QAction, QDesktopServices, QKeySequence, QTextDocument
from PySide6.QtWidgets import QMenu, QMessageBox, QWidget

from app.html import esc
from app.messages import show_error, show_info
from core.errors import RoboCalError
from core.files import atomic_write_text
from core.resources import RESOURCES_DIR

#: (menu text, file in docs/)
GUIDES = (("&User guide", "user-guide.md"), ("&Teaching guide", "teaching-guide.md"),
          ("&File formats", "file-formats.md"), ("Robot serial &protocol", "robot-protocol.md"))


def docs_dir() -> Path:
    """docs/ beside resources/ (the source tree, the desktop bundle)."""
    return RESOURCES_DIR.parent / "docs"


def guide_html(markdown_file: Path) -> str:
    """The guide as a stand-alone HTML page whose relative links and images resolve in docs/."""
    try:
        text = markdown_file.read_text(encoding="utf-8")
    except OSError as exc:
        raise RoboCalError(f"cannot read the guide ({exc.strerror or exc})", source=markdown_file,
                           hint="Reinstall RoboCal: the guides come with it.") from None
    doc = QTextDocument()
    doc.setMarkdown(text)
    html = doc.toHtml()
    base = f'<base href="{QUrl.fromLocalFile(str(markdown_file.parent) + "/").toString()}">'
    return html.replace("<head>", "<head>" + base, 1) if "<head>" in html else base + html


def open_guide(parent: QWidget | None, name: str) -> Path | None:
    """Write docs/`name` as HTML into the cache folder and open it in the browser; the page
    written, or None (with a message) when the guide cannot be shown."""
    source = docs_dir() / name
    cache = Path(QStandardPaths.writableLocation(QStandardPaths.StandardLocation.CacheLocation)) / "guides"
    try:
        page = atomic_write_text(cache / (Path(name).stem + ".html"), guide_html(source))
    except RoboCalError as exc:
        show_error(parent, exc.message)
        return None
    if not QDesktopServices.openUrl(QUrl.fromLocalFile(str(page))):
        show_info(parent, f"No web browser could be started. The guide is here: {page}")
    return page


def shortcuts_html(actions: list[QAction]) -> str:
    """A table of the actions that have keyboard shortcuts, as the menus name them."""
    rows = []
    for a in actions:
        keys = [k.toString(QKeySequence.SequenceFormat.NativeText) for k in a.shortcuts()]
        if keys:
            rows.append(f"<tr><td>{esc(a.text().replace('&', ''))}</td><td><b>{esc(' or '.join(keys))}</b>"
                        "</td></tr>")
    return "<table cellpadding='4'>" + "".join(rows) + "</table>"


def add_help_menu(parent: QWidget, menu: QMenu, about: QAction, shortcut_actions: list[QAction]) -> None:
    """Fill the Help menu: the guides, the keyboard shortcuts, About."""
    for text, name in GUIDES:
        action = menu.addAction(text)
        action.setObjectName("guide_" + Path(name).stem.replace("-", "_"))
        action.triggered.connect(lambda _=False, n=name: open_guide(parent, n))
    menu.addSeparator()
    keys = menu.addAction("&Keyboard shortcuts")
    keys.setObjectName("keyboardShortcuts")
    keys.triggered.connect(lambda: _show_shortcuts(parent, shortcut_actions))
    menu.addSeparator()
    menu.addAction(about)


def _show_shortcuts(parent: QWidget, actions: list[QAction]) -> None:
    box = QMessageBox(QMessageBox.Icon.NoIcon, "Keyboard shortcuts", shortcuts_html(actions),
                      QMessageBox.StandardButton.Close, parent)
    box.setObjectName("shortcutsDialog")
    box.setTextFormat(Qt.TextFormat.RichText)
    box.open()
