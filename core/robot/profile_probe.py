"""Trying a protocol profile on a controller line by line: send one command (a template of the
profile filled in, or a line typed by hand), collect the raw replies, and say which of the
profile's patterns each reply matched and with which groups (the Setup page's protocol test).

The probe talks over a `LineLink` (core.robot.serial_link): its own, opened on the port, or
the connected SerialRobot's, borrowed between two of the driver's exchanges
(`SerialRobot.borrow_link`). It blocks until the replies end: call it on a worker.

Safety: the move template sends the joints last read from the controller (a move of zero
length, to see the move and done replies); a typed line that starts like the profile's move
command but is not that template is refused before anything is written.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

from core.errors import RoboCalError
from core.robot.profile import ProtocolProfile
from core.robot.serial_link import DISCONNECTED, LINE, LineLink

QUIET_S = 0.3            # s without a reply that ends an exchange
REPLY_TIMEOUT_S = 2.0    # s: an exchange never waits longer for its first reply
MOVE_TIMEOUT_S = 30.0    # s: a move waits this long for its done (or error) reply


@dataclass(frozen=True)
class PatternMatch:
    """One pattern of the profile that matched a reply line: `pattern` names it ("hello",
    "position", "move ok", "done", "busy", "speed ok", "stop", "tolerated during a stop",
    "resume ok", "error", "ignored"), `groups` its named groups, `values` the numbers of a
    `values` group (controller units)."""

    pattern: str
    groups: dict[str, str] = field(default_factory=dict)
    values: tuple[float, ...] | None = None


@dataclass(frozen=True)
class ReplyLine:
    kind: str                        # "line", "garbage" (bytes that are not ASCII) or "disconnected"
    text: str
    after_s: float                   # seconds after the command was written
    matches: tuple[PatternMatch, ...] = ()


@dataclass
class ProbeExchange:
    sent: tuple[str, ...]            # the commands written (a one-character one without a line end)
    replies: list[ReplyLine]
    reply_expected: bool = True      # False: the profile says these commands get no reply


def templates(profile: ProtocolProfile, joints=None, percent: float = 25.0) -> dict[str, tuple[str, ...]]:
    """The profile's commands, filled in: name -> the command(s) it writes. `joints`: the
    controller's values last read (the move template is left out without them)."""
    out = {"identify": profile.hello.send, "position": profile.position.send}
    if profile.done_poll is not None:
        out["motion state"] = profile.done_poll.send
    speed = profile.speed_command(percent)
    if speed is not None:
        out["speed"] = speed
    if joints is not None:
        out["move (to the joints read)"] = (profile.format_move(joints),)
    out["stop"] = profile.stop.send
    if profile.resume is not None:
        out["resume"] = profile.resume.send
    return out


def match_line(profile: ProtocolProfile, text: str) -> tuple[PatternMatch, ...]:
    """Every pattern of `profile` that matches the whole reply `text`."""
    p = profile
    candidates = [("hello", p.hello.reply), ("position", p.position.reply), ("move ok", p.move.reply),
                  ("done", p.done_reply), ("done", p.done_poll.reply if p.done_poll else None),
                  ("busy", p.done_busy), ("speed ok", p.speed.reply if p.speed else None),
                  ("stop", p.stop.reply), ("resume ok", p.resume.reply if p.resume else None),
                  ("error", p.error)]
    candidates += [("tolerated during a stop", t) for t in p.stop_tolerate]
    candidates += [("ignored", i) for i in p.ignore]
    found, seen = [], set()
    for name, pattern in candidates:
        m = pattern.match(text) if pattern is not None else None
        if m is None or name in seen:
            continue
        seen.add(name)
        groups = {k: v for k, v in m.groupdict().items() if v}
        values = None
        if "values" in groups:
            try:
                values = tuple(p.parse_values(groups["values"]))
            except ValueError:
                values = None
        found.append(PatternMatch(name, groups, values))
    return tuple(found)


def is_typed_move(profile: ProtocolProfile, line: str) -> bool:
    """A typed line that starts like the profile's move command (its text before {joints})."""
    prefix = profile.move.send[0].split("{joints}")[0].strip()
    return bool(prefix) and line.strip().upper().startswith(prefix.upper())


class ProfileProbe:
    """Sends commands of `profile` over `link` and reports the replies."""

    def __init__(self, profile: ProtocolProfile, link: LineLink):
        self.profile = profile
        self.link = link

    @classmethod
    def open(cls, profile: ProtocolProfile, port: str, baudrate: int | None = None) -> "ProfileProbe":
        """A probe with its own link on `port` (RobotFault naming the port when it cannot open)."""
        link = LineLink(port, baudrate or profile.baudrate, reply_ends=profile.reply_ends,
                        send_end=profile.send_end)
        link.open()
        return cls(profile, link)

    def close(self) -> None:
        self.link.close()

    def send(self, commands: str | tuple[str, ...], *, allowed_move: str | None = None,
             quiet_s: float = QUIET_S, timeout_s: float | None = None, cancelled=None) -> ProbeExchange:
        """Write `commands` (a one-character command as a real-time byte, others with the line
        end) and collect the replies until none came for `quiet_s` seconds — for a move until
        its done or error reply, within `timeout_s`; commands the profile says get no reply
        (ProtocolProfile.expects_reply) end after `quiet_s` without one. `allowed_move`: the
        move template's text, the only move line accepted."""
        commands = (commands,) if isinstance(commands, str) else tuple(commands)
        if not commands or not any(c.strip() or len(c) == 1 for c in commands):
            raise RoboCalError("nothing to send", hint="Choose a template or type a command.")
        moving = False
        for cmd in commands:
            if is_typed_move(self.profile, cmd):
                if cmd != allowed_move:
                    raise RoboCalError("a move typed by hand is not sent",
                                       hint="Use the move template (the joints read) or the test move above, "
                                            "which checks the joint limits.")
                moving = True
        if timeout_s is None:
            timeout_s = MOVE_TIMEOUT_S if moving and self.profile.done_reply is not None else REPLY_TIMEOUT_S
        self.link.discard_pending()
        t0 = time.monotonic()
        for cmd in commands:
            self.link.write(cmd, end=len(cmd) != 1)
        replies: list[ReplyLine] = []
        deadline, last = t0 + timeout_s, t0
        wait_done = moving and self.profile.done_reply is not None
        expected = moving or self.profile.expects_reply(commands)
        while True:
            now = time.monotonic()
            if now >= deadline or ((replies or not expected) and not wait_done and now - last >= quiet_s) \
                    or (cancelled is not None and cancelled()):
                break
            event = self.link.get(min(0.05, deadline - now))
            if event is None:
                continue
            last = time.monotonic()
            kind, text = event
            matches = match_line(self.profile, text) if kind == LINE else ()
            replies.append(ReplyLine(kind, text, last - t0, matches))
            if kind == DISCONNECTED or (wait_done and {m.pattern for m in matches} & {"done", "error", "stop"}):
                break
        return ProbeExchange(commands, replies, expected)
