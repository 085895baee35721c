"""Step 5, Measurement: drive the robot through the pose list, capture, locate, write as it goes.

The page runs core.measurement.run.run_measurements on a worker thread: for each pose the
robot (``state.robot_connection``; in the virtual lab a SimulatedRobot, which refuses joint
values outside the limits) moves, both cameras capture (virtual lab: the pair rendered with a
per-pose seeded generator), the marker is located (core.marker.location.MarkerLocator with the
trained marker and the project's stereo.yaml) and the point is appended to the project's
measurements.csv at once (flushed and fsynced per pose); a pose that gives no point goes to
measurements.rejects.csv with its reason.

Pause waits between poses; Cancel stops after the current pose; Start again resumes where
the run stopped (the poses already measured or rejected are skipped, nothing is measured
twice). Start over moves the old files aside (never deletes them). Stop (Esc, the main
window) stops the robot and cancels the run: the driver refuses every motion until the user
resumes it, and the run ends before the next pose.

The page shows the poses with their status (measured / rejected with the reason / pending),
the current pair as a thumbnail, the measured points in two orthographic views (with the
nominal model's predictions in the virtual lab), and a summary. The step is complete when
measurements.csv holds at least as many poses as identification needs; the path goes to
``state.measurements``.
"""
from __future__ import annotations

import html
import threading
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QBrush, QColor
from PySide6.QtWidgets import (QAbstractItemView, QFileDialog, QGridLayout, QHeaderView, QLabel,
                               QMessageBox, QProgressBar, QPushButton, QSplitter, QTableWidget, QTableWidgetItem,
                               QVBoxLayout, QWidget)

from app import messages
from app.pages.base import WizardPage
from app.lab import build_lab
from app.pages.measurement_inputs import project_marker, stereo_source
from app.pages.steps import Step
from core.errors import RoboCalError
from core.measurement.run import JOINT_TOLERANCE, PoseOutcome, read_rejects, rejects_path_for, run_measurements
from core.measurement.file import read_measurements
from core.poses.file import PoseList, read_poses
from widgets.image_view import ImageView
from widgets.marker_views import marker_pair_thumbnail
from widgets.plot_theme import AFTER, colour
from widgets.workspace_views import ARM, CAMERA, CANDIDATE, HIGHLIGHT, WorkspaceViews, camera_wedges

THUMB_WIDTH = 400            # px per camera in the live thumbnail
MEASURED, REJECTED, PENDING, RUNNING = "measured", "rejected", "pending", "running"
STATUS_COLUMN = 5
STATUS_COLOURS = {MEASURED: "#188038", REJECTED: "#c5221f", PENDING: "#5f6368", RUNNING: "#1a73e8"}
CAPTION = (f"<span style='color:{AFTER}'>●</span> measured marker positions &nbsp; "
           f"<span style='color:{CANDIDATE}'>●</span> poses still to measure (nominal model) &nbsp; "
           f"<span style='color:{ARM}'>━●━</span> nominal arm in the selected pose, "
           f"<span style='color:{HIGHLIGHT}'>●</span> its measured marker &nbsp; "
           f"<span style='color:{CAMERA}'>▲</span> cameras (stereo.yaml)")


# -- the work (plain Python, run on a worker thread) --------------------------------------------
def measure_virtual(poses: PoseList, out: Path, trained, rect, driver, lab, seed: int, *, paused=None,
                    report=None, progress=None, cancelled=None):
    """The measurement run in the virtual lab: the driver moves, the lab renders the pair at
    the robot's joint values (generator seeded per pose), the locator finds the marker.
    `report(outcome, thumbnail)` after each pose (worker thread). A robot stopped by the
    user ends the run before the next pose, like a cancel."""
    from core.marker.location import MarkerLocator

    locator = MarkerLocator(trained, rect)
    last: dict = {}

    def capture_pose(pid, q):
        pair = lab.render_marker_pair(q, np.random.default_rng([int(seed), 41, int(pid)]))
        last["pair"] = pair
        last["loc"] = None
        return pair

    def locate(left, right):
        loc = locator.locate(left, right)
        last["loc"] = loc
        return loc

    def on_pose(outcome: PoseOutcome):
        if report is None:
            return
        thumb = None
        pair, loc = last.get("pair"), last.get("loc")
        if pair is not None:
            dl = loc.left if loc is not None else None
            dr = loc.right if loc is not None else None
            thumb = marker_pair_thumbnail(
                pair[0], pair[1], dl.outline.corners if dl is not None and dl.ok else None,
                dr.outline.corners if dr is not None and dr.ok else None,
                dl.reference if dl is not None and dl.ok else None,
                dr.reference if dr is not None and dr.ok else None,
                ok=outcome.status == MEASURED, width=THUMB_WIDTH)
        last.clear()
        report(outcome, thumb)

    def stop_requested() -> bool:
        return bool((cancelled is not None and cancelled()) or (driver is not None and driver.stopped))

    return run_measurements(poses, out, locate=locate, capture_pose=capture_pose, driver=driver, resume=True,
                            keep_locations=False, on_pose=on_pose, progress=progress, cancelled=stop_requested,
                            paused=paused)


