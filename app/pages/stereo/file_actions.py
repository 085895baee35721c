"""The Stereo page's files: Save (stereo.yaml and its details into the project), Import… (a
calibration from another tool becomes the project's stereo.yaml), and the ROS camera_info and
JSON exports. A mixin of StereoPage (before WizardPage); every write is atomic and takes the
command line's output lock."""
from __future__ import annotations

from pathlib import Path

from PySide6.QtWidgets import QFileDialog

from app.html import number
from core.errors import RoboCalError
from core.locks import output_lock, output_locks
from core.project import Output
from core.stereo.file import write_ros_camera_info, write_stereo_json, write_stereo_yaml
from core.stereo.importers import read_any_stereo


class StereoFileActions:
    def save_stereo(self) -> Path | None:
        """Accept the calibration: stereo.yaml and its details (stereo.json, for the report)
        into the project (atomic) and the result into the wizard's state."""
        r, project = self.result, self.state.project
        if r is None or project is None:
            self._set_status("Nothing to save: calibrate first." if project is not None
                             else "No project: create or open one in the Setup step (1).", ok=False)
            return None
        path = project.path(Output.STEREO)
        try:
            details = project.path(Output.STEREO_DETAILS)
            with output_locks([path, details]):         # not while a robocal command writes them
                write_stereo_yaml(path, r)
                write_stereo_json(details, r)
        except RoboCalError as exc:
            self._set_status(f"stereo.yaml was not written: {exc.message}", ok=False)
            return None
        self.saved_path = path
        self.state.set_stereo(r)
        self._set_status(f"Saved {path} ({r.pairs_used} pairs, stereo RMS {r.file.rms_stereo:.3f} px). "
                         "This step is done.", ok=True)
        self.notify_complete()
        return path

    def import_stereo(self, paths: list[str] | None = None) -> Path | None:
        """Make another tool's stereo calibration (one file, a pair, or ROS left + right) the
        project's stereo.yaml; the page's own pairs and calibration stay as they are."""
        project = self.state.project
        if project is None or self.task.busy:
            self._set_status("No project: create or open one in the Setup step (1)." if project is None
                             else "Busy: wait for the running task or cancel it.", ok=False)
            return None
        if paths is None:
            paths, _ = QFileDialog.getOpenFileNames(
                self, "Import a stereo calibration (for a pair, select both files)", str(project.folder),
                "Stereo calibrations (*.yaml *.yml *.xml *.json *.mat);;All files (*)")
            if not paths:
                return None
        try:
            imported = read_any_stereo(sorted(paths, key=_left_first))
            path = write_stereo_yaml(project.path(Output.STEREO), imported.file)
        except RoboCalError as exc:
            self._set_status(f"Not imported: {exc.message}", ok=False)
            return None
        self.saved_path = path
        self.state.set_stereo(None)               # the project's calibration is now the imported file
        sf = imported.file
        notes = "".join(f" Note: {n}." for n in imported.notes)
        errors = ("reprojection errors unknown" if sf.rms_stereo is None
                  else f"stereo RMS {number(sf.rms_stereo, 3, 'px')}")
        self._set_status(f"Imported {imported.kind} ({', '.join(p.name for p in imported.sources)}) as "
                         f"{path.name}: {sf.image_size[0]}x{sf.image_size[1]} px, baseline {sf.baseline_mm:.1f} mm, "
                         f"{errors}.{notes} This step is done.", ok=True)
        self.notify_complete()
        return path

    def export_ros(self, folder: str | None = None) -> tuple[Path, Path] | None:
        if self.result is None:
            return None
        if folder is None:
            start = str(self.state.project.folder) if self.state.project is not None else ""
            folder = QFileDialog.getExistingDirectory(self, "Folder for left.yaml and right.yaml (ROS camera_info)",
                                                      start)
            if not folder:
                return None
        try:
            with output_locks([Path(folder) / "left.yaml", Path(folder) / "right.yaml"]):
                paths = write_ros_camera_info(folder, self.result)
        except RoboCalError as exc:
            self._set_status(f"ROS camera_info not written: {exc.message}", ok=False)
            return None
        self._set_status(f"Wrote {paths[0]} and {paths[1].name} (ROS camera_info).", ok=True)
        return paths

    def export_json(self, path: str | None = None) -> Path | None:
        if self.result is None:
            return None
        if path is None:
            start = self.state.project.folder / "stereo.json" if self.state.project is not None else Path("stereo.json")
            path, _ = QFileDialog.getSaveFileName(self, "Export the stereo calibration as JSON", str(start),
                                                  "JSON (*.json)")
            if not path:
                return None
        try:
            with output_lock(path):
                out = write_stereo_json(path, self.result)
        except RoboCalError as exc:
            self._set_status(f"JSON not written: {exc.message}", ok=False)
            return None
        self._set_status(f"Wrote {out}.", ok=True)
        return Path(out)


def _left_first(path: str) -> tuple[int, str]:
    """File dialogs return names sorted alphabetically: ROS's left.yaml goes before right.yaml."""
    name = Path(path).name.lower()
    return (0 if "left" in name else 1 if "right" in name else 2, name)
