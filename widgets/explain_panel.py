"""A read-only panel that explains the current screen: equations and what to look for.

It shows an HTML file (or Markdown, rendered by QTextBrowser) and follows links to other
local help files; web links open in the browser."""
from __future__ import annotations

import html
from pathlib import Path

from PySide6.QtCore import QSize, QUrl
from PySide6.QtGui import QTextCursor, QTextDocument, QTextFormat
from PySide6.QtWidgets import QTextBrowser, QVBoxLayout, QWidget

#: the default look of help pages (QTextBrowser understands this subset of CSS)
STYLE = """
body { font-size: 10pt; color: #202124; }
h1 { font-size: 14pt; font-weight: 600; margin-bottom: 4px; }
h2 { font-size: 11pt; font-weight: 600; color: #1a73e8; margin-top: 14px; margin-bottom: 4px; }
p { margin-top: 4px; margin-bottom: 4px; }
li { margin-bottom: 3px; }
.eq { font-family: 'DejaVu Serif', 'Cambria Math', 'STIX Two Math', serif; font-size: 10.5pt;
      background-color: #f1f3f4; margin-top: 4px; margin-bottom: 4px; }
.num { color: #5f6368; }
.note { color: #5f6368; }
"""


class ExplainPanel(QWidget):
    """`show_file(path)` / `show_html(text)` / `show_markdown(text)`; `plain_text()` for tests."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.browser = QTextBrowser(self)
        self.browser.setObjectName("explainBrowser")
        self.browser.setOpenExternalLinks(True)
        self.browser.setOpenLinks(True)
        self.browser.document().setDefaultStyleSheet(STYLE)
        self.browser.document().setDocumentMargin(12)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.browser)
        self.current_file: Path | None = None

    #: the width the panel asks for (a dock starts at its content's size hint)
    preferred_width = 460

    def sizeHint(self) -> QSize:
        return QSize(self.preferred_width, 600)

    def show_file(self, path: str | Path, missing_title: str = "") -> bool:
        """Show an .html or .md file; returns False (and says so on screen) if it is missing."""
        path = Path(path)
        self.current_file = path
        try:
            content = path.read_text(encoding="utf-8")
        except OSError:
            title = html.escape(missing_title or path.stem)
            self.show_html(f"<h1>{title}</h1><p class='note'>No explanation has been written for "
                           f"this step yet ({html.escape(path.name)}).</p>")
            return False
        self.browser.document().setBaseUrl(QUrl.fromLocalFile(str(path.parent) + "/"))
        self.browser.setSearchPaths([str(path.parent)])
        if path.suffix.lower() == ".md":
            self.show_markdown(content)
        else:
            self.show_html(content)
        return True

    def show_html(self, text: str) -> None:
        self.browser.setHtml(text)
        honour_css_font_sizes(self.browser.document())

    def show_markdown(self, text: str) -> None:
        self.browser.setMarkdown(text)
        honour_css_font_sizes(self.browser.document())

    def plain_text(self) -> str:
        return self.browser.toPlainText()


def honour_css_font_sizes(document: QTextDocument) -> None:
    """Qt adds its own size step to <h1>..<h6> on top of a CSS font-size, which makes
    headings huge once the widget has a style sheet font: keep the CSS size alone."""
    adjust = QTextFormat.Property.FontSizeAdjustment
    size = QTextFormat.Property.FontPointSize
    block = document.begin()
    while block.isValid():
        if block.blockFormat().headingLevel() > 0:
            it = block.begin()
            while not it.atEnd():
                fragment = it.fragment()
                fmt = fragment.charFormat()
                if fmt.hasProperty(adjust) and fmt.hasProperty(size):
                    fmt.clearProperty(adjust)
                    cursor = QTextCursor(document)
                    cursor.setPosition(fragment.position())
                    cursor.setPosition(fragment.position() + fragment.length(), QTextCursor.MoveMode.KeepAnchor)
                    cursor.setCharFormat(fmt)
                it += 1
        block = block.next()
