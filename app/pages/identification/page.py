"""Step 6, Identification: the robot's real geometry from the measured marker positions.

The page reads the project's measurements.csv, runs app.jobs.identification.run_identification
(core.identification.solver.identify) on a worker thread (progress, Cancel), and draws what it
returns: the parameter table (nominal → identified ± σ, the parameters that were not estimated
greyed with their explanation), the errors per pose before and after and their histogram, the
cost per iteration, the correlation matrix, the validation figures and the warnings. In the
virtual lab it also measures the calibrated model against the lab's TRUE robot on fresh poses
(the accuracy a teacher wants to show), and offers ideal synthetic measurements when the
Measurement step has not produced any.
"""
from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFileDialog, QHBoxLayout, QLabel, QVBoxLayout

from app.jobs.identification import IdentificationRun, generate_ideal_measurements, run_identification
from app.lab import DEFAULT_POSES, DEFAULT_SIGMA_MM
from app.pages.base import WizardPage, out_of_date
from app.pages.forms import button
from app.pages.identification.options_panel import OptionsPanel
from app.pages.identification.results_panel import ResultsPanel
from app.pages.identification.source_panel import SourcePanel
from app.pages.identification.texts import NO_PROJECT, measurements_html, missing_html, unusable_html
from app.pages.steps import Step
from core.errors import RoboCalError
from core.identification.exports import export_model
from core.identification.result import IdentificationResult
from core.identification.file import write_calibrated_model
from core.measurement.file import read_measurements
from core.measurement.synthetic import synthetic_description
from core.project import Output
from core.provenance import changed_inputs, changed_since, fingerprint, record_inputs


