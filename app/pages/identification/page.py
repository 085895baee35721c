"""Step 6, Identification: the robot's real geometry from the measured marker positions.

The page reads the project's measurements.csv, runs app.jobs.identification.run_identification
(core.identification.solver.identify) on a worker thread (progress, Cancel), and draws what it
returns: the parameter table (nominal → identified ± σ, the parameters that were not estimated
greyed with their explanation), the errors per pose before and after and their histogram, the
cost per iteration, the correlation matrix, the validation figures and the warnings. In the
virtual lab it also measures the calibrated model against the lab's TRUE robot on fresh poses
(the accuracy a teacher wants to show), and offers ideal synthetic measurements when the
Measurement step has not produced any.

The page is the controller: the Options panel says what was chosen (IdentificationOptions), the
job runs, the model (model.py) keeps the run and the panels draw from it.
"""
from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QVBoxLayout

from app.jobs.identification import IdentificationRun, generate_ideal_measurements, run_identification
from app.lab import DEFAULT_POSES, DEFAULT_SIGMA_MM
from app.pages.base import WizardPage, out_of_date
from app.pages.identification.exports_row import ExportsRow
from app.pages.identification.model import IdentificationModel, inputs, read_source
from app.pages.identification.options_panel import OptionsPanel
from app.pages.identification.results_panel import ResultsPanel
from app.pages.identification.source_panel import SourcePanel
from app.pages.steps import Step
from core.errors import RoboCalError
from core.identification.exports import export_model
from core.identification.result import IdentificationResult
from core.project import Output
from core.provenance import fingerprint


