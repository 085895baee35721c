"""The Setup page's protocol test: for the chosen protocol profile, send one command (a template
of the profile filled in, or a line typed by hand), see the controller's raw replies and what the
profile's patterns matched in each (core.robot.profile_probe).

It talks over the connected robot's link when a serial robot is connected, else it opens the port
itself (closed again by Close port, by Connect, or when the page is left). Every exchange runs on
the page's worker. Real-time bytes are written and shown as \\xNN (GRBL's soft reset: \\x18);
several commands are separated by " ; "."""
from __future__ import annotations

import re

from PySide6.QtWidgets import QComboBox, QGroupBox, QLineEdit, QTextEdit, QVBoxLayout, QWidget

from app.html import esc
from app.pages import forms
from core.errors import RoboCalError
from core.robot.profile import load_profile
from core.robot.profile_probe import ProbeExchange, ProfileProbe, templates

SEPARATOR = " ; "


def shown(commands: tuple[str, ...]) -> str:
    """Commands as typed text: bytes outside printable ASCII as \\xNN."""
    return SEPARATOR.join(re.sub(r"[^\x20-\x7e]", lambda m: f"\\x{ord(m.group()):02x}", c) for c in commands)


def typed(text: str) -> tuple[str, ...]:
    """The commands of typed text (inverse of `shown`)."""
    parts = [p.strip() for p in text.split(SEPARATOR.strip())]
    return tuple(re.sub(r"\\x([0-9a-fA-F]{2})", lambda m: chr(int(m.group(1), 16)), p) for p in parts if p)


def exchange_on_driver(driver, commands, allowed_move) -> ProbeExchange:
    """Worker: one exchange over the connected driver's link."""
    with driver.borrow_link() as link:
        return ProfileProbe(driver.profile, link).send(commands, allowed_move=allowed_move)


def exchange_on_port(probe: ProfileProbe | None, profile, port: str, baud: int | None, commands,
                     allowed_move) -> tuple[ProfileProbe, ProbeExchange]:
    """Worker: one exchange over the probe's own link, opened first when needed."""
    opened = probe is None
    if opened:
        if not port:
            raise RoboCalError("no serial port given", field="port",
                               hint="Type the controller's device, e.g. /dev/ttyUSB0 or the path sim-robot printed.")
        probe = ProfileProbe.open(profile, port, baud)
    try:
        return probe, probe.send(commands, allowed_move=allowed_move)
    except BaseException:
        if opened:
            probe.close()
        raise


