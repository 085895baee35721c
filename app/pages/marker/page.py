"""The Marker step's page (step 3): the training controls and the stereo line above six tabs
(Training, Live pair, SSD correlation, Verification, Compare markers, Conditions); the chain is
described in the package's docstring. The page is a small controller: the panels say what was
chosen (into the model's options) and draw from the model's events; its helpers (training.py,
locating.py, studies.py, autopilot.py) start the work through the page's `task` with the
model's options and put what it returns into the model."""
from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QTabWidget, QVBoxLayout

from app.jobs.marker import marker_changed_inputs
from app.pages.base import WizardPage, out_of_date
from app.pages.marker.autopilot import MarkerActions, MarkerAutopilot
from app.pages.marker.compare_panel import ComparePanel
from app.pages.marker.conditions_panel import ConditionsPanel
from app.pages.marker.live_panel import LivePanel
from app.pages.marker.locating import MarkerLocating
from app.pages.marker.model import MarkerModel
from app.pages.marker.ssd_panel import SsdPanel
from app.pages.marker.stereo_bar import StereoBar
from app.pages.marker.studies import LabStudies
from app.pages.marker.training import AGAIN, MarkerTraining
from app.pages.marker.training_panel import TrainingPanel
from app.pages.marker.verification_panel import VerificationPanel
from app.pages.measurement_inputs import preview_source, stereo_source
from app.pages.steps import Step

TAB_TRAINING, TAB_LIVE, TAB_SSD, TAB_VERIFY, TAB_COMPARE, TAB_CONDITIONS = range(6)
TABS = {"training": TAB_TRAINING, "live": TAB_LIVE, "verification": TAB_VERIFY, "compare": TAB_COMPARE,
        "conditions": TAB_CONDITIONS}


