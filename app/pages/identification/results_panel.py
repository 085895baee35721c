"""What an identification returned, in tabs: the parameters (nominal → identified ± σ, the ones
not estimated greyed and explained), the errors per pose before and after, the cost per
iteration, the correlation matrix, and the validation and accuracy report; a summary above."""
from __future__ import annotations

import math

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLabel, QTabWidget, QTextBrowser, QVBoxLayout, QWidget

from app.html import esc
from app.jobs.identification import IdentificationRun
from app.pages.identification.texts import summary_text, validation_html
from widgets.convergence_plot import ConvergencePlot
from widgets.correlation_view import CorrelationView
from widgets.parameter_table import ParameterTable
from widgets.residual_plots import ResidualPlots

EMPTY = ("Run the identification to see the parameters, the errors before and after "
         "calibration, and how well the model predicts poses it did not see.")


def _selectable_label(name: str = "") -> QLabel:
    label = QLabel()
    if name:
        label.setObjectName(name)
    label.setWordWrap(True)
    label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
    return label


class ResultsPanel(QWidget):
    """`show_run(run)` draws an IdentificationRun (None: empty, with what to do)."""

    def __init__(self, parent: QWidget | None = None):
        super().__init__(parent)
        self.run: IdentificationRun | None = None
        self.summary = _selectable_label("summaryLabel")
        self.table = ParameterTable()
        self.table.itemSelectionChanged.connect(self.show_explanation)
        self.explanation = _selectable_label("hint")
        self.explanation.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        table_tab = QWidget()
        tv = QVBoxLayout(table_tab)
        tv.setContentsMargins(0, 0, 0, 0)
        tv.setSpacing(4)
        tv.addWidget(self.table, 1)
        tv.addWidget(self.explanation)
        self.residuals = ResidualPlots()
        self.convergence = ConvergencePlot()
        self.correlation = CorrelationView()
        self.validation_view = QTextBrowser()
        self.validation_view.setObjectName("validationView")
        self.validation_view.setOpenLinks(False)
        self.tabs = QTabWidget()
        self.tabs.addTab(table_tab, "Parameters")
        self.tabs.addTab(self.residuals, "Errors per pose")
        self.tabs.addTab(self.convergence, "Convergence")
        self.tabs.addTab(self.correlation, "Correlation")
        self.tabs.addTab(self.validation_view, "Validation && accuracy")
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addWidget(self.summary)
        layout.addWidget(self.tabs, 1)

    def show_run(self, run: IdentificationRun | None) -> None:
        self.run = run
        if run is None:
            self.summary.setText(EMPTY)
            self.table.set_rows([])
            self.explanation.setText("")
            self.residuals.clear()
            self.convergence.clear_history()
            self.correlation.clear()
            self.validation_view.setHtml("")
            return
        r = run.result
        self.summary.setText(summary_text(run))
        self.table.set_rows(r.parameters)
        self.table.horizontalHeaderItem(2).setToolTip("Nominal value; for the base pose the registered start "
                                                      "(italic)")
        self.show_explanation()
        self._show_residuals(r)
        records = [rec for i, rec in enumerate(r.iterations) if i == 0 or not rec.start]
        self.convergence.set_history([rec.iteration for rec in records], [rec.cost for rec in records],
                                     [rec.stage for rec in records])
        self.correlation.set_matrix(r.correlation, r.estimated)
        self.validation_view.setHtml(validation_html(run))

    def _show_residuals(self, r) -> None:
        before = {p["pose"]: p["error_mm"] for p in r.before.per_pose()}
        after = {p["pose"]: p["error_mm"] for p in r.after.per_pose()}
        poses = list(before)
        caption = (f"Error of each fitted pose: RMS {r.before.rms_mm:.3f} mm before, {r.after.rms_mm:.3f} mm after "
                   "calibration (nominal model with the base registered, then calibrated).")
        if r.outliers:
            caption += f" {len(r.outliers)} outlier point(s) flagged."
        self.residuals.set_errors(poses, [before[p] for p in poses], [after.get(p, math.nan) for p in poses],
                                  r.before.errors, r.after.errors, caption)

    def show_errors_per_pose(self) -> None:
        self.tabs.setCurrentWidget(self.residuals)

    def show_explanation(self) -> None:
        """The selected parameter's explanation, else which parameters were not estimated."""
        rows = self.table.selectionModel().selectedRows() if self.table.selectionModel() else []
        if rows:
            r = rows[0].row()
            text = self.table.explanation(r)
            if not text:
                row = self.table.rows()[r]
                text = f"{row.name} is estimated: {row.identified:.4f} {row.unit} (nominal {row.nominal:.4f})."
            self.explanation.setText(text)
            return
        if self.run is None:
            self.explanation.setText("")
            return
        excluded = [row for row in self.run.result.parameters if not row.identifiable]
        if not excluded:
            self.explanation.setText("Every parameter was estimated.")
            return
        parts = []
        for row in excluded:
            partners = f" ↔ {', '.join(row.partners)}" if row.partners else ""
            parts.append(f"{esc(row.name)} ({esc(row.status)}{esc(partners)})")
        self.explanation.setText("<b>Not estimated</b> (grey, kept at nominal): " + "; ".join(parts)
                                 + ". Select a row (or hover it) for the reason.")
