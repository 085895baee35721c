"""What the wizard's pages share: the project, the robot model, and the results the steps hand
to each other; the hardware, the project files and the virtual lab are its parts.

Every page gets the same `WizardState` (``self.state``) and listens to its signals rather
than to other pages. The project folder stays the durable truth: a step that produces a
file writes it with ``state.project.path(Output.STEREO)`` etc. The in-memory results the steps
hand on are typed attributes, each with its signal and its setter:

    state.set_stereo(result)          # stereoChanged(result)          StereoCalibrationResult
    state.set_marker(trained)         # markerChanged(trained)         TrainedMarker
    state.set_poses(selection)        # posesChanged(selection)        PoseSelectionResult
    state.set_measurements(path)      # measurementsChanged(path)      Path of measurements.csv
    state.set_identification(result, accuracy)   # identificationChanged(result)
    state.output_saved("calibrated")             # outputSaved(key): a step wrote that project file

A page whose result was made from other inputs than the project now has says so (core.provenance:
the inputs' hashes recorded beside an output) and its step is not done until it is run again.

Its parts, each an object of its own:
- `state.labs` (app.lab_provider.LabProvider): the virtual lab, built once on a worker thread,
  asked with `state.labs.when_ready(callback)`;
- `state.hardware` (app.cell_hardware.CellHardware): the robot connection every page moves
  (`state.hardware.robot_connection`), the cameras and the classroom controller simulator, opened
  and closed there, with their signals (`connectionChanged`, `camerasChanged`...);
- `state.files` (app.project_files.ProjectFiles): the project folder, saved and (for a demo)
  deleted at close.
"""
from __future__ import annotations

from pathlib import Path
from PySide6.QtCore import QObject, Signal

from app.cell_hardware import CellHardware
from app.lab_provider import LabProvider
from app.project_files import ProjectFiles
from core import project as projects
from core.errors import RoboCalError
from core.identification.model_comparison import TruthAccuracy
from core.identification.result import IdentificationResult
from core.marker.training import TrainedMarker
from core.poses.selection import PoseSelectionResult
from core.project import Output
from core.robot.file import read_robot
from core.robot.model import RobotModel, robot_path
from core.stereo.calibration import StereoCalibrationResult


