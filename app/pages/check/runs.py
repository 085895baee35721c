"""The Check page's runs, on the project's cell: the check poses chosen, a check, a
re-identification of what the diagnosis found and the identification of a newly mounted tool
(app/jobs/check.py, app/jobs/tool.py on the virtual lab; app/jobs/cell_check.py and
app/jobs/cell_teach.py on a real cell). Each reads the model's options, runs on a worker, and puts
what it returns into the model, with its words in the page's status line.

A helper the page holds (`CheckRuns`), with its own state: where the running task measures.
"""
from __future__ import annotations

from typing import Callable

from app.jobs import cell_check, cell_teach
from app.jobs import check as job
from app.jobs import tool as tool_job
from app.pages.check.cell import RealCell
from app.pages.check.inputs import CheckInputs
from app.pages.check.model import CheckModel
from app.pages.check.schedule import CheckSchedule
from app.pages.check.teach import TeachPoses
from app.pages.check.texts import MISSING, measured_on_lab, short_verdict
from app.pages.page_task import PageTask


def setup_on_lab(path, count, tool, *, lab, progress=None, cancelled=None) -> job.CheckSetup:
    """The check poses and limits of the calibrated robot in `path`, chosen on the virtual lab."""
    from app.lab import lab_options
    return job.setup(path, lab_options=lab_options(lab), count=count, sigma_mm=job.weighted_sigma_mm(path),
                     tool=tool, progress=progress, cancelled=cancelled)


