"""A read-only table of estimated parameters: nominal → identified ± σ, in mm and degrees.

`set_rows(rows)` takes objects with the attributes of core.identification.result.ParameterRow
(name, group, unit, nominal, initial, identified, std, identifiable, status, explanation).
For the base pose (group "base") the reference is the registered start `initial`, not the
robot file's base (which is not expressed in the measurement frame). Parameters that
were not estimated (not identifiable, fixed by the user, fixed by Hayati's rule) are greyed
and carry their explanation as tool tip; `explanation(row)` gives it for a side panel.
"""
from __future__ import annotations

import math
from typing import Sequence

from PySide6.QtCore import Qt
from PySide6.QtGui import QBrush, QColor, QFont
from PySide6.QtWidgets import QAbstractItemView, QHeaderView, QTableWidget, QTableWidgetItem, QWidget

COLUMNS = ["Parameter", "Unit", "Nominal", "Identified", "± σ", "Correction", "Status"]
GREY = QColor("#80868b")
WARN = QColor("#b06000")
UNIT_TEXT = {"mm": "mm", "deg": "°"}
REGISTERED_TIP = ("Base pose: the reference is where the rigid registration of the nominal model onto the "
                  "measurements put the base (the robot file's base pose is not in the camera frame); "
                  "the correction is what the calibration changed after that.")


def _decimals(unit: str) -> int:
    return 3 if unit == "mm" else 4


def format_value(value: float | None, unit: str) -> str:
    if value is None or not math.isfinite(value):
        return "—"
    text = f"{value:.{_decimals(unit)}f}"
    return "0" + text[2:] if text.startswith("-0") and float(text) == 0 else text


def format_std(std: float | None) -> str:
    """Two significant digits: the uncertainty of an uncertainty is tens of percent."""
    if std is None or not math.isfinite(std):
        return "—"
    if std == 0:
        return "± 0"
    digits = max(0, 1 - int(math.floor(math.log10(abs(std)))))
    return f"± {std:.{digits}f}"


def format_correction(value: float, unit: str) -> str:
    if not math.isfinite(value):
        return "—"
    text = f"{value:+.{_decimals(unit)}f}"
    return text.replace("-0.", "+0.") if float(text) == 0 else text


class ParameterTable(QTableWidget):
    def __init__(self, parent: QWidget | None = None):
        super().__init__(0, len(COLUMNS), parent)
        self.setObjectName("parameterTable")
        self.setHorizontalHeaderLabels(COLUMNS)
        self.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.setAlternatingRowColors(True)
        self.verticalHeader().setVisible(False)
        self.verticalHeader().setDefaultSectionSize(22)
        header = self.horizontalHeader()
        for c in range(len(COLUMNS) - 1):
            header.setSectionResizeMode(c, QHeaderView.ResizeMode.ResizeToContents)
        header.setSectionResizeMode(len(COLUMNS) - 1, QHeaderView.ResizeMode.Stretch)
        header.setDefaultAlignment(Qt.AlignmentFlag.AlignCenter)
        self.setWordWrap(False)
        self._rows: list = []

    def set_rows(self, rows: Sequence) -> None:
        self._rows = list(rows)
        self.setRowCount(0)
        self.setRowCount(len(self._rows))
        italic = QFont(self.font())
        italic.setItalic(True)
        for r, row in enumerate(self._rows):
            estimated = bool(row.identifiable)
            unit = UNIT_TEXT.get(row.unit, row.unit)
            registered = getattr(row, "group", "") == "base" and getattr(row, "initial", None) is not None
            reference = row.initial if registered else row.nominal
            correction = row.identified - reference
            if row.unit == "deg":
                correction = (correction + 180.0) % 360.0 - 180.0
            cells = [row.name, unit, format_value(reference, row.unit), format_value(row.identified, row.unit),
                     format_std(row.std) if estimated else "—",
                     format_correction(correction, row.unit) if estimated else "—",
                     "identified" if estimated else str(row.status)]
            tip = self.explanation(r)
            for c, text in enumerate(cells):
                item = QTableWidgetItem(text)
                align = Qt.AlignmentFlag.AlignLeft if c in (0, 1, 6) else Qt.AlignmentFlag.AlignRight
                item.setTextAlignment(align | Qt.AlignmentFlag.AlignVCenter)
                if not estimated:
                    item.setForeground(QBrush(GREY))
                    item.setFont(italic)
                elif c == 4 and row.std is not None and abs(correction) > 0 and row.std > abs(correction):
                    item.setForeground(QBrush(WARN))      # σ larger than the correction itself
                if tip:
                    item.setToolTip(tip)
                elif registered:
                    item.setToolTip(REGISTERED_TIP)
                if registered and c == 2:
                    item.setFont(italic)
                self.setItem(r, c, item)
        self.resizeColumnsToContents()

    def rows(self) -> list:
        return list(self._rows)

    def is_greyed(self, r: int) -> bool:
        item = self.item(r, 0)
        return item is not None and item.foreground().color() == GREY

    def explanation(self, r: int) -> str:
        """Why a parameter was not estimated (empty for estimated ones)."""
        if not 0 <= r < len(self._rows):
            return ""
        row = self._rows[r]
        if row.identifiable:
            return ""
        text = str(getattr(row, "explanation", "") or "")
        return f"{row.name}: {row.status}. {text}".strip() if text else f"{row.name}: {row.status}."

    def cell_text(self, r: int, c: int) -> str:
        item = self.item(r, c)
        return item.text() if item is not None else ""
