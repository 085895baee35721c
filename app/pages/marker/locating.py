"""The Marker page's locating work, a helper the page holds (not a base class): one live pair
(the virtual lab's robot at a random visible pose, or the cameras opened on the Setup page) and
the verification over random robot poses of the virtual lab, each on a worker; what they give
goes to the model (the Live pair, SSD and Verification tabs draw from its events) and, for the
report, into the project (marker_details.json, marker_verification.json)."""
from __future__ import annotations

import math
from typing import Callable

from PySide6.QtWidgets import QWidget

from app.html import number
from app.jobs.marker import (LiveResult, VerificationResult, camera_live_pair, live_pair, run_verification,
                             stereo_parameter_covariance, write_details, write_verification)
from app.lab import VirtualLab
from app.pages.marker.model import MarkerModel
from app.pages.page_task import PageTask
from app.safety import motion_refused
from core.errors import RoboCalError
from core.marker.location import MarkerLocator
from core.project import Output


class MarkerLocating:
    """Live pairs and verifications for the page: `say(text, ok)` is its status line,
    `show_tab(name)` brings a tab forward ("live", "verification"), `shown` is what a worker
    calls with the verification so far (a queued Qt signal's emit: it arrives at
    `verification_so_far` on the GUI thread), `completed()` tells the wizard the step may be done."""

    def __init__(self, state, model: MarkerModel, task: PageTask, *, parent: QWidget,
                 say: Callable[[str, bool | None], None], show_tab: Callable[[str], None],
                 shown: Callable[[VerificationResult], None], completed: Callable[[], None]):
        self.state, self.model, self.task = state, model, task
        self._parent = parent
        self._say = say
        self._show_tab = show_tab
        self._shown = shown
        self._completed = completed
        self._live_count = 0
        self._verify_count = 0
        self._verifying = 0                     # the verification run being drawn as it comes (0: none)

    def ready_locator(self) -> MarkerLocator | None:
        """The model's locator, else None and the status line says what is missing."""
        locator = self.model.locator()
        if locator is None:
            self._say("Train the marker and provide a stereo calibration first.", False)
        return locator

    def _robot_may_move(self) -> bool:
        """A real robot moves only when app.safety allows it (connected, not stopped, its first
        motion confirmed); the simulated robot always may."""
        refused = motion_refused(self._parent, self.state) if self.state.hardware.real_robot else None
        if refused:
            self._say(refused, False)
        return refused is None

    # -- live pair --------------------------------------------------------------------------
    def next_pose(self, then=None) -> bool:
        locator = self.ready_locator()
        if locator is None:
            return False
        hardware = self.state.hardware
        if hardware.cameras is not None:
            self._live_count += 1
            return self.task.start(camera_live_pair, hardware.cameras, locator, self._live_count,
                                   hardware.robot_connection, on_done=self._live_done, label="Live pair", then=then,
                                   status="Capturing a pair from the cameras and locating…")

        def go(lab: VirtualLab) -> bool:
            self._live_count += 1
            return self.task.start(live_pair, lab, locator, self._live_count, int(self.state.seed),
                                   hardware.robot_connection, on_done=self._live_done, label="Live pair", then=then,
                                   status="Moving to a random visible pose, capturing and locating…")

        if not self._robot_may_move():
            return False
        return self.task.with_lab(go)

    def _live_done(self, live: LiveResult) -> None:
        self.model.set_live(live)
        loc = live.location
        if loc.ok:
            self._save_details(live=live)
            self._mark_verified({"kind": "live pair", "poses": 1, "located": 1,
                                 "error_mm": None if not math.isfinite(live.error) else round(live.error, 6)})
            took = f"✓ Located in {1000 * loc.timings.get('total', live.seconds):.0f} ms"
            if live.truth is None:
                self._say(f"{took} at ({', '.join(f'{v:.1f}' for v in loc.point)}) mm. Move the marker and "
                          "capture again for another.", True)
            else:
                self._say(f"{took}: error against the truth {live.error:.3f} mm. Next pose for another, "
                          "or run a verification.", True)
        else:
            self._say(f"Not located: {loc.reason}", False)
        self._show_tab("live")

    # -- verification -----------------------------------------------------------------------
    def verify(self, then=None) -> bool:
        locator = self.ready_locator()
        if locator is None:
            return False
        if not self._robot_may_move():
            return False

        def go(lab: VirtualLab) -> bool:
            n = self.model.options.verification.poses
            self._verify_count += 1
            self._show_tab("verification")
            self._verifying = self._verify_count
            project, stereo = self.state.project, self.model.stereo
            rect = stereo.rect
            details = project.path(Output.STEREO_DETAILS) if project is not None and stereo.kind == "file" else None
            covariance = stereo_parameter_covariance(rect.calibration if rect is not None else None, details,
                                                     self.state.stereo)
            return self.task.start(run_verification, lab, locator, n, int(self.state.seed), self._verify_count,
                                   stereo.label, self.state.hardware.robot_connection, covariance,
                                   on_done=self._verified, shown=self._shown, label="Verification", then=then,
                                   status=f"Verification over {n} random poses…")

        return self.task.with_lab(go)

    def verification_so_far(self, v: VerificationResult) -> None:
        """The poses measured so far, drawn while the verification runs (a late one is dropped)."""
        if self.task.busy and self._verifying == self._verify_count:
            self.model.emit("verification_so_far", v)

    def _verified(self, v: VerificationResult) -> None:
        self._verifying = 0
        self.model.set_verification(v)
        self._save_details(verification=v)
        cancelled = (f"Cancelled after {v.n} of {v.poses_planned} poses, those measured are kept. "
                     if v.cancelled_after is not None else "")
        if v.n_located:
            self._mark_verified({"kind": "verification", **v.to_dict()})
            self._say(f"✓ {cancelled}Verification: {v.n_located} of {v.n} located, median 3D error "
                      f"{number(v.median_error, 3, 'mm')}, RMS {number(v.rms_error, 3, 'mm')}. "
                      "The step is done.", True)
        else:
            self._say("✗ The marker was not located in any pose: see the reasons.", False)

    # -- the project's records ----------------------------------------------------------------
    def _save_details(self, **result) -> None:
        """What the report draws of this live pair or verification, into marker_details.json."""
        project, saved = self.state.project, self.model.result.saved_path
        if project is not None and saved is not None:
            try:
                write_details(project, saved.name, **result)
            except RoboCalError as exc:
                self._say(f"The details for the report were not written: {exc.message}", False)

    def _mark_verified(self, record: dict) -> None:
        project, saved = self.state.project, self.model.result.saved_path
        if project is not None and saved is not None:
            try:
                write_verification(project, saved.name, record)
            except RoboCalError as exc:
                self._say(f"The verification record was not written: {exc.message}", False)
        self.model.set_verified(True)
        self._completed()
