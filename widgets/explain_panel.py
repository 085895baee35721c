"""A read-only panel that explains the current screen: equations and what to look for.

It shows an HTML file (or Markdown, rendered by QTextBrowser) and follows links to other
local help files; web links open in the browser."""
from __future__ import annotations

import html
from pathlib import Path

from PySide6.QtCore import QUrl
from PySide6.QtWidgets import QTextBrowser, QVBoxLayout, QWidget

#: the default look of help pages (QTextBrowser understands this subset of CSS)
STYLE = """
body { font-size: 10.5pt; color: #202124; }
h1 { font-size: 15pt; font-weight: 600; margin-bottom: 4px; }
h2 { font-size: 11.5pt; font-weight: 600; color: #1a73e8; margin-top: 14px; margin-bottom: 4px; }
p { margin-top: 4px; margin-bottom: 4px; }
li { margin-bottom: 3px; }
.eq { font-family: 'DejaVu Serif', 'Cambria Math', 'STIX Two Math', serif; font-size: 11pt;
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
            self.browser.setMarkdown(content)
        else:
            self.browser.setHtml(content)
        return True

    def show_html(self, text: str) -> None:
        self.browser.setHtml(text)

    def show_markdown(self, text: str) -> None:
        self.browser.setMarkdown(text)

    def plain_text(self) -> str:
        return self.browser.toPlainText()
