"""Step 2, Stereo calibration: checkerboard pairs → a trusted stereo model and stereo.yaml.

Pairs come from two folders (left, right; matched by sorted file name), from the virtual
lab (N pairs at well-spread board poses, rendered and saved as PNGs into the project's
checkerboard/left|right), or from the cameras (the two opened on the Setup page: the pair the
live preview shows, allowed while it sees the board in both, live_preview.py, saved into
checkerboard/left|right, live_capture.py; without them in the virtual lab, one pair from the
lab's cameras at a random board pose). Detection runs
on the worker thread in small batches (app/jobs/stereo.py), so thumbnails and the ROS-style
coverage bars fill while pairs are added. Calibration (core.stereo.calibration.calibrate_stereo)
runs on the worker thread too; the page then draws what it returns (results_panel.py).

The step is complete once a calibration is saved as the project's stereo.yaml (or the
project already has a readable one). The result also goes to ``state.stereo``. Import… makes
a calibration from another tool (core.stereo.importers) the project's stereo.yaml; its
reprojection errors and board are unknown.
"""
from __future__ import annotations

from functools import partial
from itertools import count
from pathlib import Path
from typing import Callable

from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import QVBoxLayout, QWidget

from app.jobs.stereo import AddedPair
from app.html import number
from app.lab import DEFAULT_BOARD
from app.pages.base import WizardPage
from app.pages.forms import button, row, scrolling
from app.pages.steps import Step
from app.pages.stereo.live_preview import LivePreviewPanel
from app.pages.stereo.options_panel import OptionsPanel
from app.pages.stereo.pairs_panel import VIRTUAL_PAIRS, PairsActions, PairsPanel
from app.pages.stereo.job_queue import Job, JobQueueMixin
from app.pages.stereo.file_actions import StereoFileActions
from app.pages.stereo.results_panel import ResultsActions, ResultsPanel
from app.pages.stereo.texts import (CAMERA_TOOLTIP_HARDWARE, CAMERA_TOOLTIP_LIVE, CAMERA_TOOLTIP_NO_BOARD,
                                    CAMERA_TOOLTIP_VIRTUAL, VIRTUAL_TOOLTIP)
from app.task_handle import CurrentTask
from core.errors import RoboCalError
from core.project import Output
from core.stereo.board import Board
from core.stereo.calibration import StereoCalibrationResult, calibrate_stereo
from core.stereo.screening import screen_pairs
from core.stereo.coverage import MIN_PAIRS_TO_CALIBRATE
from core.stereo.file import read_stereo_yaml
from core.stereo.importers import FORMATS

RESULTS_MIN_HEIGHT = 330     # px: a results plot keeps ~170 px beside its notes; a small screen scrolls the page instead
TOP_MIN_HEIGHT = 260         # px: the pairs and camera model box, scrolling when its rows need more


