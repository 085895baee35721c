"""What the wizard's pages share: the project, the robot model, the robot connection, the
virtual lab, and the results the steps hand to each other.

Every page gets the same `WizardState` (``self.state``) and listens to its signals rather
than to other pages. The project folder stays the durable truth: a step that produces a
file writes it with ``state.project.path("stereo")`` etc. The in-memory results the steps
hand on are typed attributes, each with its signal and its setter:

    state.set_stereo(result)          # stereoChanged(result)          StereoCalibrationResult
    state.set_marker(trained)         # markerChanged(trained)         TrainedMarker
    state.set_poses(selection)        # posesChanged(selection)        PoseSelectionResult
    state.set_measurements(path)      # measurementsChanged(path)      Path of measurements.csv
    state.set_identification(result, accuracy)   # identificationChanged(result)
    state.output_saved("calibrated")             # outputSaved(key): a step wrote that project file

A page whose result was made from other inputs than the project now has says so (core.provenance:
the inputs' hashes recorded beside an output) and its step is not done until it is run again.

The virtual lab is built once, on a worker thread, by `state.labs` (app.lab_provider), asked
with `request_lab(callback)`.

The hardware chosen on the Setup page: `robot_choice` (app.hardware.RobotChoice) and
`robot_connection` (the driver every page moves: the virtual lab's SimulatedRobot, or a
connected SerialRobot given by `use_serial_robot`), `camera_choice` and `cameras`
(app.hardware.LiveCameras, None for the virtual lab's cameras; `set_cameras`,
`camerasChanged`), `simulator` (a ControllerSim the Setup page started for a class without a
robot, closed with the project; `set_simulator`, `simulatorChanged`). The robot connection
and the cameras opened are recorded in project.json; `camera_changes` says how the cameras
opened differ from those the project recorded (a swapped cable). `motion_confirmed`: the technician confirmed the first motion of this
real robot connection (app.safety).
"""
from __future__ import annotations

import shutil
import tempfile
from dataclasses import asdict
from pathlib import Path
from typing import Callable

from PySide6.QtCore import QObject, Signal

