"""Step 4, Pose sequence: robot configurations that make the geometric parameters observable.

The page runs core.poses.selection.select_poses on a worker thread (progress, Cancel) and
draws what it returns: the chosen observability index versus the number of poses beside the
median of random selections, the comparison with random selection in numbers, the selected
poses as a table (joint values, marker depth) and on two orthographic views of the workspace
(top x–z and side z–y in the left camera frame: the cameras with their fields of view, the
candidate and selected marker positions, the arm of the highlighted pose). In the virtual lab
the candidates are limited to poses where both cameras see the marker, above the table. The
result goes to the Measurement step as ``state.poses`` (a PoseSelectionResult:
``.Q`` rad/mm, ``.q_file`` deg/mm, ``.path``) and as the project's poses.csv.
"""
from __future__ import annotations

import html
import math
from dataclasses import dataclass

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtWidgets import (QAbstractItemView, QComboBox, QDoubleSpinBox, QGridLayout, QHBoxLayout,
                               QHeaderView, QLabel, QPushButton, QSizePolicy, QSpinBox, QSplitter,
                               QTableWidget, QTableWidgetItem, QVBoxLayout, QWidget)

from app.pages.base import WizardPage
from app.lab import build_lab, lab_options
from app.pages.steps import Step
from core.errors import RoboCalError
from core.robot.model import RobotModel
from core.poses.candidates import arm_polyline
from core.poses.file import PoseList, read_poses
from core.poses.selection import (INDEXES, PoseSelectionResult, lower_is_better,
                                 select_poses, write_selection)
from core.task import Monitor
from widgets.index_curve_plot import IndexCurvePlot
from widgets.workspace_views import WorkspaceViews, camera_wedges

DEMO_COUNT = 30
DEMO_CANDIDATES = 1000
INDEX_CHOICES = [
    ("cond", "Condition number κ (smaller is better)"),
    ("O1", "O1: D-optimal, volume of the error ellipsoid"),
    ("O3", "O3: E-optimal, smallest singular value"),
    ("O4", "O4: noise amplification index"),
    ("O5", "O5: A-optimal, mean variance"),
]
AXIS_LABELS = {     # Φ is scaled to mm of marker motion per mm (or per reach·rad): indices have no unit
    "cond": "condition number κ (–)",
    "O1": "O1, D-optimal (no unit)",
    "O3": "O3 = σ_min (no unit)",
    "O4": "O4 = σ_min²/σ_max (no unit)",
    "O5": "O5, A-optimal (no unit)",
}
SHORT = {"cond": "κ", "O1": "O1", "O3": "O3", "O4": "O4", "O5": "O5"}


# -- the work (plain Python, run on a worker thread) -------------------------------------
@dataclass
class PoseRun:
    result: PoseSelectionResult
    lab: object | None = None


def run_pose_selection(robot: RobotModel, count: int, *, index: str = "cond", candidates: int = 1000,
                       margin: float = 5.0, seed: int = 0, lab=None, lab_args=None,
                       progress=None, cancelled=None) -> PoseRun:
    """Select poses for `robot`; in the virtual lab (`lab`, or `lab_args` = (seed, noise) to build
    it here, off the GUI thread) with its cameras, placed robot and table."""
    monitor = Monitor(progress, cancelled)
    if lab is None and lab_args is not None:
        monitor.step(0.0, "building the virtual lab")
        lab = build_lab(robot, lab_args[0], lab_args[1])
    options = lab_options(lab) if lab is not None else {"robot": robot}
    model = options.pop("robot")
    result = select_poses(model, count, candidates=candidates, index=index, seed=seed, margin=margin,
                          progress=progress, cancelled=cancelled, **options)
    return PoseRun(result, lab)


def _esc(text) -> str:
    return html.escape(str(text))


def _num(v: float) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{v:.3g}"


