"""The Stereo page's queue of worker jobs, run one after the other with the page's task
(detection in small batches, so thumbnails fill in between), and the wait for the virtual
lab (`state.request_lab`) before rendering. The queue's progress covers all its jobs."""
from __future__ import annotations

from typing import Callable

from core.task import Monitor

#: a queued job: (fn(progress=, cancelled=), label, on_done(value))
Job = tuple[Callable, str, Callable]


class JobQueueMixin:
    """For a WizardPage: `_run_queue(jobs, then)`, `_wait_for_lab(then)`, `_stop_jobs()`;
    Cancel and a failure drop the jobs not started. The page sets `_queue`, `_queue_total`,
    `_queue_done` and `_queue_then` in its __init__."""

    def _run_queue(self, jobs: list[Job], then: Callable[[], None] | None = None) -> None:
        self._queue = list(jobs)
        self._queue_total = len(jobs)
        self._queue_done = 0
        self._queue_then = then
        self._next_job()

    def _next_job(self) -> None:
        if not self._queue:
            then, self._queue_then = self._queue_then, None
            self.on_busy_changed()
            if then is not None:
                then()
            return
        fn, label, on_done = self._queue.pop(0)
        total = max(self._queue_total, 1)
        share = (self._queue_done / total, (self._queue_done + 1) / total)
        self.task.start(_share(fn, *share), on_done=on_done, then=self._job_ended, label=label)

    def _job_ended(self) -> None:
        self._queue_done += 1
        self._next_job()

    def _wait_for_lab(self, then: Callable) -> None:
        """Busy until the state's virtual lab is built; then `then(lab)` (the page task's wait, which
        Cancel and `task.forget` end)."""
        self.task.follow_lab(then, self.on_failed)

    def _stop_jobs(self) -> None:
        self._queue.clear()
        self._queue_then = None
        self.task.forget()

    def on_cancel_requested(self) -> None:
        self._queue.clear()
        self._queue_then = None

    def on_failed(self, message: str) -> None:
        self._queue.clear()
        self._queue_then = None
        super().on_failed(message)

    def on_cancelled(self) -> None:
        self._queue.clear()
        self._queue_then = None
        kept = len(self.items)
        self._set_status(f"Cancelled. {kept} pair{'s' if kept != 1 else ''} on the page.", ok=False)
        self._finish_autopilot(False, "cancelled")


def _share(fn: Callable, start: float, stop: float) -> Callable:
    """fn whose progress covers [start, stop] of the whole queue."""
    def job(progress=None, cancelled=None):
        return fn(progress=Monitor(progress, cancelled).sub(start, stop), cancelled=cancelled)
    return job
