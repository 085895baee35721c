"""StepModel: options and result of a step with plain-Python listeners."""
from __future__ import annotations

from dataclasses import dataclass

from app.pages.step_model import StepModel


@dataclass(frozen=True)
class Options:
    count: int = 10
    seed: int = 0


def test_listeners_hear_changed_options_and_every_result_in_order():
    model = StepModel(Options())
    heard = []
    model.on("options", lambda o: heard.append(("first", o)))
    model.on("options", lambda o: heard.append(("second", o)))
    model.on("result", lambda r: heard.append(("result", r)))
    model.set_options(Options())                       # equal: nobody is told
    model.set_options(Options(count=12))
    model.set_result(3.5)
    model.set_result(3.5)                              # a result is news even when equal
    assert heard == [("first", Options(12)), ("second", Options(12)), ("result", 3.5), ("result", 3.5)]
    assert model.options == Options(count=12) and model.result == 3.5


def test_a_stopped_listener_hears_nothing_more():
    model = StepModel(Options())
    heard = []
    stop = model.on("result", heard.append)
    model.set_result(1)
    stop()
    stop()                                             # twice: harmless
    model.set_result(None)
    assert heard == [1] and model.result is None