class CheckRuns:
    """Runs on the virtual lab or on the real cell (`real_cell`), teach mode's recorded poses (`teach`).
    The page's callables: `set_status(text, ok)`, `status_text()`, `finish_autopilot(ok, message)`,
    `refresh()` (read the log, redraw) and `on_busy_changed()` (enable the controls)."""

    def __init__(self, state, model: CheckModel, inputs: CheckInputs, task: PageTask, real_cell: RealCell,
                 teach: TeachPoses, schedule: CheckSchedule, *, set_status: Callable, status_text: Callable[[], str],
                 finish_autopilot: Callable, refresh: Callable[[], None], on_busy_changed: Callable[[], None]):
        self.state = state
        self.model = model
        self.inputs = inputs
        self.task = task
        self.real_cell = real_cell
        self.teach = teach
        self.schedule = schedule
        self._set_status = set_status
        self._status_text = status_text
        self._finish_autopilot = finish_autopilot
        self._refresh = refresh
        self._on_busy_changed = on_busy_changed
        self.where = ""                        # where the running task measures, in words

    def calibration_changed(self) -> None:
        """Another project, robot or calibration: the running task's result never arrives, nothing
        is checked yet."""
        self.task.forget()
        self.model.clear()
        self.real_cell.measure = None
        self._refresh()

    def can_run(self) -> bool:
        """The project's cell can measure now (else the status line says why)."""
        if not self.inputs.ready():
            self._set_status(MISSING, False)
            self._finish_autopilot(False, MISSING)
            return False
        if not self.state.virtual:
            problem = self.real_cell.problem()
            if problem is not None:
                self._set_status(f"Nothing measured: {problem}. (This project measures on {self.state.cell}; "
                                 "never on the virtual lab.)", False)
                self._finish_autopilot(False, problem)
                return False
        return True

    # -- check poses and checks -------------------------------------------------------
    def choose_poses(self, then: Callable[[], object] | None = None) -> bool:
        """Choose the check poses now (they are chosen with the first check otherwise); `then()`
        once they are."""
        if not self.can_run():
            return False
        key, path, options = self.inputs.key(), self.inputs.calibrated_path(), self.model.options
        if not self.state.virtual:
            return self.task.start(cell_check.setup_cell, path, self.inputs.cell_options(), count=options.count,
                                   tool=options.tool, on_done=lambda cell: self._took_cell(cell, key), then=then,
                                   status="Choosing check poses for the cell's cameras…")
        return self.task.start_with_lab(setup_on_lab, path, options.count, options.tool, then=then,
                                        on_done=lambda cell: self._took_cell(cell, key),
                                        status="Choosing check poses…")

    def _took_cell(self, cell: job.CheckSetup, key: tuple) -> None:
        self.model.take_cell(cell, key)
        self._set_status(f"✓ {len(cell.Q)} check poses chosen; limits from the calibration's uncertainty "
                         f"(σ {cell.unc.sigma_mm:.3f} mm, false alarms {100 * cell.limits.alpha:g} %).", True)
        self._on_busy_changed()

    def check(self) -> bool:
        """One check at every check pose (the poses are chosen first when needed)."""
        if not self.can_run():
            return False
        if not self.state.virtual:
            return self._check_cell()
        key, images, options = self.inputs.key(), self.inputs.images(), self.model.options
        self.where = measured_on_lab(images)
        return self.task.start_with_lab(job.check_project, self.inputs.calibrated_path(),
                                        on_done=lambda r: self._checked(r, key),
                                        cell=self.model.result.cell_for(key), count=options.count,
                                        change=options.change, images=images, log=self.inputs.log_path(),
                                        seed=self.model.result.next_seed(), tool=options.tool,
                                        status=f"Checking: {self.where}…")

    def _check_cell(self) -> bool:
        """A check on the real cell: the check poses first when needed (on a worker), then the
        robot is driven through them once app.safety allowed it (teach mode: the poses recorded by
        hand are checked once every one is recorded)."""
        key = self.inputs.key()
        cell = self.model.result.cell_for(key)
        if self.inputs.teach_mode:
            return self.choose_poses() if cell is None else self._check_taught()
        if cell is None:
            return self.choose_poses(then=lambda: self._drive_check(key))
        return self._drive_check(key)

    def _drive_check(self, key: tuple) -> bool:
        cell = self.model.result.cell
        measure = self.real_cell.measure_for(cell.Q)
        if measure is None:
            self._finish_autopilot(False, self._status_text())
            return False
        self.where = self.real_cell.words()
        return self.task.start(cell_check.check_cell, cell, measure, log=self.inputs.log_path(),
                               on_done=lambda value: self._checked((cell, *value), key),
                               status=f"Checking: {self.where}… Esc stops the robot.")

    def _check_taught(self) -> bool:
        cell = self.model.result.cell
        if self.teach.next_pose() is not None:
            self._set_status(f"Record every check pose first: {len(self.teach.taught)} of {len(cell.Q)} "
                             "recorded.", False)
            return False
        key = self.inputs.key()
        self.where = self.real_cell.words()
        self.real_cell.measure = None

        def checked(value) -> None:
            self.teach.forget()
            self._checked((cell, *value), key)
        return self.task.start(cell_teach.check_taught, cell, list(self.teach.taught.values()),
                               log=self.inputs.log_path(), on_done=checked,
                               status=f"Checking the recorded poses, {self.where}…")

    def _checked(self, value, key: tuple) -> None:
        cell, result, diagnosis = value
        self.model.take_check(cell, result, diagnosis, key)
        self._refresh()
        fault = self.real_cell.fault_words(self.schedule.switch_off)
        payload = job.payload_comparison(self.model.options.payload_kg, cell.model)[0]
        self._set_status(("✓ " if result.within and not fault else "⚠ ") + short_verdict(result)
                         + " Points " + self.where + "." + fault + (" " + payload if payload else ""),
                         result.within and not fault)
        self._finish_autopilot(bool(result.points), "" if result.points else result.verdict())

    # -- a new calibrated.json ------------------------------------------------------------
    def reidentify(self) -> bool:
        """Re-identify what the diagnosis found and check the updated robot."""
        outcome = self.model.result
        if outcome.diagnosis is None or outcome.cell is None or not self.can_run():
            return False
        if self.inputs.teach_mode:
            self._set_status("In teach mode RoboCal cannot drive the proposed poses: measure them with the "
                             "Measurement step's teach mode, then run robocal reidentify with that file.", False)
            return False
        path, log = self.inputs.calibrated_path(), self.inputs.log_path()
        if not self.state.virtual:
            measure = self.real_cell.measure_for()
            if measure is None:
                return False
            self.where = self.real_cell.words()
            return self.task.start(cell_check.reidentify_cell, outcome.cell, outcome.check, outcome.diagnosis,
                                   measure, path, self.inputs.cell_options(), log=log, on_done=self._reidentified,
                                   status=f"Re-identifying from the proposed poses, {self.where}… Esc stops the "
                                          "robot.")
        from app.lab import lab_options
        images, change = self.inputs.images(), self.model.options.change
        self.where = measured_on_lab(images)

        def go(lab):
            return self.task.start(job.reidentify_on_lab, outcome.cell, outcome.check, outcome.diagnosis, lab, change,
                                   path, images=images, lab_options=lab_options(lab), log=log,
                                   seed=outcome.next_seed(), on_done=self._reidentified,
                                   status="Re-identifying from the proposed poses…")
        return self.task.with_lab(go, status="Re-identifying…")

    def _reidentified(self, update: job.Update) -> None:
        # calibrated.json now holds a newer calibration than this session's identification:
        # Export and the report read the file from here on
        self.state.set_identification(None)
        self.model.take_update(update, self.inputs.key())
        self._refresh()
        changed = ", ".join(update.reidentification.changed)
        self._set_status(f"✓ Re-identified {changed} from {len(update.proposed)} proposed "
                         f"pose{'s' if len(update.proposed) != 1 else ''} and the check, "
                         f"{self.where}; wrote {update.path.name} (the previous one is kept in history/). Check "
                         f"of the updated robot: {short_verdict(update.after)}"
                         + self.real_cell.fault_words(self.schedule.switch_off),
                         update.after.within and not update.after.cancelled)

    def identify_tool(self) -> bool:
        """Identify the tool chosen as mounted from its proposed poses, and replace calibrated.json
        (the previous one kept in history/)."""
        options = self.model.options
        if options.tool is None or not self.can_run():
            return False
        path = self.inputs.calibrated_path()
        if not self.state.virtual:
            measure = self.real_cell.measure_for()
            if measure is None:
                return False
            self.where = self.real_cell.words()
            return self.task.start(cell_check.identify_tool_cell, path, options.tool, measure,
                                   self.inputs.cell_options(), on_done=self._tool_identified,
                                   status=f"Identifying the tool '{options.tool}' from its proposed poses, "
                                          f"{self.where}… Esc stops the robot.")
        images = self.inputs.images()
        self.where = measured_on_lab(images)
        return self.task.start_with_lab(tool_job.identify_on_lab, path, options.tool, change=options.change,
                                        images=images, seed=self.model.result.next_seed(),
                                        on_done=self._tool_identified,
                                        status=f"Identifying the tool '{options.tool}' from its proposed poses…")

    def _tool_identified(self, update: tool_job.ToolUpdate) -> None:
        self.state.set_identification(None)     # Export and the report read the updated file
        self.model.take_tool_update(update)
        self._refresh()
        self._set_status(f"✓ {update.identification.text()} Points {self.where}. Wrote {update.path.name} (the "
                         f"previous one is kept in history/).", True)