# -- helpers ------------------------------------------------------------------------------------
def _esc(text) -> str:
    return html.escape(str(text))


def minimum_poses_for(robot, targets=("marker",)) -> int:
    """The fewest poses identification can use for `robot` (more equations than parameters)."""
    from core.identification.identifiability import analyse
    from core.poses.selection import minimum_poses

    names = [t for t in targets if t in robot.targets] or list(robot.targets)[:1]
    if not names:
        return 0
    return minimum_poses(len(analyse(robot, names).free), len(names))


def read_pose_list(path: str | Path, robot) -> PoseList:
    """A poses CSV with joint values in internal units for `robot`. Poses outside the joint
    limits are kept: the robot refuses them one by one and the run reports them."""
    poses = read_poses(path)
    if poses.q_file.shape[1] != robot.dof:
        raise RoboCalError(f"the file has {poses.q_file.shape[1]} joint columns but the robot '{robot.name}' "
                           f"has {robot.dof} joints", source=path, hint="Use poses selected for this robot.")
    poses.Q = np.asarray(robot.q_from_file(poses.q_file), dtype=float).reshape(poses.q_file.shape)
    return poses


@dataclass
class PoseRow:
    index: int
    pose: int
    status: str = PENDING
    reason: str = ""
    point: np.ndarray | None = None
    sigma: np.ndarray | None = None


def _short(reason: str, n: int = 70) -> str:
    reason = " ".join(str(reason).split())
    return reason if len(reason) <= n else reason[: n - 1] + "…"


def reason_key(reason: str) -> str:
    """A reason without its numbers (alike reasons are counted together)."""
    import re

    text = re.sub(r"\(.*?\)", "", reason or "no reason given")
    text = re.sub(r"-?\d+(\.\d+)?", "#", text)
    return " ".join(text.split())[:90]


