"""A robot behind a text-protocol controller on a serial port: RoboCal protocol v1
(docs/robot-protocol.md) or any protocol profile (core.robot.profile).

Safety, in this order for every move: the target is checked against the joint limits before
anything is written (RobotDriver.move_to); the move waits for the controller's done (reply
or status poll) or for the joints to stay still (the profile's settle rule), within
`move_timeout` seconds — past it a watchdog stops the robot and raises RobotTimeout (a fault,
not a Stop); then the
joints are read back and a robot that ended more than `readback_tolerance` (deg / mm) from
the target raises RobotFault (such a pose is never measured).

Any reply that is not what the profile expects (an unknown line, bytes that are not ASCII,
an error reply, no reply in `reply_timeout` seconds, a lost connection) raises RobotFault
with one line saying what came; the driver never guesses.
"""
from __future__ import annotations

import re
import threading
import time
from contextlib import contextmanager

import numpy as np

from core.errors import RoboCalError
from core.robot.driver import DriverInfo, RobotDriver, RobotFault, RobotTimeout
from core.robot.joint_map import JointMap
from core.robot.model import RobotModel
from core.robot.profile import Exchange, ProtocolProfile, builtin_profile
from core.robot.serial_link import DISCONNECTED, GARBAGE, LineLink

DEFAULT_SPEED = 25.0          # percent, for a real robot


class RobotStopped(RobotFault):
    """The robot was stopped (the Stop key) while it moved; the watchdog raises RobotTimeout."""


