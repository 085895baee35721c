"""What a step's model says, recorded for a test."""
from __future__ import annotations

from typing import Any

from app.pages.step_model import StepModel


def heard(model: StepModel, *events: str) -> list[tuple[str, Any]]:
    """(event, value) pairs, in the order `model` emits them, for each of `events`."""
    got: list[tuple[str, Any]] = []
    for event in events:
        model.on(event, lambda value, event=event: got.append((event, value)))
    return got
