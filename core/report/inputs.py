"""What the report is made of, loaded once before any section is drawn: the project, the
nominal robot, stereo.yaml, measurements.csv and the calibration (this session's or
calibrated.json), each read at most once. The sections are functions of these inputs and never
pass anything to one another.

    inputs = load_report_inputs(project, robot=None, identification=None, accuracy=None, problems=problems)
    section = stereo_section(inputs, problems)

A file that cannot be read is kept as its error (`Loaded.error`) for its own section to report,
in the section's turn. Lengths in mm, angles in degrees.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Generic, TypeVar

from core.errors import RoboCalError
from core.project import Output, Project, load_robot
from core.robot.model import RobotModel

T = TypeVar("T")


@dataclass(frozen=True)
class Loaded(Generic[T]):
    """One input file: absent (`present` False), read (`value`) or not readable (`error`)."""
    present: bool = False
    value: T | None = None
    error: Exception | None = None

    def get(self) -> T | None:
        """The value (None when absent or not readable)."""
        return self.value if self.error is None else None


def load(present: bool, read: Callable[[], T]) -> Loaded[T]:
    if not present:
        return Loaded()
    try:
        return Loaded(True, read())
    except Exception as exc:     # noqa: BLE001 - kept for its section, which names it or re-raises it
        return Loaded(True, error=exc)


@dataclass(frozen=True)
class Calibration:
    """The calibration the report shows: `section` (the calibration section of calibrated.json:
    statistics, parameters, correlation ...), the calibrated `model` and `source`, where it
    comes from (a file name or "this session's identification")."""
    section: dict
    model: RobotModel
    source: str


@dataclass(frozen=True)
class ReportInputs:
    """`robot`: the nominal model (None when the project has none); `stereo`: a StereoFile;
    `measurements`: a Measurements; `accuracy`: a model_comparison.TruthAccuracy (virtual lab
    only, else None)."""
    project: Project
    robot: RobotModel | None
    stereo: Loaded
    measurements: Loaded
    calibration: Loaded[Calibration]
    accuracy: Any = None


def load_report_inputs(project: Project, *, robot: RobotModel | None = None, identification=None, accuracy=None,
                       problems: list[str]) -> ReportInputs:
    """The inputs of `project`'s report. `robot`: the nominal model (else robot.json; a robot.json
    that cannot be read goes into `problems`); `identification`: an IdentificationResult of this
    session (wins over calibrated.json)."""
    if robot is None and project.robot:
        try:
            robot = load_robot(project)
        except RoboCalError as exc:
            problems.append(f"{project.robot}: {exc.message}")
    from core.measurement.file import read_measurements
    from core.stereo.file import read_stereo_yaml
    return ReportInputs(
        project=project, robot=robot,
        stereo=load(project.path(Output.STEREO).is_file(), lambda: read_stereo_yaml(project.path(Output.STEREO))),
        measurements=load(project.path(Output.MEASUREMENTS).is_file(),
                          lambda: read_measurements(project.path(Output.MEASUREMENTS), robot)),
        calibration=load(identification is not None or project.has(Output.CALIBRATED),
                         lambda: _calibration(project, identification)),
        accuracy=accuracy)


def _calibration(project: Project, identification) -> Calibration:
    if identification is not None:
        return Calibration(identification.calibration_section(), identification.model,
                           "this session's identification")
    from core.robot.file import read_robot
    path = project.path(Output.CALIBRATED)
    model = read_robot(path)
    if not isinstance(model.calibration, dict):
        raise RoboCalError("no calibration section: this is a robot model, not a calibrated one",
                           source=path, field="calibration")
    return Calibration(model.calibration, model, path.name)