def comparison_html(r: PoseSelectionResult) -> str:
    """The selection against random selections, in words and a small table."""
    key = r.index
    v, med = r.value(key), r.random_median(key)
    better = (v < med) if lower_is_better(key) else (v > med)
    factor = (med / v if lower_is_better(key) else v / med) if v and med else math.nan
    head = (f"<b>{SHORT[key]} = {_num(v)}</b> for the {r.count} selected poses, against {_num(med)} for "
            f"the median of {r.random.trials} random selections of {r.count} from the same candidates: "
            + (f"<b>{factor:.2f}× {'better' if better else 'worse'}</b>." if math.isfinite(factor) else "."))
    rows = "".join(
        f"<tr><td>{SHORT[k]} {'↓' if lower_is_better(k) else '↑'}</td><td align='right'>{_num(r.value(k))}</td>"
        f"<td align='right'>{_num(r.random_median(k))}</td></tr>"
        for k in INDEXES)
    table = ("<table cellspacing='0' cellpadding='1'><tr><th align='left'>index&nbsp;</th>"
             "<th align='right'>&nbsp;selected</th><th align='right'>&nbsp;&nbsp;random</th></tr>"
             f"{rows}</table>")
    return f"{head}{table}<span style='color:#5f6368'>↓ smaller is better, ↑ larger is better.</span>"


def facts_html(r: PoseSelectionResult) -> str:
    """Candidates and rejections, travel, the smallest N."""
    c = r.candidates
    rejected = ", ".join(f"{_esc(k)} {n}" for k, n in c.rejected.items() if n) or "none"
    facts = (f"Candidates: {len(c)} feasible of {c.drawn} drawn (rejected: {rejected}). "
             f"Travel from home: {r.travel_before:.0f}° → <b>{r.travel_after:.0f}°</b> after ordering "
             f"(largest joint move per step, summed). {len(r.parameters)} identifiable parameters: at least "
             f"{r.n_min} poses, about {r.recommended} recommended.")
    warn = "".join(f" <span style='color:#8a4b00'>Note: {_esc(w)}.</span>" for w in r.warnings)
    return facts + warn


