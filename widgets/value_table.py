"""A read-only table of estimated values with their standard deviations, grouped
(e.g. "left", "right", "stereo"): group | parameter | value | ± σ | unit.

`set_rows(rows)` takes objects with `group`, `name`, `value`, `std`, `unit`, `fixed`
(such as core.stereo.uncertainty.CameraParameterRow). Fixed values are greyed and marked
"fixed"; names can be shown differently through `display_names`."""
from __future__ import annotations

import math
from typing import Mapping, Sequence

from PySide6.QtCore import Qt
from PySide6.QtGui import QBrush, QColor, QFont
from PySide6.QtWidgets import QAbstractItemView, QHeaderView, QTableWidget, QTableWidgetItem, QWidget

COLUMNS = ["", "Parameter", "Value", "± σ", "Unit"]
GREY = QColor("#80868b")


def format_value(value: float, std: float | None) -> str:
    """Enough digits to show the standard deviation's first two significant digits."""
    if value is None or not math.isfinite(value):
        return "—"
    if std is not None and math.isfinite(std) and std > 0:
        digits = max(0, min(9, 1 - int(math.floor(math.log10(std)))))
        return f"{value:.{digits}f}"
    return f"{value:.6g}"


def format_std(std: float | None) -> str:
    if std is None or not math.isfinite(std):
        return "—"
    if std == 0:
        return "0"
    digits = max(0, min(9, 1 - int(math.floor(math.log10(std)))))
    return f"± {std:.{digits}f}"


class ValueTable(QTableWidget):
    def __init__(self, parent: QWidget | None = None, *, group_names: Mapping[str, str] | None = None,
                 display_names: Mapping[str, str] | None = None, unit_names: Mapping[str, str] | None = None):
        super().__init__(0, len(COLUMNS), parent)
        self.setObjectName("valueTable")
        self.setHorizontalHeaderLabels(COLUMNS)
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.setAlternatingRowColors(True)
        self.verticalHeader().setVisible(False)
        self.verticalHeader().setDefaultSectionSize(21)
        header = self.horizontalHeader()
        for c in range(len(COLUMNS)):
            header.setSectionResizeMode(c, QHeaderView.ResizeMode.ResizeToContents)
        header.setStretchLastSection(False)
        self.setWordWrap(False)
        self.group_names = dict(group_names or {})
        self.display_names = dict(display_names or {})
        self.unit_names = dict(unit_names or {})
        self._rows: list = []

    def set_rows(self, rows: Sequence) -> None:
        self._rows = list(rows)
        self.setRowCount(0)
        self.setRowCount(len(self._rows))
        italic = QFont(self.font())
        italic.setItalic(True)
        bold = QFont(self.font())
        bold.setBold(True)
        previous = None
        for r, row in enumerate(self._rows):
            group = self.group_names.get(row.group, row.group) if row.group != previous else ""
            previous = row.group
            name = self.display_names.get(row.name, row.name)
            fixed = bool(getattr(row, "fixed", False))
            cells = [group, name, format_value(row.value, None if fixed else row.std),
                     "fixed" if fixed else format_std(row.std), self.unit_names.get(row.unit, row.unit)]
            for c, text in enumerate(cells):
                item = QTableWidgetItem(text)
                align = Qt.AlignmentFlag.AlignRight if c in (2, 3) else Qt.AlignmentFlag.AlignLeft
                item.setTextAlignment(align | Qt.AlignmentFlag.AlignVCenter)
                if c == 0:
                    item.setFont(bold)
                if fixed:
                    item.setForeground(QBrush(GREY))
                    item.setFont(italic)
                self.setItem(r, c, item)
        self.resizeColumnsToContents()

    def rows(self) -> list:
        return list(self._rows)

    def cell_text(self, r: int, c: int) -> str:
        item = self.item(r, c)
        return item.text() if item is not None else ""

    def find(self, group: str, name: str) -> int:
        """Row of a parameter, or -1."""
        for r, row in enumerate(self._rows):
            if row.group == group and row.name == name:
                return r
        return -1