class IdentificationPage(WizardPage):
    step = Step.IDENTIFICATION

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.model = IdentificationModel()
        self._ready = False                 # measurements.csv exists and reads for the robot
        self.source = SourcePanel(on_ideal=self.use_ideal_measurements)
        self.options = OptionsPanel(self.task.progress_row(), robot=lambda: self.state.robot,
                                    on_identify=self.start_identification)
        self.results = ResultsPanel()
        self.exports = ExportsRow()
        self.save_button, self.csv_button, self.urdf_button = (self.exports.save_button, self.exports.csv_button,
                                                               self.exports.urdf_button)
        self.save_button.clicked.connect(lambda *_: self.save_calibrated())
        self.csv_button.clicked.connect(lambda *_: self.export_file("dh-csv"))
        self.urdf_button.clicked.connect(lambda *_: self.export_file("urdf"))
        self.model.on("result", self.results.show_run)
        self.model.on("result", lambda run: self.exports.set_enabled(run is not None and not self.task.busy))
        self.status.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addWidget(self.source)
        layout.addWidget(self.options)
        layout.addWidget(self.results, 1)
        layout.addWidget(self.status)
        layout.addWidget(self.exports)

        state.projectChanged.connect(self._context_changed)
        state.robotChanged.connect(self._context_changed)
        state.measurementsChanged.connect(lambda *_: self._inputs_changed())
        state.outputSaved.connect(lambda key: self._inputs_changed() if key == "measurements" else None)
        self.options.set_busy(False)
        self.model.set_result(None)
        self._refresh_source()

    # -- state ---------------------------------------------------------------------------
    @property
    def run_result(self) -> IdentificationRun | None:
        return self.model.result

    @property
    def result(self) -> IdentificationResult | None:
        return self.model.result.result if self.model.result is not None else None

    def measurements_path(self) -> Path | None:
        return self.state.project.path(Output.MEASUREMENTS) if self.state.project is not None else None

    def changed_inputs(self) -> list[str]:
        """The inputs that changed since this session's result (or the project's calibrated.json)
        was made from them: [] when up to date or nothing is known."""
        return self.model.changed_inputs(self.state.project)

    def _inputs_changed(self) -> None:
        """New measurements: say whether the result is still the one made from them."""
        self._refresh_source()
        changed = self.changed_inputs()
        if changed and not self.task.busy:
            self._set_status(out_of_date("the identification", changed, "Identify again."), ok=False)
        self.notify_complete()

    def fixed_names(self) -> list[str]:
        return self.options.fixed_names()

    def _context_changed(self, *_):
        """Another project or robot: the result no longer applies, and a late one is dropped."""
        self.task.forget()
        self.model.identified(None, None)
        self.options.rebuild_fix_menu()
        self._refresh_source()
        self.notify_complete()

    # -- WizardPage ----------------------------------------------------------------------
    def on_enter(self) -> None:
        self.options.rebuild_fix_menu()
        self._inputs_changed()

    def is_complete(self) -> bool:
        return self.model.result is not None and not self.changed_inputs()

    def on_busy_changed(self) -> None:
        busy = self.task.busy
        self.options.set_busy(busy)
        self.options.run_button.setEnabled(self._ready and not busy)
        self.source.ideal_button.setEnabled(not busy)
        self.exports.set_enabled(self.model.result is not None and not busy)

    def autopilot(self, done) -> None:
        if self.state.project is None or self.state.robot is None:
            done(False, "no project or robot model (Setup step)")
            return
        self._autopilot_done = done
        path = self.measurements_path()
        if path.is_file():
            started = self.start_identification()
        elif self.state.virtual:
            started = self.use_ideal_measurements(then_identify=True)
        else:
            started = False
            self._set_status("No measurements in the project: run the Measurement step first.", ok=False)
        if not started:
            self._finish_autopilot(False, self.status.text() or "identification could not start")

    # -- measurements --------------------------------------------------------------------
    def _refresh_source(self) -> None:
        source = read_source(self.state.project, self.state.robot, self.state.virtual)
        self._ready = source.ready
        self.source.show_source(source.html, offer_ideal=source.offer_ideal)
        self.options.run_button.setEnabled(self._ready and not self.task.busy)

    def use_ideal_measurements(self, then_identify: bool = False) -> bool:
        """Write ideal virtual-lab measurements into the project (worker thread). Returns
        False (with the reason on the page) when it cannot start."""
        state = self.state
        if self.task.busy:
            return False
        if state.project is None or state.robot is None or not state.virtual:
            self._set_status("Ideal measurements need a virtual-lab project with a robot model.", ok=False)
            return False
        path = self.measurements_path()
        if path.exists():
            self._set_status(f"{path.name} already exists: it is not replaced.", ok=False)
            return False

        def written(_path) -> None:
            self._refresh_source()
            self._set_status(f"Ideal synthetic measurements written to {path} ({DEFAULT_POSES} poses, "
                             f"σ = {DEFAULT_SIGMA_MM:g} mm, no images).", ok=True)
            if then_identify and not self.start_identification():
                self._finish_autopilot(False, self.status.text())

        return self.task.with_lab(lambda lab: self.task.start(
            generate_ideal_measurements, path, lab, seed=state.seed, on_done=written, label="Ideal measurements",
            status="Generating ideal measurements…"), status="Generating ideal measurements…")

    # -- identification ------------------------------------------------------------------
    def start_identification(self) -> bool:
        """Start the identification on a worker thread; False (reason on the page) if it cannot."""
        state = self.state
        if self.task.busy:
            return False
        if state.project is None or state.robot is None:
            self._set_status("Choose a project and a robot model in the Setup step first.", ok=False)
            return False
        path = self.measurements_path()
        if not path.is_file():
            self._set_status("No measurements in the project: run the Measurement step (5) first"
                             + (", or use the ideal virtual-lab measurements." if state.virtual else "."), ok=False)
            return False
        try:
            self.model.set_options(self.options.options())
        except RoboCalError as exc:
            self._set_status(exc.message, ok=False)
            return False

        def identify(lab=None) -> bool:
            made_from = fingerprint(inputs(state.project))       # the measurements as the run reads them
            return self.task.start(run_identification, state.robot, path, seed=state.seed, lab=lab,
                                   **self.model.options.keywords(), label="Identifying", status="Identifying…",
                                   on_done=lambda run: self._identified(run, made_from))

        return self.task.with_lab(identify, status="Identifying…") if state.virtual else identify()

    def _identified(self, run: IdentificationRun, made_from: dict) -> None:
        self.model.identified(run, made_from)
        self.state.set_identification(run.result, run.accuracy)
        self._refresh_source()
        self._set_status("✓ Identified. Save calibrated.json to keep the result in the project.", ok=True)
        self.notify_complete()
        if self._autopilot_done is not None:
            self.results.show_errors_per_pose()      # the picture a class should see
            if self.save_calibrated():
                self._finish_autopilot(True, "")
            else:
                self._finish_autopilot(False, self.status.text())

    def on_failed(self, message: str) -> None:
        self._refresh_source()
        super().on_failed(message)

    def on_cancelled(self) -> None:
        self._refresh_source()
        kept = " The previous result is kept." if self.model.result is not None else ""
        self._set_status("Cancelled." + kept, ok=False)
        self._finish_autopilot(False, "cancelled")

    # -- exports -------------------------------------------------------------------------
    def save_calibrated(self) -> bool:
        """Write calibrated.json into the project (atomically)."""
        if self.result is None or self.state.project is None:
            return False
        try:
            path = self.model.save(self.state.project)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", ok=False)
            return False
        self._set_status(f"✓ Saved {path}", ok=True)
        self.state.output_saved("calibrated")
        return True

    def export_file(self, fmt: str, path: str | Path | None = None) -> Path | None:
        """Export the calibrated model as "dh-csv" or "urdf"; asks for the file without `path`."""
        if self.result is None:
            return None
        if path is None:
            path = self.exports.ask_path(fmt, self.state.project.folder if self.state.project is not None
                                         else Path.home())
            if path is None:
                return None
        try:
            out = export_model(self.result.model, fmt, path)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", ok=False)
            return None
        self._set_status(f"✓ Exported {out}", ok=True)
        return out
