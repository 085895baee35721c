"""What the Measurement page measures with, as the page shows it: the pose list (a poses CSV the
technician loaded, else the project's poses.csv, else the Pose step's selection), what is already
measured of it, the trained marker and the stereo calibration (the line above the buttons, the
cameras in the views).

`PoseListInputs` is held by the page (composed, not a base class); it writes the pose list and
the rows into the page's MeasurementModel, whose listeners redraw the page.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

from app.jobs.measurement import MEASURED
from app.pages.base import out_of_date
from app.pages.measurement.controls import RunControls
from app.pages.measurement.model import MeasurementModel
from app.pages.measurement.texts import ready_text, sources_html
from app.pages.measurement.views import MeasurementViews
from app.pages.measurement_inputs import project_marker, stereo_source
from app.pages.page_task import PageTask
from core.errors import RoboCalError
from core.poses.file import read_pose_list
from core.project import Output


@dataclass
class InputsHooks:
    """What the inputs need of their page, as plain callables on the GUI thread."""

    say: Callable[[str, bool | None], None]          # the page's status line
    measurements_path: Callable[[], Path | None]
    is_complete: Callable[[], bool]
    changed_inputs: Callable[[], list[str]]          # stereo.yaml or marker.npz changed since the measurements
    teach_mode: Callable[[], bool]


class PoseListInputs:
    """Loads the pose list and its statuses into the model; shows where the inputs come from and,
    in the status line, what the files hold."""

    def __init__(self, model: MeasurementModel, task: PageTask, state, *, controls: RunControls,
                 views: MeasurementViews, hooks: InputsHooks):
        self.model, self.task, self.state, self.hooks = model, task, state, hooks
        self.controls, self.views = controls, views

    def load(self) -> None:
        """The pose list, the minimum for identification, and what is already on disk."""
        state, project = self.state, self.state.project
        robot = state.robot if project is not None else None
        project_poses = project.path(Output.POSES) if project is not None and project.has(Output.POSES) else None
        problem = self.model.choose_poses(robot, project_poses, state.poses)
        self.views.forget_predictions()
        self.show_sources()
        self.model.read_rows(self.hooks.measurements_path())
        if problem:
            self.hooks.say(problem, False)
        elif not self.task.busy:
            self.ready_status()
        if self.hooks.is_complete() and state.measurements is None:
            state.set_measurements(self.hooks.measurements_path())      # measured in an earlier session

    def load_csv(self, path: str | Path) -> bool:
        """Measure the poses of this CSV (they go to the project's measurements.csv)."""
        if self.task.busy:
            return False
        if self.state.robot is None:
            self.hooks.say("Choose a robot model in the Setup step first.", False)
            return False
        try:
            read_pose_list(path, self.state.robot)
        except RoboCalError as exc:
            self.hooks.say(f"✗ {exc.message}", False)
            return False
        self.model.set_options(replace(self.model.options, loaded_csv=Path(path)))
        self.load()
        return True

    def changed(self, *, poses: bool = False) -> None:
        """The Pose step's poses changed (read again unless a loaded CSV is measured), or the
        marker or stereo calibration did; nothing while a task runs."""
        if self.task.busy:
            return
        if poses:
            if self.model.options.loaded_csv is None:
                self.load()
            return
        self.show_sources()
        self.views.redraw()

    def show_sources(self) -> None:
        """Poses · Marker · Stereo above the buttons; the cameras in the views."""
        src = stereo_source(self.state) if self.state.project is not None else None
        self.views.set_cameras(src.rect if src is not None else None)
        try:
            trained = project_marker(self.state)
            marker = f"trained ({trained.n_image_features} features)" if trained else "not trained (step 3)"
            marker_ok = trained is not None
        except RoboCalError as exc:
            marker, marker_ok = exc.message, False
        stereo_ok = src is not None and src.rect is not None
        stereo = src.label if stereo_ok else (src.problem if src is not None else "no project")
        self.controls.source_label.setText(sources_html(self.model.poses_label, marker, marker_ok, stereo, stereo_ok))

    def ready_status(self) -> None:
        """The status line before a run: what the files hold and what Start (or Record pose) will do."""
        changed, model = self.hooks.changed_inputs(), self.model
        if changed and not model.pending():
            self.hooks.say(out_of_date("measurements.csv", changed, "Start over… to measure every pose with them."),
                           False)
            return
        complete = self.hooks.is_complete()
        ok = False if model.file_problem else (complete if not model.pending() and model.counts()[MEASURED] else None)
        self.hooks.say(ready_text(model.rows, model.n_min, model.file_problem, complete, self.hooks.teach_mode()), ok)
