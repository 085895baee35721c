"""A RoboCal project: a folder holding `project.json` and the outputs of the wizard's steps.

```
my-robot/
  project.json        {"format": "robocal.project/1", "name", "robot", "mode", "created", ...}
  robot.json          the nominal robot model (Setup)
  stereo.yaml         stereo calibration (Stereo calibration)
  stereo.json         its details: per-pair errors, residuals, parameters with σ (for the report)
  poses.csv           pose sequence (Pose sequence)
  measurements.csv    measured marker positions (Measurement)
  calibrated.json     identified robot model (Identification)
```
The project file names the robot file (relative to the folder) and the mode, which is the
project's cell: "virtual-lab" (the simulated robot and cameras: the demo, teaching) or "hardware"
(a real cell). A real cell's robot connection (`robot_connection`: kind "serial" with port,
profile, joint_map, baud, speed %; or kind "teach": no connection, the technician brings the robot
to each pose) and its cameras (`cameras`: kind "sources", left, right, settings, identity {left,
right: {name, bus}}; each source a device, a video file or an image folder) are chosen when the
project is made and on the Setup page. Files without them (older ones) read as before. No Qt here:
the wizard and the command line share this module.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from datetime import datetime, timezone
from enum import StrEnum
from pathlib import Path, PurePath

from core.errors import RoboCalError
from core.files import atomic_write_json, ensure_writable_dir, read_json
from core.robot.model import RobotModel
from core.validate import check_format, require, text

FORMAT_FAMILY = "robocal.project"
FORMAT_MAJOR = 1
FORMAT = f"{FORMAT_FAMILY}/{FORMAT_MAJOR}"
PROJECT_FILE = "project.json"

VIRTUAL_LAB = "virtual-lab"
HARDWARE = "hardware"
MODES = (VIRTUAL_LAB, HARDWARE)
SERIAL = "serial"           # robot_connection kind: a controller on a serial port
TEACH = "teach"             # robot_connection kind: no connection, poses brought by hand (teach mode)
SOURCES = "sources"         # cameras kind: two devices, video files or image folders
LAB_WORDS = "the virtual lab (simulated robot and cameras)"

class Output(StrEnum):
    """A step output kept beside project.json (its file name: `file_name`). The value is the
    output's short name, the one `WizardState.outputSaved` carries."""
    ROBOT = "robot"                        # the nominal robot model (Setup)
    STEREO = "stereo"                      # the stereo calibration (Stereo calibration)
    STEREO_DETAILS = "stereo_details"      # its details for the report
    POSES = "poses"                        # the pose sequence (Pose sequence)
    MEASUREMENTS = "measurements"          # the measured marker positions (Measurement)
    CALIBRATED = "calibrated"              # the identified robot model (Identification)

    @property
    def file_name(self) -> str:
        return OUTPUT_FILES[self]


#: the step outputs' file names
OUTPUT_FILES = {
    Output.ROBOT: "robot.json",
    Output.STEREO: "stereo.yaml",
    Output.STEREO_DETAILS: "stereo.json",
    Output.POSES: "poses.csv",
    Output.MEASUREMENTS: "measurements.csv",
    Output.CALIBRATED: "calibrated.json",
}


@dataclass
class RobotConnection:
    """A real cell's robot as project.json records it: `kind` SERIAL (a controller on `port`
    speaking `profile`, joints mapped by the `joint_map` file, at `baud`, `speed` % of full
    speed) or TEACH (no connection: the technician brings the robot to each pose)."""
    kind: str
    port: str | None = None
    profile: str | None = None
    joint_map: str | None = None
    baud: int | None = None
    speed: float | None = None

    def to_dict(self) -> dict:
        return _fields_given(self)

    @classmethod
    def from_dict(cls, data, source: str | Path = PROJECT_FILE) -> "RobotConnection":
        data = _object(data, "robot_connection", source)
        return cls(kind=_str(data, "kind", "robot_connection", source, default=""),
                   **{k: _str(data, k, "robot_connection", source) for k in ("port", "profile", "joint_map")},
                   baud=_number(data, "baud", "robot_connection", source, int),
                   speed=_number(data, "speed", "robot_connection", source, float))


@dataclass
class CameraSources:
    """A real cell's two cameras as project.json records them: `kind` SOURCES, `left` and
    `right` (each a device number, a video file or an image folder), `settings` (a
    core.camera CameraSettings as a dict) and `identity` ({"left"|"right": {"name", "bus"}}:
    the cameras seen when they were last opened)."""
    kind: str
    left: str | None = None
    right: str | None = None
    settings: dict | None = None
    identity: dict | None = None

    def to_dict(self) -> dict:
        return _fields_given(self)

    @classmethod
    def from_dict(cls, data, source: str | Path = PROJECT_FILE) -> "CameraSources":
        data = _object(data, "cameras", source)
        return cls(kind=_str(data, "kind", "cameras", source, default=""),
                   left=_str(data, "left", "cameras", source), right=_str(data, "right", "cameras", source),
                   settings=_object(data.get("settings"), "cameras.settings", source, optional=True),
                   identity=_object(data.get("identity"), "cameras.identity", source, optional=True))


