"""Step 6, Identification: the robot's real geometry from the measured marker positions.

The page reads the project's measurements.csv, runs core.identification.solver.identify on a worker
thread (progress, Cancel), and draws what it returns: the parameter table (nominal →
identified ± σ, the parameters that were not estimated greyed with their explanation), the
errors per pose before and after and their histogram, the cost per iteration, the
correlation matrix, the validation figures and the warnings. In the virtual lab it also
measures the calibrated model against the lab's TRUE robot on fresh poses (the accuracy a
teacher wants to show), and offers ideal synthetic measurements when the Measurement step
has not produced any.
"""
from __future__ import annotations

import html
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtGui import QAction
from PySide6.QtWidgets import (QCheckBox, QComboBox, QDoubleSpinBox, QFileDialog, QGridLayout,
                               QGroupBox, QHBoxLayout, QLabel, QLineEdit, QMenu, QProgressBar, QPushButton,
                               QSizePolicy, QSpinBox, QTabWidget, QTextBrowser, QToolButton, QVBoxLayout,
                               QWidget)

from app.pages.base import WizardPage
from app.lab import build_lab
from app.pages.steps import Step
from core.identification.jacobian import all_parameters, resolve_names
from core.errors import RoboCalError
from core.identification.exports import export_model
from app.lab import DEFAULT_POSES, DEFAULT_SIGMA_MM, ideal_lab_measurements, write_ideal_measurements
from core.measurement.synthetic import synthetic_description
from core.identification.solver import IdentificationResult, identify, write_calibrated_model
from core.robot.model import RobotModel
from core.measurement.file import Measurements, read_measurements
from core.identification.model_comparison import TruthAccuracy, accuracy_against_truth
from core.task import Monitor
from widgets.convergence_plot import ConvergencePlot
from widgets.correlation_view import CorrelationView
from widgets.parameter_table import ParameterTable
from widgets.residual_plots import ResidualPlots

TRUTH_POSES = 200          # fresh random visible poses for the accuracy against the true robot
IDEAL_BUTTON_TEXT = "Use ideal virtual-lab measurements (no images)"
VALIDATION_NONE, VALIDATION_HOLDOUT, VALIDATION_KFOLD = range(3)


# -- the work (plain Python, run on a worker thread) -------------------------------------
@dataclass
class IdentificationRun:
    """What one run hands back to the page."""

    result: IdentificationResult
    measurements: Measurements
    source: Path
    synthetic: str | None = None
    accuracy: TruthAccuracy | None = None
    lab: object | None = None


def run_identification(robot: RobotModel, path: str | Path, *, fixed=(), huber: float | None = None,
                       holdout: float | None = None, kfold: int | None = None, seed: int = 0,
                       lab=None, lab_args: tuple | None = None, truth_poses: int = TRUTH_POSES,
                       progress=None, cancelled=None) -> IdentificationRun:
    """Read the measurements, identify, and (with a lab, or `lab_args` = (seed, noise) to
    build one) compare nominal and calibrated model with the lab's true robot."""
    monitor = Monitor(progress, cancelled)
    path = Path(path)
    monitor.step(0.0, "reading the measurements")
    meas = read_measurements(path, robot)
    with_truth = lab is not None or lab_args is not None
    fit = monitor.sub(0.02, 0.85 if with_truth else 1.0)
    result = identify(robot, meas, fixed=list(fixed), huber=huber, holdout=holdout, kfold=kfold, seed=seed,
                      progress=fit, cancelled=cancelled)
    accuracy = None
    if with_truth:
        monitor.step(0.86, "virtual lab: comparing with the true robot")
        if lab is None:
            lab = build_lab(robot, *lab_args)
        monitor.step(0.95, "virtual lab: comparing with the true robot")
        Q = lab.random_visible_poses(truth_poses, np.random.default_rng([int(seed), 6]))
        accuracy = accuracy_against_truth(lab.true_robot, result.initial, result.model, Q, [lab.target])
    monitor.step(1.0, "done")
    return IdentificationRun(result=result, measurements=meas, source=path,
                             synthetic=synthetic_description(path), accuracy=accuracy, lab=lab)


