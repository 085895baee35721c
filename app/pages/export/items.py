"""What the Export step can write: one ExportItem per row, each with its files, a writer
(folder -> files written) and what it still needs. Every file is written atomically (core.files);
a missing input says which step produces it."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from core.errors import RoboCalError
from core.files import atomic_write_bytes, atomic_write_many
from core.identification.exports import export_model
from core.identification.file import write_calibrated_model
from core.project import Output
from core.robot.file import read_robot
from core.robot.model import RobotModel
from core.stereo import file as stereo_file

REPORT = "report"                  # written on a worker by the page, not by a writer here


@dataclass
class ExportItem:
    key: str
    title: str
    description: str
    files: tuple[str, ...]
    write: Callable[[Path], list[Path]] | None   # folder -> written files (None: the report)
    missing: Callable[[], str | None]            # why it is not available (None: available)


class ExportSources:
    """The wizard state's calibrated model and stereo calibration, and the writers of each export."""

    def __init__(self, state):
        self.state = state

    def items(self) -> list[ExportItem]:
        return [
            ExportItem("calibrated", "Calibrated robot model (RoboCal JSON)",
                       "The robot file format plus the calibration section (statistics, parameters with σ, "
                       "identifiability). Loads anywhere a robot model does.",
                       ("calibrated.json",), self._write_calibrated, self._missing_model),
            ExportItem("dh-csv", "DH table (CSV)",
                       "One row per joint: θ, d, a, α, β (mm, °), limits and standard deviations.",
                       ("calibrated_dh.csv",), self._write_dh, self._missing_model),
            ExportItem("urdf", "URDF (ROS, robot viewers)",
                       "Kinematic URDF in metres and radians with the robot file's joint names; "
                       "world = the measurement (left camera) frame.",
                       ("calibrated.urdf",), self._write_urdf, self._missing_model),
            ExportItem("stereo", "Stereo camera files (OpenCV + ROS camera_info)",
                       "stereo.yaml (OpenCV FileStorage) and left.yaml / right.yaml (ROS camera_info, metres).",
                       ("stereo.yaml", "left.yaml", "right.yaml"), self._write_stereo, self._missing_stereo),
            ExportItem(REPORT, "Report (HTML and PDF)",
                       "A summary and the figures of every step: stereo reprojection errors, marker, poses, "
                       "measured points, identification (errors before/after, validation, parameters).",
                       ("report.html", "report.pdf"), None, self._missing_report),
        ]

    # -- sources -------------------------------------------------------------------------
    def calibrated_source(self) -> str | None:
        """'result' (this session's identification), 'file' (the project's calibrated.json) or None."""
        if self.state.identification is not None:
            return "result"
        if self.state.project is not None and self.state.project.has(Output.CALIBRATED):
            return "file"
        return None

    def calibrated_model(self) -> RobotModel:
        source = self.calibrated_source()
        if source == "result":
            return self.state.identification.model
        if source == "file":
            return read_robot(self.state.project.path(Output.CALIBRATED))
        raise RoboCalError("no calibrated model yet", hint="Run the Identification step first.")

    def _missing_model(self) -> str | None:
        if self.state.project is None:
            return "needs a project (Setup step)"
        return None if self.calibrated_source() else "available after the Identification step"

    def _missing_stereo(self) -> str | None:
        if self.state.project is None:
            return "needs a project (Setup step)"
        if not self.state.project.has(Output.STEREO):
            return "available after the Stereo calibration step"
        return None

    def _missing_report(self) -> str | None:
        return "needs a project (Setup step)" if self.state.project is None else None

    # -- writers (folder -> files written) -----------------------------------------------
    def _write_calibrated(self, folder: Path) -> list[Path]:
        dest = folder / "calibrated.json"
        if self.calibrated_source() == "result":
            return [write_calibrated_model(self.state.identification, dest)]
        return [atomic_write_bytes(dest, self.state.project.path(Output.CALIBRATED).read_bytes())]

    def _write_dh(self, folder: Path) -> list[Path]:
        return [export_model(self.calibrated_model(), "dh-csv", folder / "calibrated_dh.csv")]

    def _write_urdf(self, folder: Path) -> list[Path]:
        return [export_model(self.calibrated_model(), "urdf", folder / "calibrated.urdf")]

    def _write_stereo(self, folder: Path) -> list[Path]:
        src = self.state.project.path(Output.STEREO)
        data = stereo_file.read_stereo_yaml(src)          # checks the file before copying it
        files = {folder / "stereo.yaml": src.read_bytes(), **stereo_file.ros_camera_info_files(folder, data)}
        return atomic_write_many(files)                   # all three, or none changed
