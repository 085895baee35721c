"""What the GUI checks before it makes the robot move (every page that moves the robot asks here
first, on the GUI thread):

- a robot is connected and not stopped (after Stop, motion needs an explicit Resume);
- every target is inside the joint limits (the driver's check: the message names the joint,
  its value and its limits; nothing is sent);
- the first motion of a real robot connection is confirmed by the technician (a question box;
  the autopilot and the tests answer it through app.messages' non-interactive mode).
"""
from __future__ import annotations

from typing import Iterable

from PySide6.QtWidgets import QWidget

from app.messages import confirm
from core.errors import RoboCalError


def motion_refused(parent: QWidget | None, state, targets: Iterable = ()) -> str | None:
    """None when the robot may move to every configuration of `targets` (internal units),
    else why not, in one line for the page's status. Asks for the confirmation of the first
    motion of a real robot."""
    driver = state.hardware.robot_connection
    if driver is None or not driver.connected:
        return "No robot is connected: connect one on the Setup page."
    if driver.stopped:
        return "The robot is stopped. When the way is clear, press Resume (Robot ▸ Resume after stop)."
    for q in targets:
        try:
            driver.check_joints(q)
        except RoboCalError as exc:
            return exc.message
    if state.hardware.real_robot and not state.hardware.motion_confirmed:
        question = (f"The robot “{driver.info.name}” is about to move at {driver.speed:g} % of its speed.\n\n"
                    "Is the space around the arm clear, and is the emergency stop within reach?\n"
                    "Esc or the Stop button stops it at any time.")
        if not confirm(parent, question, "RoboCal: first motion of the robot", yes="Move the robot"):
            return "Motion not confirmed: the robot was not moved."
        state.hardware.motion_confirmed = True
    return None
