"""The Check page's results: the verdict, the diagnosis in plain words, "Re-identify", and the
control charts read from the check log (overall RMS error, then one per check pose), drawn from
the model's events (`follow(model)`)."""
from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QGridLayout, QLabel, QScrollArea, QVBoxLayout, QWidget

from app.html import esc
from app.pages import forms
from app.pages.check.model import CheckModel, CheckOutcome
from app.pages.check.texts import short_verdict
from core.monitoring.log import CheckLog
from widgets.control_chart import ControlChart

COLUMNS = 3              # check pose charts side by side, at most
CHART_MIN_WIDTH = 210    # px, a check pose's chart with its title whole: fewer columns when narrower
CHART_HEIGHT = 170       # px, one check pose's chart


class CheckResults(QWidget):
    def __init__(self, parent=None):
        super().__init__(parent)
        self.verdict_label = QLabel("No check yet.")
        self.verdict_label.setObjectName("checkVerdict")
        self.verdict_label.setWordWrap(True)
        self.diagnosis_label = QLabel()
        self.diagnosis_label.setObjectName("checkDiagnosis")
        self.diagnosis_label.setWordWrap(True)
        self.diagnosis_label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.reidentify_button = forms.button(
            "Re-identify", "reidentifyButton",
            tooltip="Measure the few poses RoboCal proposes, re-estimate only what changed (the calibration "
                    "is the prior) and write a new calibrated.json")
        self.reidentify_button.setEnabled(False)

        self.overall_chart = ControlChart("Overall: RMS error of each check")
        self.overall_chart.setObjectName("overallChart")
        self.overall_chart.setMinimumHeight(190)
        self.pose_charts: dict[int, ControlChart] = {}
        self._columns = COLUMNS
        self._grid_host = QWidget()
        self._grid = QGridLayout(self._grid_host)
        self._grid.setContentsMargins(0, 0, 0, 0)
        scroll = QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setWidget(self._grid_host)
        scroll.setFrameShape(QScrollArea.Shape.NoFrame)

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.verdict_label)
        layout.addLayout(forms.row(self.diagnosis_label, self.reidentify_button, stretch=False))
        layout.addWidget(self.overall_chart, 2)
        layout.addWidget(scroll, 3)

    def show_log(self, log: CheckLog | None) -> None:
        """Draw the charts of every check in `log` (x: the check's number in the log)."""
        checks = [c for c in (log.checks if log is not None else []) if c.points]
        done = [(k + 1, c) for k, c in enumerate(checks) if c.finished]
        self.overall_chart.set_series([k for k, _ in done], [c.rms_mm for _, c in done],
                                      [c.rms_limit_mm for _, c in done])
        series: dict[int, tuple[list, list, list]] = {}
        for k, c in enumerate(checks, start=1):
            for p in c.points:
                x, y, lim = series.setdefault(p.pose, ([], [], []))
                x.append(k)
                y.append(p.error_mm)
                lim.append(p.limit_mm)
        self._set_pose_charts(sorted(series))
        for pose, (x, y, lim) in series.items():
            self.pose_charts[pose].set_series(x, y, lim)

    def _set_pose_charts(self, poses: list[int]) -> None:
        if list(self.pose_charts) == poses:
            return
        for chart in self.pose_charts.values():
            self._grid.removeWidget(chart)
            chart.deleteLater()
        self.pose_charts = {}
        for pose in poses:
            chart = ControlChart(f"Pose {pose}: error (mm)", with_legend=False, y_label="")
            chart.setFixedHeight(CHART_HEIGHT)
            self.pose_charts[pose] = chart
        self._place_charts()

    def _place_charts(self) -> None:
        for i, chart in enumerate(self.pose_charts.values()):
            self._grid.addWidget(chart, i // self._columns, i % self._columns)
        rows = -(-len(self.pose_charts) // self._columns)
        self._grid_host.setMinimumHeight(rows * (CHART_HEIGHT + self._grid.spacing()))   # the scroll area scrolls

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        columns = max(1, min(COLUMNS, self.width() // CHART_MIN_WIDTH))
        if columns != self._columns:
            self._columns = columns
            for chart in self.pose_charts.values():
                self._grid.removeWidget(chart)
            self._place_charts()

    def show_verdict(self, text: str, within: bool | None, details: str = "") -> None:
        colour = {True: "#188038", False: "#d93025", None: "#202124"}[within]
        self.verdict_label.setText(f"<b style='color:{colour}'>{esc(text)}</b>")
        self.verdict_label.setToolTip(details)

    def show_diagnosis(self, text: str, can_reidentify: bool) -> None:
        self.diagnosis_label.setText(text)
        self.reidentify_button.setEnabled(can_reidentify)

    def show_check(self, outcome: CheckOutcome) -> None:
        """The last check's verdict and its diagnosis (Re-identify offered when it can estimate the change)."""
        result, diagnosis = outcome.check, outcome.diagnosis
        self.show_verdict(short_verdict(result), result.within, result.verdict())
        if diagnosis is None:
            self.show_diagnosis("The marker is where the calibrated model puts it." if result.within else "", False)
        else:
            self.show_diagnosis(diagnosis.text, outcome.can_reidentify)

    def follow(self, model: CheckModel) -> None:
        """Draw each check, the log's charts, and nothing checked after the calibration changed."""
        model.on("check", self.show_check)
        model.on("log", self.show_log)
        model.on("cleared", lambda _: (self.show_verdict("No check yet.", None), self.show_diagnosis("", False)))
