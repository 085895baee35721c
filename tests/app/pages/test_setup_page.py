"""The Setup page: presets fill the DH table, bad robot files give one clear message,
New/Open project write and read project.json."""
from __future__ import annotations

import json

import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QAbstractButton, QApplication, QGroupBox, QLabel, QRadioButton

from app.pages.setup.page import SetupPage
from app.state import WizardState
from app.worker import TaskRunner
from core import project as projects
from core.robot.model import preset_names
from core.robot.file import read_robot, write_robot


@pytest.fixture
def page(qtbot):
    state, tasks = WizardState(), TaskRunner()
    p = SetupPage(state, tasks)
    qtbot.addWidget(p)
    p.resize(900, 700)
    p.show()
    yield p
    tasks.shutdown()
    state.close()


def test_preset_list_offers_every_preset(page):
    data = [page.preset_combo.itemData(i) for i in range(page.preset_combo.count())]
    assert data[0] is None and data[1:] == preset_names()
    for name in preset_names():   # shown by the name written in the preset file
        assert page.preset_combo.itemText(page.preset_combo.findData(name)) == read_robot_preset(name).name


def test_choosing_a_preset_fills_the_dh_table(page, qtbot):
    with qtbot.waitSignal(page.completeChanged):
        page.preset_combo.setCurrentIndex(page.preset_combo.findData("educational_6r"))
    table = page.dh_table
    assert table.rowCount() == 6 and table.columnCount() == 9
    headers = [table.horizontalHeaderItem(c).text() for c in range(9)]
    assert headers == ["Joint", "Type", "θ offset (°)", "d (mm)", "a (mm)", "α (°)", "β (°)", "min", "max"]
    assert [table.cell_text(0, c) for c in range(9)] == ["J1", "revolute", "0", "110", "0", "90", "0",
                                                        "-150°", "150°"]
    assert [table.cell_text(1, c) for c in (2, 4, 5)] == ["90", "120", "0"]
    assert page.state.robot is not None and page.state.robot_source == "preset:educational_6r"
    assert "J2∥J3" in page.robot_summary.text()
    assert not page.is_complete()                      # no project yet
    # the table is read-only
    assert table.editTriggers() == table.EditTrigger.NoEditTriggers


@pytest.mark.parametrize("name", preset_names())
def test_every_preset_loads(page, name):
    page.choose_preset(name)
    assert page.dh_table.rowCount() == read_robot_preset(name).dof


def read_robot_preset(name):
    from core.robot.model import robot_path
    return read_robot(robot_path(name))


def test_load_robot_file(page, tmp_path):
    model = read_robot_preset("puma560")
    model.name = "My PUMA"
    write_robot(model, tmp_path / "mine.json")
    page.load_robot_file(tmp_path / "mine.json")
    assert page.state.robot.name == "My PUMA" and page.dh_table.rowCount() == 6
    assert page.preset_combo.currentIndex() == 0
    assert page.preset_combo.currentText() == "From file: mine.json"


@pytest.mark.parametrize("content, expected", [
    ("{ not json", "not valid JSON"),
    ('{"format": "robocal.robot/9", "joints": []}', "unknown format version 9"),
    ('{"format": "robocal.robot/1", "joints": [{"theta": "ninety", "d": 0, "a": 0, "alpha": 0, '
     '"min": -1, "max": 1}]}', "field 'joints[0].theta'"),
    ('{"format": "robocal.robot/1", "joints": [{"theta": 0, "d": 0, "a": 0, "alpha": 0, "min": -1}]}',
     "field 'joints[0].max': missing"),
])
def test_malformed_robot_file_gives_one_clear_message(page, tmp_path, boxes, content, expected):
    page.choose_preset("ur5")
    before = page.state.robot
    bad = tmp_path / "bad_robot.json"
    bad.write_text(content)
    assert page.load_robot_file(bad) is None
    assert len(boxes) == 1
    kind, title, text = boxes[0]
    assert kind == "critical" and "Setup" in title
    assert "bad_robot.json" in text and expected in text
    assert "\n" not in text and "Traceback" not in text
    assert page.state.robot is before                  # the previous robot stays
    assert page.dh_table.rowCount() == before.dof


def test_new_project_writes_project_json(page, tmp_path, qtbot):
    page.choose_preset("abb_irb120")
    with qtbot.waitSignal(page.completeChanged):
        project = page.new_project(tmp_path / "cell")
    data = json.loads((tmp_path / "cell" / "project.json").read_text())
    assert data["format"] == "robocal.project/1" and data["name"] == "cell"
    assert data["mode"] == "virtual-lab" and data["robot"] == "robot.json"
    assert data["robot_source"] == "preset:abb_irb120"
    assert read_robot(tmp_path / "cell" / "robot.json").dof == 6
    assert project is page.state.project and page.is_complete()
    assert "cell" in page.project_folder.text()
    assert "Ready" in page.status.text()


