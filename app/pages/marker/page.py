"""The Marker step's page (step 3): the training controls and the stereo line above six tabs
(Training, Live pair, SSD correlation, Verification, Compare markers, Conditions); the chain is
described in the package's docstring. Long work goes through the page's `task.start` with the virtual lab from
`state.request_lab`; the page keeps the step's state and draws what the work returns."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from PySide6.QtWidgets import QFileDialog, QTabWidget, QVBoxLayout

from app.html import number
from app.jobs.marker import (Comparison, LiveResult, Training, TrainingImage, VerificationResult,
                             camera_live_pair, camera_training_image, capture_training_image, live_pair,
                             load_training_image, marker_changed_inputs, recorded_verification, run_comparison,
                             run_verification, save_trained, stereo_parameter_covariance, train_job,
                             write_details, write_verification)
from app.jobs.marker_conditions import ConditionsPair, conditions_pair, run_sweep
from app.lab import RobustnessTable, VirtualLab
from app.pages.base import WizardPage, out_of_date
from app.pages.marker.autopilot import MarkerAutopilot
from app.safety import motion_refused
from app.pages.marker.compare_panel import ComparePanel
from app.pages.marker.conditions_panel import ConditionsPanel
from app.pages.marker.live_panel import LivePanel
from app.pages.marker.stereo_bar import StereoBar
from app.pages.marker.ssd_panel import SsdPanel
from app.pages.marker.training_panel import TrainingPanel
from app.pages.marker.verification_panel import VerificationPanel
from app.pages.measurement_inputs import StereoSource, marker_file, preview_source, stereo_source
from app.pages.steps import Step
from core.errors import RoboCalError
from core.marker.location import LocatorOptions, MarkerLocator
from core.marker.training import TrainedMarker
from core.project import Output

TAB_TRAINING, TAB_LIVE, TAB_SSD, TAB_VERIFY, TAB_COMPARE, TAB_CONDITIONS = range(6)
AGAIN = "Run a verification (or a live pair) again."      # what makes an out-of-date marker current


class MarkerPage(MarkerAutopilot, WizardPage):
    step = Step.MARKER

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.trained: TrainedMarker | None = None
        self.trained_offset = np.zeros(2)
        self.saved_path: Path | None = None
        self.verified = False
        self.stereo = StereoSource(None, "", "no stereo calibration")
        self._preview = False            # the user asked for the lab's true cameras
        self._locator: MarkerLocator | None = None
        self.live: LiveResult | None = None
        self.verification: VerificationResult | None = None
        self.comparison: Comparison | None = None
        self._live_count = 0
        self._verify_count = 0
        self._verifying = 0                     # the verification run being drawn as it comes (0: none)
        self._conditions_count = 0
        self._build()
        state.projectChanged.connect(self._context_changed)
        state.hardware.camerasChanged.connect(lambda *_: self._update_buttons())
        state.robotChanged.connect(self._context_changed)
        state.stereoChanged.connect(lambda *_: self._refresh_stereo())
        self._context_changed()

    # -- construction ---------------------------------------------------------------------
    def _build(self) -> None:
        self.training_panel = TrainingPanel()
        self.training_panel.load_button.clicked.connect(lambda: self.load_dialog())
        self.training_panel.capture_button.clicked.connect(lambda: self.capture_training())
        self.training_panel.train_button.clicked.connect(lambda: self.train())
        self.training_panel.statusChanged.connect(self._set_status)
        self.live_panel = LivePanel()
        self.live_panel.next_button.clicked.connect(lambda: self.next_pose())
        self.ssd_panel = SsdPanel()
        self.verification_panel = VerificationPanel(self.task.progress_row())
        self.verification_panel.verify_button.clicked.connect(lambda: self.verify())
        self.verification_panel.pointsArrived.connect(self._verification_so_far)
        self.compare_panel = ComparePanel()
        self.compare_panel.compare_button.clicked.connect(lambda: self.compare())
        self.conditions_panel = ConditionsPanel()
        self.conditions_panel.show_button.clicked.connect(lambda: self.show_conditions())
        self.conditions_panel.sweep_button.clicked.connect(lambda: self.sweep())
        self.stereo_bar = StereoBar()
        self.stereo_bar.preview_button.clicked.connect(lambda: self.use_preview())
        top = QVBoxLayout()
        top.setContentsMargins(0, 0, 0, 0)
        top.setSpacing(3)
        top.addLayout(self.training_panel.controls)
        top.addWidget(self.stereo_bar)
        self.tabs = QTabWidget()
        self.tabs.setObjectName("markerTabs")
        for panel, name in ((self.training_panel, "Training"), (self.live_panel, "Live pair"),
                            (self.ssd_panel, "SSD correlation"), (self.verification_panel, "Verification"),
                            (self.compare_panel, "Compare markers"), (self.conditions_panel, "Conditions")):
            self.tabs.addTab(panel, name)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addLayout(top)
        layout.addWidget(self.tabs, 1)
        layout.addWidget(self.status)

    # -- state ------------------------------------------------------------------------------
    @property
    def training_image(self) -> TrainingImage | None:
        return self.training_panel.image

    @property
    def locator(self) -> MarkerLocator | None:
        if self._locator is None and self.trained is not None and self.stereo.rect is not None:
            self._locator = MarkerLocator(self.trained, self.stereo.rect, LocatorOptions())
        return self._locator

    def _context_changed(self, *_) -> None:
        """Another project or robot: start again, from the project's saved marker if any."""
        self.task.forget()
        self._preview = False
        self._set_trained(None, np.zeros(2), None)
        self.training_panel.clear()
        self._clear_results()
        message, ok = self._load_saved_marker()
        self._refresh_stereo()
        self._update_buttons()
        if message:
            self._set_status(message, ok)
        self.notify_complete()

    def _clear_results(self) -> None:
        """Forget (and undraw) the live pair and the verification: another marker or project."""
        self.verified = False
        self.live = None
        self.verification = None
        self._draw_live()
        self.verification_panel.draw(None)

    def _load_saved_marker(self) -> tuple[str, bool | None]:
        """Take the project's marker.npz, if any; returns what to say about it."""
        project = self.state.project
        if project is None:
            return "No project yet: create or open one in the Setup step (1).", None
        path = marker_file(project)
        if not path.is_file():
            return ("No trained marker in this project yet: capture or load a training image of the marker, "
                    "then Train."), None
        try:
            trained = TrainedMarker.load(path)
        except RoboCalError as exc:
            return f"The project's marker.npz cannot be used ({exc.message}); train again.", False
        self._set_trained(trained, np.zeros(2), path)
        self.state.set_marker(trained)
        self.training_panel.image = TrainingImage(trained.image, trained.source or str(path), trained.outline)
        self.training_panel.size_spin.setValue(trained.outer_size)
        self._draw_training()
        self.verified = recorded_verification(project)
        changed = marker_changed_inputs(project)
        if changed:
            return out_of_date("the marker's verification", changed, AGAIN), False
        return (f"This project already has a trained marker ({path.name}, {trained.n_image_features} SIFT features)"
                + (", verified: the step is done." if self.verified else
                   ". Locate it on a pair (Live pair or Verification) to finish the step."), self.verified)

    def _refresh_stereo(self) -> None:
        lab = self.state.labs.current
        if self._preview and lab is not None and stereo_source(self.state).rect is None:
            src = preview_source(lab)
        else:
            self._preview = False
            src = stereo_source(self.state)
        changed = src.kind != self.stereo.kind or src.label != self.stereo.label
        self.stereo = src
        if changed:
            self._locator = None
        self.stereo_bar.draw(src, self.state.virtual)
        self._update_buttons()
        changed = self.changed_inputs() if self.state.project is not None else []
        if changed and not self.task.busy:
            self._set_status(out_of_date("the marker's verification", changed, AGAIN), False)
            self.notify_complete()

    # -- WizardPage -------------------------------------------------------------------------
    def on_enter(self) -> None:
        self._refresh_stereo()
        self.notify_complete()

    def is_complete(self) -> bool:
        return (self.trained is not None and self.saved_path is not None and self.verified
                and not self.changed_inputs())

    def changed_inputs(self) -> list[str]:
        """The project's inputs (stereo.yaml) changed since its marker was trained or verified."""
        return marker_changed_inputs(self.state.project) if self.saved_path is not None else []

    # -- tasks --------------------------------------------------------------------------------
    def on_busy_changed(self) -> None:
        self._update_buttons()

    def _update_buttons(self) -> None:
        busy = self.task.busy
        has_project = self.state.project is not None
        virtual = self.state.virtual and self.state.robot is not None
        live = self.state.hardware.cameras is not None
        tp = self.training_panel
        tp.load_button.setEnabled(not busy and has_project)
        tp.capture_button.setEnabled(not busy and has_project and (virtual or live))
        tp.set_source(live)
        self.live_panel.set_source(live)
        tp.crop_check.setEnabled(not busy and tp.image is not None)
        tp.train_button.setEnabled(not busy and has_project and tp.image is not None)
        self.stereo_bar.preview_button.setEnabled(not busy)
        ready = self.trained is not None and self.stereo.rect is not None
        self.live_panel.next_button.setEnabled(not busy and ready and (virtual or live))
        self.verification_panel.verify_button.setEnabled(not busy and ready and virtual)
        self.compare_panel.compare_button.setEnabled(not busy and virtual)
        self.conditions_panel.show_button.setEnabled(not busy and ready and virtual)
        self.conditions_panel.sweep_button.setEnabled(not busy and ready and virtual)

    # -- stereo preview -----------------------------------------------------------------------
    def use_preview(self, then=None) -> bool:
        """Virtual lab without a stereo calibration: locate with the lab's true cameras."""
        if not self.state.virtual or self.state.robot is None:
            self._set_status("The preview needs a virtual-lab project with a robot.", False)
            return False
        announce = not self.state.labs.built

        def preview(lab: VirtualLab) -> bool:
            self._preview = True
            self._refresh_stereo()
            if announce:
                self._set_status("Preview: locating with the virtual lab's true cameras (not a calibration).", None)
            if then is not None:
                then()
            return True

        return self.task.with_lab(preview)

    # -- training -----------------------------------------------------------------------------
    def load_dialog(self) -> bool:
        start = str(self.state.project.folder) if self.state.project else ""
        path, _ = QFileDialog.getOpenFileName(self, "Marker training image", start,
                                              "Images (*.png *.jpg *.jpeg *.bmp *.tif *.tiff)")
        return self.load_image(path) if path else False

    def load_image(self, path: str | Path) -> bool:
        try:
            image = load_training_image(path)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", False)
            return False
        self._set_training_image(image)
        return True

    def capture_training(self, then=None) -> bool:
        """From the left camera of the cameras opened on the Setup page; else the virtual lab's."""
        if self.state.hardware.cameras is not None:
            return self.task.start(camera_training_image, self.state.hardware.cameras, on_done=self._set_training_image,
                              label="Training image", then=then,
                              status="Taking the training image with the left camera…")
        if not self.state.virtual or self.state.robot is None:
            self._set_status("Open the two cameras on the Setup page to capture, or load an image of the marker.",
                             False)
            return False
        return self.task.with_lab(lambda lab: self.task.start(
            capture_training_image, lab, on_done=self._set_training_image, label="Training image", then=then,
            status="Taking the training image…"))

    def _set_training_image(self, image: TrainingImage) -> None:
        self.training_panel.set_image(image)
        self._update_buttons()

    def train(self, then=None) -> bool:
        img = self.training_image
        if img is None:
            self._set_status("Load or capture a training image first.", False)
            return False
        if self.state.project is None:
            self._set_status("Create or open a project first (Setup step).", False)
            return False
        return self.task.start(train_job, img.image, self.training_panel.crop_box(),
                          float(self.training_panel.size_spin.value()), img.source, on_done=self._trained,
                          label="Training the marker", then=then,
                          status="Training: outline, edges, SIFT features of the marker and of simulated "
                                 "tilted views…")

    def _trained(self, training: Training) -> None:
        trained = training.trained
        try:
            path = save_trained(self.state.project, trained)
        except RoboCalError as exc:
            self._set_status(f"✗ The trained marker was not saved: {exc.message}", False)
            return
        self._set_trained(trained, training.offset, path)
        self._clear_results()
        self._draw_training()
        self.state.set_marker(trained)
        self._set_status(f"✓ Trained: {trained.n_image_features} SIFT features on the marker "
                         f"({trained.n_features} with the simulated tilted views), saved as {path.name}. "
                         "Now check it on a live pair (Next pose) and run a verification.", True)
        self.tabs.setCurrentIndex(TAB_TRAINING)
        self.notify_complete()

    def _set_trained(self, trained: TrainedMarker | None, offset, path: Path | None) -> None:
        self.trained = trained
        self.trained_offset = np.asarray(offset, dtype=float)
        self.saved_path = path
        self._locator = None
        self._update_buttons()

    def _draw_training(self) -> None:
        self.training_panel.show_training(self.trained, self.trained_offset,
                                          self.saved_path.name if self.saved_path else "")

    # -- live pair ------------------------------------------------------------------------------
    def _ready_locator(self) -> MarkerLocator | None:
        if self.locator is None:
            self._set_status("Train the marker and provide a stereo calibration first.", False)
        return self.locator

    def next_pose(self, then=None) -> bool:
        locator = self._ready_locator()
        if locator is None:
            return False
        if self.state.hardware.cameras is not None:
            self._live_count += 1
            return self.task.start(camera_live_pair, self.state.hardware.cameras, locator, self._live_count,
                              self.state.hardware.robot_connection, on_done=self._live_done, label="Live pair", then=then,
                              status="Capturing a pair from the cameras and locating…")

        def go(lab: VirtualLab) -> bool:
            self._live_count += 1
            return self.task.start(live_pair, lab, locator, self._live_count, int(self.state.seed),
                              self.state.hardware.robot_connection, on_done=self._live_done, label="Live pair", then=then,
                              status="Moving to a random visible pose, capturing and locating…")

        if not self._robot_may_move():
            return False
        return self.task.with_lab(go)

    def _robot_may_move(self) -> bool:
        """A real robot moves only when app.safety allows it (connected, not stopped, its first
        motion confirmed); the simulated robot always may."""
        refused = motion_refused(self, self.state) if self.state.hardware.real_robot else None
        if refused:
            self._set_status(refused, False)
        return refused is None

    def _live_done(self, live: LiveResult) -> None:
        self.live = live
        self._draw_live()
        loc = live.location
        if loc.ok:
            self._save_details(live=live)
            self._mark_verified({"kind": "live pair", "poses": 1, "located": 1,
                                 "error_mm": None if not math.isfinite(live.error) else round(live.error, 6)})
            took = f"✓ Located in {1000 * loc.timings.get('total', live.seconds):.0f} ms"
            if live.truth is None:
                self._set_status(f"{took} at ({', '.join(f'{v:.1f}' for v in loc.point)}) mm. Move the marker and "
                                 "capture again for another.", True)
            else:
                self._set_status(f"{took}: error against the truth {live.error:.3f} mm. Next pose for another, "
                                 "or run a verification.", True)
        else:
            self._set_status(f"Not located: {loc.reason}", False)
        self.tabs.setCurrentIndex(TAB_LIVE)

    def _draw_live(self) -> None:
        self.live_panel.draw(self.live, self.stereo)
        self.ssd_panel.draw(self.live)

    # -- verification ---------------------------------------------------------------------------
    def verify(self, then=None) -> bool:
        locator = self._ready_locator()
        if locator is None:
            return False
        if not self._robot_may_move():
            return False

        def go(lab: VirtualLab) -> bool:
            n = self.verification_panel.verify_spin.value()
            self._verify_count += 1
            self.tabs.setCurrentIndex(TAB_VERIFY)
            self._verifying = self._verify_count
            project, rect = self.state.project, self.stereo.rect
            details = project.path(Output.STEREO_DETAILS) if project is not None and self.stereo.kind == "file" else None
            covariance = stereo_parameter_covariance(rect.calibration if rect is not None else None, details,
                                                     self.state.stereo)
            return self.task.start(run_verification, lab, locator, n, int(self.state.seed), self._verify_count,
                              self.stereo.label, self.state.hardware.robot_connection, covariance, on_done=self._verified,
                              shown=self.verification_panel.pointsArrived.emit,
                              label="Verification", then=then, status=f"Verification over {n} random poses…")

        return self.task.with_lab(go)

    def _verification_so_far(self, v: VerificationResult) -> None:
        """The poses measured so far, drawn while the verification runs (a late one is dropped)."""
        if self.task.busy and self._verifying == self._verify_count:
            self.verification_panel.draw(v, running=True)

    def _verified(self, v: VerificationResult) -> None:
        self._verifying = 0
        self.verification = v
        self.verification_panel.draw(v)
        self._save_details(verification=v)
        cancelled = (f"Cancelled after {v.n} of {v.poses_planned} poses, those measured are kept. "
                     if v.cancelled_after is not None else "")
        if v.n_located:
            self._mark_verified({"kind": "verification", **v.to_dict()})
            self._set_status(f"✓ {cancelled}Verification: {v.n_located} of {v.n} located, median 3D error "
                             f"{number(v.median_error, 3, 'mm')}, RMS {number(v.rms_error, 3, 'mm')}. "
                             "The step is done.", True)
        else:
            self._set_status("✗ The marker was not located in any pose: see the reasons.", False)

    def _save_details(self, **result) -> None:
        """What the report draws of this live pair or verification, into marker_details.json."""
        project = self.state.project
        if project is not None and self.saved_path is not None:
            try:
                write_details(project, self.saved_path.name, **result)
            except RoboCalError as exc:
                self._set_status(f"The details for the report were not written: {exc.message}", False)

    def _mark_verified(self, record: dict) -> None:
        project = self.state.project
        if project is not None and self.saved_path is not None:
            try:
                write_verification(project, self.saved_path.name, record)
            except RoboCalError as exc:
                self._set_status(f"The verification record was not written: {exc.message}", False)
        self.verified = True
        self.notify_complete()

    # -- comparison ---------------------------------------------------------------------------
    def compare(self) -> bool:
        if not self.state.virtual or self.state.robot is None:
            self._set_status("The marker comparison renders its views in the virtual lab.", False)
            return False
        self.tabs.setCurrentIndex(TAB_COMPARE)
        return self.task.with_lab(lambda lab: self.task.start(
            run_comparison, lab, self.compare_panel.compare_spin.value(), int(self.state.seed),
            on_done=self._compared, label="Comparing markers", status="Comparing the candidate markers…"))

    def _compared(self, comparison: Comparison) -> None:
        self.comparison = comparison
        self.compare_panel.draw(comparison)
        result = comparison.result
        best = next(p for p in result.patterns if p.key == result.recommended)
        self._set_status(f"✓ Compared {len(result.patterns)} patterns over {result.views} views: "
                         f"{best.name} detected best ({100 * best.detection_rate:.0f} %).", True)

    # -- imaging conditions ---------------------------------------------------------------------
    def _conditions_locator(self) -> MarkerLocator | None:
        """The locator, when the marker may be rendered under conditions (virtual lab only)."""
        if not self.state.virtual or self.state.robot is None:
            self._set_status("Imaging conditions are rendered in the virtual lab.", False)
            return None
        return self._ready_locator()

    def show_conditions(self, then=None) -> bool:
        """One marker pair under the chosen light, occlusion and tilt, located."""
        locator = self._conditions_locator()
        if locator is None:
            return False
        conditions = self.conditions_panel.conditions()          # the controls keep it within bounds
        self.tabs.setCurrentIndex(TAB_CONDITIONS)

        def go(lab: VirtualLab) -> bool:
            self._conditions_count += 1
            return self.task.start(conditions_pair, lab, locator, conditions, self._conditions_count, int(self.state.seed),
                              on_done=self._conditions_shown, label="Conditions", then=then,
                              status="Rendering the marker under these conditions and locating it…")

        return self.task.with_lab(go)

    def _conditions_shown(self, pair: ConditionsPair) -> None:
        self.conditions_panel.draw_pair(pair)
        loc = pair.location
        if loc.ok:
            self._set_status(f"✓ Located {number(pair.error, 3, 'mm')} from the true position.", True)
        else:
            self._set_status(f"Not located under these conditions: {loc.reason}", False)

    def sweep(self, then=None) -> bool:
        """Detection rate and 3D error over light levels, occlusions and tilts."""
        locator = self._conditions_locator()
        if locator is None:
            return False
        pairs = self.conditions_panel.pairs_spin.value()
        side = self.conditions_panel.side_combo.currentText()
        self.tabs.setCurrentIndex(TAB_CONDITIONS)
        return self.task.with_lab(lambda lab: self.task.start(
            run_sweep, lab, locator, pairs, int(self.state.seed), side, on_done=self._swept, label="Conditions sweep",
            then=then, status=f"Sweeping light, occlusion and tilt, {pairs} pairs per value…"))

    def _swept(self, table: RobustnessTable) -> None:
        self.conditions_panel.draw_table(table)
        if table.wrong:
            self._set_status(f"✗ {table.wrong} marker(s) accepted more than {table.wrong_mm:g} mm from the truth: "
                             "the locator's checks let a wrong point through.", False)
        else:
            self._set_status(f"✓ Swept {len(table.rows)} conditions × {table.pairs} pairs: no marker accepted more "
                             f"than {table.wrong_mm:g} mm off. See where detection drops.", True)
