"""The Check step's model in plain Python (no Qt): what the technician chose on the page (its
options) and what the page's runs produced (its outcome), with change notifications
(app.pages.step_model.StepModel). Besides "options" and "result", the panels draw from:

  "poses"    check poses were chosen (value: the CheckOutcome, its `cell` set)
  "check"    a check was judged, or a re-identification checked the updated robot (the CheckOutcome)
  "cleared"  another project, robot or calibration: nothing checked yet (the CheckOutcome)
  "log"      the project's check log was read (core.monitoring.log.CheckLog, or None)
  "fixture"  a fixture was located (app.jobs.fixture.FixtureRun)
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from app.pages.step_model import StepModel
from core.monitoring.check_poses import DEFAULT_CHECK_POSES

if TYPE_CHECKING:
    from app.jobs.check import CheckSetup, Update
    from app.jobs.fixture import FixtureRun
    from app.jobs.tool import ToolUpdate
    from core.monitoring.check import CheckResult
    from core.monitoring.diagnosis import Diagnosis
    from core.monitoring.log import CheckLog

_OUTCOME = object()      # an event's value is the whole outcome


@dataclass(frozen=True)
class CheckOptions:
    """What the technician chose: `count` check poses; the `tool` mounted (None: the robot has one
    tool); the `change` the virtual lab simulates, as the lab reads it ("tool:1.5", "joint3:-0.4",
    "mount:gripper"; None: none); the `payload_kg` on the flange now (kg; None: not said); a check
    every `schedule_minutes` (min; None: no schedule)."""

    count: int = DEFAULT_CHECK_POSES
    tool: str | None = None
    change: str | None = None
    payload_kg: float | None = None
    schedule_minutes: int | None = None


@dataclass(frozen=True)
class CheckOutcome:
    """What the page's runs produced: the check poses and limits (`cell`, chosen for `cell_key`:
    calibrated file, its mtime, pose count, tool), the last `check` and its `diagnosis` (None:
    within limits or not diagnosed), the last re-identification (`update`), the last identified
    tool (`tool_update`), the last located fixture (`fixture_run`) and the project's check log."""

    cell: CheckSetup | None = None
    cell_key: tuple | None = None
    check: CheckResult | None = None
    diagnosis: Diagnosis | None = None
    update: Update | None = None
    tool_update: ToolUpdate | None = None
    fixture_run: FixtureRun | None = None
    log: CheckLog | None = None

    def cell_for(self, key: tuple) -> CheckSetup | None:
        """The check poses when chosen for `key` (None: the calibration, pose count or tool changed)."""
        return self.cell if self.cell is not None and self.cell_key == key else None

    @property
    def can_reidentify(self) -> bool:
        """The diagnosis explains the change by parameters a re-identification can estimate."""
        d = self.diagnosis
        return d is not None and d.explained and bool(d.parameters)

    @property
    def complete(self) -> bool:
        """The log holds a finished check."""
        return self.log is not None and any(c.finished for c in self.log.checks)

    def next_seed(self) -> int:
        """A new noise seed for every check, also after a restart (the log's length)."""
        return 1 + len(self.log.checks) if self.log is not None else 1


class CheckModel(StepModel[CheckOptions, CheckOutcome]):
    """The Check step's options and outcome; each change of the outcome is heard as "result" and,
    when something is to be drawn, as its own event (see the module's docstring)."""

    def __init__(self, options: CheckOptions | None = None):
        super().__init__(options or CheckOptions())
        self.result: CheckOutcome = CheckOutcome()

    def _change(self, event: str | None, value: Any = _OUTCOME, **fields) -> None:
        """Replace `fields` of the outcome; then "result" and `event` with `value` (default: the outcome)."""
        self.set_result(replace(self.result, **fields))
        if event is not None:
            self.emit(event, self.result if value is _OUTCOME else value)

    def clear(self) -> None:
        """Another project, robot or calibration: no check poses, check or re-identification."""
        self._change("cleared", cell=None, cell_key=None, check=None, diagnosis=None, update=None)

    def take_cell(self, cell: CheckSetup, key: tuple) -> None:
        self._change("poses", cell=cell, cell_key=key)

    def take_check(self, cell: CheckSetup, check: CheckResult, diagnosis: Diagnosis | None, key: tuple) -> None:
        """A check judged at `cell`'s poses (taken as the check poses when others)."""
        if cell is not self.result.cell:
            self.take_cell(cell, key)
        self._change("check", check=check, diagnosis=diagnosis, update=None)

    def take_update(self, update: Update, key: tuple) -> None:
        """A re-identification: its check of the updated robot becomes the last check."""
        self._change("check", cell=update.cell, cell_key=key, check=update.after, diagnosis=None, update=update)

    def take_tool_update(self, update: ToolUpdate) -> None:
        """A tool identified: the calibration changed, check poses and check are to be made again."""
        self._change(None, cell=None, cell_key=None, check=None, diagnosis=None, tool_update=update)

    def take_log(self, log: CheckLog | None) -> None:
        self._change("log", log, log=log)

    def take_fixture(self, run: FixtureRun) -> None:
        self._change("fixture", run, fixture_run=run)
