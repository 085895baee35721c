"""The Stereo page's files: the project's stereo.yaml read back, Save (stereo.yaml and its
details into the project), Import… (a calibration from another tool becomes the project's
stereo.yaml), and the ROS camera_info and JSON exports. A helper the page holds; every write
is atomic and takes the command line's output lock."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from PySide6.QtWidgets import QFileDialog, QWidget

from app.html import number
from app.pages.page_task import BUSY, PageTask
from app.pages.stereo.model import StereoModel
from core.errors import RoboCalError
from core.locks import output_lock, output_locks
from core.project import Output
from core.stereo.file import read_stereo_yaml, write_ros_camera_info, write_stereo_json, write_stereo_yaml
from core.stereo.importers import read_any_stereo


class StereoFiles:
    """The files of `model`'s calibration; `set_status(text, ok)` is the page's status line,
    `complete_changed()` tells the wizard the step may be done, `parent` owns the dialogs."""

    def __init__(self, state, model: StereoModel, task: PageTask, parent: QWidget, *,
                 set_status: Callable[[str, bool | None], None], complete_changed: Callable[[], None]):
        self.state, self.model, self.task, self.parent = state, model, task, parent
        self._set_status, self.complete_changed = set_status, complete_changed

    def read_saved(self) -> tuple[str, bool]:
        """The project's stereo.yaml, if any: the step is done and its board is the model's.
        Returns what to say and whether it is good news."""
        project = self.state.project
        if project is None:
            return "No project yet: create or open one in the Setup step (1).", False
        if not project.has(Output.STEREO):
            return "", False
        path = project.path(Output.STEREO)
        try:
            sf = read_stereo_yaml(path)
        except RoboCalError as exc:
            return f"The project's stereo.yaml cannot be used ({exc.message}). Calibrate again.", False
        self.model.saved_path = path
        if sf.board is not None:                 # the board those pairs show (unknown when imported)
            self.model.set_board(sf.board)
        return (f"This project already has {path.name} (stereo RMS {number(sf.rms_stereo, 3, 'px')}, baseline "
                f"{sf.baseline_mm:.1f} mm, {sf.image_size[0]}x{sf.image_size[1]}): the step is done. "
                "Add pairs and calibrate to replace it."), True

    def save_stereo(self) -> Path | None:
        """Accept the calibration: stereo.yaml and its details (stereo.json, for the report)
        into the project (atomic) and the result into the wizard's state."""
        r, project = self.model.result, self.state.project
        if r is None or project is None:
            self._set_status("Nothing to save: calibrate first." if project is not None
                             else "No project: create or open one in the Setup step (1).", False)
            return None
        path = project.path(Output.STEREO)
        try:
            details = project.path(Output.STEREO_DETAILS)
            with output_locks([path, details]):         # not while a robocal command writes them
                write_stereo_yaml(path, r)
                write_stereo_json(details, r)
        except RoboCalError as exc:
            self._set_status(f"stereo.yaml was not written: {exc.message}", False)
            return None
        self.model.saved_path = path
        self.state.set_stereo(r)
        self._set_status(f"Saved {path} ({r.pairs_used} pairs, stereo RMS {r.file.rms_stereo:.3f} px). "
                         "This step is done.", True)
        self.complete_changed()
        return path

    def import_stereo(self, paths: list[str] | None = None) -> Path | None:
        """Make another tool's stereo calibration (one file, a pair, or ROS left + right) the
        project's stereo.yaml; the page's own pairs and calibration stay as they are."""
        project = self.state.project
        if project is None or self.task.busy:
            self._set_status("No project: create or open one in the Setup step (1)." if project is None
                             else BUSY, False)
            return None
        if paths is None:
            paths, _ = QFileDialog.getOpenFileNames(
                self.parent, "Import a stereo calibration (for a pair, select both files)", str(project.folder),
                "Stereo calibrations (*.yaml *.yml *.xml *.json *.mat);;All files (*)")
            if not paths:
                return None
        try:
            imported = read_any_stereo(sorted(paths, key=_left_first))
            path = write_stereo_yaml(project.path(Output.STEREO), imported.file)
        except RoboCalError as exc:
            self._set_status(f"Not imported: {exc.message}", False)
            return None
        self.model.saved_path = path
        self.state.set_stereo(None)               # the project's calibration is now the imported file
        sf = imported.file
        notes = "".join(f" Note: {n}." for n in imported.notes)
        errors = ("reprojection errors unknown" if sf.rms_stereo is None
                  else f"stereo RMS {number(sf.rms_stereo, 3, 'px')}")
        self._set_status(f"Imported {imported.kind} ({', '.join(p.name for p in imported.sources)}) as "
                         f"{path.name}: {sf.image_size[0]}x{sf.image_size[1]} px, baseline {sf.baseline_mm:.1f} mm, "
                         f"{errors}.{notes} This step is done.", True)
        self.complete_changed()
        return path

    def export_ros(self, folder: str | None = None) -> tuple[Path, Path] | None:
        if self.model.result is None:
            return None
        if folder is None:
            start = str(self.state.project.folder) if self.state.project is not None else ""
            folder = QFileDialog.getExistingDirectory(
                self.parent, "Folder for left.yaml and right.yaml (ROS camera_info)", start)
            if not folder:
                return None
        try:
            with output_locks([Path(folder) / "left.yaml", Path(folder) / "right.yaml"]):
                paths = write_ros_camera_info(folder, self.model.result)
        except RoboCalError as exc:
            self._set_status(f"ROS camera_info not written: {exc.message}", False)
            return None
        self._set_status(f"Wrote {paths[0]} and {paths[1].name} (ROS camera_info).", True)
        return paths

    def export_json(self, path: str | None = None) -> Path | None:
        if self.model.result is None:
            return None
        if path is None:
            start = self.state.project.folder / "stereo.json" if self.state.project is not None else Path("stereo.json")
            path, _ = QFileDialog.getSaveFileName(self.parent, "Export the stereo calibration as JSON", str(start),
                                                  "JSON (*.json)")
            if not path:
                return None
        try:
            with output_lock(path):
                out = write_stereo_json(path, self.model.result)
        except RoboCalError as exc:
            self._set_status(f"JSON not written: {exc.message}", False)
            return None
        self._set_status(f"Wrote {out}.", True)
        return Path(out)


def _left_first(path: str) -> tuple[int, str]:
    """File dialogs return names sorted alphabetically: ROS's left.yaml goes before right.yaml."""
    name = Path(path).name.lower()
    return (0 if "left" in name else 1 if "right" in name else 2, name)