# -- the page -----------------------------------------------------------------------------------
class MeasurementPage(WizardPage):
    step = Step.MEASUREMENT

    #: (run token, PoseOutcome, thumbnail or None), emitted from the worker thread
    poseDone = Signal(int, object, object)

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.poses: PoseList | None = None
        self.poses_label = ""
        self.loaded_csv: Path | None = None        # a CSV the user loaded instead of the project's poses
        self.rows: list[PoseRow] = []
        self._row_of: dict[int, int] = {}
        self.n_min = 0
        self.result = None                          # the last MeasurementRunResult
        self._lab = None
        self._handle = None
        self._token = 0
        self._pause = threading.Event()
        self._stopped_by_robot = False
        self._moves_at_stop: int | None = None
        self._autopilot_retried = False
        self._predicted = self._arms = None
        self._wedges = None
        self._file_problem = ""
        self._build()
        self.poseDone.connect(self._pose_done)
        state.projectChanged.connect(self._context_changed)
        state.robotChanged.connect(self._context_changed)
        state.labChanged.connect(self._lab_changed)
        state.posesChanged.connect(lambda *_: self._poses_changed())
        state.markerChanged.connect(lambda *_: self._sources_changed())
        state.stereoChanged.connect(lambda *_: self._sources_changed())
        state.connectionChanged.connect(lambda *_: self._update_buttons())
        self._context_changed()

    # -- construction ---------------------------------------------------------------------
    def _build(self) -> None:
        self.source_label = QLabel()
        self.source_label.setObjectName("sourceLabel")
        self.source_label.setWordWrap(True)
        self.source_label.setTextFormat(Qt.TextFormat.RichText)
        self.load_button = QPushButton("Load poses CSV…")
        self.load_button.setObjectName("loadPosesButton")
        self.load_button.setToolTip("Measure the poses of another file (pose,q1,...,qn; degrees, mm for prismatic "
                                    "joints) instead of the Pose sequence step's")
        self.load_button.clicked.connect(lambda: self.load_dialog())
        self.start_button = QPushButton("Start")
        self.start_button.setObjectName("startButton")
        self.start_button.clicked.connect(lambda: self.start())
        self.pause_button = QPushButton("Pause")
        self.pause_button.setObjectName("pauseButton")
        self.pause_button.setCheckable(True)
        self.pause_button.setToolTip("Wait after the current pose (the robot stays where it is)")
        self.pause_button.toggled.connect(self._pause_toggled)
        self.cancel_button = QPushButton("Cancel")
        self.cancel_button.setObjectName("cancelButton")
        self.cancel_button.setToolTip("Stop the run after the current pose; Resume continues from there")
        self.cancel_button.clicked.connect(self.cancel)
        self.over_button = QPushButton("Start over…")
        self.over_button.setObjectName("startOverButton")
        self.over_button.setToolTip("Move the measurements taken so far aside (renamed, not deleted) and "
                                    "measure every pose again")
        self.over_button.clicked.connect(lambda: self.start_over())
        self.progress = QProgressBar()
        self.progress.setObjectName("runProgress")
        self.progress.setRange(0, 1000)
        self.progress.setTextVisible(True)
        self.progress.setFormat("%p%")

        top = QGridLayout()
        top.setContentsMargins(0, 0, 0, 0)
        top.setHorizontalSpacing(8)
        top.setVerticalSpacing(4)
        top.addWidget(self.source_label, 0, 0, 1, 5)
        top.addWidget(self.load_button, 0, 5)
        top.addWidget(self.start_button, 1, 0)
        top.addWidget(self.pause_button, 1, 1)
        top.addWidget(self.cancel_button, 1, 2)
        top.addWidget(self.progress, 1, 3, 1, 2)
        top.addWidget(self.over_button, 1, 5)
        top.setColumnStretch(4, 1)

        self.table = QTableWidget(0, 6)
        self.table.setObjectName("poseTable")
        self.table.setHorizontalHeaderLabels(["Pose", "x (mm)", "y (mm)", "z (mm)", "σ (mm)", "Status"])
        self.table.setEditTriggers(QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QAbstractItemView.SelectionMode.SingleSelection)
        self.table.verticalHeader().setVisible(False)
        header = self.table.horizontalHeader()
        header.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        header.setSectionResizeMode(STATUS_COLUMN, QHeaderView.ResizeMode.Stretch)
        self.table.itemSelectionChanged.connect(self._row_selected)
        self.table.setMinimumWidth(400)

        self.thumb = ImageView()
        self.thumb.setObjectName("pairThumbnail")
        self.thumb.setMinimumHeight(120)
        self.thumb_label = QLabel("Current pair: left | right")
        self.thumb_label.setObjectName("hint")
        right = QWidget()
        rl = QVBoxLayout(right)
        rl.setContentsMargins(0, 0, 0, 0)
        rl.setSpacing(2)
        rl.addWidget(self.thumb_label)
        rl.addWidget(self.thumb, 1)

        upper = QSplitter(Qt.Orientation.Horizontal)
        upper.addWidget(self.table)
        upper.addWidget(right)
        upper.setChildrenCollapsible(False)
        upper.setStretchFactor(0, 5)
        upper.setStretchFactor(1, 4)
        self.views = WorkspaceViews(title_top="Top view (x–z, left camera frame)",
                                    title_side="Side view (z–y, left camera frame)")
        self.views.caption.setText(CAPTION)
        for view in self.views.views:          # the poses still to measure: plainly visible
            view.candidates.setSize(6)
            view.candidates.setBrush(colour(CANDIDATE, 190))
        self.splitter = QSplitter(Qt.Orientation.Vertical)
        self.splitter.addWidget(upper)
        self.splitter.addWidget(self.views)
        self.splitter.setChildrenCollapsible(False)
        self.splitter.setStretchFactor(0, 5)
        self.splitter.setStretchFactor(1, 5)
        self.splitter.setSizes([260, 300])

        self.summary = QLabel()
        self.summary.setObjectName("summaryLabel")
        self.summary.setWordWrap(True)
        self.summary.setTextFormat(Qt.TextFormat.RichText)

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(6)
        layout.addLayout(top)
        layout.addWidget(self.splitter, 1)
        layout.addWidget(self.summary)
        layout.addWidget(self.status)

    # -- state ------------------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        return self._handle is not None

    @property
    def paused(self) -> bool:
        return self._pause.is_set()

    def measurements_path(self) -> Path | None:
        return self.state.project.path("measurements") if self.state.project is not None else None

    def counts(self) -> Counter:
        return Counter(r.status for r in self.rows)

    @property
    def n_measured(self) -> int:
        return sum(1 for r in self.rows if r.status == MEASURED)

    def _lab_changed(self, lab) -> None:
        if lab is not None:
            self._lab = lab
            self._show_views()

    def _current_lab(self):
        if self._lab is None and self.state.has_lab:
            self._lab = self.state.lab
        return self._lab

    def _poses_changed(self) -> None:
        if not self.busy and self.loaded_csv is None:
            self._load_poses()

    def _sources_changed(self) -> None:
        if not self.busy:
            self._show_sources()
            self._show_views()

    def _context_changed(self, *_) -> None:
        self._token += 1
        if self._handle is not None:
            self._handle.cancel()
            self._handle = None
        self._pause.clear()
        self._lab = None
        self.loaded_csv = None
        self.result = None
        self._load_poses()
        self.notify_complete()

    # -- poses and files ------------------------------------------------------------------------
    def _load_poses(self) -> None:
        """The pose list (a loaded CSV, else the project's poses.csv, else the Pose step's
        output), the minimum for identification, and what is already on disk."""
        state = self.state
        self.poses, self.poses_label, problem = None, "", ""
        robot = state.robot
        if state.project is None or robot is None:
            problem = "No project or robot yet (Setup step)."
        else:
            selection = state.poses
            try:
                if self.loaded_csv is not None:
                    self.poses = read_pose_list(self.loaded_csv, robot)
                    self.poses_label = f"{len(self.poses)} poses from {self.loaded_csv.name}"
                elif state.project.has("poses"):
                    self.poses = read_pose_list(state.project.path("poses"), robot)
                    self.poses_label = f"{len(self.poses)} poses from the project's poses.csv"
                elif selection is not None:
                    self.poses = PoseList(q_file=np.asarray(selection.q_file, float), Q=np.asarray(selection.Q, float),
                                          pose=np.arange(len(selection.Q)))
                    self.poses_label = f"{len(self.poses)} poses from the Pose sequence step"
                else:
                    problem = "No pose list yet: select poses in step 4, or load a poses CSV."
            except RoboCalError as exc:
                problem = f"The pose list cannot be used: {exc.message}"
            self.n_min = int(getattr(selection, "n_min", 0) or 0) if selection is not None else 0
            if not self.n_min:
                try:
                    self.n_min = minimum_poses_for(robot)
                except Exception:  # noqa: BLE001 - a robot without identifiable parameters: no minimum
                    self.n_min = 0
        self._predicted = self._arms = None
        self._read_existing()
        self._fill_table()
        self._show_sources()
        self._show_summary()
        self._show_views()
        if problem:
            self._set_status(problem, False)
        elif not self.busy:
            self._ready_status()
        self._update_buttons()
        if self.is_complete() and state.measurements is None:
            state.set_measurements(self.measurements_path())      # measured in an earlier session

    def _read_existing(self) -> None:
        """Statuses from measurements.csv and its rejects file (an earlier run of this list)."""
        self.rows = []
        self._row_of = {}
        self._file_problem = ""
        if self.poses is None:
            return
        for i, pid in enumerate(np.asarray(self.poses.pose, int)):
            self.rows.append(PoseRow(i, int(pid)))
            self._row_of[int(pid)] = i
        path = self.measurements_path()
        if path is None:
            return
        try:
            if path.is_file() and path.read_bytes().strip():
                meas = read_measurements(path)
                q_list = np.atleast_2d(np.asarray(self.poses.q_file, float))
                for k in range(meas.n_points):
                    i = self._row_of.get(int(meas.pose[k]))
                    if i is None or meas.target[k] != "marker":
                        continue
                    q = np.asarray(meas.q_file[k], float)
                    if q.shape != q_list[i].shape or np.max(np.abs(q - q_list[i])) > JOINT_TOLERANCE:
                        self._file_problem = (f"{path.name} belongs to another pose list (pose {int(meas.pose[k])} "
                                              "has other joint values).")
                        for r in self.rows:
                            r.status, r.point, r.sigma = PENDING, None, None
                        return
                    r = self.rows[i]
                    r.status, r.point = MEASURED, meas.xyz[k]
                    r.sigma = meas.sigma[k] if meas.sigma is not None else None
            for pid, (_target, _q, reason) in read_rejects(rejects_path_for(path)).items():
                i = self._row_of.get(int(pid))
                if i is not None and self.rows[i].status != MEASURED:
                    self.rows[i].status, self.rows[i].reason = REJECTED, reason
        except RoboCalError as exc:
            self._file_problem = exc.message

    def load_dialog(self) -> bool:
        start = str(self.state.project.folder) if self.state.project is not None else ""
        path, _ = QFileDialog.getOpenFileName(self, "Poses to measure", start, "Poses CSV (*.csv);;All files (*)")
        return self.load_csv(path) if path else False

    def load_csv(self, path: str | Path) -> bool:
        """Measure the poses of this CSV (they go to the project's measurements.csv)."""
        if self.busy:
            return False
        if self.state.robot is None:
            self._set_status("Choose a robot model in the Setup step first.", False)
            return False
        try:
            read_pose_list(path, self.state.robot)
        except RoboCalError as exc:
            self._set_status(f"✗ {exc.message}", False)
            return False
        self.loaded_csv = Path(path)
        self._load_poses()
        return True

    # -- WizardPage -------------------------------------------------------------------------
    def on_enter(self) -> None:
        if not self.busy:
            self._load_poses()
        self.notify_complete()

    def is_complete(self) -> bool:
        return self.n_min > 0 and self.n_measured >= self.n_min

    def autopilot(self, done) -> None:
        if self.state.project is None or self.state.robot is None:
            done(False, "no project or robot model (Setup step)")
            return
        if self.busy:
            done(False, "the page is busy")
            return
        self._load_poses()
        self._autopilot_done = done
        self._autopilot_retried = False
        if self.poses is not None and not self._pending() and self.is_complete():
            self._finish_autopilot(True, self._done_message())
            return
        if not self.start():
            self._finish_autopilot(False, self.status.text() or "the measurement could not start")

    def _done_message(self) -> str:
        c = self.counts()
        return (f"{c[MEASURED]} poses measured, {c[REJECTED]} rejected (identification needs {self.n_min}) "
                f"→ {self.measurements_path().name}")

    def _pending(self) -> list[PoseRow]:
        return [r for r in self.rows if r.status in (PENDING, RUNNING)]

    # -- the run ----------------------------------------------------------------------------------
    def _inputs(self):
        """(trained marker, stereo source) or a RoboCalError saying what is missing."""
        state = self.state
        if state.project is None or state.robot is None:
            raise RoboCalError("no project or robot yet", hint="Create a project and choose a robot (Setup step).")
        if self.poses is None:
            raise RoboCalError("no pose list", hint="Select poses in step 4, or load a poses CSV.")
        trained = project_marker(state)
        if trained is None:
            raise RoboCalError("no trained marker", hint="Train the marker in step 3 (Marker).")
        src = stereo_source(state)
        if src.rect is None:
            raise RoboCalError(src.problem or "no stereo calibration",
                               hint="Calibrate the cameras in step 2 and save stereo.yaml.")
        return trained, src

    def start(self) -> bool:
        """Start the run, or resume it after the last measured or rejected pose."""
        if self.busy:
            return False
        state = self.state
        try:
            trained, src = self._inputs()
        except RoboCalError as exc:
            self._set_status(f"Cannot measure: {exc.message}. {exc.hint or ''}".strip(), False)
            return False
        if not state.virtual:
            self._set_status("Capturing from real cameras arrives with the hardware issue. Meanwhile save the "
                             "pairs with your camera software and use `robocal measure`.", False)
            return False
        driver = state.robot_connection
        if driver is None:
            self._set_status("No robot connection (Setup step).", False)
            return False
        if driver.stopped:
            self._set_status("The robot is stopped. When the way is clear: Robot ▸ Resume after stop, then Resume "
                             "the run.", False)
            return False
        lab = self._current_lab()
        if lab is None:
            # the lab first (its adoption replaces the robot connection), then the run
            self._token += 1
            token = self._token

            def built(value):
                if token != self._token:
                    return
                self._handle = None
                self._lab = value
                state.adopt_lab(value)
                self.start()

            def failed(message):
                if token != self._token:
                    return
                self._handle = None
                self._update_buttons()
                self._set_status(f"✗ {message}", False)
                self._finish_autopilot(False, message)

            self._handle = self.run_task(build_lab, state.robot, state.seed, float(state.noise), on_result=built,
                                         on_error=failed, on_cancelled=lambda: failed("cancelled"),
                                         label="Building the virtual lab")
            self._update_buttons()
            self._set_status("Building the virtual lab…", None)
            return True
        path = self.measurements_path()
        self._token += 1
        token = self._token
        self._stopped_by_robot = False
        self._moves_at_stop = None
        self.pause_button.setChecked(False)
        self._pause.clear()
        self.result = None
        pending = len(self._pending())
        self._handle = self.run_task(
            measure_virtual, self.poses, path, trained, src.rect, driver, lab, int(state.seed),
            paused=self._pause.is_set, report=lambda outcome, thumb: self.poseDone.emit(token, outcome, thumb),
            on_result=lambda r: self._finished(token, r), on_error=lambda m: self._failed(token, m),
            on_cancelled=lambda: self._cancelled(token), on_progress=self._progress, label="Measuring")
        self._update_buttons()
        done = len(self.rows) - pending
        self._set_status(f"Measuring {pending} pose{'s' if pending != 1 else ''}"
                         + (f" (continuing after the {done} done earlier)" if done else "")
                         + "… Esc stops the robot.", None)
        return True

    def pause(self, on: bool = True) -> None:
        self.pause_button.setChecked(bool(on))

    def _pause_toggled(self, on: bool) -> None:
        if on:
            self._pause.set()
        else:
            self._pause.clear()
        self.pause_button.setText("Continue" if on else "Pause")
        if self.busy:
            self._set_status("Paused after the current pose: Continue when ready." if on else "Measuring…", None)

    def cancel(self) -> None:
        if self._handle is not None:
            self._handle.cancel()
            self._set_status("Cancelling after the current pose…", None)

    def _progress(self, fraction: float, message: str) -> None:
        self.progress.setValue(int(round(1000 * min(max(fraction, 0.0), 1.0))))
        self.progress.setFormat(f"{message.replace('%', '%%')}  %p%" if message else "%p%")
        if message.startswith("pose "):
            try:
                pid = int(message.split()[1])
            except (IndexError, ValueError):
                return
            i = self._row_of.get(pid)
            if i is not None and self.rows[i].status == PENDING:
                self.rows[i].status = RUNNING
                self._set_row(i)

    def _pose_done(self, token: int, outcome: PoseOutcome, thumb) -> None:
        if token != self._token:
            return
        i = self._row_of.get(int(outcome.pose))
        if i is None:
            return
        r = self.rows[i]
        r.status = MEASURED if outcome.status == MEASURED else REJECTED
        r.reason, r.point, r.sigma = outcome.reason, outcome.point, outcome.sigma
        self._set_row(i)
        if thumb is not None:
            self.thumb.set_image(thumb)
            self.thumb_label.setText(f"Pose {outcome.pose}: left | right — "
                                     + ("located" if r.status == MEASURED else f"rejected: {_short(r.reason, 60)}"))
        self._show_summary()
        self._show_views(highlight=i)
        self.table.selectRow(i)            # scrolls to it and draws its arm
        self.notify_complete()

    def _end(self) -> None:
        self._handle = None
        self.pause_button.setChecked(False)
        self._pause.clear()
        for r in self.rows:
            if r.status == RUNNING:
                r.status = PENDING
        self._read_existing()           # the files are the truth
        done = sum(1 for r in self.rows if r.status in (MEASURED, REJECTED))
        self.progress.setValue(int(round(1000 * done / max(len(self.rows), 1))))
        self.progress.setFormat(f"{done} of {len(self.rows)} poses done")
        self._fill_table()
        self._show_summary()
        self._show_views()
        self._update_buttons()
        self.notify_complete()

    def _robot_stopped(self) -> bool:
        driver = self.state.robot_connection
        return driver is not None and driver.stopped

    def _finished(self, token: int, result) -> None:
        if token != self._token:
            return
        self.result = result
        self._end()
        c = self.counts()
        kept = f"{c[MEASURED]} measured and {c[REJECTED]} rejected poses are in {result.measurements_path.name}"
        if result.cancelled:
            if self._robot_stopped():
                self._set_status(f"Robot stopped: the run stopped before pose {self._next_pose_text()}. {kept}. "
                                 "When the way is clear: Robot ▸ Resume after stop, then Resume.", False)
                self._finish_autopilot(False, "the robot was stopped")
            else:
                self._set_status(f"Cancelled. {kept}. Resume continues with pose {self._next_pose_text()}.", False)
                self._finish_autopilot(False, "cancelled")
            return
        if self.state.project is not None and self.measurements_path().is_file():
            self.state.set_measurements(self.measurements_path())
        if self.is_complete():
            self._set_status(f"✓ Done: {c[MEASURED]} of {len(self.rows)} poses measured"
                             + (f", {c[REJECTED]} rejected (see the reasons)" if c[REJECTED] else "")
                             + f". Identification needs at least {self.n_min}: enough.", True)
            self._finish_autopilot(True, self._done_message())
        else:
            self._set_status(f"Only {c[MEASURED]} poses measured; identification needs at least {self.n_min}. "
                             "Check the rejection reasons, add poses (step 4) and measure again.", False)
            self._finish_autopilot(False, f"only {c[MEASURED]} poses measured (at least {self.n_min} needed)")

    def _failed(self, token: int, message: str) -> None:
        if token != self._token:
            return
        self._end()
        c = self.counts()
        if self._robot_stopped():
            self._set_status(f"Robot stopped: the run stopped before pose {self._next_pose_text()}. "
                             f"{c[MEASURED]} measured poses are in measurements.csv. When the way is clear: "
                             "Robot ▸ Resume after stop, then Resume.", False)
            self._finish_autopilot(False, "the robot was stopped")
            return
        if "another pose list" in message and self._autopilot_done is not None and not self._autopilot_retried:
            # the autopilot cannot ask: the old file is moved aside (kept), and the run starts again
            self._autopilot_retried = True
            if self.start_over(confirm=False) and self.start():
                return
        hint = " Use Start over to move the old file aside." if "another pose list" in message else ""
        self._set_status(f"✗ {message}{hint}", False)
        self._finish_autopilot(False, message)

    def _cancelled(self, token: int) -> None:
        if token != self._token:
            return
        self._end()
        self._set_status("Cancelled before the first pose.", False)
        self._finish_autopilot(False, "cancelled")

    def _next_pose_text(self) -> str:
        pending = self._pending()
        return str(pending[0].pose) if pending else "–"

    def start_over(self, confirm: bool = True) -> bool:
        """Move measurements.csv and its rejects file aside (renamed with the time), so that
        every pose is measured again. Nothing is deleted."""
        if self.busy or self.state.project is None:
            return False
        path = self.measurements_path()
        files = [p for p in (path, rejects_path_for(path)) if p.exists()]
        if not files:
            self._set_status("Nothing to move aside: no measurements yet.", None)
            return True
        if confirm and not messages.NON_INTERACTIVE:
            answer = QMessageBox.question(
                self, "RoboCal: start over",
                f"Move {', '.join(p.name for p in files)} aside (renamed, kept in the project folder) and measure "
                "every pose again?")
            if answer != QMessageBox.StandardButton.Yes:
                return False
        stamp = time.strftime("%Y%m%d-%H%M%S")
        moved = []
        for p in files:
            target = p.with_name(f"{p.stem}.old-{stamp}{p.suffix}")
            k = 1
            while target.exists():
                target = p.with_name(f"{p.stem}.old-{stamp}-{k}{p.suffix}")
                k += 1
            try:
                p.rename(target)
            except OSError as exc:
                self._set_status(f"✗ cannot move {p.name} aside ({exc.strerror})", False)
                return False
            moved.append(target.name)
        self.result = None
        self._read_existing()
        self._fill_table()
        self._show_summary()
        self._show_views()
        self._update_buttons()
        self.notify_complete()
        self._set_status(f"Moved aside: {', '.join(moved)}. Start measures every pose again.", None)
        return True

    # -- drawing ----------------------------------------------------------------------------------
    def _update_buttons(self) -> None:
        busy = self.busy
        pending = bool(self._pending())
        self.start_button.setEnabled(not busy and self.poses is not None and pending)
        done_before = any(r.status != PENDING for r in self.rows)
        self.start_button.setText("Resume" if done_before and pending else "Start")
        self.pause_button.setEnabled(busy)
        self.cancel_button.setEnabled(busy)
        path = self.measurements_path()
        on_disk = path is not None and (path.exists() or rejects_path_for(path).exists())
        self.over_button.setEnabled(not busy and (done_before or on_disk))
        self.load_button.setEnabled(not busy)

    def _ready_status(self) -> None:
        c = self.counts()
        if getattr(self, "_file_problem", ""):
            self._set_status(f"The existing measurements cannot be used: {self._file_problem} Start over moves "
                             "them aside (kept) and measures this pose list.", False)
        elif not self._pending() and c[MEASURED]:
            ok = self.is_complete()
            self._set_status(f"{'✓ ' if ok else ''}All {len(self.rows)} poses done: {c[MEASURED]} measured, "
                             f"{c[REJECTED]} rejected." + ("" if ok else f" Identification needs {self.n_min}."), ok)
        elif c[MEASURED] or c[REJECTED]:
            self._set_status(f"{c[MEASURED] + c[REJECTED]} of {len(self.rows)} poses done in an earlier run: Resume "
                             "continues with the others.", None)
        else:
            self._set_status("Start drives the robot through the poses; each measurement is written to "
                             "measurements.csv as it is taken. Esc stops the robot.", None)

    def _show_sources(self) -> None:
        src = stereo_source(self.state) if self.state.project is not None else None
        self._wedges = camera_wedges(src.rect.rig, 1000.0) if src is not None and src.rect is not None else None
        parts = [f"<b>Poses:</b> {_esc(self.poses_label or 'none')}"]
        try:
            trained = project_marker(self.state)
            parts.append("<b>Marker:</b> " + (f"trained ({trained.n_image_features} features)" if trained else
                                              "<span style='color:#b06000'>not trained (step 3)</span>"))
        except RoboCalError as exc:
            parts.append(f"<b>Marker:</b> <span style='color:#b06000'>{_esc(exc.message)}</span>")
        parts.append("<b>Stereo:</b> " + (_esc(src.label) if src is not None and src.rect is not None else
                                          f"<span style='color:#b06000'>"
                                          f"{_esc(src.problem if src is not None else 'no project')}</span>"))
        self.source_label.setText(" · ".join(parts))

    def _fill_table(self) -> None:
        self.table.blockSignals(True)
        self.table.setRowCount(len(self.rows))
        for i in range(len(self.rows)):
            self._set_row(i)
        self.table.blockSignals(False)

    def _set_row(self, i: int) -> None:
        r = self.rows[i]
        status = {MEASURED: "✓ measured", PENDING: "pending", RUNNING: "▶ measuring…",
                  REJECTED: f"✗ rejected: {_short(r.reason)}"}[r.status]
        cells = [str(r.pose)]
        if r.point is not None:
            cells += [f"{v:.2f}" for v in r.point]
            cells.append(f"{float(np.linalg.norm(r.sigma)):.3f}" if r.sigma is not None else "–")
        else:
            cells += ["", "", "", ""]
        cells.append(status)
        colour = QBrush(QColor(STATUS_COLOURS[r.status]))
        for j, text in enumerate(cells):
            item = self.table.item(i, j)
            if item is None:
                item = QTableWidgetItem()
                self.table.setItem(i, j, item)
            item.setText(text)
            if j == STATUS_COLUMN:
                item.setForeground(colour)
                item.setToolTip(r.reason if r.status == REJECTED else "")
            else:
                item.setTextAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)

    def _show_summary(self) -> None:
        if not self.rows:
            self.summary.setText("")
            return
        c = self.counts()
        enough = self.n_min > 0 and c[MEASURED] >= self.n_min
        need = (f"Identification needs at least <b>{self.n_min}</b> poses: "
                + ("<span style='color:#188038'><b>enough</b></span>" if enough else
                   f"<span style='color:#b06000'>{max(self.n_min - c[MEASURED], 0)} more</span>")) if self.n_min else ""
        text = (f"<b>{c[MEASURED]}</b> measured · <b>{c[REJECTED]}</b> rejected · "
                f"<b>{c[PENDING] + c[RUNNING]}</b> pending of {len(self.rows)} poses. {need}")
        reasons = Counter(reason_key(r.reason) for r in self.rows if r.status == REJECTED)
        if reasons:
            text += "<br>Rejected: " + "; ".join(f"{n}× {_esc(k)}" for k, n in reasons.most_common(4))
        sig = [float(np.linalg.norm(r.sigma)) for r in self.rows if r.status == MEASURED and r.sigma is not None]
        if sig:
            text += f"<br>Median predicted σ of the measured points: {np.median(sig):.3f} mm."
        self.summary.setText(text)

    def _predictions(self):
        """Marker positions of every pose by the nominal model, in the left camera frame (the
        virtual lab's placed nominal robot); None outside the lab."""
        if self._predicted is None and self.poses is not None:
            lab = self._current_lab()
            if lab is not None and self.poses.Q is not None:
                from core.poses.candidates import arm_polyline
                try:
                    self._predicted = lab.nominal_robot.target_positions(self.poses.Q, lab.target)
                    arms, _ = arm_polyline(lab.nominal_robot, self.poses.Q, lab.target)
                    self._arms = arms.reshape(-1, 3)          # every arm stays in view
                except Exception:  # noqa: BLE001 - a drawing aid only
                    self._predicted = self._arms = None
        return self._predicted

    def _show_views(self, highlight: int | None = None) -> None:
        wedges = getattr(self, "_wedges", None)
        measured = np.array([r.point for r in self.rows if r.status == MEASURED and r.point is not None]).reshape(-1, 3)
        predicted = self._predictions()
        if predicted is not None:
            todo = [r.index for r in self.rows if r.status in (PENDING, RUNNING)]
            predicted = predicted[todo] if todo else None
        self.views.set_scene(wedges=wedges, candidates=predicted, selected=measured,
                             extent=self._arms)
        if highlight is None:
            rows = self.table.selectionModel().selectedRows() if self.table.selectionModel() else []
            highlight = rows[0].row() if rows else None
        self._highlight(highlight)

    def _row_selected(self) -> None:
        rows = self.table.selectionModel().selectedRows()
        self._highlight(rows[0].row() if rows else None)

    def _highlight(self, i: int | None) -> None:
        if i is None or not 0 <= i < len(self.rows):
            self.views.set_highlight(None)
            return
        r = self.rows[i]
        lab = self._current_lab()
        arm = None
        if lab is not None and self.poses is not None and self.poses.Q is not None:
            from core.poses.candidates import arm_polyline
            try:
                pts, _ = arm_polyline(lab.nominal_robot, self.poses.Q[i:i + 1], lab.target)
                arm = pts[0]
            except Exception:  # noqa: BLE001 - a drawing aid only
                arm = None
        marker = r.point[None, :] if r.point is not None else None
        if arm is None and marker is None:
            self.views.set_highlight(None)
        elif arm is None:
            self.views.set_highlight(marker, marker)
        else:
            self.views.set_highlight(arm, marker)