from app.hardware import CameraChoice, LiveCameras, RobotChoice, is_real
from app.lab import VirtualLab
from app.lab_provider import LabProvider, LabWait
from core import project as projects
from core.errors import RoboCalError
from core.identification.model_comparison import TruthAccuracy
from core.identification.solver import IdentificationResult
from core.marker.training import TrainedMarker
from core.poses.selection import PoseSelectionResult
from core.measurement.capture import CameraIdentity
from core.robot.controller_sim import ControllerSim
from core.robot.driver import RobotDriver
from core.robot.file import read_robot
from core.robot.model import RobotModel, robot_path
from core.robot.simulated import SimulatedRobot
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
        self.project: projects.Project | None = None
        self.robot: RobotModel | None = None
        self.robot_source: str | None = None     # "preset:ur5" or a file path
        self.robot_connection: RobotDriver | None = None
        self.robot_choice = RobotChoice()
        self.motion_confirmed = False
        self.camera_choice = CameraChoice()
        self.cameras: LiveCameras | None = None
        self.camera_changes: list[str] = []      # what differs from the cameras the project recorded
        self.simulator: ControllerSim | None = None    # the Setup page's classroom controller simulator
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
        self._temp_dirs: list[Path] = []

    # -- project -------------------------------------------------------------------------
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
        self.project = project
        self._clear_results()
        self.projectChanged.emit(project)
        if robot is not None:
            self.set_robot(robot, project.robot_source or str(project.path("robot")), persist=False)
        elif project is not None and self.robot is not None:
            projects.save_robot(project, self.robot, self.robot_source)
        self._update_connection()

    @property
    def real_cell(self) -> bool:
        """The project measures on a real cell (never on the virtual lab)."""
        return self.project is not None and self.project.real_cell

    @property
    def cell(self) -> str:
        """The project's cell in words (the virtual lab, or the real robot connection and cameras)."""
        return self.project.describe_cell() if self.project is not None else projects.LAB_WORDS

    def new_project(self, folder: str | Path, name: str | None = None, mode: str = projects.VIRTUAL_LAB, *,
                    robot_connection: dict | None = None, cameras: dict | None = None) -> projects.Project:
        project = projects.create_project(folder, name=name, mode=mode, robot_connection=robot_connection,
                                          cameras=cameras)
        self.set_project(project)
        return project

    def set_cell(self, mode: str, *, robot_connection: dict | None = None, cameras: dict | None = None) -> None:
        """Change the project's cell (saved in project.json). To the virtual lab: a serial robot is
        stopped and disconnected. To a real cell: the virtual lab's simulated robot is no longer the
        robot connection (connect the real one on the Setup page)."""
        if self.project is None:
            raise RoboCalError("no project", hint="Create or open a project first.")
        projects.save_cell(self.project, mode, robot_connection=robot_connection, cameras=cameras)
        if self.virtual:
            self.use_virtual_robot()
        elif not self.real_robot:
            self.robot_choice = RobotChoice()
            self._update_connection()
        self.cellChanged.emit(self.project)

    def open_project(self, folder: str | Path) -> projects.Project:
        project = projects.open_project(folder)
        self.set_project(project)
        return project

    def save_project(self) -> None:
        if self.project is None:
            raise RoboCalError("no project to save", hint="Create or open a project first.")
        projects.save_project(self.project)
        if self.robot is not None:
            projects.save_robot(self.project, self.robot, self.robot_source)

    def temporary_project(self, name: str = "RoboCal demo") -> projects.Project:
        """A new project in a temporary folder, deleted by `close()` (demo, autopilot)."""
        folder = Path(tempfile.mkdtemp(prefix="robocal-demo-"))
        self._temp_dirs.append(folder)
        return self.new_project(folder / "project", name=name)

    def is_temporary(self) -> bool:
        return self.project is not None and any(
            d in self.project.folder.parents for d in self._temp_dirs)

    # -- robot ---------------------------------------------------------------------------
    def set_robot(self, model: RobotModel | None, source: str | None = None, *,
                  persist: bool = True) -> None:
        """Make `model` the nominal robot; with a project open, also write it to robot.json."""
        if model is not None and persist and self.project is not None:
            projects.save_robot(self.project, model, source)
        self.robot = model
        self.robot_source = source
        self.labs.reset("the robot changed while the virtual lab was being built")
        self.robotChanged.emit(model)
        self._update_connection()

    def choose_preset(self, name: str) -> RobotModel:
        model = read_robot(robot_path(name))
        self.set_robot(model, f"preset:{name}")
        return model

    def load_robot_file(self, path: str | Path) -> RobotModel:
        model = read_robot(path)
        self.set_robot(model, str(path))
        return model

    # -- robot connection ----------------------------------------------------------------
    def _update_connection(self) -> None:
        """The simulated robot chosen, in virtual lab mode: a SimulatedRobot over the lab's
        true geometry once the lab exists (over the nominal model before). A serial robot
        stays connected while its model is the robot; another robot disconnects it (connect
        again on the Setup page)."""
        old = self.robot_connection
        new: RobotDriver | None = None
        if self.robot_choice.real:
            if old is not None and is_real(old) and old.model is self.robot:
                return
        elif self.robot is not None and self.virtual:
            truth = getattr(self.labs.current, "true_robot", None)
            new = SimulatedRobot(truth if isinstance(truth, RobotModel) else self.robot)
            new.connect()
        if old is not None:
            if old.stopped and new is not None:
                new.stop()                  # a Stop latches until the user resumes, whatever replaced the driver
            old.stop()
            old.disconnect()
        self.robot_connection = new
        self.connectionChanged.emit(new)

    @property
    def real_robot(self) -> bool:
        """A physical robot is connected (not the virtual lab's simulated robot)."""
        return is_real(self.robot_connection)

    def use_serial_robot(self, driver: RobotDriver, choice: RobotChoice) -> None:
        """Make a connected serial robot the robot connection (the old one is stopped and
        disconnected); its first motion will be confirmed again."""
        old = self.robot_connection
        self.robot_choice = choice
        self.motion_confirmed = False
        if old is not None and old is not driver:
            old.stop()
            old.disconnect()
        self.robot_connection = driver
        if self.project is not None:
            projects.save_hardware(self.project, robot_connection={
                "kind": choice.kind, "port": choice.port, "profile": choice.profile, "joint_map": choice.joint_map,
                "baud": choice.baud, "speed": float(driver.speed)})
        self.connectionChanged.emit(driver)

    def use_virtual_robot(self) -> None:
        """Back to the virtual lab's simulated robot (a serial robot is stopped and disconnected)."""
        self.robot_choice = RobotChoice()
        old = self.robot_connection
        if old is not None and is_real(old):
            old.stop()
            old.disconnect()
            self.robot_connection = None
        self._update_connection()

    def set_cameras(self, cameras: LiveCameras | None, choice: CameraChoice | None = None) -> None:
        """The two cameras to capture from (None: the virtual lab's); the old ones are closed."""
        old, self.cameras = self.cameras, cameras
        self.camera_choice = choice or (cameras.choice if cameras is not None else None) or CameraChoice()
        self.camera_changes = self._remember_cameras(cameras) if cameras is not None else []
        self.camerasChanged.emit(cameras)          # previews of the old cameras stop first
        if old is not None and old is not cameras:
            old.close()

    def _remember_cameras(self, cameras: LiveCameras) -> list[str]:
        """Record the opened cameras in the project (sources, settings, identity); returns what
        changed since the identity recorded before (a swapped cable, another camera)."""
        if self.project is None:
            return []
        now = cameras.source.identities()
        before = (self.project.cameras or {}).get("identity") or {}
        changes = []
        try:
            expected = (CameraIdentity(**before["left"]), CameraIdentity(**before["right"]))
        except (KeyError, TypeError):
            expected = None
        if expected is not None:
            changes = cameras.source.check_identities(expected)
        choice = self.camera_choice
        projects.save_hardware(self.project, cameras={
            "kind": choice.kind, "left": choice.left, "right": choice.right,
            "settings": asdict(cameras.settings) if cameras.settings is not None else None,
            "identity": {side: {"name": i.name, "bus": i.bus} for side, i in zip(("left", "right"), now)}})
        return changes

    def set_simulator(self, sim: ControllerSim | None) -> None:
        """The running controller simulator (None: none); the old one is closed, after a robot
        connected to it was disconnected."""
        old, self.simulator = self.simulator, sim
        if old is not None and old is not sim:
            driver = self.robot_connection
            if is_real(driver) and getattr(driver, "port", None) == old.port:
                self.use_virtual_robot()
            old.close()
        self.simulatorChanged.emit(sim)

    def stop_robot(self) -> bool:
        """Stop the robot now (the Stop key). Returns True if there was a robot to stop."""
        if self.robot_connection is None:
            return False
        self.robot_connection.stop()
        self.stoppedChanged.emit(True)
        return True

    def resume_robot(self) -> bool:
        """Accept motion again after a stop (the technician checked that the way is clear).
        Returns True if there was a robot to resume. May raise RobotFault (a controller that
        refuses to unlock)."""
        if self.robot_connection is None:
            return False
        try:
            self.robot_connection.resume()
        finally:
            self.stoppedChanged.emit(self.robot_connection.stopped)
        return True

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
            self._update_connection()

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
        """Stop and disconnect the robot, delete temporary projects. Safe to call twice."""
        self.labs.close()
        if self.robot_connection is not None:
            self.robot_connection.stop()
            self.robot_connection.disconnect()
        if self.cameras is not None:
            self.set_cameras(None)
        self.set_simulator(None)
        for folder in self._temp_dirs:
            shutil.rmtree(folder, ignore_errors=True)
        self._temp_dirs.clear()
