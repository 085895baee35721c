"""The Marker page's Compare markers tab: five candidate patterns with the same outer square,
each trained and detected in the same random views of the virtual lab (the chapter's Fig. 11)."""
from __future__ import annotations

from PySide6.QtCore import QSize, Qt, Signal
from PySide6.QtGui import QIcon, QPixmap
from PySide6.QtWidgets import (QAbstractItemView, QHeaderView, QLabel, QTableWidget, QTableWidgetItem, QVBoxLayout,
                               QWidget)

from app.html import number
from app.jobs.marker import Comparison
from app.pages.forms import button, row, spin
from app.pages.marker.model import ComparisonOptions
from widgets.thumbnail_strip import to_qimage

HEADERS = ["Pattern", "Features", "Matches", "Inliers", "Detected", "Wrong", "Median error"]
NOTE = ("Five candidate patterns with the same outer square (the chapter's Fig. 11): each is trained from "
        "its own training image and detected in the same random views. <b>Features</b>: SIFT keypoints on "
        "the training image; <b>matches</b> and <b>inliers</b>: mean per view after the ratio test and "
        "agreeing with the homography; <b>detected</b>: reference point within 1 px of the truth; "
        "<b>wrong</b>: a point given more than 1 px off.")


class ComparePanel(QWidget):
    """The Compare markers tab; the page connects `compare_button` and calls `draw(comparison)`.
    `options()` the views chosen (`optionsChanged()` on a change), `show_options(o)` binds back."""

    optionsChanged = Signal()

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.compare_spin = spin(ComparisonOptions().views, 5, 400, name="compareSpin",
                                 tooltip="Random views (400–900 mm, tilted up to 60°) each candidate is detected in")
        self.compare_spin.valueChanged.connect(lambda *_: self.optionsChanged.emit())
        self.compare_button = button("Compare markers", "compareButton")
        self.compare_table = QTableWidget(0, len(HEADERS))
        self.compare_table.setObjectName("compareTable")
        self.compare_table.setHorizontalHeaderLabels(HEADERS)
        self.compare_table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.compare_table.verticalHeader().setVisible(False)
        self.compare_table.verticalHeader().setDefaultSectionSize(70)
        self.compare_table.setIconSize(QSize(64, 64))
        self.compare_table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        self.compare_table.horizontalHeader().setSectionResizeMode(0, QHeaderView.ResizeMode.Stretch)
        self.compare_note = QLabel(NOTE)
        self.compare_note.setObjectName("hint")
        self.compare_note.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addLayout(row("Views per pattern:", self.compare_spin, self.compare_button))
        layout.addWidget(self.compare_table, 1)
        layout.addWidget(self.compare_note)

    def options(self) -> ComparisonOptions:
        return ComparisonOptions(self.compare_spin.value())

    def show_options(self, options: ComparisonOptions) -> None:
        self.compare_spin.setValue(options.views)

    def draw(self, comparison: Comparison | None) -> None:
        """One row per pattern, the recommended one in bold (None: an empty table)."""
        t = self.compare_table
        if comparison is None:
            t.setRowCount(0)
            return
        r, images = comparison.result, comparison.images
        t.setRowCount(len(r.patterns))
        for i, p in enumerate(r.patterns):
            cells = [p.name + ("  ★ recommended" if p.key == r.recommended else ""), str(p.training_features),
                     f"{p.mean_matches:.1f}", f"{p.mean_inliers:.1f}", f"{100 * p.detection_rate:.0f} %",
                     str(p.wrong), number(p.median_error, 3, "px")]
            tip = p.note + (f"\nNot trained: {p.training_reason}" if p.training_reason else "")
            if p.reasons:
                tip += "\nRejected: " + "; ".join(f"{n}× {k}" for k, n in p.reasons.items())
            for j, text in enumerate(cells):
                item = QTableWidgetItem(text)
                item.setToolTip(tip)
                if j:
                    item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                if j == 0 and p.key in images:
                    item.setIcon(QIcon(QPixmap.fromImage(to_qimage(images[p.key]))))
                if p.key == r.recommended:
                    f = item.font()
                    f.setBold(True)
                    item.setFont(f)
                t.setItem(i, j, item)
