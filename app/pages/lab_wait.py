"""Waiting for the virtual lab before a page's task: `when_lab(then)`.

The state builds the lab once on its own worker (`WizardState.request_lab`); while a page waits
for it the page counts as busy (its controls off, Cancel on), Cancel or `forget_task()` drop the
wait, and `then(lab)` runs on the GUI thread only if the page still wants it. Mix in before
WizardPage: ``class MeasurementPage(LabWaitMixin, WizardPage)``.
"""
from __future__ import annotations

from typing import Callable


class LabWaitMixin:
    """`when_lab(then, status=...)`: call `then(lab)` once the state's virtual lab exists."""

    _lab_wait: int = 0            # the number of the current wait; 0 when not waiting
    _lab_waits: int = 0

    @property
    def busy(self) -> bool:
        return bool(self._lab_wait) or super().busy

    def when_lab(self, then: Callable[[object], bool], *, status: str = "Building the virtual lab…") -> bool:
        """Ask the state for the lab, then `then(lab)`, which starts the page's task and says
        whether it did. Returns `then`'s answer when the lab exists, True while it is being
        built, False when the page is busy. `then` reports its own failure to start (status
        line, autopilot)."""
        if self.busy:
            self._set_status("Busy: wait for the running task or cancel it.", False)
            return False
        if self.state.has_lab:
            return then(self.state.lab)
        self._lab_waits += 1
        wait = self._lab_wait = self._lab_waits

        def built(lab) -> None:
            if self._end_wait(wait):
                then(lab)

        def failed(message: str) -> None:
            if self._end_wait(wait):
                self.on_failed(message)

        self._busy_changed()
        self._set_status(status, None)
        self.state.request_lab(built, failed)
        return True

    def _end_wait(self, wait: int) -> bool:
        if wait != self._lab_wait:
            return False
        self._lab_wait = 0
        self._busy_changed()
        return True

    def cancel(self) -> None:
        if self._lab_wait:
            self._lab_wait = 0
            self._busy_changed()
            self.on_cancelled()
            return
        super().cancel()

    def forget_task(self) -> None:
        if self._lab_wait:
            self._lab_wait = 0
            self._busy_changed()
        super().forget_task()
