"""The pages that write project files take the same output lock as the command line
(core.locks): while a robocal command writes a file, the page writes nothing and says which
process holds it; afterwards it writes as usual."""
from __future__ import annotations

import os

import pytest

from app.pages.poses.page import PosesPage
from app.pages.stereo.page import StereoPage
from app.state import WizardState
from app.worker import TaskRunner
from core.locks import output_lock
from core.robot.file import read_robot
from core.robot.model import robot_path
from core.poses.selection import select_poses
from tests.app.pages.test_export_page import stereo_file

HELD = f"being written by process {os.getpid()}"


@pytest.fixture
def state(tmp_path):
    s = WizardState()
    s.new_project(tmp_path / "project")
    s.choose_preset("educational_6r")
    yield s
    s.close()


def _page(cls, qtbot, state):
    tasks = TaskRunner()
    page = cls(state, tasks)
    qtbot.addWidget(page)
    return page, tasks


def test_stereo_page_files(qtbot, state, tmp_path):
    page, tasks = _page(StereoPage, qtbot, state)
    page.result = stereo_file()
    stereo = state.project.path("stereo")
    stereo.write_text("previous\n")
    with output_lock(stereo):
        assert page.save_stereo() is None
    assert HELD in page.status.text() and "stereo.yaml was not written" in page.status.text()
    assert stereo.read_text() == "previous\n"
    ros = tmp_path / "ros"
    with output_lock(ros / "right.yaml"):
        assert page.export_ros(str(ros)) is None
    assert HELD in page.status.text() and not ros.exists()
    with output_lock(tmp_path / "s.json"):
        assert page.export_json(str(tmp_path / "s.json")) is None
    assert HELD in page.status.text() and not (tmp_path / "s.json").exists()
    assert [p.name for p in page.export_ros(str(ros))] == ["left.yaml", "right.yaml"]
    assert page.export_json(str(tmp_path / "s.json")) == tmp_path / "s.json"
    tasks.shutdown()


def test_poses_page_poses_csv(qtbot, state, boxes):
    page, tasks = _page(PosesPage, qtbot, state)
    result = select_poses(read_robot(robot_path("educational_6r")), 12, candidates=300, seed=1, random_trials=1)
    poses = state.project.path("poses")
    with output_lock(poses):
        page._selected(result)
    assert not poses.exists() and "poses.csv could not be written" in page.status.text()
    assert any(HELD in text for _, _, text in boxes), boxes
    page._selected(result)
    assert poses.exists()
    tasks.shutdown()
