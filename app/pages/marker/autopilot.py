"""The Marker page's classroom autopilot: stereo (or the lab's preview) → training image →
train → live pair → verify, each action started with `then=` the next one. A mixin of
MarkerPage (before WizardPage)."""
from __future__ import annotations

from typing import Callable

from app.html import number

DEMO_VERIFY = 10             # verification poses of the autopilot


class MarkerAutopilot:
    def autopilot(self, done) -> None:
        if self.state.project is None or self.state.robot is None:
            done(False, "no project or robot model (Setup step)")
            return
        if not self.state.virtual:
            done(False, "the marker autopilot needs the virtual lab (load and train a marker image by hand)")
            return
        if self.task.busy:
            done(False, "the page is busy")
            return
        self._autopilot_done = done
        self._autopilot_next()

    def _autopilot_next(self) -> None:
        """One step of the demo: stereo (or preview) → training image → train → live pair → verify."""
        if self._autopilot_done is None:
            return
        step = self._autopilot_step()
        if step is not None:
            action, why = step
            if not action(then=self._autopilot_next):
                self._finish_autopilot(False, self.status.text() or why)
            return
        v = self.verification
        if self.is_complete():
            self._finish_autopilot(True, f"{self.trained.n_image_features} SIFT features; {v.n_located}/{v.n} "
                                         f"located, median 3D error {number(v.median_error, 3, 'mm')}")
        else:
            self._finish_autopilot(False, "the marker was not located in any verification pose")

    def _autopilot_step(self) -> tuple[Callable[..., bool], str] | None:
        """The demo's next action and what to say if it cannot start; None once it has verified."""
        if self.stereo.rect is None:
            return self.use_preview, "no stereo calibration"
        if self.trained is None or self.saved_path is None:
            if self.training_image is None or self.training_image.source != "virtual lab camera":
                return self.capture_training, "no training image"
            return self.train, "training could not start"
        if self.live is None:
            return self.next_pose, "no live pair"
        if self.verification is None:
            self.verification_panel.verify_spin.setValue(DEMO_VERIFY)
            return self.verify, "verification could not start"
        return None
