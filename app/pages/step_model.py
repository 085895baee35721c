"""A step's model: what the technician chose (its options) and what the step produced (its
result), in plain Python with change notifications and no Qt (as napari's evented layers, and
Orange's widget settings). A page is the small controller between them:

    model = StereoModel(StereoOptions())                 # app/pages/<step>/model.py
    model.on("result", results_panel.draw)               # panels follow the model
    model.set_options(options_panel.options())           # the panel says what was chosen
    page.task.start(job, model.options, on_done=model.set_result)   # model -> job -> model

Rules: a panel never starts a job (it emits what the user asked, the page starts it); a job
never touches Qt; a model imports neither Qt nor widgets (an import-linter contract).
"""
from __future__ import annotations

from collections import defaultdict
from typing import Any, Callable, Generic, TypeVar

OptionsT = TypeVar("OptionsT")
ResultT = TypeVar("ResultT")


class StepModel(Generic[OptionsT, ResultT]):
    """Options and result of one step; listeners per event name ("options", "result", or a
    step's own), called in the order they were added, on the thread that changed the model."""

    def __init__(self, options: OptionsT):
        self.options: OptionsT = options
        self.result: ResultT | None = None
        self._listeners: dict[str, list[Callable[[Any], None]]] = defaultdict(list)

    def on(self, event: str, listener: Callable[[Any], None]) -> Callable[[], None]:
        """Call `listener(value)` on each `event`; returns the function that stops it."""
        self._listeners[event].append(listener)

        def stop() -> None:
            if listener in self._listeners[event]:
                self._listeners[event].remove(listener)
        return stop

    def emit(self, event: str, value: Any = None) -> None:
        for listener in list(self._listeners[event]):
            listener(value)

    def set_options(self, options: OptionsT) -> None:
        """Keep what the technician chose; listeners hear of it only when it changed."""
        if options != self.options:
            self.options = options
            self.emit("options", options)

    def set_result(self, result: ResultT | None) -> None:
        """A new result (None: cleared, e.g. another project); listeners always hear of it."""
        self.result = result
        self.emit("result", result)
