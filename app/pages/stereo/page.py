"""Step 2, Stereo calibration: checkerboard pairs → a trusted stereo model and stereo.yaml.

Pairs come from two folders (left, right; matched by sorted file name), from the virtual
lab (N pairs at well-spread board poses, rendered and saved as PNGs into the project's
checkerboard/left|right), or from the cameras (the two opened on the Setup page: the pair the
live preview shows, allowed while it sees the board in both, live_preview.py, saved into
checkerboard/left|right, live_capture.py; without them in the virtual lab, one pair from the
lab's cameras at a random board pose). Adding pairs is one worker job (app/jobs/stereo_pairs.py)
that detects in small batches, so thumbnails and the ROS-style coverage bars fill while pairs
are added (pair_sources.py). Calibration (core.stereo.calibration.calibrate_stereo) runs on the
worker thread too; the page then draws what it returns (results_panel.py, result_actions.py).

The page is a small controller: the step's model (model.py: the pairs, the board, the camera
model chosen and the calibration) -> a job on the page's task -> the model, whose events the
panels redraw from. Its helpers: PairSources (pairs), ResultActions (the calibration drawn, pairs
dropped), StereoFiles (stereo.yaml, import, exports).

The step is complete once a calibration is saved as the project's stereo.yaml (or the
project already has a readable one). The result also goes to ``state.stereo``. Import… makes
a calibration from another tool (core.stereo.importers) the project's stereo.yaml; its
reprojection errors and board are unknown.
"""
from __future__ import annotations

from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import QVBoxLayout, QWidget

from app.jobs.stereo import AddedPair
from app.lab import DEFAULT_BOARD
from app.pages.base import WizardPage
from app.pages.forms import button, row, scrolling
from app.pages.page_task import BUSY
from app.pages.steps import Step
from app.pages.stereo.file_actions import StereoFiles
from app.pages.stereo.live_preview import LivePreviewPanel
from app.pages.stereo.model import StereoModel
from app.pages.stereo.options_panel import OptionsPanel
from app.pages.stereo.pair_sources import PairSources
from app.pages.stereo.pairs_panel import VIRTUAL_PAIRS, PairsPanel
from app.pages.stereo.result_actions import ResultActions
from app.pages.stereo.results_panel import ResultsPanel
from core.stereo.board import Board
from core.stereo.calibration import StereoCalibrationResult, calibrate_stereo
from core.stereo.coverage import MIN_PAIRS_TO_CALIBRATE
from core.stereo.importers import FORMATS

RESULTS_MIN_HEIGHT = 330     # px: a results plot keeps ~170 px beside its notes; a small screen scrolls the page instead
TOP_MIN_HEIGHT = 260         # px: the pairs and camera model box, scrolling when its rows need more


def lab_board(state) -> Board:
    """The board a project starts with: the virtual lab's, or 9x6 inner corners of 24 mm."""
    if state.virtual:
        return state.labs.current.board if state.labs.built else DEFAULT_BOARD
    return Board(9, 6, 24.0)