class IdentificationPage(WizardPage):
    step = Step.IDENTIFICATION

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.run_result: IdentificationRun | None = None
        self.saved_path: Path | None = None
        self._made_from: dict[str, str | None] | None = None    # digests of the inputs of `run_result`
        self._ready = False                 # measurements.csv exists and reads for the robot
        self.source = SourcePanel(on_ideal=self.use_ideal_measurements)
        self.options = OptionsPanel(self.task.progress_row(), robot=lambda: self.state.robot,
                                    on_identify=self.start_identification)
        self.results = ResultsPanel()
        self.save_button = button("Save calibrated.json", on_click=self.save_calibrated,
                                  tooltip="Write the calibrated robot model (with its calibration section) into "
                                          "the project folder")
        self.csv_button = button("Export DH table (CSV)…", on_click=lambda: self.export_file("dh-csv"))
        self.urdf_button = button("Export URDF…", on_click=lambda: self.export_file("urdf"))
        self.status.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addWidget(self.source)
        layout.addWidget(self.options)
        layout.addWidget(self.results, 1)
        layout.addWidget(self.status)
        exports = QHBoxLayout()
        exports.addWidget(QLabel("Calibrated model:"))
        exports.addStretch(1)
        for b in (self.save_button, self.csv_button, self.urdf_button):
            exports.addWidget(b)
        layout.addLayout(exports)

        state.projectChanged.connect(self._context_changed)
        state.robotChanged.connect(self._context_changed)
        state.measurementsChanged.connect(lambda *_: self._inputs_changed())
        state.outputSaved.connect(lambda key: self._inputs_changed() if key == "measurements" else None)
        self.options.set_busy(False)
        self._show_result()
        self._refresh_source()

    # -- state ---------------------------------------------------------------------------
    @property
    def result(self) -> IdentificationResult | None:
        return self.run_result.result if self.run_result is not None else None

    def measurements_path(self) -> Path | None:
        return self.state.project.path(Output.MEASUREMENTS) if self.state.project is not None else None

    def inputs(self) -> dict[str, Path]:
        """The project files an identification is made from, by name."""
        path = self.measurements_path()
        return {path.name: path} if path is not None else {}

    def changed_inputs(self) -> list[str]:
        """The inputs that changed since this session's result (or the project's calibrated.json)
        was made from them: [] when up to date or nothing is known."""
        if self.state.project is None:
            return []
        if self.run_result is not None:
            return changed_since(self._made_from, self.inputs())
        return changed_inputs(self.state.project.path(Output.CALIBRATED), self.inputs())

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
        self.run_result = None
        self.saved_path = None
        self._made_from = None
        self._show_result()
        self.options.rebuild_fix_menu()
        self._refresh_source()
        self.notify_complete()

    # -- WizardPage ----------------------------------------------------------------------
    def on_enter(self) -> None:
        self.options.rebuild_fix_menu()
        self._inputs_changed()

    def is_complete(self) -> bool:
        return self.run_result is not None and not self.changed_inputs()

    def on_busy_changed(self) -> None:
        busy = self.task.busy
        self.options.set_busy(busy)
        self.options.run_button.setEnabled(self._ready and not busy)
        self.source.ideal_button.setEnabled(not busy)
        self._update_export_buttons()

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
        state = self.state
        path = self.measurements_path()
        self._ready = False
        if state.project is None or state.robot is None:
            self.source.show_source(NO_PROJECT, offer_ideal=False)
        elif not path.is_file():
            self.source.show_source(missing_html(path, state.virtual), offer_ideal=state.virtual)
        else:
            try:
                meas = read_measurements(path, state.robot)
            except RoboCalError as exc:
                self.source.show_source(unusable_html(exc.message), offer_ideal=False)
            else:
                self.source.show_source(measurements_html(path, meas, synthetic_description(path)),
                                        offer_ideal=False)
                self._ready = True
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
            opts = self.options.options()
        except RoboCalError as exc:
            self._set_status(exc.message, ok=False)
            return False

        def identify(lab=None) -> bool:
            made_from = fingerprint(self.inputs())            # the measurements as the run reads them

            def identified(run: IdentificationRun) -> None:
                self._made_from = made_from
                self._identified(run)

            return self.task.start(run_identification, state.robot, path, seed=state.seed, lab=lab, **opts,
                              on_done=identified, label="Identifying", status="Identifying…")

        return self.task.with_lab(identify, status="Identifying…") if state.virtual else identify()

    def _identified(self, run: IdentificationRun) -> None:
        self.run_result = run
        self.saved_path = None
        self.state.set_identification(run.result, run.accuracy)
        self._show_result()
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
        kept = " The previous result is kept." if self.run_result is not None else ""
        self._set_status("Cancelled." + kept, ok=False)
        self._finish_autopilot(False, "cancelled")

    # -- display -------------------------------------------------------------------------
    def _show_result(self) -> None:
        self.results.show_run(self.run_result)
        self._update_export_buttons()

    def _update_export_buttons(self) -> None:
        has = self.run_result is not None and not self.task.busy
        for b in (self.save_button, self.csv_button, self.urdf_button):
            b.setEnabled(has)

    # -- exports -------------------------------------------------------------------------
    def save_calibrated(self) -> bool:
        """Write calibrated.json into the project (atomically)."""
        if self.result is None or self.state.project is None:
            return False
        path = self.state.project.path(Output.CALIBRATED)
        try:
            write_calibrated_model(self.result, path)
            if self._made_from is not None:
                record_inputs(path, self._made_from, hashed=True)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", ok=False)
            return False
        self.saved_path = path
        self._set_status(f"✓ Saved {path}", ok=True)
        self.state.output_saved("calibrated")
        return True

    def export_file(self, fmt: str, path: str | Path | None = None) -> Path | None:
        """Export the calibrated model as "dh-csv" or "urdf"; asks for the file without `path`."""
        if self.result is None:
            return None
        if path is None:
            folder = self.state.project.folder if self.state.project is not None else Path.home()
            if fmt == "urdf":
                default, filt = folder / "calibrated.urdf", "URDF (*.urdf);;All files (*)"
            else:
                default, filt = folder / "calibrated_dh.csv", "CSV table (*.csv);;All files (*)"
            title = "Export the calibrated URDF" if fmt == "urdf" else "Export the calibrated DH table"
            chosen, _ = QFileDialog.getSaveFileName(self, title, str(default), filt)
            if not chosen:
                return None
            path = chosen
        try:
            out = export_model(self.result.model, fmt, path)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", ok=False)
            return None
        self._set_status(f"✓ Exported {out}", ok=True)
        return out
