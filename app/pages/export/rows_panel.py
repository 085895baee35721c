"""The Export step's rows: per export its title, description, target file(s), status and
Export button, in a grid."""
from __future__ import annotations

from typing import Callable

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QGridLayout, QGroupBox, QLabel, QVBoxLayout, QWidget

from app.html import esc
from app.pages import forms
from app.pages.export.items import ExportItem, REPORT
from app.pages.export.model import row_status, target_text

COLOURS = {True: "#188038", False: "#80868b", None: "#5f6368"}


class ExportRows(QGroupBox):
    """`rows[key]` holds the row's "title", "target", "status" and "button"; `on_export(key)`
    when a row's button is clicked."""

    def __init__(self, items: list[ExportItem], on_export: Callable[[str], None], parent=None):
        super().__init__("What can be exported", parent)
        grid = QGridLayout(self)
        grid.setHorizontalSpacing(12)
        grid.setVerticalSpacing(10)
        self.rows: dict[str, dict[str, QWidget]] = {}
        for r, item in enumerate(items):
            self.rows[item.key] = self._row(grid, r, item, on_export)
        grid.setColumnStretch(0, 1)

    @staticmethod
    def _row(grid: QGridLayout, r: int, item: ExportItem, on_export) -> dict[str, QWidget]:
        title = QLabel(f"<b>{esc(item.title)}</b>")
        desc = QLabel(item.description)
        desc.setTextFormat(Qt.TextFormat.PlainText)
        desc.setObjectName("hint")
        desc.setWordWrap(True)
        target = QLabel()
        target.setTextFormat(Qt.TextFormat.PlainText)
        target.setWordWrap(True)
        target.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        status = QLabel()
        status.setTextFormat(Qt.TextFormat.PlainText)
        status.setWordWrap(True)
        button = forms.button("Export", f"export_{item.key}", on_click=lambda key=item.key: on_export(key))
        text = QVBoxLayout()
        text.setSpacing(2)
        for w in (title, desc, target, status):
            text.addWidget(w)
        grid.addLayout(text, r, 0)
        grid.addWidget(button, r, 1, Qt.AlignmentFlag.AlignTop)
        return {"title": title, "target": target, "status": status, "button": button}

    def show_rows(self, items: list[ExportItem], folder, calibrated_source: str | None, exported: dict,
                  *, writing: bool) -> None:
        """Every row's target and status (the report's keeps "Writing…" while `writing`)."""
        for item in items:
            self.rows[item.key]["target"].setText(target_text(item, folder, calibrated_source))
            if not (writing and item.key == REPORT):
                self.set_status(item.key, *row_status(item, exported))

    def set_enabled(self, items: list[ExportItem], busy: bool) -> None:
        for item in items:
            self.rows[item.key]["button"].setEnabled(not busy and item.missing() is None)

    def set_status(self, key: str, text: str, ok: bool | None) -> None:
        label = self.rows[key]["status"]
        label.setText(text)
        label.setStyleSheet(f"color: {COLOURS[ok]};")

    def text(self, key: str) -> str:
        """Target and status of one row."""
        row = self.rows[key]
        return f"{row['target'].text()} {row['status'].text()}"
