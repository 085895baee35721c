"""The Marker page's training work, a helper the page holds (not a base class): the project's
saved marker, the training image (a file, the left camera or the virtual lab's camera) and
training on a worker. It sets the model; the Training tab draws from the model's events."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Callable

import numpy as np
from PySide6.QtWidgets import QFileDialog, QWidget

from app.jobs.marker import (Training, TrainingImage, camera_training_image, capture_training_image,
                             load_training_image, marker_changed_inputs, recorded_verification, save_trained,
                             train_job)
from app.pages.base import out_of_date
from app.pages.marker.model import MarkerModel, TrainingOptions
from app.pages.measurement_inputs import marker_file
from app.pages.page_task import PageTask
from core.errors import RoboCalError
from core.marker.training import TrainedMarker

AGAIN = "Run a verification (or a live pair) again."      # what makes an out-of-date marker current


class MarkerTraining:
    """Training image and training for the page: `say(text, ok)` is its status line,
    `training_options()` what the Training tab shows, `show_tab(name)` brings a tab forward
    ("training"), `completed()` tells the wizard the step may be done."""

    def __init__(self, state, model: MarkerModel, task: PageTask, *, parent: QWidget,
                 say: Callable[[str, bool | None], None], training_options: Callable[[], TrainingOptions],
                 show_tab: Callable[[str], None], completed: Callable[[], None]):
        self.state, self.model, self.task = state, model, task
        self._parent = parent
        self._say = say
        self._training_options = training_options
        self._show_tab = show_tab
        self._completed = completed

    def load_saved(self) -> tuple[str, bool | None]:
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
        self.model.set_trained(trained, np.zeros(2), path,
                               TrainingImage(trained.image, trained.source or str(path), trained.outline))
        self.state.set_marker(trained)
        self.model.choose(training=replace(self.model.options.training, outer_size=trained.outer_size))
        verified = recorded_verification(project)
        self.model.set_verified(verified)
        changed = marker_changed_inputs(project)
        if changed:
            return out_of_date("the marker's verification", changed, AGAIN), False
        return (f"This project already has a trained marker ({path.name}, {trained.n_image_features} SIFT features)"
                + (", verified: the step is done." if verified else
                   ". Locate it on a pair (Live pair or Verification) to finish the step."), verified)

    # -- the training image -----------------------------------------------------------------
    def load_dialog(self) -> bool:
        start = str(self.state.project.folder) if self.state.project else ""
        path, _ = QFileDialog.getOpenFileName(self._parent, "Marker training image", start,
                                              "Images (*.png *.jpg *.jpeg *.bmp *.tif *.tiff)")
        return self.load_image(path) if path else False

    def load_image(self, path: str | Path) -> bool:
        try:
            image = load_training_image(path)
        except RoboCalError as exc:
            self._say(f"✗ {exc.message}", False)
            return False
        self.model.set_training_image(image)
        return True

    def capture(self, then=None) -> bool:
        """From the left camera of the cameras opened on the Setup page; else the virtual lab's."""
        cameras = self.state.hardware.cameras
        if cameras is not None:
            return self.task.start(camera_training_image, cameras, on_done=self.model.set_training_image,
                                   label="Training image", then=then,
                                   status="Taking the training image with the left camera…")
        if not self.state.virtual or self.state.robot is None:
            self._say("Open the two cameras on the Setup page to capture, or load an image of the marker.", False)
            return False
        return self.task.with_lab(lambda lab: self.task.start(
            capture_training_image, lab, on_done=self.model.set_training_image, label="Training image", then=then,
            status="Taking the training image…"))

    # -- training ---------------------------------------------------------------------------
    def train(self, then=None) -> bool:
        img = self.model.result.training_image
        if img is None:
            self._say("Load or capture a training image first.", False)
            return False
        if self.state.project is None:
            self._say("Create or open a project first (Setup step).", False)
            return False
        self.model.choose(training=self._training_options())
        options = self.model.options.training
        return self.task.start(train_job, img.image, options.crop, float(options.outer_size), img.source,
                               on_done=self._trained, label="Training the marker", then=then,
                               status="Training: outline, edges, SIFT features of the marker and of simulated "
                                      "tilted views…")

    def _trained(self, training: Training) -> None:
        trained = training.trained
        try:
            path = save_trained(self.state.project, trained)
        except RoboCalError as exc:
            self._say(f"✗ The trained marker was not saved: {exc.message}", False)
            return
        self.model.set_trained(trained, training.offset, path)
        self.model.clear_located()
        self.state.set_marker(trained)
        self._say(f"✓ Trained: {trained.n_image_features} SIFT features on the marker "
                  f"({trained.n_features} with the simulated tilted views), saved as {path.name}. "
                  "Now check it on a live pair (Next pose) and run a verification.", True)
        self._show_tab("training")
        self._completed()
