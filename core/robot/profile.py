"""Protocol profiles: how to talk to a robot controller's text protocol (format robocal.protocol/1).

A profile is a JSON file of command templates and reply patterns (Python regular
expressions, matched against one whole reply line):

- `hello`    {"send", "reply"}: identifies the controller; named groups `name`, `dof` or `values`
- `position` {"send", "reply", "separator"}: the joint values, group `values`
- `move`     {"send" with `{joints}`, "separator", "axes" (optional letters), "reply" or null}
- `done`     {"reply"}: a line the controller sends when a move finished; or {"poll", "reply",
             "busy"}: a status query repeated until its reply matches `reply` (`busy`: its
             reply while moving); or absent: the joints are watched until still (`settle`)
- `speed`    {"send" with `{percent}`, "reply" or null}, or {"levels": [[percent, bytes], ...]}
- `stop`     {"send": [...], "reply", "tolerate": [...]}; `resume` {"send", "reply"} or null
- `error`    a pattern with groups `code` and `text`; `ignore`: patterns of lines to skip
- `settle`   {"tolerance", "dwell_s", "timeout_s"} (controller units) for controllers without `done`
- `joints`   the default joint map (core.robot.joint_map): units, sign, offset, ticks_per_unit

A command of one character is a real-time byte (GRBL's `?`, `!`, 0x18): sent without a line
end. Commands are encoded latin-1 (one byte per character).

Built-in profiles live in resources/robots/profiles/ (`builtin_profile("grbl_joint_arm")`).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from core.errors import RoboCalError
from core.files import read_json
from core.resources import resource_path
from core.validate import check_format

FAMILY = "robocal.protocol"
FORMAT = f"{FAMILY}/1"


@dataclass(frozen=True)
class Exchange:
    """A command and the pattern of its reply (None: the command has no reply)."""

    send: tuple[str, ...]
    reply: re.Pattern | None


@dataclass(frozen=True)
class SettleRule:
    """Joints unchanged within `tolerance` (controller units) for `dwell_s` seconds means
    settled; not settled after `timeout_s` is a fault (as ROS robot_calibration's settle)."""

    tolerance: float = 0.001
    dwell_s: float = 0.5
    timeout_s: float = 30.0


@dataclass
class ProtocolProfile:
    name: str
    hello: Exchange
    position: Exchange
    move: Exchange
    stop: Exchange
    error: re.Pattern
    separator: str = " "
    move_separator: str = " "
    axes: tuple[str, ...] = ()
    value_format: str = "{:.4f}"
    done_reply: re.Pattern | None = None
    done_poll: Exchange | None = None
    done_busy: re.Pattern | None = None
    settle: SettleRule | None = None
    speed: Exchange | None = None
    speed_levels: tuple[tuple[float, str], ...] = ()
    stop_tolerate: tuple[re.Pattern, ...] = ()
    resume: Exchange | None = None
    ignore: tuple[re.Pattern, ...] = ()
    baudrate: int = 115200
    send_end: str = "\n"
    reply_ends: str = "\n"
    connect_wait_s: float = 0.0
    dof: int | None = None
    joints: dict = field(default_factory=dict)
    source: str | None = None

    @property
    def reports_motion_state(self) -> bool:
        return self.done_reply is not None or self.done_poll is not None

    def format_move(self, values) -> str:
        """The move command for controller joint values."""
        parts = [self.value_format.format(float(v)) for v in values]
        if self.axes:
            if len(self.axes) < len(parts):
                raise RoboCalError(f"the profile names {len(self.axes)} axes for {len(parts)} joints",
                                   source=self.source, field="move.axes")
            parts = [a + p for a, p in zip(self.axes, parts)]
        return self.move.send[0].replace("{joints}", self.move_separator.join(parts))

    def speed_command(self, percent: float) -> tuple[str, ...] | None:
        """The command(s) that set the speed to `percent` (% of full speed): the highest speed
        level at or below it (the lowest level when none is), or the speed template filled in;
        None without either."""
        if self.speed_levels:
            fitting = [cmd for level, cmd in self.speed_levels if level <= percent + 1e-9]
            return (fitting[-1] if fitting else self.speed_levels[0][1],)
        if self.speed is not None:
            return tuple(c.replace("{percent}", f"{percent:g}") for c in self.speed.send)
        return None

    def expects_reply(self, commands: tuple[str, ...]) -> bool:
        """False when the profile says `commands` get no reply: a speed level's real-time byte
        (GRBL's overrides), or a speed, stop or resume command whose reply pattern is null (the
        speed's {percent} filled in)."""
        commands = tuple(commands)
        if len(commands) == 1 and any(commands[0] == level for _, level in self.speed_levels):
            return False
        for ex in (self.speed, self.stop, self.resume):
            if ex is None or ex.reply is not None or len(ex.send) != len(commands):
                continue
            templates = [re.escape(t).replace(re.escape("{percent}"), r"[-+0-9.eE]+") for t in ex.send]
            if all(re.fullmatch(t, c) for t, c in zip(templates, commands)):
                return False
        return True

    def parse_values(self, text: str) -> list[float]:
        """The numbers of a `values` group (raises ValueError when one is not a number)."""
        items = [t for t in (text.split(self.separator) if self.separator.strip() else text.split()) if t.strip()]
        return [float(t) for t in items]


def read_profile(path: str | Path) -> ProtocolProfile:
    """A protocol profile from a JSON file, every pattern compiled (RoboCalError naming the
    file and field otherwise)."""
    data = read_json(path)
    check_format(data, FAMILY, 1, source=path)
    return profile_from_dict(data, source=str(path))


def builtin_profile(name: str) -> ProtocolProfile:
    """One of resources/robots/profiles/*.json by its stem ("robocal_v1", "grbl_joint_arm", ...)."""
    return read_profile(resource_path("robots", "profiles", f"{name}.json"))


def load_profile(name: str) -> ProtocolProfile:
    """A built-in profile by its name, or a profile file by its path."""
    name = name.strip() or "robocal_v1"
    return builtin_profile(name) if name in builtin_names() else read_profile(name)


def builtin_names() -> list[str]:
    return sorted(p.stem for p in Path(resource_path("robots", "profiles")).glob("*.json"))


def profile_from_dict(data: dict, *, source: str | None = None) -> ProtocolProfile:
    def section(name: str, required: bool = True) -> dict | None:
        value = data.get(name)
        if value is None and required:
            raise RoboCalError(f"the profile has no '{name}' section", source=source, field=name)
        if value is not None and not isinstance(value, dict):
            raise RoboCalError("expected an object", source=source, field=name)
        return value

    def pattern(text, name: str) -> re.Pattern | None:
        if text is None:
            return None
        try:
            return re.compile(str(text))
        except re.error as exc:
            raise RoboCalError(f"not a regular expression ({exc})", source=source, field=name,
                               hint="Fix the pattern (Python re syntax).") from None

    def exchange(sec: dict | None, name: str, reply_required: bool = True) -> Exchange | None:
        if sec is None:
            return None
        send = sec.get("send")
        if isinstance(send, str):
            send = [send]
        if not send or not all(isinstance(s, str) for s in send):
            raise RoboCalError("expected a command text (or a list of them)", source=source, field=f"{name}.send")
        if reply_required and not sec.get("reply"):
            raise RoboCalError("expected a reply pattern", source=source, field=f"{name}.reply")
        return Exchange(tuple(send), pattern(sec.get("reply"), f"{name}.reply"))

    move = section("move")
    if "{joints}" not in str(move.get("send", "")):
        raise RoboCalError("the move command must contain {joints}", source=source, field="move.send")
    position = section("position")
    done = section("done", required=False)
    settle = section("settle", required=False)
    speed = section("speed", required=False)
    stop = section("stop")
    if done is not None and "poll" in done and not done.get("busy"):
        raise RoboCalError("a polled 'done' needs a 'busy' pattern (the status reply while moving)",
                           source=source, field="done.busy")
    if done is None and settle is None:
        raise RoboCalError("a profile without 'done' needs a 'settle' rule", source=source, field="settle")
    levels = ()
    if speed is not None and "levels" in speed:
        try:
            levels = tuple(sorted((float(p), str(b)) for p, b in speed["levels"]))
        except (TypeError, ValueError):
            raise RoboCalError("expected [[percent, command], ...]", source=source, field="speed.levels") from None
    try:
        rule = SettleRule(**settle) if settle is not None else None
    except TypeError:
        raise RoboCalError("expected tolerance, dwell_s and timeout_s", source=source, field="settle") from None
    if not data.get("error"):
        raise RoboCalError("the profile has no 'error' pattern", source=source, field="error")
    return ProtocolProfile(
        name=str(data.get("name") or Path(source or "profile").stem),
        hello=exchange(section("hello"), "hello"),
        position=exchange(position, "position"),
        move=exchange(move, "move", reply_required=False),
        stop=exchange(stop, "stop", reply_required=False),
        error=pattern(data["error"], "error"),
        separator=str(position.get("separator", " ")),
        move_separator=str(move.get("separator", " ")),
        axes=tuple(move.get("axes") or ()),
        value_format=str(data.get("value_format", "{:.4f}")),
        done_reply=pattern(done.get("reply"), "done.reply") if done and "poll" not in done else None,
        done_poll=exchange({"send": done["poll"], "reply": done.get("reply")}, "done") if done and "poll" in done
        else None,
        done_busy=pattern(done.get("busy"), "done.busy") if done else None,
        settle=rule,
        speed=exchange(speed, "speed", reply_required=False) if speed is not None and not levels else None,
        speed_levels=levels,
        stop_tolerate=tuple(pattern(p, "stop.tolerate") for p in stop.get("tolerate", [])),
        resume=exchange(section("resume", required=False), "resume"),
        ignore=tuple(pattern(p, "ignore") for p in data.get("ignore", [])),
        baudrate=int(data.get("baudrate", 115200)),
        send_end=str(data.get("send_end", "\n")),
        reply_ends=str(data.get("reply_ends", "\n")),
        connect_wait_s=float(data.get("connect_wait_s", 0.0)),
        dof=int(data["dof"]) if data.get("dof") is not None else None,
        joints=dict(data.get("joints") or {}),
        source=source,
    )
