"""A robot controller simulator on a pseudo-terminal: RoboCal protocol v1 or GRBL, with
realistic motion time and injected faults (`robocal sim-robot`; the tests and the bench).

The robot moves every joint at once, in a straight line in joint space, and takes
max_i |Δq_i| / (joint_speed × speed %) seconds (× `time_scale`, < 1 in tests). Joint values
are in file units (deg / mm). GRBL here takes one block at a time (no planner queue).

Faults (`FaultPlan.parse`, comma separated; N counts the accepted moves from 1):
  drop@N        the move's done reply (v1 DONE; GRBL: its `ok`) is never sent
  garbage@N     bytes that are not ASCII arrive before the move's first reply
  slow@N:S      the move's replies come S seconds late (default 1 s)
  fault@N       half way the robot halts with ERR FAULT (GRBL: ALARM:1), no done reply
  disconnect@N  move N completes; the connection drops when the next move is sent (before
                any reply); a new one opens 0.2 s later (same `link` path when one is given;
                the link is gone meanwhile, as a USB adapter's /dev/serial/by-id link is
                while it is unplugged, so nobody opens the old pty's name, which the system
                may already have given to another program)
  short@N:D     the robot stops D (default 1) deg / mm short on every moving joint, and
                reports done as usual
`KIND~P[:value]` instead of `@N` applies the fault to each move with probability P
(generator seeded with `seed`).

`on_rest(q)` (optional) is called with the joints (deg / mm) whenever the robot comes to rest
(at start, after a move, a fault or a stop), before the done reply is sent: `robocal sim-robot
--cameras` renders there what the cell's cameras see of the simulated robot.
"""
from __future__ import annotations

import heapq
import os
import re
import select
import threading
import time
import tty
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from core.errors import UsageError
from core.robot.model import RobotModel

PROTOCOLS = ("robocal", "grbl")
FAULT_KINDS = ("drop", "garbage", "slow", "fault", "disconnect", "short")
DEFAULT_JOINT_SPEED = 90.0       # deg/s (mm/s for prismatic joints) at 100 % speed
GRBL_AXES = "XYZABC"
GRBL_BANNER = b"\r\nGrbl 1.1h ['$' for help]\r\n"
RECONNECT_DELAY = 0.2            # s, after a disconnect fault
IDLE_WAKE = 0.02                 # s, the longest the simulator waits with nothing due (how soon it sees close())


@dataclass
class FaultPlan:
    at: dict[int, dict[str, float]] = field(default_factory=dict)    # move number -> kind -> value
    chance: dict[str, tuple[float, float]] = field(default_factory=dict)  # kind -> (probability, value)

    DEFAULTS = {"slow": 1.0, "short": 1.0}

    @classmethod
    def parse(cls, spec: str | None) -> "FaultPlan":
        plan = cls()
        for item in (spec or "").replace(" ", "").split(","):
            if not item:
                continue
            m = re.fullmatch(r"([a-z]+)([@~])([0-9.]+)(?::([0-9.]+))?", item)
            if not m or m.group(1) not in FAULT_KINDS:
                raise UsageError(f"fault '{item}' is not KIND@MOVE[:VALUE] or KIND~PROBABILITY[:VALUE] "
                                 f"with KIND one of {', '.join(FAULT_KINDS)}")
            kind, how, num, value = m.groups()
            value = float(value) if value else cls.DEFAULTS.get(kind, 0.0)
            if how == "@":
                if not num.isdigit() or int(num) < 1:
                    raise UsageError(f"fault '{item}': the move number must be 1 or more")
                plan.at.setdefault(int(num), {})[kind] = value
            else:
                p = float(num)
                if not 0 <= p <= 1:
                    raise UsageError(f"fault '{item}': the probability must be between 0 and 1")
                plan.chance[kind] = (p, value)
        return plan

    def for_move(self, n: int, rng: np.random.Generator) -> dict[str, float]:
        faults = dict(self.at.get(n, {}))
        for kind, (p, value) in self.chance.items():
            if rng.random() < p:
                faults.setdefault(kind, value)
        return faults


