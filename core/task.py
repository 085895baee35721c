"""Progress and cancellation for long work (the Orange3 TaskState pattern, without Qt).

A long core function takes `progress` (called with a fraction in [0, 1] and a short
message) and `cancelled` (returns True once the user pressed Cancel), both optional,
wraps them in a `Monitor`, and calls `monitor.step(...)` between units of work.

A sub-task gets its share of the progress bar from `Monitor.sub(start, stop)`; a Monitor is
itself a progress function, so it can be passed on as another function's `progress`:

    inner(..., progress=monitor.sub(0.0, 0.25), cancelled=cancelled)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

from core.errors import Cancelled

ProgressFn = Callable[[float, str], None]
CancelledFn = Callable[[], bool]


@dataclass
class Monitor:
    progress: Optional[ProgressFn] = None
    cancelled: Optional[CancelledFn] = None
    start: float = 0.0
    span: float = 1.0

    def check(self) -> None:
        """Raise `Cancelled` if the user asked to stop."""
        if self.cancelled is not None and self.cancelled():
            raise Cancelled()

    def step(self, fraction: float, message: str = "") -> None:
        """Report progress (fraction of this monitor's span) and honour Cancel."""
        self.check()
        if self.progress is not None:
            frac = min(max(fraction, 0.0), 1.0)
            self.progress(self.start + self.span * frac, message)

    def sub(self, start: float, stop: float) -> "Monitor":
        """A monitor for a sub-task covering [start, stop] of this one."""
        return Monitor(self.progress, self.cancelled,
                       self.start + self.span * start, self.span * (stop - start))

    def __call__(self, fraction: float, message: str = "") -> None:
        """A Monitor is a progress function: ``progress=monitor.sub(a, b)``."""
        self.step(fraction, message)