class ProtocolPanel(QGroupBox):
    """`page`: the Setup page; `robot`: its RobotPanel (port, profile, baud, joints read)."""

    def __init__(self, page, robot, parent: QWidget | None = None):
        super().__init__("Protocol test", parent)
        self.page, self.robot, self.state = page, robot, page.state
        self.probe: ProfileProbe | None = None          # own link while no robot is connected
        self.values: tuple[float, ...] | None = None    # controller's joint values last seen
        self._templates: dict[str, tuple[str, ...]] = {}

        self.template_combo = QComboBox()
        self.template_combo.setObjectName("templateCombo")
        self.template_combo.setMinimumContentsLength(24)
        self.template_combo.setSizeAdjustPolicy(QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon)
        self.template_combo.activated.connect(self._template_chosen)
        self.line_edit = QLineEdit()
        self.line_edit.setObjectName("protocolLineEdit")
        self.line_edit.setPlaceholderText("a command of the profile, or a line typed by hand")
        self.line_edit.returnPressed.connect(self.send_line)
        self.send_button = forms.button("Send", "protocolSendButton", on_click=self.send_line)
        self.close_button = forms.button("Close port", "protocolCloseButton", on_click=self.close_probe,
                                         tooltip="Close the port the protocol test opened")
        self.log = QTextEdit()
        self.log.setObjectName("protocolLog")
        self.log.setReadOnly(True)
        self.log.setMinimumHeight(130)
        layout = QVBoxLayout(self)
        row = forms.row("Template:", self.template_combo, self.line_edit, self.send_button, self.close_button,
                        stretch=False)
        row.setStretchFactor(self.line_edit, 1)
        layout.addLayout(row)
        layout.addWidget(self.log)

        robot.profile_combo.currentTextChanged.connect(self._profile_changed)
        robot.connecting.connect(self.close_probe)          # one reader per port
        self.state.hardware.connectionChanged.connect(self._connection_changed)
        self._profile_changed()

    # -- choices -------------------------------------------------------------------------
    def profile(self):
        driver = self.state.hardware.robot_connection
        if self.state.hardware.real_robot and driver is not None:
            return driver.profile
        return load_profile(self.robot.profile_combo.currentText())

    def _controller_values(self):
        driver = self.state.hardware.robot_connection
        if self.state.hardware.real_robot and self.robot.joints is not None:
            return driver.joint_map.to_controller(self.robot.joints)
        return self.values

    def _fill_templates(self) -> None:
        try:
            profile = self.profile()
        except RoboCalError as exc:
            self._templates = {}
            self.template_combo.clear()
            self.log.setHtml(f"<span style='color:#c5221f'>{esc(exc.message)}</span>")
            return
        values = self._controller_values()
        if values is not None and len(values) < (profile.dof or len(values)):
            values = None
        self._templates = templates(profile, values)
        current = self.template_combo.currentText()
        self.template_combo.clear()
        self.template_combo.addItems(list(self._templates))
        if current in self._templates:
            self.template_combo.setCurrentText(current)

    def _template_chosen(self, *_) -> None:
        commands = self._templates.get(self.template_combo.currentText())
        if commands:
            self.line_edit.setText(shown(commands))

    def _profile_changed(self, *_) -> None:
        self.close_probe()
        self.values = None
        self._fill_templates()

    def _connection_changed(self, *_) -> None:
        if self.state.hardware.real_robot:
            self.close_probe()                  # one reader per port
        self._fill_templates()
        self.refresh()

    # -- actions (tests call them) -------------------------------------------------------
    def send_line(self, text: str | None = None) -> bool:
        text = self.line_edit.text() if text is None else text
        commands = typed(text)
        if not commands:
            self.page._set_status("Choose a template or type a command to send.", False)
            return False
        move = self._templates.get(next((k for k in self._templates if k.startswith("move")), ""), ())
        allowed = move[0] if move else None
        driver = self.state.hardware.robot_connection
        if self.state.hardware.real_robot and driver is not None:
            return self.page.task.start(exchange_on_driver, driver, commands, allowed, on_done=self._show,
                                   on_failed=self._failed, label="Protocol test", status=f"Sending {text}…")
        try:
            profile = self.profile()
        except RoboCalError as exc:
            self.page._set_status(exc.message, False)
            return False
        choice = self.robot.choice()
        return self.page.task.start(exchange_on_port, self.probe, profile, choice.port, choice.baud, commands, allowed,
                               on_done=self._opened_and_shown, on_failed=self._failed, label="Protocol test",
                               status=f"Sending {text}…")

    def close_probe(self) -> None:
        probe, self.probe = self.probe, None
        if probe is not None:
            probe.close()
        self.refresh()

    # -- display -------------------------------------------------------------------------
    def _opened_and_shown(self, result) -> None:
        self.probe, exchange = result
        self._show(exchange)

    def _failed(self, message: str) -> None:
        self.log.append(f"<span style='color:#c5221f'>{esc(message)}</span>")
        self.page._set_status(message, False)
        self.refresh()

    def _show(self, ex: ProbeExchange) -> None:
        lines = [f"<b>→ {esc(shown(ex.sent))}</b>"]
        for r in ex.replies:
            head = f"&nbsp;&nbsp;← <code>{esc(r.text)}</code> <span style='color:#666'>({r.after_s * 1000:.0f} ms)</span>"
            if r.kind == "garbage":
                lines.append(head + " <span style='color:#c5221f'>bytes that are not ASCII text</span>")
            elif r.kind == "disconnected":
                lines.append(head + " <span style='color:#c5221f'>the connection is lost</span>")
            elif not r.matches:
                lines.append(head + " <span style='color:#c5221f'>no pattern of the profile matched</span>")
            else:
                parts = []
                for m in r.matches:
                    groups = ", ".join(f"{k}={esc(v)}" for k, v in m.groups.items() if k != "values")
                    if m.values is not None:
                        groups = ", ".join(filter(None, [groups, "values " + " ".join(f"{v:g}" for v in m.values)]))
                        if m.pattern == "position":
                            self.values = m.values
                    parts.append(f"<span style='color:#137333'>✓ {esc(m.pattern)}</span>"
                                 + (f" ({groups})" if groups else ""))
                lines.append(head + " " + " · ".join(parts))
        if not ex.replies and not ex.reply_expected:
            lines.append("&nbsp;&nbsp;<span style='color:#666'>no reply, as the profile says for this command</span>")
        elif not ex.replies:
            lines.append("&nbsp;&nbsp;<span style='color:#c5221f'>no reply</span>")
        self.log.append("<br>".join(lines))
        self.page._set_status(f"Sent {shown(ex.sent)}: {len(ex.replies)} repl{'y' if len(ex.replies) == 1 else 'ies'}.",
                              True)
        self._fill_templates()
        self.refresh()

    def refresh(self, *_) -> None:
        busy = self.page.task.busy
        self.send_button.setEnabled(not busy)
        self.close_button.setEnabled(self.probe is not None and not busy)
