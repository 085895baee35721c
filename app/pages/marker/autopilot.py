"""The Marker page's classroom autopilot, a helper the page holds (not a base class): stereo (or
the lab's preview) → training image → train → live pair → verify, each action started with
`then=` the next one; it keeps the `done` callback of the run under way."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from app.html import number
from app.pages.marker.model import MarkerModel, VerificationOptions
from app.pages.page_task import PageTask

DEMO_VERIFY = 10             # verification poses of the autopilot

Action = Callable[..., bool]           # action(then=next step) -> started


@dataclass
class MarkerActions:
    """The page's actions the demo runs, in its order."""

    use_preview: Action
    capture_training: Action
    train: Action
    next_pose: Action
    verify: Action


class MarkerAutopilot:
    """`status_text()` is the page's status line (why an action could not start),
    `is_complete()` the page's."""

    def __init__(self, state, model: MarkerModel, task: PageTask, actions: MarkerActions, *,
                 status_text: Callable[[], str], is_complete: Callable[[], bool]):
        self.state, self.model, self.task = state, model, task
        self._actions = actions
        self._status_text = status_text
        self._is_complete = is_complete
        self._done = None                       # done(ok, message) of the run under way

    def start(self, done) -> None:
        if self.state.project is None or self.state.robot is None:
            done(False, "no project or robot model (Setup step)")
            return
        if not self.state.virtual:
            done(False, "the marker autopilot needs the virtual lab (load and train a marker image by hand)")
            return
        if self.task.busy:
            done(False, "the page is busy")
            return
        self._done = done
        self._next()

    def finish(self, ok: bool, message: str = "") -> None:
        """Report the end of the run once (a failed or cancelled task ends it too)."""
        done, self._done = self._done, None
        if done is not None:
            done(ok, message)

    def _next(self) -> None:
        """One step of the demo: stereo (or preview) → training image → train → live pair → verify."""
        if self._done is None:
            return
        step = self._step()
        if step is not None:
            action, why = step
            if not action(then=self._next):
                self.finish(False, self._status_text() or why)
            return
        r = self.model.result
        v = r.verification
        if self._is_complete():
            self.finish(True, f"{r.trained.n_image_features} SIFT features; {v.n_located}/{v.n} "
                              f"located, median 3D error {number(v.median_error, 3, 'mm')}")
        else:
            self.finish(False, "the marker was not located in any verification pose")

    def _step(self) -> tuple[Action, str] | None:
        """The demo's next action and what to say if it cannot start; None once it has verified."""
        a, r = self._actions, self.model.result
        if self.model.stereo.rect is None:
            return a.use_preview, "no stereo calibration"
        if r.trained is None or r.saved_path is None:
            if r.training_image is None or r.training_image.source != "virtual lab camera":
                return a.capture_training, "no training image"
            return a.train, "training could not start"
        if r.live is None:
            return a.next_pose, "no live pair"
        if r.verification is None:
            self.model.choose(verification=VerificationOptions(DEMO_VERIFY))
            return a.verify, "verification could not start"
        return None