class MarkerPage(WizardPage):
    """`model` holds the step's options and results (app/pages/marker/model.py)."""

    step = Step.MARKER

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.model = MarkerModel()
        self._preview = False            # the user asked for the lab's true cameras
        self._build()
        say, show_tab = self._set_status, lambda name: self.tabs.setCurrentIndex(TABS[name])
        self.training = MarkerTraining(state, self.model, self.task, parent=self, say=say,
                                       training_options=self.training_panel.options, show_tab=show_tab,
                                       completed=self.notify_complete)
        self.locating = MarkerLocating(state, self.model, self.task, parent=self, say=say, show_tab=show_tab,
                                       shown=self.verification_panel.pointsArrived.emit,
                                       completed=self.notify_complete)
        self.studies = LabStudies(state, self.model, self.task, say=say, show_tab=show_tab,
                                  ready_locator=self.locating.ready_locator)
        self.pilot = MarkerAutopilot(state, self.model, self.task, MarkerActions(
            self.use_preview, self.capture_training, self.train, self.next_pose, self.verify),
            status_text=self.status.text, is_complete=self.is_complete)
        self._connect()
        state.projectChanged.connect(self._context_changed)
        state.hardware.camerasChanged.connect(lambda *_: self._update_buttons())
        state.robotChanged.connect(self._context_changed)
        state.stereoChanged.connect(lambda *_: self._refresh_stereo())
        self._context_changed()

    # -- construction ---------------------------------------------------------------------
    def _build(self) -> None:
        self.training_panel = TrainingPanel()
        self.training_panel.statusChanged.connect(self._set_status)
        self.live_panel = LivePanel()
        self.ssd_panel = SsdPanel()
        self.verification_panel = VerificationPanel(self.task.progress_row())
        self.compare_panel = ComparePanel()
        self.conditions_panel = ConditionsPanel()
        self.stereo_bar = StereoBar()
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

    def _connect(self) -> None:
        """Buttons to the actions; the panels' options into the model and back; the model's
        results to the panels that draw them."""
        tp, lp, vp, cp, cd, m = (self.training_panel, self.live_panel, self.verification_panel, self.compare_panel,
                                 self.conditions_panel, self.model)
        tp.load_button.clicked.connect(lambda: self.training.load_dialog())
        tp.capture_button.clicked.connect(lambda: self.capture_training())
        tp.train_button.clicked.connect(lambda: self.train())
        lp.next_button.clicked.connect(lambda: self.next_pose())
        vp.verify_button.clicked.connect(lambda: self.verify())
        vp.pointsArrived.connect(self.locating.verification_so_far, Qt.ConnectionType.QueuedConnection)
        cp.compare_button.clicked.connect(lambda: self.compare())
        cd.show_button.clicked.connect(lambda: self.studies.show_conditions())
        cd.sweep_button.clicked.connect(lambda: self.studies.sweep())
        self.stereo_bar.preview_button.clicked.connect(lambda: self.use_preview())
        for panel, part in ((tp, "training"), (vp, "verification"), (cp, "comparison"), (cd, "conditions")):
            panel.optionsChanged.connect(lambda p=panel, k=part: m.choose(**{k: p.options()}))
            m.on("options", lambda o, p=panel, k=part: p.show_options(getattr(o, k)))
        m.on("image", tp.set_image)
        m.on("trained", tp.draw_trained)
        m.on("live", lambda live: lp.draw(live, m.stereo))
        m.on("live", self.ssd_panel.draw)
        m.on("verification", vp.draw)
        m.on("verification_so_far", lambda v: vp.draw(v, running=True))
        m.on("comparison", cp.draw)
        m.on("conditions_pair", cd.draw_pair)
        m.on("sweep", cd.draw_table)
        m.on("stereo", lambda source: self.stereo_bar.draw(source, self.state.virtual))
        for event in ("image", "trained", "stereo"):
            m.on(event, lambda _: self._update_buttons())

    # -- state ------------------------------------------------------------------------------
    def _context_changed(self, *_) -> None:
        """Another project or robot: start again, from the project's saved marker if any."""
        self.task.forget()
        self._preview = False
        self.model.forget()
        message, ok = self.training.load_saved()
        self._refresh_stereo()
        self._update_buttons()
        if message:
            self._set_status(message, ok)
        self.notify_complete()

    def _refresh_stereo(self) -> None:
        lab = self.state.labs.current
        if self._preview and lab is not None and stereo_source(self.state).rect is None:
            self.model.set_stereo(preview_source(lab))
        else:
            self._preview = False
            self.model.set_stereo(stereo_source(self.state))
        changed = self.changed_inputs() if self.state.project is not None else []
        if changed and not self.task.busy:
            self._set_status(out_of_date("the marker's verification", changed, AGAIN), False)
            self.notify_complete()

    # -- WizardPage -------------------------------------------------------------------------
    def on_enter(self) -> None:
        self._refresh_stereo()
        self.notify_complete()

    def is_complete(self) -> bool:
        r = self.model.result
        return r.trained is not None and r.saved_path is not None and r.verified and not self.changed_inputs()

    def changed_inputs(self) -> list[str]:
        """The project's inputs (stereo.yaml) changed since its marker was trained or verified."""
        return marker_changed_inputs(self.state.project) if self.model.result.saved_path is not None else []

    def autopilot(self, done) -> None:
        self.pilot.start(done)

    def _finish_autopilot(self, ok: bool, message: str = "") -> None:
        self.pilot.finish(ok, message)

    def on_busy_changed(self) -> None:
        self._update_buttons()

    def _update_buttons(self) -> None:
        busy = self.task.busy
        has_project = self.state.project is not None
        virtual = self.state.virtual and self.state.robot is not None
        live = self.state.hardware.cameras is not None
        has_image = self.model.result.training_image is not None
        tp = self.training_panel
        tp.load_button.setEnabled(not busy and has_project)
        tp.capture_button.setEnabled(not busy and has_project and (virtual or live))
        tp.set_source(live)
        self.live_panel.set_source(live)
        tp.crop_check.setEnabled(not busy and has_image)
        tp.train_button.setEnabled(not busy and has_project and has_image)
        self.stereo_bar.preview_button.setEnabled(not busy)
        ready = self.model.ready
        self.live_panel.next_button.setEnabled(not busy and ready and (virtual or live))
        self.verification_panel.verify_button.setEnabled(not busy and ready and virtual)
        self.compare_panel.compare_button.setEnabled(not busy and virtual)
        self.conditions_panel.show_button.setEnabled(not busy and ready and virtual)
        self.conditions_panel.sweep_button.setEnabled(not busy and ready and virtual)

    # -- actions (the buttons, the autopilot and scripts) -------------------------------------------
    def use_preview(self, then=None) -> bool:
        """Virtual lab without a stereo calibration: locate with the lab's true cameras."""
        if not self.state.virtual or self.state.robot is None:
            self._set_status("The preview needs a virtual-lab project with a robot.", False)
            return False
        announce = not self.state.labs.built

        def preview(lab) -> bool:
            self._preview = True
            self._refresh_stereo()
            if announce:
                self._set_status("Preview: locating with the virtual lab's true cameras (not a calibration).", None)
            if then is not None:
                then()
            return True

        return self.task.with_lab(preview)

    def load_image(self, path: str | Path) -> bool:
        """A training image from a file."""
        return self.training.load_image(path)

    def capture_training(self, then=None) -> bool:
        """A training image from the left camera opened on the Setup page, else the virtual lab's."""
        return self.training.capture(then)

    def train(self, then=None) -> bool:
        return self.training.train(then)

    def next_pose(self, then=None) -> bool:
        """One live pair located (the virtual robot at a random visible pose, or the cameras)."""
        return self.locating.next_pose(then)

    def verify(self, then=None) -> bool:
        """The verification over the chosen number of random poses of the virtual lab."""
        return self.locating.verify(then)

    def compare(self) -> bool:
        return self.studies.compare()
