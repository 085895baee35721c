"""The Setup step's robot work on a worker thread (each blocks on the controller): connect a
serial robot, read its joints, move it a small step. Joint values in internal units (rad / mm)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.hardware import RobotChoice, open_serial_robot
from core.robot.driver import DriverInfo, RobotDriver
from core.robot.model import RobotModel


@dataclass
class Connected:
    driver: RobotDriver
    info: DriverInfo
    joints: np.ndarray


def connect_serial(model: RobotModel, choice: RobotChoice, speed: float) -> Connected:
    """Open the port, identify the controller (HELLO), set the speed, read the joints. A
    failure after the port opened closes it again."""
    driver = open_serial_robot(model, choice, speed=speed)
    try:
        return Connected(driver, driver.info, driver.current_joints())
    except BaseException:
        driver.disconnect()
        raise


def read_joints(driver: RobotDriver) -> np.ndarray:
    return driver.current_joints()


def move_and_read(driver: RobotDriver, target) -> np.ndarray:
    """Move to `target` (the driver refuses it outside the limits or after a stop), then
    read where the robot is."""
    driver.move_to(target)
    return driver.current_joints()
