"""Where the Compensation page's motions go and how their landings are measured: the virtual lab's
true robot with its rendered cameras, or the connected robot (a serial controller, sim-robot)
after the safety checks of app/safety.py, with the chosen cameras or the lab's cameras rendering
where the robot reports its joints."""
from __future__ import annotations

from typing import Callable

from app.jobs import compensation as job
from app.jobs.measurement_hardware import capture_source
from app.pages.measurement_inputs import project_marker, stereo_source
from app.pages.page_task import PageTask
from app.safety import motion_refused
from core.errors import RoboCalError


class CellMotion:
    """Given the page (asked the first-motion question), the wizard's state, the page's task and
    its status line `say(text, ok)`."""

    def __init__(self, page, state, task: PageTask, say: Callable[[str, bool | None], None]):
        self._page = page
        self._state = state
        self._task = task
        self._say = say

    @property
    def on_hardware(self) -> bool:
        """Motion goes to a connected robot (a serial controller) or the chosen cameras measure."""
        hardware = self._state.hardware
        return hardware.real_robot or hardware.cameras is not None or not self._state.virtual

    def images(self):
        """(trained marker, stereo rectification) when the project has both, else None."""
        try:
            trained = project_marker(self._state)
        except RoboCalError:
            return None
        rect = stereo_source(self._state).rect
        return (trained, rect) if trained is not None and rect is not None else None

    def with_measure(self, Q, go) -> bool:
        """`go(measure, measured_by, lab)` once the robot may move to every row of Q: the virtual
        lab's true robot, or the connected robot with the cameras (or the lab's cameras rendering
        where it is)."""
        images = self.images()
        state = self._state
        if not self.on_hardware:
            def on_lab(lab):
                measure, where = job.lab_measure(lab, images, seed=int(state.seed))
                return go(measure, where, lab)
            return self._task.with_lab(on_lab)
        if images is None:
            self._say("Measuring on this robot needs the trained marker and the stereo calibration: run "
                      "the Stereo and Marker steps first.", False)
            return False
        if state.hardware.cameras is None and not state.virtual:
            self._say("No cameras: open the two cameras on the Setup page.", False)
            return False
        refused = motion_refused(self._page, state, Q)
        if refused:
            self._say(refused, False)
            return False
        driver = state.hardware.robot_connection

        def on_robot(lab):
            try:
                source = capture_source(state.hardware.cameras, lab=lab, driver=driver, seed=int(state.seed))
            except RoboCalError as exc:
                self._say(f"✗ {exc.message}", False)
                return False
            measure, where = job.robot_measure(driver, source, images, rendered=state.hardware.cameras is None)
            return go(measure, where, lab)
        return self._task.with_lab(on_robot) if state.hardware.cameras is None else on_robot(None)