def generate_ideal_measurements(path: str | Path, *, lab=None, robot: RobotModel | None = None,
                                lab_args: tuple | None = None, n_poses: int = DEFAULT_POSES,
                                sigma_mm: float = DEFAULT_SIGMA_MM, seed: int = 0,
                                progress=None, cancelled=None):
    """Ideal measurements of the lab's true robot written to `path`; returns (path, lab)."""
    monitor = Monitor(progress, cancelled)
    if lab is None:
        monitor.step(0.0, "building the virtual lab")
        lab = build_lab(robot, *lab_args)
    monitor.step(0.7, "choosing visible poses")
    meas = ideal_lab_measurements(lab, n_poses, sigma_mm=sigma_mm, seed=np.random.default_rng([int(seed), 5]))
    monitor.step(0.9, "writing measurements.csv")
    write_ideal_measurements(meas, path, sigma_mm=sigma_mm)
    monitor.step(1.0, "done")
    return Path(path), lab


# -- text helpers ----------------------------------------------------------------------------
def _esc(text) -> str:
    return html.escape(str(text))


def _mm(v: float | None, digits: int = 3) -> str:
    return "—" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def _stats_rows(rows: list[tuple[str, object]]) -> str:
    out = ['<table cellspacing="0" cellpadding="3" border="0">',
           '<tr><th align="left"></th><th align="right">mean</th><th align="right">RMS</th>'
           '<th align="right">max</th><th align="right">points</th></tr>']
    for label, s in rows:
        out.append(f'<tr><td>{_esc(label)}&nbsp;&nbsp;</td><td align="right">{_mm(s.mean_mm)}</td>'
                   f'<td align="right"><b>{_mm(s.rms_mm)}</b></td><td align="right">{_mm(s.max_mm)}</td>'
                   f'<td align="right">{s.n}</td></tr>')
    out.append("</table>")
    return "".join(out)


def validation_html(run: IdentificationRun) -> str:
    """Validation, real accuracy, fit statistics and warnings as HTML (all in mm)."""
    r = run.result
    parts = []
    v = r.validation
    if v is not None:
        if v.method == "holdout":
            how = (f"{len(v.test_poses)} held-out poses ({v.fraction:.0%} of {r.n_poses + len(v.test_poses)}, "
                   f"seed {v.seed}) that the fit did not see")
        else:
            how = (f"{v.folds}-fold cross validation: each of the {len(v.test_poses)} poses predicted by a model "
                   f"fitted without it (seed {v.seed})")
        parts.append(f"<h3>Validation on poses left out of the fit (mm)</h3><p>{_esc(how)}.</p>")
        parts.append(_stats_rows([("before (nominal, base registered)", v.before),
                                  ("after (calibrated)", v.after)]))
        if v.fold_rms_mm:
            parts.append("<p>RMS per fold: " + ", ".join(f"{x:.3f}" for x in v.fold_rms_mm) + " mm</p>")
    else:
        parts.append("<h3>Validation</h3><p>No poses were left out: choose a hold-out fraction or k-fold "
                     "cross validation to check the model on poses the fit did not see.</p>")
    if run.accuracy is not None:
        a = run.accuracy
        parts.append(f"<h3>Real accuracy: against the virtual lab's true robot (mm)</h3>"
                     f"<p>Marker position of each model vs. the true robot at {a.n_configurations} fresh "
                     f"random visible poses (not measured): what the calibration really gained, "
                     f"{a.improvement:.0f}× more accurate. Compared after the best rigid alignment of "
                     f"the frames: the measured camera frame is off the true one by the stereo "
                     f"calibration's own error (without alignment the calibrated model is "
                     f"{a.calibrated.raw_rms_mm:.3f} mm RMS off).</p>")
        parts.append(_stats_rows([("nominal model (base registered)", a.nominal),
                                  ("calibrated model", a.calibrated)]))
    parts.append(f"<h3>Fitted poses (mm)</h3><p>{r.n_poses} poses, {r.n_points} points.</p>")
    parts.append(_stats_rows([("before (nominal, base registered)", r.before), ("after (calibrated)", r.after)]))
    obs = r.observability
    parts.append("<h3>Fit</h3><ul>"
                 f"<li>{r.n_iterations} iterations, {'converged' if r.converged else 'NOT converged'}; "
                 f"σ̂ = {r.sigma_hat_text} ({r.dof} degrees of freedom)</li>"
                 f"<li>{len(r.estimated)} parameters estimated, rank {r.rank}; "
                 f"condition number κ = {r.condition_number:.4g} of the column-scaled Φ</li>"
                 f"<li>observability O1 = {obs.o1:.3g}, O2 = 1/κ = {obs.o2:.3g}, O3 = σ<sub>min</sub> = {obs.o3:.3g}</li>"
                 f"<li>{len(r.unidentifiable)} parameters not identifiable (kept at nominal)"
                 + (f"; {len(r.outliers)} outlier point(s), Huber k = {r.huber:g}" if r.huber else "")
                 + "</li></ul>")
    if r.warnings:
        parts.append("<h3>Warnings</h3><ul>" + "".join(f"<li>{_esc(w)}</li>" for w in r.warnings) + "</ul>")
    return "".join(parts)


