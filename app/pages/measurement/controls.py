"""The Measurement page's top rows: where the inputs come from, Load poses, Start / Measure the rest,
Pause / Continue, the progress row with Cancel, Start over, Teach mode (`options()`: the switches)."""
from __future__ import annotations

from typing import Callable

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QCheckBox, QFileDialog, QGridLayout, QLabel, QWidget

from app.pages.forms import button
from app.pages.measurement.model import RunSwitches
from widgets.flow_layout import FlowLayout
from widgets.progress_row import ProgressRow


class RunControls(QWidget):
    """The run's buttons around the page's `progress` row. `on_load(path)` (a poses CSV the user
    chose; the dialog opens in `folder()`), `on_start()`, `on_pause(on)`, `on_start_over()` and
    `on_teach(on)` are the page's handlers."""

    def __init__(self, progress: ProgressRow, *, on_load: Callable[[str], object], folder: Callable[[], str],
                 on_start: Callable, on_pause: Callable[[bool], None], on_start_over: Callable,
                 on_teach: Callable[[bool], None], parent: QWidget | None = None):
        super().__init__(parent)
        self.progress = progress
        self._on_load, self._folder = on_load, folder
        self.source_label = QLabel()
        self.source_label.setObjectName("sourceLabel")
        self.source_label.setWordWrap(True)
        self.source_label.setTextFormat(Qt.TextFormat.RichText)
        self.load_button = button("Load poses CSV…", "loadPosesButton", on_click=self._ask_poses_csv,
                                  tooltip="Measure the poses of another file (pose,q1,...,qn; degrees, mm for "
                                          "prismatic joints) instead of the Pose sequence step's")
        self.start_button = button("Start", "startButton", on_click=on_start)
        self.pause_button = button("Pause", "pauseButton",
                                   tooltip="Wait after the current pose (the robot stays where it is)")
        self.pause_button.setCheckable(True)
        self.pause_button.toggled.connect(on_pause)
        self.pause_button.toggled.connect(lambda on: self.pause_button.setText("Continue" if on else "Pause"))
        self.over_button = button("Start over…", "startOverButton", on_click=on_start_over,
                                  tooltip="Move the measurements taken so far aside (renamed, not deleted) and "
                                          "measure every pose again")
        self.teach_check = QCheckBox("Teach mode")
        self.teach_check.setObjectName("teachModeCheck")
        self.teach_check.toggled.connect(on_teach)
        progress.cancel_button.setToolTip("Stop the run after the current pose; Measure the rest starts from there")
        progress.bar.setObjectName("runProgress")

        grid = QGridLayout(self)
        grid.setContentsMargins(0, 0, 0, 0)
        grid.setHorizontalSpacing(8)
        grid.setVerticalSpacing(4)
        grid.addWidget(self.source_label, 0, 0, 1, 4)
        grid.addWidget(self.load_button, 0, 4, 1, 2)
        run = FlowLayout()                # wraps on a narrow window
        for w in (self.start_button, self.pause_button, progress, self.over_button, self.teach_check):
            run.addWidget(w)
        grid.addLayout(run, 1, 0, 1, 6)
        grid.setColumnStretch(3, 1)

    def _ask_poses_csv(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Poses to measure", self._folder(),
                                              "Poses CSV (*.csv);;All files (*)")
        if path:
            self._on_load(path)

    def options(self) -> RunSwitches:
        return RunSwitches(teach=self.teach_check.isChecked(), paused=self.pause_button.isChecked())

    def show_options(self, switches: RunSwitches) -> None:
        """Tick Teach mode (without telling the page) and press or release Pause (the page hears it)."""
        self.teach_check.blockSignals(True)
        self.teach_check.setChecked(switches.teach)
        self.teach_check.blockSignals(False)
        self.pause_button.setChecked(switches.paused)

    def set_buttons(self, *, busy: bool, can_start: bool, resume: bool, can_start_over: bool,
                    teach: bool = False) -> None:
        """Enable what makes sense now; Start reads Measure the rest when poses are left after a run; in
        teach mode the technician moves the robot (no Start, no Pause)."""
        self.start_button.setEnabled(not busy and can_start and not teach)
        self.start_button.setText("Measure the rest" if resume else "Start")
        self.pause_button.setEnabled(busy and not teach)
        self.over_button.setEnabled(not busy and can_start_over)
        self.load_button.setEnabled(not busy)

    def show_done(self, done: int, total: int) -> None:
        """The bar after a run: `done` of `total` poses measured or rejected."""
        self.progress.bar.setValue(int(round(1000 * done / max(total, 1))))
        self.progress.bar.setFormat(f"{done} of {total} poses done")
