"""The Setup page's protocol test over the controller simulator on a real pty: templates of the
RoboCal and GRBL profiles sent line by line, the raw replies and the matched patterns shown,
a typed move refused before anything is written, the port closed before a connection, and the
connected robot's own link used afterwards."""
from __future__ import annotations

import time

import pytest

from app import messages
from app.pages.setup.page import SetupPage
from app.pages.setup.protocol_panel import shown, typed
from app.state import WizardState
from app.worker import TaskRunner
from core.robot.controller_sim import ControllerSim
from core.robot.file import read_robot
from core.robot.model import robot_path


@pytest.fixture
def page(qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    state.new_project(tmp_path / "project")
    state.choose_preset("educational_6r")
    p = SetupPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(1200, 1000)
    p.show()
    p.on_enter()
    yield p
    p.on_leave()
    tasks.shutdown()
    state.close()


def sim_for(protocol):
    return ControllerSim(read_robot(robot_path("educational_6r")), protocol=protocol, time_scale=0.05)


def send(page, qtbot, template=None, text=None):
    panel = page.protocol_panel
    if template is not None:
        panel.template_combo.setCurrentText(template)
        panel._template_chosen()
    else:
        panel.line_edit.setText(text)
    assert panel.send_line()
    qtbot.waitUntil(lambda: not page.task.busy, timeout=10000)
    return panel.log.toPlainText()


def choose(page, port, profile):
    robot = page.robot_panel
    robot.serial_radio.setChecked(True)
    robot.port_edit.setText(port)
    robot.profile_combo.setCurrentText(profile)


def test_typed_text_and_shown_commands_round_trip():
    assert shown(("!", "\x18")) == "! ; \\x18" and typed("! ; \\x18") == ("!", "\x18")
    assert typed("  HELLO ") == ("HELLO",) and typed(" ; ") == ()


def test_robocal_profile_line_by_line(page, qtbot):
    with sim_for("robocal") as sim:
        choose(page, sim.port, "robocal_v1")
        panel = page.protocol_panel
        assert panel.isVisible() and "move (to the joints read)" not in panel._templates
        log = send(page, qtbot, "identify")
        assert "→ HELLO" in log and "ROBOCAL 1 Educational_6R_arm_(Robix_RCS-6_style) 6" in log
        assert "✓ hello (name=Educational_6R_arm_(Robix_RCS-6_style), dof=6)" in log
        log = send(page, qtbot, "position")
        assert "✓ position (values 0 0 0 0 0 0)" in log
        assert panel.line_edit.text() == "POS?"
        send(page, qtbot, "move (to the joints read)")          # offered once the joints were read
        log = panel.log.toPlainText()
        assert "→ MOVE 0.0000 0.0000 0.0000 0.0000 0.0000 0.0000" in log and "✓ move ok" in log and "✓ done" in log
        log = send(page, qtbot, text="WAVE")
        assert "ERR SYNTAX unknown command 'WAVE'" in log and "✓ error (code=SYNTAX" in log
        assert panel.probe is not None and panel.close_button.isEnabled()

        moves = sim.moves
        panel.line_edit.setText("MOVE 10 0 0 0 0 0")
        assert panel.send_line()
        qtbot.waitUntil(lambda: not page.task.busy, timeout=10000)
        assert "typed by hand" in page.status.text()
        time.sleep(0.1)
        assert sim.moves == moves and sim.received[-1] == "WAVE"
        page.grab().save(str(page.state.project.folder.parent / "setup_protocol.png"))


def test_grbl_profile_status_and_real_time_bytes(page, qtbot):
    with sim_for("grbl") as sim:
        choose(page, sim.port, "grbl_joint_arm")
        log = send(page, qtbot, "position")
        assert "→ ?" in log and "<Idle|MPos:0.000,0.000,0.000,0.000,0.000,0.000|FS:0,0>" in log
        assert "✓ position (values 0 0 0 0 0 0)" in log and "✓ done" in log
        log = send(page, qtbot, "speed")
        assert "→ \\x97" in log and sim.speed == 25.0
        assert log.endswith("no reply, as the profile says for this command")    # GRBL's overrides say nothing
        log = send(page, qtbot, text="M3")
        assert "✓ error (code=error:20)" in log
        log = send(page, qtbot, "move (to the joints read)")
        assert "→ G90 G0 X0.000 Y0.000 Z0.000 A0.000 B0.000 C0.000" in log and "✓ move ok" in log


def test_connect_closes_the_test_port_and_the_robot_lends_its_link(page, qtbot):
    messages.set_non_interactive(True)
    try:
        with sim_for("robocal") as sim:
            choose(page, sim.port, "robocal_v1")
            send(page, qtbot, "identify")
            panel = page.protocol_panel
            assert panel.probe is not None
            assert page.robot_panel.connect_robot()
            assert panel.probe is None                          # closed before the port is opened again
            qtbot.waitUntil(lambda: page.state.hardware.real_robot and not page.task.busy, timeout=10000)
            log = send(page, qtbot, "position")
            assert log.count("✓ position") == 1 and panel.probe is None
            assert "move (to the joints read)" in panel._templates  # the connected robot's joints
            assert page.robot_panel.read_joints()
            qtbot.waitUntil(lambda: not page.task.busy, timeout=10000)
            assert "Joints read." in page.status.text()          # the driver goes on after the test
    finally:
        messages.set_non_interactive(False)


def test_a_wrong_port_is_one_clear_message(page, qtbot, tmp_path):
    choose(page, str(tmp_path / "no-such-port"), "robocal_v1")
    log = send(page, qtbot, "identify")
    assert "no-such-port" in log and "no-such-port" in page.status.text()
    assert page.protocol_panel.probe is None


def test_the_classroom_simulator_starts_fills_the_port_and_stops_with_the_project(page, qtbot, tmp_path):
    messages.set_non_interactive(True)
    try:
        row = page.robot_panel.simulator_row
        row.protocol_combo.setCurrentIndex(row.protocol_combo.findData("grbl"))
        row.seed_spin.setValue(3)
        assert row.start()
        qtbot.waitUntil(lambda: page.state.hardware.simulator is not None and not page.task.busy, timeout=30000)
        sim = page.state.hardware.simulator
        assert sim.protocol == "grbl" and sim.port.startswith("/dev/")
        assert page.robot_panel.port_edit.text() == sim.port
        assert page.robot_panel.profile_combo.currentText() == "grbl_joint_arm"
        assert sim.port in row.device_label.text() and not row.start_button.isEnabled()
        assert page.robot_panel.connect_robot()
        qtbot.waitUntil(lambda: page.state.hardware.real_robot and not page.task.busy, timeout=10000)
        assert page.state.hardware.robot_connection.port == sim.port
        page.grab().save(str(tmp_path / "setup_simulator.png"))

        page.state.new_project(tmp_path / "other")                  # the project closes: the simulator stops
        assert page.state.hardware.simulator is None and not sim._thread.is_alive()
        assert not page.state.hardware.real_robot
        assert row.start_button.isEnabled() and row.device_label.text() == ""
    finally:
        messages.set_non_interactive(False)


def test_closing_the_app_stops_the_simulator(qtbot, tmp_path):
    state, tasks = WizardState(), TaskRunner()
    state.choose_preset("educational_6r")
    p = SetupPage(state, tasks)
    qtbot.addWidget(p)
    assert p.robot_panel.simulator_row.start()
    qtbot.waitUntil(lambda: state.hardware.simulator is not None and not p.task.busy, timeout=30000)
    sim = state.hardware.simulator
    assert sim.protocol == "robocal" and p.robot_panel.profile_combo.currentText() == "robocal_v1"
    tasks.shutdown()
    state.close()
    assert state.hardware.simulator is None and not sim._thread.is_alive()