class StereoPage(WizardPage):
    step = Step.STEREO

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.model = StereoModel(lab_board(state))
        self._build()
        state.projectChanged.connect(self._context_changed)
        state.hardware.camerasChanged.connect(lambda *_: self.on_busy_changed())
        self._context_changed()

    def _build(self) -> None:
        m = self.model
        self.pairs = PairsPanel()
        self.pairs.set_board(m.board)
        self.live = LivePreviewPanel(self.state, lambda: m.board)
        self.live.readyChanged.connect(lambda *_: self.on_busy_changed())
        self.options_panel = OptionsPanel(self.task.progress_row())       # the camera model row
        self.options_panel.show_options(m.options)
        self.results = ResultsPanel()
        self.sources = PairSources(self.state, m, self.pairs, self.live, self.task, set_status=self._set_status,
                                   on_failed=self.on_failed, calibrate=self.calibrate, parent=self)
        self.results_actions = ResultActions(m, self.results, self.pairs, self.task.runner,
                                             calibrate=self.calibrate, busy=lambda: self.task.busy,
                                             busy_changed=self.on_busy_changed, report=self.sources.report,
                                             set_status=self._set_status)
        self.files = StereoFiles(self.state, m, self.task, self, set_status=self._set_status,
                                 complete_changed=self.notify_complete)
        self.pairs.follow(m)
        m.on("pairs", lambda _: self.on_busy_changed())
        m.on("result", lambda _: self.on_busy_changed())
        p, src = self.pairs, self.sources
        p.folders_button.clicked.connect(lambda: src.add_folders_dialog())
        p.virtual_button.clicked.connect(lambda: src.add_virtual_pairs(p.virtual_count.value()))
        p.capture_button.clicked.connect(lambda: src.capture_pair())
        p.remove_button.clicked.connect(lambda: src.remove_pairs(p.strip.selected_keys()))
        p.clear_button.clicked.connect(lambda: src.clear_pairs())
        p.strip.itemSelectionChanged.connect(self.on_busy_changed)
        self.options_panel.calibrate_button.clicked.connect(lambda: self.calibrate())
        self.save_button = button("Save stereo.yaml", "saveButton", on_click=self.files.save_stereo,
                                  tooltip="Accept this calibration: write stereo.yaml into the project folder "
                                          "(atomically: a failure leaves the previous file as it was)")
        self.import_button = button("Import…", "importButton", on_click=lambda: self.files.import_stereo(),
                                    tooltip="Use a stereo calibration made by another tool as the project's "
                                            f"stereo.yaml ({FORMATS}; several files: select them together)")
        self.ros_button = button("ROS camera_info…", on_click=self.files.export_ros,
                                 tooltip="Write left.yaml and right.yaml (ROS camera_info) into a folder")
        self.swap_button = button("Swap left and right", "swapButton", on_click=lambda: src.swap_cameras(),
                                  tooltip="The right camera came out on the left: give each pair's images to the "
                                          "other camera and calibrate again")
        self.json_button = button("JSON…", on_click=self.files.export_json, tooltip="Write the calibration, its "
                                  "parameter table and per-pair errors as JSON")
        self.status.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        top = QWidget()
        tl = QVBoxLayout(top)
        tl.setContentsMargins(0, 0, 0, 0)
        tl.setSpacing(6)
        tl.addWidget(self.live)
        tl.addWidget(self.pairs)
        tl.addWidget(self.options_panel)
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

    # -- the model, as the wizard and scripts read it -------------------------------------------
    @property
    def board(self) -> Board:
        return self.model.board

    @property
    def items(self) -> list[AddedPair]:
        """The pairs on the page, in the order added."""
        return self.model.items

    @property
    def result(self) -> StereoCalibrationResult | None:
        """The calibration the page saves and exports."""
        return self.model.result

    @result.setter
    def result(self, result) -> None:
        """Hold `result` for Save and the exports without drawing it (the model's set_result draws)."""
        self.model.result = result

    def usable_pairs(self) -> list[AddedPair]:
        return self.model.usable()

    def apply_board(self) -> None:
        """Apply the board the spin boxes show now (see PairSources.apply_board)."""
        self.sources.apply_board()

    def save_stereo(self):
        return self.files.save_stereo()

    def export_ros(self, folder: str | None = None):
        return self.files.export_ros(folder)

    def export_json(self, path: str | None = None):
        return self.files.export_json(path)

    def _context_changed(self, *_) -> None:
        """Another project: pairs and result no longer apply."""
        self.task.forget()
        self.sources.forget()
        self.model.reset(lab_board(self.state))
        message, ok = self.files.read_saved()
        self.model.set_result(None)
        self._set_status(message, ok=ok)
        self.notify_complete()
        project = self.state.project
        saved = project.folder / "checkerboard" if project is not None else None
        if saved is not None and any((saved / "left").glob("*.png")) and any((saved / "right").glob("*.png")):
            # pairs rendered or captured into this project earlier: back on the page
            self.sources.add_folders(saved / "left", saved / "right",
                                     then=lambda: self._set_status(message + " The project's saved pairs are back.",
                                                                   ok=ok))

    # -- WizardPage ---------------------------------------------------------------------------
    def on_enter(self) -> None:
        self.on_busy_changed()

    def on_leave(self) -> None:
        if self.sources.board_timer.isActive():
            self.sources.apply_board()

    def is_complete(self) -> bool:
        saved = self.model.saved_path
        return saved is not None and saved.is_file()

    def autopilot(self, done) -> None:
        if self.state.project is None:
            done(False, "no project (Setup step)")
            return
        if self.task.busy:
            done(False, "the page is busy")
            return
        self._autopilot_done = done
        m = self.model
        if m.current_result() is not None:
            self._autopilot_save()
            return
        if len(m.usable()) >= MIN_PAIRS_TO_CALIBRATE and (m.detections is not None and m.detections.coverage.enough):
            if not self.calibrate():
                self._finish_autopilot(False, self.status.text() or "calibration could not start")
            return
        if not self.state.virtual:
            self._finish_autopilot(False, "no checkerboard pairs: add pairs from folders first")
            return
        board = lab_board(self.state)
        if board != m.board:                  # the lab's board: pairs of another board cannot join
            self.sources.clear_pairs()
            self.sources.set_board(board)
        if not self.sources.add_virtual_pairs(VIRTUAL_PAIRS, then=self._autopilot_calibrate):
            self._finish_autopilot(False, self.status.text() or "could not render the virtual-lab pairs")

    def _autopilot_calibrate(self) -> None:
        if self._autopilot_done is None:
            return
        if len(self.model.usable()) < MIN_PAIRS_TO_CALIBRATE or not self.calibrate():
            self._finish_autopilot(False, self.status.text() or "too few usable pairs")

    def _autopilot_save(self) -> None:
        if self._autopilot_done is None:
            return
        path = self.files.save_stereo()
        if path is None:
            self._finish_autopilot(False, self.status.text() or "stereo.yaml could not be written")
        else:
            r = self.model.result
            self._finish_autopilot(True, f"{r.pairs_used} pairs, stereo RMS {r.file.rms_stereo:.3f} px, "
                                         f"baseline {r.baseline_mm:.1f} mm")

    def on_cancelled(self) -> None:
        kept = len(self.model.items)
        self._set_status(f"Cancelled. {kept} pair{'s' if kept != 1 else ''} on the page.", ok=False)
        self._finish_autopilot(False, "cancelled")

    def on_busy_changed(self) -> None:
        busy, has_project, virtual = self.task.busy, self.state.project is not None, self.state.virtual
        m = self.model
        self.task.progress_row().bar.setVisible(busy)
        live = self.state.hardware.cameras is not None
        self.pairs.show_controls(busy, has_project, virtual, live, live and self.live.ready_pair() is not None,
                                 bool(m.items))
        self.options_panel.show_calibrate(busy, len(m.usable()), m.detections is not None and m.coverage().enough)
        has_result = m.result is not None
        self.options_panel.set_enabled(not busy)
        self.save_button.setEnabled(not busy and has_result and has_project)
        self.import_button.setEnabled(not busy and has_project)
        self.ros_button.setEnabled(not busy and has_result)
        self.json_button.setEnabled(not busy and has_result)
        self.swap_button.setVisible(m.current_result() is not None and m.result.cameras_look_swapped)
        self.swap_button.setEnabled(not busy)
        self.results.show_controls(busy, m.result, any(a.excluded for a in m.items))

    # -- calibration -----------------------------------------------------------------------------
    def calibrate(self, note: str = "") -> bool:
        """Calibrate from the usable pairs with the camera model chosen, on the worker; `note` is
        said after the result (False: it could not start, the status line says why)."""
        if self.sources.board_timer.isActive():
            self.sources.apply_board()             # a board edit not applied yet
        if self.task.busy:
            self._set_status(BUSY, ok=False)
            return False
        m = self.model
        usable = m.usable()
        if len(usable) < MIN_PAIRS_TO_CALIBRATE or m.detections is None:
            self._set_status(f"Calibration needs at least {MIN_PAIRS_TO_CALIBRATE} accepted pairs "
                             f"({len(usable)} now).", ok=False)
            return False
        detections = m.screened()
        exclude = [a.detection.index for a in m.items if a.excluded]
        m.set_options(self.options_panel.options())
        self._set_status(f"Calibrating from {len(m.usable())} pairs ({m.options.describe()})…")
        return self.task.start(calibrate_stereo, detections, m.options, exclude=exclude, label="Calibrating",
                               on_done=lambda result: self._calibrated(result, note))

    def _calibrated(self, result: StereoCalibrationResult, note: str) -> None:
        self.model.set_result(result)
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
        self._set_status(text + note, ok=not result.cameras_look_swapped)
        if self._autopilot_done is not None:
            QTimer.singleShot(0, self._autopilot_save)
