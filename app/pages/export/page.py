"""Step 7, Export: the folder, one row per export (items.py says what each writes, rows_panel.py
draws them), "Export all" for every available one into the export folder (project/export/ by
default); the report is written on a worker, its figures drawn here one at a time. The folder
chosen and the files written are the model's (model.py); the boxes draw from it."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QVBoxLayout

from app.pages.base import WizardPage
from app.pages.export import export_all
from app.pages.export.folder_box import FolderBox
from app.pages.export.items import REPORT, ExportSources
from app.pages.export.model import ExportModel, ExportOptions, exported_text
from app.pages.export.rows_panel import ExportRows
from app.pages.steps import Step
from app.report.gui_drawer import GuiDrawer
from app.report.render import write_report
from app.report.title_fields import ReportTitleFields
from core.errors import RoboCalError
from core.files import ensure_writable_dir
from core.locks import output_locks
from widgets.wrapping_box import hold_height_for_width


def _finished(finished, written: list[Path]) -> list[Path]:
    """`finished(written)` when given; `written`."""
    if finished is not None:
        finished(written)
    return written


class ExportPage(WizardPage):
    step = Step.EXPORT

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.model = ExportModel()
        self._drawer = GuiDrawer(self)           # the report's figures, drawn here for its worker
        self.sources = ExportSources(state)
        self.items = self.sources.items()
        self._titles = {item.key: item.title for item in self.items}

        self.folder_box = FolderBox()
        self.folder_edit, self.folder_button, self.all_button = (self.folder_box.folder_edit,
                                                                 self.folder_box.folder_button,
                                                                 self.folder_box.all_button)
        self.folder_button.clicked.connect(lambda *_: self.choose_folder())
        self.all_button.clicked.connect(lambda *_: self.export_all())
        self.rows_panel = hold_height_for_width(ExportRows(self.items, lambda key: self.export(key)))   # all lines shown
        self.rows = self.rows_panel.rows
        self.report_title = ReportTitleFields()       # student/operator, course, serial number

        self.status.setTextFormat(Qt.TextFormat.PlainText)
        self.status.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.folder_box)
        layout.addWidget(self.rows_panel)
        layout.addWidget(self.report_title)
        layout.addWidget(self.task.progress_row())
        layout.addWidget(self.status)
        layout.addStretch(1)

        state.projectChanged.connect(self._project_changed)
        state.robotChanged.connect(lambda *_: self.refresh())
        state.identificationChanged.connect(lambda *_: self.refresh())
        state.stereoChanged.connect(lambda *_: self.refresh())
        self.refresh()

    # -- where ---------------------------------------------------------------------------
    @property
    def exported(self) -> dict[str, list[Path]]:
        """The files written in this session, by row key."""
        return self.model.result

    def folder(self) -> Path | None:
        return self.model.folder(self.state.project)

    def set_folder(self, folder: str | Path | None) -> None:
        self.model.set_options(ExportOptions(Path(folder) if folder else None))
        self.refresh()

    def choose_folder(self) -> Path | None:
        chosen = self.folder_box.ask_folder(self.folder() or Path.home())
        if chosen is None:
            return None
        self.set_folder(chosen.folder)
        return chosen.folder

    def _project_changed(self, *_):
        self.task.forget()
        self.model.forget()
        self.refresh()
        self.notify_complete()

    def calibrated_source(self) -> str | None:
        return self.sources.calibrated_source()

    # -- actions -------------------------------------------------------------------------
    def export(self, key: str, *, finished: Callable[[list[Path]], None] | None = None) -> list[Path]:
        """Write one export into the folder; the outcome is shown in its row. The report is
        written on a worker (figures drawn on the GUI thread one at a time): `export` returns []
        at once and `finished(written)` follows ([] on failure or Cancel)."""
        item = next(i for i in self.items if i.key == key)
        missing = item.missing()
        if missing:
            self.rows_panel.set_status(key, f"Not available: {missing}.", ok=False)
            return _finished(finished, [])
        try:
            folder = ensure_writable_dir(self.folder())
            if key == REPORT:
                self._start_report(folder, finished)
                return []
            with output_locks([folder / name for name in item.files]):     # not while a robocal command writes them
                written = item.write(folder)
        except RoboCalError as exc:
            self._export_failed(key, exc.message)
            return _finished(finished, [])
        except OSError as exc:
            self.rows_panel.set_status(key, f"✗ cannot read the input ({exc.strerror})", ok=False)
            return _finished(finished, [])
        self._exported(key, written, folder)
        return _finished(finished, written)

    def _start_report(self, folder: Path, finished: Callable[[list[Path]], None] | None) -> None:
        def failed(message: str) -> None:
            self.task.progress_row().reset()
            self._export_failed(REPORT, message)
            _finished(finished, [])

        def cancelled() -> None:
            self.task.progress_row().reset()
            self.rows_panel.set_status(REPORT, "Cancelled: the previous report (if any) is kept.", ok=False)
            self._set_status("Report cancelled.", ok=False)
            _finished(finished, [])

        def done(written: list[Path]) -> None:
            self._exported(REPORT, written, folder)
            _finished(finished, written)

        state = self.state
        if self.task.start(write_report, state.project, [folder / "report.html", folder / "report.pdf"],
                           robot=state.robot, identification=state.identification, accuracy=state.accuracy,
                           **self.report_title.values(), draw=self._drawer.draw, on_done=done, on_failed=failed,
                           on_cancelled=cancelled, label="report", status="Writing the report…"):
            self.task.progress_row().set_progress(0.0, "reading the project")
            self.rows_panel.set_status(REPORT, "Writing…", ok=None)
        else:
            _finished(finished, [])

    def _export_failed(self, key: str, message: str) -> None:
        self.rows_panel.set_status(key, f"✗ {message}", ok=False)
        self._set_status(f"✗ {self._titles[key]}: {message}", ok=False)

    def _exported(self, key: str, written: list[Path], folder: Path) -> None:
        self.model.exported(key, written)
        self.rows[key]["status"].setProperty("done", True)
        self.rows_panel.set_status(key, exported_text(written), ok=True)
        self._set_status(f"✓ {self._titles[key]} written to {folder}", ok=True)
        self.notify_complete()

    def export_all(self, finished: Callable[[dict, list[str]], None] | None = None) -> None:
        """Every available export into the folder, one after the other; says what was skipped
        and why. `finished(done, failed)` once all are done (the report last, on a worker)."""
        export_all.export_all(
            self.items, self.export, folder=self.folder, finished=finished,
            skipped_row=lambda key, missing: self.rows_panel.set_status(key, f"Not available: {missing}.", ok=False),
            say=lambda text, ok: self._set_status(text, ok=ok))

    def on_busy_changed(self) -> None:
        busy = self.task.busy
        self.all_button.setEnabled(not busy and any(i.missing() is None for i in self.items))
        self.folder_button.setEnabled(not busy and self.state.project is not None)
        self.rows_panel.set_enabled(self.items, busy)

    # -- WizardPage ----------------------------------------------------------------------
    def on_enter(self) -> None:
        self.refresh()

    def is_complete(self) -> bool:
        return bool(self.model.result)

    def autopilot(self, done) -> None:
        if self.state.project is None:
            done(False, "no project (Setup step)")
            return
        self.model.set_options(ExportOptions())

        def finished(written: dict, failed: list[str]) -> None:
            if not written:
                done(False, self.status.text())
            elif failed:
                done(False, "export failed: " + ", ".join(failed))
            else:
                done(True, "")
        self.export_all(finished)

    # -- display -------------------------------------------------------------------------
    def refresh(self) -> None:
        folder = self.folder()
        self.folder_box.show_folder(folder)
        self.rows_panel.show_rows(self.items, folder, self.calibrated_source(), self.model.result,
                                  writing=self.task.busy)
        self.on_busy_changed()
        if self.state.project is None:
            self._set_status("Create or open a project first (Setup step).", ok=False)
        elif not self.model.result:
            self._set_status("Choose what to export, or Export all.", ok=None)

    def row_text(self, key: str) -> str:
        """Target and status of one row (tests)."""
        return self.rows_panel.text(key)
