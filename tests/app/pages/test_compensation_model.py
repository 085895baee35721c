"""The Compensation step's model without Qt (the calibrated cell read once and again when
calibrated.json changes, the points and their events), and the Points panel's options bound
both ways."""
from __future__ import annotations

import os

import numpy as np
import pytest

from app.jobs.compensation import CompensatedPoint
from app.pages.compensation.model import CompensationModel, CompensationOptions, PointOptions
from core.errors import RoboCalError
from core.project import Output, create_project
from core.robot.file import read_robot, write_robot
from core.robot.model import robot_path


@pytest.fixture
def robot():
    return read_robot(robot_path("educational_6r"))


def point(name: str, dof: int = 6) -> CompensatedPoint:
    q = np.full(dof, 0.1)
    return CompensatedPoint(name, np.array([1.0, 2.0, 3.0]), q, q + 0.01, 0.05)


def test_the_cell_is_read_once_and_again_when_calibrated_json_changes(tmp_path, robot):
    project = create_project(tmp_path / "p")
    model = CompensationModel()
    assert not model.ready(project, robot) and model.load_cell(project, robot) is None
    calibrated = write_robot(robot, project.path(Output.CALIBRATED))
    assert model.ready(project, robot) and not model.ready(project, None)
    cell = model.load_cell(project, robot)
    assert cell.target == "marker" and model.load_cell(project, robot) is cell       # not read again
    rows = []
    model.on("points", rows.append)
    model.add_points([point("P1"), point("P2")])
    assert rows == [1] and [p.name for p in model.points] == ["P1", "P2"]
    stat = calibrated.stat()
    os.utime(calibrated, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))             # a new calibration
    again = model.load_cell(project, robot)
    assert again is not cell and model.points == [] and rows == [1, None]             # its points are dropped
    calibrated.write_text("{", encoding="utf-8")
    os.utime(calibrated, ns=(stat.st_atime_ns, stat.st_mtime_ns + 2 * 10**9))
    with pytest.raises(RoboCalError):
        model.load_cell(project, robot)


def test_points_events_name_the_row_to_select(robot):
    model = CompensationModel()
    rows = []
    model.on("points", rows.append)
    model.add_points([point("P1")])
    model.add_points([point("P2"), point("P3")])
    landed = point("P2")
    assert model.replace_point(1, landed) is landed and model.points[1] is landed
    model.forget()
    assert rows == [0, 2, 1, None] and model.points == [] and model.cell is None and model.result is None
    np.testing.assert_allclose(model.q_file(np.deg2rad([10.0, 20.0])), [10.0, 20.0])   # no cell: degrees


def test_points_panel_options_both_ways(qtbot):
    from app.pages.compensation.points_panel import PointsPanel
    panel = PointsPanel()
    qtbot.addWidget(panel)
    assert panel.options() == PointOptions()
    chosen = PointOptions((12.5, -40.25, 600.0), "fixture", True)
    panel.show_options(chosen)
    assert panel.options() == chosen and panel.frame == "fixture" and panel.nominal_check.isChecked()
    heard = []
    model = CompensationModel()
    model.on("options", heard.append)
    model.set_options(CompensationOptions(panel.options(), 8))
    model.set_options(CompensationOptions(chosen, 8))             # the same: not heard again
    assert heard == [CompensationOptions(chosen, 8)]
