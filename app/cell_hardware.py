"""The hardware of one wizard window and its lifecycle: the robot connection every page moves,
the two cameras, and the classroom controller simulator the Setup page may start.

`robot_connection` is the virtual lab's SimulatedRobot (over the lab's true geometry once the lab
exists, over the nominal model before) in a virtual-lab project, or a connected SerialRobot given
by `use_serial_robot`; `cameras` are app.hardware.LiveCameras (None: the virtual lab's cameras).
What was opened is recorded in project.json (core.project.save_hardware); `camera_changes` says
how the cameras opened differ from those the project recorded (a swapped cable).
`motion_confirmed`: the technician confirmed the first motion of this real robot connection
(app.safety). The old driver, cameras or simulator are stopped and closed when replaced.
"""
from __future__ import annotations

from dataclasses import asdict
from typing import Callable

from PySide6.QtCore import QObject, Signal

from app.hardware import CameraChoice, LiveCameras, RobotChoice, is_real
from core import project as projects
from core.measurement.capture import CameraIdentity
from core.robot.controller_sim import ControllerSim
from core.robot.driver import RobotDriver
from core.robot.model import RobotModel
from core.robot.simulated import SimulatedRobot

#: () -> (project or None, nominal robot or None, the lab's true robot or None): what the
#: hardware is chosen for
Cell = Callable[[], tuple]


class CellHardware(QObject):
    """Signals: `connectionChanged(RobotDriver | None)`, `camerasChanged(LiveCameras | None)`,
    `simulatorChanged(ControllerSim | None)`, `stoppedChanged(bool)` (Stop / Resume)."""

    connectionChanged = Signal(object)
    camerasChanged = Signal(object)
    simulatorChanged = Signal(object)
    stoppedChanged = Signal(bool)

    def __init__(self, cell: Cell, parent: QObject | None = None):
        super().__init__(parent)
        self._cell = cell
        self.robot_connection: RobotDriver | None = None
        self.robot_choice = RobotChoice()
        self.motion_confirmed = False
        self.camera_choice = CameraChoice()
        self.cameras: LiveCameras | None = None
        self.camera_changes: list[str] = []      # what differs from the cameras the project recorded
        self.simulator: ControllerSim | None = None

    @property
    def real_robot(self) -> bool:
        """A physical robot is connected (not the virtual lab's simulated robot)."""
        return is_real(self.robot_connection)

    # -- robot connection ----------------------------------------------------------------
    def update_connection(self) -> None:
        """The simulated robot chosen, in a virtual-lab project: a SimulatedRobot over the lab's
        true geometry once the lab exists (over the nominal model before). A serial robot stays
        connected while its model is the robot; another robot disconnects it (connect again on
        the Setup page)."""
        project, robot, truth = self._cell()
        virtual = project is None or project.mode == projects.VIRTUAL_LAB
        old = self.robot_connection
        new: RobotDriver | None = None
        if self.robot_choice.real:
            if old is not None and is_real(old) and old.model is robot:
                return
        elif robot is not None and virtual:
            new = SimulatedRobot(truth if isinstance(truth, RobotModel) else robot)
            new.connect()
        if old is not None:
            if old.stopped and new is not None:
                new.stop()                  # a Stop latches until the user resumes, whatever replaced the driver
            old.stop()
            old.disconnect()
        self.robot_connection = new
        self.connectionChanged.emit(new)

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
        project = self._cell()[0]
        if project is not None:
            projects.save_hardware(project, robot_connection=projects.RobotConnection(
                choice.kind, choice.port, choice.profile, choice.joint_map, choice.baud, float(driver.speed)))
        self.connectionChanged.emit(driver)

    def use_virtual_robot(self) -> None:
        """Back to the virtual lab's simulated robot (a serial robot is stopped and disconnected)."""
        self.robot_choice = RobotChoice()
        old = self.robot_connection
        if old is not None and is_real(old):
            old.stop()
            old.disconnect()
            self.robot_connection = None
        self.update_connection()

    def forget_real_choice(self) -> None:
        """The project left the virtual lab: the simulated robot is no longer the connection."""
        if not self.real_robot:
            self.robot_choice = RobotChoice()
            self.update_connection()

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

    # -- cameras and the classroom simulator ------------------------------------------------
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
        project = self._cell()[0]
        if project is None:
            return []
        now = cameras.source.identities()
        before = (project.cameras.identity if project.cameras is not None else None) or {}
        changes = []
        try:
            expected = (CameraIdentity(**before["left"]), CameraIdentity(**before["right"]))
        except (KeyError, TypeError):
            expected = None
        if expected is not None:
            changes = cameras.source.check_identities(expected)
        choice = self.camera_choice
        projects.save_hardware(project, cameras=projects.CameraSources(
            choice.kind, choice.left, choice.right,
            settings=asdict(cameras.settings) if cameras.settings is not None else None,
            identity={side: {"name": i.name, "bus": i.bus} for side, i in zip(("left", "right"), now)}))
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

    # -- end -----------------------------------------------------------------------------
    def close(self) -> None:
        """Stop and disconnect the robot, close the cameras and the simulator. Safe twice."""
        if self.robot_connection is not None:
            self.robot_connection.stop()
            self.robot_connection.disconnect()
        if self.cameras is not None:
            self.set_cameras(None)
        self.set_simulator(None)
