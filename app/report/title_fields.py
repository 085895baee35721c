"""The report's title block fields where the report is started (the Export step): who hands it
in (student or operator), the course, and the robot's serial number. Empty fields are left out of
the title block."""
from __future__ import annotations

from PySide6.QtWidgets import QGroupBox, QHBoxLayout, QLabel, QLineEdit


class ReportTitleFields(QGroupBox):
    """Three one-line fields; `values()` gives write_report's author, course and serial."""

    FIELDS = (("author", "Student / operator", "reportAuthor", "name on the report's title"),
              ("course", "Course", "reportCourse", "course or lab"),
              ("serial", "Robot serial number", "reportSerial", "on the type plate"))

    def __init__(self, parent=None):
        super().__init__("Report title", parent)
        row = QHBoxLayout(self)              # one row: the Export step is tall already
        self.edits: dict[str, QLineEdit] = {}
        for key, label, name, hint in self.FIELDS:
            edit = QLineEdit()
            edit.setObjectName(name)
            edit.setPlaceholderText(hint)
            edit.setToolTip(hint)
            edit.setMaxLength(120)
            edit.setMinimumWidth(90)
            row.addWidget(QLabel(label))
            row.addWidget(edit, 1)
            self.edits[key] = edit

    def values(self) -> dict[str, str | None]:
        """author, course, serial: the typed text, None when empty."""
        return {key: (edit.text().strip() or None) for key, edit in self.edits.items()}