HARDWARE_HINT = "Delete the field and choose the hardware again on the Setup page."


def _fields_given(record) -> dict:
    """The record's fields that are set (None ones left out, as project.json has always had them)."""
    return {f.name: getattr(record, f.name) for f in fields(record) if getattr(record, f.name) is not None}


def _object(value, field: str, source, optional: bool = False) -> dict | None:
    if value is None and optional:
        return None
    if not isinstance(value, dict):
        raise RoboCalError("expected an object", source=source, field=field, hint=HARDWARE_HINT)
    return value


def _str(data: dict, key: str, field: str, source, default: str | None = None) -> str | None:
    value = data.get(key, default)
    if value is not None and not isinstance(value, str):
        raise RoboCalError(f"expected text, found {value!r}", source=source, field=f"{field}.{key}",
                           hint=HARDWARE_HINT)
    return value


def _number(data: dict, key: str, field: str, source, kind: type):
    value = data.get(key)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (kind is int and value != int(value)):
        raise RoboCalError(f"expected a number, found {value!r}", source=source, field=f"{field}.{key}",
                           hint=HARDWARE_HINT)
    return kind(value)


def _record(value, kind: type):
    """`value` as a `kind` record (a dict is read as project.json holds it); None stays None."""
    return kind.from_dict(value, "<new project>") if isinstance(value, dict) else value


@dataclass
class Project:
    folder: Path
    name: str
    mode: str = VIRTUAL_LAB
    robot: str | None = None          # robot file name, relative to the folder
    robot_source: str | None = None   # where it came from ("preset:ur5", a path), for the user
    created: str = ""                 # ISO 8601, UTC
    robot_connection: RobotConnection | None = None   # Setup: the serial robot, or teach mode
    cameras: CameraSources | None = None               # Setup: the two camera sources

    @property
    def file(self) -> Path:
        return self.folder / PROJECT_FILE

    def path(self, output: Output) -> Path:
        """Path of a step output (the robot file is the one project.json names)."""
        try:
            output = Output(output)
        except ValueError:
            raise RoboCalError(f"unknown project output {output!r}",
                               hint=f"Use one of {', '.join(OUTPUT_FILES)}.") from None
        if output is Output.ROBOT and self.robot:
            return self.folder / self.robot
        return self.folder / output.file_name

    def has(self, output: Output) -> bool:
        return self.path(output).is_file()

    @property
    def real_cell(self) -> bool:
        return self.mode == HARDWARE

    @property
    def teach_mode(self) -> bool:
        """A real cell whose robot RoboCal does not drive (joints typed or read, poses by hand)."""
        return self.real_cell and self.robot_connection is not None and self.robot_connection.kind == TEACH

    def describe_cell(self) -> str:
        """The cell in words: the virtual lab, or the real robot connection and cameras."""
        if not self.real_cell:
            return LAB_WORDS
        robot = self.robot_connection or RobotConnection(kind="")
        if robot.kind == SERIAL:
            where = f"the serial robot on {robot.port or '(no port yet)'} ({robot.profile or 'robocal_v1'})"
        elif robot.kind == TEACH:
            where = "the robot in teach mode (brought to each pose by hand)"
        else:
            where = "no robot connection chosen yet"
        cams = self.cameras or CameraSources(kind="")
        if cams.kind == SOURCES and (cams.left or cams.right):
            seen = f"cameras {cams.left or '?'} and {cams.right or '?'}"
        else:
            seen = "no cameras chosen yet"
        return f"a real cell: {where}, {seen}"

    def to_dict(self) -> dict:
        data = {"format": FORMAT, "name": self.name, "robot": self.robot,
                "robot_source": self.robot_source, "mode": self.mode, "created": self.created}
        if self.robot_connection is not None:
            data["robot_connection"] = self.robot_connection.to_dict()
        if self.cameras is not None:
            data["cameras"] = self.cameras.to_dict()
        return data


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def _check_mode(mode, source) -> str:
    if mode not in MODES:
        raise RoboCalError(f"unknown mode {mode!r}", source=source, field="mode",
                           hint=f"Use {' or '.join(repr(m) for m in MODES)}.")
    return mode