class PosesPage(WizardPage):
    step = Step.POSES

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.run_result: PoseRun | None = None
        self.loaded: PoseList | None = None      # a poses.csv found in the project (no selection run)
        self._lab = None
        self._handle = None
        self._token = 0

        # -- controls --------------------------------------------------------------------
        self.count_spin = QSpinBox()
        self.count_spin.setObjectName("countSpin")
        self.count_spin.setRange(1, 500)
        self.count_spin.setValue(DEMO_COUNT)
        self.count_spin.setToolTip("How many poses the robot will be measured in")
        self.index_combo = QComboBox()
        self.index_combo.setObjectName("indexCombo")
        for key, text in INDEX_CHOICES:
            self.index_combo.addItem(text, key)
        self.index_combo.setToolTip("The observability index the selection optimises (see Explain)")
        self.candidates_spin = QSpinBox()
        self.candidates_spin.setObjectName("candidatesSpin")
        self.candidates_spin.setRange(50, 20000)
        self.candidates_spin.setSingleStep(500)
        self.candidates_spin.setValue(DEMO_CANDIDATES)
        self.candidates_spin.setToolTip("Feasible random configurations to choose from")
        self.margin_spin = QDoubleSpinBox()
        self.margin_spin.setObjectName("marginSpin")
        self.margin_spin.setRange(0.0, 45.0)
        self.margin_spin.setDecimals(1)
        self.margin_spin.setValue(5.0)
        self.margin_spin.setSuffix(" °")
        self.margin_spin.setToolTip("Distance kept from every joint limit (mm for prismatic joints)")
        self.seed_spin = QSpinBox()
        self.seed_spin.setObjectName("seedSpin")
        self.seed_spin.setRange(0, 1_000_000)
        self.seed_spin.setToolTip("Seed of the random candidates: the same seed gives the same poses")
        self.select_button = QPushButton("Select poses")
        self.select_button.setObjectName("selectButton")
        self.select_button.clicked.connect(lambda: self.start_selection())
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setObjectName("cancelButton")
        self.cancel_button.setEnabled(False)
        self.cancel_button.clicked.connect(self.cancel)

        controls = QGridLayout()
        controls.setContentsMargins(0, 0, 0, 0)
        controls.setHorizontalSpacing(8)
        controls.setVerticalSpacing(4)
        controls.addWidget(QLabel("Poses N:"), 0, 0)
        controls.addWidget(self.count_spin, 0, 1)
        controls.addWidget(QLabel("Index:"), 0, 2)
        controls.addWidget(self.index_combo, 0, 3, 1, 3)
        controls.addWidget(self.select_button, 0, 6)
        controls.addWidget(QLabel("Candidates:"), 1, 0)
        controls.addWidget(self.candidates_spin, 1, 1)
        controls.addWidget(QLabel("Joint margin:"), 1, 2)
        controls.addWidget(self.margin_spin, 1, 3)
        controls.addWidget(QLabel("Seed:"), 1, 4)
        controls.addWidget(self.seed_spin, 1, 5)
        controls.addWidget(self.cancel_button, 1, 6)
        controls.setColumnStretch(3, 1)

        # -- results ---------------------------------------------------------------------
        self.curve_plot = IndexCurvePlot()
        self.curve_plot.setMinimumHeight(170)
        self.summary = QLabel()
        self.summary.setObjectName("summaryLabel")
        self.summary.setWordWrap(True)
        self.summary.setTextFormat(Qt.TextFormat.RichText)
        self.summary.setAlignment(Qt.AlignmentFlag.AlignTop | Qt.AlignmentFlag.AlignLeft)
        self.summary.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        self.summary.setSizePolicy(QSizePolicy.Policy.Preferred, QSizePolicy.Policy.Preferred)
        self.facts = QLabel()
        self.facts.setObjectName("hint")
        self.facts.setWordWrap(True)
        self.facts.setTextFormat(Qt.TextFormat.RichText)
        self.views = WorkspaceViews()
        self.views.setMinimumHeight(190)
        self.table = QTableWidget(0, 0)
        self.table.setObjectName("posesTable")
        self.table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.table.verticalHeader().setVisible(False)
        self.table.horizontalHeader().setSectionResizeMode(QHeaderView.ResizeMode.Stretch)
        self.table.itemSelectionChanged.connect(self._row_changed)
        self.table.setMinimumHeight(90)

        upper = QWidget()
        ul = QHBoxLayout(upper)
        ul.setContentsMargins(0, 0, 0, 0)
        ul.setSpacing(8)
        ul.addWidget(self.curve_plot, 3)
        ul.addWidget(self.summary, 2)
        self.splitter = QSplitter(Qt.Orientation.Vertical)
        self.splitter.addWidget(upper)
        self.splitter.addWidget(self.views)
        self.splitter.addWidget(self.table)
        self.splitter.setChildrenCollapsible(False)
        self.splitter.setStretchFactor(0, 4)
        self.splitter.setStretchFactor(1, 5)
        self.splitter.setStretchFactor(2, 3)
        self.splitter.setSizes([230, 230, 150])


        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addLayout(controls)
        layout.addWidget(self.splitter, 1)
        layout.addWidget(self.facts)
        layout.addWidget(self.status)

        self.index_combo.currentIndexChanged.connect(self._index_changed)
        state.projectChanged.connect(self._context_changed)
        state.robotChanged.connect(self._context_changed)
        state.labChanged.connect(self._lab_changed)
        self._show()

    # -- state -----------------------------------------------------------------------------
    @property
    def result(self) -> PoseSelectionResult | None:
        return self.run_result.result if self.run_result is not None else None

    @property
    def busy(self) -> bool:
        return self._handle is not None

    def index(self) -> str:
        return self.index_combo.currentData()

    def set_index(self, key: str) -> None:
        self.index_combo.setCurrentIndex(self.index_combo.findData(key))

    def _lab_changed(self, lab) -> None:
        if lab is not None and lab is not self._lab and self._lab is None:
            self._lab = lab

    def _context_changed(self, *_):
        """Another project or robot: the selection no longer applies."""
        self._token += 1
        if self._handle is not None:
            self._handle.cancel()
            self._handle = None
        self._lab = None
        self.run_result = None
        self.loaded = None
        self._set_busy(False)
        self._load_existing()
        self._show()
        self.notify_complete()

    def _load_existing(self) -> None:
        """A poses.csv already in the project (an earlier session) counts as the selection."""
        project, robot = self.state.project, self.state.robot
        if self.result is not None or project is None or robot is None or not project.has("poses"):
            return
        try:
            self.loaded = read_poses(project.path("poses"), robot)
        except RoboCalError as exc:
            self.loaded = None
            self._set_status(f"The project's poses.csv cannot be used ({exc.message}); select the poses again.",
                             ok=False)

    # -- WizardPage ------------------------------------------------------------------------
    def on_enter(self) -> None:
        if self.result is None and self.loaded is None:
            self._load_existing()
            self._show()
        self.notify_complete()

    def is_complete(self) -> bool:
        return self.result is not None or self.loaded is not None

    def autopilot(self, done) -> None:
        if self.state.project is None or self.state.robot is None:
            done(False, "no project or robot model (Setup step)")
            return
        self.count_spin.setValue(DEMO_COUNT)
        self.candidates_spin.setValue(DEMO_CANDIDATES)
        self.set_index("cond")
        self._autopilot_done = done
        if not self.start_selection():
            self._finish_autopilot(False, self.status.text() or "pose selection could not start")

    # -- the work ----------------------------------------------------------------------------
    def start_selection(self) -> bool:
        if self.busy:
            return False
        robot = self.state.robot
        if robot is None:
            self._set_status("Choose a robot model in the Setup step first.", ok=False)
            return False
        kwargs = dict(index=self.index(), candidates=self.candidates_spin.value(), margin=self.margin_spin.value(),
                      seed=self.seed_spin.value())
        if self.state.virtual:
            kwargs.update({"lab": self._lab} if self._lab is not None else {"lab_args": (self.state.seed, self.state.noise)})
        self._token += 1
        token = self._token
        self._handle = self.run_task(run_pose_selection, robot, self.count_spin.value(),
                                     on_result=lambda run: self._selected(token, run),
                                     on_error=lambda msg: self._failed(token, msg),
                                     on_cancelled=lambda: self._cancelled(token),
                                     label="Selecting poses", **kwargs)
        self._set_busy(True)
        self._set_status(f"Selecting {self.count_spin.value()} poses by {SHORT[self.index()]}…", ok=None)
        return True

    def cancel(self) -> None:
        if self._handle is not None:
            self._handle.cancel()

    def _selected(self, token: int, run: PoseRun) -> None:
        if token != self._token:
            return
        self._handle = None
        self._set_busy(False)
        if run.lab is not None:
            self._lab = run.lab
            self.state.adopt_lab(run.lab)
        self.run_result = run
        self.loaded = None
        written = ""
        if self.state.project is not None:
            try:
                path = write_selection(run.result, self.state.project.path("poses"))
                written = f" Written to {path.name} for the Measurement step."
            except RoboCalError as exc:
                self.show_error(exc.message)
                written = " (poses.csv could not be written)"
        self.state.set_poses(run.result)
        self._show()
        r = run.result
        self._set_status(f"✓ {r.count} poses selected in {r.seconds:.1f} s.{written}", ok=True)
        self.notify_complete()
        if self._autopilot_done is not None:
            self._finish_autopilot(True, f"{r.count} poses, {SHORT[r.index]} {r.value():.3g} "
                                         f"(random median {r.random_median():.3g})")

    def _failed(self, token: int, message: str) -> None:
        if token != self._token:
            return
        self._handle = None
        self._set_busy(False)
        self._set_status(f"✗ {message}", ok=False)
        self._finish_autopilot(False, message)

    def _cancelled(self, token: int) -> None:
        if token != self._token:
            return
        self._handle = None
        self._set_busy(False)
        kept = " The previous selection is kept." if self.is_complete() else ""
        self._set_status("Cancelled." + kept, ok=False)
        self._finish_autopilot(False, "cancelled")

    def _set_busy(self, busy: bool) -> None:
        self.select_button.setEnabled(not busy)
        self.cancel_button.setEnabled(busy)
        for w in (self.count_spin, self.index_combo, self.candidates_spin, self.margin_spin, self.seed_spin):
            w.setEnabled(not busy)

    # -- drawing ---------------------------------------------------------------------------
    def _index_changed(self, *_):
        """Show the curve of the newly chosen index for the current selection (the selection
        itself optimised the index it was run with)."""
        self._show_curve()

    def _show(self) -> None:
        self._show_curve()
        self._show_summary()
        self._fill_table()
        self._show_views()
        if self.result is None and self.loaded is None and not self.busy:
            if self.state.robot is None:
                self._set_status("Choose a robot model in the Setup step first.", ok=False)
            else:
                where = "the virtual lab's cameras" if self.state.virtual else "the robot (no camera constraint)"
                self._set_status(f"Choose N and the index, then Select poses (candidates for {where}).", ok=None)
        elif self.loaded is not None and self.result is None:
            self._set_status(f"✓ {len(self.loaded)} poses from the project's poses.csv. Select again to see "
                             "their observability.", ok=True)

    def _show_curve(self) -> None:
        r = self.result
        if r is None:
            self.curve_plot.clear_curve()
            return
        key = self.index()
        c = r.curve
        label = "selected poses" + ("" if key == r.index else f" (chosen by {SHORT[r.index]})")
        self.curve_plot.set_curve(c.n, c.selected[key], c.random_median[key], c.random_q25[key], c.random_q75[key],
                                  count=r.count, y_label=AXIS_LABELS[key], log_y=(key == "cond"),
                                  selected_label=label, legend_corner="right" if lower_is_better(key) else "left",
                                  random_label=f"random selections: median of {r.random.trials}")

    def _show_summary(self) -> None:
        r = self.result
        self.facts.setText(facts_html(r) if r is not None else "")
        self.facts.setVisible(r is not None)
        if r is not None:
            self.summary.setText(comparison_html(r))
        elif self.loaded is not None:
            self.summary.setText(f"{len(self.loaded)} poses read from <code>{_esc(self.loaded.path)}</code>.")
        else:
            self.summary.setText("<span style='color:#5f6368'>The plot will show how the chosen index "
                                 "improves as poses are added, next to random selections of the same size. "
                                 "The flatter the curve at N, the less more poses would help.</span>")

    def _robot_for_views(self) -> RobotModel | None:
        r = self.result
        if r is not None:
            return r.robot
        if self._lab is not None:
            return self._lab.nominal_robot
        return self.state.robot

    def _fill_table(self) -> None:
        r = self.result
        robot = self._robot_for_views()
        q_file = r.q_file if r is not None else (self.loaded.q_file if self.loaded is not None else None)
        self.table.blockSignals(True)
        self.table.clearSelection()
        if q_file is None or robot is None:
            self.table.setRowCount(0)
            self.table.setColumnCount(0)
            self.table.blockSignals(False)
            return
        depth = r.depth if r is not None else None
        if depth is None and r is None and self._lab is not None:
            depth = robot.target_positions(self.loaded.Q, self._lab.target)[:, 2]
        headers = ["Pose"] + [f"q{j + 1} ({'°' if jt.revolute else 'mm'})" for j, jt in enumerate(robot.joints)]
        if depth is not None:
            headers.append("Depth (mm)")
        self.table.setColumnCount(len(headers))
        self.table.setHorizontalHeaderLabels(headers)
        self.table.setRowCount(len(q_file))
        for i, row in enumerate(q_file):
            cells = [str(i)] + [f"{v:.3f}" for v in row] + ([f"{depth[i]:.0f}"] if depth is not None else [])
            for j, text in enumerate(cells):
                item = QTableWidgetItem(text)
                item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
                self.table.setItem(i, j, item)
        self.table.blockSignals(False)
        if len(q_file):
            self.table.selectRow(0)

    def _selected_Q(self) -> np.ndarray | None:
        if self.result is not None:
            return self.result.Q
        if self.loaded is not None:
            return self.loaded.Q
        return None

    def _show_views(self) -> None:
        robot = self._robot_for_views()
        Q = self._selected_Q()
        lab = self._lab
        if robot is None or Q is None:
            self.views.set_scene(wedges=camera_wedges(lab.rig) if lab is not None else None)
            return
        target = self.result.targets[0] if self.result is not None else next(iter(robot.targets), None)
        markers = robot.target_positions(Q, target) if target else np.zeros((0, 3))
        candidates = self.result.candidates.marker if self.result is not None else None
        depth = 1000.0
        if self.result is not None and self.result.depth is not None and len(self.result.depth):
            depth = float(max(900.0, np.max(self.result.depth) * 1.1))
        arms, _ = arm_polyline(robot, Q, target)
        self.views.set_scene(wedges=camera_wedges(lab.rig, depth) if lab is not None else None,
                             candidates=candidates, selected=markers, extent=arms.reshape(-1, 3))
        self._row_changed()

    def _row_changed(self) -> None:
        robot = self._robot_for_views()
        Q = self._selected_Q()
        rows = self.table.selectionModel().selectedRows() if self.table.selectionModel() else []
        if robot is None or Q is None or not rows:
            self.views.set_highlight(None)
            return
        i = rows[0].row()
        if not 0 <= i < len(Q):
            return
        target = self.result.targets[0] if self.result is not None else next(iter(robot.targets), None)
        pts, _ = arm_polyline(robot, Q[i:i + 1], target)
        self.views.set_highlight(pts[0], pts[0, -1:] if target else None)

    def highlight(self, row: int) -> None:
        """Select table row `row` (its arm is drawn in the views)."""
        self.table.selectRow(row)

