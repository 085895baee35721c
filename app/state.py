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
  asked with `request_lab(callback)`;
- `state.hardware` (app.cell_hardware.CellHardware): the robot connection every page moves, the
  cameras and the classroom controller simulator, opened and closed there. The state passes
  through its attributes and methods (`robot_connection`, `cameras`, `use_serial_robot`,
  `set_cameras`, `stop_robot`...) and its signals (`connectionChanged`, `camerasChanged`,
  `simulatorChanged`, `stoppedChanged`);
- `state.files` (app.project_files.ProjectFiles): the project folder, saved and (for a demo)
  deleted at close.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from PySide6.QtCore import QObject, Signal

from app.cell_hardware import CellHardware
from app.hardware import CameraChoice, LiveCameras, RobotChoice
from app.lab import VirtualLab
from app.lab_provider import LabProvider, LabWait
from app.project_files import ProjectFiles
from core import project as projects
from core.errors import RoboCalError
from core.identification.model_comparison import TruthAccuracy
from core.identification.result import IdentificationResult
from core.marker.training import TrainedMarker
from core.poses.selection import PoseSelectionResult
from core.project import Output
from core.robot.controller_sim import ControllerSim
from core.robot.driver import RobotDriver
from core.robot.file import read_robot
from core.robot.model import RobotModel, robot_path
from core.stereo.calibration import StereoCalibrationResult


class WizardState(QObject):
    """Shared state of one wizard window.

    Signals: `projectChanged(Project | None)`, `robotChanged(RobotModel | None)`,
    `connectionChanged(RobotDriver | None)`, `camerasChanged(LiveCameras | None)`,
    `stoppedChanged(bool)` (Stop / Resume), `cellChanged(Project)` (the project's cell changed:
    virtual lab or real cell, `set_cell`), `labChanged(VirtualLab | None)`, and one per
    step result (`stereoChanged`, `markerChanged`, `posesChanged`, `measurementsChanged`,
    `identificationChanged`) with the new value; `outputSaved(str)`: a step wrote a project
    file (its core.project.OUTPUT_FILES key, or "marker"), so results made from it may be out of date.
    """

    projectChanged = Signal(object)
    cellChanged = Signal(object)
    robotChanged = Signal(object)
    connectionChanged = Signal(object)
    camerasChanged = Signal(object)
    simulatorChanged = Signal(object)
    stoppedChanged = Signal(bool)
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
        for signal in ("connectionChanged", "camerasChanged", "simulatorChanged", "stoppedChanged"):
            getattr(self.hardware, signal).connect(getattr(self, signal))

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
            self.set_simulator(None)
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

    # -- hardware (state.hardware: app.cell_hardware.CellHardware) -------------------------------
    @property
    def robot_connection(self) -> RobotDriver | None:
        return self.hardware.robot_connection

    @property
    def robot_choice(self) -> RobotChoice:
        return self.hardware.robot_choice

    @property
    def real_robot(self) -> bool:
        """A physical robot is connected (not the virtual lab's simulated robot)."""
        return self.hardware.real_robot

    @property
    def motion_confirmed(self) -> bool:
        return self.hardware.motion_confirmed

    @motion_confirmed.setter
    def motion_confirmed(self, confirmed: bool) -> None:
        self.hardware.motion_confirmed = confirmed

    @property
    def cameras(self) -> LiveCameras | None:
        return self.hardware.cameras

    @property
    def camera_choice(self) -> CameraChoice:
        return self.hardware.camera_choice

    @property
    def camera_changes(self) -> list[str]:
        return self.hardware.camera_changes

    @property
    def simulator(self) -> ControllerSim | None:
        return self.hardware.simulator

    def use_serial_robot(self, driver: RobotDriver, choice: RobotChoice) -> None:
        self.hardware.use_serial_robot(driver, choice)

    def use_virtual_robot(self) -> None:
        self.hardware.use_virtual_robot()

    def set_cameras(self, cameras: LiveCameras | None, choice: CameraChoice | None = None) -> None:
        self.hardware.set_cameras(cameras, choice)

    def set_simulator(self, sim: ControllerSim | None) -> None:
        self.hardware.set_simulator(sim)

    def stop_robot(self) -> bool:
        return self.hardware.stop_robot()

    def resume_robot(self) -> bool:
        return self.hardware.resume_robot()

    # -- virtual lab ---------------------------------------------------------------------
    @property
    def lab(self) -> VirtualLab:
        """The virtual lab for the current robot, waited for here (scripts and tests: ~2 s on the
        worker the first time). Pages use `request_lab`, which never blocks."""
        return self.labs.ready_now()

    @property
    def has_lab(self) -> bool:
        return self.labs.current is not None

    def request_lab(self, callback: Callable[[VirtualLab], None],
                    on_error: Callable[[str], None] | None = None) -> LabWait:
        """Call `callback(lab)` with the virtual lab of the current robot, seed and noise: at
        once when it exists, otherwise when the one build on the worker thread ends (every
        page that asks meanwhile waits for the same build). A failed build calls `on_error`.
        `cancel()` the returned wait to stop waiting (the build goes on for the others)."""
        return self.labs.when_ready(callback, on_error)

    def adopt_lab(self, lab: VirtualLab | None) -> None:
        """Take a lab built elsewhere (one lab shared by several states, as the tests do) if it
        matches this state's robot, seed and noise. Pages ask `request_lab` instead."""
        if self.has_lab or lab is None or self.robot is None:
            return
        if (getattr(lab, "seed", None), getattr(lab, "noise", None)) != (self.seed, float(self.noise)):
            return
        nominal = getattr(lab, "nominal_robot", None)
        if nominal is None or nominal.name != self.robot.name or nominal.dof != self.robot.dof:
            return
        self.labs.adopt(lab)

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
