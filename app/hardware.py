"""The robot connection and the two cameras the technician chose on the Setup page, and how
they are opened.

`RobotChoice`: the virtual lab's simulated robot, or a controller on a serial port (port,
protocol profile, joint map file, baud rate). `CameraChoice`: the virtual lab's cameras, or
two sources, each a device index (0), a device path (/dev/video2), a video file or an image
folder. `LiveCameras`: the two opened sources, shared by the previews and the captures under
one lock (a video file or an image folder starts again at its end, so a preview loops).
Opening a serial robot blocks (HELLO, speed): the app calls `open_serial_robot` on a worker.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from core.errors import RoboCalError
from core.files import read_json
from core.measurement.capture import CameraSettings, StereoFrames, StereoSource, open_camera, open_stereo
from core.robot.joint_map import JointMap
from core.robot.model import RobotModel
from core.robot.profile import load_profile
from core.robot.serial_robot import DEFAULT_SPEED, SerialRobot
from core.robot.simulated import SimulatedRobot

VIRTUAL, SERIAL, SOURCES = "virtual", "serial", "sources"


@dataclass(frozen=True)
class RobotChoice:
    """Which robot RoboCal moves. `profile`: a built-in profile name or a profile file;
    `joint_map`: a JSON file (units, sign, offset, ticks_per_unit), "" for the profile's."""

    kind: str = VIRTUAL
    port: str = ""
    profile: str = "robocal_v1"
    joint_map: str = ""
    baud: int | None = None

    @property
    def real(self) -> bool:
        return self.kind == SERIAL


@dataclass(frozen=True)
class CameraChoice:
    """Which two cameras RoboCal captures from (left, right as typed by the technician)."""

    kind: str = VIRTUAL
    left: str = ""
    right: str = ""


def open_serial_robot(model: RobotModel, choice: RobotChoice, *, speed: float = DEFAULT_SPEED,
                      **driver_options) -> SerialRobot:
    """A connected SerialRobot for `choice` (blocks for the controller's identification: call
    it on a worker). Speed `speed` % (25 % unless told). Raises RoboCalError naming the port,
    the profile or the joint map file and what to do."""
    if not choice.port.strip():
        raise RoboCalError("no serial port given", field="port",
                           hint="Type the controller's device, e.g. /dev/ttyUSB0 or the path sim-robot printed.")
    profile = load_profile(choice.profile)
    joint_map = None
    if choice.joint_map.strip():
        data = read_json(choice.joint_map)
        try:
            joint_map = JointMap.from_dict(model.revolute_mask(), data)
        except RoboCalError as exc:
            raise RoboCalError(exc.problem, source=choice.joint_map, field=exc.field,
                               hint=exc.hint or "Fix the joint map file (units, sign, offset).") from None
    driver = SerialRobot(model, choice.port.strip(), profile, joint_map=joint_map, baudrate=choice.baud,
                         speed=speed, **driver_options)
    driver.connect()
    return driver


def camera_spec(text: str) -> int | str:
    """A typed camera source: digits are a device index, anything else a path."""
    text = str(text).strip()
    if not text:
        raise RoboCalError("no camera source given", field="camera",
                           hint="Give a device index (0), a device path, a video file or an image folder.")
    return int(text) if text.isdigit() else text


class LiveCameras:
    """Two opened cameras (left, right), one lock for previews and captures."""

    def __init__(self, source: StereoSource, choice: CameraChoice | None = None,
                 settings: CameraSettings | None = None):
        self.source = source
        self.choice = choice
        self.settings = settings
        self._lock = threading.Lock()

    @classmethod
    def open(cls, choice: CameraChoice, settings: CameraSettings | None = None) -> "LiveCameras":
        left = camera_spec(choice.left)
        if not str(choice.right).strip():
            open_camera(left, settings).close()          # a bad left source is named first
        return cls(open_stereo(left, camera_spec(choice.right), settings), choice, settings)

    @property
    def warnings(self) -> list[str]:
        return self.source.warnings

    def describe(self) -> str:
        """One line per camera: its name and where it is plugged or stored."""
        left, right = self.source.identities()
        return f"left: {left.name} ({left.bus}) · right: {right.name} ({right.bus})"

    def preview(self) -> tuple[np.ndarray, np.ndarray]:
        """The next frame of each camera, both grabbed before either is decoded, as a capture
        does (no flush; files and folders loop)."""
        with self._lock:
            cams = (self.source.left, self.source.right)
            for cam in cams:
                self._grab(cam)
            return cams[0].retrieve(), cams[1].retrieve()

    def capture(self) -> StereoFrames:
        """A stereo pair taken together (stale frames of live cameras dropped first); video
        files and image folders start again after their last frame."""
        with self._lock:
            try:
                return self.source.capture()
            except RoboCalError as exc:
                if "no more images" not in exc.problem or not (self.source.left.rewind()
                                                               | self.source.right.rewind()):
                    raise
            return self.source.capture()

    def close(self) -> None:
        with self._lock:
            self.source.close()

    @staticmethod
    def _grab(cam) -> None:
        if not cam.grab():
            if not cam.rewind() or not cam.grab():
                raise RoboCalError("the source gives no image", source=cam.spec,
                                   hint="Check the camera, the video file or the folder.")


def is_real(driver) -> bool:
    """A driver that moves a physical robot (anything but the virtual lab's simulated robot)."""
    return driver is not None and not isinstance(driver, SimulatedRobot)