class StereoPage(JobQueueMixin, PairsActions, ResultsActions, StereoFileActions, WizardPage):
    step = Step.STEREO

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.items: list[AddedPair] = []
        self.detections = None                     # DetectionResult of self.items (screened)
        self.result: StereoCalibrationResult | None = None
        self.result_stale = False                  # pairs changed since the calibration
        self.saved_path: Path | None = None        # stereo.yaml of this session or found in the project
        self.ignored_files: list[str] = []
        self._keys = count()
        self._queue: list[Job] = []                # jobs still to run, one after the other
        self._queue_total = 0
        self._queue_done = 0
        self._queue_then: Callable[[], None] | None = None
        self._preview_task = CurrentTask(tasks)    # the latest rectified preview asked for
        self._after_adding_note = ""
        self._calibration_note = ""                # said once after the next calibration (a swap)
        self._board = self._default_board()
        self._build()
        state.projectChanged.connect(self._context_changed)
        state.hardware.camerasChanged.connect(lambda *_: self.on_busy_changed())
        self._context_changed()

    def _build(self) -> None:
        self.pairs = PairsPanel()
        self.pairs.set_board(self._board)
        self.live = LivePreviewPanel(self.state, lambda: self._board)
        self.live.readyChanged.connect(lambda *_: self.on_busy_changed())
        self.model = OptionsPanel(self.task.progress_row())
        self.results = ResultsPanel()
        self._connect_panels()
        self.save_button = button("Save stereo.yaml", "saveButton", on_click=self.save_stereo,
                                  tooltip="Accept this calibration: write stereo.yaml into the project folder "
                                          "(atomically: a failure leaves the previous file as it was)")
        self.import_button = button("Import…", "importButton", on_click=lambda: self.import_stereo(),
                                    tooltip="Use a stereo calibration made by another tool as the project's "
                                            f"stereo.yaml ({FORMATS}; several files: select them together)")
        self.ros_button = button("ROS camera_info…", on_click=self.export_ros,
                                 tooltip="Write left.yaml and right.yaml (ROS camera_info) into a folder")
        self.swap_button = button("Swap left and right", "swapButton", on_click=lambda: self.swap_cameras(),
                                  tooltip="The right camera came out on the left: give each pair's images to the "
                                          "other camera and calibrate again")
        self.json_button = button("JSON…", on_click=self.export_json, tooltip="Write the calibration, its "
                                  "parameter table and per-pair errors as JSON")
        self.status.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        top = QWidget()
        tl = QVBoxLayout(top)
        tl.setContentsMargins(0, 0, 0, 0)
        tl.setSpacing(6)
        tl.addWidget(self.live)
        tl.addWidget(self.pairs)
        tl.addWidget(self.model)
        self.results.setMinimumHeight(RESULTS_MIN_HEIGHT)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        # the pairs and the camera model above the results; on a small screen their box scrolls
        # (its rows wrap: a splitter or a box layout would keep its older, shorter height)
        layout.addWidget(scrolling(top, min_height=TOP_MIN_HEIGHT))
        layout.addWidget(self.results, 1)
        layout.addWidget(self.status)
        exports = row(self.swap_button, self.import_button, self.save_button, "Export:", self.ros_button, self.json_button,
                      stretch=False)
        exports.insertStretch(0, 1)
        layout.addLayout(exports)

    def _connect_panels(self) -> None:
        p, r = self.pairs, self.results
        p.folders_button.clicked.connect(lambda: self.add_folders_dialog())
        p.virtual_button.clicked.connect(lambda: self.add_virtual_pairs(p.virtual_count.value()))
        p.capture_button.clicked.connect(lambda: self.capture_pair())
        p.remove_button.clicked.connect(lambda: self.remove_pairs(p.strip.selected_keys()))
        p.clear_button.clicked.connect(lambda: self.clear_pairs())
        p.strip.currentKeyChanged.connect(self._thumbnail_picked)
        p.strip.itemSelectionChanged.connect(self.on_busy_changed)
        self._board_timer = QTimer(self)
        self._board_timer.setSingleShot(True)
        self._board_timer.setInterval(600)
        self._board_timer.timeout.connect(self.apply_board)
        for w in (p.cols_spin, p.rows_spin, p.square_spin):
            w.valueChanged.connect(lambda *_: self._board_timer.start())
        self.model.calibrate_button.clicked.connect(lambda: self.calibrate())
        r.errors_chart.selectionChanged.connect(self._threshold_selection)
        r.drop_button.clicked.connect(lambda: self.drop_selected())
        r.flagged_button.clicked.connect(self.select_flagged)
        r.restore_button.clicked.connect(self.restore_excluded)
        r.preview_combo.currentIndexChanged.connect(self._preview_changed)

    # -- state ------------------------------------------------------------------------------
    @property
    def board(self) -> Board:
        return self._board

    def usable_pairs(self) -> list[AddedPair]:
        return [a for a in self.items if a.detection.accepted and not a.excluded]

    def _default_board(self) -> Board:
        if self.state.virtual:
            return self.state.labs.current.board if self.state.labs.built else DEFAULT_BOARD
        return Board(9, 6, 24.0)

    def _context_changed(self, *_) -> None:
        """Another project: pairs and result no longer apply."""
        self._stop_jobs()
        self.items.clear()
        self.pairs.strip.clear_all()
        self.detections = None
        self.result = None
        self.result_stale = False
        self.saved_path = None
        self.ignored_files = []
        self._board = self._default_board()
        self.pairs.set_board(self._board)
        message, ok = self._read_saved()
        self._refresh_pairs()
        self._show_result()
        self._set_status(message, ok=ok)
        self.notify_complete()
        project = self.state.project
        saved = project.folder / "checkerboard" if project is not None else None
        if saved is not None and any((saved / "left").glob("*.png")) and any((saved / "right").glob("*.png")):
            # pairs rendered or captured into this project earlier: back on the page
            self.add_folders(saved / "left", saved / "right",
                             then=lambda: self._set_status(message + " The project's saved pairs are back.", ok=ok))

    def _read_saved(self) -> tuple[str, bool]:
        """The project's stereo.yaml, if any: the step is done and its board is the page's."""
        project = self.state.project
        if project is None:
            return "No project yet: create or open one in the Setup step (1).", False
        if not project.has(Output.STEREO):
            return "", False
        path = project.path(Output.STEREO)
        try:
            sf = read_stereo_yaml(path)
        except RoboCalError as exc:
            return f"The project's stereo.yaml cannot be used ({exc.message}). Calibrate again.", False
        self.saved_path = path
        if sf.board is not None:                 # the board those pairs show (unknown when imported)
            self._board = sf.board
            self.pairs.set_board(self._board)
        return (f"This project already has {path.name} (stereo RMS {number(sf.rms_stereo, 3, 'px')}, baseline "
                f"{sf.baseline_mm:.1f} mm, {sf.image_size[0]}x{sf.image_size[1]}): the step is done. "
                "Add pairs and calibrate to replace it."), True

    # -- WizardPage ---------------------------------------------------------------------------
    def on_enter(self) -> None:
        self.on_busy_changed()

    def on_leave(self) -> None:
        if self._board_timer.isActive():
            self.apply_board()

    def is_complete(self) -> bool:
        return self.saved_path is not None and self.saved_path.is_file()

    def autopilot(self, done) -> None:
        if self.state.project is None:
            done(False, "no project (Setup step)")
            return
        if self.task.busy:
            done(False, "the page is busy")
            return
        self._autopilot_done = done
        if self.result is not None and not self.result_stale:
            self._autopilot_save()
            return
        if len(self.usable_pairs()) >= MIN_PAIRS_TO_CALIBRATE and (
                self.detections is not None and self.detections.coverage.enough):
            if not self.calibrate():
                self._finish_autopilot(False, self.status.text() or "calibration could not start")
            return
        if not self.state.virtual:
            self._finish_autopilot(False, "no checkerboard pairs: add pairs from folders first")
            return
        lab_board = self._default_board()
        if lab_board != self._board:          # the lab's board: pairs of another board cannot join
            self.clear_pairs()
            self.set_board(lab_board)
        if not self.add_virtual_pairs(VIRTUAL_PAIRS, then=self._autopilot_calibrate):
            self._finish_autopilot(False, self.status.text() or "could not render the virtual-lab pairs")

    def _autopilot_calibrate(self) -> None:
        if self._autopilot_done is None:
            return
        if len(self.usable_pairs()) < MIN_PAIRS_TO_CALIBRATE or not self.calibrate():
            self._finish_autopilot(False, self.status.text() or "too few usable pairs")

    def _autopilot_save(self) -> None:
        if self._autopilot_done is None:
            return
        path = self.save_stereo()
        if path is None:
            self._finish_autopilot(False, self.status.text() or "stereo.yaml could not be written")
        else:
            r = self.result
            self._finish_autopilot(True, f"{r.pairs_used} pairs, stereo RMS {r.file.rms_stereo:.3f} px, "
                                         f"baseline {r.baseline_mm:.1f} mm")

    def on_busy_changed(self) -> None:
        busy, has_project, virtual = self.task.busy, self.state.project is not None, self.state.virtual
        p, r = self.pairs, self.results
        self.task.progress_row().bar.setVisible(busy)
        for w in (p.folders_button, p.cols_spin, p.rows_spin, p.square_spin):
            w.setEnabled(not busy and has_project)
        live = self.state.hardware.cameras is not None
        for w in (p.virtual_button, p.virtual_count):
            w.setEnabled(not busy and has_project and virtual)
        ready = live and self.live.ready_pair() is not None
        p.capture_button.setEnabled(not busy and has_project and (ready if live else virtual))
        p.virtual_button.setToolTip(VIRTUAL_TOOLTIP if virtual else "Only in a virtual-lab project")
        p.capture_button.setToolTip((CAMERA_TOOLTIP_LIVE if ready else CAMERA_TOOLTIP_NO_BOARD) if live
                                    else CAMERA_TOOLTIP_VIRTUAL if virtual else CAMERA_TOOLTIP_HARDWARE)
        p.remove_button.setEnabled(not busy and bool(p.strip.selectedItems()))
        p.clear_button.setEnabled(not busy and bool(self.items))
        self._calibrate_button_state(busy)
        has_result = self.result is not None
        self.model.set_enabled(not busy)
        self.save_button.setEnabled(not busy and has_result and has_project)
        self.import_button.setEnabled(not busy and has_project)
        self.ros_button.setEnabled(not busy and has_result)
        self.json_button.setEnabled(not busy and has_result)
        self.swap_button.setVisible(has_result and not self.result_stale and self.result.cameras_look_swapped)
        self.swap_button.setEnabled(not busy)
        r.drop_button.setEnabled(not busy and has_result and bool(r.errors_chart.selected()))
        r.flagged_button.setEnabled(not busy and has_result and bool(self.result.outliers if has_result else []))
        r.restore_button.setEnabled(not busy and any(a.excluded for a in self.items))

    def _calibrate_button_state(self, busy: bool) -> None:
        b = self.model.calibrate_button
        usable = len(self.usable_pairs())
        b.setEnabled(not busy and usable >= MIN_PAIRS_TO_CALIBRATE)
        enough = self.detections is not None and self._coverage().enough
        b.setText("Calibrate" if enough or usable < MIN_PAIRS_TO_CALIBRATE else "Calibrate (low coverage)")
        b.setToolTip(f"Needs at least {MIN_PAIRS_TO_CALIBRATE} accepted pairs" if usable < MIN_PAIRS_TO_CALIBRATE
                     else ("Enough views: calibrate" if enough else
                           "Possible, but coverage is not enough yet: the result may be poorly determined"))

    # -- calibration -----------------------------------------------------------------------------
    def calibrate(self) -> bool:
        if self._board_timer.isActive():
            self.apply_board()             # a board edit not applied yet
        if self.task.busy:
            self._set_status("Busy: wait for the running task or cancel it.", ok=False)
            return False
        usable = self.usable_pairs()
        if len(usable) < MIN_PAIRS_TO_CALIBRATE or self.detections is None:
            self._set_status(f"Calibration needs at least {MIN_PAIRS_TO_CALIBRATE} accepted pairs "
                             f"({len(usable)} now).", ok=False)
            return False
        self.detections = screen_pairs([a.detection for a in self.items], self._board)
        exclude = [a.detection.index for a in self.items if a.excluded]
        options = self.model.options()
        self._set_status(f"Calibrating from {len(self.usable_pairs())} pairs ({options.describe()})…")
        self._run_queue([(partial(calibrate_stereo, self.detections, options, exclude=exclude), "Calibrating",
                          self._calibrated)])
        return True

    def _calibrated(self, result: StereoCalibrationResult) -> None:
        self.result = result
        self.result_stale = False
        self._show_result()
        self._refresh_pairs()
        cv = result.cross_validation
        text = (f"Calibrated: {result.pairs_used} pairs, stereo RMS {result.file.rms_stereo:.3f} px, epipolar "
                f"{result.epipolar_rms:.3f} px" + (f", cross-validation {cv.rms_observed_px:.3f} px" if cv else "")
                + f", baseline {result.baseline_mm:.2f} mm"
                + (f" ({len(result.warnings)} warning{'s' if len(result.warnings) > 1 else ''}: see Summary)"
                   if result.warnings else "")
                + ". Drop outliers if needed, then Save stereo.yaml.")
        if result.cameras_look_swapped:
            text = (text.removesuffix(" Drop outliers if needed, then Save stereo.yaml.")
                    + " The right camera came out on the left of the left one: the images are likely given to the "
                      "wrong cameras. Press Swap left and right to calibrate them the other way round.")
        self._set_status(text + self._calibration_note, ok=not result.cameras_look_swapped)
        self._calibration_note = ""
        if self._autopilot_done is not None:
            QTimer.singleShot(0, self._autopilot_save)