class SerialRobot(RobotDriver):
    def __init__(self, model: RobotModel, port: str, profile: ProtocolProfile | str = "robocal_v1", *,
                 joint_map: JointMap | dict | None = None, baudrate: int | None = None,
                 speed: float = DEFAULT_SPEED, reply_timeout: float = 2.0, move_timeout: float = 60.0,
                 readback_tolerance: float = 0.05, poll_interval: float = 0.02):
        super().__init__(model)
        self.profile = builtin_profile(profile) if isinstance(profile, str) else profile
        self.port = port
        self.baudrate = baudrate or self.profile.baudrate
        if not isinstance(joint_map, JointMap):
            joint_map = JointMap.from_dict(model.revolute_mask(), joint_map or self.profile.joints)
        self.joint_map = joint_map
        self.reply_timeout = float(reply_timeout)
        self.move_timeout = float(move_timeout)
        self.readback_tolerance = float(readback_tolerance)
        self.poll_interval = float(poll_interval)
        self._initial_speed = float(speed)
        self._link: LineLink | None = None
        self._tx = threading.RLock()           # one request/reply exchange at a time
        self._stopped = False
        self._stop_pending = False
        self._stop_ack = threading.Event()
        self.controller_name = ""
        self.last_fault: str | None = None

    @property
    def name(self) -> str:
        return f"{self.profile.name} on {self.port}"

    @property
    def info(self) -> DriverInfo:
        return DriverInfo(self.controller_name or self.profile.name, self.model.dof, self.joint_map.units,
                          can_move=True, reports_motion_state=self.profile.reports_motion_state,
                          has_stop=True)

    # -- connection ----------------------------------------------------------------------
    @property
    def connected(self) -> bool:
        """True between connect() and disconnect(), also when the line was lost meanwhile
        (`lost` says so; the next exchange raises RobotFault)."""
        return self._link is not None

    @property
    def lost(self) -> str | None:
        """Why the connection went away (None while it is up or closed on purpose)."""
        return self._link.lost if self._link is not None else None

    def connect(self) -> None:
        """Open the port, identify the controller, check its joint count, set the speed."""
        self.disconnect()
        p = self.profile
        link = LineLink(self.port, self.baudrate, reply_ends=p.reply_ends, send_end=p.send_end)
        link.open()
        self._link = link
        try:
            if p.connect_wait_s:
                time.sleep(p.connect_wait_s)
            link.discard_pending()
            with self._tx:
                m = self._request(p.hello, "the identification")
            groups = m.groupdict()
            if groups.get("dof"):
                dof = int(groups["dof"])
            elif groups.get("values"):
                dof = len(p.parse_values(groups["values"]))
            else:
                dof = p.dof or self.model.dof
            if dof != self.model.dof:
                raise RoboCalError(f"the controller has {dof} joints, the robot model {self.model.dof}",
                                   source=self.port, hint="Choose the robot model of this arm.")
            self.controller_name = groups.get("name") or p.name
            self.set_speed(self._initial_speed)
        except BaseException:
            self.disconnect()
            raise

    def disconnect(self) -> None:
        link, self._link = self._link, None
        if link is not None:
            link.close()

    @contextmanager
    def borrow_link(self):
        """The open link, for a protocol test between two of the driver's exchanges (lines
        that came meanwhile are dropped before and after, so the driver starts clean)."""
        self._require_link()
        with self._tx:
            self._link.discard_pending()
            try:
                yield self._link
            finally:
                if self._link is not None:
                    self._link.discard_pending()

    # -- motion --------------------------------------------------------------------------
    def _apply_speed(self, percent: float) -> None:
        p = self.profile
        if not self.connected:
            return
        command = p.speed_command(percent)
        if command is None:
            return
        with self._tx:
            self._send(command)
            if not p.speed_levels and p.speed.reply is not None:
                self._expect({"ok": p.speed.reply}, self.reply_timeout, what="the speed")

    def _move(self, q: np.ndarray) -> None:
        self._require_link()
        p = self.profile
        target = self.joint_map.to_controller(q)
        with self._tx:
            self._raise_stale()
            self._stop_ack.clear()
            self._send((p.format_move(target),))
            if p.move.reply is not None:
                self._expect({"ack": p.move.reply}, self.reply_timeout, what="the move")
            self._wait_settled(time.monotonic() + self.move_timeout)
            reached = self._position()
        self._check_reached(q, reached)

    def _wait_settled(self, deadline: float) -> None:
        p = self.profile
        if p.done_reply is not None:
            self._expect({"done": p.done_reply}, deadline - time.monotonic(), what="done", watchdog=True)
            return
        if p.done_poll is not None:
            while True:
                self._send(p.done_poll.send)
                name, _ = self._expect({"done": p.done_poll.reply, "busy": p.done_busy},
                                       min(self.reply_timeout, max(deadline - time.monotonic(), 0.0)),
                                       what="the motion state", watchdog=time.monotonic() > deadline)
                if name == "done":
                    return
                if time.monotonic() > deadline:
                    self._watchdog("done")
                time.sleep(self.poll_interval)
        rule = p.settle
        deadline = min(deadline, time.monotonic() + rule.timeout_s)
        last, since = None, time.monotonic()
        while True:
            values = self._controller_position()
            now = time.monotonic()
            if last is None or np.max(np.abs(values - last)) > rule.tolerance:
                last, since = values, now
            elif now - since >= rule.dwell_s:
                return
            if now > deadline:
                self._watchdog("the joints to stop moving")
            time.sleep(self.poll_interval)

    def _check_reached(self, q: np.ndarray, reached: np.ndarray) -> None:
        err = np.abs(self.model.q_to_file(reached) - self.model.q_to_file(q))
        j = int(np.argmax(err))
        if err[j] > self.readback_tolerance:
            label = self.model.joints[j].name or f"J{j + 1}"
            unit = "°" if self.model.joints[j].revolute else " mm"
            raise RobotFault(f"the robot reported the move finished but joint {label} is {err[j]:.3f}{unit} "
                             f"from the target (tolerance {self.readback_tolerance:g}); the pose is not measured",
                             source=self.name, hint="Check the arm for a blocked joint or a lost step.")

    def current_joints(self) -> np.ndarray:
        self._require_link()
        with self._tx:
            self._raise_stale()
            return self._position()

    def _position(self) -> np.ndarray:
        return self.joint_map.from_controller(self._controller_position())

    def _controller_position(self) -> np.ndarray:
        m = self._request(self.profile.position, "the joint values")
        try:
            values = np.array(self.profile.parse_values(m.group("values")), dtype=float)
        except (ValueError, IndexError):
            raise RobotFault(f"unreadable joint values '{m.group(0)}'", source=self.name) from None
        if values.size < self.model.dof:
            raise RobotFault(f"the controller gave {values.size} joint values, expected {self.model.dof}: "
                             f"'{m.group(0)}'", source=self.name)
        return values[:self.model.dof]

    # -- stop ----------------------------------------------------------------------------
    @property
    def stopped(self) -> bool:
        return self._stopped

    def stop(self) -> None:
        """Stop at once, from any thread, also during a move: unlike the base class this does
        not wait for the move to return (the controller's STOPPED ends it). Never raises."""
        self._halt()

    def _halt(self) -> None:
        """Send the stop command(s) and wait up to `reply_timeout` for the controller to
        confirm; motion stays refused until `resume()`."""
        self._stopped = True
        if not self.connected or self.lost:
            return
        p = self.profile
        self._stop_ack.clear()
        self._stop_pending = True
        try:
            self._send(p.stop.send)
            if p.stop.reply is None:
                return
            deadline = time.monotonic() + self.reply_timeout
            while not self._stop_ack.is_set() and time.monotonic() < deadline:
                if self._tx.acquire(timeout=0.05):
                    try:
                        if not self._stop_ack.is_set():
                            self._expect({}, 0.05, what="the stop", on_timeout=None)
                    finally:
                        self._tx.release()
        except RobotFault as exc:
            if not isinstance(exc, RobotStopped):
                self.last_fault = exc.message
        finally:
            self._stop_pending = False

    def resume(self) -> None:
        """Accept motion again (and unlock the controller if its profile says how)."""
        if self.connected and self.profile.resume is not None:
            with self._tx:
                self._request(self.profile.resume, "the resume")
        self._stopped = False

    # -- exchanges -----------------------------------------------------------------------
    def _require_link(self) -> None:
        if self._link is None:
            raise RoboCalError("the robot is not connected", source=self.name, hint="Connect it first (Setup step).")

    def _send(self, commands: tuple[str, ...]) -> None:
        link = self._link
        if link is None:
            raise RobotFault("the robot is not connected", source=self.name)
        for cmd in commands:
            link.write(cmd, end=len(cmd) != 1)

    def _request(self, exchange: Exchange, what: str) -> re.Match:
        self._send(exchange.send)
        return self._expect({"reply": exchange.reply}, self.reply_timeout, what=what)[1]

    def _expect(self, patterns: dict, timeout: float, *, what: str, watchdog: bool = False,
                on_timeout="raise"):
        """Wait for a line matching one of `patterns` (name -> regex); returns (name, match).
        Every other event raises RobotFault, except ignored lines and, while a stop is
        pending, the profile's tolerated lines; the stop reply raises RobotStopped."""
        p = self.profile
        deadline = time.monotonic() + max(timeout, 0.0)
        while True:
            event = self._link.get(deadline - time.monotonic()) if self._link is not None else (DISCONNECTED, "closed")
            if event is None:
                if on_timeout is None:
                    return None
                if watchdog:
                    self._watchdog(what)
                raise RobotFault(f"no reply to {what} within {timeout:.3g} s", source=self.name,
                                 hint="Check that the controller is on and speaks this protocol.")
            kind, text = event
            self._check_line(kind, text)
            for name, pat in patterns.items():
                m = pat.match(text) if pat is not None else None
                if m:
                    return name, m
            if p.stop.reply is not None and p.stop.reply.match(text) and (self._stop_pending or self._stopped):
                self._stop_ack.set()
                raise RobotStopped("the robot was stopped during the move", source=self.name,
                                   hint="Check that the way is clear, then resume.")
            if self._stop_pending and (on_timeout is None or any(t.match(text) for t in p.stop_tolerate)):
                continue                # waiting for the stop's reply: late replies of the interrupted move
            m = p.error.match(text)
            if m:
                code, detail = m.group("code"), (m.groupdict().get("text") or "").strip()
                raise RobotFault(f"the controller reported {code}" + (f": {detail}" if detail else ""),
                                 source=self.name, hint="Clear the cause on the robot, reconnect, then resume.")
            if any(i.match(text) for i in p.ignore):
                continue
            raise RobotFault(f"unexpected reply '{text[:80]}' while waiting for {what}", source=self.name,
                             hint="Check that the controller speaks this protocol.")

    def _check_line(self, kind: str, text: str) -> None:
        """A lost link or unreadable bytes are a fault; a line is left to the caller."""
        if kind == DISCONNECTED:
            raise RobotFault(f"the connection is lost ({text})", source=self.name,
                             hint="Check the cable, reconnect, then resume the run.")
        if kind == GARBAGE:
            raise RobotFault(f"unreadable bytes from the controller {text}", source=self.name,
                             hint="Check the baud rate and the cable, then reconnect.")

    def _raise_stale(self) -> None:
        """Lines that came between exchanges: an error, garbage or a lost link is a fault;
        anything else the profile does not ignore too."""
        link = self._link
        for kind, text in link.discard_pending() if link is not None else ():
            self._check_line(kind, text)
            if any(i.match(text) for i in self.profile.ignore):
                continue
            m = self.profile.error.match(text)
            problem = (f"the controller reported {m.group('code')}" if m
                       else f"unexpected line '{text[:80]}' between commands")
            raise RobotFault(problem, source=self.name, hint="Reconnect, then resume.")

    def _watchdog(self, what: str):
        self.stop()
        raise RobotTimeout(f"no {what} within {self.move_timeout:g} s; the robot was stopped", source=self.name,
                         hint="Check the robot and the move timeout, then resume.")
