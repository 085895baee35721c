"""The virtual lab of one wizard window, built once on a worker thread and handed to whoever
waits for it.

    labs = LabProvider(recipe)                  # recipe() -> (nominal RobotModel, seed, noise)
    wait = labs.when_ready(use_lab, on_error)   # at once if built; else when the one build ends
    wait.cancel()                               # use_lab / on_error will not be called
    labs.current                                # the lab, or None while not built (labs.built)
    labs.ready_now()                            # scripts and tests: build if need be and wait
    labs.reset("why")                           # the robot changed: forget the lab and its build

Every caller that waits meanwhile waits for the same build (`changed(lab)` is emitted when the
lab is there or forgotten). Building the lab takes about 0.3 s (its first rendering ~1 s more),
never on the GUI thread.
"""
from __future__ import annotations

from typing import Callable

from PySide6.QtCore import QObject, Signal

from app.lab import VirtualLab, build_lab
from app.task_handle import CurrentTask
from app.worker import TaskRunner
from core.errors import RoboCalError

#: () -> (nominal robot, seed, noise in grey levels): what the lab is built from when asked
Recipe = Callable[[], tuple]


class LabWait:
    """One caller waiting for the lab; `cancel()` and neither of its callbacks runs."""

    def __init__(self, provider: "LabProvider", callback: Callable[[VirtualLab], None],
                 on_error: Callable[[str], None] | None):
        self._provider = provider
        self.callback, self.on_error = callback, on_error

    def cancel(self) -> None:
        self._provider._withdraw(self)


class LabProvider(QObject):
    """Signal: `changed(VirtualLab | None)`."""

    changed = Signal(object)

    def __init__(self, recipe: Recipe, parent: QObject | None = None):
        super().__init__(parent)
        self._recipe = recipe
        self._lab: VirtualLab | None = None
        self._waiting: list[LabWait] = []
        self._runner = TaskRunner(self, max_threads=1)
        self._build = CurrentTask(self._runner)

    @property
    def current(self) -> VirtualLab | None:
        return self._lab

    @property
    def built(self) -> bool:
        """The lab exists (no wait)."""
        return self._lab is not None

    @property
    def building(self) -> bool:
        return self._build.busy

    def when_ready(self, callback: Callable[[VirtualLab], None],
                   on_error: Callable[[str], None] | None = None) -> LabWait:
        """Call `callback(lab)`: at once when the lab exists, otherwise when the build on the
        worker thread ends (started now if none runs). A failed build calls `on_error(message)`."""
        wait = LabWait(self, callback, on_error)
        if self._lab is not None:
            callback(self._lab)
            return wait
        self._waiting.append(wait)
        if not self._build.busy:
            robot, seed, noise = self._recipe()
            self._build.start(build_lab, robot, seed, float(noise), on_result=self.adopt, on_error=self._failed,
                              on_cancelled=lambda: self._failed("the virtual lab was not built"),
                              label="Building the virtual lab")
        return wait

    def ready_now(self, timeout_ms: int = 600_000) -> VirtualLab:
        """The lab, built on the worker if need be and waited for here (scripts and tests; a
        page uses `when_ready`). Raises RoboCalError when the build fails."""
        if self._lab is None:
            errors: list[str] = []
            self.when_ready(lambda lab: None, errors.append)
            self._runner.wait(timeout_ms)
            if self._lab is None:
                raise RoboCalError(errors[0] if errors else "the virtual lab was not built in time")
        return self._lab

    def adopt(self, lab: VirtualLab) -> None:
        """Make `lab` the lab (built here or elsewhere); a build under way is dropped and every
        caller waiting gets this one."""
        self._build.forget()
        if lab is not self._lab:
            self._lab = lab
            self.changed.emit(lab)
        waiting, self._waiting = self._waiting, []
        for wait in waiting:
            wait.callback(lab)

    def adopt_matching(self, lab: VirtualLab | None) -> None:
        """Take a lab built elsewhere (one lab shared by several windows, as the tests do) when
        none is built here and it matches the recipe's robot, seed and noise; else nothing."""
        robot, seed, noise = self._recipe()
        if self._lab is not None or lab is None or robot is None:
            return
        if (getattr(lab, "seed", None), getattr(lab, "noise", None)) != (seed, float(noise)):
            return
        nominal = getattr(lab, "nominal_robot", None)
        if nominal is None or nominal.name != robot.name or nominal.dof != robot.dof:
            return
        self.adopt(lab)

    def reset(self, reason: str) -> None:
        """Forget the lab and any build under way (the robot changed); callers waiting get
        `on_error(reason)`."""
        self._build.forget()
        self._failed(reason)
        if self._lab is not None:
            self._lab = None
            self.changed.emit(None)

    def close(self) -> None:
        """Stop the build and its thread (the window closes). Nobody waiting is called."""
        self._waiting.clear()
        self._build.forget()
        self._runner.shutdown()

    def _failed(self, message: str) -> None:
        waiting, self._waiting = self._waiting, []
        for wait in waiting:
            if wait.on_error is not None:
                wait.on_error(message)

    def _withdraw(self, wait: LabWait) -> None:
        if wait in self._waiting:
            self._waiting.remove(wait)