class ControllerSim:
    """Serves one protocol for `model` (joint limits in the model) on a pseudo-terminal."""

    def __init__(self, model: RobotModel, *, protocol: str = "robocal", faults: str | FaultPlan | None = None,
                 seed: int = 0, time_scale: float = 1.0, joint_speed: float = DEFAULT_JOINT_SPEED,
                 link: str | Path | None = None, report_done: bool = True, name: str | None = None,
                 on_rest: Callable[[np.ndarray], None] | None = None):
        if protocol not in PROTOCOLS:
            raise UsageError(f"protocol '{protocol}' is not one of {', '.join(PROTOCOLS)}")
        self.model = model
        self.protocol = protocol
        self.plan = faults if isinstance(faults, FaultPlan) else FaultPlan.parse(faults)
        self.rng = np.random.default_rng(seed)
        self.time_scale = float(time_scale)
        self.joint_speed = float(joint_speed)
        self.link = Path(link) if link else None
        self.report_done = report_done
        self.on_rest = on_rest
        self.robot_name = "_".join((name or model.name or "robot").split())
        lo, hi = model.limits()
        self.lo, self.hi = model.q_to_file(lo), model.q_to_file(hi)
        self.speed = 100.0
        self.moves = 0                          # accepted moves
        self.motion_seconds = 0.0               # total motion time of the accepted moves (s)
        self.fired: list[str] = []              # "drop@3", ... the faults that happened
        self.received: list[str] = []           # every command line, in order
        self._q = np.clip(np.zeros(model.dof), self.lo, self.hi)
        self._motion = None                     # (start, target, t0, duration, faults) while moving
        self._state = "Idle"                    # GRBL state: Idle, Run, Hold:0, Alarm
        self._out: list = []                    # heap of (time, seq, bytes)
        self._seq = 0
        self._master = self._slave = None
        self._tty_name = ""
        self._closing = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self._drop_next_move = False            # a disconnect fault: drop when the next move comes
        self._drop_now = False

    # -- life cycle -----------------------------------------------------------------------
    @property
    def port(self) -> str:
        """The device to open: the stable link when one was given, else the pty's path."""
        return str(self.link) if self.link else self._tty_name

    def start(self) -> "ControllerSim":
        self._rest()
        self._open()
        self._thread = threading.Thread(target=self._serve, name="controller-sim", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        self._closing.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self._remove_link()
        self._close_fds()

    def __enter__(self) -> "ControllerSim":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    def joints(self) -> np.ndarray:
        """Where the robot is now (deg / mm)."""
        with self._lock:
            return self._position(time.monotonic())

    def _open(self) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)                  # no echo, no line editing, no CR/LF translation
        self._tty_name = os.ttyname(self._slave)
        if self.link:
            tmp = self.link.with_name(self.link.name + ".new")
            tmp.unlink(missing_ok=True)
            os.symlink(self._tty_name, tmp)
            os.replace(tmp, self.link)

    def _remove_link(self) -> None:
        """Remove the stable link while it still points at this simulator's pty."""
        if self.link and self._tty_name:
            try:
                if os.readlink(self.link) == self._tty_name:
                    self.link.unlink()
            except OSError:
                pass

    def _close_fds(self) -> None:
        for fd in (self._master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = None

    # -- serving --------------------------------------------------------------------------
    def _serve(self) -> None:
        buf = bytearray()
        reopen_at = None
        while not self._closing.is_set():
            now = time.monotonic()
            if self._master is None:
                if reopen_at is not None and now >= reopen_at:
                    self._open()
                    reopen_at = None
                    buf.clear()
                time.sleep(0.005)
                continue
            with self._lock:
                wait = self._next_due(now)
            try:
                ready, _, _ = select.select([self._master], [], [], wait)
                data = os.read(self._master, 4096) if ready else b""
            except OSError:
                data = b""
                time.sleep(0.005)
            now = time.monotonic()
            with self._lock:
                for byte in data:
                    if self.protocol == "grbl" and byte in b"?!\x18\x95\x96\x97":
                        self._grbl_realtime(byte, now)
                    elif byte == 0x0A:
                        line = bytes(buf).rstrip(b"\r").decode("latin-1")
                        buf.clear()
                        self.received.append(line)
                        (self._robocal_line if self.protocol == "robocal" else self._grbl_line)(line, now)
                    else:
                        buf.append(byte)
                self._advance(now)
            self._flush(now)
            if self._drop_now:
                self._drop_now = False
                self._remove_link()
                self._close_fds()
                reopen_at = time.monotonic() + RECONNECT_DELAY

    def _next_due(self, now: float) -> float:
        """Seconds until the simulator has something to do on its own (a reply due, a move ending or
        faulting), at most IDLE_WAKE; what the computer sends wakes it at once."""
        due = [IDLE_WAKE]
        if self._out:
            due.append(self._out[0][0] - now)
        if self._motion is not None:
            _, _, t0, duration, faults = self._motion
            due.append(t0 + (duration / 2 if "fault" in faults else duration) - now)
        return max(0.0, min(due))

    def _send(self, text: bytes | str, at: float) -> None:
        data = text.encode("ascii") if isinstance(text, str) else text
        self._seq += 1
        heapq.heappush(self._out, (at, self._seq, data))

    def _flush(self, now: float) -> None:
        while self._out and self._out[0][0] <= now and self._master is not None:
            _, _, data = heapq.heappop(self._out)
            try:
                os.write(self._master, data)
            except OSError:
                pass

    # -- motion -----------------------------------------------------------------------------
    def _rest(self) -> None:
        if self.on_rest is not None:
            self.on_rest(self._q.copy())

    def _position(self, now: float) -> np.ndarray:
        if self._motion is None:
            return self._q.copy()
        start, target, t0, duration, _ = self._motion
        f = 1.0 if duration <= 0 else min(1.0, (now - t0) / duration)
        return start + (target - start) * f

    def _dropping(self) -> bool:
        """A disconnect fault is due: the move that just came is never answered, the line drops."""
        if self._drop_next_move:
            self._drop_next_move, self._drop_now = False, True
        return self._drop_now

    def _start_move(self, target: np.ndarray, now: float) -> dict:
        self.moves += 1
        faults = self.plan.for_move(self.moves, self.rng)
        self.fired += [f"{k}@{self.moves}" for k in faults]
        start = self._q.copy()
        if "short" in faults:
            moving = np.abs(target - start) > faults["short"]
            target = np.where(moving, target - np.sign(target - start) * faults["short"], target)
        speed = self.joint_speed * self.speed / 100.0
        duration = float(np.max(np.abs(target - start))) / speed * self.time_scale
        self.motion_seconds += duration
        self._motion = (start, target, now, duration, faults)
        return faults

    def _advance(self, now: float) -> None:
        """Finish or fault the motion in progress."""
        if self._motion is None:
            return
        start, target, t0, duration, faults = self._motion
        delay = faults.get("slow", 0.0)
        if "fault" in faults and now >= t0 + duration / 2:
            self._q = self._position(t0 + duration / 2)
            self._motion = None
            self._rest()
            if self.protocol == "robocal":
                self._send("ERR FAULT motor driver fault on J1\n", now + delay)
            else:
                self._state = "Alarm"
                self._send("ALARM:1\r\n", now + delay)
            return
        if now < t0 + duration:
            return
        self._q = target.copy()
        self._motion = None
        self._rest()
        self._state = "Idle"
        if self.protocol == "robocal" and self.report_done and "drop" not in faults:
            self._send("DONE\n", now + delay)
        if "disconnect" in faults:
            self._drop_next_move = True

    def _halt(self, now: float) -> bool:
        """Stop where the robot is; True if it was moving."""
        if self._motion is None:
            return False
        self._q = self._position(now)
        self._motion = None
        self._rest()
        return True

    def _check_limits(self, target: np.ndarray) -> str | None:
        for i in range(len(target)):
            if not self.lo[i] - 1e-6 <= target[i] <= self.hi[i] + 1e-6:
                return f"J{i + 1} {target[i]:.3f} outside [{self.lo[i]:.3f}, {self.hi[i]:.3f}]"
        return None

    def _first_reply_faults(self, faults: dict, now: float) -> float:
        if "garbage" in faults:
            self._send(bytes(self.rng.integers(128, 256, 12).astype(np.uint8)) + b"\n", now)
        return now + faults.get("slow", 0.0)

    # -- RoboCal protocol v1 -------------------------------------------------------------
    def _robocal_line(self, line: str, now: float) -> None:
        words = line.split()
        cmd = words[0] if words else ""
        fmt = " ".join(f"{v:.4f}" for v in self._position(now))
        if cmd == "HELLO" and len(words) == 1:
            self._send(f"ROBOCAL 1 {self.robot_name} {self.model.dof}\n", now)
        elif cmd == "POS?" and len(words) == 1:
            self._send(f"POS {fmt}\n", now)
        elif cmd == "MOVE" and self._dropping():
            return
        elif cmd == "MOVE":
            try:
                target = np.array([float(w) for w in words[1:]])
            except ValueError:
                target = None
            if target is None or target.size != self.model.dof or not np.all(np.isfinite(target)):
                self._send(f"ERR SYNTAX MOVE needs {self.model.dof} numbers\n", now)
            elif self._motion is not None:
                self._send("ERR BUSY the robot is moving\n", now)
            elif (why := self._check_limits(target)) is not None:
                self._send(f"ERR LIMIT {why}\n", now)
            else:
                faults = self._start_move(target, now)
                self._send("ACK\n", self._first_reply_faults(faults, now))
        elif cmd == "SPEED" and len(words) == 2:
            try:
                p = float(words[1])
            except ValueError:
                p = -1.0
            if 0 < p <= 100:
                self.speed = p
                self._send("OK\n", now)
            else:
                self._send("ERR SYNTAX SPEED needs a percent in (0, 100]\n", now)
        elif cmd == "STOP" and len(words) == 1:
            self._halt(now)
            self._out = [o for o in self._out if o[2] != b"DONE\n"]
            heapq.heapify(self._out)
            self._send("STOPPED\n", now)
        else:
            self._send(f"ERR SYNTAX unknown command '{line[:40]}'\n", now)

    # -- GRBL ------------------------------------------------------------------------------
    def _grbl_realtime(self, byte: int, now: float) -> None:
        if byte == ord("?"):
            state = "Run" if self._motion is not None else self._state
            pos = ",".join(f"{v:.3f}" for v in self._position(now))
            self._send(f"<{state}|MPos:{pos}|FS:0,0>\r\n", now)
        elif byte == ord("!"):
            if self._halt(now):
                self._state = "Hold:0"
        elif byte == 0x18:
            if self._halt(now):
                self._state = "Alarm"
                self._send("ALARM:3\r\n", now)
            self._out = []
            self._send(GRBL_BANNER, now)
            if self._state == "Alarm":
                self._send("[MSG:'$H'|'$X' to unlock]\r\n", now)
            else:
                self._state = "Idle"
        else:
            self.speed = {0x95: 100.0, 0x96: 50.0, 0x97: 25.0}[byte]

    def _grbl_line(self, line: str, now: float) -> None:
        text = line.strip().upper().replace(" ", "")
        if text == "":
            self._send("ok\r\n", now)
        elif text == "$X":
            if self._state == "Alarm":
                self._send("[MSG:Caution: Unlocked]\r\n", now)
            self._state = "Idle"
            self._send("ok\r\n", now)
        elif self._state == "Alarm":
            self._send("error:9\r\n", now)
        elif text.startswith(("G90G0", "G0", "G90G1")):
            if self._dropping():
                return
            words = re.findall(r"([A-Z])(-?[0-9.]+)", text)
            target = self._position(now)
            try:
                for letter, value in words:
                    if letter in GRBL_AXES[:self.model.dof]:
                        target[GRBL_AXES.index(letter)] = float(value)
                    elif letter not in "GF":
                        raise ValueError(letter)
            except ValueError:
                self._send("error:20\r\n", now)
                return
            if self._check_limits(target) is not None:
                self._state = "Alarm"
                self._send("ALARM:2\r\n", now)
                return
            self._halt(now)
            faults = self._start_move(target, now)
            self._state = "Run"
            if "drop" not in faults:
                self._send("ok\r\n", self._first_reply_faults(faults, now))
        else:
            self._send("error:20\r\n", now)