def summary_text(run: IdentificationRun) -> str:
    r = run.result
    text = (f"RMS position error {r.before.rms_mm:.3f} → <b>{r.after.rms_mm:.3f} mm</b> on {r.n_poses} fitted poses")
    if r.validation is not None:
        text += (f"; on poses left out: {r.validation.before.rms_mm:.3f} → "
                 f"<b>{r.validation.after.rms_mm:.3f} mm</b>")
    if run.accuracy is not None:
        text += (f"; against the true robot: {run.accuracy.nominal.rms_mm:.3f} → "
                 f"<b>{run.accuracy.calibrated.rms_mm:.3f} mm</b>")
    text += (f". {len(r.estimated)} parameters estimated (rank {r.rank}, κ = {r.condition_number:.3g}), "
             f"{len(r.unidentifiable)} not identifiable, {r.n_iterations} iterations.")
    return text


# -- the page --------------------------------------------------------------------------------
class IdentificationPage(WizardPage):
    step = Step.IDENTIFICATION

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.run_result: IdentificationRun | None = None
        self.saved_path: Path | None = None
        self._handle = None
        self._token = 0
        self._lab = None                 # the state's lab (from labChanged) or one built for this page
        self._fix_actions: dict[str, QAction] = {}

        # -- measurements --------------------------------------------------------------
        self.source_label = QLabel()
        self.source_label.setObjectName("sourceLabel")
        self.source_label.setWordWrap(True)
        self.source_label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.ideal_button = QPushButton(IDEAL_BUTTON_TEXT)
        self.ideal_button.setObjectName("idealButton")
        self.ideal_button.setToolTip(
            f"Teaching aid: the virtual lab's TRUE robot at {DEFAULT_POSES} random poses where both cameras "
            f"see the marker, plus Gaussian noise σ = {DEFAULT_SIGMA_MM:g} mm. No images are rendered or "
            "measured. Written to the project's measurements.csv, marked as synthetic.")
        self.ideal_button.clicked.connect(lambda: self.use_ideal_measurements())
        source_box = QGroupBox("Measurements")
        sl = QHBoxLayout(source_box)
        sl.addWidget(self.source_label, 1)
        sl.addWidget(self.ideal_button, 0, Qt.AlignmentFlag.AlignTop)

        # -- options -------------------------------------------------------------------
        self.validation_combo = QComboBox()
        self.validation_combo.addItems(["No validation", "Hold out poses", "k-fold cross validation"])
        self.validation_combo.setCurrentIndex(VALIDATION_HOLDOUT)
        self.holdout_spin = QSpinBox()
        self.holdout_spin.setRange(5, 50)
        self.holdout_spin.setValue(25)
        self.holdout_spin.setSuffix(" % of the poses")
        self.kfold_spin = QSpinBox()
        self.kfold_spin.setRange(2, 20)
        self.kfold_spin.setValue(5)
        self.kfold_spin.setSuffix(" folds")
        self.validation_combo.currentIndexChanged.connect(self._validation_changed)
        self.huber_check = QCheckBox("Robust (Huber), k =")
        self.huber_check.setToolTip("Down-weight points whose error is beyond k robust standard deviations "
                                    "and flag outliers (a marker found in the wrong place).")
        self.huber_spin = QDoubleSpinBox()
        self.huber_spin.setRange(1.0, 10.0)
        self.huber_spin.setSingleStep(0.5)
        self.huber_spin.setValue(3.0)
        self.huber_spin.setEnabled(False)
        self.huber_check.toggled.connect(self.huber_spin.setEnabled)
        self.fix_edit = QLineEdit()
        self.fix_edit.setObjectName("fixEdit")
        self.fix_edit.setPlaceholderText("parameters kept at nominal, e.g. J6.d, marker.z")
        self.fix_edit.textEdited.connect(self._sync_fix_menu)
        self.fix_button = QToolButton()
        self.fix_button.setText("Choose ▾")
        self.fix_button.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        self.fix_menu = QMenu(self)
        self.fix_button.setMenu(self.fix_menu)
        self.run_button = QPushButton("Identify")
        self.run_button.setObjectName("identifyButton")
        self.run_button.setDefault(True)
        self.run_button.clicked.connect(lambda: self.start_identification())
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setEnabled(False)
        self.cancel_button.clicked.connect(self.cancel)
        self.progress = QProgressBar()
        self.progress.setRange(0, 1000)
        self.progress.setTextVisible(True)
        self.progress.setFormat("")
        self.progress.setVisible(False)
        options_box = QGroupBox("Options")
        grid = QGridLayout(options_box)
        grid.setHorizontalSpacing(8)
        grid.addWidget(QLabel("Validation:"), 0, 0)
        vrow = QHBoxLayout()
        vrow.addWidget(self.validation_combo)
        vrow.addWidget(self.holdout_spin)
        vrow.addWidget(self.kfold_spin)
        vrow.addSpacing(12)
        vrow.addWidget(self.huber_check)
        vrow.addWidget(self.huber_spin)
        vrow.addStretch(1)
        grid.addLayout(vrow, 0, 1, 1, 3)
        grid.addWidget(QLabel("Fix:"), 1, 0)
        grid.addWidget(self.fix_edit, 1, 1)
        grid.addWidget(self.fix_button, 1, 2)
        brow = QHBoxLayout()
        brow.addWidget(self.run_button)
        brow.addWidget(self.cancel_button)
        grid.addLayout(brow, 1, 3)
        grid.addWidget(self.progress, 2, 0, 1, 4)
        grid.setColumnStretch(1, 1)
        self._validation_changed()

        # -- results -------------------------------------------------------------------
        self.summary = QLabel()
        self.summary.setObjectName("summaryLabel")
        self.summary.setWordWrap(True)
        self.summary.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.table = ParameterTable()
        self.table.itemSelectionChanged.connect(self._show_explanation)
        self.explanation = QLabel()
        self.explanation.setObjectName("hint")
        self.explanation.setWordWrap(True)
        self.explanation.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.explanation.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
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

        # -- exports -------------------------------------------------------------------
        self.save_button = QPushButton("Save calibrated.json")
        self.save_button.setToolTip("Write the calibrated robot model (with its calibration section) into "
                                    "the project folder")
        self.save_button.clicked.connect(lambda: self.save_calibrated())
        self.csv_button = QPushButton("Export DH table (CSV)…")
        self.csv_button.clicked.connect(lambda: self.export_file("dh-csv"))
        self.urdf_button = QPushButton("Export URDF…")
        self.urdf_button.clicked.connect(lambda: self.export_file("urdf"))
        self.status.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        erow = QHBoxLayout()
        erow.addWidget(QLabel("Calibrated model:"))
        erow.addStretch(1)
        erow.addWidget(self.save_button)
        erow.addWidget(self.csv_button)
        erow.addWidget(self.urdf_button)

        for box in (source_box, options_box):
            box.setSizePolicy(QSizePolicy.Policy.Preferred, QSizePolicy.Policy.Maximum)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addWidget(source_box)
        layout.addWidget(options_box)
        layout.addWidget(self.summary)
        layout.addWidget(self.tabs, 1)
        layout.addWidget(self.status)
        layout.addLayout(erow)

        state.projectChanged.connect(self._context_changed)
        state.robotChanged.connect(self._context_changed)
        state.labChanged.connect(self._lab_changed)
        self._show_result()
        self._refresh_source()

    # -- state ---------------------------------------------------------------------------
    @property
    def result(self) -> IdentificationResult | None:
        return self.run_result.result if self.run_result is not None else None

    @property
    def busy(self) -> bool:
        return self._handle is not None

    def measurements_path(self) -> Path | None:
        return self.state.project.path("measurements") if self.state.project is not None else None

    def _lab_changed(self, lab) -> None:
        self._lab = lab

    def _context_changed(self, *_):
        """Another project or robot: the result (and the lab built for it) no longer apply."""
        self._token += 1
        if self._handle is not None:
            self._handle.cancel()
            self._handle = None
            self._set_busy(False)
        self._lab = None
        self.run_result = None
        self.saved_path = None
        self._show_result()
        self._rebuild_fix_menu()
        self._refresh_source()
        self.notify_complete()

    def _lab_source(self) -> dict:
        """How the worker gets the virtual lab: the known one, or (seed, noise) to build it."""
        if not self.state.virtual:
            return {}
        if self._lab is not None:
            return {"lab": self._lab}
        return {"lab_args": (self.state.seed, self.state.noise)}

    # -- WizardPage ----------------------------------------------------------------------
    def on_enter(self) -> None:
        self._rebuild_fix_menu()
        self._refresh_source()

    def is_complete(self) -> bool:
        return self.run_result is not None

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
        virtual = state.virtual
        self.ideal_button.setVisible(False)
        ready = False
        if state.project is None or state.robot is None:
            self.source_label.setText("<b>No project or robot model yet.</b> Choose them in the Setup step (1).")
        elif not path.is_file():
            text = (f"<b>No measurements in this project yet</b> ({_esc(path.name)} is missing). "
                    "Run the <b>Measurement</b> step (5): it drives the robot through the poses, locates the "
                    "marker in 3D and writes measurements.csv. Then come back here.")
            if virtual:
                text += ("<br><span style='color:#8a4b00'>Virtual lab, for teaching: you can also use "
                         f"<b>ideal synthetic measurements</b> — the lab's true robot at {DEFAULT_POSES} random "
                         f"visible poses plus noise σ = {DEFAULT_SIGMA_MM:g} mm, with no images "
                         "(no camera calibration or marker detection involved).</span>")
                self.ideal_button.setVisible(True)
            self.source_label.setText(text)
        else:
            synthetic = synthetic_description(path)
            try:
                meas = read_measurements(path, state.robot)
            except RoboCalError as exc:
                self.source_label.setText(f"<b>The measurements cannot be used:</b> {_esc(exc.message)}<br>"
                                          "Fix or replace the file, or run the Measurement step (5) again.")
            else:
                targets = ", ".join(meas.target_names)
                text = (f"<b>{_esc(path.name)}</b>: {meas.n_poses} poses, {meas.n_points} points "
                        f"(target {_esc(targets)}) — {_esc(path.parent)}")
                if synthetic:
                    text = ("<span style='color:#8a4b00'><b>SYNTHETIC:</b> " + _esc(synthetic)
                            + ".</span><br>" + text)
                self.source_label.setText(text)
                ready = True
        self.run_button.setEnabled(ready and not self.busy)

    def use_ideal_measurements(self, then_identify: bool = False) -> bool:
        """Write ideal virtual-lab measurements into the project (worker thread). Returns
        False (with the reason on the page) when it cannot start."""
        state = self.state
        if self.busy:
            return False
        if state.project is None or state.robot is None or not state.virtual:
            self._set_status("Ideal measurements need a virtual-lab project with a robot model.", ok=False)
            return False
        path = self.measurements_path()
        if path.exists():
            self._set_status(f"{path.name} already exists: it is not replaced.", ok=False)
            return False
        token = self._token
        source = self._lab_source() or {"lab_args": (state.seed, state.noise)}

        def on_result(value):
            if token != self._token:
                return
            self._handle = None
            self._set_busy(False)
            _, lab = value
            if self._lab is None:
                self._lab = lab
                self.state.adopt_lab(lab)
            self._refresh_source()
            self._set_status(f"Ideal synthetic measurements written to {path} ({DEFAULT_POSES} poses, "
                             f"σ = {DEFAULT_SIGMA_MM:g} mm, no images).", ok=True)
            if then_identify and not self.start_identification():
                self._finish_autopilot(False, self.status.text())

        self._handle = self.run_task(generate_ideal_measurements, path, robot=state.robot, seed=state.seed,
                                     on_result=on_result, on_error=lambda m: self._failed(token, m),
                                     on_cancelled=lambda: self._cancelled(token),
                                     on_progress=self._progress, label="Ideal measurements", **source)
        self._set_busy(True, "Generating ideal measurements…")
        return True

    # -- identification ------------------------------------------------------------------
    def options(self) -> dict:
        """The identify() options chosen on the page (raises RoboCalError for unknown names)."""
        mode = self.validation_combo.currentIndex()
        opts = {"huber": float(self.huber_spin.value()) if self.huber_check.isChecked() else None,
                "holdout": self.holdout_spin.value() / 100.0 if mode == VALIDATION_HOLDOUT else None,
                "kfold": self.kfold_spin.value() if mode == VALIDATION_KFOLD else None,
                "fixed": self.fixed_names()}
        return opts

    def fixed_names(self) -> list[str]:
        raw = [t for t in self.fix_edit.text().replace(";", ",").replace(" ", ",").split(",") if t.strip()]
        if not raw:
            return []
        robot = self.state.robot
        return resolve_names(raw, all_parameters(robot, list(robot.targets)), robot)

    def start_identification(self) -> bool:
        """Start the identification on a worker thread; False (reason on the page) if it cannot."""
        state = self.state
        if self.busy:
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
            opts = self.options()
        except RoboCalError as exc:
            self._set_status(exc.message, ok=False)
            return False
        token = self._token
        self._handle = self.run_task(run_identification, state.robot, path, seed=state.seed,
                                     on_result=lambda run: self._identified(token, run),
                                     on_error=lambda m: self._failed(token, m),
                                     on_cancelled=lambda: self._cancelled(token),
                                     on_progress=self._progress, label="Identifying",
                                     **opts, **self._lab_source())
        self._set_busy(True, "Identifying…")
        return True

    def cancel(self) -> None:
        if self._handle is not None:
            self._handle.cancel()

    def _identified(self, token: int, run: IdentificationRun) -> None:
        if token != self._token:
            return
        self._handle = None
        self._set_busy(False)
        if run.lab is not None and self._lab is None:
            self._lab = run.lab
            self.state.adopt_lab(run.lab)
        self.run_result = run
        self.saved_path = None
        self.state.set_identification(run.result, run.accuracy)
        self._show_result()
        self._refresh_source()
        self._set_status("✓ Identified. Save calibrated.json to keep the result in the project.", ok=True)
        self.notify_complete()
        if self._autopilot_done is not None:
            self.tabs.setCurrentWidget(self.residuals)      # the picture a class should see
            if self.save_calibrated():
                self._finish_autopilot(True, "")
            else:
                self._finish_autopilot(False, self.status.text())

    def _failed(self, token: int, message: str) -> None:
        if token != self._token:
            return
        self._handle = None
        self._set_busy(False)
        self._refresh_source()
        self._set_status(f"✗ {message}", ok=False)
        self._finish_autopilot(False, message)

    def _cancelled(self, token: int) -> None:
        if token != self._token:
            return
        self._handle = None
        self._set_busy(False)
        self._refresh_source()
        kept = " The previous result is kept." if self.run_result is not None else ""
        self._set_status("Cancelled." + kept, ok=False)
        self._finish_autopilot(False, "cancelled")

    def _progress(self, fraction: float, message: str) -> None:
        self.progress.setValue(int(round(1000 * fraction)))
        self.progress.setFormat(f"{message}  %p%" if message else "%p%")

    def _set_busy(self, busy: bool, message: str = "") -> None:
        self.cancel_button.setEnabled(busy)
        self.run_button.setEnabled(not busy and self.measurements_path() is not None
                                   and self.measurements_path().is_file() and self.state.robot is not None)
        self.ideal_button.setEnabled(not busy)
        for w in (self.validation_combo, self.holdout_spin, self.kfold_spin, self.huber_check, self.fix_edit,
                  self.fix_button):
            w.setEnabled(not busy)
        self.huber_spin.setEnabled(not busy and self.huber_check.isChecked())
        self.progress.setVisible(busy)
        if busy:
            self.progress.setValue(0)
            self.progress.setFormat(message)
            self._set_status(message, ok=None)
        else:
            self.progress.setValue(0)
            self.progress.setFormat("")
        self._update_export_buttons()

    # -- options widgets -----------------------------------------------------------------
    def _validation_changed(self, *_):
        mode = self.validation_combo.currentIndex()
        self.holdout_spin.setVisible(mode == VALIDATION_HOLDOUT)
        self.kfold_spin.setVisible(mode == VALIDATION_KFOLD)

    def _rebuild_fix_menu(self) -> None:
        self.fix_menu.clear()
        self._fix_actions.clear()
        robot = self.state.robot
        if robot is None:
            return
        try:
            params = all_parameters(robot, list(robot.targets))
        except RoboCalError:
            return
        groups: dict[str, list] = {}
        for p in params:
            groups.setdefault(p.name.split(".")[0], []).append(p)
        for group, members in groups.items():
            sub = self.fix_menu.addMenu(group)
            for p in members:
                action = sub.addAction(p.name)
                action.setCheckable(True)
                action.toggled.connect(self._fix_toggled)
                self._fix_actions[p.name] = action
        self._sync_fix_menu()

    def _fix_toggled(self, *_):
        names = [n for n, a in self._fix_actions.items() if a.isChecked()]
        self.fix_edit.setText(", ".join(names))

    def _sync_fix_menu(self, *_):
        try:
            names = set(self.fixed_names())
        except RoboCalError:
            return
        for name, action in self._fix_actions.items():
            action.blockSignals(True)
            action.setChecked(name in names)
            action.blockSignals(False)

    # -- display -------------------------------------------------------------------------
    def _show_result(self) -> None:
        run = self.run_result
        if run is None:
            self.summary.setText("Run the identification to see the parameters, the errors before and after "
                                 "calibration, and how well the model predicts poses it did not see.")
            self.table.set_rows([])
            self.explanation.setText("")
            self.residuals.clear()
            self.convergence.clear_history()
            self.correlation.clear()
            self.validation_view.setHtml("")
            self._update_export_buttons()
            return
        r = run.result
        self.summary.setText(summary_text(run))
        self.table.set_rows(r.parameters)
        self.table.horizontalHeaderItem(2).setToolTip("Nominal value; for the base pose the registered start "
                                                      "(italic)")
        self._show_explanation()
        before = {p["pose"]: p["error_mm"] for p in r.before.per_pose()}
        after = {p["pose"]: p["error_mm"] for p in r.after.per_pose()}
        poses = list(before)
        caption = (f"Error of each fitted pose: RMS {r.before.rms_mm:.3f} mm before, {r.after.rms_mm:.3f} mm after "
                   "calibration (nominal model with the base registered, then calibrated).")
        if r.outliers:
            caption += f" {len(r.outliers)} outlier point(s) flagged."
        self.residuals.set_errors(poses, [before[p] for p in poses], [after.get(p, math.nan) for p in poses],
                                  r.before.errors, r.after.errors, caption)
        records = [rec for i, rec in enumerate(r.iterations) if i == 0 or not rec.start]
        self.convergence.set_history([rec.iteration for rec in records], [rec.cost for rec in records],
                                     [rec.stage for rec in records])
        self.correlation.set_matrix(r.correlation, r.estimated)
        self.validation_view.setHtml(validation_html(run))
        self._update_export_buttons()

    def _show_explanation(self) -> None:
        rows = self.table.selectionModel().selectedRows() if self.table.selectionModel() else []
        if rows:
            r = rows[0].row()
            text = self.table.explanation(r)
            if text:
                self.explanation.setText(text)
                return
            row = self.table.rows()[r]
            self.explanation.setText(f"{row.name} is estimated: {row.identified:.4f} {row.unit} "
                                     f"(nominal {row.nominal:.4f}).")
            return
        result = self.result
        if result is None:
            self.explanation.setText("")
            return
        excluded = [row for row in result.parameters if not row.identifiable]
        if not excluded:
            self.explanation.setText("Every parameter was estimated.")
            return
        parts = []
        for row in excluded:
            partners = f" ↔ {', '.join(row.partners)}" if row.partners else ""
            parts.append(f"{_esc(row.name)} ({_esc(row.status)}{_esc(partners)})")
        self.explanation.setText("<b>Not estimated</b> (grey, kept at nominal): " + "; ".join(parts)
                                 + ". Select a row (or hover it) for the reason.")

    def _update_export_buttons(self) -> None:
        has = self.run_result is not None and not self.busy
        for b in (self.save_button, self.csv_button, self.urdf_button):
            b.setEnabled(has)

    # -- exports -------------------------------------------------------------------------
    def save_calibrated(self) -> bool:
        """Write calibrated.json into the project (atomically)."""
        if self.result is None or self.state.project is None:
            return False
        path = self.state.project.path("calibrated")
        try:
            write_calibrated_model(self.result, path)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", ok=False)
            return False
        self.saved_path = path
        self._set_status(f"✓ Saved {path}", ok=True)
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
