"""Step 7, Export: the folder, one row per export (items.py says what each writes, rows_panel.py
draws them), "Export all" for every available one into the export folder (project/export/ by
default); the report is written on a worker, its figures drawn here one at a time."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFileDialog, QGroupBox, QHBoxLayout, QLineEdit, QVBoxLayout

from app.pages import forms
from app.pages.base import WizardPage
from app.pages.export.items import REPORT, ExportItem, ExportSources
from app.pages.export.rows_panel import ExportRows
from app.pages.steps import Step
from app.report.gui_drawer import GuiDrawer
from app.report.render import write_report
from app.report.title_fields import ReportTitleFields
from core.errors import RoboCalError
from core.files import ensure_writable_dir
from core.locks import output_locks
from widgets.wrapping_box import hold_height_for_width

EXPORT_FOLDER = "export"


class ExportPage(WizardPage):
    step = Step.EXPORT

    def __init__(self, state, tasks, **kwargs):
        super().__init__(state, tasks, **kwargs)
        self.exported: dict[str, list[Path]] = {}
        self._folder: Path | None = None         # chosen by the user; None: project/export
        self._drawer = GuiDrawer(self)           # the report's figures, drawn here for its worker

        self.sources = ExportSources(state)
        self.items = self.sources.items()

        # -- folder --------------------------------------------------------------------
        self.folder_edit = QLineEdit()
        self.folder_edit.setObjectName("exportFolder")
        self.folder_edit.setReadOnly(True)
        self.folder_button = forms.button("Choose folder…", on_click=self.choose_folder)
        self.all_button = forms.button("Export all", "exportAllButton", on_click=self.export_all)
        self.all_button.setDefault(True)
        folder_box = QGroupBox("Export folder")
        fl = QHBoxLayout(folder_box)
        fl.addWidget(self.folder_edit, 1)
        fl.addWidget(self.folder_button)
        fl.addWidget(self.all_button)

        self.rows_panel = hold_height_for_width(ExportRows(self.items, lambda key: self.export(key)))   # all lines shown
        self.rows = self.rows_panel.rows
        self.report_title = ReportTitleFields()       # student/operator, course, serial number

        self.status.setTextFormat(Qt.TextFormat.PlainText)
        self.status.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)

        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(folder_box)
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
    def folder(self) -> Path | None:
        if self._folder is not None:
            return self._folder
        if self.state.project is None:
            return None
        return self.state.project.folder / EXPORT_FOLDER

    def set_folder(self, folder: str | Path | None) -> None:
        self._folder = Path(folder) if folder else None
        self.refresh()

    def choose_folder(self) -> Path | None:
        start = str(self.folder() or Path.home())
        chosen = QFileDialog.getExistingDirectory(self, "Export folder", start)
        if not chosen:
            return None
        self.set_folder(chosen)
        return Path(chosen)

    def _project_changed(self, *_):
        self.task.forget()
        self._folder = None
        self.exported.clear()
        self.refresh()
        self.notify_complete()

    def calibrated_source(self) -> str | None:
        return self.sources.calibrated_source()

    # -- actions -------------------------------------------------------------------------
    def item(self, key: str) -> ExportItem:
        return next(i for i in self.items if i.key == key)

    def export(self, key: str, *, finished: Callable[[list[Path]], None] | None = None) -> list[Path]:
        """Write one export into the folder; the outcome is shown in its row. The report is
        written on a worker (figures drawn on the GUI thread one at a time): `export` returns []
        at once and `finished(written)` follows ([] on failure or Cancel)."""
        item = self.item(key)
        missing = item.missing()
        if missing:
            self._row_status(key, f"Not available: {missing}.", ok=False)
            return self._finished(finished, [])
        try:
            folder = ensure_writable_dir(self.folder())
            if key == REPORT:
                self._start_report(folder, finished)
                return []
            with output_locks([folder / name for name in item.files]):     # not while a robocal command writes them
                written = item.write(folder)
        except RoboCalError as exc:
            self._export_failed(key, exc.message)
            return self._finished(finished, [])
        except OSError as exc:
            self._row_status(key, f"✗ cannot read the input ({exc.strerror})", ok=False)
            return self._finished(finished, [])
        self._exported(key, written, folder)
        return self._finished(finished, written)

    @staticmethod
    def _finished(finished, written: list[Path]) -> list[Path]:
        if finished is not None:
            finished(written)
        return written

    def _start_report(self, folder: Path, finished: Callable[[list[Path]], None] | None) -> None:
        def failed(message: str) -> None:
            self.task.progress_row().reset()
            self._export_failed("report", message)
            self._finished(finished, [])

        def cancelled() -> None:
            self.task.progress_row().reset()
            self._row_status("report", "Cancelled: the previous report (if any) is kept.", ok=False)
            self._set_status("Report cancelled.", ok=False)
            self._finished(finished, [])

        def done(written: list[Path]) -> None:
            self._exported("report", written, folder)
            self._finished(finished, written)

        if self.task.start(write_report, self.state.project, [folder / "report.html", folder / "report.pdf"],
                      robot=self.state.robot, identification=self.state.identification, accuracy=self.state.accuracy,
                      **self.report_title.values(), draw=self._drawer.draw, on_done=done, on_failed=failed,
                      on_cancelled=cancelled,
                      label="report", status="Writing the report…"):
            self.task.progress_row().set_progress(0.0, "reading the project")
            self._row_status("report", "Writing…", ok=None)
        else:
            self._finished(finished, [])

    def _export_failed(self, key: str, message: str) -> None:
        self._row_status(key, f"✗ {message}", ok=False)
        self._set_status(f"✗ {self.item(key).title}: {message}", ok=False)

    def _exported(self, key: str, written: list[Path], folder: Path) -> None:
        self.exported[key] = written
        self.rows[key]["status"].setProperty("done", True)
        self._row_status(key, "✓ Exported: " + ", ".join(p.name for p in written), ok=True)
        self._set_status(f"✓ {self.item(key).title} written to {folder}", ok=True)
        self.notify_complete()

    def export_all(self, finished: Callable[[dict, list[str]], None] | None = None) -> None:
        """Every available export into the folder, one after the other; says what was skipped
        and why. `finished(done, failed)` once all are done (the report last, on a worker)."""
        done: dict[str, list[Path]] = {}
        skipped: list[str] = []
        failed: list[str] = []
        todo = []
        for item in self.items:
            missing = item.missing()
            if missing:
                skipped.append(f"{item.title} ({missing})")
                self._row_status(item.key, f"Not available: {missing}.", ok=False)
            else:
                todo.append(item)

        def next_one(_written=None) -> None:
            if not todo:
                summary()
                return
            item = todo.pop(0)

            def one_done(written: list[Path]) -> None:
                if written:
                    done[item.key] = written
                else:
                    failed.append(item.title)
                next_one()
            self.export(item.key, finished=one_done)

        def summary() -> None:
            n = sum(len(v) for v in done.values())
            text = f"✓ {n} file(s) written to {self.folder()}." if done else "Nothing was exported."
            if failed:
                text += " Failed: " + "; ".join(failed) + " (see the rows above)."
            if skipped:
                text += " Skipped: " + "; ".join(skipped) + "."
            self._set_status(text, ok=bool(done) and not failed)
            if finished is not None:
                finished(done, failed)

        next_one()

    def on_busy_changed(self) -> None:
        busy = self.task.busy
        self.all_button.setEnabled(not busy and any(i.missing() is None for i in self.items))
        self.folder_button.setEnabled(not busy and self.state.project is not None)
        for item in self.items:
            self.rows[item.key]["button"].setEnabled(not busy and item.missing() is None)

    # -- WizardPage ----------------------------------------------------------------------
    def on_enter(self) -> None:
        self.refresh()

    def is_complete(self) -> bool:
        return bool(self.exported)

    def autopilot(self, done) -> None:
        if self.state.project is None:
            done(False, "no project (Setup step)")
            return
        self._folder = None

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
        self.folder_edit.setText(str(folder) if folder else "")
        for item in self.items:
            row = self.rows[item.key]
            missing = item.missing()
            where = ", ".join(item.files)
            if folder is not None:
                where = f"→ {folder / item.files[0]}" + (f" (+ {', '.join(item.files[1:])})" if len(item.files) > 1
                                                         else "")
            source = ""
            if item.key in ("calibrated", "dh-csv", "urdf") and missing is None:
                source = (" · from this session's identification" if self.calibrated_source() == "result"
                          else " · from the project's calibrated.json")
            row["target"].setText(where + source)
            if self.task.busy and item.key == "report":
                continue                                  # its row says "Writing…"
            if missing:
                self._row_status(item.key, f"Not available: {missing}.", ok=False)
            elif item.key in self.exported:
                self._row_status(item.key, "✓ Exported: " + ", ".join(p.name for p in self.exported[item.key]),
                                 ok=True)
            else:
                self._row_status(item.key, "Ready.", ok=None)
        self.on_busy_changed()
        if self.state.project is None:
            self._set_status("Create or open a project first (Setup step).", ok=False)
        elif not self.exported:
            self._set_status("Choose what to export, or Export all.", ok=None)

    def _row_status(self, key: str, text: str, ok: bool | None) -> None:
        self.rows_panel.set_status(key, text, ok)

    def row_text(self, key: str) -> str:
        """Target and status of one row (tests)."""
        return self.rows_panel.text(key)