def test_choosing_a_robot_after_the_project_writes_robot_json(page, tmp_path):
    page.new_project(tmp_path)
    assert not page.is_complete()
    page.choose_preset("ur5")
    assert json.loads((tmp_path / "project.json").read_text())["robot_source"] == "preset:ur5"
    assert read_robot(tmp_path / "robot.json").name == read_robot_preset("ur5").name


def test_new_project_over_an_existing_one_is_refused_clearly(page, tmp_path, boxes):
    page.new_project(tmp_path)
    assert page.new_project(tmp_path) is None
    assert len(boxes) == 1 and "already holds a project" in boxes[0][2]


def test_open_project_restores_the_robot(page, tmp_path, qtbot):
    other = WizardState()
    other.new_project(tmp_path / "saved")
    other.choose_preset("puma560")
    other.close()
    page.open_project(tmp_path / "saved")
    assert page.state.robot.name == read_robot_preset("puma560").name
    assert page.dh_table.rowCount() == 6 and page.is_complete()
    assert page.preset_combo.currentData() == "puma560"


def test_open_a_bad_project_gives_one_message(page, tmp_path, boxes):
    (tmp_path / "project.json").write_text('{"format": "robocal.project/7", "name": "x"}')
    assert page.open_project(tmp_path) is None
    assert len(boxes) == 1 and "unknown format version 7" in boxes[0][2]
    assert page.state.project is None


def screen_words(page) -> str:
    """Every text and tooltip the page shows."""
    widgets = page.findChildren(QLabel) + page.findChildren(QAbstractButton) + page.findChildren(QGroupBox)
    return " ".join(f"{w.title() if isinstance(w, QGroupBox) else w.text()} {w.toolTip()}" for w in widgets)


def test_connection_and_cameras_offer_the_virtual_lab_and_hardware(page):
    robot, cams = page.robot_panel, page.camera_panel
    assert robot.virtual_radio.isChecked() and cams.virtual_radio.isChecked()
    assert [b.text() for b in page.findChildren(QRadioButton)] == [
        "Virtual lab (simulated robot)", "Serial robot", "Virtual lab cameras (simulated stereo pair)",
        "Cameras or recordings"]
    assert all(b.isEnabled() for b in page.findChildren(QRadioButton))
    assert "Choose a robot model to connect the simulated robot" in robot.info_label.text()
    page.choose_preset("ur5")
    assert "connected" in robot.info_label.text()
    assert page.state.hardware.robot_connection.connected
    words = screen_words(page).lower()
    assert "not yet" not in words and "issue" not in words and "arrives with" not in words


def test_serial_chosen_but_not_connected_says_so(page):
    robot = page.robot_panel
    page.choose_preset("ur5")
    assert "Simulated robot" in robot.info_label.text() and robot.read_button.isEnabled()
    robot.serial_radio.setChecked(True)
    text = robot.info_label.text()
    assert "Serial robot: not connected" in text and "Simulated robot" not in text
    assert not robot.read_button.isEnabled() and robot.connect_button.isEnabled()
    robot.virtual_radio.setChecked(True)
    assert "Simulated robot" in robot.info_label.text() and robot.read_button.isEnabled()


def test_a_hardware_project_offers_real_hardware_only(page, tmp_path):
    page.state.new_project(tmp_path, mode=projects.HARDWARE)
    robot, cams = page.robot_panel, page.camera_panel
    assert robot.serial_radio.isChecked() and cams.sources_radio.isChecked()
    assert not robot.virtual_radio.isEnabled() and not cams.virtual_radio.isEnabled()
    assert page.state.hardware.robot_connection is None
    assert "not yet" not in screen_words(page).lower()


def test_autopilot_sets_up_a_demo(page):
    done = []
    page.autopilot(lambda ok=True, message="": done.append((ok, message)))
    assert done == [(True, "")]
    assert page.state.is_temporary() and page.state.robot_source == "preset:educational_6r"
    folder = page.state.project.folder
    assert (folder / "project.json").is_file()
    page.state.close()
    assert not folder.exists()                       # temporary demo folders are removed


def test_choosing_the_virtual_robot_without_a_model_connects_nothing(page, qtbot):
    qtbot.mouseClick(page.robot_panel.virtual_radio, Qt.MouseButton.LeftButton)
    assert page.robot_panel.virtual_radio.isChecked()
    assert page.state.hardware.robot_connection is None           # nothing to connect without a robot


@pytest.mark.parametrize("width", [1000, 1700])
def test_the_dh_tables_joint_names_are_shown_whole(page, width):
    """The UR5's joint names (shoulder_lift_joint …) are never cut, on a small screen's page
    width as on a large one."""
    page.resize(width, 650)
    page.choose_preset("ur5")
    table = page.dh_table
    names = [table.cell_text(r, 0) for r in range(table.rowCount())]
    assert "shoulder_lift_joint" in names
    QApplication.processEvents()
    assert table.columnWidth(0) >= table.sizeHintForColumn(0)
    assert table.columnWidth(0) >= max(table.fontMetrics().horizontalAdvance(n) for n in names)
    assert table.columnWidth(1) >= table.sizeHintForColumn(1)            # "revolute", "prismatic"