class WizardState(QObject):
    """Shared state of one wizard window.

    Signals: `projectChanged(Project | None)`, `robotChanged(RobotModel | None)`,
    `cellChanged(Project)` (the project's cell changed: virtual lab or real cell, `set_cell`),
    and one per
    step result (`stereoChanged`, `markerChanged`, `posesChanged`, `measurementsChanged`,
    `identificationChanged`) with the new value; `outputSaved(str)`: a step wrote a project
    file (its core.project.OUTPUT_FILES key, or "marker"), so results made from it may be out of date.
    """

    projectChanged = Signal(object)
    cellChanged = Signal(object)
    robotChanged = Signal(object)
    labChanged = Signal(object)
    stereoChanged = Signal(object)
    markerChanged = Signal(object)
    posesChanged = Signal(object)
    measurementsChanged = Signal(object)
    identificationChanged = Signal(object)
    outputSaved = Signal(str)

    def __init__(self, parent: QObject | None = None, *, seed: int = 0, noise: float = 0.5):
        super().__init__(parent)
        self.files = ProjectFiles()
        self.robot: RobotModel | None = None
        self.robot_source: str | None = None     # "preset:ur5" or a file path
        self.seed = seed                          # virtual lab: same seed, same lab
        self.noise = noise                        # virtual lab: sensor noise (grey levels)
        self.stereo: StereoCalibrationResult | None = None
        self.marker: TrainedMarker | None = None
        self.poses: PoseSelectionResult | None = None
        self.measurements: Path | None = None
        self.identification: IdentificationResult | None = None
        self.accuracy: TruthAccuracy | None = None    # virtual lab: identified vs true robot
        self.labs = LabProvider(self._lab_recipe, self)      # the virtual lab, built on a worker
        self.labs.changed.connect(self._lab_changed)
        self.hardware = CellHardware(lambda: (self.project, self.robot, getattr(self.labs.current, "true_robot", None)),
                                     self)

    # -- project -------------------------------------------------------------------------
    @property
    def project(self) -> projects.Project | None:
        return self.files.project

    @property
    def mode(self) -> str:
        return self.project.mode if self.project is not None else projects.VIRTUAL_LAB

    @property
    def virtual(self) -> bool:
        return self.mode == projects.VIRTUAL_LAB

    def set_project(self, project: projects.Project | None, *, load_robot: bool = True) -> None:
        """Make `project` current. Its robot (if any) becomes the robot; if it has none and a
        robot is already chosen, that robot is written into the project."""
        robot = projects.load_robot(project) if (project is not None and load_robot) else None
        if project is not self.project:
            self.hardware.set_simulator(None)
        self.files.project = project
        self._clear_results()
        self.projectChanged.emit(project)
        if robot is not None:
            self.set_robot(robot, project.robot_source or str(project.path(Output.ROBOT)), persist=False)
        else:
            self.files.save_robot(self.robot, self.robot_source)
        self.hardware.update_connection()

    @property
    def real_cell(self) -> bool:
        """The project measures on a real cell (never on the virtual lab)."""
        return self.project is not None and self.project.real_cell

    @property
    def cell(self) -> str:
        """The project's cell in words (the virtual lab, or the real robot connection and cameras)."""
        return self.project.describe_cell() if self.project is not None else projects.LAB_WORDS

    def new_project(self, folder: str | Path, name: str | None = None, mode: str = projects.VIRTUAL_LAB, *,
                    robot_connection: projects.RobotConnection | None = None,
                    cameras: projects.CameraSources | None = None) -> projects.Project:
        project = self.files.create(folder, name, mode, robot_connection=robot_connection, cameras=cameras)
        self.set_project(project)
        return project

    def set_cell(self, mode: str, *, robot_connection: projects.RobotConnection | None = None,
                 cameras: projects.CameraSources | None = None) -> None:
        """Change the project's cell (saved in project.json). To the virtual lab: a serial robot is
        stopped and disconnected. To a real cell: the virtual lab's simulated robot is no longer the
        robot connection (connect the real one on the Setup page)."""
        if self.project is None:
            raise RoboCalError("no project", hint="Create or open a project first.")
        projects.save_cell(self.project, mode, robot_connection=robot_connection, cameras=cameras)
        if self.virtual:
            self.hardware.use_virtual_robot()
        else:
            self.hardware.forget_real_choice()
        self.cellChanged.emit(self.project)

    def open_project(self, folder: str | Path) -> projects.Project:
        project = projects.open_project(folder)
        self.set_project(project)
        return project

    def save_project(self) -> None:
        self.files.save(self.robot, self.robot_source)

    def temporary_project(self, name: str = "RoboCal demo") -> projects.Project:
        """A new project in a temporary folder, deleted by `close()` (demo, autopilot)."""
        project = self.files.create_temporary(name)
        self.set_project(project)
        return project

    def is_temporary(self) -> bool:
        return self.files.is_temporary()

    # -- robot ---------------------------------------------------------------------------
    def set_robot(self, model: RobotModel | None, source: str | None = None, *,
                  persist: bool = True) -> None:
        """Make `model` the nominal robot; with a project open, also write it to robot.json."""
        if persist:
            self.files.save_robot(model, source)
        self.robot = model
        self.robot_source = source
        self.labs.reset("the robot changed while the virtual lab was being built")
        self.robotChanged.emit(model)
        self.hardware.update_connection()

    def choose_preset(self, name: str) -> RobotModel:
        model = read_robot(robot_path(name))
        self.set_robot(model, f"preset:{name}")
        return model

    def load_robot_file(self, path: str | Path) -> RobotModel:
        model = read_robot(path)
        self.set_robot(model, str(path))
        return model

    def _lab_recipe(self) -> tuple:
        return self.robot, self.seed, self.noise

    def _lab_changed(self, lab) -> None:
        self.labChanged.emit(lab)
        if lab is not None:
            self.hardware.update_connection()

    # -- results the steps hand on ----------------------------------------------------------
    def set_stereo(self, result: StereoCalibrationResult | None) -> None:
        self.stereo = result
        self.stereoChanged.emit(result)

    def set_marker(self, trained: TrainedMarker | None) -> None:
        self.marker = trained
        self.markerChanged.emit(trained)

    def set_poses(self, selection: PoseSelectionResult | None) -> None:
        self.poses = selection
        self.posesChanged.emit(selection)

    def set_measurements(self, path: Path | None) -> None:
        self.measurements = None if path is None else Path(path)
        self.measurementsChanged.emit(self.measurements)

    def set_identification(self, result: IdentificationResult | None,
                           accuracy: TruthAccuracy | None = None) -> None:
        self.identification = result
        self.accuracy = accuracy
        self.identificationChanged.emit(result)

    def output_saved(self, key: str) -> None:
        """A step wrote the project file `key` ("stereo", "measurements", "calibrated", "marker"...)."""
        self.outputSaved.emit(key)

    def _clear_results(self) -> None:
        self.stereo = self.marker = self.poses = self.measurements = None
        self.identification = self.accuracy = None

    # -- end -----------------------------------------------------------------------------
    def close(self) -> None:
        """Stop the lab's build, stop and disconnect the robot, close the cameras, delete
        temporary projects. Safe to call twice."""
        self.labs.close()
        self.hardware.close()
        self.files.close()