def create_project(folder: str | Path, *, name: str | None = None, mode: str = VIRTUAL_LAB,
                   robot_connection: RobotConnection | dict | None = None,
                   cameras: CameraSources | dict | None = None) -> Project:
    """Make `folder` (created if needed) a new project on its cell (`mode`, and for a real cell its
    robot connection and cameras: records, or dicts as project.json holds them); refuses a folder
    that already is one."""
    folder = Path(folder)
    if (folder / PROJECT_FILE).exists():
        raise RoboCalError("this folder already holds a project", source=folder / PROJECT_FILE,
                           hint="Open it instead, or choose another folder.")
    if folder.exists() and not folder.is_dir():
        raise RoboCalError("not a folder", source=folder, hint="Choose a folder for the project.")
    _check_mode(mode, "<new project>")
    ensure_writable_dir(folder)
    project = Project(folder=folder, name=name or folder.resolve().name or "project", mode=mode,
                      created=_now(), robot_connection=_record(robot_connection, RobotConnection),
                      cameras=_record(cameras, CameraSources))
    save_project(project)
    return project


def open_project(path: str | Path) -> Project:
    """Open a project from its folder or from its project.json."""
    path = Path(path)
    file = path / PROJECT_FILE if path.is_dir() or path.name != PROJECT_FILE else path
    if not file.exists():
        raise RoboCalError("no project here (project.json is missing)", source=file.parent,
                           hint="Choose a folder made with New project.")
    data = read_json(file)
    check_format(data, FORMAT_FAMILY, FORMAT_MAJOR, file)
    name = text(require(data, "name", file), file, "name")
    mode = _check_mode(data.get("mode", VIRTUAL_LAB), file)
    robot = data.get("robot")
    if robot is not None:
        robot = text(robot, file, "robot")
        pure = PurePath(robot)
        if pure.is_absolute() or ".." in pure.parts or not robot.strip():
            raise RoboCalError(f"expected a file name inside the project folder, got {robot!r}",
                               source=file, field="robot")
    source = data.get("robot_source")
    if source is not None:
        source = text(source, file, "robot_source")
    created = text(data.get("created", ""), file, "created")
    robot_connection, cameras = data.get("robot_connection"), data.get("cameras")
    return Project(folder=file.parent, name=name, mode=mode, robot=robot, robot_source=source, created=created,
                   robot_connection=RobotConnection.from_dict(robot_connection, file) if robot_connection is not None
                   else None,
                   cameras=CameraSources.from_dict(cameras, file) if cameras is not None else None)


#: what `robocal simulate` writes into a dataset folder last: the folder is a virtual-lab one
DATASET_TRUTH = "truth.json"


def command_line_folder(path: str | Path) -> Project:
    """A folder the command-line chain wrote its results into (stereo.yaml, measurements.csv,
    calibrated.json under the names the wizard uses), read as a project without project.json:
    named after the folder, a virtual-lab one when `robocal simulate`'s truth.json is there."""
    folder = Path(path)
    if not folder.is_dir() or not any((folder / k.file_name).is_file()
                                      for k in (Output.STEREO, Output.MEASUREMENTS, Output.CALIBRATED)):
        raise RoboCalError("no project here (project.json is missing) and no results of the command line "
                           "(stereo.yaml, measurements.csv or calibrated.json)", source=folder,
                           hint="Choose a folder made with New project, or the folder the commands wrote into.")
    mode = VIRTUAL_LAB if (folder / DATASET_TRUTH).is_file() else HARDWARE
    return Project(folder=folder, name=folder.resolve().name, mode=mode)


def save_project(project: Project) -> Path:
    """Write project.json atomically."""
    return atomic_write_json(project.file, project.to_dict())


def save_hardware(project: Project, *, robot_connection: RobotConnection | dict | None = None,
                  cameras: CameraSources | dict | None = None) -> Path:
    """Record the Setup page's robot connection and/or cameras (records, or dicts as project.json
    holds them) in project.json (atomically); a section not given is kept."""
    if robot_connection is not None:
        project.robot_connection = _record(robot_connection, RobotConnection)
    if cameras is not None:
        project.cameras = _record(cameras, CameraSources)
    return save_project(project)


def save_cell(project: Project, mode: str, *, robot_connection: RobotConnection | dict | None = None,
              cameras: CameraSources | dict | None = None) -> Path:
    """Change the project's cell (project.json, atomically): the virtual lab, or a real cell with
    its robot connection and cameras (a section not given is kept)."""
    project.mode = _check_mode(mode, project.file)
    return save_hardware(project, robot_connection=robot_connection, cameras=cameras)


def save_robot(project: Project, model: RobotModel, source: str | None = None) -> Path:
    """Write the robot model into the project (robot.json) and record it in project.json."""
    from core.robot.file import write_robot

    project.robot = project.robot or Output.ROBOT.file_name
    path = write_robot(model, project.path(Output.ROBOT))
    project.robot_source = source
    save_project(project)
    return path


def load_robot(project: Project) -> RobotModel | None:
    """The project's robot model, or None if none was chosen yet."""
    from core.robot.file import read_robot

    if not project.robot:
        return None
    path = project.path(Output.ROBOT)
    if not path.exists():
        raise RoboCalError("the project's robot file is missing", source=path,
                           hint="Choose the robot again in the Setup step.")
    return read_robot(path)
